//! Random parts of the generator against their requested laws: orientations,
//! roughness, quantisation, intensity levels.

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{
    Disc, FlakeAmount, LayerParams, LayerSpec, generate, generate_from_discs, place_flakes,
};
use nalgebra::{Unit, Vector3};

/// CDF of θn for `p(θ) ∝ sin θ exp(-θ²/(2 s²))` on `[0, π/2)`, by composite Simpson
/// written here (independent of the stats crate's normalisation).
fn gaussian_theta_cdf(s: f64) -> impl Fn(f64) -> f64 {
    let f = move |t: f64| t.sin() * (-t * t / (2.0 * s * s)).exp();
    let simpson = move |b: f64| {
        let n = 2000;
        let h = b / n as f64;
        let mut acc = f(0.0) + f(b);
        for k in 1..n {
            acc += f(k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        acc * h / 3.0
    };
    let total = simpson(FRAC_PI_2);
    move |t| simpson(t.min(FRAC_PI_2)) / total
}

/// Weighted Kolmogorov–Smirnov distance between samples (value, weight) and a CDF.
fn ks_distance(mut s: Vec<(f64, f64)>, cdf: impl Fn(f64) -> f64) -> (f64, f64) {
    s.sort_by(|a, b| a.0.total_cmp(&b.0));
    let w: f64 = s.iter().map(|p| p.1).sum();
    let w2: f64 = s.iter().map(|p| p.1 * p.1).sum();
    let mut acc = 0.0;
    let mut d: f64 = 0.0;
    for (x, wi) in &s {
        let f = cdf(*x);
        d = d.max((f - acc / w).abs());
        acc += wi;
        d = d.max((acc / w - f).abs());
    }
    // Effective sample size of a weighted sample (Kish).
    (d, w * w / w2)
}

#[test]
fn area_weighted_normals_follow_the_requested_gaussian() {
    let s = 6f64.to_radians() / (2.0 * 2f64.ln()).sqrt();
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(64, 64, o, 2024);
    spec.amount = FlakeAmount::Count(20_000);
    let discs = place_flakes(&LayerParams::new(spec).unwrap());
    assert_eq!(discs.len(), 20_000);
    // Weighted by true area, the θn distribution must be p (diameters are independent of
    // normals, so the weights do not bias it).
    let sample: Vec<(f64, f64)> = discs
        .iter()
        .map(|d| (d.normal.z.acos(), d.true_area_um2()))
        .collect();
    let (d, n_eff) = ks_distance(sample, gaussian_theta_cdf(s));
    // KS critical value at α = 0.001: 1.95 / sqrt(n).
    assert!(d < 1.95 / n_eff.sqrt(), "theta: D = {d}, n_eff = {n_eff}");
    // Azimuths uniform on [0, 2π).
    let phis: Vec<(f64, f64)> = discs
        .iter()
        .map(|d| (d.normal.y.atan2(d.normal.x).rem_euclid(2.0 * PI), 1.0))
        .collect();
    let (d, n) = ks_distance(phis, |p| p / (2.0 * PI));
    assert!(d < 1.95 / n.sqrt(), "phi: D = {d}");
    // Positions uniform over the placement region (map plus half the largest diameter,
    // 3 × 16 / 2 = 24 µm, on each side); heights uniform over where each flake fits in
    // the 38 µm film (the film rule): a disc tilted by θ spans t cos θ + d sin θ, half of
    // it h above and below its centre, so (z − h)/(38 − 2h) is uniform on [0, 1] and
    // every flake lies inside [0, 38].
    let (lo, w) = (-0.09 - 24.0, 64.0 * 0.18 + 48.0);
    let xs: Vec<(f64, f64)> = discs.iter().map(|d| (d.centre_x_um, 1.0)).collect();
    let (d, n) = ks_distance(xs, |x| ((x - lo) / w).clamp(0.0, 1.0));
    assert!(d < 1.95 / n.sqrt(), "x: D = {d}");
    let half = |d: &Disc| {
        let nz = d.normal.z;
        0.5 * (d.thickness_um * nz + d.diameter_um * (1.0 - nz * nz).sqrt())
    };
    for d in &discs {
        let h = half(d);
        assert!(
            d.centre_z_um - h >= -1e-9 && d.centre_z_um + h <= 38.0 + 1e-9,
            "{d:?}"
        );
    }
    let us: Vec<(f64, f64)> = discs
        .iter()
        .map(|d| ((d.centre_z_um - half(d)) / (38.0 - 2.0 * half(d)), 1.0))
        .collect();
    let (d, n) = ks_distance(us, |u| u.clamp(0.0, 1.0));
    assert!(d < 1.95 / n.sqrt(), "z: D = {d}");
}

#[test]
fn diameters_follow_the_lognormal_and_coverage_is_met() {
    let mut spec = LayerSpec::new(512, 512, Orientation::flat(), 5);
    spec.amount = FlakeAmount::Coverage(2.0);
    let params = LayerParams::new(spec).unwrap();
    let discs = place_flakes(&params);
    // Log-normal with mean 16, relative sd 0.25: ln d ~ N(μ, σ²), σ² = ln(1.0625).
    let var = 1.0625f64.ln();
    let (mu, sd) = (16f64.ln() - var / 2.0, var.sqrt());
    let logs: Vec<(f64, f64)> = discs.iter().map(|d| (d.diameter_um.ln(), 1.0)).collect();
    let normal_cdf = |x: f64| 0.5 * erfc(-(x - mu) / (sd * 2f64.sqrt()));
    let (d, n) = ks_distance(logs, normal_cdf);
    assert!(d < 1.95 / n.sqrt(), "ln d: D = {d}, n = {n}");
    // Coverage: Σ π d²/4 first reaches 2 × placement area (92.16 + 48 µm square).
    let region = (512.0 * 0.18 + 48.0f64).powi(2);
    let total: f64 = discs.iter().map(Disc::true_area_um2).sum();
    let last = discs.last().unwrap().true_area_um2();
    assert!(total >= 2.0 * region && total - last < 2.0 * region);
}

/// Complementary error function (Numerical Recipes `erfcc`, |rel. error| < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

#[test]
fn roughness_has_the_requested_rms_and_correlation_length() {
    // One flat disc far larger than the map: every pixel shows its face at z = 5.5 µm,
    // so height - 5.5 is the roughness field itself.
    let (nx, ny, dx, dy) = (1024, 640, 0.18, 0.3);
    let (rms, ell) = (0.1, 1.8);
    let mut spec = LayerSpec::new(nx, ny, Orientation::flat(), 77);
    spec.dx_um = dx;
    spec.dy_um = dy;
    spec.confocal.z_step_um = 0.0;
    spec.roughness.rms_um = rms;
    spec.roughness.correlation_um = ell;
    let params = LayerParams::new(spec).unwrap();
    let big = Disc {
        centre_x_um: 90.0,
        centre_y_um: 90.0,
        centre_z_um: 5.0,
        diameter_um: 1000.0,
        thickness_um: 1.0,
        normal: Unit::new_normalize(Vector3::z()),
    };
    let layer = generate_from_discs(&params, &[big]).unwrap();
    let f: Vec<f64> = layer.height.heights().iter().map(|z| z - 5.5).collect();
    let area = nx as f64 * dx * ny as f64 * dy;
    // For C(r) = σ² exp(-r²/ℓ²), the mean square over area A has variance
    // (2/A) ∫ C² dA = σ⁴ π ℓ² / A, i.e. relative sd sqrt(π ℓ² / A) (≈ 1.6 % here).
    let rel = (PI * ell * ell / area).sqrt();
    let ms = f.iter().map(|v| v * v).sum::<f64>() / f.len() as f64;
    assert!(
        (ms / (rms * rms) - 1.0).abs() < 4.0 * rel,
        "mean square {ms}"
    );
    // Normalised autocorrelation at lag ℓ must be 1/e along both axes (ℓ is 10 px along
    // x and 6 px along y), and e^-4 at 2ℓ along x. The estimates scatter by about the
    // same relative amount as the mean square.
    let acf = |lx: usize, ly: usize| {
        let mut s = 0.0;
        let mut n = 0usize;
        for r in 0..ny - ly {
            for c in 0..nx - lx {
                s += f[r * nx + c] * f[(r + ly) * nx + c + lx];
                n += 1;
            }
        }
        s / n as f64 / ms
    };
    let e1 = (-1.0f64).exp();
    let tol = 4.0 * rel;
    assert!((acf(10, 0) - e1).abs() < tol, "x lag ℓ: {}", acf(10, 0));
    assert!((acf(0, 6) - e1).abs() < tol, "y lag ℓ: {}", acf(0, 6));
    assert!(
        (acf(20, 0) - (-4.0f64).exp()).abs() < tol,
        "x lag 2ℓ: {}",
        acf(20, 0)
    );
    // And about 0.78 = exp(-1/4) at ℓ/2 (5 px).
    assert!(
        (acf(5, 0) - (-0.25f64).exp()).abs() < tol,
        "x lag ℓ/2: {}",
        acf(5, 0)
    );
}

fn default_layer(seed: u64, f: impl FnOnce(&mut LayerSpec)) -> flakescatter_synth::SyntheticLayer {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(256, 200, o, seed);
    f(&mut spec);
    generate(&LayerParams::new(spec).unwrap()).unwrap()
}

#[test]
fn quantised_heights_are_multiples_of_the_step_and_close_to_the_exact_ones() {
    let rough = |s: &mut LayerSpec| {
        s.roughness.rms_um = 0.05;
        s.confocal.psf_sd_um = 0.1;
    };
    let q = default_layer(9, rough);
    let exact = default_layer(9, |s| {
        rough(s);
        s.confocal.z_step_um = 0.0;
    });
    for (a, b) in q.height.heights().iter().zip(exact.height.heights()) {
        let k = a / 0.3;
        assert!((k - k.round()).abs() < 1e-9, "{a} is not a multiple of 0.3");
        assert!((a - b).abs() <= 0.15 + 1e-9, "{a} vs {b}");
    }
}

#[test]
fn height_noise_has_the_requested_sd() {
    let base = default_layer(4, |s| s.confocal.z_step_um = 0.0);
    let noisy = default_layer(4, |s| {
        s.confocal.z_step_um = 0.0;
        s.confocal.noise_sd_um = 0.2;
    });
    let d: Vec<f64> = noisy
        .height
        .heights()
        .iter()
        .zip(base.height.heights())
        .map(|(a, b)| a - b)
        .collect();
    let n = d.len() as f64;
    let ms = d.iter().map(|v| v * v).sum::<f64>() / n;
    // Independent N(0, 0.04) draws: the mean square has relative sd sqrt(2/n) ≈ 0.6 %.
    assert!((ms / 0.04 - 1.0).abs() < 4.0 * (2.0 / n).sqrt(), "{ms}");
}

#[test]
fn intensity_separates_flakes_from_background_at_the_midpoint() {
    let layer = default_layer(12, |_| {});
    let cutoff = 0.5 * (0.9 + 0.08);
    let mut bright = 0;
    for (v, l) in layer.intensity.heights().iter().zip(&layer.labels) {
        assert!(
            (v * 255.0 - (v * 255.0).round()).abs() < 1e-9,
            "8-bit levels"
        );
        assert!((0.0..=1.0).contains(v));
        // Levels 0.9 and 0.08 with noise sd 0.03 lie 13.7 sd from the midpoint.
        assert_eq!(*v >= cutoff, *l != 0);
        bright += usize::from(*l != 0);
    }
    // Flat-ish flakes dropped at random with coverage 1.5 cover about 1 - e^-1.5 = 0.78 of
    // the map (a Boolean model); the map holds few flakes, so only a loose check.
    let frac = bright as f64 / layer.labels.len() as f64;
    assert!((0.5..0.95).contains(&frac), "{frac}");
}

#[test]
fn truth_table_is_consistent_with_the_label_map() {
    let layer = default_layer(21, |_| {});
    let labelled = layer.labels.iter().filter(|&&l| l != 0).count();
    let visible: usize = layer.truth.iter().map(|f| f.visible_pixels).sum();
    assert_eq!(labelled, visible);
    for (k, f) in layer.truth.iter().enumerate() {
        assert_eq!(f.id as usize, k + 1);
        let count = layer.labels.iter().filter(|&&l| l == f.id).count();
        assert_eq!(count, f.visible_pixels);
        let proj = count as f64 * 0.18 * 0.18;
        assert!((f.visible_projected_area_um2 - proj).abs() < 1e-9);
        assert!((f.visible_true_area_um2 - proj / f.normal.z).abs() < 1e-9);
        assert!((f.depth_um - (38.0 - f.centre_z_um)).abs() < 1e-12);
        assert!((f.theta_n.cos() - f.normal.z).abs() < 1e-12);
        assert!(f.visible_true_area_um2 <= f.true_area_um2 * 1.05 + 1.0);
    }
}
