//! The physics of the isotropic model: the ring of exit directions of one pixel normal
//! of polar angle `θ` as the sample turns about its normal (module docs of
//! [`super`], which define the response `h_j(θ) = (1/2π) ∫_0^{2π} F γ / cos θt ·
//! 1[k_out(θ, φ) ∈ cone j] dφ`), and a detector cone as the ring meets it.
//!
//! With `k1 = (sin θt, 0, −cos θt)`, `m = (sin θ cos φ, sin θ sin φ, cos θ)`,
//! `γ = −k1·m = cos θt cos θ − sin θt sin θ cos φ` and `k2 = k1 + 2γ m` (the plain
//! model's mirror, physics.md §5), the inside exit cosine is `k2.z = A − B cos φ` with
//! `A = cos θt cos 2θ`, `B = sin θt sin 2θ ≥ 0`. Rays escape exactly where `k2.z > κ`,
//! `κ = sqrt(1 − 1/n²)` (otherwise they are totally internally reflected, `0 < k2.z ≤ κ`,
//! or head down, `k2.z ≤ 0`): one arc `cos φ < (A − κ)/B` symmetric about `φ = π`, whose
//! ends exit at the horizon ([`Ring::arc`]). The lost fractions of the ring are
//! therefore closed forms, `P(k2.z ≤ x) = acos((A − x)/B)/π` ([`Ring::fraction_below`]).
//! On the arc the exit direction is `k_out = (n k2.x, n k2.y, sqrt(1 − n²(k2.x² +
//! k2.y²)))`, with its derivative in `φ` in closed form ([`Ring::at`]); a cone of axis
//! `r` and half-angle `α` holds it where `f(φ) = k_out·r − cos α > 0` ([`Axis`]).
//!
//! How the response is computed from these (sampling, roots, quadrature) is in
//! `response.rs` and `search.rs`.

use std::f64::consts::PI;
use std::f64::consts::TAU;

use flakescatter_optics::detector::Cone;

/// One point of a ring: exit direction, its azimuth derivative, obliquity, `k2.z`.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct RingPoint {
    pub(crate) o: [f64; 3],
    pub(crate) d: [f64; 3],
    pub(crate) gamma: f64,
    pub(crate) k2z: f64,
}

/// The ring of one node `θ` at one incidence.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ring {
    pub(crate) n: f64,
    pub(crate) st: f64,
    pub(crate) ct: f64,
    pub(crate) s: f64,
    pub(crate) c: f64,
}

/// Which azimuths escape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Arc {
    None,
    Full,
    Range(f64, f64),
}

impl Ring {
    pub(crate) fn new(n: f64, st: f64, ct: f64, theta: f64) -> Self {
        let (s, c) = theta.sin_cos();
        Self { n, st, ct, s, c }
    }

    /// `A`, `B` of `k2.z = A − B cos φ`.
    pub(crate) fn ab(&self) -> (f64, f64) {
        let cos2 = self.c * self.c - self.s * self.s;
        let sin2 = 2.0 * self.s * self.c;
        (self.ct * cos2, (self.st * sin2).max(0.0))
    }

    /// Fraction of `φ ∈ [0, 2π)` with `k2.z ≤ x`.
    pub(crate) fn fraction_below(&self, x: f64) -> f64 {
        let (a, b) = self.ab();
        if b <= 0.0 {
            return if a <= x { 1.0 } else { 0.0 };
        }
        ((a - x) / b).clamp(-1.0, 1.0).acos() / PI
    }

    /// The escaping arc `k2.z > κ`.
    pub(crate) fn arc(&self, kappa: f64) -> Arc {
        let (a, b) = self.ab();
        if b <= 0.0 {
            return if a > kappa { Arc::Full } else { Arc::None };
        }
        let q = (a - kappa) / b;
        if q >= 1.0 {
            Arc::Full
        } else if q <= -1.0 {
            Arc::None
        } else {
            let lo = q.acos();
            if lo >= PI {
                Arc::None
            } else {
                Arc::Range(lo, TAU - lo)
            }
        }
    }

    /// The ray at azimuth `phi` (extended continuously to the horizon beyond the arc).
    #[inline]
    pub(crate) fn at(&self, phi: f64) -> RingPoint {
        let (sp, cp) = phi.sin_cos();
        let (n, s, c, st, ct) = (self.n, self.s, self.c, self.st, self.ct);
        let (mx, my) = (s * cp, s * sp);
        let gamma = ct * c - st * mx;
        let dgamma = st * s * sp;
        let (k2x, k2y, k2z) = (
            st + 2.0 * gamma * mx,
            2.0 * gamma * my,
            -ct + 2.0 * gamma * c,
        );
        let dk2x = 2.0 * (dgamma * mx - gamma * my);
        let dk2y = 2.0 * (dgamma * my + gamma * mx);
        let (ox, oy) = (n * k2x, n * k2y);
        let (dox, doy) = (n * dk2x, n * dk2y);
        let oz = (1.0 - ox * ox - oy * oy).max(0.0).sqrt();
        let doz = if oz > 0.0 {
            -(ox * dox + oy * doy) / oz
        } else {
            0.0
        };
        RingPoint {
            o: [ox, oy, oz],
            d: [dox, doy, doz],
            gamma,
            k2z,
        }
    }
}

/// One detector as the ring search needs it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Axis {
    pub(crate) a: [f64; 3],
    pub(crate) cos_alpha: f64,
    pub(crate) alpha: f64,
}

impl Axis {
    pub(crate) fn new(c: &Cone) -> Self {
        Self {
            a: [c.axis().x, c.axis().y, c.axis().z],
            cos_alpha: c.cos_half_angle(),
            alpha: c.half_angle(),
        }
    }

    /// Angle between the axis and the exit direction of `p`.
    #[inline]
    pub(crate) fn angle(&self, p: &RingPoint) -> f64 {
        (self.f(p) + self.cos_alpha).clamp(-1.0, 1.0).acos()
    }

    /// Arc length of the step from `p` to `q`, bounded above by 1.05 × the chord's
    /// angle (steps are short against the ring's curvature).
    #[inline]
    pub(crate) fn step_length(p: &RingPoint, q: &RingPoint) -> f64 {
        let d = [q.o[0] - p.o[0], q.o[1] - p.o[1], q.o[2] - p.o[2]];
        let chord = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        1.05 * 2.0 * (0.5 * chord).min(1.0).asin()
    }

    /// Whether the step from `p` to `q` (both outside) can come within `α` of the axis.
    pub(crate) fn may_enter(&self, p: &RingPoint, q: &RingPoint) -> bool {
        0.5 * (self.angle(p) + self.angle(q) - Self::step_length(p, q)) < self.alpha
    }

    /// Whether the step from `p` to `q` (both inside) can go beyond `α` from the axis.
    pub(crate) fn may_leave(&self, p: &RingPoint, q: &RingPoint) -> bool {
        0.5 * (self.angle(p) + self.angle(q) + Self::step_length(p, q)) > self.alpha
    }

    #[inline]
    pub(crate) fn f(&self, p: &RingPoint) -> f64 {
        self.a[0] * p.o[0] + self.a[1] * p.o[1] + self.a[2] * p.o[2] - self.cos_alpha
    }

    #[inline]
    pub(crate) fn df(&self, p: &RingPoint) -> f64 {
        self.a[0] * p.d[0] + self.a[1] * p.d[1] + self.a[2] * p.d[2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic azimuth derivative of the exit direction against central
    /// differences.
    #[test]
    fn ring_derivative_matches_finite_differences() {
        for (ti, theta) in [(0.3f64, 0.05f64), (0.9, 0.2), (0.0, 0.1), (1.2, 0.02)] {
            let st = ti.sin() / 1.5;
            let ring = Ring::new(1.5, st, (1.0 - st * st).sqrt(), theta);
            for k in 0..12 {
                let phi = 0.1 + 0.5 * f64::from(k);
                let p = ring.at(phi);
                if p.o[2] < 0.05 {
                    continue;
                }
                let e = 1e-6;
                let (a, b) = (ring.at(phi + e), ring.at(phi - e));
                for c in 0..3 {
                    let fd = (a.o[c] - b.o[c]) / (2.0 * e);
                    assert!((fd - p.d[c]).abs() < 1e-7, "{ti} {theta} {phi} {c}");
                }
            }
        }
    }

    /// The closed-form lost fractions against counting a fine azimuth grid.
    #[test]
    fn lost_fractions_match_counting() {
        let n: f64 = 1.5;
        let kappa = (1.0 - 1.0 / (n * n)).sqrt();
        for (ti, theta) in [(1.2f64, 0.4f64), (0.5, 0.5), (1.4, 0.1), (0.8, 0.9)] {
            let st = ti.sin() / n;
            let ring = Ring::new(n, st, (1.0 - st * st).sqrt(), theta);
            let m = 200_000;
            let (mut down, mut tir) = (0usize, 0usize);
            for i in 0..m {
                let p = ring.at((i as f64 + 0.5) / m as f64 * TAU);
                let s2 = p.o[0] * p.o[0] + p.o[1] * p.o[1];
                if p.k2z <= 0.0 || p.gamma <= 0.0 {
                    down += 1;
                } else if s2 >= 1.0 {
                    tir += 1;
                }
            }
            let d = ring.fraction_below(0.0);
            let t = ring.fraction_below(kappa) - d;
            assert!(
                (down as f64 / m as f64 - d).abs() < 1e-4,
                "down {ti} {theta}"
            );
            assert!((tir as f64 / m as f64 - t).abs() < 1e-4, "tir {ti} {theta}");
        }
    }
}
