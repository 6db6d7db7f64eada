//! Composite 16-point Gauss–Legendre quadrature on equal panels.
//!
//! Used for the exact normalisations of the orientation distributions: on their smooth
//! integrands (Gaussians times `sin`/`cos`, panel widths below half a standard
//! deviation) the result is exact to rounding.

use std::sync::OnceLock;

/// Number of nodes of the rule.
const N: usize = 16;

/// Nodes on `[-1, 1]` and weights of the `n`-point Gauss–Legendre rule (`n ≥ 1`), by
/// Newton iteration on the Legendre polynomial `P_n` from Tricomi's initial guesses.
/// Exact for polynomials of degree `2n − 1`.
#[must_use]
pub fn rule(n: usize) -> Vec<(f64, f64)> {
    let nf = n as f64;
    (0..n)
        .map(|i| {
            // Tricomi's initial guess for the i-th root, then Newton.
            let mut t = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, t);
                for k in 2..=n {
                    let k = k as f64;
                    let p2 = ((2.0 * k - 1.0) * t * p1 - (k - 1.0) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                // P_n'(t) from the standard identity.
                dp = nf * (t * p1 - p0) / (t * t - 1.0);
                let dt = p1 / dp;
                t -= dt;
                if dt.abs() < 1e-16 {
                    break;
                }
            }
            (t, 2.0 / ((1.0 - t * t) * dp * dp))
        })
        .collect()
}

/// The `n`-point rule of [`rule`] for `n ≤ 64`, computed once per `n` (for callers that
/// apply a rule many times).
///
/// # Panics
/// If `n` is 0 or above 64.
#[must_use]
pub fn cached_rule(n: usize) -> &'static [(f64, f64)] {
    static RULES: [OnceLock<Vec<(f64, f64)>>; 64] = [const { OnceLock::new() }; 64];
    assert!(
        (1..=64).contains(&n),
        "cached Gauss-Legendre rules have 1 to 64 points"
    );
    RULES[n - 1].get_or_init(|| rule(n))
}

/// The `N`-point rule of [`integrate`], computed once.
fn rule16() -> &'static [(f64, f64)] {
    static RULE: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    RULE.get_or_init(|| rule(N))
}

/// `∫_a^b f` with the 16-point rule on `panels` equal panels (at least one).
///
/// Exact for polynomials of degree 31 on each panel.
pub fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let nodes = rule16();
    let h = (b - a) / panels as f64;
    let mut total = 0.0;
    for p in 0..panels {
        let mid = a + (p as f64 + 0.5) * h;
        let half = 0.5 * h;
        let mut s = 0.0;
        for (xi, wi) in nodes {
            s += wi * f(mid + half * xi);
        }
        total += s * half;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_integrate_their_degree_exactly() {
        for n in [1, 2, 5, 24, 40] {
            let r = rule(n);
            // ∫_{-1}^{1} x^(2n−2) dx = 2/(2n − 1) (the highest even degree it must get).
            let k = 2 * n - 2;
            let v: f64 = r.iter().map(|(x, w)| w * x.powi(k as i32)).sum();
            assert!((v - 2.0 / (k as f64 + 1.0)).abs() < 1e-14, "n {n}: {v}");
            let wsum: f64 = r.iter().map(|p| p.1).sum();
            assert!((wsum - 2.0).abs() < 1e-14);
        }
    }

    #[test]
    fn integrates_known_closed_forms() {
        // ∫_0^π sin = 2; ∫_0^1 x^31 = 1/32 (degree 31 is the highest a 16-point rule
        // integrates exactly on one panel).
        assert!((integrate(f64::sin, 0.0, std::f64::consts::PI, 4) - 2.0).abs() < 1e-15);
        assert!((integrate(|x| x.powi(31), 0.0, 1.0, 1) - 1.0 / 32.0).abs() < 1e-15);
        // ∫_0^∞ exp(-x²/2) = sqrt(π/2), truncated at 12 (tail < 1e-31).
        let g = integrate(|x| (-0.5 * x * x).exp(), 0.0, 12.0, 32);
        assert!((g - (std::f64::consts::PI / 2.0).sqrt()).abs() < 1e-15);
    }
}
