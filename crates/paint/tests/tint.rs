//! The binder's tint over the flakes (physics.md §12.9): the flake term's factor against
//! Beer–Lambert along the refracted path worked out here from Snell's law, the
//! directional albedo against the bounds that factor puts on it, and a table made with
//! known tints fitted back.

use flakescatter_optics::Vec3;
use flakescatter_paint::fit::{
    Family, FitExtras, FitOptions, Measurement, Observation, Selection, evaluate, fit_paint_with,
};
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
use flakescatter_stats::Orientation;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const TINTS: [f64; 3] = [0.05, 0.15, 0.4];

/// Trowbridge–Reitz flakes (α = 0.12) at coverage 0.5 under a slightly rough, hazy coat
/// of index `n`; channels r, g, b with the tints `tints`.
fn paint(n: f64, tints: [f64; 3]) -> PaintParams {
    let scales = [0.7, 0.6, 0.4];
    let albedos = [0.3, 0.2, 0.6];
    PaintParams {
        coat: CoatParams {
            n,
            roughness: 0.02,
            haze: 0.2,
            haze_roughness: 0.3,
        },
        orientation: Orientation::trowbridge_reitz(0.12).unwrap(),
        coverage: 0.5,
        flake_metal: FlakeMetal::Aluminium,
        channels: ["r", "g", "b"]
            .iter()
            .enumerate()
            .map(|(k, c)| ChannelParams {
                channel: Channel::parse(c).unwrap(),
                flake_scale: scales[k],
                base_albedo: albedos[k],
                tint: tints[k],
            })
            .collect(),
    }
}

/// The exit direction of polar angle `tr` and azimuth `pr` (degrees).
fn dir(tr: f64, pr: f64) -> Vec3 {
    let (t, p) = (tr.to_radians(), pr.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Cosine of the refracted angle inside a binder of index `n` for a ray at polar angle
/// `theta` outside: Snell, `sin θ' = sin θ / n`.
fn snell_cos(theta: f64, n: f64) -> f64 {
    let s = theta.sin() / n;
    (1.0 - s * s).sqrt()
}

/// (a) Flake term with tint over the flake term without = `exp(−t (1/μt + 1/μ2))`, μ
/// from Snell's law; the coat and base terms unchanged to the bit.
#[test]
fn the_flake_term_is_attenuated_along_the_refracted_path() {
    for n in [1.5, 1.33] {
        let clear = PaintModel::new(paint(n, [0.0; 3])).unwrap();
        let tinted = PaintModel::new(paint(n, TINTS)).unwrap();
        for ti in [0.0, 20.0, 45.0, 70.0, 85.0] {
            let (ic, it) = (
                clear.incidence(f64::to_radians(ti)).unwrap(),
                tinted.incidence(f64::to_radians(ti)).unwrap(),
            );
            for (tr, pr) in [
                (0.0, 0.0),
                (ti, 0.0),
                (ti + 10.0, 0.0),
                (30.0, 180.0),
                (60.0, 45.0),
                (80.0, 120.0),
                (89.0, 10.0),
            ] {
                if tr >= 90.0 {
                    continue;
                }
                let r = dir(tr, pr);
                let mu_t = snell_cos(ti.to_radians(), n);
                let mu_2 = snell_cos(tr.to_radians(), n);
                for (k, t) in TINTS.iter().enumerate() {
                    let (a, b) = (clear.terms(&ic, &r, k), tinted.terms(&it, &r, k));
                    assert!(a.flakes > 0.0, "θi {ti} θr {tr} φr {pr}");
                    let want = (-t * (1.0 / mu_t + 1.0 / mu_2)).exp();
                    let got = b.flakes / a.flakes;
                    assert!(
                        (got - want).abs() <= 1e-12 * want,
                        "n {n} θi {ti} θr {tr} φr {pr} t {t}: {got} vs {want}"
                    );
                    assert_eq!((a.coat, a.base), (b.coat, b.base));
                }
            }
        }
    }
}

/// Directional albedo of the flake term (and the whole BRDF) by a midpoint rule over the
/// hemisphere in `(cos θo, φo)`.
fn albedo(model: &PaintModel, ti: f64, k: usize) -> (f64, f64) {
    let inc = model.incidence(ti.to_radians()).unwrap();
    let (nm, np) = (400, 360);
    let (mut flakes, mut total) = (0.0, 0.0);
    for i in 0..nm {
        let mu = (i as f64 + 0.5) / nm as f64;
        let s = (1.0 - mu * mu).sqrt();
        for j in 0..np {
            let p = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
            let r = Vec3::new(s * p.cos(), s * p.sin(), mu);
            let t = model.terms(&inc, &r, k);
            let w = mu / nm as f64 * std::f64::consts::TAU / np as f64;
            flakes += t.flakes * w;
            total += t.total() * w;
        }
    }
    (flakes, total)
}

/// (b) The tint only takes light away: the tinted flake albedo lies between the
/// untinted one times `exp(−t (1/μt + n/√(n² − 1)))` (the longest exit path, at
/// grazing exit) and times `exp(−t (1/μt + 1))` (the shortest, straight up), and the
/// whole directional albedo stays below the untinted one and below 1 (§12.4).
#[test]
fn the_tint_only_takes_light_away() {
    let n = 1.5;
    let clear = PaintModel::new(paint(n, [0.0; 3])).unwrap();
    let tinted = PaintModel::new(paint(n, TINTS)).unwrap();
    for ti in [15.0, 45.0, 75.0] {
        let mu_t = snell_cos(f64::to_radians(ti), n);
        for (k, t) in TINTS.iter().enumerate() {
            let (fa, ta) = albedo(&clear, ti, k);
            let (fb, tb) = albedo(&tinted, ti, k);
            let lo = fa * (-t * (1.0 / mu_t + n / (n * n - 1.0).sqrt())).exp();
            let hi = fa * (-t * (1.0 / mu_t + 1.0)).exp();
            assert!(lo < fb && fb < hi, "θi {ti} t {t}: {lo} < {fb} < {hi}");
            assert!(
                tb < ta && ta <= 1.0 + 2e-4,
                "θi {ti} t {t}: {tb} < {ta} <= 1"
            );
            assert!(
                (ta - tb - (fa - fb)).abs() < 1e-12,
                "only the flake term changes"
            );
        }
    }
}

/// A goniometer grid: incidences 20°, 45°, 65°; in-plane detectors every 4° on both
/// sides up to 80°; out-of-plane detectors at 30°, 60° azimuth every 10° of polar angle.
fn table(params: &PaintParams, mut noise: impl FnMut() -> f64, u: Option<f64>) -> Measurement {
    let model = PaintModel::new(params.clone()).unwrap();
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
    let rows = g
        .into_iter()
        .enumerate()
        .map(|(line, (ti, tr, pr)): (usize, (f64, f64, f64))| {
            let inc = model.incidence(ti.to_radians()).unwrap();
            let o = Observation {
                theta_i: ti.to_radians(),
                theta_r: tr.to_radians(),
                phi_r: pr.to_radians(),
                values: vec![],
                uncertainties: vec![],
                line: line as u64 + 2,
            };
            let r = o.direction();
            let values: Vec<f64> = (0..3).map(|k| model.brdf(&inc, &r, k) * noise()).collect();
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

/// (c) A table made with tints 0.05, 0.15, 0.4 is fitted back to them (exact data:
/// within 1e-4, χ² ~ 0), the fitted paint's channels carry them, and the fit's own
/// evaluator is the model's BRDF with them (1e-12). With 3 % noise and its stated
/// uncertainty (one fixed draw) the 95 % intervals contain them.
#[test]
fn known_tints_are_fitted_back() {
    let p = paint(1.5, TINTS);
    let m = table(&p, || 1.0, None);
    let fit = fit_paint_with(&m, &options(), FitExtras { tint: true }).unwrap();
    assert!(fit.evidence.chi2 < 1e-10, "chi2 {}", fit.evidence.chi2);
    for (k, (c, want)) in ["r", "g", "b"].iter().zip(TINTS).enumerate() {
        let e = fit
            .physical
            .iter()
            .find(|e| e.name == format!("tint {c}"))
            .unwrap();
        assert!(
            (e.value - want).abs() < 1e-4,
            "{}: {} vs {want}",
            e.name,
            e.value
        );
        assert!((fit.params.channels[k].tint - want).abs() < 1e-4);
        assert!(fit.fitted.iter().any(|f| f.name == format!("tint {c}")));
    }
    let model = PaintModel::new(fit.params.clone()).unwrap();
    let (points, values) = evaluate(&model, &m, &Selection::default()).unwrap();
    assert_eq!(points, fit.points);
    for (a, b) in values.iter().zip(&fit.model) {
        assert!((a - b).abs() <= 1e-12 * a.abs(), "{a} vs {b}");
    }

    let normal: Normal<f64> = Normal::new(0.0, 0.03).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let m = table(&p, || normal.sample(&mut rng).exp(), Some(0.03));
    let fit = fit_paint_with(&m, &options(), FitExtras { tint: true }).unwrap();
    for (c, want) in ["r", "g", "b"].iter().zip(TINTS) {
        let e = fit
            .physical
            .iter()
            .find(|e| e.name == format!("tint {c}"))
            .unwrap();
        eprintln!("{}: {} ({} to {})", e.name, e.value, e.lo95, e.hi95);
        assert!(e.lo95 <= want && want <= e.hi95, "{e:?} vs {want}");
        assert!(
            e.hi95 - e.lo95 < 0.5,
            "an interval that says something: {e:?}"
        );
    }
}

/// Without the extra parameters the fit is the plain one, and a table without tint
/// fitted with it gives tints at (or near) 0.
#[test]
fn an_untinted_table_gives_no_tint() {
    let p = paint(1.5, [0.0; 3]);
    let m = table(&p, || 1.0, None);
    let plain = fit_paint_with(&m, &options(), FitExtras::default()).unwrap();
    assert!(plain.physical.iter().all(|e| !e.name.starts_with("tint")));
    assert!(plain.params.channels.iter().all(|c| c.tint == 0.0));
    let fit = fit_paint_with(&m, &options(), FitExtras { tint: true }).unwrap();
    for c in &fit.params.channels {
        assert!(c.tint < 1e-4, "{}: {}", c.channel.name, c.tint);
    }
}

/// A tint that is negative or not finite is refused, naming the channel; a fitted
/// tint with no flakes (coverage 0) is refused before any work.
#[test]
fn a_bad_tint_is_refused() {
    let m = table(&paint(1.5, [0.0; 3]), || 1.0, None);
    let o = FitOptions {
        coverage: Some(0.0),
        ..options()
    };
    let e = fit_paint_with(&m, &o, FitExtras { tint: true }).unwrap_err();
    assert!(
        e.to_string().contains("a fitted tint with coverage 0"),
        "{e}"
    );
    for t in [-0.1, f64::NAN, f64::INFINITY] {
        let mut p = paint(1.5, [0.0; 3]);
        p.channels[1].tint = t;
        let e = PaintModel::new(p).unwrap_err().to_string();
        assert!(e.contains("tint of channel `g`"), "{t}: {e}");
    }
}
