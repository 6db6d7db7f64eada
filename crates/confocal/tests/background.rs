//! The default background threshold is estimated from the stack's own noise (issue 52,
//! item 20): on a stack half surface, half dark background, the background pixels are
//! left out (at the stated rate of one in a thousand) and the surface pixels kept.
//!
//! Noise model of the test stack: every sample is `b + A·g(z − h) + N(0, σ²)`, with
//! `A = 0` on the background half; `g` a Gaussian axial response of FWHM 0.9 µm,
//! slices 0.3 µm apart, `nz` = 40, surface heights `h` in the middle of the stack.
//! Derivation of the expected fractions, from that model alone:
//! * a background pixel passes the threshold `t` iff the largest of its `nz` samples
//!   reaches `t`: `p_bg = 1 − Φ((t − b)/σ)^nz`, which the estimator aims at 1e-3; the
//!   count over `N` background pixels is binomial, and the test allows its mean plus
//!   five standard deviations;
//! * a surface pixel fails iff its brightest sample is below `t`: with `A = 0.5`,
//!   `σ = 0.01`, `t ≈ b + 4.06 σ`, the peak sample `≥ b + A·g(0.15 µm) − 5σ ≈ b + 0.48`
//!   with probability `1 − 3e-7` per pixel: none of the 4096 is lost to the threshold
//!   (they are lost to nothing else either: peaks are well inside the stack and the
//!   log fit's neighbours are ≥ `b + 0.3`).

use flakescatter_confocal::{
    Localiser, MinSignal, PeakOptions, SliceOrder, StackGeometry, noise::FALSE_VALID,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const NX: usize = 128;
const NY: usize = 64;
const NZ: usize = 40;
const DZ: f64 = 0.3;
const B: f64 = 0.05;
const SIGMA: f64 = 0.01;
const A: f64 = 0.5;

fn surface_height(col: usize, row: usize) -> f64 {
    // 4.5 .. 7.2 µm in a stack spanning 0 .. 11.7 µm.
    4.5 + 0.02 * col as f64 + 0.0017 * row as f64
}

/// Localises the test stack (columns < NX/2 surface, the rest background).
fn localise(min_signal: MinSignal) -> flakescatter_confocal::PeakMaps {
    let g = StackGeometry {
        nx: NX,
        ny: NY,
        nz: NZ,
        dx_um: 0.2,
        dy_um: 0.2,
        dz_um: DZ,
        order: SliceOrder::BottomFirst,
    };
    let options = PeakOptions {
        min_signal,
        ..PeakOptions::default()
    };
    let mut loc = Localiser::new(g, options).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(52);
    let noise = Normal::new(0.0, SIGMA).unwrap();
    let w = 0.9;
    for k in 0..NZ {
        let z = k as f64 * DZ;
        let slice: Vec<f32> = (0..NX * NY)
            .map(|i| {
                let (col, row) = (i % NX, i / NX);
                let signal = if col < NX / 2 {
                    let u = z - surface_height(col, row);
                    A * (-4.0 * 2f64.ln() * u * u / (w * w)).exp()
                } else {
                    0.0
                };
                (B + signal + noise.sample(&mut rng)) as f32
            })
            .collect();
        loc.push_slice(&slice).unwrap();
    }
    loc.finish().unwrap()
}

/// Valid pixels of the surface half and of the background half.
fn counts(maps: &flakescatter_confocal::PeakMaps) -> (usize, usize) {
    let mut surface = 0;
    let mut background = 0;
    for row in 0..NY {
        for col in 0..NX {
            if maps.height.get(col, row).is_some() {
                if col < NX / 2 {
                    surface += 1;
                } else {
                    background += 1;
                }
            }
        }
    }
    (surface, background)
}

/// Φ(x) for x ≥ 3, from the asymptotic series of the upper tail (independent of the
/// crate's quantile, which comes from `statrs`).
fn normal_cdf(x: f64) -> f64 {
    // Φ(x) = 1 − φ(x)/x · (1 − 1/x² + 3/x⁴ − 15/x⁶ + 105/x⁸) for x ≥ 3 (error < 1e-4
    // relative in the tail, here 1e-6 absolute at most).
    assert!(x >= 3.0, "{x}");
    let phi = (-x * x / 2.0).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let x2 = x * x;
    1.0 - phi / x
        * (1.0 - 1.0 / x2 + 3.0 / (x2 * x2) - 15.0 / (x2 * x2 * x2) + 105.0 / (x2 * x2 * x2 * x2))
}

#[test]
fn estimated_threshold_drops_the_background_and_keeps_the_surface() {
    let maps = localise(MinSignal::Estimated);
    let t = maps.threshold;
    let e = t.estimate.expect("the default threshold is estimated");
    // The estimators against the model's b and σ. Each pixel's brightest sample and the
    // 3 slices on either side are left out: the surface peaks (FWHM 3 slices) are
    // gone but for their tails (≤ A·e^(−4 ln2 (4/3)²) = 0.004 = 0.4 σ four slices
    // away), and each background pixel loses its largest sample, which narrows the
    // rest a little (the median of 33 samples drops by ~0.04 σ; the MAD of their
    // differences by ~2 %). The MAD of 200 000 differences has a sampling error of
    // ~0.2 %.
    assert!((e.baseline - B).abs() < 0.1 * SIGMA, "{e:?}");
    assert!((e.noise_sd / SIGMA - 1.0).abs() < 0.05, "{e:?}");
    assert_eq!(e.false_valid, FALSE_VALID);
    assert!((t.level - (e.baseline + e.k * e.noise_sd)).abs() < 1e-15);
    // The background pass rate the threshold actually used implies, from the model.
    let p_bg = 1.0 - normal_cdf((t.level - B) / SIGMA).powi(NZ as i32);
    assert!(p_bg < 3e-3, "{p_bg}");
    let n_bg = (NX / 2 * NY) as f64;
    let allowed = n_bg * p_bg + 5.0 * (n_bg * p_bg * (1.0 - p_bg)).sqrt();
    let (surface, background) = counts(&maps);
    assert!(
        (background as f64) <= allowed,
        "{background} background pixels kept, expected at most {allowed:.1} (p = {p_bg:.2e})"
    );
    assert!((background as f64) < 0.01 * n_bg);
    assert_eq!(surface, NX / 2 * NY, "every surface pixel kept");
    assert_eq!(
        maps.report.below_signal
            + maps.report.valid
            + maps.report.first_slice
            + maps.report.last_slice
            + maps.report.not_fittable,
        NX * NY
    );
}

#[test]
fn a_given_level_is_used_as_given() {
    // The old default, 0: background pixels whose brightest sample is not on an end
    // slice (38 of 40 slices, 95 %) and whose fit works are kept — most of them.
    let maps = localise(MinSignal::Level(0.0));
    assert!(maps.threshold.estimate.is_none() && !maps.threshold.too_short);
    assert_eq!(maps.threshold.level, 0.0);
    let (surface, background) = counts(&maps);
    assert_eq!(surface, NX / 2 * NY);
    assert!(
        background as f64 > 0.3 * (NX / 2 * NY) as f64,
        "{background}"
    );
}

#[test]
fn a_stack_too_short_to_measure_its_noise_gets_no_threshold() {
    // 7 slices, half_window 3: every slice lies within 3 of some pixel's maximum, so
    // nothing is left to measure the noise on: threshold 0, and it says so.
    let g = StackGeometry {
        nx: 4,
        ny: 4,
        nz: 7,
        dx_um: 0.2,
        dy_um: 0.2,
        dz_um: DZ,
        order: SliceOrder::BottomFirst,
    };
    let mut loc = Localiser::new(g, PeakOptions::default()).unwrap();
    for k in 0..7 {
        let v = (-((k as f32 - 3.0) / 1.5).powi(2)).exp();
        loc.push_slice(&[v; 16]).unwrap();
    }
    let maps = loc.finish().unwrap();
    assert!(maps.threshold.too_short && maps.threshold.estimate.is_none());
    assert_eq!(maps.threshold.level, 0.0);
    assert!(maps.threshold.to_string().contains("too short"));
    assert_eq!(maps.report.valid, 16);
}
