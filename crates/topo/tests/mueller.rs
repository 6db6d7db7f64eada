//! The topographic model's Mueller matrices (physics.md §11, issue 18): maps of flat
//! flakes against the distribution model element by element (the polarimetric form of
//! `flat_flakes.rs`), a tilted mirror plane against the vector closed form of mirror
//! reflection, the m00 and readout channels against the scalar runs, the clear coat, and
//! thread-count independence.

// Matrix elements read best as m[i][k] over explicit index ranges.
#![allow(clippy::needless_range_loop)]

use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions};
use flakescatter_optics::Vec3;
use flakescatter_optics::detector::Cone;
use flakescatter_optics::mueller::Mueller;
use flakescatter_optics::polarization::Transmission;
use flakescatter_stats::HeightMap;
use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{DiameterDistribution, FlakeAmount, LayerParams, LayerSpec, generate};
use flakescatter_topo::{TopoModel, TopoOptions};

/// Unpolarised light, everything detected: the readout is m00.
const M00: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
];

/// A 2048² map at 0.5 µm pitch of 8 µm flat flakes (about 10⁴ flakes), edges masked so
/// that no window straddles two flakes (as in `flat_flakes.rs`).
fn flat_flake_map(orientation: &Orientation, seed: u64) -> HeightMap {
    let mut spec = LayerSpec::new(2048, 2048, orientation.clone(), seed);
    spec.dx_um = 0.5;
    spec.dy_um = 0.5;
    spec.diameter = DiameterDistribution::Fixed(8.0);
    spec.amount = FlakeAmount::Coverage(0.5);
    spec.confocal.z_step_um = 0.0;
    spec.confocal.psf_sd_um = 0.0;
    spec.confocal.noise_sd_um = 0.0;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let (nx, ny) = (layer.height.nx(), layer.height.ny());
    let l = &layer.labels;
    let mask: Vec<bool> = (0..nx * ny)
        .map(|i| {
            let (c, r) = (i % nx, i / nx);
            let same = |j: usize| l[j] == l[i];
            l[i] != 0
                && (c == 0 || same(i - 1))
                && (c + 1 == nx || same(i + 1))
                && (r == 0 || same(i - nx))
                && (r + 1 == ny || same(i + nx))
        })
        .collect();
    HeightMap::with_mask(nx, ny, 0.5, 0.5, layer.height.heights().to_vec(), mask).unwrap()
}

#[test]
fn flat_flakes_reproduce_the_distribution_models_mueller_matrix() {
    // Expectation per element: coverage × the distribution model's cone Mueller matrix
    // (the same argument as flat_flakes.rs, element by element: each pixel's ray carries
    // its path Mueller matrix with the scalar weight, in the cone's basis like the
    // distribution model's). Each element of each well-populated cell must agree within
    // its tile standard error: z² averages about 1 (elements of one cell are correlated,
    // so the sum is not chi-square distributed; the mean and the largest |z| are tested),
    // and a model 10 % too high is visible.
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let maps: Vec<HeightMap> = (21..29).map(|s| flat_flake_map(&orientation, s)).collect();
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let alpha = 3f64.to_radians();
    let mut cones: Vec<Cone> = (-12..=12)
        .map(|k| Cone::in_plane(f64::from(k * 7).to_radians(), alpha).unwrap())
        .collect();
    for theta_r in [20.0f64, 40.0, 60.0] {
        for phi in [30.0f64, 60.0, 100.0, 150.0] {
            cones.push(Cone::out_of_plane(theta_r.to_radians(), phi.to_radians(), alpha).unwrap());
        }
    }
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let topo = TopoModel::new(TopoOptions::default())
        .unwrap()
        .run_mueller(&refs, &theta_i, &cones, &M00, &|_, _| {})
        .unwrap();
    let coverage = topo.totals.usable_pixels as f64 / topo.totals.pixels as f64;
    let model = DistributionModel::new(orientation, 1.5, ModelOptions::default()).unwrap();
    let (mut sum_z2, mut sum_z2_off, mut n, mut worst) = (0.0, 0.0, 0usize, 0.0f64);
    let mut off_plane_cells = 0;
    for p in &topo.points {
        // As in flat_flakes.rs: cells resting on fewer than ~25 flakes' worth of rays have
        // a poorly estimated tile variance.
        if (p.rays as f64) < 25.0 * 40.0 {
            continue;
        }
        let inc = model.incidence(p.theta_i).unwrap();
        let want = model
            .collect_mueller(&inc, &p.cone, ConeMethod::Exact)
            .reflectance
            .unwrap()
            * coverage;
        if p.cone.axis().y.abs() > 1e-9 {
            off_plane_cells += 1;
        }
        for i in 0..4 {
            for k in 0..4 {
                let se = p.reflectance_std_err.unwrap().get(i, k);
                // Elements that vanish by symmetry (in-plane cells: the s/p–S2/S3
                // coupling) are zero to rounding on both sides.
                if se <= 1e-6 * p.reflectance.m00() {
                    assert!((p.reflectance.get(i, k) - want.get(i, k)).abs() <= 1e-9 * want.m00());
                    continue;
                }
                let z = (p.reflectance.get(i, k) - want.get(i, k)) / se;
                let z_off = (p.reflectance.get(i, k) - 1.1 * want.get(i, k)) / se;
                worst = worst.max(z.abs());
                sum_z2 += z * z;
                sum_z2_off += z_off * z_off;
                n += 1;
            }
        }
    }
    let (mean, mean_off) = (sum_z2 / n as f64, sum_z2_off / n as f64);
    eprintln!("{n} elements: mean z² {mean:.2} (10 % off: {mean_off:.2}), worst |z| {worst:.2}");
    assert!(
        n > 200 && off_plane_cells >= 8,
        "{n} elements, {off_plane_cells} out-of-plane cells"
    );
    assert!(
        mean < 1.6 && worst < 5.0,
        "mean z² {mean}, worst |z| {worst}"
    );
    assert!(
        mean_off > 2.5,
        "a 10 % error would go unnoticed ({mean_off})"
    );
}

/// A plane `z = a x + b y` on an `nx × ny` grid (µm).
fn plane(nx: usize, ny: usize, pitch: f64, a: f64, b: f64) -> HeightMap {
    let z = (0..nx * ny)
        .map(|i| a * (i % nx) as f64 * pitch + b * (i / nx) as f64 * pitch)
        .collect();
    HeightMap::new(nx, ny, pitch, pitch, z).unwrap()
}

/// SCATMECH's s vector `z × k/|z × k|` (y along z), written out.
fn s_of(k: &Vec3) -> Vec3 {
    let rho = k.x.hypot(k.y);
    if rho > 0.0 {
        Vec3::new(-k.y / rho, k.x / rho, 0.0)
    } else {
        Vec3::y()
    }
}

#[test]
fn a_tilted_mirror_without_a_coat_is_the_vector_mirror_in_the_cones_basis() {
    // n = 1, perfect conductor: every pixel of a plane with normal m reflects
    // k_in into k = k_in − 2 (k_in·m) m with the field E_out = 2 (m·E) m − E. In the
    // incident basis (s = y, p = k_in × s) and the cone's basis (s' = the axis's s
    // projected perpendicular to k, p' = k × s'), J_ab = e'_a · (2 m mᵀ − 1) e_b, and
    // each usable pixel carries γ/(m.z cos θi) of the beam (no Fresnel loss): the cone
    // collects that fraction times M(J) times usable/all pixels.
    let (nx, ny) = (50, 40);
    let (a, b) = (0.08f64, -0.05f64);
    let map = plane(nx, ny, 0.5, a, b);
    let q = (1.0 + a * a + b * b).sqrt();
    let m = Vec3::new(-a / q, -b / q, 1.0 / q);
    let model = TopoModel::new(TopoOptions {
        n: 1.0,
        ..TopoOptions::default()
    })
    .unwrap();
    for ti_deg in [0.0f64, 35.0, 70.0] {
        let ti = ti_deg.to_radians();
        let k_in = Vec3::new(ti.sin(), 0.0, -ti.cos());
        let k = k_in - m * (2.0 * k_in.dot(&m));
        // A cone whose axis is 0.4° off the ray, so its basis differs from the ray's.
        let axis = (k + Vec3::new(0.004, -0.005, 0.0)).normalize();
        let cone = Cone::new(
            flakescatter_optics::UnitVec3::new_normalize(axis),
            1f64.to_radians(),
        )
        .unwrap();
        let r = model
            .run_mueller(&[&map], &[ti], &[cone], &M00, &|_, _| {})
            .unwrap();
        let p = &r.points[0];
        let usable = ((nx - 4) * (ny - 4)) as f64;
        assert_eq!(p.rays, usable as u64);
        let (si, pi) = (s_of(&k_in), k_in.cross(&s_of(&k_in)));
        let u = s_of(&axis);
        let so = (u - k * u.dot(&k)).normalize();
        let po = k.cross(&so);
        let mirror = |e: &Vec3| m * (2.0 * m.dot(e)) - e;
        let j = flakescatter_optics::jones::JonesMatrix([
            [so.dot(&mirror(&si)), so.dot(&mirror(&pi))]
                .map(|v| flakescatter_optics::jones::C64::new(v, 0.0)),
            [po.dot(&mirror(&si)), po.dot(&mirror(&pi))]
                .map(|v| flakescatter_optics::jones::C64::new(v, 0.0)),
        ]);
        let gamma = -k_in.dot(&m);
        let want = Mueller::from_jones(&j) * (gamma / (m.z * ti.cos()) * usable / (nx * ny) as f64);
        for i in 0..4 {
            for k in 0..4 {
                assert!(
                    (p.reflectance.get(i, k) - want.get(i, k)).abs() < 1e-12,
                    "θi {ti_deg}: m{i}{k} {} vs {}",
                    p.reflectance.get(i, k),
                    want.get(i, k)
                );
            }
        }
        // One normal: every tile has the same weight per usable pixel, and m33 = −m00.
        assert!((p.reflectance.get(3, 3) + p.reflectance.m00()).abs() < 1e-12);
    }
}

#[test]
fn m00_and_the_readout_are_the_scalar_runs_and_the_clear_coat_is_its_fresnel_matrix() {
    // m00 is the scalar model (exact-unpolarized), the readout for s light with no
    // analyser (w_0j = s_j, s = (1, 1, 0, 0)) the scalar model with `s` (m00 + m01), the
    // tile errors likewise; with the clear coat on, a cone containing the specular
    // direction gains diag(rs, rp)'s Mueller matrix: m00 = R_av.
    let map = rough(220, 200, 4);
    let cones: Vec<Cone> = (-50..=50)
        .step_by(5)
        .map(|d| Cone::in_plane(f64::from(d).to_radians(), 2f64.to_radians()).unwrap())
        .chain((0..6).map(|k| Cone::out_of_plane(0.4, f64::from(k), 3f64.to_radians()).unwrap()))
        .collect();
    let ti = [20f64.to_radians(), 50f64.to_radians()];
    let s_light = [
        1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ];
    for clearcoat in [false, true] {
        let opts = TopoOptions {
            clearcoat,
            ..TopoOptions::default()
        };
        let mu = TopoModel::new(opts.clone())
            .unwrap()
            .run_mueller(&[&map], &ti, &cones, &s_light, &|_, _| {})
            .unwrap();
        let unpol = TopoModel::new(opts.clone())
            .unwrap()
            .run(&[&map], &ti, &cones)
            .unwrap();
        let s = TopoModel::new(TopoOptions {
            transmission: Transmission::S,
            ..opts
        })
        .unwrap()
        .run(&[&map], &ti, &cones)
        .unwrap();
        let mut seen = 0;
        for ((p, u), s) in mu.points.iter().zip(&unpol.points).zip(&s.points) {
            assert_eq!(p.rays, u.rays);
            assert_eq!(p.clearcoat_seen, u.clearcoat_seen);
            let tol = 1e-12 * u.reflectance.max(1e-300);
            assert!(
                (p.reflectance.m00() - u.reflectance).abs() < tol,
                "{} vs {}",
                p.reflectance.m00(),
                u.reflectance
            );
            // Standard errors: both absent (no ray, or one tile), or equal to rounding.
            let same = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) => (a - b).abs() < 1e-9 * b.max(1e-300) + 1e-18,
                (a, b) => a.is_none() && b.is_none(),
            };
            assert!(same(
                p.reflectance_std_err.map(|e| e.m00()),
                u.reflectance_std_err
            ));
            assert!((p.readout - s.reflectance).abs() < 1e-12 * s.reflectance.max(1e-300));
            assert!(same(p.readout_std_err, s.reflectance_std_err));
            assert!(
                (p.relative - s.relative).abs() <= 1e-9 * s.relative.abs()
                    || (p.relative.is_nan() && s.relative.is_nan()),
                "{} vs {} ({} rays, readout {}, {})",
                p.relative,
                s.relative,
                p.rays,
                p.readout,
                s.reflectance
            );
            if p.clearcoat_seen {
                seen += 1;
            }
        }
        assert_eq!(seen > 0, clearcoat);
    }
}

/// A smooth random surface (sum of plane waves, slopes up to ~10°).
fn rough(nx: usize, ny: usize, seed: u64) -> HeightMap {
    let waves: Vec<(f64, f64, f64)> = (0..8)
        .map(|k| {
            let t = (seed * 31 + k) as f64;
            (
                0.3 + 0.2 * (1.7 * t).sin(),
                0.3 + 0.2 * (2.3 * t).cos(),
                1.1 * t,
            )
        })
        .collect();
    let z = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as f64 * 0.5, (i / nx) as f64 * 0.5);
            waves
                .iter()
                .map(|&(kx, ky, ph)| 0.06 / kx.hypot(ky) * (kx * x + ky * y + ph).sin())
                .sum()
        })
        .collect();
    HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap()
}

#[test]
fn the_mueller_run_is_bit_identical_for_any_thread_count() {
    let maps = [rough(300, 260, 1), rough(180, 200, 2)];
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let cones: Vec<Cone> = (-40..=40)
        .step_by(4)
        .map(|d| {
            Cone::out_of_plane(
                f64::from(d).abs().to_radians(),
                f64::from(d).to_radians(),
                2f64.to_radians(),
            )
            .unwrap()
        })
        .collect();
    let ti = [10f64.to_radians(), 45f64.to_radians()];
    let m = TopoModel::new(TopoOptions::default()).unwrap();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| m.run_mueller(&refs, &ti, &cones, &M00, &|_, _| {}).unwrap())
    };
    let (one, three) = (run(1), run(3));
    assert_eq!(one, three);
    let bits = |r: &flakescatter_topo::TopoMuellerResult| -> Vec<u64> {
        r.points
            .iter()
            .flat_map(|p| {
                p.reflectance
                    .to_row_major()
                    .map(f64::to_bits)
                    .into_iter()
                    .chain(
                        p.reflectance_std_err
                            .map_or([u64::MAX; 16], |e| e.to_row_major().map(f64::to_bits)),
                    )
            })
            .collect()
    };
    assert_eq!(bits(&one), bits(&three));
    assert!(one.points.iter().filter(|p| p.rays > 0).count() > 5);
}

#[test]
fn a_detector_at_the_pole_takes_the_basis_of_its_azimuth() {
    // Issue 52, item 13. A flat mirror at normal incidence (n = 1, perfect conductor)
    // sends every ray straight up, to the pole. In the basis of a detector (0, φ) —
    // the limit θr → 0 at fixed φ: s' = (−sin φ, cos φ, 0), p' = z × s' — the vector
    // mirror E_out = 2 (z·E) z − E = −E gives J_ab = −e'_a · e_b with the incident
    // basis s = y, p = k_in × y = x: the closed form of the tilted-mirror test at the
    // pole. m11 is +m00 at φ = 0 and −m00 at φ = 90°. The same detector 1e-6° off the
    // pole (its basis is the axis's s = (−sin φ, cos φ, 0) projected perpendicular to
    // the rays, the same vector) collects the same rays: the same matrix.
    let (nx, ny) = (30, 20);
    let map = plane(nx, ny, 0.5, 0.0, 0.0);
    let model = TopoModel::new(TopoOptions {
        n: 1.0,
        ..TopoOptions::default()
    })
    .unwrap();
    let usable = ((nx - 4) * (ny - 4)) as f64;
    for phi_deg in [0.0f64, 30.0, 90.0, 135.0, 270.0] {
        let phi = phi_deg.to_radians();
        let cones = [
            Cone::out_of_plane(0.0, phi, 1f64.to_radians()).unwrap(),
            Cone::out_of_plane(1e-6f64.to_radians(), phi, 1f64.to_radians()).unwrap(),
        ];
        let r = model
            .run_mueller(&[&map], &[0.0], &cones, &M00, &|_, _| {})
            .unwrap();
        let so = Vec3::new(-phi.sin(), phi.cos(), 0.0);
        let po = Vec3::z().cross(&so);
        let (si, pi) = (Vec3::y(), Vec3::new(0.0, 0.0, -1.0).cross(&Vec3::y()));
        let c = |v: f64| flakescatter_optics::jones::C64::new(v, 0.0);
        let j = flakescatter_optics::jones::JonesMatrix([
            [c(-so.dot(&si)), c(-so.dot(&pi))],
            [c(-po.dot(&si)), c(-po.dot(&pi))],
        ]);
        let want = Mueller::from_jones(&j) * (usable / (nx * ny) as f64);
        for p in &r.points {
            assert_eq!(p.rays, usable as u64, "φ {phi_deg}°");
            for i in 0..4 {
                for k in 0..4 {
                    assert!(
                        (p.reflectance.get(i, k) - want.get(i, k)).abs() < 1e-12,
                        "φ {phi_deg}°, θr {}: m{i}{k} {} vs {}",
                        p.cone.axis().z.acos().to_degrees(),
                        p.reflectance.get(i, k),
                        want.get(i, k)
                    );
                }
            }
        }
        let m11 = r.points[0].reflectance.get(1, 1) / r.points[0].reflectance.m00();
        let expected = (2.0 * phi).cos();
        assert!(
            (m11 - expected).abs() < 1e-12,
            "φ {phi_deg}°: m11/m00 {m11}"
        );
    }
}
