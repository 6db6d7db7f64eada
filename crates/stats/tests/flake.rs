//! Plane fits, endpoint tilts, conversions, histograms and the eq. 8 slope conversion.

mod common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::simpson;
use flakescatter_stats::flake::{
    FlakeError, endpoint_area, endpoint_tilts, fit_plane, normal_from_polar, normal_from_tilts,
    polar_from_normal, tilts_from_normal, tilts_from_polar,
};
use flakescatter_stats::histogram::{
    AreaHistogram, HistogramError, orientation_from_slope_pdf, p_tilde_from_slope_pdf,
};
use flakescatter_stats::{Flake, GaussianWidth, Orientation};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

#[test]
fn plane_fit_recovers_an_exact_plane() {
    // z = 0.1 x − 0.05 y + 2 sampled on a 5 × 5 grid: exact fit, zero residual,
    // normal (−0.1, 0.05, 1)/sqrt(1.0125).
    let pts: Vec<[f64; 3]> = (0..25)
        .map(|i| {
            let (x, y) = ((i % 5) as f64 * 0.3, (i / 5) as f64 * 0.7);
            [x, y, 0.1 * x - 0.05 * y + 2.0]
        })
        .collect();
    let f = fit_plane(&pts).unwrap();
    assert!((f.a - 0.1).abs() < 1e-13 && (f.b + 0.05).abs() < 1e-13);
    assert!((f.c - 2.0).abs() < 1e-12 && f.rms_um < 1e-12);
    let norm = 1.0125f64.sqrt();
    assert!((f.normal.x + 0.1 / norm).abs() < 1e-13);
    assert!((f.normal.y - 0.05 / norm).abs() < 1e-13);
}

#[test]
fn plane_fit_residual_by_hand() {
    // Four corners of the unit square with heights 0, 0, 0, 1 (at (1,1)).
    // Normal equations by hand (centred): a = b = 0.5, c = −0.25; residuals
    // ±0.25 at every corner, so rms = 0.25.
    let pts = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 1.0],
    ];
    let f = fit_plane(&pts).unwrap();
    assert!((f.a - 0.5).abs() < 1e-14 && (f.b - 0.5).abs() < 1e-14);
    assert!((f.c + 0.25).abs() < 1e-14);
    assert!((f.rms_um - 0.25).abs() < 1e-14);
}

#[test]
fn plane_fit_errors() {
    assert_eq!(
        fit_plane(&[[0.0; 3], [1.0, 0.0, 0.0]]),
        Err(FlakeError::TooFewPoints(2))
    );
    let line = [
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 2.0],
        [2.0, 2.0, 0.0],
        [3.0, 3.0, 1.0],
    ];
    assert_eq!(fit_plane(&line), Err(FlakeError::Collinear(4)));
    assert!(matches!(
        fit_plane(&[[0.0; 3], [1.0, 0.0, f64::NAN], [0.0, 1.0, 0.0]]),
        Err(FlakeError::NonFinite { what: "z", .. })
    ));
}

#[test]
fn endpoint_tilts_and_area() {
    // A trace rising 1 µm over 10 µm in x and falling 2 µm over 20 µm in y:
    // tan θx = 0.1, tan θy = −0.1, tan² θn = 0.02.
    let (tx, ty) = endpoint_tilts(0.0, 5.0, 10.0, 6.0, 3.0, 4.0, 23.0, 2.0).unwrap();
    assert!((tx - 0.1f64.atan()).abs() < 1e-15 && (ty + 0.1f64.atan()).abs() < 1e-15);
    let f = Flake::from_endpoints(0.0, 5.0, 10.0, 6.0, 3.0, 4.0, 23.0, 2.0).unwrap();
    assert!((f.theta_n() - 0.02f64.sqrt().atan()).abs() < 1e-15);
    // Eq. 7: 10 · 20 / (cos θx cos θy) = 200 · (1 + 0.01) (since 1/cos = sqrt(1 + tan²)).
    assert!((f.area_um2 - 202.0).abs() < 1e-12);
    assert!((endpoint_area(-10.0, 20.0, tx, ty) - 202.0).abs() < 1e-12);
    // Rising toward +x: normal leans toward −x (φn = π for a pure x tilt).
    let n = normal_from_tilts(0.2, 0.0).unwrap();
    assert!(n.x < 0.0 && n.y.abs() < 1e-16);
    assert!((polar_from_normal(&n).1 - PI).abs() < 1e-15);
    assert!(matches!(
        endpoint_tilts(1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0),
        Err(FlakeError::DegenerateEndpoints { axis: "x", .. })
    ));
    assert!(matches!(
        endpoint_tilts(0.0, 0.0, 1.0, 1.0, 2.0, 0.0, 2.0, 0.0),
        Err(FlakeError::DegenerateEndpoints { axis: "y", .. })
    ));
}

#[test]
fn conversions_round_trip() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for _ in 0..1000 {
        let tn = rng.random_range(0.0..1.5);
        let pn = rng.random_range(0.0..2.0 * PI);
        let n = normal_from_polar(tn, pn);
        let (t2, p2) = polar_from_normal(&n);
        assert!((t2 - tn).abs() < 1e-12);
        assert!(((p2 - pn + PI).rem_euclid(2.0 * PI) - PI).abs() < 1e-9);
        let (tx, ty) = tilts_from_polar(tn, pn).unwrap();
        // Independent relation: tan² θn = tan² θx + tan² θy (eq. 6).
        assert!(
            (tx.tan().powi(2) + ty.tan().powi(2) - tn.tan().powi(2)).abs()
                < 1e-9 * (1.0 + tn.tan().powi(2))
        );
        let m = normal_from_tilts(tx, ty).unwrap();
        assert!((m.into_inner() - n.into_inner()).norm() < 1e-12);
        let (tx2, ty2) = tilts_from_normal(&m.into_inner()).unwrap();
        assert!((tx2 - tx).abs() < 1e-12 && (ty2 - ty).abs() < 1e-12);
    }
    assert!(tilts_from_normal(&Vector3::new(1.0, 0.0, 0.0)).is_err());
    assert!(normal_from_tilts(FRAC_PI_2, 0.0).is_err());
}

#[test]
fn histogram_normalisations_by_hand() {
    // Three flakes: θ = 0.5° (area 1), 1.5° (area 2), 1.7° (area 1); 1° bins.
    let d = |x: f64| x.to_radians();
    let h = AreaHistogram::new([(d(0.5), 1.0), (d(1.5), 2.0), (d(1.7), 1.0)], d(1.0)).unwrap();
    assert_eq!(h.edges().len(), 91);
    assert_eq!(h.flakes(), 3);
    assert_eq!(h.total_area_um2(), 4.0);
    let b = h.bins();
    assert_eq!(b[0].area_fraction, 0.25);
    assert_eq!(b[1].area_fraction, 0.75);
    assert!((b[1].p_per_rad - 0.75 / d(1.0)).abs() < 1e-12);
    let expected = 0.75 / (d(1.0).cos() - d(2.0).cos());
    assert!((b[1].p_tilde / expected - 1.0).abs() < 1e-12);
    // Σ p̃ (cos lo − cos hi) = 1: the histogram's p̃ integrates like the continuous one.
    let s: f64 = b
        .iter()
        .map(|b| b.p_tilde * (b.theta_lo.cos() - b.theta_hi.cos()))
        .sum();
    assert!((s - 1.0).abs() < 1e-12);
    // 7° bins: 13 bins, the last cut at 90°.
    let h7 = AreaHistogram::new([(d(89.0), 1.0), (FRAC_PI_2, 1.0)], d(7.0)).unwrap();
    assert_eq!(h7.edges().len(), 14);
    assert_eq!(h7.area_fractions()[12], 1.0);
}

#[test]
fn histogram_errors() {
    for bw in [0.0, -0.1, 46f64.to_radians(), f64::NAN] {
        assert!(matches!(
            AreaHistogram::new([(0.1, 1.0)], bw),
            Err(HistogramError::BadBinWidth(_))
        ));
    }
    assert!(AreaHistogram::new([(0.1, 1.0)], 45f64.to_radians()).is_ok());
    assert_eq!(AreaHistogram::new([], 0.1), Err(HistogramError::Empty));
    assert!(matches!(
        AreaHistogram::new([(0.1, 1.0), (0.1, 0.0)], 0.1),
        Err(HistogramError::BadArea { index: 1, .. })
    ));
    assert!(matches!(
        AreaHistogram::new([(f64::NAN, 1.0)], 0.1),
        Err(HistogramError::BadTheta { index: 0, .. })
    ));
}

#[test]
fn histogram_of_sampled_flakes_matches_the_pdf() {
    // 10⁵ normals from a hwhm 5° Gaussian, 1° bins: each bin's p̃ must match the bin
    // average of the pdf, ∫ p dθ / (cos lo − cos hi) (Simpson), within 5 binomial
    // standard deviations.
    let dist = Orientation::gaussian(GaussianWidth::Hwhm(5f64.to_radians())).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let n = 100_000;
    let flakes: Vec<Flake> = (0..n)
        .map(|_| Flake::new(dist.sample_normal(&mut rng).into_inner(), 3.0).unwrap())
        .collect();
    let h = AreaHistogram::from_flakes(&flakes, 1f64.to_radians()).unwrap();
    for b in h.bins().iter().take(12) {
        let mass = simpson(|t| dist.p(t), b.theta_lo, b.theta_hi, 100);
        let sd = (mass * (1.0 - mass) / n as f64).sqrt();
        assert!((b.area_fraction - mass).abs() < 5.0 * sd, "{b:?} vs {mass}");
        let pt = mass / (b.theta_lo.cos() - b.theta_hi.cos());
        assert!((b.p_tilde - pt).abs() < 5.0 * sd / (b.theta_lo.cos() - b.theta_hi.cos()));
    }
}

/// The eq. 8 sampling test. A heightfield of facets, one per point of a uniform `xy`
/// grid, each with slopes `(ζx, ζy)` drawn iid `N(0, σ²)` (so the slope magnitude has
/// the Rayleigh density `P(ζ) = ζ/σ² exp(−ζ²/2σ²)` over projected area). Each facet's
/// true area is computed geometrically as `|(1, 0, ζx) × (0, 1, ζy)|` per unit cell. The
/// area-weighted histogram of `θ = atan ζ` must follow the derived
/// `P(tan θ)/(sin θ cos³ θ)`, and must visibly reject the printed
/// `P(tan θ)/(sin θ cos θ)`.
#[test]
fn eq8_derived_form_holds_printed_form_fails() {
    let sigma: f64 = 0.4;
    let rayleigh = move |z: f64| z / (sigma * sigma) * (-z * z / (2.0 * sigma * sigma)).exp();
    let normal = Normal::new(0.0, sigma).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let n = 200_000;
    let mut samples = Vec::with_capacity(n);
    for _ in 0..n {
        let (zx, zy): (f64, f64) = (normal.sample(&mut rng), normal.sample(&mut rng));
        let area = Vector3::new(1.0, 0.0, zx)
            .cross(&Vector3::new(0.0, 1.0, zy))
            .norm();
        let theta = zx.hypot(zy).atan();
        samples.push((theta, area));
    }
    let bw = 3f64.to_radians();
    let h = AreaHistogram::new(samples, bw).unwrap();
    // Each candidate p̃ normalised independently with Simpson: ∫ p̃ sin θ dθ = 1.
    let derived = |t: f64| p_tilde_from_slope_pdf(rayleigh, t);
    let printed = |t: f64| rayleigh(t.tan()) / (t.sin() * t.cos());
    let top = FRAC_PI_2 - 1e-6;
    let zd = simpson(|t| derived(t) * t.sin(), 1e-9, top, 20_000);
    let zp = simpson(|t| printed(t) * t.sin(), 1e-9, top, 20_000);
    let mut worst_derived: f64 = 0.0;
    let mut worst_printed: f64 = 0.0;
    for b in h.bins().iter().filter(|b| b.area_fraction > 0.01) {
        let c = b.theta_lo.cos() - b.theta_hi.cos();
        let lo = b.theta_lo.max(1e-9);
        let md = simpson(|t| derived(t) * t.sin(), lo, b.theta_hi, 200) / zd / c;
        let mp = simpson(|t| printed(t) * t.sin(), lo, b.theta_hi, 200) / zp / c;
        worst_derived = worst_derived.max((b.p_tilde / md - 1.0).abs());
        worst_printed = worst_printed.max((b.p_tilde / mp - 1.0).abs());
    }
    // Bins with > 1 % of 2·10⁵ samples have < 3 % relative noise; the printed form is off
    // by tens of percent at the tilts where σ = 0.4 puts its mass.
    assert!(worst_derived < 0.05, "derived form off by {worst_derived}");
    assert!(
        worst_printed > 0.2,
        "printed form only off by {worst_printed}"
    );
    // The tabulated version agrees with the histogram bin by bin too.
    let tab = orientation_from_slope_pdf(rayleigh, h.edges().to_vec()).unwrap();
    for b in h.bins().iter().filter(|b| b.area_fraction > 0.01) {
        let m = tab.mass_between(b.theta_lo, b.theta_hi);
        assert!((b.area_fraction / m - 1.0).abs() < 0.05);
    }
}
