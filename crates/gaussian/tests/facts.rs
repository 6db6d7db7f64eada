//! The distribution model against closed forms and the published facts of physics.md §4.

use std::f64::consts::PI;

use flakescatter_gaussian::hemisphere::{total_detector_space, totals_normal_space};
use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelError, ModelOptions};
use flakescatter_optics::detector::{Cone, in_plane_direction};
use flakescatter_optics::fresnel;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::{GaussianWidth, Orientation};

fn model(n: f64, hwhm_deg: f64, options: ModelOptions) -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
    DistributionModel::new(o, n, options).unwrap()
}

/// In-plane collected power per sr for a point detector: BRDF × cos θs.
fn power(m: &DistributionModel, theta_i: f64, theta_s: f64) -> f64 {
    let inc = m.incidence(theta_i).unwrap();
    let r = in_plane_direction(theta_s);
    m.brdf(&inc, &r.into_inner()) * r.z
}

/// Golden-section maximum of `g` on `[a, b]` (unimodal there).
fn argmax(g: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let k = (5f64.sqrt() - 1.0) / 2.0;
    while b - a > 1e-10 {
        let c = b - k * (b - a);
        let d = a + k * (b - a);
        if g(c) < g(d) {
            a = c;
        } else {
            b = d;
        }
    }
    0.5 * (a + b)
}

/// The point where `g` crosses `level` between `a` (above) and `b` (below), by bisection.
fn crossing(g: impl Fn(f64) -> f64, level: f64, mut a: f64, mut b: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (a + b);
        if g(mid) > level {
            a = mid;
        } else {
            b = mid;
        }
    }
    0.5 * (a + b)
}

fn fwhm(g: impl Fn(f64) -> f64 + Copy, peak: f64, lo: f64, hi: f64) -> f64 {
    let half = 0.5 * g(peak);
    crossing(g, half, peak, hi) - crossing(g, half, peak, lo)
}

#[test]
fn bare_facets_peak_at_specular_with_fwhm_4w() {
    // n = 1: every Fresnel factor is 1 and, in plane, the half vector tilts by
    // (θs + θi)/2, so BRDF × cos θs ∝ p̃((θs + θi)/2): maximum at θs = −θi and
    // FWHM exactly 4w for a hwhm-w Gaussian.
    for (w, incidences) in [
        (3.0, vec![0.0, 30.0, 45.0, 60.0, 75.0]),
        (10.0, vec![0.0, 30.0, 45.0, 60.0]),
    ] {
        let m = model(1.0, w, ModelOptions::default());
        for ti_deg in incidences {
            let ti = f64::to_radians(ti_deg);
            let g = |ts: f64| power(&m, ti, ts);
            let peak = argmax(g, -ti - 0.5, (-ti + 0.5).min(1.5));
            assert!(
                (peak + ti).abs() < 1e-7,
                "w={w} θi={ti_deg}: peak at {}",
                peak.to_degrees()
            );
            let lim = std::f64::consts::FRAC_PI_2 - 1e-4;
            let width = fwhm(g, -ti, -lim, lim);
            let expected = 4.0 * w.to_radians();
            assert!(
                (width - expected).abs() < 1e-3 * expected,
                "w={w} θi={ti_deg}: {}",
                width.to_degrees()
            );
        }
    }
}

#[test]
fn normal_incidence_widening_at_n_1_5() {
    // physics.md §4: FWHM of BRDF × cos θs ≈ 2.99 × FWHM of p̃ at w = 3°, 2.89 at w = 10°.
    for (w, ratio) in [(3.0, 2.99), (10.0, 2.89)] {
        let m = model(1.5, w, ModelOptions::default());
        let g = |ts: f64| power(&m, 0.0, ts);
        let width = fwhm(g, 0.0, -1.5, 1.5);
        let got = width / (2.0 * f64::to_radians(w));
        assert!((got - ratio).abs() < 0.01, "w={w}: ratio {got}");
    }
}

#[test]
fn off_specular_peak_shift_at_n_1_5() {
    // physics.md §4, w = 10°, point detector: the maximum of BRDF × cos θs moves toward
    // the normal by 4.0°, 8.1°, 15.2°, 25.7° at θi = 30°, 45°, 60°, 75°, with
    // I_peak / I_spec ≈ 1.013, 1.057, 1.25, 2.40. These figures hold for the paper's
    // Fresnel bookkeeping (T_av at each crossing); the exact unpolarised default differs
    // by up to 0.3° at 75° (25.4°), see `exact_unpolarized_is_the_mean_of_s_and_p`.
    let m = model(
        1.5,
        10.0,
        ModelOptions {
            transmission: Transmission::Paper,
            ..ModelOptions::default()
        },
    );
    for (ti_deg, shift, ratio) in [
        (30.0, 4.0, 1.013),
        (45.0, 8.1, 1.057),
        (60.0, 15.2, 1.25),
        (75.0, 25.7, 2.40),
    ] {
        let ti = f64::to_radians(ti_deg);
        let g = |ts: f64| power(&m, ti, ts);
        let peak = argmax(g, -ti, (-ti + 0.8).min(1.2));
        let got = (peak + ti).to_degrees();
        assert!((got - shift).abs() <= 0.1, "θi={ti_deg}: shift {got}");
        let r = g(peak) / g(-ti);
        assert!(
            (r - ratio).abs() <= 0.006 * ratio.max(1.0) + 0.005,
            "θi={ti_deg}: ratio {r}"
        );
    }
}

#[test]
fn paper_printed_weighting_breaks_conservation_as_documented() {
    // physics.md §4: at θi = 60°, w = 10°, the physical hemispherical total is 0.51 and the
    // printed weighting sends 0.78 of the beam out; its peak shift shrinks to 4.9°.
    let ti = 60f64.to_radians();
    let phys = model(1.5, 10.0, ModelOptions::default());
    let paper = model(
        1.5,
        10.0,
        ModelOptions {
            weighting: Weighting::PaperPrinted,
            ..ModelOptions::default()
        },
    );
    let paper_t = model(
        1.5,
        10.0,
        ModelOptions {
            weighting: Weighting::PaperPrinted,
            transmission: Transmission::Paper,
            ..ModelOptions::default()
        },
    );
    let (tp, _) = total_detector_space(&phys, &phys.incidence(ti).unwrap());
    let (tq, _) = total_detector_space(&paper, &paper.incidence(ti).unwrap());
    assert!((tp - 0.51).abs() < 0.005, "physical total {tp}");
    assert!((tq - 0.78).abs() < 0.005, "paper-printed total {tq}");
    // The 4.9° shift is with the paper's T_av bookkeeping too (as in the test above).
    let g = |ts: f64| power(&paper_t, ti, ts);
    let peak = argmax(g, -ti, -ti + 0.5);
    assert!(
        ((peak + ti).to_degrees() - 4.9).abs() <= 0.1,
        "{}",
        (peak + ti).to_degrees()
    );
}

#[test]
fn normal_incidence_total_tends_to_t0_squared() {
    // θi = 0, all factors on, w → 0: every ray crosses twice at normal incidence,
    // total → T(0)² = (4n/(n+1)²)² = 0.9216 for n = 1.5.
    let m = model(1.5, 0.3, ModelOptions::default());
    let (t, _) = total_detector_space(&m, &m.incidence(0.0).unwrap());
    assert!((t - 0.9216).abs() < 2e-4, "{t}");
}

#[test]
fn cone_average_tends_to_the_point_brdf() {
    // For a smooth BRDF the cone average differs from the axis value by O(α²):
    // halving α must cut the difference about fourfold, and at α = 0.05° it is tiny.
    let m = model(1.5, 6.0, ModelOptions::default());
    let inc = m.incidence(45f64.to_radians()).unwrap();
    for ts_deg in [-60.0, -45.0, -30.0, 0.0, 20.0] {
        let ts = f64::to_radians(ts_deg);
        let point = m.brdf(&inc, &in_plane_direction(ts).into_inner());
        let diff = |a_deg: f64| {
            let c = Cone::in_plane(ts, f64::to_radians(a_deg)).unwrap();
            (m.collect(&inc, &c, ConeMethod::Exact).brdf - point).abs()
        };
        let (d1, d2, d3) = (diff(1.0), diff(0.5), diff(0.05));
        assert!(d3 < 1e-4 * point, "θs={ts_deg}: {d3} vs {point}");
        if d1 > 1e-9 * point {
            let ratio = d1 / d2;
            assert!((ratio - 4.0).abs() < 0.2, "θs={ts_deg}: ratio {ratio}");
        }
    }
}

#[test]
fn exact_cone_integral_error_estimate_is_small_and_honest() {
    // A 2° cone on the flank of a narrow (w = 1°) peak: compare with a much finer
    // midpoint-rule integral (400 × 720 nodes) written here.
    let m = model(1.5, 1.0, ModelOptions::default());
    let ti = 30f64.to_radians();
    let inc = m.incidence(ti).unwrap();
    let cone = Cone::in_plane(-ti + 2f64.to_radians(), 2f64.to_radians()).unwrap();
    let got = m.collect(&inc, &cone, ConeMethod::Exact);
    let (u, v) = flakescatter_optics::detector::orthonormal_frame(cone.axis());
    let a = cone.axis().into_inner();
    let (nb, np) = (400, 720);
    let alpha = cone.half_angle();
    let mut sum = 0.0;
    for i in 0..nb {
        let b = (i as f64 + 0.5) * alpha / nb as f64;
        for j in 0..np {
            let p = (j as f64 + 0.5) * 2.0 * PI / np as f64;
            let r = a * b.cos() + (u.into_inner() * p.cos() + v.into_inner() * p.sin()) * b.sin();
            sum += m.brdf(&inc, &r) * r.z * b.sin();
        }
    }
    sum *= (alpha / nb as f64) * (2.0 * PI / np as f64);
    let rho = got.reflectance.unwrap();
    assert!((rho - sum).abs() < 1e-5 * sum, "{rho} vs {sum}");
    assert!(got.error < 1e-2 * rho);
}

#[test]
fn clearcoat_adds_the_surface_reflection_in_the_specular_cone() {
    let ti = 60f64.to_radians();
    let with = model(
        1.5,
        6.0,
        ModelOptions {
            clearcoat: true,
            ..ModelOptions::default()
        },
    );
    let without = model(1.5, 6.0, ModelOptions::default());
    let inc = with.incidence(ti).unwrap();
    let spec = Cone::in_plane(-ti, 1.5f64.to_radians()).unwrap();
    let off = Cone::in_plane(-ti + 0.2, 1.5f64.to_radians()).unwrap();
    let r_av = fresnel::air_to_coating(ti, 1.5).r_av(); // 0.089 at 60°
    let a = with
        .collect(&inc, &spec, ConeMethod::Exact)
        .reflectance
        .unwrap();
    let b = without
        .collect(&inc, &spec, ConeMethod::Exact)
        .reflectance
        .unwrap();
    assert!((a - b - r_av).abs() < 1e-15);
    let c = with
        .collect(&inc, &off, ConeMethod::Exact)
        .reflectance
        .unwrap();
    let d = without
        .collect(&inc, &off, ConeMethod::Exact)
        .reflectance
        .unwrap();
    assert_eq!(c, d);
}

#[test]
fn bad_input_is_an_error() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(0.1)).unwrap();
    assert!(matches!(
        DistributionModel::new(o.clone(), 0.9, ModelOptions::default()),
        Err(ModelError::Index(_))
    ));
    assert!(DistributionModel::new(o.clone(), f64::NAN, ModelOptions::default()).is_err());
    let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    assert!(matches!(
        DistributionModel::new(Orientation::flat(), 1.5, ModelOptions::default()),
        Err(ModelError::Delta)
    ));
    assert!(matches!(
        m.incidence(PI / 2.0),
        Err(ModelError::Incidence(_))
    ));
    assert!(m.incidence(-0.1).is_err());
    assert!(m.incidence(f64::NAN).is_err());
    let cones = [Cone::in_plane(0.0, 0.01).unwrap()];
    assert!(flakescatter_gaussian::curve(&m, &[], &cones, ConeMethod::Exact).is_err());
    assert!(flakescatter_gaussian::curve(&m, &[0.1], &[], ConeMethod::Exact).is_err());
    // Normal-space totals are finite for a valid model (smoke check of the API).
    let t = totals_normal_space(&m, &m.incidence(0.3).unwrap());
    assert!(t.escaping_power.is_finite());
}

/// `curve_each` checks every incidence before it computes any: an invalid angle late in
/// the list is an error with no row handed out; the consumer's first error ends the run.
#[test]
fn curve_each_reports_model_errors_before_any_row_and_stops_at_the_consumers() {
    let m = model(1.5, 6.0, ModelOptions::default());
    let cones: Vec<Cone> = (-3..=3)
        .map(|d| Cone::in_plane(f64::from(d) * 0.1, 0.0).unwrap())
        .collect();
    let mut calls = 0;
    let r = flakescatter_gaussian::curve_each(
        &m,
        &[0.1, 0.2, PI / 2.0],
        &cones,
        ConeMethod::Exact,
        |_| {
            calls += 1;
            Ok::<(), ModelError>(())
        },
    );
    assert!(matches!(r, Err(ModelError::Incidence(_))));
    assert_eq!(calls, 0);
    let mut seen = Vec::new();
    let r = flakescatter_gaussian::curve_each(
        &m,
        &[0.1, 0.2, 0.3],
        &cones,
        ConeMethod::Exact,
        |points| {
            seen.push((points.len(), points[0].theta_i));
            if seen.len() == 2 {
                Err(ModelError::Empty("stop"))
            } else {
                Ok(())
            }
        },
    );
    assert!(matches!(r, Err(ModelError::Empty("stop"))));
    assert_eq!(seen, [(cones.len(), 0.1), (cones.len(), 0.2)]);
}

#[test]
fn exact_unpolarized_is_the_mean_of_s_and_p() {
    // In the plane of incidence s and p do not mix: the unpolarised BRDF is the mean of
    // the s- and p-polarised ones, at every angle.
    let opts = |t| ModelOptions {
        transmission: t,
        ..ModelOptions::default()
    };
    let e = model(1.5, 10.0, opts(Transmission::ExactUnpolarized));
    let s = model(1.5, 10.0, opts(Transmission::S));
    let p = model(1.5, 10.0, opts(Transmission::P));
    for ti_deg in [0.0, 30.0, 75.0] {
        let ti = f64::to_radians(ti_deg);
        for k in -80..=80 {
            let ts = f64::to_radians(f64::from(k));
            let (a, b, c) = (power(&e, ti, ts), power(&s, ti, ts), power(&p, ti, ts));
            assert!((a - 0.5 * (b + c)).abs() <= 1e-14 * a.max(1e-300));
        }
    }
}

#[test]
fn mirror_symmetric_in_plane_rule_equals_the_general_rule() {
    // In-plane detectors use only half the azimuths (y → −y mirror symmetry). The same
    // cone built out of plane at φr = π has an axis with a 1e-16 y component and takes the
    // general, full-azimuth path: both must agree.
    let m = model(1.5, 4.0, ModelOptions::default());
    let inc = m.incidence(40f64.to_radians()).unwrap();
    for ts_deg in [5.0, 20.0, 45.0, 70.0] {
        let ts = f64::to_radians(ts_deg);
        let a = Cone::in_plane(ts, 1.5f64.to_radians()).unwrap();
        let b = Cone::out_of_plane(ts, PI, 1.5f64.to_radians()).unwrap();
        assert!(a.axis().y == 0.0 && b.axis().y != 0.0);
        let ra = m.collect(&inc, &a, ConeMethod::Exact).reflectance.unwrap();
        let rb = m.collect(&inc, &b, ConeMethod::Exact).reflectance.unwrap();
        assert!((ra - rb).abs() <= 1e-9 * ra, "θs={ts_deg}: {ra} vs {rb}");
    }
}

/// `kernel` is the point BRDF without its density: `K · p2(θn)/⟨cos θn⟩` is `brdf` to
/// rounding, in and out of the plane, for a metal flake and every Fresnel bookkeeping.
#[test]
fn kernel_times_density_is_the_point_brdf() {
    use flakescatter_optics::Vec3;
    use flakescatter_optics::flake::FlakeReflectance;
    let o = Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap();
    for transmission in Transmission::ALL {
        let options = ModelOptions {
            transmission,
            flake: FlakeReflectance::complex(0.96, 6.69).unwrap(),
            ..ModelOptions::default()
        };
        let model = DistributionModel::new(o.clone(), 1.5, options).unwrap();
        for ti in [0.0, 30.0, 72.0] {
            let inc = model.incidence(f64::to_radians(ti)).unwrap();
            for (tr, pr) in [(10.0, 0.0), (35.0, 180.0), (50.0, 40.0), (20.0, 120.0)] {
                let (tr, pr) = (f64::to_radians(tr), f64::to_radians(pr));
                let r = Vec3::new(tr.sin() * pr.cos(), tr.sin() * pr.sin(), tr.cos());
                let f = model.brdf(&inc, &r);
                let k = model.kernel(&inc, &r).unwrap();
                let g = k.factor * o.p2(k.theta_n) / o.mean_cos();
                assert!(
                    (f - g).abs() <= 1e-14 * f.abs(),
                    "{ti} {tr} {pr}: {f} vs {g}"
                );
            }
        }
    }
}
