//! Binder absorption in the distribution model (physics.md §8.1): the point BRDF with
//! absorption is the clear-binder BRDF times the path factor of the in-plane closed
//! form, and the hemispherical total computed over exit directions equals the one
//! computed over flake normals (the factor enters both with the right inside angle).

use flakescatter_gaussian::hemisphere::{total_detector_space, totals_normal_space};
use flakescatter_gaussian::{DistributionModel, ModelOptions};
use flakescatter_optics::Vec3;
use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_stats::{GaussianWidth, Orientation};

const N: f64 = 1.5;

fn model() -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap();
    let options = ModelOptions {
        flake: FlakeReflectance::complex(1.0, 6.6).unwrap(),
        ..ModelOptions::default()
    };
    DistributionModel::new(o, N, options).unwrap()
}

#[test]
fn point_brdf_is_multiplied_by_the_path_factor() {
    let (alpha, d) = (0.15, 4.0);
    let absorbing = model()
        .with_absorption(PathAbsorption::new(alpha, FlakeDepth::At { depth_um: d }).unwrap());
    let clear = model();
    for theta_i in [0.0f64, 30.0, 45.0, 70.0] {
        let ti = theta_i.to_radians();
        let (inc_a, inc_c) = (
            absorbing.incidence(ti).unwrap(),
            clear.incidence(ti).unwrap(),
        );
        for theta_s in [-80.0f64, -50.0, -20.0, 0.0, 15.0, 60.0] {
            let ts = theta_s.to_radians();
            let r = Vec3::new(-ts.sin(), 0.0, ts.cos());
            let (fa, fc) = (absorbing.brdf(&inc_a, &r), clear.brdf(&inc_c, &r));
            if fc == 0.0 {
                continue;
            }
            // Snell inside: cos θt = sqrt(1 − sin²θi/n²), cos θ2 = sqrt(1 − sin²θs/n²).
            let ct = (1.0 - (ti.sin() / N).powi(2)).sqrt();
            let c2 = (1.0 - (ts.sin() / N).powi(2)).sqrt();
            let want = (-alpha * d * (1.0 / ct + 1.0 / c2)).exp();
            assert!(
                (fa / fc - want).abs() < 1e-13 * want,
                "θi {theta_i} θs {theta_s}: ratio {} vs {want}",
                fa / fc
            );
            // The Mueller BRDF carries the same factor.
            let (ma, mc) = (
                absorbing.brdf_mueller(&inc_a, &r),
                clear.brdf_mueller(&inc_c, &r),
            );
            assert!((ma.m00() / mc.m00() - want).abs() < 1e-13 * want);
        }
    }
}

#[test]
fn totals_in_detector_and_normal_space_agree_with_absorption() {
    let m = model().with_absorption(
        PathAbsorption::new(0.08, FlakeDepth::UniformInFilm { film_um: 25.0 }).unwrap(),
    );
    for theta_i in [0.0f64, 40.0, 65.0] {
        let inc = m.incidence(theta_i.to_radians()).unwrap();
        let (detector, _) = total_detector_space(&m, &inc);
        let normal = totals_normal_space(&m, &inc).escaping_power;
        assert!(
            (detector - normal).abs() < 1e-6 * normal,
            "θi {theta_i}: {detector} vs {normal}"
        );
        // And the binder takes something: below the clear binder's total.
        let clear = totals_normal_space(&model(), &inc).escaping_power;
        assert!(normal < 0.9 * clear);
    }
}
