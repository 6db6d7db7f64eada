//! The clear coat's top surface: Fresnel reflection by a surface that may be rough
//! (physics.md §12.2).
//!
//! Conventions: radians; `wi` points from the surface toward the source and `wo` toward
//! the detector, both unit vectors in air with `z > 0` (so `wi = −k_in`); `n` is the
//! coat's real index (air outside). The surface is a mixture of two isotropic
//! Trowbridge–Reitz (GGX) microfacet populations of slope scales `α` (the coat's own
//! roughness, `α = 0` an optically flat mirror) and `αh` (haze), with weights `1 − h`
//! and `h`. Each facet reflects the unpolarised Fresnel fraction `F(i·m)` of an
//! air-to-coat crossing. Per population,
//!
//! `f = F(i·m) D(m) G2(i, o) / (4 cos θi cos θo)`, `m = (wi + wo)/|wi + wo|`,
//!
//! with `D(m) = α² / (π (1 + (α² − 1) cos²θm)²)` (`∫ D cos θm dΩ = 1`) and Smith's
//! height-correlated masking–shadowing `G2 = 1/(1 + Λ(i) + Λ(o))`,
//! `Λ(θ) = (√(1 + α² tan²θ) − 1)/2`. The flat mirror (`α = 0`) is a delta at the specular
//! direction carrying `(1 − h) R_av(θi)`: zero in the point BRDF, collected by a detector
//! cone that contains the specular direction (physics.md §6).
//!
//! Light crossing the surface is refracted as by the mean (flat) surface; its power is
//! what the surface does not reflect, at most the flat surface's transmittance:
//! [`CoatSurface::transmission_factor`] `= min(1, (1 − A(θ))/T_av(θ))`, `A` the surface's
//! directional albedo (exactly 1 for a flat coat).

use std::f64::consts::{FRAC_PI_2, PI};

use crate::PaintError;
use flakescatter_numerics::quad::adaptive_nested;
use flakescatter_optics::{Vec3, fresnel};

/// The largest slope scale accepted for either population (a GGX surface of slope scale
/// 2 scatters almost uniformly; wider is not a coat).
pub const MAX_ROUGHNESS: f64 = 2.0;

/// Nodes of the directional-albedo table, equally spaced in `cos θ` on `[0, 1]`.
const ALBEDO_NODES: usize = 65;

/// The coat's top surface.
#[derive(Debug, Clone, PartialEq)]
pub struct CoatParams {
    /// Refractive index of the clear coat (real, ≥ 1).
    pub n: f64,
    /// Slope scale `α` of the coat's own surface (GGX); 0 is an optically flat mirror.
    pub roughness: f64,
    /// Fraction `h ∈ [0, 1]` of the surface in the haze population.
    pub haze: f64,
    /// Slope scale `αh` of the haze population (GGX), `> 0` when `haze > 0`.
    pub haze_roughness: f64,
}

impl CoatParams {
    /// A flat coat of index `n`.
    #[must_use]
    pub fn flat(n: f64) -> Self {
        Self {
            n,
            roughness: 0.0,
            haze: 0.0,
            haze_roughness: 0.0,
        }
    }

    /// Checks the parameters.
    ///
    /// # Errors
    /// [`PaintError::Parameter`] naming the first value out of range.
    pub fn validate(&self) -> Result<(), PaintError> {
        let bad = |name: &str, v: f64, want: &str| {
            Err(PaintError::Parameter(format!(
                "coat {name} = {v}: expected {want}"
            )))
        };
        if !(self.n.is_finite() && self.n >= 1.0) {
            return bad("index n", self.n, "a finite real >= 1");
        }
        if !((0.0..=MAX_ROUGHNESS).contains(&self.roughness)) {
            return bad("roughness", self.roughness, "a slope scale in [0, 2]");
        }
        if !((0.0..=1.0).contains(&self.haze)) {
            return bad("haze", self.haze, "a fraction in [0, 1]");
        }
        if self.haze > 0.0 && !(self.haze_roughness > 0.0 && self.haze_roughness <= MAX_ROUGHNESS) {
            return bad(
                "haze roughness",
                self.haze_roughness,
                "a slope scale in (0, 2] when the haze is not zero",
            );
        }
        if !(self.haze_roughness.is_finite() && self.haze_roughness >= 0.0) {
            return bad(
                "haze roughness",
                self.haze_roughness,
                "a slope scale in [0, 2]",
            );
        }
        Ok(())
    }
}

/// The coat surface with its directional-albedo table.
#[derive(Debug, Clone)]
pub struct CoatSurface {
    params: CoatParams,
    /// `A(μ)` at `μ = k/(ALBEDO_NODES − 1)`; empty for a flat coat without haze.
    albedo: Vec<f64>,
}

impl CoatSurface {
    /// The surface of `params`.
    ///
    /// # Errors
    /// As [`CoatParams::validate`].
    pub fn new(params: CoatParams) -> Result<Self, PaintError> {
        params.validate()?;
        let mut s = Self {
            params,
            albedo: Vec::new(),
        };
        if !s.is_flat() {
            s.albedo = (0..ALBEDO_NODES)
                .map(|k| s.albedo_exact(k as f64 / (ALBEDO_NODES - 1) as f64))
                .collect();
        }
        Ok(s)
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &CoatParams {
        &self.params
    }

    /// `true` for a flat coat without haze (the coat of physics.md §6).
    #[must_use]
    pub fn is_flat(&self) -> bool {
        self.params.roughness == 0.0 && self.params.haze == 0.0
    }

    /// Point BRDF of the rough populations, sr⁻¹ (the flat mirror's delta is not in it).
    #[must_use]
    pub fn brdf(&self, wi: &Vec3, wo: &Vec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let p = &self.params;
        let mut total = 0.0;
        if p.roughness > 0.0 && p.haze < 1.0 {
            total += (1.0 - p.haze) * lobe(p.roughness, p.n, wi, wo);
        }
        if p.haze > 0.0 {
            total += p.haze * lobe(p.haze_roughness, p.n, wi, wo);
        }
        total
    }

    /// The fraction of the beam at incidence `theta_i` that the flat mirror part
    /// reflects into the specular direction (a delta): `(1 − h) R_av(θi)` for a flat
    /// coat surface (`α = 0`), else 0.
    #[must_use]
    pub fn specular_delta(&self, theta_i: f64) -> f64 {
        if self.params.roughness == 0.0 {
            (1.0 - self.params.haze) * fresnel::air_to_coating(theta_i, self.params.n).r_av()
        } else {
            0.0
        }
    }

    /// Directional albedo `A(θ)` of the surface (delta included), from the table
    /// (linear in `cos θ`; interpolation error below 1e-5) or exactly for a flat coat.
    #[must_use]
    pub fn albedo(&self, cos_theta: f64) -> f64 {
        let mu = cos_theta.clamp(0.0, 1.0);
        if self.albedo.is_empty() {
            return fresnel::power_from_cosines(mu, inside_cos(mu, self.params.n), self.params.n)
                .r_av();
        }
        let x = mu * (ALBEDO_NODES - 1) as f64;
        let k = (x.floor() as usize).min(ALBEDO_NODES - 2);
        let t = x - k as f64;
        self.albedo[k] + t * (self.albedo[k + 1] - self.albedo[k])
    }

    /// The factor on the power of light crossing the surface at air-side `cos θ`:
    /// `min(1, (1 − A(θ))/T_av(θ))` (module docs), exactly 1 for a flat coat.
    #[must_use]
    pub fn transmission_factor(&self, cos_theta: f64) -> f64 {
        if self.albedo.is_empty() {
            return 1.0;
        }
        let mu = cos_theta.clamp(0.0, 1.0);
        let t =
            fresnel::power_from_cosines(mu, inside_cos(mu, self.params.n), self.params.n).t_av();
        if t <= 0.0 {
            return 1.0;
        }
        ((1.0 - self.albedo(mu)) / t).clamp(0.0, 1.0)
    }

    /// `A(μ)` by quadrature (the table's nodes; also used by tests): per population
    /// `∫ F G2 (i·m)/(μ cos θm) D cos θm dΩm`, written in the slope variable
    /// `tan θm = α tan ψ` where `D cos θm dΩm = sin ψ cos ψ dψ dφ/π`, a smooth integrand
    /// on `[0, π/2] × [0, π]` (doubled by symmetry). Adaptive Gauss–Kronrod, relative
    /// tolerance 1e-9.
    #[must_use]
    pub fn albedo_exact(&self, mu: f64) -> f64 {
        let p = &self.params;
        let mut a = 0.0;
        if p.roughness == 0.0 {
            a += (1.0 - p.haze) * fresnel::power_from_cosines(mu, inside_cos(mu, p.n), p.n).r_av();
        } else if p.haze < 1.0 {
            a += (1.0 - p.haze) * lobe_albedo(p.roughness, p.n, mu);
        }
        if p.haze > 0.0 {
            a += p.haze * lobe_albedo(p.haze_roughness, p.n, mu);
        }
        a
    }
}

/// `cos θt` inside for air-side `cos θ = mu` (Snell).
fn inside_cos(mu: f64, n: f64) -> f64 {
    (1.0 - (1.0 - mu * mu) / (n * n)).max(0.0).sqrt()
}

/// GGX `D(m)`, `∫ D cos θm dΩ = 1`.
#[inline]
fn ggx_d(alpha: f64, cos_m: f64) -> f64 {
    let a2 = alpha * alpha;
    let d = 1.0 + (a2 - 1.0) * cos_m * cos_m;
    a2 / (PI * d * d)
}

/// Smith's `Λ` of GGX at a direction of cosine `cz > 0`.
#[inline]
fn ggx_lambda(alpha: f64, cz: f64) -> f64 {
    let t2 = (1.0 - cz * cz).max(0.0) / (cz * cz);
    0.5 * ((1.0 + alpha * alpha * t2).sqrt() - 1.0)
}

/// One population's point BRDF (module docs).
fn lobe(alpha: f64, n: f64, wi: &Vec3, wo: &Vec3) -> f64 {
    let h = wi + wo;
    let len = h.norm();
    if len == 0.0 {
        return 0.0;
    }
    let m = h / len;
    let cos_d = wi.dot(&m);
    if cos_d <= 0.0 || m.z <= 0.0 {
        return 0.0;
    }
    let f = fresnel::power_from_cosines(cos_d, inside_cos(cos_d, n), n).r_av();
    let g2 = 1.0 / (1.0 + ggx_lambda(alpha, wi.z) + ggx_lambda(alpha, wo.z));
    f * ggx_d(alpha, m.z) * g2 / (4.0 * wi.z * wo.z)
}

/// One population's directional albedo at `cos θ = mu` (see [`CoatSurface::albedo_exact`]).
fn lobe_albedo(alpha: f64, n: f64, mu: f64) -> f64 {
    if mu <= 0.0 {
        return 0.0;
    }
    let st = (1.0 - mu * mu).max(0.0).sqrt();
    let wi = Vec3::new(st, 0.0, mu);
    let lam_i = ggx_lambda(alpha, mu);
    let inner = |psi: f64| -> (f64, f64) {
        let (sp, cp) = psi.sin_cos();
        // tan θm = α tan ψ.
        let tm = alpha * psi.tan();
        let cm = 1.0 / tm.mul_add(tm, 1.0).sqrt();
        let sm = tm * cm;
        let weight = sp * cp / PI;
        let phi = |ph: f64| -> f64 {
            let m = Vec3::new(sm * ph.cos(), sm * ph.sin(), cm);
            let cd = wi.dot(&m);
            if cd <= 0.0 {
                return 0.0;
            }
            let o = m * (2.0 * cd) - wi;
            if o.z <= 0.0 {
                return 0.0;
            }
            let f = fresnel::power_from_cosines(cd, inside_cos(cd, n), n).r_av();
            let g2 = 1.0 / (1.0 + lam_i + ggx_lambda(alpha, o.z));
            // (i·m)/(μ cos θm) with cos θm = cm.
            f * g2 * cd / (mu * cm)
        };
        // The integrand vanishes where the reflected ray goes below the horizon: break
        // at φ = π/2 where i·m changes least smoothly.
        let (v, e) = adaptive_nested(
            |ph: f64| (phi(ph), 0.0),
            0.0,
            PI,
            &[FRAC_PI_2],
            1e-14,
            1e-11,
            200,
        );
        (2.0 * weight * v, 2.0 * weight * e)
    };
    adaptive_nested(inner, 0.0, FRAC_PI_2, &[FRAC_PI_2 / 2.0], 1e-13, 1e-9, 200).0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The substitution `tan θm = α tan ψ` (`D cos θm dΩ = sin ψ cos ψ dψ dφ/π`): with
    /// `F = G2 = 1` and the factor `(i·m)/(μ cos θm)` replaced by 1 the integral is
    /// `∫ D cos θm dΩ = 1`; checked through the normal-incidence albedo of a mirror-like
    /// index limit instead, and here directly on the Jacobian.
    #[test]
    fn slope_substitution_has_unit_jacobian() {
        let alpha: f64 = 0.3;
        // ∫_0^{π/2} sin ψ cos ψ dψ · 2π/π = 1.
        let (v, _) = flakescatter_numerics::quad::adaptive(
            |psi: f64| psi.sin() * psi.cos() * 2.0,
            0.0,
            FRAC_PI_2,
            &[],
            1e-15,
            1e-13,
            50,
        );
        assert!((v - 1.0).abs() < 1e-13);
        // And the same as an integral of D cos θm sin θm over θm.
        let (w, _) = flakescatter_numerics::quad::adaptive(
            |t: f64| 2.0 * PI * ggx_d(alpha, t.cos()) * t.cos() * t.sin(),
            0.0,
            FRAC_PI_2,
            &[alpha.atan()],
            1e-15,
            1e-13,
            200,
        );
        assert!((w - 1.0).abs() < 1e-12, "{w}");
    }
}
