//! Errors of the generator.

use flakescatter_stats::heightmap::HeightMapError;
use thiserror::Error;

/// Why a layer could not be generated.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SynthError {
    /// `nx` or `ny` is zero.
    #[error("map size must be at least 1 x 1 pixels, got {nx} x {ny}")]
    EmptyMap {
        /// Columns requested.
        nx: usize,
        /// Rows requested.
        ny: usize,
    },
    /// More than [`crate::MAX_PIXELS`] pixels.
    #[error(
        "map of {nx} x {ny} pixels is larger than the limit of {} pixels",
        crate::MAX_PIXELS
    )]
    TooLarge {
        /// Columns requested.
        nx: usize,
        /// Rows requested.
        ny: usize,
    },
    /// A parameter is not finite or out of range.
    #[error("parameter `{field}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        /// Name of the parameter (with its unit suffix).
        field: &'static str,
        /// The value given.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// A disc given to `generate_from_discs` is invalid.
    #[error("disc {index} (0-based): {reason}")]
    InvalidDisc {
        /// 0-based index of the disc in the list.
        index: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// More discs than labels can number.
    #[error("{0} discs are more than the label map can number (u32)")]
    TooManyFlakes(usize),
    /// The height or intensity map could not be built.
    #[error("building the map: {0}")]
    HeightMap(#[from] HeightMapError),
}
