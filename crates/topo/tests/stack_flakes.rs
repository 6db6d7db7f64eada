//! Interference flakes in the topographic model (physics.md §13): the stack's reflectance
//! replaces the metal's. A 1 µm aluminium layer is bulk aluminium (the metal flake's
//! numbers to 1e-9), and on a tilted plane (every ray on the same facet, cos ι known in
//! closed form) a single lossless layer scales the perfect mirror's reflectance by the
//! Airy formula written here.

use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::polarization::Transmission;
use flakescatter_optics::thinfilm::{FilmStack, Layer};
use flakescatter_stats::HeightMap;
use flakescatter_topo::{TopoModel, TopoOptions};

const N: f64 = 1.5;

fn plane(a: f64) -> HeightMap {
    let (nx, ny) = (40, 30);
    let z = (0..nx * ny)
        .map(|i| a * (i % nx) as f64 * 0.5 + 1.0)
        .collect();
    HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap()
}

fn rough() -> HeightMap {
    let (nx, ny) = (48, 48);
    let z = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as f64, (i / nx) as f64);
            0.3 * (0.31 * x).sin() + 0.2 * (0.17 * y + 0.4 * x).cos()
        })
        .collect();
    HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap()
}

fn stack(layers: &[(f64, f64, f64)], wl: f64) -> FlakeReflectance {
    let l = layers
        .iter()
        .map(|&(n, k, d)| Layer::new(Complex::new(n, k), d).unwrap())
        .collect();
    FlakeReflectance::stack(FilmStack::new(l).unwrap(), wl, None).unwrap()
}

#[test]
fn thick_aluminium_stack_is_the_metal_flake() {
    let (n, k) = (0.96, 6.69);
    let map = rough();
    let cones: Vec<Cone> = [-60.0f64, -30.0, -10.0, 0.0, 25.0]
        .iter()
        .map(|&t| Cone::in_plane(t.to_radians(), 3f64.to_radians()).unwrap())
        .collect();
    let thetas = [0.0f64.to_radians(), 30f64.to_radians(), 50f64.to_radians()];
    for t in [Transmission::ExactUnpolarized, Transmission::P] {
        let opts = |flake| TopoOptions {
            flake,
            transmission: t,
            ..TopoOptions::default()
        };
        let metal = TopoModel::new(opts(FlakeReflectance::complex(n, k).unwrap())).unwrap();
        let thick = TopoModel::new(opts(stack(&[(n, k, 1000.0)], 550.0))).unwrap();
        let a = metal.run(&[&map], &thetas, &cones).unwrap();
        let b = thick.run(&[&map], &thetas, &cones).unwrap();
        let mut compared = 0;
        for (p, q) in a.points.iter().zip(&b.points) {
            assert!(
                (p.reflectance - q.reflectance).abs() <= 1e-9 * p.reflectance.abs(),
                "{t:?}: {} vs {}",
                q.reflectance,
                p.reflectance
            );
            compared += usize::from(p.reflectance > 0.0);
        }
        assert!(compared >= 8, "only {compared} lit detectors");
    }
}

#[test]
fn tilted_plane_scales_by_the_airy_reflectance() {
    let (n1, d, wl) = (2.4, 160.0, 600.0);
    for (theta_i_deg, beta_deg) in [(0.0f64, 4.0f64), (45.0, -6.0), (60.0, 10.0)] {
        let (ti, beta) = (theta_i_deg.to_radians(), beta_deg.to_radians());
        let map = plane(beta.tan());
        // The inside ray at θt meets a facet tilted by β in the plane: local incidence
        // ι = θt − β (tests/geometry.rs), and leaves at θt − 2β.
        let tt = (ti.sin() / N).asin();
        let theta_s = -(N * (tt - 2.0 * beta).sin()).asin();
        let cones = [Cone::in_plane(theta_s, 0.5f64.to_radians()).unwrap()];
        let opts = |flake| TopoOptions {
            flake,
            transmission: Transmission::S,
            ..TopoOptions::default()
        };
        let mirror = TopoModel::new(opts(FlakeReflectance::PerfectConductor)).unwrap();
        let film = TopoModel::new(opts(stack(&[(n1, 0.0, d)], wl))).unwrap();
        let rm = mirror.run(&[&map], &[ti], &cones).unwrap().points[0].reflectance;
        let rf = film.run(&[&map], &[ti], &cones).unwrap().points[0].reflectance;
        let iota = tt - beta;
        let (c0, s0) = (iota.cos(), N * iota.sin());
        let c1 = (1.0 - (s0 / n1).powi(2)).sqrt();
        let r = (N * c0 - n1 * c1) / (N * c0 + n1 * c1);
        let cb = (4.0 * std::f64::consts::PI * n1 * d * c1 / wl).cos();
        let airy = 2.0 * r * r * (1.0 - cb) / (1.0 + r.powi(4) - 2.0 * r * r * cb);
        assert!(rm > 0.0);
        assert!(
            (rf / rm - airy).abs() < 1e-12,
            "θi {theta_i_deg} β {beta_deg}: {} vs {airy}",
            rf / rm
        );
    }
}
