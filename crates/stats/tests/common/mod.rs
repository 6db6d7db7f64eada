//! Independent numerical helpers for the tests (not shared with the library code).

#![allow(dead_code)]

/// Composite Simpson rule with `n` (even) intervals: an integrator independent of the
/// library's Gauss–Legendre rule.
pub fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    assert!(n.is_multiple_of(2));
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        let x = a + i as f64 * h;
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(x);
    }
    s * h / 3.0
}

/// Pearson chi-square statistic over cells with expected counts, pooling adjacent cells
/// until each pooled cell expects at least 5. Returns `(statistic, degrees of freedom)`.
pub fn chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize) {
    let mut pooled = Vec::new();
    let (mut o, mut e) = (0.0, 0.0);
    for (oi, ei) in observed.iter().zip(expected) {
        o += oi;
        e += ei;
        if e >= 5.0 {
            pooled.push((o, e));
            o = 0.0;
            e = 0.0;
        }
    }
    if e > 0.0 || o > 0.0 {
        if let Some(last) = pooled.last_mut() {
            last.0 += o;
            last.1 += e;
        } else {
            pooled.push((o, e));
        }
    }
    let stat = pooled.iter().map(|(o, e)| (o - e) * (o - e) / e).sum();
    (stat, pooled.len() - 1)
}

/// Upper `1 - alpha` quantile of the chi-square distribution (statrs).
pub fn chi_square_critical(df: usize, alpha: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    ChiSquared::new(df as f64).unwrap().inverse_cdf(1.0 - alpha)
}
