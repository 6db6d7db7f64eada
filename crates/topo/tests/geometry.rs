//! Closed-form checks of the topographic model: tilted planes, windowed normals against
//! a direct least-squares fit, ray losses, the clear coat, the paper-printed weight,
//! thread-count independence and bad input.

use flakescatter_optics::detector::Cone;
use flakescatter_optics::fresnel;
use flakescatter_optics::nalgebra::{DMatrix, DVector, Vector3};
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::HeightMap;
use flakescatter_topo::{TopoError, TopoModel, TopoOptions};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};

const N: f64 = 1.5;

/// A plane `z = a x + b y + 3` on an `nx × ny` grid with pitch `dx × dy` (µm).
fn plane(nx: usize, ny: usize, dx: f64, dy: f64, a: f64, b: f64) -> HeightMap {
    let z = (0..nx * ny)
        .map(|i| a * (i % nx) as f64 * dx + b * (i / nx) as f64 * dy + 3.0)
        .collect();
    HeightMap::new(nx, ny, dx, dy, z).unwrap()
}

fn model(options: TopoOptions) -> TopoModel {
    TopoModel::new(options).unwrap()
}

/// In-plane tilt: slope `a = tan β` along `x` leans the normal toward the source (−x).
/// In the plane of incidence the inside ray at `θt` (toward +x) is turned by `2β`
/// toward the source: `k2 = (sin(θt − 2β), 0, cos(θt − 2β))`, so it leaves at the signed
/// angle `θs = −asin(n sin(θt − 2β))`. The obliquity is the angle between `−k1` (at `θt`
/// on the −x side) and `m` (at `β` on the −x side): `γ = cos(θt − β)`. The weight is
/// `F γ / (cos β cos θt)` per pixel, `F = ½[Ts(θi)Ts(θo) + Tp(θi)Tp(θo)]`.
#[test]
fn tilted_plane_in_plane_sends_every_ray_to_the_predicted_direction() {
    let (nx, ny, dx, dy) = (60, 45, 0.3, 0.7);
    for (theta_i_deg, beta_deg) in [(0.0f64, 3.0f64), (30.0, -4.0), (60.0, 7.0), (45.0, 0.0)] {
        let (ti, beta) = (theta_i_deg.to_radians(), beta_deg.to_radians());
        let map = plane(nx, ny, dx, dy, beta.tan(), 0.0);
        let tt = (ti.sin() / N).asin();
        let theta_o = (N * (tt - 2.0 * beta).sin()).asin();
        let theta_s = -theta_o;
        let alpha = 0.25f64.to_radians();
        let cones = [
            Cone::in_plane(theta_s, alpha).unwrap(),
            Cone::in_plane(theta_s + 3.0 * alpha, alpha).unwrap(),
            Cone::out_of_plane(theta_o.abs(), 0.3, alpha).unwrap(),
        ];
        let r = model(TopoOptions::default())
            .run(&[&map], &[ti], &cones)
            .unwrap();
        let usable = ((nx - 4) * (ny - 4)) as u64;
        assert_eq!(r.usable_pixels, usable);
        assert_eq!(r.pixels, (nx * ny) as u64);
        assert_eq!(r.points[0].rays, usable, "θi {theta_i_deg} β {beta_deg}");
        assert_eq!(r.points[1].rays, 0);
        assert_eq!(r.points[2].rays, 0);
        let fi = fresnel::air_to_coating(ti, N);
        let fo = fresnel::air_to_coating(theta_o.abs(), N);
        let f = 0.5 * (fi.ts * fo.ts + fi.tp * fo.tp);
        let gamma = (tt - beta).cos();
        let w = f * gamma / (beta.cos() * tt.cos());
        let expected = w * usable as f64 / (nx * ny) as f64;
        let p = &r.points[0];
        assert!(
            (p.reflectance - expected).abs() < 1e-12,
            "{} vs {expected}",
            p.reflectance
        );
        // Every tile gets the same weight per usable pixel; the brdf is reflectance over
        // cos θj π sin²α.
        let proj = theta_o.cos() * std::f64::consts::PI * alpha.sin().powi(2);
        assert!((p.brdf - expected / proj).abs() < 1e-9 * p.brdf);
        // The specular reference: with β = 0 the detector is the specular one.
        if beta_deg == 0.0 {
            assert!((p.relative - 1.0).abs() < 1e-15);
        }
    }
}

/// Out-of-plane tilt at normal incidence: slope `b = tan β` along `y` gives
/// `m = (0, −sin β, cos β)`, `k1 = −z`, `k2 = (0, −sin 2β, cos 2β)`, so the ray leaves at
/// polar angle `asin(n sin 2β)` and azimuth `φr = −90°`.
#[test]
fn tilted_plane_out_of_plane_follows_the_y_axis() {
    let beta = 4f64.to_radians();
    let map = plane(40, 50, 0.5, 0.25, 0.0, beta.tan());
    let theta_r = (N * (2.0 * beta).sin()).asin();
    let alpha = 0.2f64.to_radians();
    let cones = [
        Cone::out_of_plane(theta_r, -std::f64::consts::FRAC_PI_2, alpha).unwrap(),
        Cone::out_of_plane(theta_r, std::f64::consts::FRAC_PI_2, alpha).unwrap(),
        Cone::in_plane(theta_r, alpha).unwrap(),
    ];
    let r = model(TopoOptions::default())
        .run(&[&map], &[0.0], &cones)
        .unwrap();
    assert_eq!(r.points[0].rays, 36 * 46);
    assert_eq!(r.points[1].rays, 0);
    assert_eq!(r.points[2].rays, 0);
}

/// Ray losses: at normal incidence a plane tilted by 25° sends the inside ray at 50°,
/// beyond the critical angle asin(1/1.5) = 41.8°, so every ray is totally internally
/// reflected. At θi = 60° (θt = 35.26°) a plane tilted by 70° toward the source gives
/// `k2` at θt − 2β = −104.7° from the normal: every ray heads down.
#[test]
fn total_internal_reflection_and_downward_rays_are_counted() {
    let cone = [Cone::in_plane(0.0, 0.05).unwrap()];
    let tir = plane(20, 20, 1.0, 1.0, 25f64.to_radians().tan(), 0.0);
    let r = model(TopoOptions::default())
        .run(&[&tir], &[0.0], &cone)
        .unwrap();
    assert_eq!(
        (r.rays_lost_tir, r.rays_lost_down, r.rays_traced),
        (256, 0, 256)
    );
    assert_eq!(r.points[0].reflectance, 0.0);
    let down = plane(20, 20, 1.0, 1.0, 70f64.to_radians().tan(), 0.0);
    let r = model(TopoOptions::default())
        .run(&[&down], &[60f64.to_radians()], &cone)
        .unwrap();
    assert_eq!((r.rays_lost_tir, r.rays_lost_down), (0, 256));
}

/// A flat map sends everything specular: `ρ = Ts,i·Ts,o` averaged over s and p at
/// `θo = θi`, i.e. `½(Ts² + Tp²)` times the usable fraction, plus with the clear coat
/// `R_av(θi)` (0.0891 at 60°, n = 1.5: Rs = 0.1775, Rp = 0.0007 from the Fresnel
/// formulas). Several maps accumulate with `N_pixels` over all of them.
#[test]
fn flat_maps_accumulate_and_clear_coat_adds_the_top_reflection() {
    let ti = 60f64.to_radians();
    let a = plane(30, 20, 1.0, 1.0, 0.0, 0.0);
    let b = plane(10, 10, 1.0, 1.0, 0.0, 0.0);
    let alpha = 1f64.to_radians();
    let cones = [
        Cone::in_plane(-ti, alpha).unwrap(),
        Cone::in_plane(0.0, alpha).unwrap(),
    ];
    let opts = TopoOptions {
        clearcoat: true,
        ..TopoOptions::default()
    };
    let r = model(opts).run(&[&a, &b], &[ti], &cones).unwrap();
    let f = fresnel::air_to_coating(ti, N);
    let usable = (26 * 16 + 6 * 6) as f64;
    let expected = 0.5 * (f.ts * f.ts + f.tp * f.tp) * usable / 700.0 + f.r_av();
    assert!((r.points[0].reflectance - expected).abs() < 1e-12);
    assert!((f.r_av() - 0.0891).abs() < 2e-4);
    assert!(r.points[0].clearcoat_seen && !r.points[1].clearcoat_seen);
    assert_eq!(r.points[1].reflectance, 0.0);
    assert_eq!((r.maps, r.pixels, r.usable_pixels), (2, 700, 452));
}

/// `paper-printed` is the printed eq. 14, `(cos ϑ'_j/cos ϑ_j) T γ`: for a flat map at
/// θi = 45° with `--transmission paper`, `T = T_av(θi)²`, `γ = cos θt`, `ϑ_j = 45°`,
/// `cos ϑ'_j = sqrt(1 − sin²45°/n²)`; each usable pixel adds that (over `N_pixels`).
#[test]
fn paper_printed_weight_is_the_printed_equation() {
    let ti = 45f64.to_radians();
    let map = plane(25, 25, 1.0, 1.0, 0.0, 0.0);
    let opts = TopoOptions {
        weighting: Weighting::PaperPrinted,
        transmission: Transmission::Paper,
        ..TopoOptions::default()
    };
    let r = model(opts)
        .run(&[&map], &[ti], &[Cone::in_plane(-ti, 0.02).unwrap()])
        .unwrap();
    let t_av = fresnel::t_av_printed(ti, N);
    let cos_t = (1.0 - ti.sin().powi(2) / (N * N)).sqrt();
    let w = cos_t / ti.cos() * t_av * t_av * cos_t;
    let expected = w * 441.0 / 625.0;
    assert!((r.points[0].reflectance - expected).abs() < 1e-12);
}

/// Direct least squares: solve the 3 × 3 normal equations of `z = a x + b y + c` over
/// the `k × k` window in absolute map coordinates for every pixel, and compare with the
/// separable running-sum normals (1e-12). The skip rule is checked by brute force.
#[test]
fn windowed_normals_equal_a_direct_least_squares_fit() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for (case, k) in [3usize, 5, 7, 5, 9].into_iter().enumerate() {
        let (nx, ny) = (rng.random_range(20..60), rng.random_range(15..50));
        let (dx, dy) = (rng.random_range(0.1..2.0), rng.random_range(0.1..2.0));
        let mut z: Vec<f64> = (0..nx * ny)
            .map(|i| {
                let (c, r) = ((i % nx) as f64, (i / nx) as f64);
                20.0 + 0.3 * c * dx - 0.2 * r * dy + rng.random_range(-2.0..2.0)
            })
            .collect();
        let mut mask = vec![true; nx * ny];
        for i in 0..nx * ny {
            if rng.random::<f64>() < 0.01 {
                z[i] = f64::NAN;
            }
            if rng.random::<f64>() < 0.01 {
                mask[i] = false;
            }
        }
        let map = HeightMap::with_mask(nx, ny, dx, dy, z, mask).unwrap();
        let m = model(TopoOptions {
            window: k,
            ..TopoOptions::default()
        })
        .with_block_um(5.0)
        .unwrap();
        let normals = m.normals(&map).unwrap();
        let h = k / 2;
        let mut usable = 0;
        for row in 0..ny {
            for col in 0..nx {
                let full = row >= h && col >= h && row + h < ny && col + h < nx && {
                    (row - h..=row + h)
                        .all(|r| (col - h..=col + h).all(|c| map.get(c, r).is_some()))
                };
                let got = normals.slope(col, row);
                assert_eq!(got.is_some(), full, "case {case} pixel ({col}, {row})");
                if !full {
                    continue;
                }
                usable += 1;
                // Least squares by SVD of the design matrix (no normal equations, so
                // the reference keeps full accuracy with absolute coordinates).
                let mut design = DMatrix::zeros(k * k, 3);
                let mut rhs = DVector::zeros(k * k);
                for (t, (r, c)) in (row - h..=row + h)
                    .flat_map(|r| (col - h..=col + h).map(move |c| (r, c)))
                    .enumerate()
                {
                    design[(t, 0)] = c as f64 * dx;
                    design[(t, 1)] = r as f64 * dy;
                    design[(t, 2)] = 1.0;
                    rhs[t] = map.get(c, r).unwrap();
                }
                let sol = design.svd(true, true).solve(&rhs, 1e-14).unwrap();
                let sol = Vector3::new(sol[0], sol[1], sol[2]);
                let (a, b) = got.unwrap();
                assert!(
                    (a - sol.x).abs() < 1e-12 && (b - sol.y).abs() < 1e-12,
                    "case {case} ({col}, {row}): ({a}, {b}) vs ({}, {})",
                    sol.x,
                    sol.y
                );
                let n = normals.get(col, row).unwrap();
                let q = (1.0 + a * a + b * b).sqrt();
                assert!((n.x + a / q).abs() < 1e-15 && (n.z - 1.0 / q).abs() < 1e-15);
            }
        }
        assert_eq!(normals.usable(), usable);
        assert!(usable > 50, "case {case} exercises the fit ({usable})");
        assert_eq!(
            normals.to_vec().iter().filter(|n| n.is_some()).count(),
            usable
        );
    }
}

/// A smooth random surface with holes.
fn rough_map(nx: usize, ny: usize, seed: u64) -> HeightMap {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let waves: Vec<[f64; 4]> = (0..10)
        .map(|_| {
            let k = std::f64::consts::TAU / rng.random_range(5.0..40.0);
            let d: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            [
                k * d.cos(),
                k * d.sin(),
                0.05 / k,
                rng.random_range(0.0..6.3),
            ]
        })
        .collect();
    let z = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as f64 * 0.5, (i / nx) as f64 * 0.5);
            if rng.random::<f64>() < 0.002 {
                return f64::NAN;
            }
            waves
                .iter()
                .map(|w| w[2] * (w[0] * x + w[1] * y + w[3]).sin())
                .sum()
        })
        .collect();
    HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap()
}

/// One thread and four threads give identical bits (and so do two maps vs the same run
/// repeated).
#[test]
fn result_is_bit_identical_for_any_thread_count() {
    let maps = [rough_map(300, 260, 1), rough_map(180, 200, 2)];
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let cones: Vec<Cone> = (-60..=60)
        .map(|d| Cone::in_plane(f64::from(d).to_radians(), 1.5f64.to_radians()).unwrap())
        .collect();
    let ti = [0.0, 30f64.to_radians(), 60f64.to_radians()];
    let m = model(TopoOptions::default());
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| m.run(&refs, &ti, &cones).unwrap())
    };
    let bits = |r: &flakescatter_topo::TopoResult| -> Vec<u64> {
        r.points
            .iter()
            .flat_map(|p| {
                [
                    p.reflectance.to_bits(),
                    p.reflectance_std_err.map_or(0, f64::to_bits),
                    p.brdf.to_bits(),
                    p.relative.to_bits(),
                    p.rays,
                ]
            })
            .collect()
    };
    let one = run(1);
    let four = run(4);
    let default_pool = m.run(&refs, &ti, &cones).unwrap();
    assert_eq!(bits(&one), bits(&four));
    assert_eq!(bits(&one), bits(&default_pool));
    assert_eq!(one, four);
    assert!(one.points.iter().filter(|p| p.rays > 0).count() > 50);
    assert!(one.rays_lost_tir + one.rays_lost_down < one.rays_traced);
}

#[test]
fn bad_input_gives_clear_errors() {
    for w in [0, 1, 2, 4, 6] {
        let e = TopoModel::new(TopoOptions {
            window: w,
            ..TopoOptions::default()
        })
        .unwrap_err();
        assert_eq!(e, TopoError::Window(w));
        assert!(e.to_string().contains("odd"));
    }
    assert!(matches!(
        TopoModel::new(TopoOptions {
            n: 0.9,
            ..TopoOptions::default()
        }),
        Err(TopoError::Index(_))
    ));
    let m = model(TopoOptions::default());
    let cone = [Cone::in_plane(0.0, 0.02).unwrap()];
    let small = plane(4, 10, 1.0, 1.0, 0.0, 0.0);
    let e = m.run(&[&small], &[0.0], &cone).unwrap_err();
    assert!(matches!(
        e,
        TopoError::WindowTooLarge {
            window: 5,
            nx: 4,
            ny: 10,
            ..
        }
    ));
    assert!(e.to_string().contains("larger than map"));
    assert!(m.normals(&small).is_err());
    let nan = HeightMap::new(8, 8, 1.0, 1.0, vec![f64::NAN; 64]).unwrap();
    let e = m.run(&[&nan], &[0.0], &cone).unwrap_err();
    assert_eq!(e, TopoError::NoValidPixels { map: 0, pixels: 64 });
    // Valid points, but no complete window: every other column is a hole.
    let z = (0..100)
        .map(|i| if i % 2 == 0 { 1.0 } else { f64::NAN })
        .collect();
    let holes = HeightMap::new(10, 10, 1.0, 1.0, z).unwrap();
    let e = m.run(&[&holes], &[0.0], &cone).unwrap_err();
    assert_eq!(
        e,
        TopoError::NoUsablePixels {
            window: 5,
            valid: 50,
            pixels: 100
        }
    );
    assert!(e.to_string().contains("50 of 100 pixels are valid"), "{e}");
    let ok = plane(10, 10, 1.0, 1.0, 0.0, 0.0);
    assert_eq!(
        m.run(&[], &[0.0], &cone).unwrap_err(),
        TopoError::Empty("height map")
    );
    assert_eq!(
        m.run(&[&ok], &[], &cone).unwrap_err(),
        TopoError::Empty("incidence angle")
    );
    assert_eq!(
        m.run(&[&ok], &[0.0], &[]).unwrap_err(),
        TopoError::Empty("detector")
    );
    assert!(matches!(
        m.run(&[&ok], &[1.6], &cone),
        Err(TopoError::Incidence(_))
    ));
    let point = [
        Cone::in_plane(0.0, 0.02).unwrap(),
        Cone::in_plane(0.1, 0.0).unwrap(),
    ];
    assert_eq!(
        m.run(&[&ok], &[0.0], &point).unwrap_err(),
        TopoError::PointDetector(1)
    );
    assert!(m.clone().with_block_um(0.0).is_err());
    // The specular direction is available even when not among the detectors.
    let r = m
        .run(&[&ok], &[0.3], &[Cone::in_plane(0.2, 0.02).unwrap()])
        .unwrap();
    assert!(r.points[0].relative == 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// On an exact plane with holes, every usable pixel's normal is the plane's normal
    /// `(−a, −b, 1)/sqrt(1 + a² + b²)`, whatever the pitch, window and hole pattern.
    #[test]
    fn plane_normals_are_exact(
        a in -2.0f64..2.0,
        b in -2.0f64..2.0,
        dx in 0.05f64..3.0,
        dy in 0.05f64..3.0,
        half in 1usize..4,
        holes in proptest::collection::vec(0usize..600, 0..12),
    ) {
        let (nx, ny) = (30, 20);
        let mut z: Vec<f64> = (0..nx * ny)
            .map(|i| a * (i % nx) as f64 * dx + b * (i / nx) as f64 * dy - 7.0)
            .collect();
        for h in holes {
            z[h] = f64::NAN;
        }
        let map = HeightMap::new(nx, ny, dx, dy, z).unwrap();
        let k = 2 * half + 1;
        let m = TopoModel::new(TopoOptions { window: k, ..TopoOptions::default() }).unwrap();
        let normals = m.normals(&map).unwrap();
        let q = (1.0 + a * a + b * b).sqrt();
        for n in normals.to_vec().into_iter().flatten() {
            prop_assert!((n.x + a / q).abs() < 1e-9);
            prop_assert!((n.y + b / q).abs() < 1e-9);
            prop_assert!((n.z - 1.0 / q).abs() < 1e-9);
        }
    }
}

/// A detector collects the same rays whatever other detectors there are: each of 100
/// overlapping cones (every one of them a candidate of the same index cells, more than
/// a ray's candidates are tested at once) gets, bit for bit, what it gets alone.
#[test]
fn a_detector_collects_the_same_rays_among_many_overlapping_ones() {
    let map = rough_map(200, 180, 3);
    let ti = [0.2, 0.5];
    let crowd: Vec<Cone> = (0..100)
        .map(|k| Cone::in_plane(-0.2 + 0.0004 * f64::from(k), 0.08).unwrap())
        .collect();
    let m = model(TopoOptions::default());
    let together = m.run(&[&map], &ti, &crowd).unwrap();
    let mut seen = 0;
    for k in [0, 37, 99] {
        let alone = m.run(&[&map], &ti, &crowd[k..=k]).unwrap();
        for (ii, a) in alone.points.iter().enumerate() {
            let t = &together.points[ii * crowd.len() + k];
            assert_eq!(t.rays, a.rays);
            assert_eq!(t.reflectance.to_bits(), a.reflectance.to_bits());
            assert_eq!(t.brdf.to_bits(), a.brdf.to_bits());
            seen += a.rays;
        }
    }
    assert!(seen > 1000, "the cones must collect rays ({seen})");
}
