//! Flake orientation statistics (paper eqs. 3–8) and height maps.
//!
//! Conventions follow `physics.md` §1 and §3: angles in radians, lengths in
//! micrometres, `z` is the macroscopic coating normal pointing into the air.
//! Densities of flake normals are area-weighted (see [`distribution`]).
//!
//! ```
//! use flakescatter_stats::distribution::{GaussianWidth, Orientation};
//!
//! // The paper's w = 3° Gaussian (half-width at half-maximum of p̃).
//! let w = 3f64.to_radians();
//! let d = Orientation::gaussian(GaussianWidth::Hwhm(w)).unwrap();
//! // p̃ falls to half its peak at θ = w.
//! assert!((d.p_tilde(w) / d.p_tilde(0.0) - 0.5).abs() < 1e-12);
//! // Nearly all the area lies within 4w of the normal.
//! assert!(d.mass_between(0.0, 4.0 * w) > 0.999);
//! ```

pub mod distribution;
pub mod fit;
pub mod flake;
pub mod heightmap;
pub mod histogram;
pub mod pool;
pub mod segment;

/// The linear-algebra crate whose types appear in this API (re-exported so callers
/// need not depend on it).
pub use flakescatter_numerics::decimal;
pub use nalgebra;

pub use distribution::{DistributionError, GaussianWidth, Orientation};
pub use fit::{
    FitError, HistogramFit, IntervalMethod, WidthFit, fit_gaussian_histogram, fit_gaussian_ml,
};
pub use flake::{Flake, FlakeError, PlaneFit, UnitVec3, fit_plane};
pub use heightmap::{HeightMap, HeightMapError};
pub use histogram::{AreaHistogram, HistogramBin, HistogramError};
pub use pool::{PoolError, PoolWarning, PooledWidth, pool_maps};
pub use segment::{
    SegmentError, SegmentParams, SegmentWarning, Segmentation, SegmentedFlake, segment,
};
