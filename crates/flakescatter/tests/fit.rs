//! Comparison and fitting against synthetic measurements with a known truth.

use flakescatter::compare::{MeasuredKind, Region, compare, distribution_points};
use flakescatter::fit::{FitSetup, FitWarning, UncertaintyBasis, fit_gaussian, fit_nonparametric};
use flakescatter::gaussian::{DistributionModel, ModelOptions, monte_carlo};
use flakescatter::io::measured::{MeasuredCurve, MeasuredPoint};
use flakescatter::optics::detector::Cone;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{Coating, PipelineError, Settings};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

fn deg(x: f64) -> f64 {
    x.to_radians()
}

/// A noisy "measured" BRDF curve from the Monte Carlo ray tracer (which shares no code
/// with the quadrature the fit uses) with 0.7 % relative noise on top, the instrument's
/// stated uncertainty. Uncertainties combine the 0.7 % and the Monte Carlo error.
fn mc_curve(
    orientation: &Orientation,
    incidences: &[f64],
    samples: u64,
    seed: u64,
) -> MeasuredCurve {
    let n = 1.5;
    let model = DistributionModel::new(orientation.clone(), n, ModelOptions::default()).unwrap();
    let alpha = deg(1.5);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.007).unwrap();
    let mut points = Vec::new();
    let mut line = 2;
    for &ti in incidences {
        let ts: Vec<f64> = (-70..=70).map(|d| deg(f64::from(d))).collect();
        let cones: Vec<Cone> = ts
            .iter()
            .map(|&t| Cone::in_plane(t, alpha).unwrap())
            .collect();
        let inc = model.incidence(deg(ti)).unwrap();
        let est = monte_carlo(&model, &inc, &cones, samples, seed ^ ti.to_bits()).unwrap();
        for ((t, c), e) in ts.iter().zip(&cones).zip(&est) {
            if e.hits < 400 {
                continue;
            }
            let brdf = e.reflectance / c.projected_solid_angle();
            let rel_mc = e.std_err / e.reflectance;
            let value = brdf * (1.0 + noise.sample(&mut rng));
            points.push(MeasuredPoint {
                theta_i: deg(ti),
                theta_s: *t,
                value,
                uncertainty: Some(value * (0.007f64.powi(2) + rel_mc * rel_mc).sqrt()),
                line,
            });
            line += 1;
        }
    }
    MeasuredCurve {
        file: "synthetic.csv".into(),
        points,
    }
}

#[test]
fn gaussian_width_is_recovered_from_a_noisy_monte_carlo_curve() {
    let truth = Orientation::gaussian(GaussianWidth::Hwhm(deg(6.0))).unwrap();
    let measured = mc_curve(&truth, &[30.0, 60.0], 3_000_000, 5);
    let setup = FitSetup::new(
        Coating::default(),
        Settings::default(),
        deg(1.5),
        MeasuredKind::Brdf,
    );
    let fit = fit_gaussian(&measured, &setup, deg(3.0), false).unwrap();
    let got = fit.hwhm.to_degrees();
    assert!((got - 6.0).abs() < 0.2, "hwhm {got}");
    // The reported uncertainty is honest: the truth lies within 4 standard errors.
    assert!(
        (got - 6.0).abs() < 4.0 * fit.hwhm_std.to_degrees() + 0.02,
        "hwhm {got} ± {}",
        fit.hwhm_std.to_degrees()
    );
    assert!(fit.points > 40);
    // The data are absolute BRDFs of a fully covering layer: the scales are 1 within noise.
    for (_, s) in &fit.scales {
        assert!((s - 1.0).abs() < 0.02, "scale {s}");
    }
    // Also with the index free: n comes back near 1.5.
    let fit_n = fit_gaussian(&measured, &setup, deg(3.0), true).unwrap();
    assert!((fit_n.n - 1.5).abs() < 0.1, "n {}", fit_n.n);
    assert!((fit_n.hwhm.to_degrees() - 6.0).abs() < 0.5);
}

/// Tabulated two-component mixture: a fraction `a` of hwhm `w1` and the rest of hwhm `w2`
/// (p̃ as a mixture of the two normalised Gaussians), on 0.25° bins to 60°.
fn mixture(a: f64, w1: f64, w2: f64) -> Orientation {
    let g1 = Orientation::gaussian(GaussianWidth::Hwhm(deg(w1))).unwrap();
    let g2 = Orientation::gaussian(GaussianWidth::Hwhm(deg(w2))).unwrap();
    let edges: Vec<f64> = (0..=240).map(|k| deg(0.25 * f64::from(k))).collect();
    let masses = edges
        .windows(2)
        .map(|e| a * g1.mass_between(e[0], e[1]) + (1.0 - a) * g2.mass_between(e[0], e[1]))
        .collect();
    Orientation::tabulated(edges, masses).unwrap()
}

#[test]
fn nonparametric_inversion_recovers_a_two_component_shape() {
    let truth = mixture(0.6, 3.0, 10.0);
    let measured = mc_curve(&truth, &[30.0, 60.0], 3_000_000, 9);
    let setup = FitSetup::new(
        Coating::default(),
        Settings::default(),
        deg(1.5),
        MeasuredKind::Brdf,
    );
    let edges: Vec<f64> = (0..=15).map(|k| deg(2.0 * f64::from(k))).collect();
    let est = fit_nonparametric(&measured, &setup, &edges, 0.05).unwrap();
    // Compare cumulative area fractions at the bin edges (a shape measure that does not
    // depend on the bin width): the largest deviation is small.
    let mut cum_est = 0.0;
    let mut worst: f64 = 0.0;
    for (b, f) in est.area_fractions.iter().enumerate() {
        cum_est += f;
        let cum_true = truth.mass_between(0.0, edges[b + 1]) / truth.mass_between(0.0, edges[15]);
        worst = worst.max((cum_est - cum_true).abs());
    }
    assert!(worst < 0.06, "largest CDF deviation {worst}");
    // Two components: much more mass beyond 10° than a single Gaussian of the same
    // core width would have (hwhm 3°: < 0.1 % beyond 10°); the truth has about 17 %.
    let beyond10: f64 = est.area_fractions[5..].iter().sum();
    let truth10 = truth.mass_between(deg(10.0), deg(30.0)) / truth.mass_between(0.0, deg(30.0));
    assert!((beyond10 - truth10).abs() < 0.05, "{beyond10} vs {truth10}");
    // A single Gaussian fit to the same data cannot reach the same χ² per point.
    assert!(est.p_tilde[0] > est.p_tilde[6] * 5.0);
}

#[test]
fn compare_finds_a_known_scale_and_zero_residuals() {
    // "Measured" = 0.3 × the model itself (clear coat on, as in comparisons): the
    // fitted scale is 0.3 and every residual vanishes, in all three regions.
    let o = Orientation::gaussian(GaussianWidth::Hwhm(deg(6.0))).unwrap();
    let settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let coating = Coating::default();
    let ts: Vec<f64> = (-70..=70).map(|d| deg(f64::from(d))).collect();
    let mut points = Vec::new();
    for ti in [30.0, 60.0] {
        let m = distribution_points(&coating, &settings, deg(1.5), &o, deg(ti), &ts).unwrap();
        for (k, (t, p)) in ts.iter().zip(&m).enumerate() {
            points.push(MeasuredPoint {
                theta_i: deg(ti),
                theta_s: *t,
                value: 0.3 * p.brdf,
                uncertainty: None,
                line: k as u64 + 2,
            });
        }
    }
    let measured = MeasuredCurve {
        file: "m.csv".into(),
        points,
    };
    let model =
        |ti: f64, ts: &[f64]| distribution_points(&coating, &settings, deg(1.5), &o, ti, ts);
    let cmp = compare(&measured, MeasuredKind::Brdf, &model).unwrap();
    assert_eq!(cmp.len(), 2);
    for c in &cmp {
        assert!((c.scale - 0.3).abs() < 1e-12);
        for r in &c.regions {
            assert!(r.points > 0);
            assert!(r.rms_log10.unwrap() < 1e-12, "{:?}", r);
        }
    }
    // Region boundaries: 5° and 40° from specular.
    assert_eq!(Region::of(deg(30.0), deg(-26.0)), Region::Specular);
    assert_eq!(Region::of(deg(30.0), deg(-25.0)), Region::NearSpecular);
    assert_eq!(Region::of(deg(30.0), deg(10.0)), Region::NearSpecular);
    assert_eq!(Region::of(deg(30.0), deg(10.5)), Region::Far);
}

#[test]
fn unusable_measurements_are_clear_errors() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(deg(6.0))).unwrap();
    let setup = FitSetup::new(
        Coating::default(),
        Settings::default(),
        deg(1.5),
        MeasuredKind::Brdf,
    );
    let pt = |ts: f64, v: f64, line: u64| MeasuredPoint {
        theta_i: deg(30.0),
        theta_s: deg(ts),
        value: v,
        uncertainty: None,
        line,
    };
    // Only specular points: nothing in the fit region.
    let only_spec = MeasuredCurve {
        file: "s.csv".into(),
        points: vec![pt(-30.0, 1.0, 2), pt(-29.0, 0.9, 3)],
    };
    let e = fit_gaussian(&only_spec, &setup, deg(3.0), false).unwrap_err();
    assert!(
        matches!(e, PipelineError::Measurement(_)) && e.to_string().contains("s.csv"),
        "{e}"
    );
    // A negative value in the fit region.
    let neg = MeasuredCurve {
        file: "n.csv".into(),
        points: vec![pt(-20.0, -1.0, 7), pt(-15.0, 1.0, 8)],
    };
    let e = fit_gaussian(&neg, &setup, deg(3.0), false).unwrap_err();
    assert!(e.to_string().contains("line 7"), "{e}");
    let model = |ti: f64, ts: &[f64]| {
        distribution_points(
            &Coating::default(),
            &Settings::default(),
            deg(1.5),
            &o,
            ti,
            ts,
        )
    };
    let e = compare(&neg, MeasuredKind::Brdf, &model).unwrap_err();
    assert!(e.to_string().contains("line 7"), "{e}");
    // One uncertainty of 0 among positive ones (a curve built in code; the reader
    // refuses it too): refused naming the line, not read as "no uncertainties".
    let mut zero = MeasuredCurve {
        file: "z.csv".into(),
        points: (0..6)
            .map(|k: u32| pt(-20.0 + 2.0 * f64::from(k), 1.0, 2 + u64::from(k)))
            .collect(),
    };
    for p in &mut zero.points {
        p.uncertainty = Some(0.05);
    }
    zero.points[3].uncertainty = Some(0.0);
    for e in [
        fit_gaussian(&zero, &setup, deg(3.0), false).unwrap_err(),
        fit_nonparametric(&zero, &setup, &[0.0, deg(10.0), deg(20.0)], 0.1).unwrap_err(),
    ] {
        let e = e.to_string();
        assert!(e.contains("z.csv, line 5, column uncertainty"), "{e}");
    }
    // Too few points for the parameters.
    let few = MeasuredCurve {
        file: "f.csv".into(),
        points: vec![pt(-20.0, 1.0, 2)],
    };
    assert!(fit_gaussian(&few, &setup, deg(3.0), false).is_err());
    // Bad bins.
    assert!(fit_nonparametric(&few, &setup, &[deg(1.0), 0.0], 0.1).is_err());
}

#[test]
fn nonparametric_inversion_of_relative_values() {
    // Relative data (1 at specular per incidence): the columns must use the un-normalised
    // power, the per-incidence scale absorbs the normalisation. Data: the exact model of a
    // known mixture, relative kind.
    let truth = mixture(0.6, 3.0, 10.0);
    let settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let ts: Vec<f64> = (-70..=70).map(|d| deg(f64::from(d))).collect();
    let mut points = Vec::new();
    for ti in [30.0, 60.0] {
        let m = distribution_points(
            &Coating::default(),
            &settings,
            deg(1.5),
            &truth,
            deg(ti),
            &ts,
        )
        .unwrap();
        for (k, (t, p)) in ts.iter().zip(&m).enumerate() {
            points.push(MeasuredPoint {
                theta_i: deg(ti),
                theta_s: *t,
                value: p.relative,
                uncertainty: None,
                line: k as u64 + 2,
            });
        }
    }
    let measured = MeasuredCurve {
        file: "rel.csv".into(),
        points,
    };
    let setup = FitSetup::new(
        Coating::default(),
        settings,
        deg(1.5),
        MeasuredKind::Relative,
    );
    let edges: Vec<f64> = (0..=15).map(|k| deg(2.0 * f64::from(k))).collect();
    let est = fit_nonparametric(&measured, &setup, &edges, 0.05).unwrap();
    // Relative data lose the calibration between incidences (one free scale each), so the
    // wide component is less well pinned than from absolute BRDFs: 0.07 instead of 0.05.
    let beyond10: f64 = est.area_fractions[5..].iter().sum();
    let truth10 = truth.mass_between(deg(10.0), deg(30.0)) / truth.mass_between(0.0, deg(30.0));
    assert!((beyond10 - truth10).abs() < 0.07, "{beyond10} vs {truth10}");
    assert!(est.p_tilde[0] > est.p_tilde[6] * 5.0);
    // A common scale makes no sense for relative data.
    let mut common = setup;
    common.common_scale = true;
    assert!(matches!(
        fit_nonparametric(&measured, &common, &edges, 0.05),
        Err(PipelineError::Measurement(_))
    ));
}

#[test]
fn index_fit_works_at_the_lower_bound() {
    // Data from n = 1 (bare facets): the fit starts at the bound n = 1 and must not step
    // outside it while differentiating.
    let o = Orientation::gaussian(GaussianWidth::Hwhm(deg(5.0))).unwrap();
    let coating = Coating {
        n: 1.0,
        ..Coating::default()
    };
    let ts: Vec<f64> = (-70..=70).map(|d| deg(f64::from(d))).collect();
    let m =
        distribution_points(&coating, &Settings::default(), deg(1.5), &o, deg(30.0), &ts).unwrap();
    let points = ts
        .iter()
        .zip(&m)
        .enumerate()
        .map(|(k, (t, p))| MeasuredPoint {
            theta_i: deg(30.0),
            theta_s: *t,
            value: p.brdf,
            uncertainty: None,
            line: k as u64 + 2,
        })
        .collect();
    let measured = MeasuredCurve {
        file: "n1.csv".into(),
        points,
    };
    let setup = FitSetup::new(coating, Settings::default(), deg(1.5), MeasuredKind::Brdf);
    let fit = fit_gaussian(&measured, &setup, deg(4.0), true).unwrap();
    assert!((fit.n - 1.0).abs() < 1e-3, "n {}", fit.n);
    assert!((fit.hwhm.to_degrees() - 5.0).abs() < 1e-2);
}

#[test]
fn incidences_without_points_in_the_region_get_no_scale() {
    // Points at 60° only in the specular region: only 30° is fitted and gets a scale.
    let o = Orientation::gaussian(GaussianWidth::Hwhm(deg(6.0))).unwrap();
    let ts: Vec<f64> = (-70..=70).map(|d| deg(f64::from(d))).collect();
    let m = distribution_points(
        &Coating::default(),
        &Settings::default(),
        deg(1.5),
        &o,
        deg(30.0),
        &ts,
    )
    .unwrap();
    let mut points: Vec<MeasuredPoint> = ts
        .iter()
        .zip(&m)
        .enumerate()
        .map(|(k, (t, p))| MeasuredPoint {
            theta_i: deg(30.0),
            theta_s: *t,
            value: 2.0 * p.brdf,
            uncertainty: None,
            line: k as u64 + 2,
        })
        .collect();
    points.push(MeasuredPoint {
        theta_i: deg(60.0),
        theta_s: deg(-60.0),
        value: 1.0,
        uncertainty: None,
        line: 999,
    });
    let measured = MeasuredCurve {
        file: "m.csv".into(),
        points,
    };
    let setup = FitSetup::new(
        Coating::default(),
        Settings::default(),
        deg(1.5),
        MeasuredKind::Brdf,
    );
    let fit = fit_gaussian(&measured, &setup, deg(4.0), false).unwrap();
    assert_eq!(fit.scales.len(), 1);
    assert!((fit.scales[0].1 - 2.0).abs() < 1e-6);
}

#[test]
fn points_where_the_model_vanishes_are_counted_not_averaged() {
    // Flakes only within 3° of the normal: far from specular the model is exactly zero.
    let o = Orientation::tabulated(vec![0.0, deg(3.0)], vec![1.0]).unwrap();
    let ts: Vec<f64> = (-70..=70).map(|d| deg(f64::from(d))).collect();
    let points = ts
        .iter()
        .enumerate()
        .map(|(k, t)| MeasuredPoint {
            theta_i: deg(30.0),
            theta_s: *t,
            value: 1.0,
            uncertainty: None,
            line: k as u64 + 2,
        })
        .collect();
    let measured = MeasuredCurve {
        file: "m.csv".into(),
        points,
    };
    let model = |ti: f64, ts: &[f64]| {
        distribution_points(
            &Coating::default(),
            &Settings::default(),
            deg(1.5),
            &o,
            ti,
            ts,
        )
    };
    let cmp = compare(&measured, MeasuredKind::Brdf, &model).unwrap();
    let far = cmp[0]
        .regions
        .iter()
        .find(|r| r.region == Region::Far)
        .unwrap();
    assert!(far.no_model > 0);
    assert!(far.rms_log10.is_none_or(f64::is_finite));
}

/// A "measured" BRDF curve from the distribution model itself (hwhm `w_deg` at 45°,
/// point detectors, aspecular 6°–38° every 2°: 17 points) with log-normal noise of sd
/// `noise` in `ln y`, and stated uncertainties `u = y · stated` (relative).
fn noisy_model_curve(w_deg: f64, noise: f64, stated: f64, seed: u64) -> MeasuredCurve {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(deg(w_deg))).unwrap();
    let ti = deg(45.0);
    let ts: Vec<f64> = (0..17)
        .map(|k| -ti + deg(6.0 + 2.0 * f64::from(k)))
        .collect();
    let pts =
        distribution_points(&Coating::default(), &Settings::default(), 0.0, &o, ti, &ts).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let eps = Normal::new(0.0, noise).unwrap();
    let points = ts
        .iter()
        .zip(&pts)
        .enumerate()
        .map(|(k, (&t, p))| {
            let value = p.brdf * eps.sample(&mut rng).exp();
            MeasuredPoint {
                theta_i: ti,
                theta_s: t,
                value,
                uncertainty: Some(stated * value),
                line: k as u64 + 2,
            }
        })
        .collect();
    MeasuredCurve {
        file: "noisy.csv".into(),
        points,
    }
}

/// Share of `reps` seeded curves whose reported `hwhm ± hwhm_std` (times `k`) covers the
/// truth, with `k = 1/uncertainty_scale` giving the unscaled interval.
fn fit_coverage(w_deg: f64, noise: f64, stated: f64, reps: u64, unscaled: bool) -> f64 {
    let setup = FitSetup::new(
        Coating::default(),
        Settings::default(),
        0.0,
        MeasuredKind::Brdf,
    );
    let mut covered = 0;
    for r in 0..reps {
        let measured = noisy_model_curve(w_deg, noise, stated, 7000 + r);
        let fit = fit_gaussian(&measured, &setup, deg(3.0), false).unwrap();
        let half = if unscaled {
            fit.hwhm_std / fit.uncertainty_scale
        } else {
            fit.hwhm_std
        };
        if (fit.hwhm - deg(w_deg)).abs() <= half {
            covered += 1;
        }
    }
    f64::from(covered) / reps as f64
}

#[test]
fn fit_uncertainty_covers_the_truth_when_stated_uncertainties_are_3x_too_small() {
    // 700 seeded curves, 4 % log-normal noise, uncertainties stated as 4/3 %: χ²/dof ≈ 9,
    // so the covariance is scaled by χ²/dof. With the noise level estimated from dof = 15
    // residuals (17 points, width and scale fitted), (ŵ − w)/std is Student-t with 15
    // dof, so hwhm ± std covers the truth with probability P(|t₁₅| ≤ 1) = 0.6666 (the fit
    // is linear to well within the noise here). Binomial sd for 700 curves: 1.8 %; the
    // tolerance 5.5 % is 3 sd. Unscaled, the interval is 3× too narrow and covers about
    // P(|t| ≤ 1/3) ≈ 26 %.
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let t = StudentsT::new(0.0, 1.0, 15.0).unwrap();
    let want = t.cdf(1.0) - t.cdf(-1.0);
    let cov = fit_coverage(5.0, 0.04, 0.04 / 3.0, 700, false);
    assert!((cov - want).abs() < 0.055, "coverage {cov} vs {want}");
    let raw = fit_coverage(5.0, 0.04, 0.04 / 3.0, 200, true);
    assert!(raw < 0.4, "unscaled coverage {raw}");
    // The result says so.
    let fit = fit_gaussian(
        &noisy_model_curve(5.0, 0.04, 0.04 / 3.0, 1),
        &FitSetup::new(
            Coating::default(),
            Settings::default(),
            0.0,
            MeasuredKind::Brdf,
        ),
        deg(3.0),
        false,
    )
    .unwrap();
    assert_eq!(fit.uncertainty_basis, UncertaintyBasis::StatedScaledByChi2);
    assert!((fit.uncertainty_scale - (fit.chi2 / fit.dof as f64).sqrt()).abs() < 1e-12);
    assert!(
        fit.warnings
            .iter()
            .any(|w| matches!(w, FitWarning::PoorFit { .. })),
        "{:?}",
        fit.warnings
    );
}

#[test]
fn fit_uncertainty_with_honest_stated_uncertainties_is_not_scaled_down() {
    // Stated uncertainties equal to the noise: χ²/dof scatters about 1 and the
    // covariance is scaled only when it exceeds 1, so hwhm ± std covers with probability
    // E[P(|Z| ≤ max(1, S))], S² ~ χ²₁₅/15 (Z the standardised error, independent of S
    // for a linear fit): computed below by quadrature over the χ² density. 500 curves:
    // binomial sd 2.0 %, tolerance 6 %.
    use statrs::distribution::{ChiSquared, Continuous, ContinuousCDF, Normal as SNormal};
    let chi = ChiSquared::new(15.0).unwrap();
    let z = SNormal::new(0.0, 1.0).unwrap();
    let (mut want, steps) = (0.0, 20_000);
    let top = 80.0;
    for i in 0..steps {
        let x = (f64::from(i) + 0.5) * top / f64::from(steps);
        let s = (x / 15.0).sqrt().max(1.0);
        want += chi.pdf(x) * (2.0 * z.cdf(s) - 1.0) * top / f64::from(steps);
    }
    let cov = fit_coverage(5.0, 0.04, 0.04, 500, false);
    assert!((cov - want).abs() < 0.06, "coverage {cov} vs {want}");
    let fit = fit_gaussian(
        &noisy_model_curve(5.0, 0.04, 0.04, 3),
        &FitSetup::new(
            Coating::default(),
            Settings::default(),
            0.0,
            MeasuredKind::Brdf,
        ),
        deg(3.0),
        false,
    )
    .unwrap();
    let expected_basis = if fit.chi2 > fit.dof as f64 {
        UncertaintyBasis::StatedScaledByChi2
    } else {
        UncertaintyBasis::Stated
    };
    assert_eq!(fit.uncertainty_basis, expected_basis);
    assert!(fit.uncertainty_scale >= 1.0);
}

#[test]
fn fit_warnings_flag_poor_fits_bounds_and_few_points() {
    let setup = FitSetup::new(
        Coating::default(),
        Settings::default(),
        0.0,
        MeasuredKind::Brdf,
    );
    // Garbage: values scattered by a factor e^{±2} with 1 % stated uncertainties.
    let garbage = noisy_model_curve(5.0, 2.0, 0.01, 11);
    let fit = fit_gaussian(&garbage, &setup, deg(3.0), false).unwrap();
    assert!(fit.chi2 / fit.dof as f64 > 100.0);
    let poor = fit
        .warnings
        .iter()
        .find(|w| matches!(w, FitWarning::PoorFit { .. }));
    assert!(poor.is_some(), "{:?}", fit.warnings);
    assert!(poor.unwrap().to_string().contains("chi2/dof"));
    // Its uncertainty grew with sqrt(χ²/dof) (≈ 200/1 here): no more "± 0.036°" on
    // garbage.
    assert!(fit.uncertainty_scale > 10.0);
    // Without uncertainty columns the rms log residual is the criterion (threshold 0.3).
    let mut no_u = garbage.clone();
    for p in &mut no_u.points {
        p.uncertainty = None;
    }
    let fit = fit_gaussian(&no_u, &setup, deg(3.0), false).unwrap();
    assert_eq!(fit.uncertainty_basis, UncertaintyBasis::ResidualScatter);
    assert!(fit.warnings.iter().any(|w| matches!(
        w,
        FitWarning::PoorFit {
            uncertainties_given: false,
            ..
        }
    )));
    // A clean, much wider curve than the search range allows (60°): at the bound.
    let wide = noisy_model_curve(75.0, 0.001, 0.001, 12);
    let fit = fit_gaussian(&wide, &setup, deg(10.0), false).unwrap();
    assert!(
        fit.warnings.iter().any(|w| matches!(
            w,
            FitWarning::AtBound {
                parameter: "hwhm",
                ..
            }
        )),
        "{:?} at {}°",
        fit.warnings,
        fit.hwhm.to_degrees()
    );
    // Four points for two parameters (width and scale): fewer than 3 per parameter.
    let mut few = noisy_model_curve(5.0, 0.01, 0.01, 13);
    few.points.truncate(4);
    let fit = fit_gaussian(&few, &setup, deg(3.0), false).unwrap();
    assert!(fit.warnings.contains(&FitWarning::FewPoints {
        points: 4,
        parameters: 2
    }));
    // A good fit has none.
    let good = noisy_model_curve(5.0, 0.01, 0.01, 14);
    let fit = fit_gaussian(&good, &setup, deg(3.0), false).unwrap();
    assert!(fit.warnings.is_empty(), "{:?}", fit.warnings);
}
