//! Physics invariants of the optics layer. Every expected number comes from a closed
//! form written next to the assertion, never from the code under test.

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_optics::reflection;
use flakescatter_optics::refraction;
use flakescatter_optics::{UnitVec3, Vec3, check_index};
use proptest::prelude::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// Unit vectors with `z` strictly below `-zmin` (downward propagation).
fn downward(zmin: f64) -> impl Strategy<Value = UnitVec3> {
    (0.0..(1.0 - zmin), 0.0..(2.0 * PI)).prop_map(|(s, phi): (f64, f64)| {
        let c = (1.0 - s * s).sqrt();
        UnitVec3::new_normalize(Vec3::new(s * phi.cos(), s * phi.sin(), -c))
    })
}

/// Flake normals within `max_tilt` of `+z`.
fn normal(max_tilt: f64) -> impl Strategy<Value = UnitVec3> {
    (0.0..max_tilt, 0.0..(2.0 * PI)).prop_map(|(t, phi): (f64, f64)| {
        UnitVec3::new_normalize(Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos()))
    })
}

/// Solid angle of the spherical triangle (a, b, c) (Van Oosterom & Strackee 1983):
/// `tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a)`.
fn triangle_solid_angle(a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
    let num = a.dot(&b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// Solid angle of the small spherical quadrilateral with corners `p[0..4]` in order.
fn quad_solid_angle(p: &[Vec3; 4]) -> f64 {
    triangle_solid_angle(&p[0], &p[1], &p[2]) + triangle_solid_angle(&p[0], &p[2], &p[3])
}

/// Corners of a small square patch of half-size `eps` centred on `c` (tangent plane).
fn patch(c: &UnitVec3, eps: f64) -> [UnitVec3; 4] {
    let (u, v) = detector::orthonormal_frame(c);
    let (u, v, c) = (u.into_inner(), v.into_inner(), c.into_inner());
    [
        UnitVec3::new_normalize(c + eps * (u + v)),
        UnitVec3::new_normalize(c + eps * (-u + v)),
        UnitVec3::new_normalize(c + eps * (-u - v)),
        UnitVec3::new_normalize(c + eps * (u - v)),
    ]
}

fn area(p: &[UnitVec3; 4]) -> f64 {
    quad_solid_angle(&[
        p[0].into_inner(),
        p[1].into_inner(),
        p[2].into_inner(),
        p[3].into_inner(),
    ])
}

#[test]
fn normal_incidence_transmittance_is_4n_over_n_plus_1_squared() {
    // T(0) = 1 − ((n−1)/(n+1))² = 4n/(n+1)²; 0.96 at n = 1.5.
    for n in [1.0, 1.2, 1.5, 2.0, 3.3] {
        let p = fresnel::air_to_coating(0.0, n);
        let expected = 4.0 * n / ((n + 1.0) * (n + 1.0));
        assert!(close(p.ts, expected, 1e-14), "Ts(0) n={n}");
        assert!(close(p.tp, expected, 1e-14), "Tp(0) n={n}");
    }
    assert!(close(fresnel::air_to_coating(0.0, 1.5).t_av(), 0.96, 1e-14));
    // Clear-coat reflectance R_av(0) = ((n−1)/(n+1))² = 0.04 at n = 1.5.
    assert!(close(fresnel::air_to_coating(0.0, 1.5).r_av(), 0.04, 1e-14));
}

#[test]
fn clearcoat_reflectance_at_60_degrees() {
    // Closed form at θi = 60°, n = 1.5: sin θt = sin60/1.5 = 0.57735 → cos θt = sqrt(2/3).
    let ci = 0.5_f64;
    let ct = (2.0_f64 / 3.0).sqrt();
    let n = 1.5;
    let rs = ((ci - n * ct) / (ci + n * ct)).powi(2);
    let rp = ((n * ci - ct) / (n * ci + ct)).powi(2);
    let expected = 0.5 * (rs + rp); // 0.0892 (physics.md §6: 0.089)
    assert!(close(expected, 0.089, 5e-4));
    let p = fresnel::air_to_coating(60f64.to_radians(), n);
    assert!(close(p.r_av(), expected, 1e-14));
    assert!(close(
        Transmission::ExactUnpolarized.clearcoat_reflectance(&p),
        expected,
        1e-14
    ));
}

#[test]
fn brewster_angle_has_no_p_reflection() {
    for n in [1.3, 1.5, 2.0] {
        let theta_b = f64::atan(n);
        let p = fresnel::air_to_coating(theta_b, n);
        assert!(p.rp < 1e-28, "Rp at Brewster n={n}: {}", p.rp);
        assert!(p.rs > 1e-3);
        // Inside, the Brewster angle is atan(1/n) and Rp vanishes too.
        let q = fresnel::coating_to_air((1.0 / n).atan(), n).unwrap();
        assert!(q.rp < 1e-28);
    }
}

#[test]
fn total_internal_reflection_past_the_critical_angle() {
    let n: f64 = 1.5;
    let critical = (1.0 / n).asin(); // 41.81°
    assert!(fresnel::coating_to_air(critical - 1e-6, n).is_some());
    assert!(fresnel::coating_to_air(critical + 1e-9, n).is_none());
    assert!(refraction::snell_outside(critical + 1e-9, n).is_none());
    let k2 = UnitVec3::new_normalize(Vec3::new(
        (critical + 1e-6).sin(),
        0.0,
        (critical + 1e-6).cos(),
    ));
    assert!(refraction::out_of_coating(&k2, n).is_none());
    let k2 = UnitVec3::new_normalize(Vec3::new(
        (critical - 1e-6).sin(),
        0.0,
        (critical - 1e-6).cos(),
    ));
    let out = refraction::out_of_coating(&k2, n).unwrap();
    // Just below the critical angle the ray leaves almost grazing.
    assert!(out.z < 0.01);
}

#[test]
fn printed_eq10_equals_exact_average() {
    for n in [1.1, 1.5, 2.0] {
        for deg in [0.0, 1e-3, 5.0, 30.0, 45.0, 60.0, 75.0, 89.0] {
            let th = f64::to_radians(deg);
            let exact = 1.0 - fresnel::air_to_coating(th, n).r_av();
            let printed = fresnel::t_av_printed(th, n);
            assert!(
                close(printed, exact, 1e-12),
                "n={n} θ={deg}: {printed} vs {exact}"
            );
        }
    }
}

#[test]
fn paper_factor_is_lower_than_exact_by_the_cross_term() {
    // ½(Ts Ts' + Tp Tp') − T_av T_av' = (Ts − Tp)(Ts' − Tp')/4 for a perfect conductor.
    let n = 1.5;
    let a = fresnel::air_to_coating(75f64.to_radians(), n);
    let b = fresnel::air_to_coating(60f64.to_radians(), n);
    let exact = Transmission::ExactUnpolarized.path_factor(&a, (1.0, 1.0), &b);
    let paper = Transmission::Paper.path_factor(&a, (1.0, 1.0), &b);
    let cross = (a.ts - a.tp) * (b.ts - b.tp) / 4.0;
    assert!(close(exact - paper, cross, 1e-15));
    // physics.md §4 quotes "up to 2.9 % at θi = 75°": that is the far end of the
    // measured range, θo = 70° (|θs| ≤ 70°). Closed form at n = 1.5: 0.02948.
    let c = fresnel::air_to_coating(70f64.to_radians(), n);
    let e = Transmission::ExactUnpolarized.path_factor(&a, (1.0, 1.0), &c);
    let p = Transmission::Paper.path_factor(&a, (1.0, 1.0), &c);
    assert!(close((e - p) / e, 0.029, 1e-3), "{}", (e - p) / e);
}

#[test]
fn option_names_round_trip() {
    for t in Transmission::ALL {
        assert_eq!(t.name().parse::<Transmission>().unwrap(), t);
    }
    assert!("unpolarized".parse::<Transmission>().is_err());
    assert_eq!(
        "paper-printed".parse::<Weighting>().unwrap(),
        Weighting::PaperPrinted
    );
    assert!("paper".parse::<Weighting>().is_err());
}

#[test]
fn index_validation() {
    assert!(check_index(1.0).is_ok());
    assert!(check_index(0.99).is_err());
    assert!(check_index(f64::NAN).is_err());
    assert!(check_index(f64::INFINITY).is_err());
}

#[test]
fn specular_detector_angle() {
    for deg in [0.0, 30.0, 45.0, 60.0, 75.0] {
        let ti = f64::to_radians(deg);
        let r = detector::in_plane_direction(-ti);
        let s = detector::specular_direction(ti);
        assert!((r.into_inner() - s.into_inner()).norm() < 1e-15);
        // Specular has aspecular angle 0; the normal has aspecular θi.
        assert!(close(detector::theta_s_to_aspecular(ti, -ti), 0.0, 1e-15));
        assert!(close(detector::aspecular_to_theta_s(ti, ti), 0.0, 1e-15));
        // The in-plane polar form is (θi, 0): the specular half-plane.
        let (tr, pr) = detector::in_plane_to_polar(-ti);
        let o = detector::out_of_plane_direction(tr, pr);
        assert!((o.into_inner() - s.into_inner()).norm() < 1e-15);
    }
    // θs > 0 is on the source side: the incident ray comes from (−sin θi, 0, cos θi).
    let ti = 0.5;
    let back = -detector::incident_direction(ti).into_inner();
    assert!((detector::in_plane_direction(ti).into_inner() - back).norm() < 1e-15);
    let (tr, pr) = detector::in_plane_to_polar(ti);
    assert!((detector::out_of_plane_direction(tr, pr).into_inner() - back).norm() < 1e-15);
}

#[test]
fn cone_membership_and_solid_angle() {
    let alpha = 1.5f64.to_radians();
    let cone = Cone::in_plane(-0.5, alpha).unwrap();
    assert!(close(
        cone.solid_angle(),
        2.0 * PI * (1.0 - alpha.cos()),
        1e-15
    ));
    // Directions just inside and outside the aperture, rotated about y.
    let inside = detector::in_plane_direction(-0.5 + alpha * 0.999);
    let outside = detector::in_plane_direction(-0.5 + alpha * 1.001);
    assert!(cone.contains(&inside));
    assert!(!cone.contains(&outside));
    // A point detector contains nothing.
    let point = Cone::in_plane(0.2, 0.0).unwrap();
    assert!(!point.contains(&detector::in_plane_direction(0.2)));
    // Bad geometry is an error, not a panic.
    assert!(Cone::in_plane(FRAC_PI_2, alpha).is_err());
    assert!(Cone::in_plane(0.1, -0.1).is_err());
    assert!(Cone::in_plane(0.1, f64::NAN).is_err());
    assert!(Cone::out_of_plane(-0.1, 0.0, alpha).is_err());
}

#[test]
fn projected_solid_angle_matches_a_direct_sum() {
    // ∫cone cos θ dΩ by brute force in the cone's own polar coordinates (midpoint rule).
    let alpha = 5f64.to_radians();
    let cone = Cone::out_of_plane(0.7, 0.3, alpha).unwrap();
    let (u, v) = detector::orthonormal_frame(cone.axis());
    let (nb, np) = (400, 400);
    let mut sum = 0.0;
    for i in 0..nb {
        let b = (i as f64 + 0.5) * alpha / nb as f64;
        for j in 0..np {
            let p = (j as f64 + 0.5) * 2.0 * PI / np as f64;
            let d = cone.axis().into_inner() * b.cos()
                + (u.into_inner() * p.cos() + v.into_inner() * p.sin()) * b.sin();
            sum += d.z * b.sin() * (alpha / nb as f64) * (2.0 * PI / np as f64);
        }
    }
    assert!(close(cone.projected_solid_angle(), sum, 1e-5 * sum));
}

#[test]
fn complex_flake_reflectance_closed_forms() {
    // Normal incidence: R = |(N − n_m)/(N + n_m)|² = ((n−n_m)² + k²)/((n+n_m)² + k²).
    let (n, k, nm) = (0.96, 6.69, 1.5);
    let f = FlakeReflectance::complex(n, k).unwrap();
    let (rs, rp) = f.power(1.0, nm);
    let expected = ((n - nm).powi(2) + k * k) / ((n + nm).powi(2) + k * k);
    assert!(close(rs, expected, 1e-14));
    assert!(close(rp, expected, 1e-14));
    // A lossless "metal" equal to a dielectric of index n2 reproduces the dielectric
    // Fresnel coefficients (n_m → n2, relative index n2/n_m).
    let d = FlakeReflectance::complex(2.25, 0.0).unwrap();
    let th = 0.6_f64;
    let (ds, dp) = d.power(th.cos(), 1.5);
    let q = fresnel::air_to_coating(th, 1.5); // relative index 1.5 = 2.25/1.5
    assert!(close(ds, q.rs, 1e-13) && close(dp, q.rp, 1e-13));
    // Grazing incidence reflects everything.
    let (gs, gp) = f.power(0.0, nm);
    assert!(close(gs, 1.0, 1e-12) && close(gp, 1.0, 1e-12));
    assert_eq!(
        FlakeReflectance::PerfectConductor.power(0.3, 1.5),
        (1.0, 1.0)
    );
    assert!(FlakeReflectance::complex(-1.0, 1.0).is_err());
    assert!(FlakeReflectance::complex(1.0, f64::NAN).is_err());
}

proptest! {
    #[test]
    fn energy_is_conserved_at_the_interface(theta in 0.0..(FRAC_PI_2 - 1e-6), n in 1.0..3.0f64) {
        // T is computed from the transmitted amplitudes, so R + T = 1 is a real check.
        let p = fresnel::air_to_coating(theta, n);
        prop_assert!(close(p.rs + p.ts, 1.0, 1e-13));
        prop_assert!(close(p.rp + p.tp, 1.0, 1e-13));
        let theta_t = refraction::snell_inside(theta, n);
        let q = fresnel::coating_to_air(theta_t, n).unwrap();
        prop_assert!(close(q.rs + q.ts, 1.0, 1e-13));
        prop_assert!(close(q.rp + q.tp, 1.0, 1e-13));
    }

    #[test]
    fn transmittance_is_reciprocal(theta in 0.0..1.55f64, n in 1.0..3.0f64) {
        // Same power transmittance both ways for a Snell-related pair of angles.
        let p = fresnel::air_to_coating(theta, n);
        let theta_t = refraction::snell_inside(theta, n);
        let q = fresnel::coating_to_air(theta_t, n).unwrap();
        prop_assert!(close(p.ts, q.ts, 1e-13));
        prop_assert!(close(p.tp, q.tp, 1e-13));
        // And the inside reflectances equal the outside ones (Stokes relations).
        prop_assert!(close(p.rs, q.rs, 1e-13));
    }

    #[test]
    fn refraction_round_trips(k_in in downward(1e-3), n in 1.0..2.5f64) {
        // In: Snell for the polar angle, azimuth kept.
        let k1 = refraction::into_coating(&k_in, n);
        prop_assert!(close(k1.norm(), 1.0, 1e-14));
        let s_in = (k_in.x * k_in.x + k_in.y * k_in.y).sqrt();
        let s_1 = (k1.x * k1.x + k1.y * k1.y).sqrt();
        prop_assert!(close(s_in, n * s_1, 1e-14));
        // A flat flake then the exit gives the mirror image of k_in.
        let k2 = UnitVec3::new_unchecked(Vec3::new(k1.x, k1.y, -k1.z));
        let out = refraction::out_of_coating(&k2, n).unwrap();
        let mirror = Vec3::new(k_in.x, k_in.y, -k_in.z);
        prop_assert!((out.into_inner() - mirror).norm() < 1e-13);
        // exit_to_inside inverts out_of_coating.
        let back = refraction::exit_to_inside(&out, n);
        prop_assert!((back.into_inner() - k2.into_inner()).norm() < 1e-13);
    }

    #[test]
    fn reflection_round_trips(k1 in downward(1e-3), m in normal(1.2)) {
        let k2 = reflection::reflect(&k1, &m);
        prop_assert!(close(k2.norm(), 1.0, 1e-14));
        let again = reflection::reflect(&k2, &m);
        prop_assert!((again.into_inner() - k1.into_inner()).norm() < 1e-13);
        // The half vector recovers the normal, up to its sign.
        let h = reflection::half_vector(&k1, &k2).unwrap();
        let s = if h.dot(&m) < 0.0 { -1.0 } else { 1.0 };
        prop_assert!((s * h.into_inner() - m.into_inner()).norm() < 1e-9);
    }

    #[test]
    fn gamma_forms_agree(k1 in downward(1e-3), m in normal(1.2)) {
        let gamma = reflection::obliquity(&k1, &m);
        prop_assume!(gamma > 1e-6);
        let k2 = reflection::reflect(&k1, &m);
        prop_assert!(close(gamma, reflection::obliquity_from_rays(&k1, &k2), 1e-12));
    }

    #[test]
    fn reflection_jacobian_matches_finite_patches(k1 in downward(0.05), m in normal(1.0)) {
        let gamma = reflection::obliquity(&k1, &m);
        prop_assume!(gamma > 0.05);
        let eps = 1e-3;
        let src = patch(&m, eps);
        let img = src.map(|mm| reflection::reflect(&k1, &mm));
        let ratio = area(&img) / area(&src);
        let expected = 4.0 * gamma;
        prop_assert!(close(ratio, expected, 1e-5 * expected), "{ratio} vs {expected}");
        prop_assert!(close(reflection::reflection_jacobian(gamma), expected, 0.0));
    }

    #[test]
    fn refraction_jacobian_matches_finite_patches(n in 1.0..2.0f64, t in 0.0..1.2f64, phi in 0.0..(2.0 * PI)) {
        // Inside direction k2 whose exit angle stays away from grazing.
        let t2 = t.min(0.95 * (1.0 / n).asin());
        let k2 = UnitVec3::new_normalize(Vec3::new(t2.sin() * phi.cos(), t2.sin() * phi.sin(), t2.cos()));
        let out = refraction::out_of_coating(&k2, n).unwrap();
        let eps = 1e-4;
        let src = patch(&k2, eps);
        let img = src.map(|k| refraction::out_of_coating(&k, n).unwrap());
        let ratio = area(&img) / area(&src);
        // Closed form: n² cos θ2 / cos θo.
        let expected = n * n * k2.z / out.z;
        prop_assert!(close(ratio, expected, 1e-5 * expected), "{ratio} vs {expected}");
        prop_assert!(close(reflection::refraction_out_jacobian(n, k2.z, out.z), expected, 1e-15 * expected));
    }
}
