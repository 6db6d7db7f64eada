//! A Lambertian base under transmitting flakes (physics.md §13, "A base under
//! transmitting flakes"; module `flakescatter_gaussian::base`).
//!
//! Checked against: a photon Monte Carlo of exactly the stated geometry written here
//! (facet normals drawn from the Gaussian weighted by their projected area seen from the
//! ray, a keep-going/reflect/absorb draw at each flake, a Lambertian base, the flat coat
//! interface with its own Fresnel formulas), with and without the base-to-base loop;
//! closed forms where the flakes pass everything (no coat interface: `ρ/π`; a coat of
//! index 1.5: the Lambertian base under a flat interface with its internal diffuse
//! reflectance); the energy of a white base; `ρ = 0` giving the model without a base.

use std::f64::consts::PI;

use flakescatter_gaussian::hemisphere::{base_total, total_detector_space};
use flakescatter_gaussian::{BaseLoop, ConeMethod, DistributionModel, ModelError, ModelOptions};
use flakescatter_optics::Vec3;
use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::polarization::Transmission;
use flakescatter_optics::thinfilm::{FilmStack, Layer};
use flakescatter_stats::{GaussianWidth, Orientation};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn stack(layers: &[(f64, f64, f64)], core: Option<Complex<f64>>) -> FlakeReflectance {
    let l = layers
        .iter()
        .map(|&(n, k, d)| Layer::new(Complex::new(n, k), d).unwrap())
        .collect();
    FlakeReflectance::stack(FilmStack::new(l).unwrap(), 550.0, core).unwrap()
}

fn plain(flake: FlakeReflectance, n: f64, sigma_deg: f64) -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::Sigma(sigma_deg.to_radians())).unwrap();
    let options = ModelOptions {
        flake,
        ..ModelOptions::default()
    };
    DistributionModel::new(o, n, options).unwrap()
}

fn with_base(
    flake: FlakeReflectance,
    n: f64,
    sigma_deg: f64,
    rho: f64,
    l: BaseLoop,
) -> DistributionModel {
    plain(flake, n, sigma_deg).with_base(rho, l).unwrap()
}

/// Unpolarised power transmittance of the flat interface for the air cosine `co` and
/// the coat cosine `ci` (Fresnel, §2), written here.
fn fresnel_t(co: f64, ci: f64, n: f64) -> f64 {
    let rs = (co - n * ci) / (co + n * ci);
    let rp = (n * co - ci) / (n * co + ci);
    1.0 - 0.5 * (rs * rs + rp * rp)
}

/// The same for light inside at cosine `ci` (0 beyond the critical angle).
fn t_inside(ci: f64, n: f64) -> f64 {
    let co2 = 1.0 - n * n * (1.0 - ci * ci);
    if co2 <= 0.0 {
        0.0
    } else {
        fresnel_t(co2.sqrt(), ci, n)
    }
}

/// The base's share of a cone: what the model with the base collects minus what it
/// collects without.
fn base_share(with: &DistributionModel, without: &DistributionModel, ti: f64, cone: &Cone) -> f64 {
    let a = with.incidence(ti).unwrap();
    let b = without.incidence(ti).unwrap();
    with.collect(&a, cone, ConeMethod::Exact)
        .reflectance
        .unwrap()
        - without
            .collect(&b, cone, ConeMethod::Exact)
            .reflectance
            .unwrap()
}

/// A flake's mean `(T, R)` at local cosine `γ` seen from above (`up == false`) or
/// below, tabulated on a fine grid for speed.
struct FlakeTable {
    down: Vec<(f64, f64)>,
    up: Vec<(f64, f64)>,
}

impl FlakeTable {
    const NODES: usize = 20001;
    fn new(flake: &FlakeReflectance, n: f64) -> Self {
        let FlakeReflectance::Stack(s) = flake else {
            panic!("a stack")
        };
        let under = FlakeReflectance::stack(s.stack().reversed(), s.wavelength_nm(), None).unwrap();
        let tab = |f: &FlakeReflectance| {
            (0..Self::NODES)
                .map(|i| {
                    let g = (i as f64 / (Self::NODES - 1) as f64).max(1e-9);
                    let (ts, tp) = f.transmitted(g, n);
                    (0.5 * (ts + tp), f.average(g, n))
                })
                .collect()
        };
        Self {
            down: tab(flake),
            up: tab(&under),
        }
    }
    fn at(&self, g: f64, up: bool) -> (f64, f64) {
        let t = if up { &self.up } else { &self.down };
        let x = g.clamp(0.0, 1.0) * (Self::NODES - 1) as f64;
        let i = (x as usize).min(Self::NODES - 2);
        let f = x - i as f64;
        let (a, b) = (t[i], t[i + 1]);
        (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1))
    }
}

/// The photon simulation of the stated geometry.
struct Photons<'a> {
    n: f64,
    sigma: f64,
    rho: f64,
    repeat: bool,
    flakes: &'a FlakeTable,
}

impl Photons<'_> {
    /// The local cosine `γ` on the side met by a ray of direction `k`, with the facet
    /// normal drawn from `p̃ ∝ exp(−θ²/2s²)` per solid angle times `γ⁺` (rejection: a
    /// 2-D Gaussian tilt accepted with `sin θ/θ`, then with `γ`).
    fn facet(&self, rng: &mut ChaCha8Rng, k: &Vec3) -> f64 {
        loop {
            let (u1, u2): (f64, f64) = (rng.random(), rng.random());
            let r = self.sigma * (-2.0 * (1.0 - u1).ln()).sqrt();
            let phi = 2.0 * PI * u2;
            // The tilt vector's magnitude is Rayleigh: θ = r.
            let theta = r;
            if theta >= PI / 2.0 {
                continue;
            }
            if theta > 0.0 && rng.random::<f64>() >= theta.sin() / theta {
                continue;
            }
            let m = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let gamma = if k.z < 0.0 { -k.dot(&m) } else { k.dot(&m) };
            if gamma > 0.0 && rng.random::<f64>() < gamma {
                return gamma;
            }
        }
    }

    /// One photon at incidence `ti`: the air exit direction of light that went through
    /// the base, or `None`.
    fn trace(&self, rng: &mut ChaCha8Rng, ti: f64) -> Option<Vec3> {
        let n = self.n;
        let ct = (1.0 - (ti.sin() / n).powi(2)).sqrt();
        if rng.random::<f64>() >= fresnel_t(ti.cos(), ct, n) {
            return None;
        }
        let k = Vec3::new(ti.sin() / n, 0.0, -ct);
        let g = self.facet(rng, &k);
        if rng.random::<f64>() >= self.flakes.at(g, false).0 {
            return None;
        }
        let mut returns = 0;
        loop {
            if returns > 0 && !self.repeat {
                return None;
            }
            returns += 1;
            if rng.random::<f64>() >= self.rho {
                return None;
            }
            let mu = rng.random::<f64>().sqrt();
            let phi = 2.0 * PI * rng.random::<f64>();
            let s = (1.0 - mu * mu).sqrt();
            let up = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
            let g = self.facet(rng, &up);
            let (t, r) = self.flakes.at(g, true);
            let u: f64 = rng.random();
            if u >= t + r {
                return None;
            }
            if u >= t {
                continue; // reflected by an underside, back to the base
            }
            if rng.random::<f64>() < t_inside(mu, n) {
                let z = (1.0 - n * n * (1.0 - mu * mu)).sqrt();
                return Some(Vec3::new(n * up.x, n * up.y, z));
            }
            // The cavity: down to the flakes' tops, which pass to the base, send the
            // light up again at its polar angle, or absorb.
            loop {
                let down = Vec3::new(up.x, up.y, -up.z);
                let g = self.facet(rng, &down);
                let (t, r) = self.flakes.at(g, false);
                let u: f64 = rng.random();
                if u < t {
                    break; // to the base
                }
                if u >= t + r {
                    return None;
                }
                if rng.random::<f64>() < t_inside(mu, n) {
                    let z = (1.0 - n * n * (1.0 - mu * mu)).sqrt();
                    return Some(Vec3::new(n * up.x, n * up.y, z));
                }
            }
        }
    }
}

/// In-plane cones (signed θs, half-angle) and one out of the plane.
fn cones() -> Vec<Cone> {
    let a = 8f64.to_radians();
    let mut c: Vec<Cone> = [-55.0f64, 0.0, 30.0, 62.0]
        .iter()
        .map(|d| Cone::in_plane(d.to_radians(), a).unwrap())
        .collect();
    let (t, p) = (40f64.to_radians(), 70f64.to_radians());
    c.push(
        Cone::new(
            flakescatter_optics::UnitVec3::new_normalize(Vec3::new(
                t.sin() * p.cos(),
                t.sin() * p.sin(),
                t.cos(),
            )),
            a,
        )
        .unwrap(),
    );
    c
}

fn monte_carlo_case(flake: FlakeReflectance, rho: f64, repeat: bool, seed: u64) {
    let (n, sigma_deg) = (1.5, 6.0);
    let l = if repeat {
        BaseLoop::Included
    } else {
        BaseLoop::Dropped
    };
    let model = with_base(flake.clone(), n, sigma_deg, rho, l);
    let without = plain(flake.clone(), n, sigma_deg);
    let table = FlakeTable::new(&flake, n);
    let photons = Photons {
        n,
        sigma: sigma_deg.to_radians(),
        rho,
        repeat,
        flakes: &table,
    };
    let cones = cones();
    let count = 2_400_000usize;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for ti_deg in [20.0f64, 60.0] {
        let ti = ti_deg.to_radians();
        let mut hits = vec![0usize; cones.len()];
        let mut out = 0usize;
        for _ in 0..count {
            if let Some(k) = photons.trace(&mut rng, ti) {
                out += 1;
                for (h, c) in hits.iter_mut().zip(&cones) {
                    *h += usize::from(c.contains(&flakescatter_optics::UnitVec3::new_normalize(k)));
                }
            }
        }
        let nf = count as f64;
        for (h, c) in hits.iter().zip(&cones) {
            let p = *h as f64 / nf;
            let se = (p * (1.0 - p) / nf).sqrt();
            let m = base_share(&model, &without, ti, c);
            eprintln!(
                "loop {repeat}, θi {ti_deg}, cone {:?}: model {m:.5e}, MC {p:.5e} ± {se:.1e}",
                c.axis().into_inner()
            );
            assert!(
                (m - p).abs() < 4.0 * se,
                "θi {ti_deg}, cone {:?}: model {m:.5e}, Monte Carlo {p:.5e} ± {se:.1e}",
                c.axis()
            );
            assert!(*h > 500, "{h} photons");
        }
        // Everything the base sends out, over the hemisphere.
        let p = out as f64 / nf;
        let se = (p * (1.0 - p) / nf).sqrt();
        let (m, err) = base_total(&model, &model.incidence(ti).unwrap());
        assert!(err < 1e-9);
        eprintln!("loop {repeat}, θi {ti_deg}: total model {m:.6}, MC {p:.6} ± {se:.1e}");
        assert!(
            (m - p).abs() < 4.0 * se,
            "θi {ti_deg}: total {m} vs {p} ± {se}"
        );
    }
}

/// A lossless TiO2-like layer (n = 2.4, 100 nm) at a white-ish base: the model's base
/// term against the photon simulation, with the loop and with one pass.
#[test]
fn base_term_matches_the_photon_simulation() {
    let tio2 = stack(&[(2.4, 0.0, 100.0)], None);
    monte_carlo_case(tio2.clone(), 0.9, true, 1);
    monte_carlo_case(tio2, 0.9, false, 2);
}

/// An absorbing asymmetric stack: the flakes transmit differently from above and below.
#[test]
fn asymmetric_absorbing_stack_matches_the_photon_simulation() {
    let asym = stack(&[(2.4, 0.0, 80.0), (2.0, 0.3, 40.0)], None);
    monte_carlo_case(asym, 0.7, true, 3);
}

/// Flakes that pass everything (an empty stack: the binder on both sides of no layer).
fn clear() -> FlakeReflectance {
    FlakeReflectance::stack(FilmStack::new(vec![]).unwrap(), 550.0, None).unwrap()
}

/// No coat interface (`n = 1`) and flakes that pass everything: the base alone,
/// `f = ρ/π`, and a cone of half-angle `α` about an axis at `θa` collects
/// `ρ/π · π sin²α cos θa` (`∫_cone cos θ dΩ = π sin²α cos θa` for a cone above the
/// horizon).
#[test]
fn clear_flakes_without_a_coat_are_the_bare_lambertian_base() {
    let rho = 0.8;
    let m = with_base(clear(), 1.0, 6.0, rho, BaseLoop::Included);
    for ti in [0.0f64, 35.0, 70.0] {
        let inc = m.incidence(ti.to_radians()).unwrap();
        for ts in [-60.0f64, -10.0, 0.0, 45.0, 80.0] {
            let t = ts.to_radians();
            let f = m.base_brdf(&inc, &Vec3::new(-t.sin(), 0.0, t.cos()));
            assert!((f - rho / PI).abs() < 1e-12 * rho, "{f}");
            let a = 3f64.to_radians();
            let cone = Cone::in_plane(t, a).unwrap();
            if ts.abs() < 80.0 {
                let got = m
                    .collect(&inc, &cone, ConeMethod::Exact)
                    .reflectance
                    .unwrap();
                let want = rho * a.sin().powi(2) * t.cos();
                assert!((got - want).abs() < 1e-10 * want, "{got} vs {want}");
            }
        }
    }
}

/// Clear flakes under a coat of index 1.5: the base under a flat interface,
/// `f = ρ T(θi) T(θo) / (π n² (1 − ρ r_i))` with `r_i = ∫ (1 − T_inside(θ)) 2 cos θ sin θ dθ`
/// (integrated here by Simpson in `cos θ` on both sides of the critical angle; Walsh's
/// closed form gives 0.596346, physics.md §12.3).
#[test]
fn clear_flakes_under_a_coat_are_the_base_under_a_flat_interface() {
    let (n, rho) = (1.5, 0.6);
    let m = with_base(clear(), n, 4.0, rho, BaseLoop::Included);
    let simpson = |f: &dyn Fn(f64) -> f64, a: f64, b: f64| {
        let k = 20000;
        let h = (b - a) / k as f64;
        (0..=k)
            .map(|i| {
                let w = if i == 0 || i == k {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * f(a + h * i as f64)
            })
            .sum::<f64>()
            * h
            / 3.0
    };
    // Below μc everything is reflected (∫ 2μ dμ = μc²); above it μ = μc + (1 − μc) s²
    // removes the square root of the transmittance at the critical angle.
    let mu_c = (1.0 - 1.0 / (n * n)).sqrt();
    let g = |s: f64| {
        let mu = mu_c + (1.0 - mu_c) * s * s;
        (1.0 - t_inside(mu, n)) * 2.0 * mu * 2.0 * (1.0 - mu_c) * s
    };
    let r_i = mu_c * mu_c + simpson(&g, 0.0, 1.0);
    assert!((r_i - 0.596346).abs() < 1e-6, "{r_i}");
    assert!((m.base().unwrap().return_fraction() - r_i).abs() < 1e-8);
    for ti in [0.0f64, 40.0, 75.0] {
        let t = ti.to_radians();
        let inc = m.incidence(t).unwrap();
        let t_in = fresnel_t(t.cos(), (1.0 - (t.sin() / n).powi(2)).sqrt(), n);
        for ts in [-70.0f64, -20.0, 0.0, 50.0] {
            let o = ts.to_radians();
            let t_out = fresnel_t(o.cos(), (1.0 - (o.sin() / n).powi(2)).sqrt(), n);
            let want = rho * t_in * t_out / (PI * n * n * (1.0 - rho * r_i));
            let f = m.base_brdf(&inc, &Vec3::new(-o.sin(), 0.0, o.cos()));
            assert!((f - want).abs() < 1e-8 * want, "{f} vs {want}");
        }
    }
}

/// Energy. Clear flakes over a white base under a coat: nothing is absorbed anywhere,
/// so the coat's mirror reflection plus the base's light is the whole beam (the flakes
/// reflect nothing). A lossless stack over a white base: every facet has `R + T = 1`,
/// so of the base's Lambertian light a share `r̄` returns and `e = 1 − r̄` leaves (the
/// cavity loses nothing), and the base's light is all that reached it,
/// `T(θi) τ↓(θt) e / (1 − r̄) = T(θi) τ↓(θt)`; with the flakes' own light and the
/// coat's mirror reflection at most the whole beam.
#[test]
fn a_white_base_conserves_energy() {
    let n = 1.5;
    let m = with_base(clear(), n, 6.0, 1.0, BaseLoop::Included);
    for ti in [0.0f64, 30.0, 60.0, 80.0] {
        let t = ti.to_radians();
        let inc = m.incidence(t).unwrap();
        let (b, _) = base_total(&m, &inc);
        let (f, _) = total_detector_space(&m, &inc);
        let ct = (1.0 - (t.sin() / n).powi(2)).sqrt();
        let mirror = 1.0 - fresnel_t(t.cos(), ct, n);
        assert!(f.abs() < 1e-15, "{f}");
        assert!((b + mirror - 1.0).abs() < 1e-8, "θi {ti}: {}", b + mirror);
    }
    let tio2 = stack(&[(2.4, 0.0, 100.0)], None);
    let m = with_base(tio2, n, 6.0, 1.0, BaseLoop::Included);
    let base = m.base().unwrap();
    // (The detector-space total of the flakes is slow in a debug build: two incidences.)
    let (e, r) = (base.escape_fraction(), base.return_fraction());
    assert!((e + r - 1.0).abs() < 1e-9, "{e} {r}");
    assert!(r > 0.1, "{r}");
    for ti in [0.0f64, 60.0] {
        let t = ti.to_radians();
        let inc = m.incidence(t).unwrap();
        let (b, _) = base_total(&m, &inc);
        let (f, _) = total_detector_space(&m, &inc);
        let ct = (1.0 - (t.sin() / n).powi(2)).sqrt();
        let mirror = 1.0 - fresnel_t(t.cos(), ct, n);
        let total = b + f + mirror;
        assert!(total <= 1.0 + 1e-9 && total > 0.9, "θi {ti}: {total}");
        let reaching = fresnel_t(t.cos(), ct, n) * base.tau_down(ct.acos());
        assert!((b - reaching).abs() < 1e-8, "{b} vs {reaching}");
    }
}

/// `ρ = 0` is the model without a base, to the bit; bad albedos, flakes that transmit
/// nothing and settings the base does not follow are refused.
#[test]
fn zero_albedo_is_the_black_base_and_bad_input_is_refused() {
    let tio2 = stack(&[(2.4, 0.0, 100.0)], None);
    let a = plain(tio2.clone(), 1.5, 6.0);
    let b = plain(tio2.clone(), 1.5, 6.0)
        .with_base(0.0, BaseLoop::Included)
        .unwrap();
    assert!(b.base().is_none());
    for ti in [10.0f64, 50.0] {
        let (ia, ib) = (
            a.incidence(ti.to_radians()).unwrap(),
            b.incidence(ti.to_radians()).unwrap(),
        );
        for c in cones() {
            assert_eq!(
                a.collect(&ia, &c, ConeMethod::Exact),
                b.collect(&ib, &c, ConeMethod::Exact)
            );
        }
    }
    for bad in [-0.1, 1.5, f64::NAN, f64::INFINITY] {
        let e = plain(tio2.clone(), 1.5, 6.0)
            .with_base(bad, BaseLoop::Included)
            .unwrap_err();
        assert!(matches!(e, ModelError::BaseAlbedo(_)), "{e}");
    }
    for flake in [
        FlakeReflectance::PerfectConductor,
        FlakeReflectance::aluminium_550nm(),
        stack(&[(2.4, 0.0, 100.0)], Some(Complex::new(0.96, 6.69))),
    ] {
        let e = plain(flake, 1.5, 6.0)
            .with_base(0.5, BaseLoop::Included)
            .unwrap_err();
        assert_eq!(e, ModelError::BaseFlake);
    }
    let o = Orientation::gaussian(GaussianWidth::Hwhm(0.1)).unwrap();
    let s = ModelOptions {
        flake: tio2,
        transmission: Transmission::S,
        ..ModelOptions::default()
    };
    let e = DistributionModel::new(o, 1.5, s)
        .unwrap()
        .with_base(0.5, BaseLoop::Included)
        .unwrap_err();
    assert!(matches!(e, ModelError::BaseSetting(_)), "{e}");
}
