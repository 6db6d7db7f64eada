//! Geometry of rendered discs against closed forms: pixel areas, planes, occlusion.

use std::f64::consts::PI;

use flakescatter_stats::distribution::Orientation;
use flakescatter_synth::{Disc, LayerParams, LayerSpec, SyntheticLayer, generate_from_discs};
use nalgebra::{Unit, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Exact-height parameters: no quantisation, no noise, no roughness, no blur.
fn exact(nx: usize, ny: usize, dx: f64, dy: f64) -> LayerParams {
    let mut spec = LayerSpec::new(nx, ny, Orientation::flat(), 3);
    spec.dx_um = dx;
    spec.dy_um = dy;
    spec.confocal.z_step_um = 0.0;
    LayerParams::new(spec).unwrap()
}

fn disc(x: f64, y: f64, z: f64, d: f64, theta: f64, phi: f64) -> Disc {
    Disc {
        centre_x_um: x,
        centre_y_um: y,
        centre_z_um: z,
        diameter_um: d,
        thickness_um: 1.0,
        normal: Unit::new_normalize(Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )),
    }
}

/// Pixels (col, row) carrying label `id`.
fn pixels(layer: &SyntheticLayer, id: u32) -> Vec<(usize, usize)> {
    let nx = layer.height.nx();
    layer
        .labels
        .iter()
        .enumerate()
        .filter(|(_, l)| **l == id)
        .map(|(i, _)| (i % nx, i / nx))
        .collect()
}

/// Bound on the pixel-count area error of a convex shape of perimeter `p`: every pixel
/// whose centre is inside lies in the shape grown by the half-diagonal `h`, and every
/// pixel inside the shape shrunk by `h` has its centre inside, so
/// `|N·dx·dy - A| ≤ p·h + π h²` (Steiner formula for the grown body).
fn count_bound(perimeter: f64, dx: f64, dy: f64) -> f64 {
    let h = 0.5 * (dx * dx + dy * dy).sqrt();
    perimeter * h + PI * h * h
}

#[test]
fn flat_disc_has_the_pixel_area_of_pi_d2_over_4() {
    let (dx, dy) = (0.18, 0.18);
    let params = exact(120, 120, dx, dy);
    let d = 16.0;
    let area = PI * d * d / 4.0;
    let bound = count_bound(PI * d, dx, dy);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 200;
    let mut sum = 0.0;
    for _ in 0..n {
        let x = 10.7 + rng.random::<f64>() * dx;
        let y = 10.7 + rng.random::<f64>() * dy;
        let layer = generate_from_discs(&params, &[disc(x, y, 5.0, d, 0.0, 0.0)]).unwrap();
        let f = &layer.truth[0];
        let a = f.visible_pixels as f64 * dx * dy;
        assert!((a - area).abs() <= bound, "area {a} vs {area} ± {bound}");
        assert_eq!(f.visible_pixels, pixels(&layer, 1).len());
        assert!((f.visible_true_area_um2 - a).abs() < 1e-12);
        assert!((f.true_area_um2 - area).abs() < 1e-12);
        sum += a;
    }
    // For a centre uniform over one pixel cell the expected count is exactly A / (dx dy)
    // (each lattice point is inside with probability equal to the fraction of the cell…
    // summed, the shape's area). Each draw errs by at most `bound`, so the mean of n draws
    // lies within 4 bound / sqrt(n) of A with overwhelming probability.
    let mean = sum / n as f64;
    let tol = 4.0 * bound / (n as f64).sqrt();
    assert!((mean - area).abs() < tol, "mean {mean} vs {area} ± {tol}");
}

#[test]
fn tilted_disc_heights_lie_on_its_plane_and_cover_an_ellipse() {
    let (dx, dy) = (0.18, 0.25);
    let params = exact(150, 110, dx, dy);
    let (theta, phi) = (20f64.to_radians(), 35f64.to_radians());
    let (cx, cy, cz, d) = (13.1, 13.4, 7.0, 16.0);
    let f = disc(cx, cy, cz, d, theta, phi);
    let layer = generate_from_discs(&params, &[f]).unwrap();
    let px = pixels(&layer, 1);
    assert!(px.len() > 1000);

    // Least-squares plane z = a x + b y + c via the 3 × 3 normal equations, centred.
    let pts: Vec<[f64; 3]> = px
        .iter()
        .map(|&(c, r)| {
            let z = layer.height.heights()[r * 150 + c];
            [c as f64 * dx, r as f64 * dy, z]
        })
        .collect();
    let n = pts.len() as f64;
    let mean = |k: usize| pts.iter().map(|p| p[k]).sum::<f64>() / n;
    let (mx, my, mz) = (mean(0), mean(1), mean(2));
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in &pts {
        let (u, v, w) = (p[0] - mx, p[1] - my, p[2] - mz);
        sxx += u * u;
        sxy += u * v;
        syy += v * v;
        sxz += u * w;
        syz += v * w;
    }
    let det = sxx * syy - sxy * sxy;
    let a = (sxz * syy - syz * sxy) / det;
    let b = (syz * sxx - sxz * sxy) / det;
    let c = mz - a * mx - b * my;
    let fitted = Vector3::new(-a, -b, 1.0).normalize();
    assert!(
        (fitted - f.normal.into_inner()).norm() < 1e-10,
        "{fitted:?}"
    );
    // Residuals are rounding only.
    let worst = pts
        .iter()
        .map(|p| (p[2] - (a * p[0] + b * p[1] + c)).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-10, "{worst}");
    // Above the disc centre the top face is at cz + t / (2 cos θ) (brief's definition).
    let z_at_centre = a * cx + b * cy + c;
    assert!((z_at_centre - (cz + 0.5 / theta.cos())).abs() < 1e-9);

    // The covered set is an ellipse of semi-axes r and r cos θ: area π r² cos θ, perimeter
    // below 2π r.
    let r = d / 2.0;
    let ellipse = PI * r * r * theta.cos();
    let got = layer.truth[0].visible_projected_area_um2;
    let bound = count_bound(2.0 * PI * r, dx, dy);
    assert!(
        (got - ellipse).abs() <= bound,
        "{got} vs {ellipse} ± {bound}"
    );
    // Its true area is the projected area over cos θ.
    let t = layer.truth[0].visible_true_area_um2;
    assert!((t - got / theta.cos()).abs() < 1e-9);
    assert!((t - PI * r * r).abs() <= bound / theta.cos());
    // Truth angles.
    assert!((layer.truth[0].theta_n - theta).abs() < 1e-12);
    assert!((layer.truth[0].phi_n - phi).abs() < 1e-12);
}

#[test]
fn the_upper_of_two_overlapping_flat_discs_wins() {
    let params = exact(100, 60, 0.2, 0.2);
    for (z1, z2) in [(10.0, 20.0), (20.0, 10.0)] {
        let discs = [
            disc(7.0, 6.0, z1, 10.0, 0.0, 0.0),
            disc(12.0, 6.0, z2, 10.0, 0.0, 0.0),
        ];
        let layer = generate_from_discs(&params, &discs).unwrap();
        let upper = if z1 > z2 { 1 } else { 2 };
        for row in 0..60 {
            for col in 0..100 {
                let (x, y) = (col as f64 * 0.2, row as f64 * 0.2);
                let in1 = (x - 7.0).powi(2) + (y - 6.0).powi(2) <= 25.0;
                let in2 = (x - 12.0).powi(2) + (y - 6.0).powi(2) <= 25.0;
                let k = row * 100 + col;
                let (want, top) = match (in1, in2) {
                    (true, true) => (upper, z1.max(z2) + 0.5),
                    (true, false) => (1, z1 + 0.5),
                    (false, true) => (2, z2 + 0.5),
                    (false, false) => (0, f64::NAN),
                };
                assert_eq!(layer.labels[k], want, "pixel ({col}, {row})");
                if want != 0 {
                    assert!((layer.height.heights()[k] - top).abs() < 1e-12);
                }
            }
        }
    }
}

#[test]
fn crossing_tilted_discs_show_the_higher_plane_pixel_by_pixel() {
    let (dx, dy) = (0.2, 0.2);
    let params = exact(120, 100, dx, dy);
    let discs = [
        disc(11.0, 10.0, 15.0, 16.0, 25f64.to_radians(), 0.0),
        disc(13.0, 10.0, 15.0, 16.0, 25f64.to_radians(), PI),
    ];
    let layer = generate_from_discs(&params, &discs).unwrap();
    // Each face written out independently of the library: plane through
    // c + (t/2) m with normal m, covered within r of that point.
    let face = |d: &Disc, x: f64, y: f64| -> Option<f64> {
        let m = d.normal;
        let top = Vector3::new(d.centre_x_um, d.centre_y_um, d.centre_z_um) + 0.5 * m.into_inner();
        let z = top.z - (m.x * (x - top.x) + m.y * (y - top.y)) / m.z;
        let dist2 = (x - top.x).powi(2) + (y - top.y).powi(2) + (z - top.z).powi(2);
        (dist2 <= 64.0).then_some(z)
    };
    let mut both = 0;
    for row in 0..100 {
        for col in 0..120 {
            let (x, y) = (col as f64 * dx, row as f64 * dy);
            let k = row * 120 + col;
            let (a, b) = (face(&discs[0], x, y), face(&discs[1], x, y));
            let want = match (a, b) {
                (Some(za), Some(zb)) => {
                    both += 1;
                    if zb > za { (2, zb) } else { (1, za) }
                }
                (Some(za), None) => (1, za),
                (None, Some(zb)) => (2, zb),
                (None, None) => (0, 0.0),
            };
            assert_eq!(layer.labels[k], want.0, "pixel ({col}, {row})");
            if want.0 != 0 {
                assert!((layer.height.heights()[k] - want.1).abs() < 1e-9);
            }
        }
    }
    assert!(both > 1000, "the discs must overlap: {both}");
}

#[test]
fn flakes_cut_by_the_map_edge_count_only_pixels_inside() {
    let (dx, dy) = (0.2, 0.2);
    let params = exact(50, 50, dx, dy);
    // Centre on the left edge: half the disc is inside (pixel centres x ≥ 0).
    let layer = generate_from_discs(&params, &[disc(0.0, 5.0, 1.0, 8.0, 0.0, 0.0)]).unwrap();
    let got = layer.truth[0].visible_projected_area_um2;
    // Pixels with x = 0 lie on the cut and count: the half disc plus a strip of width
    // dx/2 along the diameter, within the count bound of the half disc (perimeter π r + d).
    let want = PI * 16.0 / 2.0 + 8.0 * dx / 2.0;
    let bound = count_bound(PI * 4.0 + 8.0, dx, dy);
    assert!((got - want).abs() <= bound, "{got} vs {want}");
}
