//! The isotropic average of the topographic model (physics.md §5.1): closed forms,
//! a per-pixel brute-force integration written here independently, invariance under
//! the map's orientation on its grid, determinism and bad input.

use std::f64::consts::{PI, TAU};

use flakescatter_optics::detector::Cone;
use flakescatter_optics::fresnel;
use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::HeightMap;
use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{LayerParams, LayerSpec, generate};
use flakescatter_topo::{IsotropicOptions, TopoError, TopoModel, TopoOptions};

const N: f64 = 1.5;

/// A plane `z = a x + b y + 3` on an `nx × ny` grid with pitch `dx × dy` (µm).
fn plane(nx: usize, ny: usize, dx: f64, dy: f64, a: f64, b: f64) -> HeightMap {
    let z = (0..nx * ny)
        .map(|i| a * (i % nx) as f64 * dx + b * (i / nx) as f64 * dy + 3.0)
        .collect();
    HeightMap::new(nx, ny, dx, dy, z).unwrap()
}

fn model() -> TopoModel {
    TopoModel::new(TopoOptions::default()).unwrap()
}

/// At normal incidence a pixel tilted by `θ` reflects to `k2 = (sin 2θ cos φ,
/// sin 2θ sin φ, cos 2θ)`, so its ring of exit directions is the circle of polar angle
/// `θo = asin(n sin 2θ)` and azimuth `φ`, with a constant weight: `γ = cos θ`,
/// `cos θt = 1`, and the area factor `1/cos θ` cancels `γ`, leaving
/// `F = ½[Ts(0) Ts(θo) + Tp(0) Tp(θo)]`. A cone of half-angle `α` about a direction
/// of polar angle `θr` holds the azimuths with
/// `cos θo cos θr + sin θo sin θr cos(φ − φr) > cos α`: the fraction `acos(q)/π` with
/// `q = (cos α − cos θo cos θr)/(sin θo sin θr)` (0 for `q ≥ 1`, 1 for `q ≤ −1`).
/// So `ρ = coverage · F · acos(q)/π`, whatever the tilt direction and `φr`.
#[test]
fn tilted_plane_at_normal_incidence_matches_the_closed_form_ring() {
    let (nx, ny, dx, dy) = (30, 26, 0.4, 0.55);
    let alpha = 2f64.to_radians();
    let usable = ((nx - 4) * (ny - 4)) as f64 / (nx * ny) as f64;
    let mut nonzero = 0;
    for theta_deg in [1.0f64, 4.0, 9.0, 15.0, 25.0] {
        let theta = theta_deg.to_radians();
        let theta_o_sin = N * (2.0 * theta).sin();
        // Tilted along x, along y and diagonally: the same ring.
        for (ux, uy) in [(1.0, 0.0), (0.0, 1.0), (0.6, -0.8)] {
            let map = plane(nx, ny, dx, dy, theta.tan() * ux, theta.tan() * uy);
            let mut cones = Vec::new();
            for ts in [
                -40.0f64, -30.0, -15.0, -7.0, 0.0, 5.0, 13.5, 26.0, 44.0, 60.0,
            ] {
                cones.push(Cone::in_plane(ts.to_radians(), alpha).unwrap());
            }
            for (tr, pr) in [(26.0f64, 1.0f64), (13.5, 2.5), (44.0, -2.0)] {
                cones.push(Cone::out_of_plane(tr.to_radians(), pr, alpha).unwrap());
            }
            // A wide cone about the normal holds whole rings up to 20°.
            cones.push(Cone::in_plane(0.0, 20f64.to_radians()).unwrap());
            let r = model().run_isotropic(&[&map], &[0.0], &cones).unwrap();
            assert_eq!(r.usable_pixels, ((nx - 4) * (ny - 4)) as u64);
            for p in &r.points {
                let expected = if theta_o_sin >= 1.0 {
                    0.0
                } else {
                    let theta_o = theta_o_sin.asin();
                    let theta_r = p.cone.axis().z.acos();
                    let (ca, ct, st) = (p.cone.cos_half_angle(), theta_r.cos(), theta_r.sin());
                    let q = (ca - theta_o.cos() * ct) / (theta_o.sin() * st);
                    let frac = if st == 0.0 {
                        f64::from(u8::from(theta_o.cos() > ca))
                    } else {
                        q.clamp(-1.0, 1.0).acos() / PI
                    };
                    let fi = fresnel::air_to_coating(0.0, N);
                    let fo = fresnel::air_to_coating(theta_o, N);
                    usable * 0.5 * (fi.ts * fo.ts + fi.tp * fo.tp) * frac
                };
                if expected > 0.0 {
                    nonzero += 1;
                }
                assert!(
                    (p.reflectance - expected).abs() <= 1e-9 * expected.max(1e-6),
                    "θ {theta_deg}° tilt ({ux}, {uy}) axis {:?}: {} vs {expected}",
                    p.cone.axis(),
                    p.reflectance
                );
            }
        }
    }
    assert!(
        nonzero >= 20,
        "the closed form must be exercised ({nonzero})"
    );
}

/// Per-pixel brute force, written here from physics.md §2 and §5 without the library's
/// ring code: for each pixel normal (from the library's windowed fit) and each sample
/// rotation `ψ`, trace `k1 → k2 → k_out` with vector algebra, test the cone with
/// `Cone::contains`, locate each change of that indicator between samples by bisection
/// on the indicator, and integrate the physical weight over the intervals found with a
/// 24-point Gauss–Legendre rule (Golub–Welsch nodes from `statrs`-free code below).
struct Brute {
    k1: Vec3,
    cos_i: f64,
    cos_t: f64,
}

impl Brute {
    fn new(theta_i: f64) -> Self {
        let tt = (theta_i.sin() / N).asin();
        Self {
            k1: Vec3::new(tt.sin(), 0.0, -tt.cos()),
            cos_i: theta_i.cos(),
            cos_t: tt.cos(),
        }
    }

    /// Exit direction and weight `F γ / (m.z cos θt)` of normal `m` rotated by `psi`.
    fn ray(&self, m: &Vec3, psi: f64) -> Option<(UnitVec3, f64)> {
        let (s, c) = psi.sin_cos();
        let mr = Vec3::new(c * m.x - s * m.y, s * m.x + c * m.y, m.z);
        let gamma = -self.k1.dot(&mr);
        let k2 = self.k1 + 2.0 * gamma * mr;
        if gamma <= 0.0 || k2.z <= 0.0 {
            return None;
        }
        let h2 = N * N * (k2.x * k2.x + k2.y * k2.y);
        if h2 >= 1.0 {
            return None;
        }
        let out = UnitVec3::new_normalize(Vec3::new(N * k2.x, N * k2.y, (1.0 - h2).sqrt()));
        let f = self.path_power(&mr, &k2, &out);
        Some((out, f * gamma / (m.z * self.cos_t)))
    }

    /// The unpolarised path factor of one ray by vector field calculus, written out here
    /// (physics.md §11): for incident s and p fields, refract with the entry amplitudes
    /// `ts, tp` (s stays s, p turns with the ray), reflect by a perfect-conductor flake
    /// (`E' = 2 (m·E) m − E`), split the field into the exit plane's s and p and refract
    /// out with the coating → air amplitudes; the power is the mean of `|E_out|²` over
    /// the two inputs times the beam-section factors `(cos θt/cos θi)(cos θo/cos θ2)`.
    fn path_power(&self, m: &Vec3, k2: &Vec3, out: &UnitVec3) -> f64 {
        let (ci, ct) = (self.cos_i, self.cos_t);
        let (c2, co) = (k2.z, out.z);
        let ts = 2.0 * ci / (ci + N * ct);
        let tp = 2.0 * ci / (N * ci + ct);
        let ts_out = 2.0 * N * c2 / (N * c2 + co);
        let tp_out = 2.0 * N * c2 / (c2 + N * co);
        let z = Vec3::z();
        // In the plane of incidence (xz) the entry s is y; p = k × s for each direction.
        let s_in = Vec3::y();
        let p1 = self.k1.cross(&s_in);
        let s2 = z.cross(k2).normalize();
        let p2 = k2.cross(&s2);
        let mut power = 0.0;
        for e1 in [s_in * ts, p1 * tp] {
            let e2 = 2.0 * m.dot(&e1) * m - e1;
            let (es, ep) = (e2.dot(&s2) * ts_out, e2.dot(&p2) * tp_out);
            power += 0.5 * (es * es + ep * ep);
        }
        power * (ct / ci) * (co / c2)
    }

    fn inside(&self, m: &Vec3, psi: f64, cone: &Cone) -> bool {
        self.ray(m, psi).is_some_and(|(k, _)| cone.contains(&k))
    }

    /// `(1/2π) ∫ w 1[cone] dψ` for one pixel and each cone.
    fn pixel(&self, m: &Vec3, cones: &[Cone], samples: usize, gl: &[(f64, f64)]) -> Vec<f64> {
        let step = TAU / samples as f64;
        let dirs: Vec<Option<UnitVec3>> = (0..=samples)
            .map(|i| self.ray(m, i as f64 * step).map(|(k, _)| k))
            .collect();
        cones
            .iter()
            .map(|cone| {
                let flags: Vec<bool> = dirs
                    .iter()
                    .map(|k| k.is_some_and(|k| cone.contains(&k)))
                    .collect();
                let edge = |lo: f64, hi: f64, inside_lo: bool| {
                    let (mut a, mut b) = (lo, hi);
                    for _ in 0..55 {
                        let x = 0.5 * (a + b);
                        if self.inside(m, x, cone) == inside_lo {
                            a = x;
                        } else {
                            b = x;
                        }
                    }
                    0.5 * (a + b)
                };
                let mut total = 0.0;
                let mut start = if flags[0] { Some(0.0) } else { None };
                for i in 0..samples {
                    let (lo, hi) = (i as f64 * step, (i + 1) as f64 * step);
                    match (flags[i], flags[i + 1]) {
                        (false, true) => start = Some(edge(lo, hi, false)),
                        (true, false) => {
                            let end = edge(lo, hi, true);
                            total += self.integral(m, start.take().unwrap(), end, gl);
                        }
                        _ => {}
                    }
                }
                if let Some(s) = start {
                    total += self.integral(m, s, TAU, gl);
                }
                total / TAU
            })
            .collect()
    }

    fn integral(&self, m: &Vec3, a: f64, b: f64, gl: &[(f64, f64)]) -> f64 {
        let panels = ((b - a) / 0.2).ceil().max(1.0) as usize;
        let h = (b - a) / panels as f64;
        let mut s = 0.0;
        for p in 0..panels {
            let mid = a + (p as f64 + 0.5) * h;
            for &(x, w) in gl {
                if let Some((_, wt)) = self.ray(m, mid + 0.5 * h * x) {
                    s += 0.5 * h * w * wt;
                }
            }
        }
        s
    }
}

/// Gauss–Legendre nodes and weights on `[−1, 1]` by Newton's method on `P_n`.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// A small rough flake layer (no z quantisation) whose pixel normals spread over
/// 0–20°.
fn rough_map(nx: usize, ny: usize, seed: u64) -> HeightMap {
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(nx, ny, orientation, seed);
    spec.roughness.rms_um = 0.05;
    spec.roughness.correlation_um = 1.5;
    spec.confocal.z_step_um = 0.0;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let mut map = layer.height;
    map.apply_intensity_cutoff(&layer.intensity, 0.49).unwrap();
    map
}

#[test]
fn isotropic_model_matches_a_per_pixel_brute_force_integration() {
    let map = rough_map(40, 40, 11);
    let model = model();
    let normals: Vec<Vec3> = model
        .normals(&map)
        .unwrap()
        .to_vec()
        .into_iter()
        .flatten()
        .map(UnitVec3::into_inner)
        .collect();
    assert!(normals.len() > 800, "{}", normals.len());
    let alpha = 1.5f64.to_radians();
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let mut cones: Vec<Cone> = [
        -66.0f64, -58.0, -49.5, -40.0, -31.0, -26.0, -17.0, -5.0, 8.0,
    ]
    .iter()
    .map(|d| Cone::in_plane(d.to_radians(), alpha).unwrap())
    .collect();
    cones.push(Cone::out_of_plane(32f64.to_radians(), 0.2, alpha).unwrap());
    cones.push(Cone::out_of_plane(55f64.to_radians(), -0.15, 3f64.to_radians()).unwrap());
    let r = model.run_isotropic(&[&map], &theta_i, &cones).unwrap();
    let fine = model
        .run_isotropic_with(
            &[&map],
            &theta_i,
            &cones,
            &IsotropicOptions {
                node_spacing: Some(r.node_spacing / 16.0),
            },
            &|_, _| {},
        )
        .unwrap();
    let gl = gauss_legendre(24);
    // Brute force per incidence, all cones at once.
    let mut brute = Vec::new();
    for &ti in &theta_i {
        let b = Brute::new(ti);
        let mut acc = vec![0.0; cones.len()];
        for m in &normals {
            for (a, v) in acc.iter_mut().zip(b.pixel(m, &cones, 4096, &gl)) {
                *a += v;
            }
        }
        brute.extend(acc.into_iter().map(|v| v / map.len() as f64));
    }
    let mut compared = 0;
    for (k, p) in r.points.iter().enumerate() {
        let bf = brute[k];
        let err = (p.reflectance - bf).abs();
        let est = r.interpolation_error[k];
        let fine_err = (fine.points[k].reflectance - bf).abs();
        eprintln!(
            "θi {:.0} axis ({:+.3},{:+.3}) iso {:.6e} brute {:.6e} rel {:.2e} est {:.2e} δ/16: rel {:.2e} est {:.2e}",
            p.theta_i.to_degrees(),
            p.cone.axis().x,
            p.cone.axis().y,
            p.reflectance,
            bf,
            err / bf,
            est / bf,
            fine_err / bf,
            fine.interpolation_error[k] / bf,
        );
        if bf == 0.0 {
            assert_eq!(p.reflectance, 0.0);
            continue;
        }
        compared += 1;
        assert!(err <= 3e-3 * bf, "default spacing: {err:e} of {bf:e}");
        assert!(
            err <= 1.5 * est,
            "error {err:e} above 1.5 × estimate {est:e}"
        );
        assert!(est <= 6e-3 * bf, "estimate {est:e} of {bf:e}");
        // 16 times finer nodes: the error falls by more than 16^1.5 / 4 = 16.
        assert!(fine_err <= 3e-4 * bf, "δ/16: {fine_err:e} of {bf:e}");
    }
    assert!(compared >= 14, "{compared}");
}

/// A 512² map like the fixtures (`fixtures/README.md`: 0.18 µm pixels, 0.3 µm z step,
/// intensity cutoff 0.49), regenerated with the fixtures' parameters.
fn fixture_like(hwhm_deg: f64, roughness_um: f64, correlation_um: f64, seed: u64) -> HeightMap {
    fixture_variant(hwhm_deg, roughness_um, correlation_um, seed, 0.3, 0.0)
}

/// As [`fixture_like`] with another z step and height noise (µm).
fn fixture_variant(
    hwhm_deg: f64,
    roughness_um: f64,
    correlation_um: f64,
    seed: u64,
    z_step_um: f64,
    noise_um: f64,
) -> HeightMap {
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
    let mut spec = LayerSpec::new(512, 512, orientation, seed);
    spec.roughness.rms_um = roughness_um;
    spec.roughness.correlation_um = correlation_um;
    spec.confocal.z_step_um = z_step_um;
    spec.confocal.noise_sd_um = noise_um;
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    assert!(
        (55..=85).contains(&layer.visible_flakes().count()),
        "about 70 flakes"
    );
    let mut map = layer.height;
    map.apply_intensity_cutoff(&layer.intensity, 0.49).unwrap();
    map
}

/// The instrument of `reproduce`: in-plane θs = −70°:0.5°:70°, α = 1.5°.
fn goniometer() -> Vec<Cone> {
    (-140..=140)
        .map(|d| Cone::in_plane((f64::from(d) * 0.5).to_radians(), 1.5f64.to_radians()).unwrap())
        .collect()
}

/// Points within 40° of specular (`|θs + θi| ≤ 40°`), as (θs, point) pairs.
fn near_specular(
    points: &[flakescatter_topo::TopoPoint],
) -> impl Iterator<Item = &flakescatter_topo::TopoPoint> {
    points.iter().filter(|p| {
        let ts = flakescatter_optics::detector::in_plane_angle(p.cone.axis());
        (ts + p.theta_i).abs() <= 40f64.to_radians() + 1e-9
    })
}

/// Issue 17: on one 512² map of ~70 rough flakes, every in-plane detector within 40° of
/// specular gets light with a finite standard error at θi = 30° and 60°. The map is the
/// rough fixture's layer seen with the paper's 0.3 µm z step and a 10 nm height noise.
#[test]
fn rough_map_reaches_every_detector_near_specular() {
    let map = fixture_variant(6.0, 0.05, 1.5, 6, 0.3, 0.01);
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let cones = goniometer();
    let r = model().run_isotropic(&[&map], &theta_i, &cones).unwrap();
    let plain = model().run(&[&map], &theta_i, &cones).unwrap();
    let near: Vec<_> = near_specular(&r.points).collect();
    assert_eq!(near.len(), 161 + 101, "detectors within 40° of specular");
    let empty: Vec<String> = near
        .iter()
        .filter(|p| p.reflectance == 0.0)
        .map(|p| {
            format!(
                "{:.0}/{:.1}",
                p.theta_i.to_degrees(),
                flakescatter_optics::detector::in_plane_angle(p.cone.axis()).to_degrees()
            )
        })
        .collect();
    eprintln!("empty: {empty:?}");
    for p in &near {
        assert!(
            p.reflectance > 0.0
                && p.reflectance_std_err
                    .is_some_and(|e| e.is_finite() && e > 0.0),
            "θi {:.0}°, axis {:?}: {} ± {:?}",
            p.theta_i.to_degrees(),
            p.cone.axis(),
            p.reflectance,
            p.reflectance_std_err
        );
    }
    let plain_empty = near_specular(&plain.points).filter(|p| p.rays == 0).count();
    eprintln!(
        "plain model: {plain_empty} of {} near-specular detectors empty",
        near.len()
    );
    assert!(
        plain_empty > 20,
        "the plain model leaves gaps here ({plain_empty})"
    );
}

/// Issue 17: on a map like the smooth fixture (0.3 µm z steps; here with a 10 nm height
/// noise, as a confocal has) the isotropic model leaves at least 4× fewer near-specular
/// detectors empty than the plain model.
#[test]
fn smooth_quantised_map_has_at_least_four_times_fewer_empty_detectors() {
    let map = fixture_variant(3.0, 0.0, 1.0, 3, 0.3, 0.01);
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let cones = goniometer();
    let r = model().run_isotropic(&[&map], &theta_i, &cones).unwrap();
    let plain = model().run(&[&map], &theta_i, &cones).unwrap();
    for ti in theta_i {
        let empty = |ps: &[flakescatter_topo::TopoPoint]| {
            near_specular(ps)
                .filter(|p| p.theta_i == ti && p.reflectance == 0.0)
                .count()
        };
        let (iso_empty, plain_empty) = (empty(&r.points), empty(&plain.points));
        eprintln!(
            "θi {:.0}°: empty near-specular detectors: plain {plain_empty}, isotropic {iso_empty}",
            ti.to_degrees()
        );
        assert!(plain_empty >= 40, "{plain_empty}");
        assert!(4 * iso_empty <= plain_empty, "{iso_empty} vs {plain_empty}");
    }
}

/// The normals a map holds bound what it can reach. On the noiseless smooth fixture
/// the 5 × 5 fit sees flat quantised terraces (tilt 0) or parts of 0.3 µm steps, whose
/// slopes are multiples of `0.3 µm / (5 · 0.18 µm · 10)` = 1/15 (a step across the
/// whole window: 1/3 or 1/2, 18° or 27°), and windows across flake edges give steep
/// tilts: the map holds no tilt between 0 and 3.8°, so no detector between the specular cone and the rings of the smallest
/// non-zero tilts can be reached, rotation or not. A ring meets the plane of incidence
/// only where it crosses it (`φ = 0, π`; it is symmetric about the plane and, away
/// from tilt 0, much larger than the 1.5° cones), so an in-plane detector is reachable
/// exactly when one of the map's tilts crosses the plane within the aperture of its
/// axis; crossings traced here with the brute-force tracer above.
#[test]
fn isotropic_model_reaches_what_the_map_tilts_can_reach() {
    let map = fixture_like(3.0, 0.0, 1.0, 3);
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let cones = goniometer();
    let m = model();
    let r = m.run_isotropic(&[&map], &theta_i, &cones).unwrap();
    let plain = m.run(&[&map], &theta_i, &cones).unwrap();
    let mut tilts: Vec<f64> = m
        .normals(&map)
        .unwrap()
        .to_vec()
        .into_iter()
        .flatten()
        .map(|n| n.z.acos())
        .collect();
    tilts.sort_by(f64::total_cmp);
    tilts.dedup_by(|a, b| (*a - *b).abs() < 1e-7);
    let smallest = tilts.iter().find(|&&t| t > 1e-6).copied().unwrap();
    eprintln!(
        "{} distinct tilts, the smallest non-zero {:.2}°",
        tilts.len(),
        smallest.to_degrees()
    );
    assert!(smallest > 3f64.to_radians());
    let (mut checked, mut ambiguous) = (0, 0);
    for ti in theta_i {
        let brute = Brute::new(ti);
        let crossings: Vec<f64> = tilts
            .iter()
            .flat_map(|&t| {
                let m = Vec3::new(t.sin(), 0.0, t.cos());
                [0.0, PI].map(|psi| brute.ray(&m, psi))
            })
            .flatten()
            .map(|(k, _)| flakescatter_optics::detector::in_plane_angle(&k))
            .collect();
        for p in near_specular(&r.points).filter(|p| p.theta_i == ti) {
            let ts = flakescatter_optics::detector::in_plane_angle(p.cone.axis());
            let closest = crossings
                .iter()
                .map(|c| (c - ts).abs())
                .fold(f64::INFINITY, f64::min);
            let alpha = p.cone.half_angle();
            if (closest - alpha).abs() < 0.02f64.to_radians() {
                ambiguous += 1;
                continue;
            }
            checked += 1;
            assert_eq!(
                p.reflectance == 0.0,
                closest > alpha,
                "θi {:.0}° θs {:.1}°: {} (closest crossing {:.3}° away)",
                ti.to_degrees(),
                ts.to_degrees(),
                p.reflectance,
                closest.to_degrees(),
            );
        }
    }
    let empty = |ps: &[flakescatter_topo::TopoPoint]| {
        near_specular(ps).filter(|p| p.reflectance == 0.0).count()
    };
    eprintln!(
        "noiseless smooth map: empty near-specular detectors: plain {}, isotropic {} ({checked} checked, {ambiguous} within 0.02° of the rim)",
        empty(&plain.points),
        empty(&r.points)
    );
    assert!(checked > 240 && ambiguous < 20, "{checked} {ambiguous}");
    assert!(empty(&r.points) > 50 && empty(&r.points) < empty(&plain.points));
}

/// A map transposed, flipped or turned by 90° on its grid.
fn transformed(map: &HeightMap, how: &str) -> HeightMap {
    let (nx, ny) = (map.nx(), map.ny());
    let (z, v) = (map.heights(), map.valid());
    let (mx, my, dx, dy) = match how {
        "transpose" | "rotate90" => (ny, nx, map.dy(), map.dx()),
        _ => (nx, ny, map.dx(), map.dy()),
    };
    let source = |c: usize, r: usize| -> usize {
        match how {
            "transpose" => c * nx + r,
            // Turned by 90°: new (c, r) = old (r, ny − 1 − c).
            "rotate90" => (ny - 1 - c) * nx + r,
            "flip_x" => r * nx + (nx - 1 - c),
            "flip_y" => (ny - 1 - r) * nx + c,
            _ => unreachable!(),
        }
    };
    let idx: Vec<usize> = (0..mx * my).map(|i| source(i % mx, i / mx)).collect();
    HeightMap::with_mask(
        mx,
        my,
        dx,
        dy,
        idx.iter().map(|&i| z[i]).collect(),
        idx.iter().map(|&i| v[i]).collect(),
    )
    .unwrap()
}

/// Rotating, transposing or flipping the map leaves the isotropic result unchanged (to
/// rounding: the windowed sums run in another order) while the plain model changes.
/// Tiles of 128 pixels divide the 512-pixel map, so every transform maps tiles onto
/// tiles and the standard errors agree too.
#[test]
fn isotropic_result_does_not_depend_on_the_map_orientation() {
    let map = fixture_like(6.0, 0.05, 1.5, 6);
    let theta_i = [30f64.to_radians(), 60f64.to_radians()];
    let mut cones = goniometer();
    for (tr, pr) in [(20.0f64, 0.5f64), (40.0, 0.7), (50.0, 2.0), (30.0, -1.2)] {
        cones.push(Cone::out_of_plane(tr.to_radians(), pr, 2f64.to_radians()).unwrap());
    }
    let m = model().with_block_um(128.0 * 0.18).unwrap();
    let iso = m.run_isotropic(&[&map], &theta_i, &cones).unwrap();
    let plain = m.run(&[&map], &theta_i, &cones).unwrap();
    assert_eq!(iso.tiles, 16);
    // The comparisons below are relative, so they are only worth something where there
    // is a value: at least 80 % of the in-plane detectors and every out-of-plane one
    // read light with a standard error (500 of 562 and 8 of 8 when written).
    let lit = |out_of_plane: bool| {
        iso.points
            .iter()
            .filter(|p| (p.cone.axis().y != 0.0) == out_of_plane)
            .filter(|p| p.reflectance > 0.0 && p.reflectance_std_err.is_some_and(|e| e > 0.0))
            .count()
    };
    let n_out = 4 * theta_i.len();
    let n_in = iso.points.len() - n_out;
    let (lit_in, lit_out) = (lit(false), lit(true));
    eprintln!(
        "isotropic: {lit_in} of {n_in} in-plane, {lit_out} of {n_out} out-of-plane detectors lit"
    );
    assert!(lit_in * 10 >= n_in * 8, "in plane: {lit_in} of {n_in}");
    assert_eq!(lit_out, n_out, "out of plane");
    for how in ["transpose", "rotate90", "flip_x", "flip_y"] {
        let t = transformed(&map, how);
        let iso_t = m.run_isotropic(&[&t], &theta_i, &cones).unwrap();
        assert_eq!(iso_t.usable_pixels, iso.usable_pixels);
        for (a, b) in iso.points.iter().zip(&iso_t.points) {
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * x.abs().max(y.abs());
            assert!(
                close(a.reflectance, b.reflectance)
                    && match (a.reflectance_std_err, b.reflectance_std_err) {
                        (Some(x), Some(y)) => close(x, y),
                        (x, y) => x == y,
                    },
                "{how}: {} ± {:?} vs {} ± {:?}",
                a.reflectance,
                a.reflectance_std_err,
                b.reflectance,
                b.reflectance_std_err
            );
        }
        // The plain model changes; a flip across the plane of incidence (y → −y) is a
        // symmetry of the in-plane detectors, so there only the out-of-plane ones change.
        let plain_t = m.run(&[&t], &theta_i, &cones).unwrap();
        let changed = |in_plane: bool| {
            plain
                .points
                .iter()
                .zip(&plain_t.points)
                .filter(|(a, _)| (a.cone.axis().y == 0.0) == in_plane)
                .filter(|(a, b)| {
                    (a.reflectance - b.reflectance).abs() > 0.1 * a.reflectance.max(b.reflectance)
                })
                .count()
        };
        let (in_plane, out) = (changed(true), changed(false));
        eprintln!(
            "{how}: plain model changed by > 10 % at {in_plane} in-plane, {out} out-of-plane detectors"
        );
        assert!(out >= 1, "{how}: out of plane ({out})");
        if how == "flip_y" {
            assert!(in_plane <= 2, "{how}: in plane ({in_plane})");
        } else {
            assert!(in_plane > 20, "{how}: in plane ({in_plane})");
        }
    }
}

/// One thread and three threads give identical bits.
#[test]
fn isotropic_result_is_bit_identical_for_any_thread_count() {
    let maps = [rough_map(150, 120, 3), rough_map(90, 140, 4)];
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let cones = goniometer();
    let ti = [0.0, 45f64.to_radians()];
    let m = model().with_block_um(8.0).unwrap();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| m.run_isotropic(&refs, &ti, &cones).unwrap())
    };
    let bits = |r: &flakescatter_topo::IsotropicResult| -> Vec<u64> {
        r.points
            .iter()
            .zip(&r.interpolation_error)
            .flat_map(|(p, e)| {
                [
                    p.reflectance.to_bits(),
                    p.reflectance_std_err.map_or(u64::MAX, f64::to_bits),
                    p.relative.to_bits(),
                    e.to_bits(),
                    p.rays,
                ]
            })
            .chain([r.rings_lost_tir.to_bits(), r.rings_lost_down.to_bits()])
            .collect()
    };
    let (one, three) = (run(1), run(3));
    assert_eq!(bits(&one), bits(&three));
    assert!(one.tiles > 20 && one.points.iter().filter(|p| p.rays > 0).count() > 50);
}

/// The isotropic run refuses what the plain run refuses, and a bad node spacing.
#[test]
fn isotropic_bad_input_is_an_error() {
    let map = plane(20, 20, 0.5, 0.5, 0.01, 0.0);
    let cones = goniometer();
    let m = model();
    let with = |d: f64| {
        m.run_isotropic_with(
            &[&map],
            &[0.3],
            &cones,
            &IsotropicOptions {
                node_spacing: Some(d),
            },
            &|_, _| {},
        )
    };
    for d in [0.0, -1e-4, f64::NAN, f64::INFINITY, 0.02] {
        assert!(matches!(with(d), Err(TopoError::NodeSpacing(_))), "{d}");
    }
    assert!(matches!(
        m.run_isotropic(&[], &[0.3], &cones),
        Err(TopoError::Empty(_))
    ));
    assert!(matches!(
        m.run_isotropic(&[&map], &[1.6], &cones),
        Err(TopoError::Incidence(_))
    ));
    assert!(matches!(
        m.run_isotropic(&[&map], &[0.3], &[Cone::in_plane(0.0, 0.0).unwrap()]),
        Err(TopoError::PointDetector(0))
    ));
    let tiny = plane(3, 3, 0.5, 0.5, 0.0, 0.0);
    assert!(matches!(
        m.run_isotropic(&[&tiny], &[0.3], &cones),
        Err(TopoError::WindowTooLarge { .. })
    ));
}
