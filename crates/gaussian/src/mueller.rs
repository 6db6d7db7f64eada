//! The Mueller matrix of the distribution model (physics.md §11): the point Mueller BRDF
//! and what a detector cone collects, element by element.
//!
//! Conventions: those of [`flakescatter_optics::jones`] and
//! [`flakescatter_optics::mueller`] (SCATMECH's): Stokes vectors in the `(s, p)` basis
//! of the incident direction `(sin θi, 0, −cos θi)` (`s = y`) and of the exit direction
//! `(θr, φr)` (`s = (−sin φr, cos φr, 0)`; for an exit direction along `z` given alone,
//! [`DistributionModel::brdf_mueller`], `s = y`; for a detector at the pole, its `φr`,
//! below), `S1 = |E_s|²
//! − |E_p|²`, `S_out = M S_in`. Angles in radians.
//!
//! For an exit direction `r` with internal half vector `m` (model docs, steps 1–2) the
//! point Mueller BRDF is
//!
//! `F(θi, r) = M_path(k_in → r) · D(m) / (4 n² cos θt cos θ2)` (sr⁻¹),
//!
//! where `M_path = (cos θt/cos θi)(cos θo/cos θ2) · M(J)` is the Mueller matrix of the
//! ray's Jones matrix `J` as a fraction of the beam power
//! ([`flakescatter_optics::jones::Transfer::mueller`]): the scalar BRDF of the model
//! with the scalar path factor replaced by the matrix, so that `F00` is the exact
//! unpolarised BRDF and `F00 ± F01` the exact s and p ones ([`DistributionModel::brdf`]
//! with `exact-unpolarized`, `s`, `p`). The result does not depend on
//! [`ModelOptions::transmission`](crate::ModelOptions): the matrix is exact, and the
//! incident polarisation is the Stokes vector it multiplies. The weighting
//! (`paper-printed` multiplies by `cos θ2/cos θo`), the flake reflectance and the exit
//! switch (`exit_fresnel == false`: a lossless exit) are honoured.
//!
//! A cone collects `∫_cone F cos θr dΩr` (a Mueller matrix of fractions of the beam
//! power), integrated element by element on the nodes of the scalar rules
//! ([`crate::cone`]); their error estimate is the largest element difference between a
//! rule and its embedded coarser ones, and tolerances are relative to `m00`. Everything
//! a cone collects is given in **the basis of its axis**, as a detector with a fixed
//! analyser sees it: for each direction `r` in the cone, `s` is the axis's `s` projected
//! perpendicular to `r` ([`flakescatter_optics::jones::exit_frame`]). At the axis this
//! is SCATMECH's basis; it stays regular for a cone about the vertical, where the
//! per-direction bases turn with the azimuth. A detector at the pole (`θr = 0`) takes
//! the basis of its azimuth, `s = (−sin φr, cos φr, 0)`, the limit `θr → 0` at fixed
//! `φr` ([`flakescatter_optics::detector::Cone::basis_s`]), so its matrix is continuous
//! in `θr` for every `φr` (for the point BRDF too). The clear coat's specular reflection
//! adds the Mueller matrix of `diag(rs, rp)`
//! ([`flakescatter_optics::jones::clearcoat_jones`]), re-expressed in the cone's basis,
//! to every cone that contains the specular direction.
//!
//! # Example
//! The Mueller BRDF out of the plane of incidence: its `m00` is the scalar model's
//! unpolarised BRDF, and it is non-depolarising at a point:
//! ```
//! use flakescatter_gaussian::{DistributionModel, ModelOptions};
//! use flakescatter_optics::detector::out_of_plane_direction;
//! use flakescatter_stats::{GaussianWidth, Orientation};
//!
//! let o = Orientation::gaussian(GaussianWidth::RmsTilt(12f64.to_radians()))?;
//! let model = DistributionModel::new(o, 1.5, ModelOptions::default())?;
//! let inc = model.incidence(45f64.to_radians())?;
//! let r = out_of_plane_direction(40f64.to_radians(), 60f64.to_radians()).into_inner();
//! let f = model.brdf_mueller(&inc, &r);
//! assert!((f.m00() / model.brdf(&inc, &r) - 1.0).abs() < 1e-12);
//! assert!((f.gil_bernabeu_ratio() - 1.0).abs() < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use flakescatter_optics::detector::Cone;
use flakescatter_optics::jones::{clearcoat_jones, exit_frame};
use flakescatter_optics::mueller::Mueller;
use flakescatter_optics::polarization::Weighting;
use flakescatter_optics::{UnitVec3, Vec3, refraction};
use rayon::prelude::*;

use crate::ModelError;
use crate::cone::ConeMethod;
use crate::model::{DistributionModel, Incidence};

/// What one detector collects at one incidence, as Mueller matrices (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollectedMueller {
    /// Mueller BRDF averaged over the cone, `ρ / ∫_cone cos θr dΩ` (sr⁻¹); the point
    /// Mueller BRDF for a point detector (`α = 0`). Includes the clear coat when it is
    /// on and seen.
    pub brdf: Mueller,
    /// Collected fraction of the incident beam power, `ρ` (no unit); `None` for a
    /// point detector.
    pub reflectance: Option<Mueller>,
    /// `ρ / ΔΩ` (sr⁻¹), or `F cos θr` for a point detector: the quantity that the
    /// paper's figures normalise to the specular direction.
    pub power_per_sr: Mueller,
    /// Absolute error estimate of `reflectance` (of `brdf` for a point detector), the
    /// largest over the 16 elements; 0 for the constant-integrand approximation.
    pub error: f64,
    /// Whether the clear coat's specular reflection was added.
    pub clearcoat_seen: bool,
}

/// One row of a Mueller curve: one incidence × one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MuellerCurvePoint {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// The detector.
    pub cone: Cone,
    /// What it collects.
    pub collected: CollectedMueller,
}

impl DistributionModel {
    /// The point Mueller BRDF `F(θi, r)` of the flakes, sr⁻¹ (module docs; the clear
    /// coat's specular delta is not included). Zero for `r.z ≤ 0` and where no flake
    /// normal sends light to `r`.
    #[must_use]
    #[inline]
    pub fn brdf_mueller(&self, inc: &Incidence, r: &Vec3) -> Mueller {
        self.brdf_mueller_about(inc, r, &Vec3::zeros())
    }

    /// The point Mueller BRDF at the exit direction `base + offset` (a unit vector),
    /// sr⁻¹, with the offset's digits kept as in [`DistributionModel::brdf_about`].
    #[must_use]
    #[inline]
    pub fn brdf_mueller_about(&self, inc: &Incidence, base: &Vec3, offset: &Vec3) -> Mueller {
        self.mueller_about(inc, base, offset, None)
    }

    /// The point Mueller BRDF at `r` with the outgoing Stokes vector in the basis whose
    /// `s` is `reference` projected perpendicular to `r`
    /// ([`flakescatter_optics::jones::exit_frame`]; `reference` not parallel to `r`),
    /// sr⁻¹. With `reference` = the `s` of a detector's axis this is how the detector's
    /// analyser sees the light arriving along `r`.
    #[must_use]
    pub fn brdf_mueller_in_frame(&self, inc: &Incidence, r: &Vec3, reference: &Vec3) -> Mueller {
        self.mueller_about(inc, r, &Vec3::zeros(), Some(reference))
    }

    /// The point Mueller BRDF at `base + offset`, in SCATMECH's basis (`frame == None`)
    /// or in the frame of `reference` (module docs).
    #[inline]
    fn mueller_about(
        &self,
        inc: &Incidence,
        base: &Vec3,
        offset: &Vec3,
        frame: Option<&Vec3>,
    ) -> Mueller {
        let r = base + offset;
        if r.z <= 0.0 {
            return Mueller::ZERO;
        }
        let n = self.index();
        let Some((h, c2)) = self.half_vector(inc, base, offset, r.z) else {
            return Mueller::ZERO;
        };
        let p2 = self
            .orientation()
            .p2((h.x * h.x + h.y * h.y).sqrt().atan2(h.z));
        if p2 == 0.0 {
            return Mueller::ZERO;
        }
        let k2 = Vec3::new(r.x / n, r.y / n, c2);
        let t = self.transfer(inc, &h, &k2, &r, self.obliquity(inc, &h));
        let mut k = t.power_scale * p2 * self.inv_mean_cos() / (4.0 * n * n * inc.cos_t * c2);
        if self.options().weighting == Weighting::PaperPrinted {
            k *= c2 / r.z;
        }
        if let Some(a) = self.absorption_factor(inc.cos_t, c2) {
            k *= a;
        }
        let jones = match frame {
            Some(u) => t.jones.rotate_out(exit_frame(&r, u)),
            None => t.jones,
        };
        jones.mueller() * k
    }

    /// What the ray reflected by a flake of normal `m` carries out of the coating per
    /// unit of flake area density, as a Mueller matrix: `M_path γ / cos θt` (times
    /// `cos θ2/cos θo` for the paper-printed weighting), with its exit direction;
    /// `None` when the ray is lost. The matrix form of [`DistributionModel::ray_weight`]
    /// (its `m00` for `exact-unpolarized`).
    #[must_use]
    pub fn ray_mueller(&self, inc: &Incidence, m: &UnitVec3) -> Option<(Mueller, UnitVec3)> {
        let k1 = UnitVec3::new_unchecked(inc.k1);
        let gamma = -k1.dot(m);
        if gamma <= 0.0 {
            return None;
        }
        let k2 = flakescatter_optics::reflection::reflect(&k1, m);
        if k2.z <= 0.0 {
            return None;
        }
        let out = refraction::out_of_coating(&k2, self.index())?;
        let t = self.transfer(inc, m, &k2, &out, gamma);
        let mut w = t.power_scale * gamma / inc.cos_t;
        if self.options().weighting == Weighting::PaperPrinted {
            w *= k2.z / out.z;
        }
        if let Some(a) = self.absorption_factor(inc.cos_t, k2.z) {
            w *= a;
        }
        Some((t.jones.mueller() * w, out))
    }

    /// The Mueller matrix of the clear coat's specular reflection at this incidence, a
    /// fraction of the beam power (`m00 = R_av`), in SCATMECH's basis of the specular
    /// direction.
    #[must_use]
    pub fn clearcoat_mueller(&self, inc: &Incidence) -> Mueller {
        clearcoat_jones(inc.amplitudes[0], inc.amplitudes[1]).mueller()
    }

    /// What the detector `cone` collects at incidence `inc`, as Mueller matrices
    /// (module docs). `m00` of each is what [`DistributionModel::collect`] gives for
    /// `exact-unpolarized`.
    #[must_use]
    pub fn collect_mueller(
        &self,
        inc: &Incidence,
        cone: &Cone,
        method: ConeMethod,
    ) -> CollectedMueller {
        let axis = cone.axis().into_inner();
        let alpha = cone.half_angle();
        // The cone's basis (module docs): the axis's s, projected at each direction. At
        // the pole the axis's own basis is the limit at the detector's azimuth
        // (`Cone::basis_s`), not the direction's `s = y`.
        let u = *cone.basis_s();
        let at_pole = (axis.x == 0.0 && axis.y == 0.0).then_some(&u);
        let point = || self.mueller_about(inc, &axis, &Vec3::zeros(), at_pole);
        if alpha == 0.0 {
            let f = point();
            return CollectedMueller {
                brdf: f,
                reflectance: None,
                power_per_sr: f * axis.z,
                error: 0.0,
                clearcoat_seen: false,
            };
        }
        let solid = cone.solid_angle();
        let (mut rho, proj, error) = match method {
            ConeMethod::ConstantIntegrand => {
                let f = point();
                (f * (axis.z * solid), axis.z.max(0.0) * solid, 0.0)
            }
            ConeMethod::Exact => self.cone_integral_of(
                inc,
                cone,
                |dirs: &[Vec3], out: &mut Vec<Mueller>| {
                    out.clear();
                    out.extend(
                        dirs.iter()
                            .map(|r| self.mueller_about(inc, r, &Vec3::zeros(), Some(&u))),
                    );
                },
                |p: &Vec3, o: &Vec3| self.mueller_about(inc, p, o, Some(&u)),
            ),
        };
        let clearcoat_seen = self.options().clearcoat && cone.contains(&inc.specular);
        if clearcoat_seen {
            let j = clearcoat_jones(inc.amplitudes[0], inc.amplitudes[1]);
            rho += j.rotate_out(exit_frame(&inc.specular, &u)).mueller();
        }
        CollectedMueller {
            brdf: if proj > 0.0 {
                rho * (1.0 / proj)
            } else {
                Mueller::ZERO
            },
            reflectance: Some(rho),
            power_per_sr: rho * (1.0 / solid),
            error,
            clearcoat_seen,
        }
    }
}

/// The Mueller matrices of the model at every incidence in `theta_i` (radians) for every
/// detector in `cones`, rows ordered by incidence then detector. Detectors are evaluated
/// in parallel; the result does not depend on the number of threads.
///
/// # Errors
/// [`ModelError::Incidence`] for an angle outside `[0, π/2)`, [`ModelError::Empty`]
/// for an empty list, [`ModelError::ConstantIntegrandTooNarrow`] for the
/// constant-integrand approximation with a distribution narrower than the aperture.
pub fn curve_mueller(
    model: &DistributionModel,
    theta_i: &[f64],
    cones: &[Cone],
    method: ConeMethod,
) -> Result<Vec<MuellerCurvePoint>, ModelError> {
    if theta_i.is_empty() {
        return Err(ModelError::Empty("incidence angle"));
    }
    if cones.is_empty() {
        return Err(ModelError::Empty("detector"));
    }
    let mut rows = Vec::with_capacity(theta_i.len() * cones.len());
    for &ti in theta_i {
        let inc = model.incidence(ti)?;
        for c in cones {
            model.check_method(&inc, c.half_angle(), method)?;
        }
        let collected: Vec<CollectedMueller> = cones
            .par_iter()
            .map(|c| model.collect_mueller(&inc, c, method))
            .collect();
        rows.extend(
            cones
                .iter()
                .zip(collected)
                .map(|(cone, collected)| MuellerCurvePoint {
                    theta_i: ti,
                    cone: *cone,
                    collected,
                }),
        );
    }
    Ok(rows)
}
