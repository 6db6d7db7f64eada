//! Pixel-level orientation statistics (physics.md §5.2) on maps with known normals.

use flakescatter_stats::HeightMap;
use flakescatter_topo::{TopoError, TopoModel, TopoOptions};

/// A plane `z = a x + b y` on an `nx × ny` grid with pitch `dx × dy` (µm).
fn plane(nx: usize, ny: usize, dx: f64, dy: f64, a: f64, b: f64) -> HeightMap {
    let z = (0..nx * ny)
        .map(|i| a * (i % nx) as f64 * dx + b * (i / nx) as f64 * dy)
        .collect();
    HeightMap::new(nx, ny, dx, dy, z).unwrap()
}

/// A plane tilted by `θ` has every usable pixel at `θn = θ` with true area
/// `dx · dy / cos θ`; two planes side by side split the area by their pixel counts.
#[test]
fn tilted_planes_give_their_tilt_and_true_area() {
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let (dx, dy) = (0.3, 0.45);
    let t1 = 7.3f64.to_radians();
    let t2 = 12.2f64.to_radians();
    let p1 = plane(40, 30, dx, dy, t1.tan() * 0.6, t1.tan() * 0.8);
    let p2 = plane(50, 20, dx, dy, -t2.tan(), 0.0);
    let tilts = model.pixel_tilts(&[&p1, &p2], 1f64.to_radians()).unwrap();
    let (n1, n2) = (36.0 * 26.0, 46.0 * 16.0);
    assert_eq!(tilts.usable_pixels, (n1 + n2) as u64);
    assert_eq!(tilts.pixels, 40 * 30 + 50 * 20);
    let (a1, a2) = (n1 * dx * dy / t1.cos(), n2 * dx * dy / t2.cos());
    assert!((tilts.total_area_um2() - (a1 + a2)).abs() < 1e-9 * (a1 + a2));
    assert!((tilts.bin_area_um2[7] - a1).abs() < 1e-9 * a1);
    assert!((tilts.bin_area_um2[12] - a2).abs() < 1e-9 * a2);
    let m2 = (a1 * t1 * t1 + a2 * t2 * t2) / (a1 + a2);
    assert!((tilts.mean_square_tilt() - m2).abs() < 1e-12);
    let f = tilts.area_fractions();
    assert!((f.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert!((tilts.coverage() - (n1 + n2) / 2200.0).abs() < 1e-15);
    let o = tilts.orientation().unwrap();
    assert!((o.mass_between(0.0, 8f64.to_radians()) - a1 / (a1 + a2)).abs() < 1e-12);
}

/// Maps one window tall give one usable row each, the same row and columns in every
/// map, so a row of slopes held over from the last tile would be the wrong map's
/// (a review found that the first version of the row-at-a-time slopes did just that).
/// Sixteen such maps, alternately tilted by 5.5° and 20.5°, in one call: each plane's 36
/// usable pixels have true area `dx dy / cos θ` and land in their own 1° bin, and each
/// tile holds its own plane's tilt.
#[test]
fn one_row_maps_in_a_row_each_keep_their_own_slopes() {
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let (t1, t2) = (5.5f64.to_radians(), 20.5f64.to_radians());
    let flat = plane(40, 5, 0.5, 0.5, t1.tan(), 0.0);
    let steep = plane(40, 5, 0.5, 0.5, t2.tan(), 0.0);
    let maps: Vec<&HeightMap> = (0..16)
        .map(|i| if i % 2 == 0 { &flat } else { &steep })
        .collect();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let tilts = pool
            .install(|| model.pixel_tilts(&maps, 1f64.to_radians()))
            .unwrap();
        let n = 36.0 * 0.25;
        let (a1, a2) = (8.0 * n / t1.cos(), 8.0 * n / t2.cos());
        assert!(
            (tilts.bin_area_um2[5] - a1).abs() < 1e-9 * a1,
            "{threads} threads"
        );
        assert!(
            (tilts.bin_area_um2[20] - a2).abs() < 1e-9 * a2,
            "{threads} threads"
        );
        assert!((tilts.total_area_um2() - (a1 + a2)).abs() < 1e-9 * (a1 + a2));
        for (i, tile) in tilts.tiles.iter().enumerate() {
            let t = if i % 2 == 0 { t1 } else { t2 };
            let mean = (tile.area_theta2 / tile.area_um2).sqrt();
            assert!(
                (mean - t).abs() < 1e-9,
                "{threads} threads, tile {i}: {mean}"
            );
        }
    }
}

/// Tile standard error of the mean square tilt: two tiles of one plane each, so the
/// ratio estimator's spread is known in closed form. With tiles `A_t`, `S_t = A_t θ_t²`
/// and `m2 = ΣS/ΣA`: `se = sqrt(2 Σ (S_t − m2 A_t)²)/ΣA`.
#[test]
fn mean_square_tilt_error_comes_from_the_tiles() {
    let t1 = 5f64.to_radians();
    let t2 = 9f64.to_radians();
    let model = TopoModel::new(TopoOptions::default())
        .unwrap()
        .with_block_um(1000.0)
        .unwrap();
    let p1 = plane(30, 30, 0.5, 0.5, t1.tan(), 0.0);
    let p2 = plane(30, 30, 0.5, 0.5, 0.0, t2.tan());
    let tilts = model.pixel_tilts(&[&p1, &p2], 0.5f64.to_radians()).unwrap();
    assert_eq!(tilts.tiles.len(), 2);
    let a = [676.0 * 0.25 / t1.cos(), 676.0 * 0.25 / t2.cos()];
    let s = [a[0] * t1 * t1, a[1] * t2 * t2];
    let m2 = (s[0] + s[1]) / (a[0] + a[1]);
    let se =
        (2.0 * ((s[0] - m2 * a[0]).powi(2) + (s[1] - m2 * a[1]).powi(2))).sqrt() / (a[0] + a[1]);
    assert!((tilts.mean_square_tilt_std_err() - se).abs() < 1e-12 * se);
    let one = model.pixel_tilts(&[&p1], 0.5f64.to_radians()).unwrap();
    assert!(one.mean_square_tilt_std_err().is_nan());
}

#[test]
fn pixel_tilts_bad_input_is_an_error() {
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let p = plane(10, 10, 0.5, 0.5, 0.0, 0.0);
    for w in [0.0, -0.1, f64::NAN, 1.0] {
        assert!(
            matches!(model.pixel_tilts(&[&p], w), Err(TopoError::BinWidth(_))),
            "{w}"
        );
    }
    assert!(matches!(
        model.pixel_tilts(&[], 0.01),
        Err(TopoError::Empty(_))
    ));
    // A 9 × 9 map cut into 4 × 4 quadrants: no 5 × 5 window is complete.
    let masked = HeightMap::with_mask(9, 9, 0.5, 0.5, vec![0.0; 81], {
        let mut m = vec![true; 81];
        for i in 0..9 {
            m[i * 9 + 4] = false;
            m[36 + i] = false;
        }
        m
    })
    .unwrap();
    assert!(matches!(
        model.pixel_tilts(&[&masked], 0.01),
        Err(TopoError::NoUsablePixels { .. })
    ));
}
