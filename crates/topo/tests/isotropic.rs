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
use flakescatter_topo::{IsotropicOptions, TopoModel, TopoOptions};

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
            for ts in [-40.0f64, -30.0, -15.0, -7.0, 0.0, 5.0, 13.5, 26.0, 44.0, 60.0] {
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
    assert!(nonzero >= 20, "the closed form must be exercised ({nonzero})");
}

/// Per-pixel brute force, written here from physics.md §2 and §5 without the library's
/// ring code: for each pixel normal (from the library's windowed fit) and each sample
/// rotation `ψ`, trace `k1 → k2 → k_out` with vector algebra, test the cone with
/// `Cone::contains`, locate each change of that indicator between samples by bisection
/// on the indicator, and integrate the physical weight over the intervals found with a
/// 24-point Gauss–Legendre rule (Golub–Welsch nodes from `statrs`-free code below).
struct Brute {
    k1: Vec3,
    entry: fresnel::FresnelPower,
    cos_t: f64,
}

impl Brute {
    fn new(theta_i: f64) -> Self {
        let tt = (theta_i.sin() / N).asin();
        Self {
            k1: Vec3::new(tt.sin(), 0.0, -tt.cos()),
            entry: fresnel::air_to_coating(theta_i, N),
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
        // Exit Fresnel at the outside angle (reciprocity, physics.md §2).
        let exit = fresnel::air_to_coating(out.z.acos(), N);
        let f = 0.5 * (self.entry.ts * exit.ts + self.entry.tp * exit.tp);
        Some((out, f * gamma / (m.z * self.cos_t)))
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
    let mut cones: Vec<Cone> = [-66.0f64, -58.0, -49.5, -40.0, -31.0, -26.0, -17.0, -5.0, 8.0]
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
        assert!(err <= 3.0 * est, "error {err:e} above 3 × estimate {est:e}");
        assert!(est <= 6e-3 * bf, "estimate {est:e} of {bf:e}");
        // 16 times finer nodes: the error falls by more than 16^1.5 / 4 = 16.
        assert!(fine_err <= 3e-4 * bf, "δ/16: {fine_err:e} of {bf:e}");
    }
    assert!(compared >= 14, "{compared}");
}
