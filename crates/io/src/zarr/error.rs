//! What can go wrong with a Zarr v3 height-map store: [`ZarrProblem`] says what (and in
//! which array or attribute), [`ZarrError`] adds the store.

use std::path::PathBuf;

use thiserror::Error;

/// A problem with a Zarr v3 store, naming the array (`height`, `mask`, `intensity`) or
/// the attribute (`pitch_x_um`, `pitch_y_um`, `height_unit`) at fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ZarrProblem {
    /// The path is not a Zarr v3 store (no `zarr.json`, or not a directory).
    #[error("not a Zarr v3 store: {reason}")]
    NotAStore {
        /// Why.
        reason: String,
    },
    /// The store has no `height` array.
    #[error("the store has no `height` array (a directory `height` with a zarr.json){}",
        if *has_intensity {
            "; it holds an `intensity` array only: give it where an intensity image is expected"
        } else { "" })]
    NoHeight {
        /// Whether it has an `intensity` array.
        has_intensity: bool,
    },
    /// The store has neither a `height` nor an `intensity` array.
    #[error("the store has neither a `height` nor an `intensity` array")]
    NoArray,
    /// zarrs could not open an array or read its chunks (bad metadata, a chunk grid
    /// that does not fit the shape, a chunk of the wrong size, an unsupported codec).
    #[error("array `{array}`: {reason}")]
    Array {
        /// The array.
        array: &'static str,
        /// What zarrs reported.
        reason: String,
    },
    /// An array's data type is not the one the layout states.
    #[error("array `{array}` has data type {found}, expected {expected}")]
    DataType {
        /// The array.
        array: &'static str,
        /// Its data type.
        found: String,
        /// What is accepted.
        expected: &'static str,
    },
    /// An array is not two-dimensional, is empty, or has another shape than `height`.
    #[error("array `{array}` has shape {found:?}, expected {expected}")]
    Shape {
        /// The array.
        array: &'static str,
        /// Its shape.
        found: Vec<u64>,
        /// What is expected.
        expected: String,
    },
    /// The chunk grid of an array does not tile it (not a regular 2-D grid of
    /// non-empty chunks).
    #[error("array `{array}`: its chunks do not tile the array: {reason}")]
    Chunks {
        /// The array.
        array: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// An attribute is missing or has an unusable value.
    #[error(
        "attribute `{attribute}` (of the `height` array or the root group) is {found}, expected {expected}"
    )]
    Attribute {
        /// The attribute.
        attribute: &'static str,
        /// What it is (`missing`, or its JSON value).
        found: String,
        /// What is expected.
        expected: &'static str,
    },
    /// A window reaches outside the array.
    #[error(
        "window of {ny} x {nx} points at row {y0}, column {x0} reaches outside the {rows} x {cols} map"
    )]
    Window {
        /// First row.
        y0: u64,
        /// First column.
        x0: u64,
        /// Rows.
        ny: u64,
        /// Columns.
        nx: u64,
        /// Rows of the map.
        rows: u64,
        /// Columns of the map.
        cols: u64,
    },
    /// The store could not be written.
    #[error("cannot write: {reason}")]
    Write {
        /// What failed.
        reason: String,
    },
}

/// A problem with the Zarr v3 store `store`.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("Zarr store {}: {problem}", store.display())]
pub struct ZarrError {
    /// The store (its directory).
    pub store: PathBuf,
    /// What is wrong.
    pub problem: ZarrProblem,
}
