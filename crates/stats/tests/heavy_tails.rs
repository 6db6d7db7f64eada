//! The heavy-tailed (Pearson VII, Trowbridge–Reitz) and log-linear orientation families
//! against closed forms and independent integrals.

mod common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::{chi_square, chi_square_critical, simpson};
use flakescatter_stats::distribution::{DistributionError, Orientation};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// `∫ D dΩ` of Trowbridge–Reitz in closed form. With `x = cos θ`,
/// `cos⁴θ (α² + tan²θ)² = (1 − β x²)²`, `β = 1 − α²`, so
/// `∫ D dΩ = 2α² ∫_0^1 dx/(1 − βx²)² = 2α² [x/(2(1 − βx²)) + atanh(√β x)/(2√β)]_0^1
///        = 1 + α² atanh(√β)/√β` (α < 1).
fn ggx_area(alpha: f64) -> f64 {
    let b = 1.0 - alpha * alpha;
    1.0 + alpha * alpha * b.sqrt().atanh() / b.sqrt()
}

#[test]
fn trowbridge_reitz_mean_cos_is_the_closed_form() {
    for alpha in [0.01, 0.05, 0.2, 0.5, 0.9] {
        let d = Orientation::trowbridge_reitz(alpha).unwrap();
        let want = 1.0 / ggx_area(alpha);
        assert!(
            (d.mean_cos() - want).abs() < 1e-12 * want,
            "alpha {alpha}: {} vs {want}",
            d.mean_cos()
        );
        // D itself: α²/(π cos⁴θ (α² + tan²θ)²).
        for deg in [0.0, 1.0, 7.0, 30.0, 60.0, 85.0] {
            let t = f64::to_radians(deg);
            let ggx = alpha * alpha
                / (PI * t.cos().powi(4) * (alpha * alpha + t.tan() * t.tan()).powi(2));
            let got = d.macro_density(t);
            assert!((got - ggx).abs() < 1e-12 * ggx, "{deg}°: {got} vs {ggx}");
        }
    }
}

/// `∫_lo^hi g(θ) sin θ dθ` as an independent Simpson integral in `x = cos θ = y^m`,
/// `m = 2/(2γ − 1)` (at least 1): `D(θ) ~ x^(2γ−2)` at the horizon, so that
/// `D dx = D m y^(m−1) dy ~ y` is smooth in `y` for every `γ > 1/2`.
fn in_cos(g: &dyn Fn(f64) -> f64, shape: f64, lo: f64, hi: f64) -> f64 {
    let m = (2.0 / (2.0 * shape - 1.0)).max(1.0);
    let (ya, yb) = (hi.cos().max(0.0).powf(1.0 / m), lo.cos().powf(1.0 / m));
    let f = |y: f64| {
        let x = y.powf(m);
        g(x.clamp(0.0, 1.0).acos()) * m * y.powf(m - 1.0)
    };
    // A fine grid near the normal (y → 1), where a narrow peak lives.
    let split = ya.max((0.6f64).cos().powf(1.0 / m)).min(yb);
    simpson(f, ya, split, 200_000) + simpson(f, split, yb, 200_000)
}

/// The normalisations of physics.md §3 (`∫ D cos θ dΩ = 1`, `⟨cos θn⟩ = 1/∫ D dΩ`,
/// `∫ p2 dΩ = 1`) and band masses, as independent integrals ([`in_cos`]).
#[test]
fn pearson_normalisations_against_simpson() {
    for (alpha, shape) in [(0.05, 1.0), (0.2, 1.0), (0.1, 2.5), (0.3, 8.0), (0.08, 0.7)] {
        let d = Orientation::pearson_vii(alpha, shape).unwrap();
        let int = |g: &dyn Fn(f64) -> f64| 2.0 * PI * in_cos(g, shape, 0.0, FRAC_PI_2);
        let int_dcos = int(&|t: f64| d.macro_density(t) * t.cos());
        assert!(
            (int_dcos - 1.0).abs() < 1e-9,
            "({alpha}, {shape}): ∫D cos = {int_dcos}"
        );
        // Below γ = 1 the Simpson reference loses digits at the horizon (cos θ of
        // acos(x) for x → 0); there the 30-digit values below are the reference.
        let tol = if shape >= 1.0 { 1e-9 } else { 1e-7 };
        let int_d = int(&|t: f64| d.macro_density(t));
        assert!(
            (d.mean_cos() - 1.0 / int_d).abs() < tol,
            "({alpha}, {shape}): mean cos {} vs {}",
            d.mean_cos(),
            1.0 / int_d
        );
        let int_p2 = int(&|t: f64| d.p2(t));
        assert!(
            (int_p2 - 1.0).abs() < tol,
            "({alpha}, {shape}): ∫p2 = {int_p2}"
        );
        for (lo, hi) in [
            (0.0, alpha.atan()),
            (alpha.atan() * 0.5, alpha.atan() * 3.0),
            (1.0, FRAC_PI_2),
        ] {
            let band = 2.0 * PI * in_cos(&|t: f64| d.p2(t), shape, lo, hi);
            assert!(
                (d.mass_between(lo, hi) - band).abs() < tol,
                "({alpha}, {shape}) [{lo}, {hi}]: {} vs {band}",
                d.mass_between(lo, hi)
            );
        }
        assert!((d.mass_between(0.0, FRAC_PI_2) - 1.0).abs() < 1e-12);
    }
}

/// `∫ D dΩ` from mpmath at 30 digits (rounded to 17 here), in slope space (an independent implementation):
/// `E[sqrt(1 + s²)] = ∫_0^∞ 2s (1 + s²/(γα²))^(−(γ+1)) sqrt(1 + s²) ds / α²`, with
/// `mpmath.quad` split at `α, 10α, 1, 10, 100, 1e4`; the same integral without the
/// square root is 1 to all digits.
#[test]
fn pearson_flake_area_against_mpmath() {
    for (alpha, shape, area) in [
        (0.05, 1.0, 1.009_232_182_117_722_6),
        (0.2, 1.0, 1.093_588_131_010_357),
        (0.1, 2.5, 1.008_178_003_016_878_6),
        (0.3, 8.0, 1.048_828_091_912_936_4),
        (0.08, 0.7, 1.080_518_107_555_856_4),
    ] {
        let d = Orientation::pearson_vii(alpha, shape).unwrap();
        let got = 1.0 / d.mean_cos();
        assert!(
            (got - area).abs() < 1e-12,
            "({alpha}, {shape}): {got} vs {area}"
        );
    }
}

#[test]
fn pearson_tends_to_beckmann_at_large_shape() {
    // (1 + x/γ)^(−(γ+1)) → e^(−x): Beckmann D = exp(−tan²θ/α²)/(π α² cos⁴θ). The
    // relative difference is about x²/(2γ) − x at x = tan²θ/α² ≤ 4: below 2e-3 at γ = 1e4.
    let alpha = 0.2;
    let d = Orientation::pearson_vii(alpha, 1e4).unwrap();
    for deg in [0.0, 3.0, 8.0, 15.0, 21.0] {
        let t = f64::to_radians(deg);
        let b = (-(t.tan() / alpha).powi(2)).exp() / (PI * alpha * alpha * t.cos().powi(4));
        let got = d.macro_density(t);
        assert!((got / b - 1.0).abs() < 2e-3, "{deg}°: {got} vs {b}");
    }
}

#[test]
fn heavy_tail_sampling_chi_square() {
    for (k, (alpha, shape)) in [(0.1, 1.0), (0.05, 3.0), (0.2, 0.7)]
        .into_iter()
        .enumerate()
    {
        let d = Orientation::pearson_vii(alpha, shape).unwrap();
        let mass = |lo: f64, hi: f64| 2.0 * PI * in_cos(&|t: f64| d.p2(t), shape, lo, hi);
        chi_square_sampling(&d, (6.0 * alpha).atan(), 40, 21 + k as u64, &mass);
    }
}

#[test]
fn log_linear_normalisation_against_the_closed_form() {
    // ∫ e^(a+bθ) sin θ dθ = e^(a+bθ)(b sin θ − cos θ)/(1 + b²), segment by segment.
    let knots: Vec<f64> = [0.0, 2.0, 5.0, 11.0, 20.0, 40.0, 75.0]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect();
    let ln_p = vec![3.0, 2.7, 1.0, -0.5, -3.0, -6.0, -12.0];
    let d = Orientation::log_linear(knots.clone(), ln_p.clone()).unwrap();
    let anti = |a: f64, b: f64, t: f64| (a + b * t).exp() * (b * t.sin() - t.cos()) / (1.0 + b * b);
    let anti_cos = |a: f64, b: f64, t: f64| {
        0.5 * (a + b * t).exp() * (b * (2.0 * t).sin() - 2.0 * (2.0 * t).cos()) / (b * b + 4.0)
    };
    let (mut z, mut zc) = (0.0, 0.0);
    for j in 0..knots.len() - 1 {
        let b = (ln_p[j + 1] - ln_p[j]) / (knots[j + 1] - knots[j]);
        let a = ln_p[j] - b * knots[j];
        z += anti(a, b, knots[j + 1]) - anti(a, b, knots[j]);
        zc += anti_cos(a, b, knots[j + 1]) - anti_cos(a, b, knots[j]);
    }
    // p̃(θ) = exp(ln p(θ))/z.
    for deg in [0.0, 1.0, 3.5, 10.0, 33.0, 74.0] {
        let t = f64::to_radians(deg);
        let j = knots.partition_point(|&k| k <= t) - 1;
        let l = ln_p[j] + (ln_p[j + 1] - ln_p[j]) * (t - knots[j]) / (knots[j + 1] - knots[j]);
        let want = l.exp() / z;
        assert!((d.p_tilde(t) - want).abs() < 1e-12 * want, "{deg}°");
    }
    assert!((d.mean_cos() - zc / z).abs() < 1e-13);
    assert_eq!(d.p2(76f64.to_radians()), 0.0);
    // A band's mass from the antiderivative.
    let (lo, hi) = (3f64.to_radians(), 15f64.to_radians());
    let mut band = 0.0;
    for j in 0..knots.len() - 1 {
        let (ka, kb) = (knots[j].max(lo), knots[j + 1].min(hi));
        if kb > ka {
            let b = (ln_p[j + 1] - ln_p[j]) / (knots[j + 1] - knots[j]);
            let a = ln_p[j] - b * knots[j];
            band += anti(a, b, kb) - anti(a, b, ka);
        }
    }
    assert!((d.mass_between(lo, hi) - band / z).abs() < 1e-12);
    let mass = |lo: f64, hi: f64| simpson(|t| d.p(t), lo, hi, 20_000);
    chi_square_sampling(&d, 40f64.to_radians(), 50, 31, &mass);
}

#[test]
fn bad_parameters_are_refused() {
    for (a, g) in [
        (0.0, 1.0),
        (f64::NAN, 1.0),
        (0.1, 0.5),
        (0.1, f64::INFINITY),
        (200.0, 1.0),
    ] {
        assert!(matches!(
            Orientation::pearson_vii(a, g),
            Err(DistributionError::BadPearson { .. })
        ));
    }
    let k = |v: &[f64]| v.iter().map(|d| d.to_radians()).collect::<Vec<_>>();
    for (knots, vals) in [
        (k(&[0.0]), vec![1.0]),
        (k(&[1.0, 5.0]), vec![1.0, 0.0]),
        (k(&[0.0, 5.0, 5.0]), vec![1.0, 0.0, -1.0]),
        (k(&[0.0, 95.0]), vec![1.0, 0.0]),
        (k(&[0.0, 5.0]), vec![1.0, f64::NAN]),
        (k(&[0.0, 5.0]), vec![1.0]),
    ] {
        let e = Orientation::log_linear(knots, vals).unwrap_err();
        assert!(matches!(e, DistributionError::BadKnots(_)), "{e}");
    }
}

/// Chi-square of `sample_normal` against `p` (as in tests/distribution.rs): equal θ
/// cells up to `theta_max` (the last takes the rest), expected counts from `mass`, an
/// independent integral of `p` over a band.
fn chi_square_sampling(
    d: &Orientation,
    theta_max: f64,
    n_theta: usize,
    seed: u64,
    mass: &dyn Fn(f64, f64) -> f64,
) {
    let n = 40_000;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut observed = vec![0.0; n_theta];
    for _ in 0..n {
        let m = d.sample_normal(&mut rng);
        assert!(m.z >= 0.0 && (m.norm() - 1.0).abs() < 1e-12);
        let theta = m.z.clamp(-1.0, 1.0).acos();
        observed[((theta / theta_max * n_theta as f64) as usize).min(n_theta - 1)] += 1.0;
    }
    let h = theta_max / n_theta as f64;
    let expected: Vec<f64> = (0..n_theta)
        .map(|i| {
            let hi = if i == n_theta - 1 {
                FRAC_PI_2
            } else {
                (i + 1) as f64 * h
            };
            n as f64 * mass(i as f64 * h, hi)
        })
        .collect();
    let (stat, df) = chi_square(&observed, &expected);
    let crit = chi_square_critical(df, 1e-3);
    assert!(stat < crit, "chi2 = {stat} > {crit} (df {df})");
}
