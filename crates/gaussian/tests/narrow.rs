//! Narrow orientation distributions down to the all-flat (delta) limit: what a cone
//! collects against closed forms derived here, against the Monte Carlo tracer, and the
//! hemispherical totals (issue 13, item 4).

use flakescatter_gaussian::hemisphere::{total_detector_space, totals_normal_space};
use flakescatter_gaussian::{
    ConeMethod, DistributionModel, ModelError, ModelOptions, curve, monte_carlo,
};
use flakescatter_optics::detector::Cone;
use flakescatter_optics::polarization::Transmission;
use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::{GaussianWidth, Orientation};
use statrs::distribution::{ContinuousCDF, Normal};

const N: f64 = 1.5;

fn gaussian(hwhm_deg: f64, options: ModelOptions) -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
    DistributionModel::new(o, N, options).unwrap()
}

/// Fresnel power transmittances `(Ts, Tp)` air → coating at `θi`, written out here from
/// Snell's law and the amplitude coefficients (physics.md §2), not taken from the crate.
fn fresnel_t(theta_i: f64) -> (f64, f64) {
    let (si, ci) = theta_i.sin_cos();
    let ct = (1.0 - (si / N).powi(2)).sqrt();
    let rs = (ci - N * ct) / (ci + N * ct);
    let rp = (N * ci - ct) / (N * ci + ct);
    (1.0 - rs * rs, 1.0 - rp * rp)
}

/// The delta limit. All flakes flat (`m = z`): the refracted beam `k1` is mirrored to
/// `k2 = (sin θt, 0, cos θt)` and leaves exactly along the specular direction
/// `(sin θi, 0, cos θi)`. The flakes cover the coating, so the whole entering beam meets
/// them (`γ / cos θt = 1`: the flake area the beam sees per unit beam cross-section is
/// that of the coating). The perfect conductor reflects all of it (`R = 1`), and the exit
/// crossing at the inside angle `θt` transmits `Ts(θi)`, `Tp(θi)` again (reciprocity of
/// the power transmittance). For flat mirrors s and p do not mix, so the fraction of the
/// beam leaving is `½(Ts² + Tp²)` unpolarised, `Ts²` or `Tp²` polarised, and
/// `T_av(θi)²` with `T_av = (Ts + Tp)/2` for the paper's bookkeeping. A cone that contains
/// the specular direction with a margin collects all of it.
fn delta_limit(theta_i: f64, transmission: Transmission) -> f64 {
    let (ts, tp) = fresnel_t(theta_i);
    match transmission {
        Transmission::ExactUnpolarized => 0.5 * (ts * ts + tp * tp),
        Transmission::Paper => (0.5 * (ts + tp)).powi(2),
        Transmission::S => ts * ts,
        Transmission::P => tp * tp,
    }
}

fn specular(theta_i: f64) -> Vec3 {
    Vec3::new(theta_i.sin(), 0.0, theta_i.cos())
}

/// A cone of half-angle `alpha` whose axis is `p` rotated by `offset` (radians) in the
/// plane of incidence toward the normal (`in_plane`) or out of it toward `+y`.
fn offset_cone(theta_i: f64, offset: f64, alpha: f64, in_plane: bool) -> Cone {
    let p = specular(theta_i);
    let dir = if in_plane {
        Vec3::new(-theta_i.cos(), 0.0, theta_i.sin())
    } else {
        Vec3::new(0.0, 1.0, 0.0)
    };
    let axis = p * offset.cos() + dir * offset.sin();
    Cone::new(UnitVec3::new_normalize(axis), alpha).unwrap()
}

#[test]
fn a_cone_around_specular_collects_the_delta_limit_for_narrow_widths() {
    // Full containment: a 1.5° cone around (or near) specular collects all the flake
    // light, i.e. the mean ray weight E[g(m)] over the distribution. Its first-order terms
    // in the tilt average out (isotropic distribution), so E[g] = g(z) + O(σ²) with σ the
    // spread of exit angles, up to 2 n cos θt s / cos θi (next test). Hence: within 1e-9
    // of the delta limit for hwhm ≤ 1e-5° (σ² ≤ 1e-12), and within the 1e-4 at
    // 0.01° (σ² ≈ 2e-6 at θi = 75°).
    let alpha = 1.5f64.to_radians();
    for transmission in [
        Transmission::ExactUnpolarized,
        Transmission::Paper,
        Transmission::S,
        Transmission::P,
    ] {
        let options = ModelOptions {
            transmission,
            ..ModelOptions::default()
        };
        for (hwhm, tol) in [(1e-7, 1e-9), (1e-5, 1e-9), (1e-2, 1e-4)] {
            let m = gaussian(hwhm, options.clone());
            for ti_deg in [0.0, 30.0, 60.0, 75.0] {
                let ti = f64::to_radians(ti_deg);
                let inc = m.incidence(ti).unwrap();
                let want = delta_limit(ti, transmission);
                for offset_deg in [0.0, 0.5] {
                    let cone = offset_cone(ti, f64::to_radians(offset_deg), alpha, true);
                    let got = m.collect(&inc, &cone, ConeMethod::Exact);
                    let rho = got.reflectance.unwrap();
                    assert!(
                        (rho / want - 1.0).abs() < tol,
                        "{transmission:?} hwhm {hwhm}° θi {ti_deg}° offset {offset_deg}°: {rho} vs {want}"
                    );
                    assert!(got.error < 1e-8 * want, "error estimate {}", got.error);
                }
            }
        }
    }
}

#[test]
fn the_approach_to_the_delta_limit_is_second_order_in_the_width() {
    // ρ(w) − ρδ = c w² + O(w⁴) (previous test): doubling the width quadruples the
    // deviation, whatever c is. At θi = 0 the deviation vanishes to rounding (the s and p
    // transmittances curve in opposite directions at normal incidence), so it starts at 30°.
    let alpha = 1.5f64.to_radians();
    for ti_deg in [30.0, 60.0, 75.0] {
        let ti = f64::to_radians(ti_deg);
        let want = delta_limit(ti, Transmission::ExactUnpolarized);
        let dev = |hwhm: f64| {
            let m = gaussian(hwhm, ModelOptions::default());
            let inc = m.incidence(ti).unwrap();
            let cone = offset_cone(ti, 0.0, alpha, true);
            m.collect(&inc, &cone, ConeMethod::Exact)
                .reflectance
                .unwrap()
                - want
        };
        let (d1, d2) = (dev(0.01), dev(0.02));
        assert!(
            d1.abs() > 1e-10,
            "θi {ti_deg}°: deviation {d1} too small to test"
        );
        assert!((d2 / d1 - 4.0).abs() < 0.02, "θi {ti_deg}°: {d1} {d2}");
    }
}

#[test]
fn curves_of_narrow_widths_converge_to_the_delta_limit() {
    // The CLI's `model --hwhm W --theta-i 30` curve: cones every 0.5° of 1.5° half-angle.
    // Every cone whose axis is within α − 0.5° of specular holds all the light; those
    // farther than α + 0.5° hold none of it (the light is within ~10⁻² ° of specular).
    let alpha = 1.5f64.to_radians();
    let cones: Vec<Cone> = (0..=280)
        .map(|k| Cone::in_plane((-70.0 + 0.5 * f64::from(k)).to_radians(), alpha).unwrap())
        .collect();
    let ti = 30f64.to_radians();
    let want = delta_limit(ti, Transmission::ExactUnpolarized);
    for hwhm in [1e-6, 1e-3, 1e-2] {
        let m = gaussian(hwhm, ModelOptions::default());
        let rows = curve(&m, &[ti], &cones, ConeMethod::Exact).unwrap();
        for r in &rows {
            let d = (r.theta_s_deg() + 30.0).abs();
            let rho = r.collected.reflectance.unwrap();
            if d <= 1.0 {
                assert!((rho / want - 1.0).abs() < 1e-6, "hwhm {hwhm}: {d}° {rho}");
                assert!((r.relative - 1.0).abs() < 1e-6);
            } else if d >= 2.0 {
                assert!(rho < 1e-12, "hwhm {hwhm}: {d}° {rho}");
            }
        }
    }
}

#[test]
fn a_cone_edge_near_specular_cuts_the_image_of_the_distribution() {
    // Linearised about m = z, a flake tilted by (εx, εy) sends its ray to exit angles
    // displaced by (2 n cos θt / cos θi) εx in the plane of incidence and by
    // 2 n cos θt εy across it: reflection doubles the tilt of k2, and refraction out
    // stretches in-plane angles by n cos θt / cos θi (n cos θ2 dθ2 = cos θo dθo) and the
    // transverse component by n (r.y = n k2.y). The area-weighted Gaussian has tilt
    // components N(0, s²), so the exit directions are N(0, σx²) × N(0, σy²) about
    // specular with σx = 2 n cos θt s / cos θi and σy = 2 n cos θt s. A cone whose edge
    // passes at signed distance δ from specular (δ > 0: specular inside), perpendicular to
    // the displacement, collects Φ(δ/σ) of the delta limit. Corrections: the edge's
    // curvature (relative ~σ/α ≈ 1e-4 here) and the ray weight's variation (~s).
    let std = Normal::new(0.0, 1.0).unwrap();
    let alpha = 1.5f64.to_radians();
    let s = 1e-6; // rad
    let o = Orientation::gaussian(GaussianWidth::Sigma(s)).unwrap();
    let m = DistributionModel::new(o, N, ModelOptions::default()).unwrap();
    for ti_deg in [0.0, 45.0, 70.0] {
        let ti = f64::to_radians(ti_deg);
        let inc = m.incidence(ti).unwrap();
        let want = delta_limit(ti, Transmission::ExactUnpolarized);
        let ct = (1.0 - (ti.sin() / N).powi(2)).sqrt();
        for in_plane in [true, false] {
            let sigma = if in_plane {
                2.0 * N * ct * s / ti.cos()
            } else {
                2.0 * N * ct * s
            };
            for z in [-2.5, -1.0, 0.0, 0.5, 1.0, 2.5] {
                let cone = offset_cone(ti, alpha - z * sigma, alpha, in_plane);
                let got = m.collect(&inc, &cone, ConeMethod::Exact);
                let frac = got.reflectance.unwrap() / want;
                assert!(
                    (frac - std.cdf(z)).abs() < 2e-4,
                    "θi {ti_deg}° in-plane {in_plane} δ/σ {z}: {frac} vs Φ = {}",
                    std.cdf(z)
                );
                assert!(got.error < 1e-7, "error estimate {}", got.error);
            }
        }
    }
}

/// `|quadrature − Monte Carlo| ≤ 4.5 se` for every cone, with the quadrature's own error
/// estimate far below the Monte Carlo's.
fn check_against_monte_carlo(m: &DistributionModel, ti: f64, cones: &[Cone], seed: u64) {
    const SAMPLES: u64 = 400_000;
    let inc = m.incidence(ti).unwrap();
    let mc = monte_carlo(m, &inc, cones, SAMPLES, seed).unwrap();
    for (est, cone) in mc.iter().zip(cones) {
        let q = m.collect(&inc, cone, ConeMethod::Exact);
        let rho = q.reflectance.unwrap();
        // 4.5 standard errors: with ~300 comparisons in this file the chance that any
        // honest one fails is 300 · 6.8e-6 ≈ 2e-3 (and the seeds are fixed). A cone the
        // tracer barely reaches has no usable se: there the expected number of rays,
        // ρ N / w with ray weights w ≤ 1/cos θt ≤ 1.5, must be consistent with the hits
        // seen (≤ 8 expected for 0 or 1 hits, Poisson upper 99.9 % bound ≈ 9.2 for 1).
        let floor = 8.0 * 1.5 / SAMPLES as f64;
        let tol = 4.5 * est.std_err + if est.hits < 10 { floor } else { 0.0 };
        assert!(
            (est.reflectance - rho).abs() <= tol,
            "θi {:.1}° axis {:?}: quadrature {rho} (err {}) vs MC {} ± {} ({} hits)",
            ti.to_degrees(),
            cone.axis(),
            q.error,
            est.reflectance,
            est.std_err,
            est.hits
        );
        assert!(q.error <= 0.05 * est.std_err + 1e-12, "error {}", q.error);
    }
}

/// In-plane and out-of-plane cones around specular at offsets that put the specular
/// direction inside, on the edge, and outside.
fn cones_around(ti: f64, alpha: f64, spread: f64) -> Vec<Cone> {
    let mut v = Vec::new();
    for f in [-2.0, -1.2, -1.0, -0.6, 0.0, 0.3, 0.9, 1.0, 1.1, 1.7] {
        v.push(offset_cone(ti, f * (alpha + spread), alpha, true));
        v.push(offset_cone(ti, f * (alpha + spread), alpha, false));
    }
    v
}

#[test]
fn narrow_and_moderate_widths_agree_with_monte_carlo() {
    // From 10⁻³ ° (specular-centred rule) to 1° (axis rule), cones in and out of the
    // plane of incidence that contain, cut or miss the peak. The Monte Carlo tracer draws
    // normals and traces rays, with no BRDF and no Jacobian (module `montecarlo`).
    let alpha = 1.5f64.to_radians();
    let mut seed = 40;
    for hwhm in [1e-3, 1e-2, 0.1, 0.3, 1.0] {
        let m = gaussian(hwhm, ModelOptions::default());
        for ti_deg in [20.0, 60.0] {
            let ti = f64::to_radians(ti_deg);
            let spread = 3.0 * f64::to_radians(hwhm);
            seed += 1;
            check_against_monte_carlo(&m, ti, &cones_around(ti, alpha, spread), seed);
        }
    }
}

#[test]
fn hemispherical_totals_of_narrow_distributions_are_the_delta_limit() {
    // The whole upper hemisphere holds all the light; for these widths nothing is lost to
    // total internal reflection or back-lit flakes, so both totals (detector space and
    // normal space, module `hemisphere`) are the delta limit up to O(σ²) as above: 1e-9
    // for hwhm ≤ 1e-5°, 1e-4 at 0.01°. They are also what a 1.5° cone around specular
    // collects (a third, independent integration), to 1e-9.
    let alpha = 1.5f64.to_radians();
    for (hwhm, tol) in [(1e-6, 1e-9), (1e-5, 1e-9), (1e-2, 1e-4)] {
        let m = gaussian(hwhm, ModelOptions::default());
        for ti_deg in [0.0, 60.0] {
            let ti = f64::to_radians(ti_deg);
            let inc = m.incidence(ti).unwrap();
            let want = delta_limit(ti, Transmission::ExactUnpolarized);
            let (det, _) = total_detector_space(&m, &inc);
            let normal = totals_normal_space(&m, &inc).escaping_power;
            let cone = m
                .collect(&inc, &offset_cone(ti, 0.0, alpha, true), ConeMethod::Exact)
                .reflectance
                .unwrap();
            for (name, v) in [("detector", det), ("normal", normal)] {
                assert!(
                    (v / want - 1.0).abs() < tol,
                    "hwhm {hwhm}° θi {ti_deg}°: {name}-space total {v} vs {want}"
                );
                assert!((v / cone - 1.0).abs() < 1e-9, "{name} {v} vs cone {cone}");
            }
        }
    }
}

#[test]
fn a_table_with_one_narrow_bin_is_resolved() {
    let alpha = 1.5f64.to_radians();
    // All the area in [0, 1e-4°]: p2 is uniform on that cap, so the image is a filled
    // ellipse about specular (the linear map above); the specular cone collects the delta
    // limit, and a cone whose edge passes through specular half of it (a centrally
    // symmetric image cut through its centre; the edge's curvature changes this by about
    // the image's radius over α, 1e-4 here).
    let cap = 1e-4f64.to_radians();
    let o = Orientation::tabulated(vec![0.0, cap], vec![1.0]).unwrap();
    let m = DistributionModel::new(o, N, ModelOptions::default()).unwrap();
    for ti_deg in [0.0, 50.0] {
        let ti = f64::to_radians(ti_deg);
        let inc = m.incidence(ti).unwrap();
        let want = delta_limit(ti, Transmission::ExactUnpolarized);
        let full = m.collect(
            &inc,
            &offset_cone(ti, 0.2 * alpha, alpha, true),
            ConeMethod::Exact,
        );
        assert!((full.reflectance.unwrap() / want - 1.0).abs() < 1e-9);
        for in_plane in [true, false] {
            let half = m.collect(
                &inc,
                &offset_cone(ti, alpha, alpha, in_plane),
                ConeMethod::Exact,
            );
            let frac = half.reflectance.unwrap() / want;
            assert!((frac - 0.5).abs() < 5e-4, "θi {ti_deg}°: {frac}");
        }
    }
    // A narrow first bin (half the area within 0.002°) under a wide one: a spike on a
    // broad background, against the Monte Carlo tracer.
    let edges = vec![
        0.0,
        0.002f64.to_radians(),
        3f64.to_radians(),
        8f64.to_radians(),
    ];
    let o = Orientation::tabulated(edges, vec![0.5, 0.4, 0.1]).unwrap();
    let m = DistributionModel::new(o, N, ModelOptions::default()).unwrap();
    for (k, ti_deg) in [10.0, 55.0].into_iter().enumerate() {
        let ti = f64::to_radians(ti_deg);
        let mut cones = cones_around(ti, alpha, 0.0);
        cones.extend(cones_around(ti, alpha, 4f64.to_radians()));
        check_against_monte_carlo(&m, ti, &cones, 90 + k as u64);
    }
}

#[test]
fn the_constant_integrand_approximation_is_refused_for_narrow_distributions() {
    // It takes f at the axis as constant over the cone: with the light 10⁻² ° wide in a
    // 1.5° cone it gives reflectances above 1 or 0. Refused; a wide distribution is fine.
    let alpha = 1.5f64.to_radians();
    let cones = vec![Cone::in_plane(-0.5, alpha).unwrap()];
    let narrow = gaussian(0.01, ModelOptions::default());
    assert!(matches!(
        curve(&narrow, &[0.5], &cones, ConeMethod::ConstantIntegrand),
        Err(ModelError::ConstantIntegrandTooNarrow { .. })
    ));
    let msg = curve(&narrow, &[0.5], &cones, ConeMethod::ConstantIntegrand)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("degree") && msg.contains("exact"), "{msg}");
    let wide = gaussian(6.0, ModelOptions::default());
    assert!(curve(&wide, &[0.5], &cones, ConeMethod::ConstantIntegrand).is_ok());
    // Point detectors have no cone to approximate.
    let points = vec![Cone::in_plane(-0.5, 0.0).unwrap()];
    assert!(curve(&narrow, &[0.5], &points, ConeMethod::ConstantIntegrand).is_ok());
}
