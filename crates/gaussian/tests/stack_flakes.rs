//! Interference flakes in the distribution model (physics.md §13): a thin-film stack's
//! reflectance replaces the metal's, nothing else changes. Checked against the bulk metal
//! (a thick metal layer), against the Airy formula of a single layer written here, and
//! the hemispherical albedo against the metal's and 1.

use flakescatter_gaussian::hemisphere::total_detector_space;
use flakescatter_gaussian::{DistributionModel, ModelOptions};
use flakescatter_optics::Vec3;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::polarization::Transmission;
use flakescatter_optics::thinfilm::{FilmStack, Layer};
use flakescatter_stats::{GaussianWidth, Orientation};

const N: f64 = 1.5;

fn model(flake: FlakeReflectance, transmission: Transmission, hwhm_deg: f64) -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
    let options = ModelOptions {
        flake,
        transmission,
        ..ModelOptions::default()
    };
    DistributionModel::new(o, N, options).unwrap()
}

fn stack(layers: &[(f64, f64, f64)], wl: f64, core: Option<Complex<f64>>) -> FlakeReflectance {
    let l = layers
        .iter()
        .map(|&(n, k, d)| Layer::new(Complex::new(n, k), d).unwrap())
        .collect();
    FlakeReflectance::stack(FilmStack::new(l).unwrap(), wl, core).unwrap()
}

fn detector(theta_s_deg: f64, phi_deg: f64) -> Vec3 {
    let (t, p) = (theta_s_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(-t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// A 1 µm aluminium layer is bulk aluminium: every point BRDF equals the metal flake's
/// to 1e-9 relative, in and out of the plane, for every transmission mode.
#[test]
fn thick_aluminium_stack_is_the_metal_flake() {
    let (n, k) = (0.96, 6.69);
    for t in [
        Transmission::ExactUnpolarized,
        Transmission::S,
        Transmission::P,
    ] {
        let metal = model(FlakeReflectance::complex(n, k).unwrap(), t, 7.0);
        let thick = model(stack(&[(n, k, 1000.0)], 550.0, None), t, 7.0);
        let on_core = model(
            stack(&[(1.5, 0.0, 1e-3)], 550.0, Some(Complex::new(n, k))),
            t,
            7.0,
        );
        for ti in [0.0f64, 30.0, 60.0] {
            let (a, b, c) = (
                metal.incidence(ti.to_radians()).unwrap(),
                thick.incidence(ti.to_radians()).unwrap(),
                on_core.incidence(ti.to_radians()).unwrap(),
            );
            for (ts, phi) in [
                (-80.0, 0.0),
                (-30.0, 0.0),
                (0.0, 0.0),
                (20.0, 0.0),
                (40.0, 35.0),
            ] {
                let r = detector(ts, phi);
                let want = metal.brdf(&a, &r);
                for got in [thick.brdf(&b, &r), on_core.brdf(&c, &r)] {
                    assert!(
                        (got - want).abs() <= 1e-9 * want.abs(),
                        "{t:?} θi {ti} θs {ts}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// At the specular detector the facet is flat (cos ι = cos θt), so the stack flake's
/// BRDF over the perfect conductor's is the stack's s reflectance there (s-only
/// transmission): for one lossless layer n₁, d in the binder n₀ = 1.5, the Airy formula
/// `R = 2r²(1 − cos 2β)/(1 + r⁴ − 2r² cos 2β)`, `r = (n₀c₀ − n₁c₁)/(n₀c₀ + n₁c₁)`,
/// `β = 2π n₁ d c₁/λ`, with real trigonometry only.
#[test]
fn specular_ratio_is_the_airy_reflectance() {
    let (n1, d, wl) = (2.6, 140.0, 530.0);
    let film = model(stack(&[(n1, 0.0, d)], wl, None), Transmission::S, 5.0);
    let mirror = model(FlakeReflectance::PerfectConductor, Transmission::S, 5.0);
    for ti in [0.0f64, 20.0, 45.0, 70.0] {
        let t = ti.to_radians();
        let c0 = (1.0 - (t.sin() / N).powi(2)).sqrt(); // cos θt in the binder
        let s0 = t.sin(); // n₀ sin θt = sin θi
        let c1 = (1.0 - (s0 / n1).powi(2)).sqrt();
        let r = (N * c0 - n1 * c1) / (N * c0 + n1 * c1);
        let cb = (4.0 * std::f64::consts::PI * n1 * d * c1 / wl).cos();
        let airy = 2.0 * r * r * (1.0 - cb) / (1.0 + r.powi(4) - 2.0 * r * r * cb);
        let spec = Vec3::new(t.sin(), 0.0, t.cos());
        let ratio = film.brdf(&film.incidence(t).unwrap(), &spec)
            / mirror.brdf(&mirror.incidence(t).unwrap(), &spec);
        assert!((ratio - airy).abs() < 1e-12, "θi {ti}: {ratio} vs {airy}");
    }
}

/// The directional albedo of a stack flake's coating is at most the perfect mirror's
/// and at most 1 (the light the flakes transmit leaves the model), and a lossless free
/// stack keeps the rest: its albedo is between the mirror's times the stack's least and
/// greatest reflectance over the facets' angles.
#[test]
fn albedo_is_at_most_one() {
    let film = model(
        stack(
            &[(2.6, 0.0, 120.0), (1.6, 0.0, 400.0), (2.6, 0.0, 120.0)],
            550.0,
            None,
        ),
        Transmission::ExactUnpolarized,
        10.0,
    );
    let mirror = model(
        FlakeReflectance::PerfectConductor,
        Transmission::ExactUnpolarized,
        10.0,
    );
    let f = film.options().flake.clone();
    // Stack reflectance over the facets' local incidence cosines (0.3 to 1 covers every
    // facet within 60° of the axis lit from θi ≤ 45°).
    let rs: Vec<f64> = (0..=700)
        .map(|i| f.average(0.3 + 0.001 * i as f64, N))
        .collect();
    let (lo, hi) = rs
        .iter()
        .fold((1.0f64, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    for ti in [0.0f64, 30.0, 45.0] {
        let t = ti.to_radians();
        let (af, ef) = total_detector_space(&film, &film.incidence(t).unwrap());
        let (am, _) = total_detector_space(&mirror, &mirror.incidence(t).unwrap());
        assert!(af <= 1.0 && af <= am + ef, "θi {ti}: {af} vs mirror {am}");
        assert!(
            af >= lo * am * 0.98 && af <= hi * am * 1.02,
            "θi {ti}: {af} not in [{lo}, {hi}] × {am}"
        );
    }
}
