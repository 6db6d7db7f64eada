//! The flake layer's shadowing and masking of its own flakes (physics.md §12.1).
//!
//! Conventions: radians; directions inside the coat by their polar angle `θ` from the
//! coating normal (the inside angle of the incident ray `θt` or of the exit ray `θ2`);
//! the flakes' macro-area density `D = p2/⟨cos θn⟩`, `∫ D cos θn dΩ = 1`.
//!
//! The distribution model lets every flake catch the beam in proportion to its area
//! projected on the beam. Flakes tilted so far that the beam meets their backs carry no
//! light, but the ones facing the beam then catch more than the coating's area: per unit
//! area the flakes facing a direction at `θ` project `cos θ (1 + Λ(θ))`, with
//! `Λ(θ) = (1/cos θ) ∫ D(m) ⟨−ω·m⟩⁺ dΩm` (the back-facing share, Smith's Λ). A layer
//! intercepts only what reaches it, so each flake's share is scaled by Smith's
//! `G1(θ) = 1/(1 + Λ(θ))`, once for the incident and once for the exit direction
//! (uncorrelated). Then the flakes intercept exactly the light that reaches them, which
//! conserves energy for every distribution; for narrow ones (hwhm ≲ 10°) `Λ` is below
//! 1e-6 and the factor changes nothing. For Trowbridge–Reitz `Λ = (√(1 + α² tan²θ) − 1)/2`
//! (a test).
//!
//! With `ω = (sin θ, 0, cos θ)` and `m` at `(θm, φ)`, the azimuth integral of
//! `⟨−ω·m⟩⁺ = max(0, −(a cos φ + b))`, `a = sin θ sin θm`, `b = cos θ cos θm`, is
//! `2(a sin φ0 − b(π − φ0))`, `cos φ0 = −b/a`, when `a > b` (only `θm > π/2 − θ`) and 0
//! otherwise; the polar integral is adaptive Gauss–Kronrod.

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_numerics::quad::adaptive;
use flakescatter_stats::Orientation;

/// Nodes of the `Λ` table, equally spaced in `θ` up to the largest inside angle.
const NODES: usize = 33;

/// Gauss–Legendre points of the table's rule (see [`smith_lambda_rule`]).
const RULE_POINTS: usize = 48;

/// Smith's `Λ` of the flakes, tabulated over the inside angles light can have.
#[derive(Debug, Clone)]
pub struct FlakeShadowing {
    /// Largest tabulated angle, radians: the critical angle `asin(1/n)` (π/2 at `n = 1`,
    /// where the table stops just short of it).
    theta_max: f64,
    /// `Λ` at `θ_k = k θmax/(NODES − 1)`; empty when it is zero everywhere.
    lambda: Vec<f64>,
}

impl FlakeShadowing {
    /// The table for `orientation` under a coat of index `n ≥ 1`.
    #[must_use]
    pub fn new(orientation: &Orientation, n: f64) -> Self {
        let theta_max = if n > 1.0 {
            (1.0 / n).asin()
        } else {
            FRAC_PI_2 - 1e-3
        };
        // No normal beyond the support: Λ(θ) = 0 for θ ≤ π/2 − support end.
        if orientation.support_end() <= FRAC_PI_2 - theta_max {
            return Self {
                theta_max,
                lambda: Vec::new(),
            };
        }
        let lambda: Vec<f64> = (0..NODES)
            .map(|k| smith_lambda_rule(orientation, theta_max * k as f64 / (NODES - 1) as f64))
            .collect();
        if lambda.iter().all(|&l| l == 0.0) {
            return Self {
                theta_max,
                lambda: Vec::new(),
            };
        }
        Self { theta_max, lambda }
    }

    /// `Λ(θ)` from the table (linear in `θ`; clamped to the tabulated range).
    #[must_use]
    pub fn lambda(&self, theta: f64) -> f64 {
        if self.lambda.is_empty() {
            return 0.0;
        }
        let x = (theta / self.theta_max).clamp(0.0, 1.0) * (NODES - 1) as f64;
        let k = (x.floor() as usize).min(NODES - 2);
        let t = x - k as f64;
        self.lambda[k] + t * (self.lambda[k + 1] - self.lambda[k])
    }

    /// `G1(θ) = 1/(1 + Λ(θ))`.
    #[must_use]
    pub fn g1(&self, theta: f64) -> f64 {
        1.0 / (1.0 + self.lambda(theta))
    }
}

/// The integrand of `Λ(θ) cos θ` over the flake tilt `θm` (module docs), and its limits;
/// `None` when no flake faces away.
fn lambda_integrand(
    orientation: &Orientation,
    theta: f64,
) -> Option<(impl Fn(f64) -> f64 + '_, f64, f64)> {
    if theta <= 0.0 {
        return None;
    }
    let (st, ct) = theta.sin_cos();
    let lo = FRAC_PI_2 - theta;
    let hi = orientation.support_end().min(FRAC_PI_2);
    if hi <= lo {
        return None;
    }
    let inv_mean_cos = 1.0 / orientation.mean_cos();
    let f = move |tm: f64| {
        let (sm, cm) = tm.sin_cos();
        let a = st * sm;
        let b = ct * cm;
        if a <= b {
            return 0.0;
        }
        let phi0 = (-b / a).clamp(-1.0, 1.0).acos();
        let az = 2.0 * (a * phi0.sin() - b * (PI - phi0));
        orientation.p2(tm) * inv_mean_cos * sm * az
    };
    Some((f, lo, hi))
}

/// Smith's `Λ(θ)` of the flakes for a direction at polar angle `theta` (module docs), by
/// adaptive Gauss–Kronrod (relative tolerance 1e-10).
#[must_use]
pub fn smith_lambda(orientation: &Orientation, theta: f64) -> f64 {
    match lambda_integrand(orientation, theta) {
        Some((f, lo, hi)) => adaptive(f, lo, hi, &[], 1e-300, 1e-10, 400).0 / theta.cos(),
        None => 0.0,
    }
}

/// The same by a fixed rule, for the table: `RULE_POINTS`-point (48) Gauss–Legendre in `u`
/// with `θm = lo + (hi − lo)(3u² − 2u³)`, which gathers the nodes toward both ends: the
/// lower one, where the back-facing share starts like `(θm − lo)^(3/2)`, and the horizon,
/// where a heavy tail is largest. `G1 = 1/(1 + Λ)` from it agrees with the one from
/// [`smith_lambda`] to 5e-5 (a test; a Pearson VII tail with `γ < 1` is the worst case).
#[must_use]
pub fn smith_lambda_rule(orientation: &Orientation, theta: f64) -> f64 {
    let Some((f, lo, hi)) = lambda_integrand(orientation, theta) else {
        return 0.0;
    };
    let w = hi - lo;
    let total: f64 = flakescatter_numerics::legendre::cached_rule(RULE_POINTS)
        .iter()
        .map(|&(x, weight)| {
            let u = 0.5 * (x + 1.0);
            let s = u * u * (3.0 - 2.0 * u);
            weight * f(lo + w * s) * 6.0 * w * u * (1.0 - u)
        })
        .sum();
    0.5 * total / theta.cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trowbridge_reitz_lambda_is_the_closed_form() {
        for alpha in [0.05, 0.2, 0.6] {
            let o = Orientation::trowbridge_reitz(alpha).unwrap();
            for deg in [5.0, 20.0, 41.0, 60.0, 80.0] {
                let t = f64::to_radians(deg);
                let want = 0.5 * ((1.0 + alpha * alpha * t.tan().powi(2)).sqrt() - 1.0);
                let got = smith_lambda(&o, t);
                assert!(
                    (got - want).abs() < 1e-9 * want.max(1e-6),
                    "alpha {alpha}, {deg}°: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn the_tables_rule_agrees_with_the_adaptive_integral() {
        let knots: Vec<f64> = [0.0, 2.0, 6.0, 15.0, 30.0, 60.0, 90.0]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect();
        for o in [
            Orientation::trowbridge_reitz(0.3).unwrap(),
            Orientation::pearson_vii(0.1, 0.7).unwrap(),
            Orientation::pearson_vii(0.2, 4.0).unwrap(),
            Orientation::log_linear(knots, vec![0.0, -0.5, -2.0, -4.0, -7.0, -9.0, -12.0]).unwrap(),
        ] {
            for deg in [5.0, 20.0, 41.0] {
                let t = f64::to_radians(deg);
                let (a, b) = (smith_lambda(&o, t), smith_lambda_rule(&o, t));
                // What matters is G1 = 1/(1 + Λ): Λ to 5e-5 of 1 + Λ.
                assert!((a - b).abs() <= 5e-5 * (1.0 + a), "{deg}°: {a} vs {b}");
            }
        }
    }

    #[test]
    fn narrow_distributions_do_not_shadow() {
        let o = Orientation::gaussian(flakescatter_stats::GaussianWidth::Hwhm(5f64.to_radians()))
            .unwrap();
        let s = FlakeShadowing::new(&o, 1.5);
        assert!(s.lambda(0.7) < 1e-12);
        assert_eq!(s.g1(0.0), 1.0);
    }
}
