//! Errors of the generator.

use flakescatter_stats::heightmap::HeightMapError;
use thiserror::Error;

use crate::params::Param;

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
    #[error("parameter `{param}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        /// Which parameter (its `Display` is the [`LayerSpec`](crate::LayerSpec) field
        /// name with its unit suffix, e.g. `dx_um`), so that callers can name their own
        /// flag.
        param: Param,
        /// The value given, in the parameter's unit.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// The flakes are thicker than the film: not even a flat flake fits.
    #[error(
        "flakes {thickness_um} um thick cannot lie inside a film {film_um} um thick: the film must be at least as thick as the flakes"
    )]
    FilmThinnerThanFlakes {
        /// Film thickness, µm.
        film_um: f64,
        /// Flake thickness, µm.
        thickness_um: f64,
    },
    /// Too many flakes would stick out of the film at the tilt drawn for them
    /// (module docs of [`LayerParams`](crate::LayerParams), the film rule).
    #[error(
        "flakes of {diameter_um} um diameter (up to {max_diameter_um} um) and {thickness_um} um thickness do not fit in a {film_um} um film: {:.3} % of them are tilted too far to lie inside it (a flake tilted by theta spans t cos(theta) + d sin(theta) in height), more than the {:.1} % that may be re-drawn; use a thicker film, smaller flakes or a narrower orientation distribution",
        100.0 * .fraction,
        100.0 * crate::params::MAX_REDRAWN_FRACTION
    )]
    FlakesDoNotFit {
        /// Film thickness, µm.
        film_um: f64,
        /// Flake diameter, µm (the mean of a log-normal).
        diameter_um: f64,
        /// Largest flake diameter that can be drawn, µm.
        max_diameter_um: f64,
        /// Flake thickness, µm.
        thickness_um: f64,
        /// Expected fraction of flakes that cannot lie inside the film at their tilt.
        fraction: f64,
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
