//! The joint fit against data made from the paint model itself: exact data give the
//! parameters back, noisy data give them back within their 95 % intervals as often as
//! the intervals claim (200 draws), and the fit's fast evaluator is the model's BRDF.

use flakescatter_paint::fit::{
    Family, FitOptions, Measurement, Observation, Selection, evaluate, fit_paint,
};
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
use flakescatter_stats::Orientation;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The true paint: Trowbridge–Reitz flakes (α = 0.12) at coverage 0.5, a slightly rough
/// coat with haze, two channels.
fn truth() -> PaintParams {
    PaintParams {
        coat: CoatParams {
            n: 1.5,
            roughness: 0.02,
            haze: 0.2,
            haze_roughness: 0.3,
        },
        orientation: Orientation::trowbridge_reitz(0.12).unwrap(),
        coverage: 0.5,
        flake_metal: FlakeMetal::Aluminium,
        channels: vec![
            ChannelParams {
                channel: Channel::parse("g").unwrap(),
                flake_scale: 0.6,
                base_albedo: 0.2,
                tint: 0.0,
            },
            ChannelParams {
                channel: Channel::parse("b").unwrap(),
                flake_scale: 0.4,
                base_albedo: 0.6,
                tint: 0.0,
            },
        ],
    }
}

/// A goniometer grid: incidences 20°, 45°, 65°; in-plane detectors every 4° on both
/// sides up to 80°; out-of-plane detectors at 30°, 60° azimuth every 10° of polar angle.
fn geometry() -> Vec<(f64, f64, f64)> {
    let mut g = Vec::new();
    for ti in [20.0, 45.0, 65.0] {
        for tr in (0..=20).map(|k| 4.0 * f64::from(k)) {
            g.push((ti, tr, 0.0));
            if tr > 0.0 {
                g.push((ti, tr, 180.0));
            }
        }
        for phi in [30.0, 60.0] {
            for tr in (1..=8).map(|k| 10.0 * f64::from(k)) {
                g.push((ti, tr, phi));
            }
        }
    }
    g
}

/// The table the model of `params` predicts on [`geometry`], each value multiplied by
/// `noise()` and given the uncertainty `u·value` when `u` is set.
fn table(params: &PaintParams, mut noise: impl FnMut() -> f64, u: Option<f64>) -> Measurement {
    let model = PaintModel::new(params.clone()).unwrap();
    let rows = geometry()
        .into_iter()
        .enumerate()
        .map(|(line, (ti, tr, pr))| {
            let inc = model.incidence(f64::to_radians(ti)).unwrap();
            let o = Observation {
                theta_i: ti.to_radians(),
                theta_r: tr.to_radians(),
                phi_r: f64::to_radians(pr),
                values: vec![],
                uncertainties: vec![],
                line: line as u64 + 2,
            };
            let r = o.direction();
            let values: Vec<f64> = (0..2).map(|k| model.brdf(&inc, &r, k) * noise()).collect();
            Observation {
                uncertainties: values.iter().map(|v| u.map(|u| u * v)).collect(),
                values,
                ..o
            }
        })
        .collect();
    Measurement {
        file: "synthetic".into(),
        channels: params.channels.iter().map(|c| c.channel.clone()).collect(),
        rows,
    }
}

fn options() -> FitOptions {
    FitOptions {
        families: vec![Family::TrowbridgeReitz],
        ..FitOptions::new()
    }
}

/// The true values of the fitted parameters, in the fit's own (logarithmic) units and
/// order: ln α, ln coat roughness, haze, ln haze roughness, ln(c s_k), ln((1−c)² ρ_k).
fn true_fitted(p: &PaintParams) -> Vec<f64> {
    let c = p.coverage;
    let mut v = vec![
        0.12f64.ln(),
        p.coat.roughness.ln(),
        p.coat.haze,
        p.coat.haze_roughness.ln(),
    ];
    v.extend(p.channels.iter().map(|ch| (c * ch.flake_scale).ln()));
    v.extend(
        p.channels
            .iter()
            .map(|ch| ((1.0 - c) * (1.0 - c) * ch.base_albedo).ln()),
    );
    v
}

#[test]
fn exact_data_give_the_parameters_back() {
    let p = truth();
    let m = table(&p, || 1.0, None);
    let fit = fit_paint(&m, &options()).unwrap();
    let want = true_fitted(&p);
    for (e, w) in fit.fitted.iter().zip(&want) {
        assert!((e.value - w).abs() < 1e-5, "{}: {} vs {w}", e.name, e.value);
    }
    assert!(fit.evidence.chi2 < 1e-12, "chi2 {}", fit.evidence.chi2);
    // The coverage interval contains the truth and the scales at its middle reproduce
    // the same amplitudes.
    assert!(fit.coverage.min <= 0.5 && 0.5 <= fit.coverage.max);
    let c = fit.coverage.used;
    for (k, ch) in fit.params.channels.iter().enumerate() {
        assert!((c * ch.flake_scale - 0.5 * p.channels[k].flake_scale).abs() < 1e-6);
    }
}

/// The fit's evaluator (cached kernels and tables) against the model's own BRDF at the
/// points, for the fitted parameters.
#[test]
fn the_fits_evaluator_is_the_model() {
    let p = truth();
    let m = table(&p, || 1.0, None);
    let fit = fit_paint(&m, &options()).unwrap();
    let model = PaintModel::new(fit.params.clone()).unwrap();
    let (points, values) = evaluate(&model, &m, &Selection::default()).unwrap();
    assert_eq!(points, fit.points);
    for (a, b) in values.iter().zip(&fit.model) {
        assert!((a - b).abs() <= 1e-12 * a.abs(), "{a} vs {b}");
    }
}

/// 5 % multiplicative noise with its stated uncertainty, 200 draws: each parameter's
/// 95 % interval must contain the truth in 95 % of them. With 200 draws the count is
/// binomial (mean 190, sd 3.1); the test accepts 181–200, which a correct interval
/// misses with probability 0.2 % per parameter.
#[test]
fn intervals_cover_the_truth_as_claimed() {
    let p = truth();
    let want = true_fitted(&p);
    let mut covered = vec![0usize; want.len()];
    let draws = 200;
    let normal: Normal<f64> = Normal::new(0.0, 0.05).unwrap();
    for seed in 0..draws {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
        let m = table(&p, || normal.sample(&mut rng).exp(), Some(0.05));
        let fit = fit_paint(&m, &options()).unwrap();
        for (j, e) in fit.fitted.iter().enumerate() {
            if e.lo95 <= want[j] && want[j] <= e.hi95 {
                covered[j] += 1;
            }
        }
    }
    let names: Vec<String> = fit_paint(&table(&p, || 1.0, Some(0.05)), &options())
        .unwrap()
        .fitted
        .iter()
        .map(|e| e.name.clone())
        .collect();
    eprintln!("covered {covered:?} of {draws} for {names:?}");
    for (j, c) in covered.iter().enumerate() {
        assert!(
            (181..=200).contains(c),
            "{}: covered {c} of {draws} (all: {covered:?})",
            names[j]
        );
    }
}
