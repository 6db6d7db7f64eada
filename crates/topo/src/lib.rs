//! The topographic reflectance model of flake coatings (NIST, Sung et al. 2002, eqs. 14
//! and 15, with the corrections of physics.md §5).
//!
//! A confocal height map of the flakes under a flat clear coat of index `n` is turned
//! into a reflectance curve by ray tracing: every usable pixel gets a local normal from a
//! least-squares plane over a `k × k` window ([`normals`]), one ray per pixel and
//! incidence is refracted into the coating, mirror-reflected by the local plane,
//! refracted out, and its weight is added to every detector cone that contains it
//! ([`model`]). Several maps accumulate into one result, with per-detector ray counts
//! and a standard error from the spread between map tiles. [`TopoModel::run_mueller`]
//! accumulates the Mueller matrix of every ray instead ([`mueller`], physics.md §11).
//!
//! [`isotropic`] averages the model exactly over the sample's rotation about its normal
//! (each pixel's ray becomes a ring of exit directions; [`TopoModel::run_isotropic`]),
//! and [`pixels`] gives the area-weighted distribution of the pixel normals that the
//! distribution model must be fed to reproduce it ([`TopoModel::pixel_tilts`]).
//!
//! # Instruction sets
//! The hot loops run on AVX-512 or AVX2 where the processor has them, chosen at run
//! time, and give the same bits as the portable code. The environment variable
//! `FLAKESCATTER_SIMD` (read once per process) sets what [`TopoModel::new`] uses:
//! unset, empty or `auto` the run-time choice, `portable` the portable code alone (to
//! check that a result does not depend on the processor); any other value is refused
//! with [`TopoError::SimdSwitch`]. [`TopoModel::with_kernels`] chooses per model
//! ([`Kernels`]).
//!
//! # Conventions
//! * Frame of physics.md §1: `z` is the coating normal pointing into the air, `x` lies in
//!   the plane of incidence, the source is on the `−x` side; in-plane detectors use the
//!   signed angle `θs` (`θs = −θi` is specular).
//! * Angles in **radians**, lengths (heights, pitches, tile size) in **micrometres**.
//! * Map axes: `x = col · dx`, `y = row · dy`, row-major storage (as
//!   [`flakescatter_stats::HeightMap`]). Validity comes from the map's mask (NaN, masked
//!   points, the intensity cutoff), never from `z = 0`.
//! * Results are absolute: `reflectance` is the fraction of the incident beam power a
//!   detector collects, over **all** pixels of all maps (dark pixels are black
//!   substrate); `brdf` is that divided by the cone's projected solid angle (sr⁻¹).
//!
//! # Example
//! A tilted mirror plane sends every ray into one direction. Tilting the flake by `β`
//! about `y` (slope `a = tan β` along `x`, the normal leans toward `−x`, the source side)
//! turns the inside ray by `2β` toward the source, so at normal incidence the light
//! leaves at `θs = asin(n sin 2β)` on the source side:
//! ```
//! use flakescatter_optics::detector::Cone;
//! use flakescatter_stats::HeightMap;
//! use flakescatter_topo::{TopoModel, TopoOptions};
//!
//! let (nx, ny, beta) = (40, 40, 2f64.to_radians());
//! let z: Vec<f64> = (0..nx * ny).map(|i| (i % nx) as f64 * 0.5 * beta.tan()).collect();
//! let map = HeightMap::new(nx, ny, 0.5, 0.5, z)?; // 0.5 µm pitch
//! let model = TopoModel::new(TopoOptions::default())?;
//! let theta_s = (1.5 * (2.0 * beta).sin()).asin();
//! let cones = [Cone::in_plane(theta_s, 0.5f64.to_radians())?, Cone::in_plane(0.0, 0.5f64.to_radians())?];
//! let result = model.run(&[&map], &[0.0], &cones)?;
//! // Every usable pixel (all but a 2-pixel border for the 5 × 5 window) lands in the
//! // first detector and none in the second.
//! assert_eq!(result.points[0].rays, 36 * 36);
//! assert_eq!(result.points[1].rays, 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod index;
pub mod isotropic;
pub mod model;
pub mod mueller;
pub mod normals;
pub mod pixels;
mod simd;
pub mod source;

pub use isotropic::{DEFAULT_NODES_PER_APERTURE, IsotropicOptions, IsotropicResult};
pub use model::{
    DEFAULT_BLOCK_UM, MIN_TILES, TileSums, TileSumsKind, TopoModel, TopoOptions, TopoPoint,
    TopoResult, TopoWarning,
};
pub use mueller::{TopoMuellerPoint, TopoMuellerResult};
pub use normals::{Normals, normal_from_slopes};
pub use pixels::{PixelTilts, TileTilts};
pub use simd::Kernels;
pub use source::{BoxedError, HeightSource, SourceError};

/// Errors of the topographic model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TopoError {
    /// Invalid clear-coat index.
    #[error("clear-coat index: {0}")]
    Index(flakescatter_optics::OpticsError),
    /// Invalid complex flake index.
    #[error("flake index: {0}")]
    FlakeIndex(flakescatter_optics::OpticsError),
    /// The window side is even or below 3.
    #[error("window {0} is not valid: expected an odd number >= 3")]
    Window(usize),
    /// The window does not fit in a map.
    #[error(
        "window {window} x {window} is larger than map {map} ({nx} x {ny} pixels, 0-based map index)"
    )]
    WindowTooLarge {
        /// Window side, pixels.
        window: usize,
        /// Which map (0-based).
        map: usize,
        /// Map columns.
        nx: usize,
        /// Map rows.
        ny: usize,
    },
    /// A map has no valid pixel (all NaN or masked).
    #[error("map {map} (0-based) has no valid pixel: all {pixels} pixels are NaN or masked")]
    NoValidPixels {
        /// Which map (0-based).
        map: usize,
        /// Its number of pixels.
        pixels: usize,
    },
    /// No pixel of any map has a complete window of valid points.
    #[error(
        "no pixel has a complete {window} x {window} window of valid points ({valid} of {pixels} pixels are valid): nothing to trace"
    )]
    NoUsablePixels {
        /// Window side.
        window: usize,
        /// Valid pixels over all maps.
        valid: usize,
        /// All pixels over all maps.
        pixels: usize,
    },
    /// Incidence angle outside `[0, π/2)`.
    #[error("incidence angle {0} rad is out of range: expected [0, pi/2)")]
    Incidence(f64),
    /// A detector with zero aperture: it can catch no ray.
    #[error(
        "detector {0} (0-based) has aperture 0: the topographic model counts rays and needs a cone half-angle > 0"
    )]
    PointDetector(usize),
    /// Invalid detector geometry.
    #[error("detector: {0}")]
    Detector(flakescatter_optics::OpticsError),
    /// Nothing to compute.
    #[error("{0} list is empty")]
    Empty(&'static str),
    /// The statistics tile size is not finite and positive.
    #[error("tile size {0} um is not valid: expected a finite number > 0")]
    BlockSize(f64),
    /// An option the requested computation does not implement (instead of ignoring it).
    #[error("{0}")]
    Unsupported(&'static str),
    /// The histogram bin width is not finite, not positive or above π/4.
    #[error("bin width {0} rad is not valid: expected a finite number in (0, pi/4]")]
    BinWidth(f64),
    /// The isotropic model's node spacing is not finite, not positive or too coarse.
    #[error("node spacing {0} rad is not valid: expected a finite number in (0, 0.01] rad")]
    NodeSpacing(f64),
    /// The environment variable `FLAKESCATTER_SIMD` holds a value other than `auto` or
    /// `portable` ([`Kernels::from_env`]); the value, lossily decoded.
    #[error(
        "environment variable FLAKESCATTER_SIMD={0:?} is not valid: expected `auto` (or unset) for the processor's best instruction set, or `portable` for the portable code"
    )]
    SimdSwitch(String),
    /// A [`HeightSource`] could not give a band of map `map` (0-based): its reader's
    /// error, which names the file.
    #[error("map {map} (0-based): {error}")]
    Source {
        /// Which map (0-based).
        map: usize,
        /// The reader's error.
        error: SourceError,
    },
    /// Partial sums given to a `finish` that do not make up the run: not in tile order,
    /// overlapping, leaving tiles out, or of another model or detector set.
    #[error("partial sums: {0}")]
    Partials(String),
}
