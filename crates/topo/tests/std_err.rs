//! Standard errors of the topographic model: not estimable (None, with a warning) from
//! fewer than two tiles or from a detector without rays, and the between-tile formula
//! against a closed form (issue 13, item 7).

use flakescatter_optics::detector::Cone;
use flakescatter_stats::HeightMap;
use flakescatter_topo::{MIN_TILES, TopoModel, TopoOptions, TopoWarning};

const N: f64 = 1.5;

/// `nx × ny` pixels of 1 µm (tiles of the default 32 µm are 32 × 32 pixels): the tile
/// whose top-left corner is at pixel `(0, 0)` is a plane tilted by `beta` along `x`,
/// the rest is flat; a band of invalid pixels along the tile boundaries keeps every
/// 5 × 5 window inside one tile.
fn patched_map(nx: usize, ny: usize, beta: f64) -> HeightMap {
    let z = (0..nx * ny)
        .map(|i| {
            let (r, c) = (i / nx, i % nx);
            if (30..34).contains(&(r % 32)) || (30..34).contains(&(c % 32)) {
                f64::NAN
            } else if r < 32 && c < 32 {
                beta.tan() * c as f64
            } else {
                0.0
            }
        })
        .collect();
    HeightMap::new(nx, ny, 1.0, 1.0, z).unwrap()
}

/// The in-plane exit angle of a plane tilted by `beta` (tests/geometry.rs derives it).
fn tilted_exit(theta_i: f64, beta: f64) -> f64 {
    let tt = (theta_i.sin() / N).asin();
    -(N * (tt - 2.0 * beta).sin()).asin()
}

#[test]
fn one_tile_gives_no_standard_error_and_says_why() {
    // A map smaller than one tile (20 µm < 32 µm), and a large map with --tile-um 1e9:
    // one tile, no spread to estimate from. Every row's error is None (not NaN) and the
    // result carries the warning once.
    let small = HeightMap::new(20, 20, 1.0, 1.0, vec![1.0; 400]).unwrap();
    let large = patched_map(96, 96, 0.05);
    let cones = [
        Cone::in_plane(-0.3, 0.02).unwrap(),
        Cone::in_plane(0.2, 0.02).unwrap(),
    ];
    let default = TopoModel::new(TopoOptions::default()).unwrap();
    let huge = default.clone().with_block_um(1e9).unwrap();
    for (model, map) in [(&default, &small), (&huge, &large)] {
        let r = model.run(&[map], &[0.3], &cones).unwrap();
        assert_eq!(r.tiles, 1);
        assert_eq!(
            r.warnings,
            vec![TopoWarning::StdErrNotEstimable { tiles: 1 }]
        );
        assert!(r.warnings[0].to_string().contains("not estimable"));
        for p in &r.points {
            assert_eq!(p.reflectance_std_err, None);
            assert_eq!(p.brdf_std_err, None);
            assert!(p.reflectance.is_finite());
        }
    }
}

#[test]
fn between_tile_error_of_a_single_lit_tile_is_the_value_itself() {
    // Four tiles; only the tilted one sends rays into the detector at its exit angle.
    // With tile sums s = (S, 0, 0, 0): s̄ = S/4, Σ(s_t − s̄)² = (3S/4)² + 3(S/4)² = 3S²/4,
    // and se = sqrt(T/(T − 1) · 3S²/4)/N_pixels = S/N_pixels = ρ. The specular detector,
    // lit by the three flat tiles, has a smaller relative error; a detector that no ray
    // reaches has none (None, not 0), and 4 tiles earn the few-tiles warning.
    let beta = 4f64.to_radians();
    let ti = 30f64.to_radians();
    let map = patched_map(64, 64, beta);
    let alpha = 0.5f64.to_radians();
    let cones = [
        Cone::in_plane(tilted_exit(ti, beta), alpha).unwrap(),
        Cone::in_plane(-ti, alpha).unwrap(),
        Cone::in_plane(0.5, alpha).unwrap(),
    ];
    let r = TopoModel::new(TopoOptions::default())
        .unwrap()
        .run(&[&map], &[ti], &cones)
        .unwrap();
    assert_eq!(r.tiles, 4);
    assert_eq!(r.warnings, vec![TopoWarning::FewTiles { tiles: 4 }]);
    let (lit, spec, dark) = (&r.points[0], &r.points[1], &r.points[2]);
    assert!(lit.rays > 0 && lit.reflectance > 0.0);
    let se = lit.reflectance_std_err.unwrap();
    assert!(
        (se / lit.reflectance - 1.0).abs() < 1e-12,
        "{se} vs {}",
        lit.reflectance
    );
    let brdf_se = lit.brdf_std_err.unwrap();
    assert!((brdf_se / lit.brdf - 1.0).abs() < 1e-12);
    assert!(spec.rays > 0 && spec.reflectance_std_err.unwrap() < 0.5 * spec.reflectance);
    assert_eq!(dark.rays, 0);
    assert_eq!(dark.reflectance, 0.0);
    assert_eq!(dark.reflectance_std_err, None);
    assert_eq!(dark.brdf_std_err, None);
}

#[test]
fn enough_tiles_give_no_warning() {
    // 64 × 160 pixels of 1 µm: 2 × 5 = MIN_TILES tiles.
    assert_eq!(MIN_TILES, 10);
    let map = patched_map(64, 160, 0.05);
    let r = TopoModel::new(TopoOptions::default())
        .unwrap()
        .run(&[&map], &[0.3], &[Cone::in_plane(-0.3, 0.02).unwrap()])
        .unwrap();
    assert_eq!(r.tiles, 10);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    assert!(r.points[0].reflectance_std_err.is_some());
}
