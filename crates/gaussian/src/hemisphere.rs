//! Hemispherical totals, computed two independent ways (physics.md §4, "Conservation").
//!
//! * **Detector space**: `∫ f(θi, r) cos θr dΩr` over the upper hemisphere, in polar
//!   coordinates `(β, ψ)` about the specular direction (`β` from it, `ψ = 0` toward the
//!   surface normal), up to the horizon `β_h(ψ) = atan2(cos θi, −sin θi cos ψ)`.
//! * **Normal space**: `∫ F R D(m) γ / cos θt dΩm` over the flake normals whose rays
//!   escape (`γ > 0`, `k2.z > 0`, no total internal reflection), in polar coordinates
//!   `(θn, φn)` about `z`, split exactly at the boundaries `γ = 0` and
//!   `k2.z = sqrt(1 − 1/n²)` (found by bisection along each `φn`).
//!
//! The change of variables between them conserves probability, so the two must agree;
//! the normal-space side also returns the purely geometric integrals of `D γ / cos θt`
//! over the escaping, lost and back-lit normals, which obey the closed form
//! `escaping + lost − back = 1` (because `∫ D m dΩ = ẑ` for an isotropic distribution,
//! so `∫ D γ dΩ = −k1·ẑ = cos θt`). Both use nested adaptive Gauss–Kronrod 15.
//! Both exploit the mirror symmetry `y → −y` of the in-plane incidence. The base under
//! transmitting flakes (physics.md §13) has its own total, [`base_total`].

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_optics::{UnitVec3, Vec3, reflection};

use crate::breaks::scale_breaks;
use crate::model::{DistributionModel, Incidence};
use crate::quad::adaptive;

/// Relative tolerance of the inner integrals.
const INNER_REL: f64 = 1e-11;
/// Relative tolerance of the outer integrals.
const OUTER_REL: f64 = 1e-10;
/// Panel budgets.
const INNER_PANELS: usize = 400;
const OUTER_PANELS: usize = 400;

/// Inner adaptive integral over `[0, hi]` with break points.
fn inner_integral(f: impl FnMut(f64) -> f64, hi: f64, breaks: &[f64]) -> f64 {
    adaptive(f, 0.0, hi, breaks, 1e-300, INNER_REL, INNER_PANELS).0
}

/// Outer integral over the azimuth `[0, π]`, doubled for the mirror half `[π, 2π]`
/// (`y → −y` symmetry); `(value, error)`.
fn over_both_halves(f: impl FnMut(f64) -> f64) -> (f64, f64) {
    let (val, err) = adaptive(f, 0.0, PI, &[FRAC_PI_2], 1e-300, OUTER_REL, OUTER_PANELS);
    (2.0 * val, 2.0 * err)
}

/// The hemispherical total in detector space, with its error estimate (fraction of the
/// incident beam; the clear coat is not included).
#[must_use]
pub fn total_detector_space(model: &DistributionModel, inc: &Incidence) -> (f64, f64) {
    // The peak about specular is at least this wide (cone module docs).
    let feature = model.exit_feature(inc);
    let (s, c) = inc.theta_i.sin_cos();
    let a = Vec3::new(s, 0.0, c);
    let u = Vec3::new(-c, 0.0, s);
    let v = Vec3::new(0.0, 1.0, 0.0);
    let outer = |psi: f64| {
        let (sp, cp) = psi.sin_cos();
        let horizon = c.atan2(-s * cp);
        let side = u * cp + v * sp;
        let inner = |beta: f64| {
            let (sb, cb) = beta.sin_cos();
            let r = a * cb + side * sb;
            model.brdf(inc, &r) * r.z.max(0.0) * sb
        };
        inner_integral(inner, horizon, &scale_breaks(horizon, feature, &[]))
    };
    over_both_halves(outer)
}

/// Normal-space integrals at one incidence (fractions of the beam, or dimensionless
/// for the geometric ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalSpaceTotals {
    /// `∫_escaping F R D γ / cos θt dΩm`: the power that leaves the coating.
    pub escaping_power: f64,
    /// `∫_escaping D γ / cos θt dΩm`.
    pub escaping: f64,
    /// `∫ D γ / cos θt dΩm` over lit normals (`γ > 0`) whose rays do not escape
    /// (`k2.z ≤ 0` or total internal reflection).
    pub lost: f64,
    /// `∫ D |γ| / cos θt dΩm` over normals lit from behind (`γ < 0`).
    pub back: f64,
    /// Error estimate of `escaping_power`.
    pub error: f64,
}

/// Which region a flake normal belongs to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Region {
    Escaping,
    Lost,
    Back,
}

/// The hemispherical integrals in normal space.
#[must_use]
pub fn totals_normal_space(model: &DistributionModel, inc: &Incidence) -> NormalSpaceTotals {
    let n = model.index();
    let k1 = UnitVec3::new_unchecked(inc.k1);
    // Escape needs n² (1 − k2.z²) < 1, i.e. k2.z > sqrt(1 − 1/n²) (which implies k2.z > 0).
    let cz = (1.0 - 1.0 / (n * n)).max(0.0).sqrt();
    let theta_max = model.orientation().max_theta().min(FRAC_PI_2);
    let feature = model.orientation().narrowest_feature();
    let edges = model.orientation().bin_edges().unwrap_or(&[]);
    let normal = |t: f64, p: f64| {
        let (st, ct) = t.sin_cos();
        let (sp, cp) = p.sin_cos();
        UnitVec3::new_unchecked(Vec3::new(st * cp, st * sp, ct))
    };
    let region = |m: &UnitVec3| {
        let gamma = -k1.dot(m);
        if gamma < 0.0 {
            return Region::Back;
        }
        let k2 = reflection::reflect(&k1, m);
        if k2.z > cz {
            Region::Escaping
        } else {
            Region::Lost
        }
    };
    let mut results = [0.0; 5];
    for (slot, which) in [(0usize, 0u8), (1, 1), (2, 2), (3, 3)] {
        let outer = |phi: f64| {
            // Boundaries along this meridian: sign changes of γ and of k2.z − cz.
            let mut breaks = scale_breaks(theta_max, feature, edges);
            let g = |t: f64| {
                let m = normal(t, phi);
                let gamma = -k1.dot(&m);
                let k2 = reflection::reflect(&k1, &m);
                (gamma, k2.z - cz)
            };
            let steps = 256;
            let mut prev = g(0.0);
            let mut t_prev = 0.0;
            for i in 1..=steps {
                let t = theta_max * i as f64 / steps as f64;
                let cur = g(t);
                for comp in 0..2 {
                    let (a, b) = if comp == 0 {
                        (prev.0, cur.0)
                    } else {
                        (prev.1, cur.1)
                    };
                    if (a > 0.0) != (b > 0.0) {
                        let (mut lo, mut hi) = (t_prev, t);
                        for _ in 0..80 {
                            let mid = 0.5 * (lo + hi);
                            let y = if comp == 0 { g(mid).0 } else { g(mid).1 };
                            if (y > 0.0) == (a > 0.0) {
                                lo = mid;
                            } else {
                                hi = mid;
                            }
                        }
                        breaks.push(0.5 * (lo + hi));
                    }
                }
                prev = cur;
                t_prev = t;
            }
            let inner = |t: f64| {
                let m = normal(t, phi);
                let st = t.sin();
                let d = model.orientation().p2(t) * model.inv_mean_cos();
                if d == 0.0 {
                    return 0.0;
                }
                let gamma = -k1.dot(&m);
                let r = region(&m);
                match which {
                    0 => model
                        .normal_space_weight(inc, &m)
                        .map_or(0.0, |(w, _)| w * st),
                    1 if r == Region::Escaping => d * gamma / inc.cos_t * st,
                    2 if r == Region::Lost => d * gamma / inc.cos_t * st,
                    3 if r == Region::Back => -d * gamma / inc.cos_t * st,
                    _ => 0.0,
                }
            };
            inner_integral(inner, theta_max, &breaks)
        };
        let (val, err) = over_both_halves(outer);
        results[slot] = val;
        if slot == 0 {
            results[4] = err;
        }
    }
    NormalSpaceTotals {
        escaping_power: results[0],
        escaping: results[1],
        lost: results[2],
        back: results[3],
        error: results[4],
    }
}

/// The base term's hemispherical total `∫ f_base(θi, r) cos θr dΩr` (physics.md §13),
/// fraction of the incident beam, with its error estimate; 0 without a base. The base's
/// light does not depend on the exit azimuth, so the integral is `2π ∫ f cos θ sin θ dθ`
/// by adaptive Gauss–Kronrod 15.
#[must_use]
pub fn base_total(model: &DistributionModel, inc: &Incidence) -> (f64, f64) {
    let f = |theta: f64| {
        let (s, c) = theta.sin_cos();
        model.base_brdf(inc, &Vec3::new(s, 0.0, c)) * c * s
    };
    let (v, e) = adaptive(f, 0.0, FRAC_PI_2, &[], 1e-300, OUTER_REL, OUTER_PANELS);
    (2.0 * PI * v, 2.0 * PI * e)
}
