//! The distribution model of flake coatings (NIST, Sung et al. 2002, eqs. 9–13, as
//! corrected in physics.md §4).
//!
//! Flat mirror flakes under a clear coat of index `n`, with normals distributed as an
//! [`Orientation`](flakescatter_stats::Orientation), reflect a collimated beam. This crate
//! gives:
//!
//! * the point BRDF `f(θi, r)` (sr⁻¹) with the four Fresnel bookkeepings and both
//!   weightings ([`DistributionModel::brdf`], module [`model`]);
//! * what a detector cone collects, exactly (quadrature with an error estimate, about the
//!   detector axis or, for distributions narrower than the aperture down to the delta
//!   limit, about the specular direction) or in the paper's constant-integrand
//!   approximation ([`DistributionModel::collect`], module [`cone`]), and whole curves
//!   with the `relative` normalisation to the specular detector ([`curve`]);
//! * the point Mueller BRDF and the Mueller matrix a cone collects, element by element,
//!   in SCATMECH's `(s, p)` bases ([`DistributionModel::brdf_mueller`],
//!   [`DistributionModel::collect_mueller`], [`curve_mueller`], module [`mueller`]);
//! * the hemispherical total computed in detector space and in normal space, which must
//!   agree (module [`hemisphere`]);
//! * an independent Monte Carlo estimator (module [`montecarlo`]).
//!
//! Conventions: radians; the frame and the signed in-plane angle `θs` of
//! `flakescatter_optics` (`θs = −θi` is specular). Reflectances are fractions of the
//! incident beam power; BRDFs are per steradian.
//!
//! # Example
//! The relative in-plane curve for a `hwhm` 6° Gaussian at 45° incidence, with 1.5°
//! detectors:
//! ```
//! use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions, curve};
//! use flakescatter_optics::detector::Cone;
//! use flakescatter_stats::{GaussianWidth, Orientation};
//!
//! let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians()))?;
//! let model = DistributionModel::new(orientation, 1.5, ModelOptions::default())?;
//! let alpha = 1.5f64.to_radians();
//! let cones: Vec<Cone> = (-70..=70)
//!     .map(|d| Cone::in_plane(f64::from(d).to_radians(), alpha))
//!     .collect::<Result<_, _>>()?;
//! let rows = curve(&model, &[45f64.to_radians()], &cones, ConeMethod::Exact)?;
//! // The specular detector (θs = −45°) has relative value 1 by definition.
//! let spec = rows.iter().find(|r| (r.theta_s_deg() + 45.0).abs() < 1e-9).unwrap();
//! assert!((spec.relative - 1.0).abs() < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod base;
pub mod batch;
mod breaks;
pub mod cone;
pub mod hemisphere;
pub mod model;
pub mod montecarlo;
pub mod mueller;
/// The quadrature rules, from `flakescatter-numerics` (re-exported where the cone rules
/// were written).
pub use flakescatter_numerics::quad;

use flakescatter_optics::Vec3;
use flakescatter_optics::detector::{Cone, in_plane_angle};
use rayon::prelude::*;

pub use base::{BaseLoop, BaseUnder};
pub use cone::{Collected, ConeMethod};
pub use flakescatter_numerics::simd::Kernels;
pub use model::{DistributionModel, Incidence, ModelOptions, RayKernel};
pub use montecarlo::{McEstimate, monte_carlo};
pub use mueller::{CollectedMueller, MuellerCurvePoint, curve_mueller};

/// Errors of the distribution model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// Invalid clear-coat index.
    #[error("clear-coat index: {0}")]
    Index(flakescatter_optics::OpticsError),
    /// Invalid complex flake index.
    #[error("flake index: {0}")]
    FlakeIndex(flakescatter_optics::OpticsError),
    /// Incidence angle outside `[0, π/2)`.
    #[error("incidence angle {0} rad is out of range: expected [0, pi/2)")]
    Incidence(f64),
    /// Invalid detector geometry.
    #[error("detector: {0}")]
    Detector(flakescatter_optics::OpticsError),
    /// Nothing to compute.
    #[error("{0} list is empty")]
    Empty(&'static str),
    /// A base albedo outside `[0, 1]` (physics.md §13).
    #[error("base albedo {0} is not valid: expected a number in [0, 1]")]
    BaseAlbedo(f64),
    /// A base under flakes that transmit nothing (physics.md §13).
    #[error(
        "a base under the flakes needs flakes that transmit: a thin-film stack without an opaque core (metal flakes, and a core, send nothing down to it)"
    )]
    BaseFlake,
    /// A base with a setting whose path it does not follow (physics.md §13).
    #[error("a base under the flakes is not modelled with {0}")]
    BaseSetting(&'static str),
    /// The constant-integrand approximation was asked for a distribution narrower than
    /// the aperture (see [`DistributionModel::check_method`]).
    #[error(
        "the constant-integrand approximation takes the BRDF as constant over the detector cone, but the flake light is only {:.3e} degrees wide in exit directions against a {:.3} degree aperture (half-angle): its values would be wrong by orders of magnitude; use the exact cone integral",
        .feature.to_degrees(),
        .aperture.to_degrees()
    )]
    ConstantIntegrandTooNarrow {
        /// Narrowest width of the flake light in exit directions, radians
        /// ([`DistributionModel::exit_feature`]).
        feature: f64,
        /// Aperture half-angle, radians.
        aperture: f64,
    },
    /// The flat (delta) distribution has no density to integrate.
    #[error(
        "all flakes flat (a delta distribution): the reflectance is a delta at the specular direction; use a Gaussian of small width instead"
    )]
    Delta,
    /// The environment variable `FLAKESCATTER_SIMD` holds a value other than `auto` or
    /// `portable` ([`Kernels::from_env`]); the value, lossily decoded.
    #[error(
        "environment variable FLAKESCATTER_SIMD={0:?} is not valid: expected `auto` (or unset) for the processor's best instruction set, or `portable` for the portable code"
    )]
    SimdSwitch(String),
}

/// One row of a reflectance curve: one incidence × one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePoint {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// The detector.
    pub cone: Cone,
    /// What it collects.
    pub collected: Collected,
    /// `power_per_sr` divided by that of the same detector at the specular direction
    /// (the paper's "normalised to 1 in the specular direction").
    pub relative: f64,
}

impl CurvePoint {
    /// Signed in-plane angle of the detector axis in degrees (`θs = −θi` specular);
    /// for an out-of-plane detector, the angle of its projection on the plane of
    /// incidence.
    #[must_use]
    pub fn theta_s_deg(&self) -> f64 {
        in_plane_angle(self.cone.axis()).to_degrees()
    }
}

/// Point detectors per block of [`curve`]'s batch evaluation, a block to a thread: about
/// 60 µs of work, so that an incidence of a few thousand directions (an in-plane scan
/// every 0.1°) is one block on the calling thread rather than several handed between
/// threads for a few µs each (what the hand-offs cost).
const POINT_BLOCK: usize = 4096;

/// The model at every incidence in `theta_i` (radians) for every detector in `cones`,
/// rows ordered by incidence then detector: [`curve_each`]'s rows, collected.
///
/// # Errors
/// Those of [`curve_each`].
pub fn curve(
    model: &DistributionModel,
    theta_i: &[f64],
    cones: &[Cone],
    method: ConeMethod,
) -> Result<Vec<CurvePoint>, ModelError> {
    let mut rows = Vec::with_capacity(theta_i.len().saturating_mul(cones.len()));
    curve_each(model, theta_i, cones, method, |points| {
        rows.extend_from_slice(points);
        Ok::<(), ModelError>(())
    })?;
    Ok(rows)
}

/// [`curve`] one incidence at a time: `each` is given the rows of each incidence in
/// turn (one per detector, in order) as they are computed, so that a large grid is
/// never held whole. Every error of the model comes before the first call of `each`;
/// `each`'s own first error ends the run and is returned.
///
/// Detectors are evaluated in parallel; the result does not depend on the number of
/// threads. When every detector is a point (`α = 0`), the point BRDF is evaluated in
/// blocks by [`DistributionModel::brdf_batch`] (equal to [`DistributionModel::brdf`] to
/// 1e-12 relative), the specular reference too.
///
/// # Errors
/// [`ModelError::Incidence`] for an angle outside `[0, π/2)`, [`ModelError::Empty`]
/// for an empty list, [`ModelError::Detector`] if the specular reference cone cannot be
/// built, [`ModelError::ConstantIntegrandTooNarrow`] for the constant-integrand
/// approximation with a distribution narrower than the aperture; the first error of
/// `each`.
pub fn curve_each<E: From<ModelError>>(
    model: &DistributionModel,
    theta_i: &[f64],
    cones: &[Cone],
    method: ConeMethod,
    mut each: impl FnMut(&[CurvePoint]) -> Result<(), E>,
) -> Result<(), E> {
    if theta_i.is_empty() {
        return Err(ModelError::Empty("incidence angle").into());
    }
    if cones.is_empty() {
        return Err(ModelError::Empty("detector").into());
    }
    // Every check first, incidence by incidence in the order the rows would meet them,
    // so that the first error is the one a row-by-row pass would give, and comes before
    // any row. Kept: each incidence and its specular reference cone per aperture.
    let mut checked = Vec::with_capacity(theta_i.len());
    for &ti in theta_i {
        let inc = model.incidence(ti)?;
        for c in cones {
            model.check_method(&inc, c.half_angle(), method)?;
        }
        let mut specular: Vec<(f64, Cone)> = Vec::new();
        for c in cones {
            let alpha = c.half_angle();
            if !specular.iter().any(|(a, _)| *a == alpha) {
                let sc = Cone::in_plane(-ti, alpha).map_err(ModelError::Detector)?;
                specular.push((alpha, sc));
            }
        }
        checked.push((inc, specular));
    }
    // Point detectors: the vectorised point BRDF over blocks of directions (equal to
    // `collect`'s scalar value to 1e-12 relative), the specular reference from the same
    // kernel.
    let axes: Option<Vec<Vec3>> = cones
        .iter()
        .all(|c| c.half_angle() == 0.0)
        .then(|| cones.iter().map(|c| c.axis().into_inner()).collect());
    let mut rows = Vec::with_capacity(cones.len());
    for (inc, specular) in &checked {
        let collected: Vec<Collected> = match &axes {
            Some(axes) => {
                let f: Vec<f64> = axes
                    .par_chunks(POINT_BLOCK)
                    .flat_map_iter(|block| {
                        let mut out = Vec::with_capacity(block.len());
                        model.brdf_batch(inc, block, &mut out);
                        if model.base().is_some() {
                            for (f, r) in out.iter_mut().zip(block) {
                                *f += model.base_brdf(inc, r);
                            }
                        }
                        out
                    })
                    .collect();
                axes.iter()
                    .zip(f)
                    .map(|(r, f)| Collected::point(f, r.z))
                    .collect()
            }
            None => cones
                .par_iter()
                .map(|c| model.collect(inc, c, method))
                .collect(),
        };
        // What the detector at the specular direction collects, per aperture.
        let spec: Vec<(f64, f64)> = specular
            .iter()
            .map(|(alpha, sc)| {
                let v = if *alpha == 0.0 {
                    let axis = sc.axis().into_inner();
                    let mut out = Vec::with_capacity(1);
                    model.brdf_batch(inc, &[axis], &mut out);
                    if model.base().is_some() {
                        out[0] += model.base_brdf(inc, &axis);
                    }
                    out[0] * axis.z
                } else {
                    model.collect(inc, sc, method).power_per_sr
                };
                (*alpha, v)
            })
            .collect();
        rows.clear();
        for (cone, col) in cones.iter().zip(collected) {
            let alpha = cone.half_angle();
            let spec = spec
                .iter()
                .find(|(a, _)| *a == alpha)
                .map_or(f64::NAN, |&(_, v)| v);
            rows.push(CurvePoint {
                theta_i: inc.theta_i,
                cone: *cone,
                collected: col,
                relative: if spec > 0.0 {
                    col.power_per_sr / spec
                } else {
                    f64::NAN
                },
            });
        }
        each(&rows)?;
    }
    Ok(())
}
