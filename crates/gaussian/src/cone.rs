//! What a detector cone collects (physics.md §4).
//!
//! Conventions: a detector is a [`Cone`] of half-angle `α` about its axis `r_j`. It
//! collects `ρ_j = ∫_cone f(θi, r) cos θr dΩr`, a fraction of the incident beam power.
//! The exact rule integrates in polar coordinates about the detector axis: angle
//! `β ∈ [0, α]` from the axis by Gauss–Kronrod, azimuth `ψ` about the axis by the
//! trapezoid rule (spectrally accurate for a periodic integrand). A light rule
//! (Kronrod 7 × 16 points) is tried first and kept when its error estimate is below
//! 1e-6 of the value; otherwise Kronrod 15 × 48 points is used. The error estimate is the
//! difference between the rule used and its embedded coarser rules (Gauss in `β`, half
//! the points in `ψ`): a bound on the coarse rules' error, so the reported error is
//! conservative. Directions below the horizon contribute nothing, also to the
//! projected solid angle. The paper's constant-integrand approximation is
//! `ρ_j ≈ f(r_j) cos θj ΔΩ` with `ΔΩ = 2π(1 − cos α)`.

use std::f64::consts::PI;

use flakescatter_optics::Vec3;
use flakescatter_optics::detector::{Cone, orthonormal_frame};

use crate::model::{DistributionModel, Incidence};
use crate::quad::{gk7_nodes, gk15_nodes};

/// How a detector's cone is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ConeMethod {
    /// The exact cone integral (GK15 × 48-point trapezoid, with an error estimate).
    #[default]
    Exact,
    /// The paper's constant-integrand approximation `f(r_j) cos θj ΔΩ`.
    ConstantIntegrand,
}

/// Relative error estimate up to which the light cone rule is accepted.
pub const LIGHT_RULE_TOLERANCE: f64 = 1e-6;

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
    ///
    /// First a light rule, Kronrod 7 in `β` × 16-point trapezoid in `ψ` (error from the
    /// embedded Gauss 3 and 8-point rules); when its error estimate exceeds
    /// [`LIGHT_RULE_TOLERANCE`] of the value, the full Kronrod 15 × 48 rule is used.
    fn cone_integral(&self, inc: &Incidence, cone: &Cone) -> (f64, f64, f64) {
        let light = self.cone_rule(inc, cone, &gk7_nodes(0.0, cone.half_angle()), 16);
        if light.2 <= LIGHT_RULE_TOLERANCE * light.0.abs() {
            return light;
        }
        self.cone_rule(inc, cone, &gk15_nodes(0.0, cone.half_angle()), 48)
    }

    /// One product rule: `nodes` (Kronrod nodes with Kronrod and Gauss weights) in `β`,
    /// `n_psi`-point trapezoid in `ψ`. In-plane detectors use the mirror symmetry
    /// `y → −y` of the problem (isotropic flakes, incidence in the xz-plane): only
    /// `ψ ∈ [0, π]` is evaluated, with the frame chosen so that `ψ → −ψ` is that mirror.
    fn cone_rule(
        &self,
        inc: &Incidence,
        cone: &Cone,
        nodes: &[(f64, f64, f64)],
        n_psi: usize,
    ) -> (f64, f64, f64) {
        let axis = cone.axis().into_inner();
        let in_plane = axis.y == 0.0;
        let (u, v) = if in_plane {
            // u in the plane of incidence, v = axis × u = ±y.
            let u = Vec3::new(axis.z, 0.0, -axis.x);
            (u, axis.cross(&u))
        } else {
            let (u, v) = orthonormal_frame(cone.axis());
            (u.into_inner(), v.into_inner())
        };
        // (sin ψ, cos ψ, weight in units of dψ) for the nodes evaluated.
        let psi: Vec<(f64, f64, f64, bool)> = (0..n_psi)
            .filter_map(|j| {
                let (sp, cp) = (2.0 * PI * j as f64 / n_psi as f64).sin_cos();
                let even = j % 2 == 0;
                if !in_plane || j == 0 || 2 * j == n_psi {
                    Some((sp, cp, 1.0, even))
                } else if 2 * j < n_psi {
                    Some((sp, cp, 2.0, even))
                } else {
                    None
                }
            })
            .collect();
        let dpsi = 2.0 * PI / n_psi as f64;
        let (mut k_rho, mut g_rho, mut half_rho, mut proj) = (0.0, 0.0, 0.0, 0.0);
        for &(beta, wk, wg) in nodes {
            let (sb, cb) = beta.sin_cos();
            let (mut ring, mut ring_half, mut ring_proj) = (0.0, 0.0, 0.0);
            for &(sp, cp, w, even) in &psi {
                let r: Vec3 = axis * cb + (u * cp + v * sp) * sb;
                if r.z <= 0.0 {
                    continue;
                }
                let g = w * self.brdf(inc, &r) * r.z;
                ring += g;
                ring_proj += w * r.z;
                if even {
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
