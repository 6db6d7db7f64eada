//! Binder absorption in the topographic model (physics.md §8.1): on a tilted plane every
//! ray takes the same path, so absorption multiplies the clear-binder reflectance by the
//! closed-form path factor of that one ray, for the scalar and the Mueller accumulation.

use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};
use flakescatter_optics::detector::Cone;
use flakescatter_stats::HeightMap;
use flakescatter_topo::{TopoError, TopoModel, TopoOptions};

const N: f64 = 1.5;

fn plane(a: f64) -> HeightMap {
    let (nx, ny) = (40, 30);
    let z = (0..nx * ny)
        .map(|i| a * (i % nx) as f64 * 0.5 + 1.0)
        .collect();
    HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap()
}

#[test]
fn tilted_plane_reflectance_carries_the_path_factor() {
    for (theta_i_deg, beta_deg) in [(0.0f64, 4.0f64), (45.0, -6.0), (60.0, 10.0)] {
        let (ti, beta) = (theta_i_deg.to_radians(), beta_deg.to_radians());
        let map = plane(beta.tan());
        // In the plane: the inside ray at θt leaves the flake at θt − 2β (see
        // tests/geometry.rs), so cos θ2 = cos(θt − 2β).
        let tt = (ti.sin() / N).asin();
        let theta_s = -(N * (tt - 2.0 * beta).sin()).asin();
        let cones = [Cone::in_plane(theta_s, 0.5f64.to_radians()).unwrap()];
        let clear = TopoModel::new(TopoOptions::default()).unwrap();
        let (alpha, film) = (0.2, 12.0);
        let absorbing = clear.clone().with_absorption(
            PathAbsorption::new(alpha, FlakeDepth::UniformInFilm { film_um: film }).unwrap(),
        );
        let x = alpha * film * (1.0 / tt.cos() + 1.0 / (tt - 2.0 * beta).cos());
        let want = (1.0 - (-x).exp()) / x;
        let rc = clear.run(&[&map], &[ti], &cones).unwrap().points[0].reflectance;
        let ra = absorbing.run(&[&map], &[ti], &cones).unwrap().points[0].reflectance;
        assert!(rc > 0.0);
        assert!(
            (ra / rc - want).abs() < 1e-12,
            "θi {theta_i_deg} β {beta_deg}: {} vs {want}",
            ra / rc
        );
        // The Mueller accumulation carries the same factor in every element.
        let readout = [0.0; 16];
        let mc = clear
            .run_mueller(&[&map], &[ti], &cones, &readout, &|_, _| {})
            .unwrap();
        let ma = absorbing
            .run_mueller(&[&map], &[ti], &cones, &readout, &|_, _| {})
            .unwrap();
        let (a, c) = (&ma.points[0], &mc.points[0]);
        assert!((a.reflectance.m00() / c.reflectance.m00() - want).abs() < 1e-12);
    }
}

#[test]
fn the_isotropic_average_refuses_absorption() {
    let map = plane(0.05);
    let m = TopoModel::new(TopoOptions::default())
        .unwrap()
        .with_absorption(PathAbsorption::new(0.1, FlakeDepth::At { depth_um: 2.0 }).unwrap());
    let cones = [Cone::in_plane(0.0, 0.02).unwrap()];
    assert!(matches!(
        m.run_isotropic(&[&map], &[0.3], &cones),
        Err(TopoError::Unsupported(_))
    ));
}
