//! Normalisations, widths and sampling of the orientation distributions.

mod common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::{chi_square, chi_square_critical, simpson};
use flakescatter_stats::distribution::{DistributionError, GaussianWidth, Orientation};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn gaussians() -> Vec<Orientation> {
    [
        GaussianWidth::Hwhm(3f64.to_radians()),
        GaussianWidth::Hwhm(10f64.to_radians()),
        GaussianWidth::Sigma(0.02),
        // Wide enough that the truncation at π/2 matters.
        GaussianWidth::RmsTilt(1.2),
    ]
    .into_iter()
    .map(|w| Orientation::gaussian(w).unwrap())
    .collect()
}

fn table() -> Orientation {
    let edges: Vec<f64> = [0.0, 1.0, 2.0, 4.0, 7.0, 12.0]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect();
    Orientation::tabulated(edges, vec![0.5, 2.0, 3.0, 1.0, 0.5]).unwrap()
}

#[test]
fn gaussian_normalisations_against_simpson() {
    // Independent integrals: Simpson with 2·10⁵ intervals on [0, π/2).
    for d in gaussians() {
        let n = 200_000;
        let int_p = simpson(|t| d.p(t), 0.0, FRAC_PI_2 - 1e-15, n);
        // ∫ p2 dΩ written out as ∫∫ p2 sin θ dθ dφ with the φ integral done (2π).
        let int_p2 = simpson(|t| 2.0 * PI * d.p2(t) * t.sin(), 0.0, FRAC_PI_2 - 1e-15, n);
        let int_pt = simpson(|t| d.p_tilde(t) * t.sin(), 0.0, FRAC_PI_2 - 1e-15, n);
        let mean_cos = simpson(|t| d.p(t) * t.cos(), 0.0, FRAC_PI_2 - 1e-15, n);
        let int_d = simpson(
            |t| 2.0 * PI * d.macro_density(t) * t.cos() * t.sin(),
            0.0,
            FRAC_PI_2 - 1e-15,
            n,
        );
        for v in [int_p, int_p2, int_pt, int_d] {
            assert!((v - 1.0).abs() < 1e-9, "{v} for {:?}", d.gaussian_width());
        }
        assert!((d.mean_cos() - mean_cos).abs() < 1e-10);
    }
}

#[test]
fn gaussian_small_width_limit() {
    // For s → 0 the truncation and the curvature of sin vanish: ∫_0^∞ e^{-θ²/2s²} θ dθ
    // = s², so p̃(0) → 1/s² with relative correction +s²/3 (sin θ ≈ θ − θ³/6 gives
    // ∫ e^{..} sin θ dθ ≈ s² − s⁴/3). And ⟨cos θ⟩ ≈ 1 − ⟨θ²⟩/2 = 1 − s² (Rayleigh).
    let s: f64 = 0.01;
    let d = Orientation::gaussian(GaussianWidth::Sigma(s)).unwrap();
    let expected = 1.0 / (s * s * (1.0 - s * s / 3.0));
    assert!((d.p_tilde(0.0) / expected - 1.0).abs() < 1e-8);
    assert!((d.mean_cos() - (1.0 - s * s)).abs() < 1e-7);
}

#[test]
fn width_forms_agree() {
    // One shape, three names: w = s·sqrt(2 ln 2), σt = s·√2.
    let s: f64 = 0.07;
    let w = s * (2.0 * 2f64.ln()).sqrt();
    let t = s * 2f64.sqrt();
    let a = Orientation::gaussian(GaussianWidth::Sigma(s)).unwrap();
    let b = Orientation::gaussian(GaussianWidth::Hwhm(w)).unwrap();
    let c = Orientation::gaussian(GaussianWidth::RmsTilt(t)).unwrap();
    for theta in [0.0, 0.03, 0.1, 0.2] {
        assert!((a.p2(theta) / b.p2(theta) - 1.0).abs() < 1e-12);
        assert!((a.p2(theta) / c.p2(theta) - 1.0).abs() < 1e-12);
    }
    // Half maximum at w, 1/e at σt, e^{-1/2} at s.
    assert!((b.p_tilde(w) / b.p_tilde(0.0) - 0.5).abs() < 1e-12);
    assert!((c.p_tilde(t) / c.p_tilde(0.0) - (-1f64).exp()).abs() < 1e-12);
    assert!((a.p_tilde(s) / a.p_tilde(0.0) - (-0.5f64).exp()).abs() < 1e-12);
    assert!((GaussianWidth::Hwhm(w).sigma() - s).abs() < 1e-15);
    assert!((GaussianWidth::RmsTilt(t).hwhm() - w).abs() < 1e-15);
    // Zero beyond the support.
    assert_eq!(a.p2(FRAC_PI_2), 0.0);
    assert_eq!(a.p2(-0.1), 0.0);
}

#[test]
fn tabulated_values_by_hand() {
    let d = table();
    // Masses 0.5, 2, 3, 1, 0.5 renormalise to /7. Bin 2 (2°..4°):
    // p2 = (3/7) / (2π (cos 2° − cos 4°)).
    let (lo, hi) = (2f64.to_radians(), 4f64.to_radians());
    let expected = (3.0 / 7.0) / (2.0 * PI * (lo.cos() - hi.cos()));
    // The difference of cosines (0.0018) carries ~1e-16/0.0018 ≈ 6e-14 of rounding.
    assert!((d.p2(3f64.to_radians()) / expected - 1.0).abs() < 3e-13);
    assert_eq!(d.p2(12f64.to_radians()), 0.0);
    assert_eq!(d.max_theta(), 12f64.to_radians());
    // ⟨cos θ⟩ from Simpson (piecewise: integrate each bin separately, the density jumps).
    let edges = [0.0f64, 1.0, 2.0, 4.0, 7.0, 12.0].map(|x| x.to_radians());
    let mut total = 0.0;
    let mut mc = 0.0;
    for w in edges.windows(2) {
        let mid = 0.5 * (w[0] + w[1]);
        let p2 = d.p2(mid);
        total += simpson(|t| 2.0 * PI * p2 * t.sin(), w[0], w[1], 1000);
        mc += simpson(|t| 2.0 * PI * p2 * t.sin() * t.cos(), w[0], w[1], 1000);
    }
    assert!((total - 1.0).abs() < 1e-12);
    assert!((d.mean_cos() - mc).abs() < 1e-12);
    // Partial mass inside bin 3 (4°..7°): (1/7)·(cos 5° − cos 6°)/(cos 4° − cos 7°).
    let r = |x: f64| x.to_radians().cos();
    let expected = (1.0 / 7.0) * (r(5.0) - r(6.0)) / (r(4.0) - r(7.0));
    let got = d.mass_between(5f64.to_radians(), 6f64.to_radians());
    assert!((got / expected - 1.0).abs() < 1e-12);
}

#[test]
fn flat_is_a_delta() {
    let d = Orientation::flat();
    assert!(d.is_delta());
    assert_eq!(d.p2(0.0), 0.0);
    assert_eq!(d.macro_density(0.0), 0.0);
    assert_eq!(d.mean_cos(), 1.0);
    assert_eq!(d.max_theta(), 0.0);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    assert_eq!(
        d.sample_normal(&mut rng).into_inner(),
        nalgebra::Vector3::z()
    );
}

#[test]
fn constructor_errors() {
    for bad in [0.0, -0.1, FRAC_PI_2, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            Orientation::gaussian(GaussianWidth::Hwhm(bad)),
            Err(DistributionError::BadWidth { kind: "hwhm", .. })
        ));
    }
    assert!(matches!(
        Orientation::tabulated(vec![0.0, 0.1], vec![1.0, 1.0]),
        Err(DistributionError::BinCount { .. })
    ));
    assert!(matches!(
        Orientation::tabulated(vec![0.0, 0.2, 0.1], vec![1.0, 1.0]),
        Err(DistributionError::EdgesNotIncreasing { index: 2, .. })
    ));
    assert!(matches!(
        Orientation::tabulated(vec![0.0, 2.0], vec![1.0]),
        Err(DistributionError::EdgeOutOfRange { index: 1, .. })
    ));
    assert!(matches!(
        Orientation::tabulated(vec![0.0, 0.1], vec![-1.0]),
        Err(DistributionError::BadMass { index: 0, .. })
    ));
    assert_eq!(
        Orientation::tabulated(vec![0.0, 0.1, 0.2], vec![0.0, 0.0]),
        Err(DistributionError::ZeroTotal)
    );
}

/// Chi-square test of `sample_normal` against the distribution's own `p`: cells are
/// `n_theta` equal bins of θ up to `theta_max` times 4 azimuth quadrants; expected
/// cell probabilities integrate `p` with Simpson (independent of the sampler) and split
/// evenly over φ. Also checks every sample is a unit vector with z ≥ 0.
fn chi_square_sampling(d: &Orientation, theta_max: f64, n_theta: usize, seed: u64) {
    let n = 40_000;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut observed = vec![0.0; n_theta * 4];
    for _ in 0..n {
        let m = d.sample_normal(&mut rng);
        assert!(m.z >= 0.0 && (m.norm() - 1.0).abs() < 1e-12);
        let theta = m.z.clamp(-1.0, 1.0).acos();
        let phi = m.y.atan2(m.x).rem_euclid(2.0 * PI);
        let i = ((theta / theta_max * n_theta as f64) as usize).min(n_theta - 1);
        let j = ((phi / (0.5 * PI)) as usize).min(3);
        observed[i * 4 + j] += 1.0;
    }
    let mut expected = Vec::new();
    let h = theta_max / n_theta as f64;
    for i in 0..n_theta {
        let (lo, hi) = (i as f64 * h, (i + 1) as f64 * h);
        let mut prob = simpson(|t| d.p(t), lo, hi.min(FRAC_PI_2 - 1e-15), 200);
        if i == n_theta - 1 {
            prob += simpson(|t| d.p(t), hi, FRAC_PI_2 - 1e-15, 2000);
        }
        for _ in 0..4 {
            expected.push(n as f64 * prob / 4.0);
        }
    }
    let (stat, df) = chi_square(&observed, &expected);
    let crit = chi_square_critical(df, 1e-3);
    assert!(stat < crit, "chi2 = {stat} > {crit} (df {df})");
}

#[test]
fn gaussian_sampling_chi_square() {
    for (k, d) in gaussians().iter().enumerate() {
        let s = d.gaussian_width().unwrap().sigma();
        let theta_max = (4.0 * s).min(FRAC_PI_2);
        chi_square_sampling(d, theta_max, 30, 11 + k as u64);
    }
}

#[test]
fn tabulated_sampling_chi_square() {
    // 60 cells of 0.2° straddle the table's bin edges, so the within-bin shape
    // (uniform in cos θ) is tested, not only the bin masses.
    chi_square_sampling(&table(), 12f64.to_radians(), 60, 5);
}

#[test]
fn chi_square_detects_a_wrong_sampler() {
    // Power check of the procedure above: samples from hwhm 3.3° tested against the
    // hwhm 3° pdf must fail.
    let truth = Orientation::gaussian(GaussianWidth::Hwhm(3f64.to_radians())).unwrap();
    let wrong = Orientation::gaussian(GaussianWidth::Hwhm(3.3f64.to_radians())).unwrap();
    let n = 40_000;
    let n_theta = 30;
    let theta_max = 4.0 * GaussianWidth::Hwhm(3f64.to_radians()).sigma();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut observed = vec![0.0; n_theta];
    for _ in 0..n {
        let theta = wrong.sample_normal(&mut rng).z.acos();
        let i = ((theta / theta_max * n_theta as f64) as usize).min(n_theta - 1);
        observed[i] += 1.0;
    }
    let h = theta_max / n_theta as f64;
    let expected: Vec<f64> = (0..n_theta)
        .map(|i| {
            let hi = if i == n_theta - 1 {
                FRAC_PI_2 - 1e-15
            } else {
                (i + 1) as f64 * h
            };
            n as f64 * simpson(|t| truth.p(t), i as f64 * h, hi, 2000)
        })
        .collect();
    let (stat, df) = chi_square(&observed, &expected);
    assert!(stat > chi_square_critical(df, 1e-3));
}

#[test]
fn narrow_bins_keep_their_digits() {
    // A bin [0, b] with b = 1e-7 rad: its solid angle is 2π(1 − cos b) = 4π sin²(b/2),
    // which the plain difference of cosines gets wrong by ~2 % (1 − cos b ≈ 5e-15 is a
    // few ulps of 1). p2 · 4π sin²(b/2) must be the whole mass.
    let b = 1e-7;
    let d = Orientation::tabulated(vec![0.0, b, 2.0 * b], vec![1.0, 0.0]).unwrap();
    let cap = 4.0 * PI * (0.5 * b).sin().powi(2);
    assert!(
        (d.p2(0.5 * b) * cap - 1.0).abs() < 1e-12,
        "{}",
        d.p2(0.5 * b) * cap
    );
    assert!((d.mass_between(0.0, 0.5 * b) - 0.25).abs() < 1e-9);
    // Samples: θ² is uniform on [0, b²] for a cap this small (cos θ uniform, 1 − cos θ ≈
    // θ²/2), so the mean of θ²/b² is 1/2 (sd of the mean 0.29/sqrt(n)) and every sample
    // lies in the bin.
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n = 20_000;
    let mut sum = 0.0;
    for _ in 0..n {
        let m = d.sample_normal(&mut rng);
        let t = (m.x * m.x + m.y * m.y).sqrt().atan2(m.z);
        assert!((0.0..=b * (1.0 + 1e-12)).contains(&t), "{t}");
        sum += (t / b).powi(2);
    }
    let mean = sum / f64::from(n);
    assert!(
        (mean - 0.5).abs() < 5.0 * 0.29 / f64::from(n).sqrt(),
        "{mean}"
    );
}

#[test]
fn narrow_gaussians_integrate_to_one() {
    // mass_between over the whole support must be 1 for any width: with s = 1e-9 rad
    // the panels once spread over [0, π/2] and missed the peak entirely.
    for s in [1e-9, 1e-6, 1e-3, 0.3] {
        let d = Orientation::gaussian(GaussianWidth::Sigma(s)).unwrap();
        assert!(
            (d.mass_between(0.0, FRAC_PI_2) - 1.0).abs() < 1e-12,
            "s {s}"
        );
        // P(θ ≤ s) = 1 − e^{-1/2} for a Rayleigh tilt (small s).
        if s < 1e-3 {
            let want = 1.0 - (-0.5f64).exp();
            assert!((d.mass_between(0.0, s) - want).abs() < 1e-9, "s {s}");
        }
        assert_eq!(d.narrowest_feature(), s);
        // exp(−θ²/(2s²)) is exactly 0 in f64 beyond 38.7 s (exp(x) = 0 below −745.2).
        assert_eq!(d.p2(38.7 * s * 1.0001), 0.0);
        assert!(d.p2(38.0 * s) > 0.0 || 38.0 * s >= FRAC_PI_2);
        assert_eq!(d.support_end(), FRAC_PI_2.min(38.7 * s));
    }
}

#[test]
fn support_and_features_of_tables() {
    let e = |x: f64| x.to_radians();
    let d = Orientation::tabulated(
        vec![0.0, e(0.5), e(1.0), e(3.0), e(9.0)],
        vec![0.0, 1.0, 2.0, 0.0],
    )
    .unwrap();
    // Support [0.5°, 3°] (first and last bins empty); the bin [0.5°, 1°] has p2 =
    // (1/3)/(2π(cos 0.5° − cos 1°)) against (2/3)/(2π(cos 1° − cos 3°)) beside it: 5.3×
    // as dense (solid angles 0.75 : 8 in units of 2π·(1°)²/2), isolated, so the feature is
    // its 0.5°. The edges are returned as given.
    assert!((d.narrowest_feature() - e(0.5)).abs() < 1e-15);
    let even =
        Orientation::tabulated(vec![0.0, e(0.5), e(1.0), e(3.0)], vec![0.0, 0.75, 8.0]).unwrap();
    // Equal p2 in both bins: no isolated bin, the support's 2.5° it is.
    assert!((even.narrowest_feature() - e(2.5)).abs() < 1e-15);
    assert_eq!(d.support_end(), e(3.0));
    assert_eq!(d.bin_edges().unwrap().len(), 5);
    assert_eq!(Orientation::flat().support_end(), 0.0);
    // A spike: half the area within 0.002° under a 3° bin (p2 ratio ~ (3/0.002)²/0.8).
    let spike =
        Orientation::tabulated(vec![0.0, e(0.002), e(3.0), e(8.0)], vec![0.5, 0.4, 0.1]).unwrap();
    assert!((spike.narrowest_feature() - e(0.002)).abs() < 1e-18);
    // A thin ring at 5°, 0.01° wide, on a faint background: isolated.
    let ring =
        Orientation::tabulated(vec![0.0, e(5.0), e(5.01), e(20.0)], vec![0.1, 0.5, 0.4]).unwrap();
    assert!((ring.narrowest_feature() - e(0.01)).abs() < 1e-15);
    // A smooth table of fine bins (a Gaussian of hwhm 3° on 0.25° bins): no isolated bin,
    // the feature is its support.
    let g = Orientation::gaussian(GaussianWidth::Hwhm(e(3.0))).unwrap();
    let edges: Vec<f64> = (0..=120).map(|k| e(0.25 * f64::from(k))).collect();
    let masses = edges
        .windows(2)
        .map(|w| g.mass_between(w[0], w[1]))
        .collect();
    let fine = Orientation::tabulated(edges, masses).unwrap();
    assert!((fine.narrowest_feature() - e(30.0)).abs() < 1e-12);
    assert!(
        Orientation::gaussian(GaussianWidth::Hwhm(0.1))
            .unwrap()
            .bin_edges()
            .is_none()
    );
}

#[test]
fn widths_below_the_resolvable_floor_are_refused() {
    // Below 1e-10 rad a cone sees the delta limit to double precision (see
    // MIN_GAUSSIAN_WIDTH); the error names the kind and gives degrees too.
    let err = Orientation::gaussian(GaussianWidth::Hwhm(1e-11)).unwrap_err();
    assert!(matches!(
        err,
        DistributionError::BadWidth { kind: "hwhm", .. }
    ));
    let msg = err.to_string();
    assert!(msg.contains("degrees") && msg.contains("1e-10"), "{msg}");
    assert!(Orientation::gaussian(GaussianWidth::Sigma(1e-10)).is_ok());
}

#[test]
fn bins_too_narrow_for_double_precision_are_refused_or_harmless() {
    // [0, 1e-200] rad has a solid angle of ~π·1e-400, which underflows: with area in it
    // the density would be infinite, so it is refused; empty, it is just a zero bin (it
    // once gave p2 = 0/0 = NaN).
    let e = Orientation::tabulated(vec![0.0, 1e-200, 0.1], vec![1.0, 1.0]).unwrap_err();
    assert!(
        matches!(e, DistributionError::BinTooNarrow { index: 0, .. }),
        "{e:?}"
    );
    let d = Orientation::tabulated(vec![0.0, 1e-200, 0.1], vec![0.0, 1.0]).unwrap();
    assert_eq!(d.p2(1e-201), 0.0);
    assert!(d.p2(0.05).is_finite() && d.p2(0.05) > 0.0);
}
