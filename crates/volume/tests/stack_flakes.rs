//! Interference (thin-film stack) flakes in the volume model (physics.md §10, §13): a
//! free flake's face reflects `R`, absorbs `A` and passes `T` on through the flake.
//!
//! * The energy balance sums to 1 within 1e-12 with stack flakes (clear and absorbing),
//!   whatever the substrate and rim rule: the transmitted light is followed on (to the
//!   substrate, out of the coat, or to another flake), never lost.
//! * Closed form at normal incidence, one flat flake under the top interface, black
//!   substrate (derivation in `one_flat_stack_flake_splits_as_the_airy_formula`).
//! * A stack of no layers on an aluminium core is the aluminium flake.

use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::thinfilm::{FilmStack, Layer as FilmLayer};
use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{
    Amount, Diameter, Flake, Layer, LayerParams, LayerSpec, RimRule, Substrate, TraceOptions,
    Tracer,
};

fn one_layer(n: f64, k: f64, d_nm: f64) -> FlakeReflectance {
    let stack = FilmStack::new(vec![FilmLayer::new(Complex::new(n, k), d_nm).unwrap()]).unwrap();
    FlakeReflectance::stack(stack, 550.0, None).unwrap()
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
fn energy_balance_sums_to_one_with_stack_flakes() {
    let layer = tilted_layer(3);
    let angles = [0.0f64, 35.0, 70.0].map(f64::to_radians);
    let cones = [Cone::in_plane(0.0, 2f64.to_radians()).unwrap()];
    // A clear TiO2-like film, an absorbing asymmetric two-layer stack (its faces differ).
    let absorbing = FilmStack::new(vec![
        FilmLayer::new(Complex::new(2.6, 0.3), 80.0).unwrap(),
        FilmLayer::new(Complex::new(1.6, 0.0), 300.0).unwrap(),
    ])
    .unwrap();
    let flakes = [
        one_layer(2.6, 0.0, 120.0),
        FlakeReflectance::stack(absorbing, 600.0, None).unwrap(),
    ];
    let configs = [
        (Substrate::Black, RimRule::Absorb),
        (Substrate::Specular(0.7), RimRule::Ignore),
        (Substrate::Lambertian(0.5), RimRule::Diffuse),
    ];
    for (m, flake) in flakes.iter().enumerate() {
        for &(substrate, rims) in &configs {
            let options = TraceOptions {
                flake: flake.clone(),
                substrate,
                rims,
                rays: 64 * 300,
                seed: 5,
                ..TraceOptions::default()
            };
            let res = Tracer::new(&layer, options)
                .unwrap()
                .run(&angles, &cones)
                .unwrap();
            for (i, e) in res.energy.iter().enumerate() {
                eprintln!(
                    "stack {m} {substrate:?} {rims:?} θi {:.0}: total − 1 = {:.2e}, \
                     substrate {:.4}, flakes {:.4}, escaped {:.4}",
                    angles[i].to_degrees(),
                    e.total() - 1.0,
                    e.absorbed_substrate,
                    e.absorbed_flakes,
                    e.escaped_single + e.escaped_multiple
                );
                assert!((e.total() - 1.0).abs() < 1e-12, "{e:?}");
                if m == 0 {
                    // A clear stack absorbs nothing (to rounding).
                    assert!(e.absorbed_flakes.abs() < 1e-12, "{e:?}");
                } else {
                    assert!(e.absorbed_flakes > 0.0);
                }
                if m == 0 && substrate == Substrate::Black {
                    // The light the flakes pass on reaches the black substrate: more than
                    // the bare film's share of rays that miss every flake.
                    assert!(e.absorbed_substrate > 0.5, "{e:?}");
                }
            }
        }
    }
}

/// Derivation. Normal incidence, binder `n = 1.5`; the coat passes `a = 1 − ρ`,
/// `ρ = ((n − 1)/(n + 1))² = 0.04`, equally in both channels, and reflects `ρ` back down
/// from inside at normal incidence. One flat flake of radius `r` lies 5 µm under the top
/// interface in a tile of side `L`; a ray meets its top face with probability
/// `c = π r²/L²` (its shadow), else it goes straight to the black substrate. The flake is
/// a lossless film of index 2.6, 53 nm thick (near a quarter wave), at 550 nm in the
/// binder (Airy formula):
/// `r = (r₀₁ + r₁₂ e^{2iδ})/(1 + r₀₁ r₁₂ e^{2iδ})`, `r₀₁ = (n − 2.6)/(n + 2.6) = −r₁₂`,
/// `δ = 2π · 2.6 · 53/550`, `R = |r|²`, `T = 1 − R` (same for s and p at normal
/// incidence). At the flake the ray is reflected with probability `R` keeping its weight
/// (the split's weights `w R (R + T)/R = w`), or transmitted, also keeping it. Reflected,
/// it rises straight up, leaves `a` of its weight (the first time: the single bounce),
/// and `ρ` comes back down onto the same point of the flake. So a ray that meets the
/// flake puts `Z = ρᵐ` of `a` into the substrate with probability `Rᵐ T`, and its first
/// escape `a²` with probability `R`:
///
/// * `E[single] = a² c R`, a Bernoulli variable of `a²` with `p = c R`;
/// * `E[substrate] = a (1 − c) + a c T/(1 − R ρ)` (the share reaching the substrate is
///   `T` times what reaches the flake, summed over the returns), with
///   `E[substrate²] = a² ((1 − c) + c T/(1 − R ρ²))`;
/// * `E[escaped] = a² c R/(1 − R ρ)`, each ray's escapes at most `a`.
///
/// Had the transmitted light been counted as absorbed, the substrate would get only
/// `a (1 − c) ≈ 0.48` instead of `≈ 0.84`.
#[test]
fn one_flat_stack_flake_splits_as_the_airy_formula() {
    let n = 1.5;
    let (tile, radius, thickness) = (20.0, 8.0, 0.5);
    let flake = Flake {
        centre: Vec3::new(10.0, 10.0, -(5.0 + 0.5 * thickness)),
        normal: UnitVec3::new_normalize(Vec3::z()),
        radius_um: radius,
        thickness_um: thickness,
    };
    let layer = Layer::from_flakes(40.0, tile, vec![flake]).unwrap();
    let options = TraceOptions {
        n,
        flake: one_layer(2.6, 0.0, 53.0),
        rays: 64 * 4000,
        seed: 17,
        min_weight: 1e-16,
        max_events: 5000,
        ..TraceOptions::default()
    };
    let cone = Cone::in_plane(0.0, 1f64.to_radians()).unwrap();
    let res = Tracer::new(&layer, options)
        .unwrap()
        .run(&[0.0], &[cone])
        .unwrap();
    let e = &res.energy[0];
    let nn = res.rays_per_incidence as f64;

    // Airy.
    let (n0, n1) = (Complex::new(n, 0.0), Complex::new(2.6, 0.0));
    let r01 = (n0 - n1) / (n0 + n1);
    let r12 = -r01;
    let delta = 2.0 * std::f64::consts::PI * 2.6 * 53.0 / 550.0;
    let ph = Complex::new(0.0, 2.0 * delta).exp();
    let big_r = ((r01 + r12 * ph) / (Complex::new(1.0, 0.0) + r01 * r12 * ph)).norm_sqr();
    let big_t = 1.0 - big_r;
    let rho: f64 = ((n - 1.0) / (n + 1.0)).powi(2);
    let a = 1.0 - rho;
    let c = std::f64::consts::PI * radius * radius / (tile * tile);
    assert!((fresnel::air_to_coating(0.0, n).r_av() - rho).abs() < 1e-15);

    let p = c * big_r;
    let single = a * a * p;
    let single_sd = a * a * (p * (1.0 - p) / nn).sqrt();
    let sub = a * (1.0 - c) + a * c * big_t / (1.0 - big_r * rho);
    let sub2 = a * a * ((1.0 - c) + c * big_t / (1.0 - big_r * rho * rho));
    let sub_sd = ((sub2 - sub * sub) / nn).sqrt();
    let esc = a * a * c * big_r / (1.0 - big_r * rho);
    let esc_sd = 0.5 * a / nn.sqrt();
    eprintln!("R = {big_r:.6}, T = {big_t:.6}, c = {c:.6}");
    eprintln!(
        "single {:.6} expected {single:.6} ± {single_sd:.1e}",
        e.escaped_single
    );
    eprintln!(
        "substrate {:.6} expected {sub:.6} ± {sub_sd:.1e}",
        e.absorbed_substrate
    );
    eprintln!(
        "escaped {:.6} expected {esc:.6} (sd ≤ {esc_sd:.1e})",
        e.escaped_single + e.escaped_multiple
    );
    eprintln!("total − 1 = {:.2e}", e.total() - 1.0);
    assert!(big_r > 0.2 && big_t > 0.7, "R {big_r}, T {big_t}");
    assert!((e.escaped_single - single).abs() < 4.5 * single_sd);
    assert!((e.absorbed_substrate - sub).abs() < 4.5 * sub_sd);
    assert!((e.escaped_single + e.escaped_multiple - esc).abs() < 4.5 * esc_sd);
    assert!(e.absorbed_flakes.abs() < 1e-12);
    assert!(e.absorbed_rims == 0.0 && e.cut_off < 1e-15);
    assert!((e.total() - 1.0).abs() < 1e-12);
}

#[test]
fn a_bare_aluminium_core_is_the_aluminium_flake() {
    let layer = tilted_layer(4);
    let angles = [0.0f64, 45.0].map(f64::to_radians);
    let cones = [
        Cone::in_plane(0.0, 2f64.to_radians()).unwrap(),
        Cone::in_plane(-45f64.to_radians(), 3f64.to_radians()).unwrap(),
    ];
    let run = |flake: FlakeReflectance| {
        let options = TraceOptions {
            flake,
            substrate: Substrate::Specular(0.6),
            rays: 64 * 200,
            seed: 9,
            ..TraceOptions::default()
        };
        Tracer::new(&layer, options)
            .unwrap()
            .run(&angles, &cones)
            .unwrap()
    };
    let metal = run(FlakeReflectance::aluminium_550nm());
    let cored = run(FlakeReflectance::stack(
        FilmStack::new(Vec::new()).unwrap(),
        550.0,
        Some(Complex::new(0.96, 6.69)),
    )
    .unwrap());
    for (a, b) in metal.energy.iter().zip(&cored.energy) {
        assert!((a.absorbed_flakes - b.absorbed_flakes).abs() < 1e-12);
        assert!((a.escaped_multiple - b.escaped_multiple).abs() < 1e-12);
        assert!((a.absorbed_substrate - b.absorbed_substrate).abs() < 1e-12);
        assert!(b.absorbed_flakes > 0.0);
    }
    for (a, b) in metal.points.iter().zip(&cored.points) {
        assert!((a.reflectance - b.reflectance).abs() < 1e-12);
    }
}
