//! Width fitting: maximum likelihood with interval coverage, and least squares on
//! histograms.

use flakescatter_stats::fit::{FitError, fit_gaussian_histogram, fit_gaussian_ml};
use flakescatter_stats::histogram::AreaHistogram;
use flakescatter_stats::{GaussianWidth, Orientation};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn draw(d: &Orientation, n: usize, seed: u64, random_areas: bool) -> Vec<(f64, f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let m = d.sample_normal(&mut rng);
            // Areas independent of orientation (area-weighting then leaves p unchanged).
            let a = if random_areas {
                rng.random_range(1.0..50.0)
            } else {
                1.0
            };
            (m.z.acos(), a)
        })
        .collect()
}

#[test]
fn ml_interval_covers_truth_at_the_nominal_rate() {
    // 40 seeds × 10⁴ flakes from hwhm = 3°. Coverage ~ Binomial(40, 0.95): mean 38;
    // we require ≥ 34 (P(X ≤ 33) = 0.34 %).
    // Each estimate within 3 % of the truth: for small s, θ² is ≈ 2s²·Exp(1), so m2 has
    // relative sd 1/sqrt(N) = 1 % and s = sqrt(m2/2) has 0.5 %: 3 % is 6 sd.
    let w = 3f64.to_radians();
    let d = Orientation::gaussian(GaussianWidth::Hwhm(w)).unwrap();
    let mut covered = 0;
    for seed in 0..40 {
        let fit = fit_gaussian_ml(&draw(&d, 10_000, 1000 + seed, seed % 2 == 0)).unwrap();
        assert!(
            (fit.hwhm() / w - 1.0).abs() < 0.03,
            "seed {seed}: {}",
            fit.hwhm()
        );
        let (lo, hi) = fit.hwhm_ci95();
        assert!(lo < fit.hwhm() && fit.hwhm() < hi);
        if lo <= w && w <= hi {
            covered += 1;
        }
        if seed % 2 == 1 {
            // Equal areas: half-width of the interval ≈ 1.96 · 0.5 % of s (see above).
            let rel = 0.5 * (hi - lo) / fit.hwhm();
            assert!((rel / (1.96 * 0.005) - 1.0).abs() < 0.1, "rel {rel}");
        }
    }
    assert!((34..=40).contains(&covered), "covered {covered}/40");
}

#[test]
fn ml_fit_of_a_wide_truncated_gaussian() {
    // s = 0.6 rad: the truncation at π/2 matters; ML must still recover s (2·10⁴ flakes,
    // sd of the estimate about 1 %).
    let d = Orientation::gaussian(GaussianWidth::Sigma(0.6)).unwrap();
    let fit = fit_gaussian_ml(&draw(&d, 20_000, 5, false)).unwrap();
    assert!((fit.sigma / 0.6 - 1.0).abs() < 0.04, "{}", fit.sigma);
    assert_eq!(fit.flakes, 20_000);
    assert!((fit.effective_n - 20_000.0).abs() < 1e-6);
}

#[test]
fn ml_errors() {
    assert_eq!(fit_gaussian_ml(&[]), Err(FitError::Empty));
    assert_eq!(
        fit_gaussian_ml(&[(0.0, 1.0), (0.0, 2.0)]),
        Err(FitError::ZeroWidth)
    );
    assert!(matches!(
        fit_gaussian_ml(&[(0.1, 0.0)]),
        Err(FitError::BadInput { what: "area", .. })
    ));
    // All flakes at 85°: wider than a uniform p̃ (π − 2 ≈ 1.14 < 1.48²).
    assert!(matches!(
        fit_gaussian_ml(&[(1.48, 1.0)]),
        Err(FitError::Unbounded { .. })
    ));
}

#[test]
fn least_squares_fit_of_exact_and_sampled_histograms() {
    let w = 4f64.to_radians();
    let d = Orientation::gaussian(GaussianWidth::Hwhm(w)).unwrap();
    // Sampled: 10⁵ flakes, 1° bins; the LS estimate is within 3 % of the truth.
    let h = AreaHistogram::new(draw(&d, 100_000, 8, false), 1f64.to_radians()).unwrap();
    let fit = fit_gaussian_histogram(&h).unwrap();
    assert!(
        (fit.hwhm() / w - 1.0).abs() < 0.03,
        "{}",
        fit.hwhm().to_degrees()
    );
    assert!((fit.amplitude - 1.0).abs() < 0.03);
    // A histogram made from the paper-style small-angle Gaussian p̃ (no truncation,
    // masses by Simpson in the test) with an arbitrary scale: amplitude is free.
    let s = w / (2.0 * 2f64.ln()).sqrt();
    let edges: Vec<f64> = (0..=90).map(|i| (i as f64).to_radians()).collect();
    let mut samples = Vec::new();
    for win in edges.windows(2) {
        let h = (win[1] - win[0]) / 100.0;
        let mut m = 0.0;
        for k in 0..100 {
            let t = win[0] + (k as f64 + 0.5) * h;
            m += (-t * t / (2.0 * s * s)).exp() * t.sin() * h;
        }
        if m > 1e-300 {
            samples.push((0.5 * (win[0] + win[1]), 7.0 * m));
        }
    }
    let h = AreaHistogram::new(samples, 1f64.to_radians()).unwrap();
    let fit = fit_gaussian_histogram(&h).unwrap();
    // Midpoint-rule masses are accurate to ~1e-5 relative; s comes back to 1e-3.
    assert!((fit.sigma / s - 1.0).abs() < 1e-3, "{} vs {s}", fit.sigma);
}

/// Share of `reps` seeded samples of `n` flakes from `d` whose 95 % interval covers the
/// true hwhm `w`, and the median relative width `(hi − lo)/ŵ` of the intervals.
fn coverage(
    d: &Orientation,
    w: f64,
    n: usize,
    reps: u64,
    seed: u64,
    random_areas: bool,
) -> (f64, f64) {
    use rayon::prelude::*;
    let out: Vec<(bool, f64)> = (0..reps)
        .into_par_iter()
        .map(|r| {
            let fit = fit_gaussian_ml(&draw(d, n, seed + r, random_areas)).unwrap();
            let (lo, hi) = fit.hwhm_ci95();
            assert!(
                lo < fit.hwhm() && fit.hwhm() < hi,
                "n {n}: {lo} {} {hi}",
                fit.hwhm()
            );
            (lo <= w && w <= hi, (hi - lo) / fit.hwhm())
        })
        .collect();
    let covered = out.iter().filter(|c| c.0).count() as f64 / reps as f64;
    let mut widths: Vec<f64> = out.iter().map(|c| c.1).collect();
    widths.sort_by(f64::total_cmp);
    (covered, widths[widths.len() / 2])
}

#[test]
fn ml_interval_holds_for_small_samples() {
    // Coverage by simulation: for n = 3 … 100 flakes from a hwhm 3° Gaussian, R = 1200
    // seeded samples each; the 95 % interval must cover the truth in 95 % of them. The
    // count is Binomial(R, 0.95) for an honest interval: sd 0.63 %, so ±2.5 % is 4 sd
    // (a false alarm over the 8 checks below has probability ~5e-4; the seeds are
    // fixed). The delta-method interval this replaces covered 0 % at n = 1 and ~83 % at
    // n = 5 (its width shrank with the sample's own spread).
    let w = 3f64.to_radians();
    let d = Orientation::gaussian(GaussianWidth::Hwhm(w)).unwrap();
    let reps = 1200;
    let mut medians = Vec::new();
    for (k, n) in [1usize, 3, 5, 10, 30, 100].into_iter().enumerate() {
        let (cov, median) = coverage(&d, w, n, reps, 10_000 * k as u64, false);
        assert!((cov - 0.95).abs() < 0.025, "n {n}: coverage {cov}");
        medians.push((n, median));
    }
    // Area weights through the effective number of flakes: random areas, n = 5 and 30.
    for (k, n) in [5usize, 30].into_iter().enumerate() {
        let (cov, _) = coverage(&d, w, n, reps, 90_000 + 10_000 * k as u64, true);
        assert!(
            (cov - 0.95).abs() < 0.025,
            "random areas, n {n}: coverage {cov}"
        );
    }
    // Wider with fewer flakes. For small tilts m2 is (2s²/n) times a Gamma(n) variable,
    // relative sd 1/sqrt(n), so ŵ ∝ sqrt(m2) has relative sd 1/(2 sqrt(n)) and the 95 %
    // interval a relative width of about 1.96/sqrt(n) at large n (0.196 at n = 100).
    let m = |n: usize| medians.iter().find(|x| x.0 == n).unwrap().1;
    assert!(m(1) > m(3) && m(3) > m(5) && m(5) > m(10) && m(10) > m(30) && m(30) > m(100));
    assert!(
        (m(100) / (1.96 / 100f64.sqrt()) - 1.0).abs() < 0.1,
        "{}",
        m(100)
    );
}

#[test]
fn ml_interval_of_one_flake_is_wide_and_says_how_it_was_made() {
    let fit = fit_gaussian_ml(&[(3f64.to_radians(), 1.0)]).unwrap();
    let (lo, hi) = fit.hwhm_ci95();
    assert!(lo > 0.0 && hi.is_finite() && hi / lo > 10.0, "{lo} {hi}");
    assert_eq!(
        fit.ci_method,
        flakescatter_stats::IntervalMethod::ProfileLikelihood
    );
    assert!(fit.ci_method.describe().contains("Bartlett"));
    // A wide tilt from few flakes: the uniform limit is inside the interval, whose upper
    // end is then explicitly unbounded.
    let fit = fit_gaussian_ml(&[(0.9, 1.0), (1.1, 1.0)]).unwrap();
    assert_eq!(fit.sigma_ci95.1, f64::INFINITY);
}

#[test]
fn histogram_fit_refuses_widths_its_bins_cannot_resolve() {
    // Flakes of hwhm 0.01° in 1° bins: all area in the first bin, where every width
    // below ~0.1° gives the same bin masses; the scan ends at s = 1e-3 rad and that end
    // is not a fit.
    let d = Orientation::gaussian(GaussianWidth::Hwhm(0.01f64.to_radians())).unwrap();
    let h = AreaHistogram::new(draw(&d, 2_000, 4, false), 1f64.to_radians()).unwrap();
    let e = fit_gaussian_histogram(&h).unwrap_err();
    assert!(matches!(e, FitError::HistogramWidthAtBound { .. }), "{e:?}");
    assert!(e.to_string().contains("narrower than"), "{e}");
}
