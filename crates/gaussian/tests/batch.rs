//! The batch point BRDF (`DistributionModel::brdf_batch`, issue 22) against the scalar
//! point BRDF (`DistributionModel::brdf`), which stays the reference: two
//! implementations of physics.md §4 that share no arithmetic after the half vector (the
//! batch regroups the Fresnel, Jacobian and frame products into one quotient and has
//! its own arctangent and exponential). Over random models (every orientation kind,
//! transmission mode, weighting, flake kind, exit factor, absorption), incidences and
//! directions (uniform on the sphere, below the horizon, grazing, near specular, at and
//! near the zenith, the retro direction) every value agrees to 1e-12 relative, and
//! every exact zero and non-finite value is the scalar path's own.

use flakescatter_gaussian::{DistributionModel, ModelOptions};
use flakescatter_optics::Vec3;
use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::{GaussianWidth, Orientation};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const TRANSMISSIONS: [Transmission; 4] = [
    Transmission::ExactUnpolarized,
    Transmission::S,
    Transmission::P,
    Transmission::Paper,
];

/// A random model: `kind` picks the orientation (0–1 Gaussian of width `w_deg` given as
/// hwhm or sigma, 2 a random table), the other flags the options.
fn random_model(rng: &mut ChaCha8Rng, n: f64) -> DistributionModel {
    let orientation = match rng.random_range(0..3) {
        0 => Orientation::gaussian(GaussianWidth::Hwhm(
            10f64.powf(rng.random_range(-1.3..1.7)).to_radians(),
        ))
        .unwrap(),
        1 => Orientation::gaussian(GaussianWidth::Sigma(rng.random_range(0.001..1.2))).unwrap(),
        _ => {
            let bins = rng.random_range(1..12);
            let top = rng.random_range(0.05..std::f64::consts::FRAC_PI_2);
            let mut edges: Vec<f64> = (0..=bins)
                .map(|k| top * f64::from(k) / f64::from(bins))
                .collect();
            edges[0] = if rng.random_bool(0.5) {
                0.0
            } else {
                0.01 * top
            };
            let masses: Vec<f64> = (0..bins).map(|_| rng.random_range(0.0..1.0)).collect();
            Orientation::tabulated(edges, masses).unwrap()
        }
    };
    let options = ModelOptions {
        transmission: TRANSMISSIONS[rng.random_range(0..4)],
        weighting: if rng.random_bool(0.3) {
            Weighting::PaperPrinted
        } else {
            Weighting::Physical
        },
        flake: if rng.random_bool(0.5) {
            FlakeReflectance::PerfectConductor
        } else {
            FlakeReflectance::complex(rng.random_range(0.2..2.0), rng.random_range(0.0..8.0))
                .unwrap()
        },
        clearcoat: false,
        exit_fresnel: rng.random_bool(0.7),
    };
    let model = DistributionModel::new(orientation, n, options).unwrap();
    if rng.random_bool(0.2) {
        let depth = if rng.random_bool(0.5) {
            FlakeDepth::At { depth_um: 3.0 }
        } else {
            FlakeDepth::UniformInFilm { film_um: 20.0 }
        };
        model.with_absorption(PathAbsorption::new(rng.random_range(0.0..0.2), depth).unwrap())
    } else {
        model
    }
}

/// Directions of every kind the module docs list (not all unit: the scalar path takes
/// whatever it is given, and so must the batch).
fn directions(rng: &mut ChaCha8Rng, theta_i: f64, count: usize) -> Vec<Vec3> {
    let (si, ci) = theta_i.sin_cos();
    (0..count)
        .map(|_| match rng.random_range(0..8) {
            0 | 1 => {
                // Uniform on the sphere (half of them below the horizon).
                let z: f64 = rng.random_range(-1.0..1.0);
                let phi = rng.random_range(0.0..std::f64::consts::TAU);
                let s = (1.0 - z * z).sqrt();
                Vec3::new(s * phi.cos(), s * phi.sin(), z)
            }
            2 => {
                // Grazing: r_z from 1e-12 to 1e-2.
                let z = 10f64.powf(rng.random_range(-12.0..-2.0));
                let phi = rng.random_range(0.0..std::f64::consts::TAU);
                let s = (1.0 - z * z).sqrt();
                Vec3::new(s * phi.cos(), s * phi.sin(), z)
            }
            3 => {
                // Near specular, offsets from 1e-14 to 0.1 rad.
                let d = 10f64.powf(rng.random_range(-14.0..-1.0));
                let phi = rng.random_range(0.0..std::f64::consts::TAU);
                Vec3::new(si + d * phi.cos(), d * phi.sin(), ci).normalize()
            }
            4 => {
                // In the plane of incidence.
                let t = rng.random_range(-1.55..1.55f64);
                Vec3::new(-t.sin(), 0.0, t.cos())
            }
            5 => {
                // At and near the zenith.
                let d = if rng.random_bool(0.3) {
                    0.0
                } else {
                    10f64.powf(rng.random_range(-12.0..-1.0))
                };
                Vec3::new(d, rng.random_range(-1.0..1.0) * d, 1.0).normalize()
            }
            6 => {
                // Near the retro direction (−k_in), where the flake sees normal incidence.
                let d =
                    10f64.powf(rng.random_range(-12.0..-1.0)) * f64::from(rng.random_range(0..2));
                Vec3::new(-si + d, d, ci).normalize()
            }
            _ => {
                // Exactly horizontal, straight down, or below by a hair.
                match rng.random_range(0..3) {
                    0 => Vec3::new(1.0, 0.0, 0.0),
                    1 => Vec3::new(0.0, 0.0, -1.0),
                    _ => Vec3::new(0.6, 0.8, -1e-300),
                }
            }
        })
        .collect()
}

/// `batch` equals `scalar` to 1e-12 relative; exact zeros and non-finite values equal
/// (a floor at 1e-300 sr⁻¹, where subnormal rounding has no relative precision).
fn agree(batch: f64, scalar: f64) -> bool {
    if scalar == 0.0 || !scalar.is_finite() {
        return batch.to_bits() == scalar.to_bits() || (batch.is_nan() && scalar.is_nan());
    }
    (batch - scalar).abs() <= 1e-12 * scalar.abs() + 1e-300
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn batch_equals_scalar(seed in any::<u64>(), count in 0usize..40) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = [1.0, 1.2, 1.5, 2.0][rng.random_range(0..4)];
        let m = random_model(&mut rng, n);
        let ti = if rng.random_bool(0.1) { 0.0 } else { rng.random_range(0.0..std::f64::consts::FRAC_PI_2 - 1e-4) };
        let inc = m.incidence(ti).unwrap();
        let dirs = directions(&mut rng, ti, count);
        let mut out = vec![f64::NAN; 3];
        m.brdf_batch(&inc, &dirs, &mut out);
        prop_assert_eq!(out.len(), dirs.len());
        for (r, &b) in dirs.iter().zip(&out) {
            let s = m.brdf(&inc, r);
            prop_assert!(agree(b, s), "{:?} θi {ti} r {r:?}: batch {b:e} scalar {s:e} rel {:e}",
                m.options(), (b - s).abs() / s.abs());
        }
        // Splitting the batch does not change a bit.
        let cut = rng.random_range(0..=dirs.len());
        let (mut a, mut b) = (Vec::new(), Vec::new());
        m.brdf_batch(&inc, &dirs[..cut], &mut a);
        m.brdf_batch(&inc, &dirs[cut..], &mut b);
        a.extend(b);
        prop_assert!(a.iter().zip(&out).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

#[test]
fn default_model_agrees_over_the_whole_hemisphere() {
    // The configuration the benches time, on a dense grid of the upper hemisphere and
    // at every 5° of incidence; also records the worst relative difference.
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    let dirs: Vec<Vec3> = (0..90)
        .flat_map(|i| {
            let t = (f64::from(i) + 0.5).to_radians();
            (0..180).map(move |j| {
                let p = f64::from(2 * j).to_radians();
                Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
            })
        })
        .collect();
    let mut worst: f64 = 0.0;
    let mut out = Vec::new();
    for ti in (0..18).map(|k| f64::from(5 * k).to_radians()) {
        let inc = m.incidence(ti).unwrap();
        m.brdf_batch(&inc, &dirs, &mut out);
        for (r, &b) in dirs.iter().zip(&out) {
            let s = m.brdf(&inc, r);
            assert!(agree(b, s), "θi {ti} r {r:?}: {b:e} vs {s:e}");
            if s > 0.0 {
                worst = worst.max((b - s).abs() / s);
            }
        }
    }
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn narrow_gaussian_tails_agree() {
    // Narrow widths put the Gaussian exponent anywhere from 0 to far below the
    // hand-over to the scalar path, where an error in θn is amplified most.
    let mut out = Vec::new();
    for hwhm in [0.05, 0.2, 1.0, 3.0] {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(f64::to_radians(hwhm))).unwrap();
        let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
        for ti in [0.0, 0.3, 1.0] {
            let inc = m.incidence(ti).unwrap();
            let spec = inc.specular.into_inner();
            let dirs: Vec<Vec3> = (0..4000)
                .map(|k| {
                    let d = 1e-5 * 1.003f64.powi(k);
                    let p = 0.7 * f64::from(k);
                    (spec + Vec3::new(d * p.cos(), d * p.sin(), 0.0)).normalize()
                })
                .filter(|r| r.z > 0.0)
                .collect();
            m.brdf_batch(&inc, &dirs, &mut out);
            for (r, &b) in dirs.iter().zip(&out) {
                let s = m.brdf(&inc, r);
                assert!(agree(b, s), "hwhm {hwhm} θi {ti} r {r:?}: {b:e} vs {s:e}");
            }
        }
    }
}

#[test]
fn a_curve_of_point_detectors_equals_the_scalar_point_brdf() {
    // `curve` evaluates point detectors (α = 0) with the batch kernel; every row's BRDF,
    // power per sr and relative value equal what the scalar `brdf` gives for the same
    // direction (and the scalar specular reference) to 1e-12 relative, over random
    // models, in and out of the plane of incidence, out to 89° from the zenith.
    use flakescatter_gaussian::{ConeMethod, curve};
    use flakescatter_optics::UnitVec3;
    use flakescatter_optics::detector::Cone;
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let mut compared = 0;
    for _ in 0..40 {
        let n = rng.random_range(1.0..2.0);
        let m = random_model(&mut rng, n);
        let cones: Vec<Cone> = (0..1500)
            .map(|k| {
                let ts = f64::to_radians(-89.0 + 0.1187 * f64::from(k));
                let phi = if k % 3 == 0 {
                    0.0
                } else {
                    rng.random_range(-0.5..0.5)
                };
                let axis = Vec3::new(
                    -ts.sin() * f64::cos(phi),
                    f64::sin(phi),
                    ts.cos() * f64::cos(phi),
                );
                Cone::new(UnitVec3::new_normalize(axis), 0.0).unwrap()
            })
            .collect();
        let ti = [0.0, rng.random_range(0.0..1.5)];
        let rows = curve(&m, &ti, &cones, ConeMethod::Exact).unwrap();
        for row in &rows {
            let inc = m.incidence(row.theta_i).unwrap();
            let axis = row.cone.axis().into_inner();
            let f = m.brdf(&inc, &axis);
            let spec = {
                let p = Cone::in_plane(-row.theta_i, 0.0)
                    .unwrap()
                    .axis()
                    .into_inner();
                m.brdf(&inc, &p) * p.z
            };
            let close =
                |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs() || (a.is_nan() && b.is_nan());
            assert!(
                close(row.collected.brdf, f),
                "{} vs {f}",
                row.collected.brdf
            );
            assert!(close(row.collected.power_per_sr, f * axis.z));
            let want = if spec > 0.0 {
                f * axis.z / spec
            } else {
                f64::NAN
            };
            assert!(close(row.relative, want), "{} vs {want}", row.relative);
            compared += usize::from(f > 0.0);
        }
    }
    assert!(compared > 10_000, "{compared}");
}

/// The batch with the processor's best kernels (`Kernels::Auto`: AVX-512 or AVX2 where
/// the processor has them) and with the portable code alone (`Kernels::Portable`, what
/// `FLAKESCATTER_SIMD=portable` selects) gives the same bits, over random models of
/// every kind, incidences and directions of every kind. No tolerance: the kernel's
/// operations are correctly rounded in every instruction set, its fused multiply–adds
/// explicit (module docs of `batch`, "Vector instructions"); the portable run, one lane
/// per vector without any instruction chosen at run time, is the reference. The models'
/// kernels follow the switch: `with_kernels` sets them, and `new` reads
/// `FLAKESCATTER_SIMD` (unset or `auto` here unless CI sets `portable`).
#[test]
fn portable_and_dispatched_kernels_give_the_same_bits() {
    use flakescatter_gaussian::Kernels;
    let mut rng = ChaCha8Rng::seed_from_u64(45);
    let (mut auto, mut port) = (Vec::new(), Vec::new());
    let mut compared = 0;
    for _ in 0..300 {
        let n = [1.0, 1.2, 1.5, 2.0][rng.random_range(0..4)];
        let m = random_model(&mut rng, n);
        let expected = match std::env::var("FLAKESCATTER_SIMD").as_deref() {
            Ok("portable") => Kernels::Portable,
            _ => Kernels::Auto,
        };
        assert_eq!(m.kernels(), expected);
        let (ma, mp) = (
            m.clone().with_kernels(Kernels::Auto),
            m.with_kernels(Kernels::Portable),
        );
        assert_eq!(mp.kernels(), Kernels::Portable);
        let ti = rng.random_range(0.0..std::f64::consts::FRAC_PI_2 - 1e-4);
        let inc = ma.incidence(ti).unwrap();
        let dirs = directions(&mut rng, ti, 150);
        ma.brdf_batch(&inc, &dirs, &mut auto);
        mp.brdf_batch(&inc, &dirs, &mut port);
        for ((r, a), p) in dirs.iter().zip(&auto).zip(&port) {
            assert_eq!(
                a.to_bits(),
                p.to_bits(),
                "{:?} θi {ti} r {r:?}: {a:e} vs portable {p:e}",
                ma.options()
            );
            compared += usize::from(*p > 0.0);
        }
    }
    assert!(
        compared > 10_000,
        "only {compared} non-zero values compared"
    );
}
