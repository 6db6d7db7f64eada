//! Numerics shared by the flakescatter models and fits, each written and tested once:
//!
//! * [`legendre`]: composite 16-point Gauss–Legendre quadrature on equal panels (the
//!   exact normalisations of orientation distributions);
//! * [`quad`]: Gauss–Kronrod 7 and 15 rules with their embedded Gauss rules, and an
//!   adaptive integrator with an error estimate, for numbers or vectors of numbers
//!   integrated on the same nodes (detector cones, conservation integrals);
//! * [`welford`]: Welford's running mean and sum of squared deviations, slot by slot
//!   (the ordered reductions of tile and batch sums behind the ray models' standard
//!   errors);
//! * [`cone_grid`]: a grid index from exit directions to the detector cones that may
//!   contain them (the topographic and the volume model's detector test);
//! * [`simd`]: the portable switch (`FLAKESCATTER_SIMD`) and the one instruction-set
//!   choice and dispatch of every SIMD kernel;
//! * [`lm`]: bounded Levenberg–Marquardt least squares with central-difference
//!   Jacobians (every fit of the project);
//! * [`nnls`]: non-negative least squares (Lawson & Hanson), for the non-parametric
//!   orientation estimate;
//! * [`Vec3`] and [`UnitVec3`]: the 3-vector and unit 3-vector every layer shares
//!   (defined here once; `optics` and `stats` re-export them);
//! * [`decimal`]: ranges and bin edges stepped on the decimals the user typed, and
//!   angles in radians shown as the degrees they were typed as.
//!
//! No physics and no units here: the callers state theirs.
//!
//! # Example
//! Fit `y = a exp(−b t)` to four points, with `b` kept in `[0, 5]`:
//! ```
//! use flakescatter_numerics::lm::{self, Settings};
//!
//! let t = [0.0, 1.0, 2.0, 3.0];
//! let y = [2.0, 1.2131, 0.7358, 0.4463]; // 2 exp(−0.5 t), rounded
//! let fit = lm::minimise(
//!     |p: &[f64]| -> Result<lm::Residuals, std::convert::Infallible> {
//!         Ok(Some(t.iter().zip(&y).map(|(t, y)| p[0] * (-p[1] * t).exp() - y).collect()))
//!     },
//!     &[1.0, 1.0],
//!     &[(0.0, 10.0), (0.0, 5.0)],
//!     &[1e-6, 1e-6],
//!     Settings::default(),
//! )?;
//! assert!((fit.x[0] - 2.0).abs() < 1e-3 && (fit.x[1] - 0.5).abs() < 1e-3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod cone_grid;
pub mod decimal;
pub mod legendre;
pub mod lm;
pub mod nnls;
pub mod quad;
pub mod simd;
pub mod welford;

/// A 3-vector of `f64` (the math type every flakescatter layer shares; units are the
/// caller's).
pub type Vec3 = nalgebra::Vector3<f64>;

/// A unit 3-vector: a direction or a surface normal.
pub type UnitVec3 = nalgebra::Unit<Vec3>;
