//! The pooled width of several maps: closed forms of its pieces, coverage of the
//! map-level interval and the rate at which the consistency test flags maps, on seeded
//! samples drawn from the model (the numbers the module docs quote come from the
//! independent numpy script `tests/reference/pool_simulation.py`).

use std::f64::consts::PI;

use flakescatter_stats::fit::fit_gaussian_ml;
use flakescatter_stats::pool::{PoolError, PoolWarning, pool_maps, trigamma};
use flakescatter_stats::{GaussianWidth, Orientation};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, LogNormal, Poisson};

#[test]
fn trigamma_closed_forms() {
    // ψ'(1) = π²/6, ψ'(1/2) = π²/2, and the recurrence ψ'(x + 1) = ψ'(x) − 1/x²:
    // ψ'(3/2) = π²/2 − 4, ψ'(5/2) = π²/2 − 4 − 4/9, ψ'(11) = π²/6 − Σ_{k=1}^{10} 1/k².
    let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-13;
    assert!(close(trigamma(1.0), PI * PI / 6.0));
    assert!(close(trigamma(0.5), PI * PI / 2.0));
    assert!(close(trigamma(1.5), PI * PI / 2.0 - 4.0));
    assert!(close(trigamma(2.5), PI * PI / 2.0 - 4.0 - 4.0 / 9.0));
    let h2: f64 = (1..=10).map(|k| 1.0 / f64::from(k * k)).sum();
    assert!(close(trigamma(11.0), PI * PI / 6.0 - h2));
    // Large x: ψ'(x) = 1/x + 1/(2x²) + 1/(6x³) + O(x⁻⁵).
    let x = 1e4;
    assert!(close(
        trigamma(x),
        1.0 / x + 0.5 / (x * x) + 1.0 / (6.0 * x * x * x)
    ));
}

/// `s` whose truncated Gaussian has `E[θ²] = m2` (the ML fit of one flake at `√m2`).
fn sigma_of_m2(m2: f64) -> f64 {
    fit_gaussian_ml(&[(m2.sqrt(), 1.0)]).unwrap().sigma
}

#[test]
fn map_level_interval_of_two_one_flake_maps_by_hand() {
    // Two maps of one flake each, areas 1 and 3, tilts 0.04 and 0.08 rad.
    // A = (1, 3), S = (0.0016, 0.0192), m2 = 0.0208 / 4 = 0.0052.
    // V = 2/1 · [(0.0016 − 0.0052)² + (0.0192 − 0.0156)²] / 16 = 2 · 2 · 0.0036² / 16.
    // t_{0.975, 1} = 12.706204736174698 (scipy.stats.t.ppf).
    let (a, b) = (vec![(0.04, 1.0)], vec![(0.08, 3.0)]);
    let p = pool_maps(&[&a, &b]).unwrap();
    let m = p.map_level.unwrap();
    assert_eq!((m.maps, m.dof), (2, 1));
    assert!((m.t_quantile / 12.706_204_736_174_698 - 1.0).abs() < 1e-9);
    let se = (4.0 * 0.0036f64.powi(2) / 16.0).sqrt();
    assert!((m.mean_square_tilt_std_err / se - 1.0).abs() < 1e-12);
    let m2 = 0.0052;
    assert!((p.flake_level.mean_square_tilt / m2 - 1.0).abs() < 1e-12);
    let half = 12.706_204_736_174_698 * se / m2;
    let lo = sigma_of_m2(m2 * (-half).exp());
    assert!(
        (m.sigma_ci95.0 / lo - 1.0).abs() < 1e-9,
        "{:?} vs {lo}",
        m.sigma_ci95
    );
    // Upper end: m2 · e^half = 0.0052 · e^4.398 = 0.42 rad², below the uniform limit.
    let hi = sigma_of_m2(m2 * half.exp());
    assert!(
        (m.sigma_ci95.1 / hi - 1.0).abs() < 1e-9,
        "{:?} vs {hi}",
        m.sigma_ci95
    );
    assert!(
        p.warnings
            .iter()
            .any(|w| matches!(w, PoolWarning::FewMaps { maps: 2, .. }))
    );
}

fn refs(v: &[Vec<(f64, f64)>]) -> Vec<&[(f64, f64)]> {
    v.iter().map(Vec::as_slice).collect()
}

#[test]
fn t_quantiles_match_scipy() {
    // scipy.stats.t.ppf(0.975, dof) for dof = 2 and 7.
    let m = |k: usize| -> Vec<(f64, f64)> { vec![(0.03 + 0.001 * k as f64, 1.0)] };
    let three: Vec<Vec<(f64, f64)>> = (0..3).map(m).collect();
    let eight: Vec<Vec<(f64, f64)>> = (0..8).map(m).collect();
    let t3 = pool_maps(&refs(&three))
        .unwrap()
        .map_level
        .unwrap()
        .t_quantile;
    let t8 = pool_maps(&refs(&eight))
        .unwrap()
        .map_level
        .unwrap()
        .t_quantile;
    assert!((t3 / 4.302_652_729_749_464 - 1.0).abs() < 1e-9, "{t3}");
    assert!((t8 / 2.364_624_251_592_784 - 1.0).abs() < 1e-9, "{t8}");
}

/// A map of one sample: Poisson(70) flakes (at least 2) with tilts from the model and
/// log-normal areas (σ_ln = 1), as in the numpy script.
fn draw_map(d: &Orientation, rng: &mut ChaCha8Rng) -> Vec<(f64, f64)> {
    let n = (Poisson::new(70.0).unwrap().sample(rng) as usize).max(2);
    let area = LogNormal::new(0.0, 1.0).unwrap();
    (0..n)
        .map(|_| (d.sample_normal(rng).z.acos(), area.sample(rng)))
        .collect()
}

#[test]
fn map_level_interval_covers_the_population_width() {
    // 1200 samples each of 3 and of 8 maps from one population (s from hwhm 6°).
    // Coverage ~ Binomial(1200, 0.95): sd 0.63 %; we require 92.5–97.5 % (4 sd).
    let s = GaussianWidth::Hwhm(6f64.to_radians()).sigma();
    let d = Orientation::gaussian(GaussianWidth::Sigma(s)).unwrap();
    for (maps, seed) in [(3usize, 11u64), (8, 12)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut covered = 0;
        let reps = 1200;
        for _ in 0..reps {
            let sample: Vec<Vec<(f64, f64)>> = (0..maps).map(|_| draw_map(&d, &mut rng)).collect();
            let refs: Vec<&[(f64, f64)]> = sample.iter().map(Vec::as_slice).collect();
            let (lo, hi) = pool_maps(&refs).unwrap().map_level.unwrap().sigma_ci95;
            covered += usize::from(lo <= s && s <= hi);
        }
        let c = covered as f64 / reps as f64;
        assert!((0.925..=0.975).contains(&c), "{maps} maps: coverage {c}");
    }
}

#[test]
fn consistency_test_flags_a_wide_map_and_rarely_a_good_one() {
    // 8 maps of hwhm 6°; in half the samples map 0 has hwhm 10° instead. The numpy
    // script finds: no bad map → some map flagged in 3.7 % of samples; the bad map
    // flagged in 97.7 %, a good one with it in 4.7 %. Bounds (400 samples each, sd about
    // 1 %): ≤ 8 %, ≥ 93 %, ≤ 9 %.
    let good = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let bad = Orientation::gaussian(GaussianWidth::Hwhm(10f64.to_radians())).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let reps = 400;
    let (mut null_flags, mut bad_flagged, mut good_flagged) = (0, 0, 0);
    for rep in 0..2 * reps {
        let with_bad = rep % 2 == 1;
        let sample: Vec<Vec<(f64, f64)>> = (0..8)
            .map(|j| draw_map(if with_bad && j == 0 { &bad } else { &good }, &mut rng))
            .collect();
        let refs: Vec<&[(f64, f64)]> = sample.iter().map(Vec::as_slice).collect();
        let p = pool_maps(&refs).unwrap();
        let flagged: Vec<bool> = p.maps.iter().map(|m| m.flagged).collect();
        if with_bad {
            bad_flagged += usize::from(flagged[0]);
            good_flagged += usize::from(flagged[1..].iter().any(|&f| f));
        } else {
            null_flags += usize::from(flagged.iter().any(|&f| f));
        }
        // A flag always comes with its warning and a z beyond the bound.
        for (m, &f) in p.maps.iter().zip(&flagged) {
            if f {
                assert!(m.z.unwrap().abs() > p.z_bound.unwrap());
            }
        }
        assert_eq!(
            flagged.iter().any(|&f| f),
            p.warnings
                .iter()
                .any(|w| matches!(w, PoolWarning::Inconsistent { .. }))
        );
    }
    let r = |k: usize| k as f64 / reps as f64;
    assert!(r(null_flags) <= 0.08, "no bad map: {}", r(null_flags));
    assert!(
        r(bad_flagged) >= 0.93,
        "bad map flagged: {}",
        r(bad_flagged)
    );
    assert!(
        r(good_flagged) <= 0.09,
        "good map flagged: {}",
        r(good_flagged)
    );
}

#[test]
fn the_pooled_width_is_the_fit_of_all_flakes() {
    let d = Orientation::gaussian(GaussianWidth::Hwhm(5f64.to_radians())).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let sample: Vec<Vec<(f64, f64)>> = (0..4).map(|_| draw_map(&d, &mut rng)).collect();
    let refs: Vec<&[(f64, f64)]> = sample.iter().map(Vec::as_slice).collect();
    let p = pool_maps(&refs).unwrap();
    let all: Vec<(f64, f64)> = sample.concat();
    assert_eq!(p.flake_level, fit_gaussian_ml(&all).unwrap());
    for (m, s) in p.maps.iter().zip(&sample) {
        assert_eq!(m.fit, Some(fit_gaussian_ml(s).unwrap()));
        assert_eq!(m.flakes, s.len());
    }
    // With four maps the quoted interval is the map-level one.
    assert_eq!(p.sigma_ci95(), p.map_level.unwrap().sigma_ci95);
}

#[test]
fn one_map_empty_maps_and_bad_values() {
    let a = vec![(0.05, 2.0), (0.1, 1.0)];
    let one = pool_maps(&[&a]).unwrap();
    assert!(one.map_level.is_none() && one.heterogeneity.is_none());
    assert_eq!(one.sigma_ci95(), one.flake_level.sigma_ci95);
    assert!(one.warnings.contains(&PoolWarning::OneMap));
    assert!(one.maps[0].z.is_none() && !one.maps[0].flagged);

    let empty: Vec<(f64, f64)> = Vec::new();
    let p = pool_maps(&[&a, &empty, &a]).unwrap();
    assert!(
        p.warnings
            .contains(&PoolWarning::EmptyMaps { maps: vec![1] })
    );
    assert_eq!(p.map_level.unwrap().maps, 2);
    assert!(p.maps[1].fit.is_none() && p.maps[1].z.is_none());

    assert_eq!(pool_maps(&[]), Err(PoolError::NoMaps));
    assert_eq!(
        pool_maps(&[&empty, &empty]),
        Err(PoolError::NoFlakes { maps: 2 })
    );
    let bad = vec![(0.05, 1.0), (0.05, -1.0)];
    let e = pool_maps(&[&a, &bad]).unwrap_err();
    assert!(matches!(e, PoolError::Map { map: 1, .. }), "{e}");
    assert!(e.to_string().starts_with("map 1: flake 1: area"), "{e}");
}
