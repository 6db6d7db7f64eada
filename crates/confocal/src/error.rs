//! Errors of the localiser.

use flakescatter_stats::heightmap::HeightMapError;
use thiserror::Error;

/// Why a stack could not be localised.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ConfocalError {
    /// A geometry field or an option is out of range.
    #[error("{name} = {value} is invalid: expected {expected}")]
    BadOption {
        /// The field (`dz_um`, `fraction`, `half_window`, ...).
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
    /// Fewer than three slices: no peak can be told from the stack's ends.
    #[error(
        "a z-stack needs at least 3 slices to localise a peak between its first and last slice, got {nz}"
    )]
    TooFewSlices {
        /// Slices given.
        nz: usize,
    },
    /// The slice is empty or larger than [`crate::MAX_SLICE_PIXELS`].
    #[error(
        "slice size {nx} x {ny} is not usable: expected at least 1 x 1 and at most {} pixels",
        crate::MAX_SLICE_PIXELS
    )]
    TooLarge {
        /// Pixels per row.
        nx: usize,
        /// Rows.
        ny: usize,
    },
    /// A pushed slice has the wrong number of samples.
    #[error("slice {slice} (0-based) has {found} samples, expected nx * ny = {expected}")]
    SliceLength {
        /// 0-based index of the slice.
        slice: usize,
        /// `nx · ny`.
        expected: usize,
        /// Samples given.
        found: usize,
    },
    /// More slices were pushed than the geometry declares.
    #[error("the stack declares {nz} slices; no more can be pushed")]
    TooManySlices {
        /// Declared slices.
        nz: usize,
    },
    /// `finish` was called before every slice was pushed.
    #[error("the stack declares {expected} slices but only {found} were pushed")]
    MissingSlices {
        /// Declared slices.
        expected: usize,
        /// Slices pushed.
        found: usize,
    },
    /// A map could not be built (not expected for a validated geometry).
    #[error("building the map: {0}")]
    HeightMap(#[from] HeightMapError),
}
