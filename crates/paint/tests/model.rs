//! The paint model's terms against independent references: today's distribution model,
//! reciprocity, a direct integration and a photon random walk for the base, and energy.

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_gaussian::{DistributionModel, ModelOptions};
use flakescatter_numerics::quad::adaptive_nested;
use flakescatter_optics::{Vec3, fresnel};
use flakescatter_paint::base::{external_diffuse_reflectance, internal_diffuse_reflectance};
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
use flakescatter_stats::{GaussianWidth, Orientation};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn dir(theta: f64, phi: f64) -> Vec3 {
    Vec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

fn paint(
    coat: CoatParams,
    orientation: Orientation,
    coverage: f64,
    scale: f64,
    albedo: f64,
) -> PaintModel {
    PaintModel::new(PaintParams {
        coat,
        orientation,
        coverage,
        flake_metal: FlakeMetal::Aluminium,
        channels: vec![
            ChannelParams {
                channel: Channel::parse("r").unwrap(),
                flake_scale: scale,
                base_albedo: albedo,
                tint: 0.0,
            },
            ChannelParams {
                channel: Channel::parse("450nm").unwrap(),
                flake_scale: scale * 0.8,
                base_albedo: albedo * 0.5,
                tint: 0.0,
            },
        ],
    })
    .unwrap()
}

/// With a flat coat, full coverage, scale 1 and no base, the flakes of the Gaussian
/// family are the distribution model of physics.md §4 (its point BRDF with aluminium at
/// the channel's wavelength): for a 6° Gaussian the flake layer's `Λ` underflows
/// (`exp(−(48°/5.1°)²/2)`), so the two agree to rounding.
#[test]
fn gaussian_flakes_are_the_distribution_model() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let m = paint(CoatParams::flat(1.5), o.clone(), 1.0, 1.0, 0.0);
    for (k, wl) in [(0, 612.0), (1, 450.0)] {
        let flake = flakescatter_optics::material::ComplexIndexTable::aluminium()
            .flake_at(wl)
            .unwrap();
        let reference = DistributionModel::new(
            o.clone(),
            1.5,
            ModelOptions {
                flake,
                ..ModelOptions::default()
            },
        )
        .unwrap();
        for ti in [0.0, 15.0, 45.0, 75.0] {
            let ti = f64::to_radians(ti);
            let inc = m.incidence(ti).unwrap();
            let rinc = reference.incidence(ti).unwrap();
            for (tr, pr) in [
                (10.0, 0.0),
                (40.0, 0.0),
                (20.0, 180.0),
                (50.0, 30.0),
                (70.0, 150.0),
            ] {
                let r = dir(f64::to_radians(tr), f64::to_radians(pr));
                let t = m.terms(&inc, &r, k);
                // The second channel's flakes have scale 0.8 (`paint`).
                let want = reference.brdf(&rinc, &r) * if k == 0 { 1.0 } else { 0.8 };
                assert!(
                    (t.flakes - want).abs() <= 1e-12 * want.abs(),
                    "{k} {ti} {tr} {pr}: {} vs {want}",
                    t.flakes
                );
                assert_eq!(t.base, 0.0);
                assert_eq!(t.coat, 0.0);
            }
        }
    }
}

/// Parameter sets that exercise every term.
fn assorted() -> Vec<PaintModel> {
    let knots: Vec<f64> = [0.0, 2.0, 6.0, 15.0, 30.0, 60.0, 90.0]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect();
    vec![
        paint(
            CoatParams {
                n: 1.5,
                roughness: 0.02,
                haze: 0.3,
                haze_roughness: 0.5,
            },
            Orientation::trowbridge_reitz(0.15).unwrap(),
            0.4,
            0.9,
            0.6,
        ),
        paint(
            CoatParams {
                n: 1.35,
                roughness: 0.3,
                haze: 0.0,
                haze_roughness: 0.0,
            },
            Orientation::pearson_vii(0.08, 0.7).unwrap(),
            0.8,
            1.0,
            1.0,
        ),
        paint(
            CoatParams::flat(1.6),
            Orientation::log_linear(knots, vec![0.0, -0.5, -2.0, -4.0, -7.0, -9.0, -12.0]).unwrap(),
            0.2,
            0.5,
            0.9,
        ),
    ]
}

/// Helmholtz reciprocity `f(θi, θr, φr) = f(θr, θi, φr)` (the relative azimuth of
/// source and detector is the same in both), every term, to rounding.
#[test]
fn every_term_is_reciprocal() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for m in assorted() {
        for _ in 0..200 {
            let a: f64 = rng.random_range(0.0..1.45);
            let b: f64 = rng.random_range(0.0..1.45);
            let phi: f64 = rng.random_range(0.0..2.0 * PI);
            for k in 0..2 {
                let t1 = m.terms(&m.incidence(a).unwrap(), &dir(b, phi), k);
                let t2 = m.terms(&m.incidence(b).unwrap(), &dir(a, phi), k);
                for (x, y, what) in [
                    (t1.coat, t2.coat, "coat"),
                    (t1.flakes, t2.flakes, "flakes"),
                    (t1.base, t2.base, "base"),
                ] {
                    assert!(
                        (x - y).abs() <= 1e-10 * x.abs().max(y.abs()) + 1e-300,
                        "{what} at ({a}, {b}, {phi}): {x} vs {y}"
                    );
                }
            }
        }
    }
}

/// `∫ g(r) cos θr dΩr` over the hemisphere by nested adaptive Gauss–Kronrod, with break
/// points at the specular polar angle and in azimuth at 0 (the specular half-plane).
fn hemisphere(g: &dyn Fn(&Vec3) -> f64, theta_spec: f64) -> f64 {
    let inner = |theta: f64| -> (f64, f64) {
        let (st, ct) = theta.sin_cos();
        let (v, e) = adaptive_nested(
            |phi: f64| (g(&dir(theta, phi)) * ct * st, 0.0),
            0.0,
            PI,
            &[0.02, 0.1, 0.4],
            1e-14,
            1e-9,
            400,
        );
        (2.0 * v, 2.0 * e)
    };
    let breaks = [
        theta_spec - 0.1,
        theta_spec - 0.02,
        theta_spec,
        theta_spec + 0.02,
        theta_spec + 0.1,
    ];
    adaptive_nested(inner, 0.0, FRAC_PI_2, &breaks, 1e-13, 1e-8, 400).0
}

/// The base term's directional albedo from the closed form of physics.md §12.3
/// (flat coat): `(1−c)²ρ T_av(θi)(1 − r_e) / (n² (1 − (1−c)²ρ r_i))`, against a direct
/// numerical integration of the point BRDF over the hemisphere.
#[test]
fn base_albedo_against_direct_integration() {
    let n = 1.5;
    let o = Orientation::gaussian(GaussianWidth::Hwhm(5f64.to_radians())).unwrap();
    for (c, rho) in [(0.0, 1.0), (0.3, 0.7), (0.7, 0.2)] {
        let m = paint(CoatParams::flat(n), o.clone(), c, 1.0, rho);
        for ti in [0.0, 40.0, 70.0] {
            let ti = f64::to_radians(ti);
            let inc = m.incidence(ti).unwrap();
            let got = hemisphere(&|r| m.terms(&inc, r, 0).base, ti);
            let a = (1.0 - c) * (1.0 - c) * rho;
            let want =
                a * fresnel::air_to_coating(ti, n).t_av() * (1.0 - external_diffuse_reflectance(n))
                    / (n * n * (1.0 - a * internal_diffuse_reflectance(n)));
            assert!(
                (got - want).abs() < 1e-8,
                "c {c} rho {rho} ti {ti}: {got} vs {want}"
            );
        }
    }
}

/// The same albedo from a photon random walk that knows nothing of the geometric
/// series: a photon enters with probability `T_av(θi)`, crosses the flake layer with
/// probability `1 − c` each way, is reflected by the base with probability `ρ` into a
/// cosine-distributed direction, and at the surface leaves with the Fresnel
/// transmittance of its own inside angle (else it is reflected back down).
#[test]
fn base_albedo_against_a_photon_random_walk() {
    let n = 1.5;
    let (c, rho) = (0.3, 0.8);
    let ti = 35f64.to_radians();
    let o = Orientation::gaussian(GaussianWidth::Hwhm(5f64.to_radians())).unwrap();
    let m = paint(CoatParams::flat(n), o, c, 1.0, rho);
    let inc = m.incidence(ti).unwrap();
    let closed = hemisphere(&|r| m.terms(&inc, r, 0).base, ti);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let photons = 400_000;
    let mut out = 0u64;
    let t_in = fresnel::air_to_coating(ti, n).t_av();
    for _ in 0..photons {
        if rng.random::<f64>() >= t_in || rng.random::<f64>() >= 1.0 - c {
            continue;
        }
        loop {
            if rng.random::<f64>() >= rho || rng.random::<f64>() >= 1.0 - c {
                break;
            }
            // Cosine-weighted inside direction: sin²θ uniform.
            let theta = rng.random::<f64>().sqrt().asin();
            let t = fresnel::coating_to_air(theta, n).map_or(0.0, |p| p.t_av());
            if rng.random::<f64>() < t {
                out += 1;
                break;
            }
            if rng.random::<f64>() >= 1.0 - c {
                break;
            }
        }
    }
    let p = out as f64 / photons as f64;
    let se = (p * (1.0 - p) / photons as f64).sqrt();
    assert!((p - closed).abs() < 4.0 * se, "walk {p} ± {se} vs {closed}");
}

/// Energy: the directional albedo (the hemispherical integral of every term, plus the
/// flat coat's specular delta) never exceeds 1, for parameter sets at the edges of
/// their ranges.
#[test]
fn energy_is_conserved() {
    let extreme = [
        // Everything that reflects at its maximum, a rough and hazy coat.
        (
            CoatParams {
                n: 1.5,
                roughness: 0.6,
                haze: 0.5,
                haze_roughness: 1.5,
            },
            Orientation::trowbridge_reitz(0.3).unwrap(),
            0.5,
            1.0,
            1.0,
        ),
        // No flakes, white base, flat coat: all that enters comes out (1 − R + R = 1).
        (
            CoatParams::flat(1.5),
            Orientation::gaussian(GaussianWidth::Hwhm(4f64.to_radians())).unwrap(),
            0.0,
            1.0,
            1.0,
        ),
        // No flakes, white base, a rough coat: what the rough surface does not reflect
        // enters and, after the base, leaves again.
        (
            CoatParams {
                n: 1.5,
                roughness: 0.6,
                haze: 0.5,
                haze_roughness: 1.5,
            },
            Orientation::gaussian(GaussianWidth::Hwhm(4f64.to_radians())).unwrap(),
            0.0,
            1.0,
            1.0,
        ),
        // Full coverage of very heavy-tailed flakes.
        (
            CoatParams {
                n: 1.8,
                roughness: 0.1,
                haze: 0.0,
                haze_roughness: 0.0,
            },
            Orientation::pearson_vii(0.3, 0.6).unwrap(),
            1.0,
            1.0,
            1.0,
        ),
    ];
    for (case, (coat, o, c, s, rho)) in extreme.into_iter().enumerate() {
        let m = paint(coat, o, c, s, rho);
        for ti in [0.0, 30.0, 60.0, 80.0] {
            let ti = f64::to_radians(ti);
            let inc = m.incidence(ti).unwrap();
            let total = hemisphere(&|r| m.brdf(&inc, r, 0), ti) + m.specular_delta(ti);
            // A rough coat's transmitted power is 1 − A from its albedo table, within
            // 2e-4 of the exact albedo (coat.rs): the bound holds to that.
            let tolerance = if m.coat().is_flat() { 1e-6 } else { 2e-4 };
            assert!(
                total <= 1.0 + tolerance,
                "case {case} at {ti}: albedo {total}"
            );
            assert!(total > 0.0);
            if case == 1 || case == 2 {
                // A white base with no flakes returns everything that enters, under a flat
                // coat and (with its own internal reflectance) under a rough one.
                assert!(
                    (total - 1.0).abs() < tolerance,
                    "white base, case {case}: {total}"
                );
            }
        }
    }
}
