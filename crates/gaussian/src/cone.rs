//! What a detector cone collects (physics.md §4).
//!
//! Conventions: a detector is a [`Cone`] of half-angle `α` about its axis `r_j`. It
//! collects `ρ_j = ∫_cone f(θi, r) cos θr dΩr`, a fraction of the incident beam power.
//! The exact rule integrates in polar coordinates about the detector axis: angle
//! `β ∈ [0, α]` from the axis by Gauss–Kronrod 15, azimuth `ψ` about the axis by the
//! 48-point trapezoid rule (spectrally accurate for a periodic integrand). The error
//! estimate is the difference between this rule and its embedded coarser rules (Gauss 7
//! in `β`, 24 points in `ψ`): a bound on the coarse rules' error, so the reported
//! error is conservative. Directions below the horizon contribute nothing, also to the
//! projected solid angle. The paper's constant-integrand approximation is
//! `ρ_j ≈ f(r_j) cos θj ΔΩ` with `ΔΩ = 2π(1 − cos α)`.

use std::f64::consts::PI;

use flakescatter_optics::Vec3;
use flakescatter_optics::detector::{Cone, orthonormal_frame};

use crate::model::{DistributionModel, Incidence};
use crate::quad::gk15_nodes;

/// How a detector's cone is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ConeMethod {
    /// The exact cone integral (GK15 × 48-point trapezoid, with an error estimate).
    #[default]
    Exact,
    /// The paper's constant-integrand approximation `f(r_j) cos θj ΔΩ`.
    ConstantIntegrand,
}

/// Trapezoid nodes in azimuth about the detector axis.
const N_PSI: usize = 48;

/// What one detector collects at one incidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collected {
    /// BRDF averaged over the cone, `ρ / ∫_cone cos θr dΩ` (sr⁻¹); the point BRDF for a
    /// point detector (`α = 0`). Includes the clear coat when it is on and seen.
    pub brdf: f64,
    /// Fraction of the incident beam power collected, `ρ`; `None` for a point detector.
    pub reflectance: Option<f64>,
    /// Collected power per steradian of aperture, `ρ / ΔΩ` (the cone average of
    /// `BRDF × cos θr`), or `f cos θr` for a point detector: the quantity the paper's
    /// figures normalise to the specular direction.
    pub power_per_sr: f64,
    /// Absolute error estimate of `reflectance` (of `brdf` for a point detector);
    /// 0 for the constant-integrand approximation, whose error is not estimated.
    pub error: f64,
    /// Whether the clear coat's specular reflection was added.
    pub clearcoat_seen: bool,
}

impl DistributionModel {
    /// What the detector `cone` collects at incidence `inc`.
    #[must_use]
    pub fn collect(&self, inc: &Incidence, cone: &Cone, method: ConeMethod) -> Collected {
        let axis = cone.axis().into_inner();
        let alpha = cone.half_angle();
        if alpha == 0.0 {
            let f = self.brdf(inc, &axis);
            return Collected {
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
                let f = self.brdf(inc, &axis);
                (f * axis.z * solid, axis.z.max(0.0) * solid, 0.0)
            }
            ConeMethod::Exact => self.cone_integral(inc, cone),
        };
        let clearcoat_seen = self.options().clearcoat && cone.contains(&inc.specular);
        if clearcoat_seen {
            rho += inc.clearcoat;
        }
        Collected {
            brdf: if proj > 0.0 { rho / proj } else { 0.0 },
            reflectance: Some(rho),
            power_per_sr: rho / solid,
            error,
            clearcoat_seen,
        }
    }

    /// `(∫ f cos θr dΩ, ∫ max(cos θr, 0) dΩ, error of the first)` over the cone.
    fn cone_integral(&self, inc: &Incidence, cone: &Cone) -> (f64, f64, f64) {
        let axis = cone.axis().into_inner();
        let (u, v) = orthonormal_frame(cone.axis());
        let (u, v) = (u.into_inner(), v.into_inner());
        let mut dirs = [(0.0, 0.0); N_PSI];
        for (j, d) in dirs.iter_mut().enumerate() {
            *d = (2.0 * PI * j as f64 / N_PSI as f64).sin_cos();
        }
        let dpsi = 2.0 * PI / N_PSI as f64;
        let (mut k_rho, mut g_rho, mut half_rho, mut proj) = (0.0, 0.0, 0.0, 0.0);
        for (beta, wk, wg) in gk15_nodes(0.0, cone.half_angle()) {
            let (sb, cb) = beta.sin_cos();
            let (mut ring, mut ring_half, mut ring_proj) = (0.0, 0.0, 0.0);
            for (j, &(sp, cp)) in dirs.iter().enumerate() {
                let r: Vec3 = axis * cb + (u * cp + v * sp) * sb;
                if r.z <= 0.0 {
                    continue;
                }
                let g = self.brdf(inc, &r) * r.z;
                ring += g;
                ring_proj += r.z;
                if j % 2 == 0 {
                    ring_half += g;
                }
            }
            let s = sb * dpsi;
            k_rho += wk * ring * s;
            g_rho += wg * ring * s;
            half_rho += wk * ring_half * 2.0 * s;
            proj += wk * ring_proj * s;
        }
        let error = (k_rho - g_rho).abs() + (k_rho - half_rho).abs();
        (k_rho, proj, error)
    }
}
