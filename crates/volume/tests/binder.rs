//! A tinted binder in the volume model (physics.md §10, "Tinted binder"): Beer–Lambert
//! along every path inside the film, its share tallied as `absorbed_binder`.
//!
//! Notation: `n` the binder's index, `θt` the refracted angle inside
//! (`sin θt = sin θi / n`), `T_c` the Fresnel power transmittance air → film of channel
//! `c ∈ {s, p}` at `θi` (the same both ways for the Snell pair), `R_in,c = 1 − T_c` the
//! internal reflectance at the top from inside, `α` the absorption coefficient (µm⁻¹).
//! A ray starts with channel weights `½ T_c`.
//!
//! **Film without flakes over a mirror of reflectance `R_m`** (every ray the same path,
//! so the Monte Carlo is exact and its standard error 0). Going down the film thickness
//! `d` keeps `g = exp(−α d / cos θt)`; one round trip (down, mirror, up) keeps
//! `g² R_m`; at the top `T_c` escapes and `R_in,c` goes round again. Per channel, with
//! `q_c = g² R_m R_in,c`:
//!
//! * escaped `E_c = ½ T_c² g² R_m / (1 − q_c)` (all into the specular cone);
//! * substrate `S_c = ½ T_c g (1 − R_m) / (1 − q_c)`;
//! * binder `B_c = ½ T_c (1 − g)(1 + g R_m) / (1 − q_c)` (the descent takes `1 − g` of
//!   what starts down, the ascent `1 − g` of the `g R_m` that comes back up);
//!
//! and `E + S + B = ½ T_c` (the sum checks the algebra). A black substrate is
//! `R_m = 0`: `S_c = ½ T_c g`, `B_c = ½ T_c (1 − g)`, nothing escapes. The reflectance
//! into the specular cone is `½(R_s + R_p) + Σ_c E_c`.
//!
//! **One flat flake whose round trip shifts a ray by one tile** (the geometry of
//! `closed_form.rs`, top face at depth `h`): a ray that meets the flake meets it at the
//! same place after every internal reflection. Per round trip `a = exp(−2 α h / cos θt)`;
//! with flake reflectance `R_f,c`, single `½ T_c² R_f,c a`, multiple/single
//! `q/(1 − q)` with `q = R_in,c R_f,c a` (exact per ray), and the binder takes
//! `½ T_c (1 − √a)(1 + √a R_f,c)/(1 − q)` from a ray that meets the flake and
//! `½ T_c (1 − g)` (black substrate) from one that does not. Which rays meet it is
//! binomial with `p = π r²/L²`, so with the realised fraction `p̂` (read off the single
//! bounce) the binder's share is exact, and `p̂` is within `4σ` of `p`.
//!
//! **One flat free stack flake at normal incidence** (lossless layers, black substrate):
//! the transmitted ray crosses the flake's thickness `t`, which is not binder. Per unit
//! weight arriving at the top face from above, the substrate gets
//! `X = T g₂ / (1 − R ρ g₁²)` with `g₁ = exp(−α h)` (top face ↔ interface),
//! `g₂ = exp(−α (d − h − t))` (bottom face → substrate) and `ρ` the internal reflectance
//! (`R_in` at normal incidence); the substrate's share is
//! `(1 − c)(1 − ρ) e^{−α d} + c (1 − ρ) g₁ X`, checked within 4.5 standard errors.
//! Counting the flake's own thickness as binder would lower it by about 4 % of the
//! transmitted part — well outside the error.

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer as FilmLayer};
use flakescatter_optics::{UnitVec3, Vec3, refraction};
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{
    Amount, Diameter, Flake, Layer, LayerParams, LayerSpec, RimRule, Substrate, TraceOptions,
    Tracer, VolumeError,
};

const N: f64 = 1.5;

fn cos_t(theta_i: f64) -> f64 {
    refraction::snell_inside(theta_i, N).cos()
}

/// Per channel `(escaped, substrate, binder)` of the no-flake film (module docs).
fn film_series(t: f64, r_m: f64, g: f64) -> (f64, f64, f64) {
    let q = g * g * r_m * (1.0 - t);
    (
        0.5 * t * t * g * g * r_m / (1.0 - q),
        0.5 * t * g * (1.0 - r_m) / (1.0 - q),
        0.5 * t * (1.0 - g) * (1.0 + g * r_m) / (1.0 - q),
    )
}

#[test]
fn a_film_without_flakes_is_fresnel_beer_lambert_and_the_internal_series() {
    let (film, alpha) = (20.0, 0.015);
    let layer = Layer::from_flakes(film, 50.0, Vec::new()).unwrap();
    let angles = [0.0f64, 40.0, 70.0].map(f64::to_radians);
    let cones: Vec<Cone> = angles
        .iter()
        .map(|&t| Cone::in_plane(-t, 1f64.to_radians()).unwrap())
        .collect();
    for r_m in [0.0, 0.9] {
        let options = TraceOptions {
            n: N,
            substrate: if r_m == 0.0 {
                Substrate::Black
            } else {
                Substrate::Specular(r_m)
            },
            rays: 640,
            min_weight: 1e-16,
            max_events: 5000,
            binder_alpha_per_um: alpha,
            ..TraceOptions::default()
        };
        let res = Tracer::new(&layer, options)
            .unwrap()
            .run(&angles, &cones)
            .unwrap();
        for (i, &ti) in angles.iter().enumerate() {
            let f = fresnel::air_to_coating(ti, N);
            let g = (-alpha * film / cos_t(ti)).exp();
            let (es, ss, bs) = film_series(f.ts, r_m, g);
            let (ep, sp, bp) = film_series(f.tp, r_m, g);
            let half_t = 0.5 * (f.ts + f.tp);
            assert!((es + ss + bs + ep + sp + bp - half_t).abs() < 1e-15);
            let e = &res.energy[i];
            let se = &res.energy_std_err[i];
            eprintln!(
                "R_m {r_m}, θi {:.0}°: binder {:.15} expected {:.15}, escaped {:.15} expected {:.15}",
                ti.to_degrees(),
                e.absorbed_binder,
                bs + bp,
                e.escaped_multiple,
                es + ep
            );
            // Every ray follows the same path: the standard errors are 0 (to rounding),
            // so "within 4σ" is "equal to rounding".
            let tol = |s: f64| (4.0 * s).max(1e-12);
            assert!((e.absorbed_binder - (bs + bp)).abs() < tol(se.absorbed_binder));
            assert!((e.absorbed_substrate - (ss + sp)).abs() < tol(se.absorbed_substrate));
            assert!((e.escaped_multiple - (es + ep)).abs() < tol(se.escaped_multiple));
            assert_eq!(e.escaped_single, 0.0);
            assert!((e.total() - 1.0).abs() < 1e-12);
            let p = &res.points[i * cones.len() + i];
            assert!((p.reflectance - (f.r_av() + es + ep)).abs() < tol(p.reflectance_std_err));
        }
    }
}

/// One flat flake whose round trip shifts the ray by one tile width at `theta_i`
/// (`closed_form.rs`); returns it and the depth of its top face.
fn returning_flake(theta_i: f64, tile: f64, radius: f64, thickness: f64) -> (Flake, f64) {
    let k1 = refraction::into_coating(&detector::incident_direction(theta_i), N);
    let tan_t = k1.x / -k1.z;
    let h_top = if tan_t > 0.0 {
        tile / (2.0 * tan_t)
    } else {
        5.0
    };
    let flake = Flake {
        centre: Vec3::new(10.0, 10.0, -(h_top + 0.5 * thickness)),
        normal: UnitVec3::new_normalize(Vec3::z()),
        radius_um: radius,
        thickness_um: thickness,
    };
    (flake, h_top)
}

#[test]
fn one_returning_flake_gives_the_attenuated_series_and_the_binder_share() {
    let (tile, radius, thickness, film, alpha) = (20.0, 8.0, 0.5, 40.0, 0.02);
    for (theta_deg, flake_r) in [
        (0.0, FlakeReflectance::PerfectConductor),
        (45.0, FlakeReflectance::aluminium_550nm()),
        (60.0, FlakeReflectance::aluminium_550nm()),
    ] {
        let theta_i = f64::to_radians(theta_deg);
        let (flake, h) = returning_flake(theta_i, tile, radius, thickness);
        let layer = Layer::from_flakes(film, tile, vec![flake]).unwrap();
        let options = TraceOptions {
            n: N,
            flake: flake_r.clone(),
            // Rays passing by the rim go through the flake as if it were binder, so a
            // ray either meets the top face or runs down to the substrate.
            rims: RimRule::Ignore,
            rays: 64 * 4000,
            seed: 11,
            min_weight: 1e-16,
            max_events: 5000,
            binder_alpha_per_um: alpha,
            ..TraceOptions::default()
        };
        let cone = Cone::in_plane(-theta_i, 1f64.to_radians()).unwrap();
        let res = Tracer::new(&layer, options)
            .unwrap()
            .run(&[theta_i], &[cone])
            .unwrap();
        let e = &res.energy[0];
        let f = fresnel::air_to_coating(theta_i, N);
        let ct = cos_t(theta_i);
        let a = (-2.0 * alpha * h / ct).exp();
        let g = (-alpha * film / ct).exp();
        let (rfs, rfp) = flake_r.power(ct, N);
        let mut single = 0.0;
        let mut multiple = 0.0;
        let mut binder_hit = 0.0;
        let mut binder_miss = 0.0;
        for (t, rf) in [(f.ts, rfs), (f.tp, rfp)] {
            let q = (1.0 - t) * rf * a;
            let s = 0.5 * t * t * rf * a;
            single += s;
            multiple += s * q / (1.0 - q);
            binder_hit += 0.5 * t * (1.0 - a.sqrt()) * (1.0 + a.sqrt() * rf) / (1.0 - q);
            binder_miss += 0.5 * t * (1.0 - g);
        }
        let ratio = e.escaped_multiple / e.escaped_single;
        assert!(
            (ratio / (multiple / single) - 1.0).abs() < 1e-12,
            "θi {theta_deg}: {ratio} vs {}",
            multiple / single
        );
        let p = std::f64::consts::PI * radius * radius / (tile * tile);
        let hit = e.escaped_single / single;
        let sd = (p * (1.0 - p) / res.rays_per_incidence as f64).sqrt();
        let binder = binder_miss + hit * (binder_hit - binder_miss);
        eprintln!(
            "θi {theta_deg}°: hit {hit:.5} expected {p:.5} ± {sd:.5}; binder {:.15} expected {binder:.15}",
            e.absorbed_binder
        );
        assert!(
            (hit - p).abs() < 4.0 * sd,
            "hit fraction {hit} vs {p} ± {sd}"
        );
        assert!((e.absorbed_binder - binder).abs() < 1e-12);
        assert!((e.total() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn the_stretch_through_a_free_stack_flake_is_not_binder() {
    let (tile, radius, thickness, film, h, alpha) = (20.0, 8.0, 1.0, 20.0, 5.0, 0.1);
    let flake = Flake {
        centre: Vec3::new(10.0, 10.0, -(h + 0.5 * thickness)),
        normal: UnitVec3::new_normalize(Vec3::z()),
        radius_um: radius,
        thickness_um: thickness,
    };
    let layer = Layer::from_flakes(film, tile, vec![flake]).unwrap();
    let stack =
        FilmStack::new(vec![FilmLayer::new(Complex::new(2.6, 0.0), 53.0).unwrap()]).unwrap();
    let flake_r = FlakeReflectance::stack(stack, 550.0, None).unwrap();
    let (big_r, _) = flake_r.power(1.0, N);
    let (big_t, _) = flake_r.transmitted(1.0, N);
    let options = TraceOptions {
        n: N,
        flake: flake_r,
        rays: 64 * 4000,
        seed: 5,
        min_weight: 1e-16,
        max_events: 5000,
        binder_alpha_per_um: alpha,
        ..TraceOptions::default()
    };
    let cone = Cone::in_plane(0.0, 1f64.to_radians()).unwrap();
    let res = Tracer::new(&layer, options)
        .unwrap()
        .run(&[0.0], &[cone])
        .unwrap();
    let rho = ((N - 1.0) / (N + 1.0)).powi(2);
    let c = std::f64::consts::PI * radius * radius / (tile * tile);
    let (g1, g2) = ((-alpha * h).exp(), (-alpha * (film - h - thickness)).exp());
    let x = big_t * g2 / (1.0 - big_r * rho * g1 * g1);
    let sub = (1.0 - c) * (1.0 - rho) * (-alpha * film).exp() + c * (1.0 - rho) * g1 * x;
    // What it would be with the flake's thickness counted as binder.
    let wrong = sub - c * (1.0 - rho) * g1 * x * (1.0 - (-alpha * thickness).exp());
    let e = &res.energy[0];
    let se = res.energy_std_err[0].absorbed_substrate;
    eprintln!(
        "R {big_r:.5} T {big_t:.5}: substrate {:.6} expected {sub:.6} ± {se:.1e} (thickness as binder: {wrong:.6})",
        e.absorbed_substrate
    );
    assert!(big_t > 0.7 && (big_r + big_t - 1.0).abs() < 1e-12);
    assert!((e.absorbed_substrate - sub).abs() < 4.5 * se);
    assert!((wrong - sub).abs() > 10.0 * se);
    assert!((e.total() - 1.0).abs() < 1e-12);
}

fn tilted_layer(seed: u64) -> Layer {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(12f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(o, 150.0, seed);
    spec.film_um = 15.0;
    spec.diameter = Diameter::LogNormal {
        mean_um: 8.0,
        rel_sd: 0.25,
    };
    spec.thickness_um = 0.5;
    spec.amount = Amount::VolumeFraction(0.05);
    Layer::generate(&LayerParams::new(spec).unwrap()).unwrap()
}

#[test]
fn energy_balance_sums_to_one_with_a_tinted_binder_flakes_and_stacks() {
    let layer = tilted_layer(8);
    let angles = [0.0f64, 35.0, 70.0].map(f64::to_radians);
    let cones: Vec<Cone> = (-6..=6)
        .map(|k| Cone::in_plane(f64::from(k * 10).to_radians(), 2f64.to_radians()).unwrap())
        .collect();
    let stack = |k: f64| {
        FilmStack::new(vec![
            FilmLayer::new(Complex::new(2.6, k), 80.0).unwrap(),
            FilmLayer::new(Complex::new(1.6, 0.0), 300.0).unwrap(),
        ])
        .unwrap()
    };
    let flakes = [
        FlakeReflectance::PerfectConductor,
        FlakeReflectance::aluminium_550nm(),
        FlakeReflectance::stack(stack(0.0), 550.0, None).unwrap(),
        FlakeReflectance::stack(stack(0.3), 550.0, None).unwrap(),
        FlakeReflectance::stack(stack(0.0), 550.0, Some(Complex::new(0.96, 6.69))).unwrap(),
    ];
    let substrates = [
        Substrate::Black,
        Substrate::Specular(0.8),
        Substrate::Lambertian(0.6),
    ];
    let rims = [RimRule::Absorb, RimRule::Ignore, RimRule::Diffuse];
    let mut checked = 0;
    for (j, flake) in flakes.iter().enumerate() {
        for (k, &substrate) in substrates.iter().enumerate() {
            let options = TraceOptions {
                flake: flake.clone(),
                substrate,
                rims: rims[(j + k) % 3],
                rays: 6400,
                seed: 3,
                binder_alpha_per_um: 0.04,
                ..TraceOptions::default()
            };
            let res = Tracer::new(&layer, options)
                .unwrap()
                .run(&angles, &cones)
                .unwrap();
            for e in &res.energy {
                let total = e.total();
                assert!(
                    (total - 1.0).abs() < 1e-12,
                    "{flake:?} {substrate:?}: total {total:.17} {e:?}"
                );
                // 15 µm of film at α = 0.04/µm: at least the straight crossing of a
                // ray that reaches the substrate takes a visible share.
                assert!(e.absorbed_binder > 0.05, "{e:?}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 45);
}

#[test]
fn a_negative_or_non_finite_coefficient_is_refused_by_name() {
    let layer = Layer::from_flakes(10.0, 50.0, Vec::new()).unwrap();
    for a in [-0.1, f64::NAN, f64::INFINITY] {
        let options = TraceOptions {
            binder_alpha_per_um: a,
            ..TraceOptions::default()
        };
        match Tracer::new(&layer, options) {
            Err(VolumeError::Parameter { name, .. }) => assert_eq!(name, "binder_absorption"),
            other => panic!("α {a}: {other:?}"),
        }
    }
}
