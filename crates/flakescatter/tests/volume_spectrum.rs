//! The volume model at several wavelengths ([`spectral_volume_curves`]) and with a
//! tinted binder whose absorption is a table versus wavelength.
//!
//! * **Airy's spectrum.** One flat free flake per layer, a single layer of index
//!   `n₁ = 2.6`, `d = 300 nm`, in a binder of `n₀ = 1.5`, seen at normal incidence with a
//!   cone about the normal; black substrate. A ray either meets the flake's top face
//!   (probability `c = π r²/L²`, the disc's share of the tile: flat flakes at one depth do
//!   not shadow each other) or goes down to the substrate. At the face it is reflected
//!   with probability `R(λ)` carrying its whole weight (lossless stack, `R_s = R_p` at
//!   normal incidence, module `stack` of the volume crate), goes straight up and leaves
//!   with `1 − ρ` into the cone, `ρ = ((n₀ − 1)/(n₀ + 1))²`: the single bounce. So the
//!   single-bounce reflectance is `(1 − ρ)² c R(λ)`, each ray contributing `(1 − ρ)²` or
//!   0 (binomial with `p = c R(λ)`), with Airy's
//!   `R = |(r₀₁ + r₁₂ e^{2iδ})/(1 + r₀₁ r₁₂ e^{2iδ})|²`, `r₀₁ = (n₀ − n₁)/(n₀ + n₁) = −r₁₂`,
//!   `δ = 2π n₁ d / λ`, written here independently of the optics crate. Checked within
//!   4σ at each of 16 wavelengths from 400 to 700 nm, over which `R` runs from 0 (at
//!   520 nm, `2 n₁ d = 3λ`) to about 0.25 (near 446 and 624 nm).
//! * The energy balance at every wavelength sums to 1 within 1e-12, with a stack flake
//!   layer and a binder whose absorption is a table.
//! * Each wavelength's curves are the bits of the one-wavelength run at that wavelength
//!   (the same seed: common random numbers), and a spectrum is the same bits on one
//!   thread and on two.

use flakescatter::optics::absorption::FlakeDepth;
use flakescatter::optics::catalogue::Catalogue;
use flakescatter::optics::dispersion::{CoatIndex, SpectralTable};
use flakescatter::optics::nalgebra::Complex;
use flakescatter::optics::stack_spec::StackSpec;
use flakescatter::spectral::{BinderAbsorption, FlakeSpectrum, SpectralCoating};
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::volume::{Amount, Depth, Diameter};
use flakescatter::{
    DetectorSet, Instrument, OrientationSource, PipelineError, SpectralVolumeCurves,
    VolumeSettings, spectral_volume_curves, volume_curves,
};

fn stack_coating(spec: &str) -> SpectralCoating {
    SpectralCoating {
        coat: CoatIndex::Constant(1.5),
        flake: FlakeSpectrum::Stack {
            stack: StackSpec::parse(spec, &Catalogue::builtin()).unwrap(),
            core: None,
        },
        binder: None,
    }
}

fn airy(n0: f64, n1: f64, d_nm: f64, wl: f64) -> f64 {
    let r01 = Complex::new((n0 - n1) / (n0 + n1), 0.0);
    let r12 = -r01;
    let delta = 2.0 * std::f64::consts::PI * n1 * d_nm / wl;
    let ph = Complex::new(0.0, 2.0 * delta).exp();
    ((r01 + r12 * ph) / (Complex::new(1.0, 0.0) + r01 * r12 * ph)).norm_sqr()
}

#[test]
fn the_single_bounce_spectrum_of_flat_film_flakes_follows_airy() {
    let (tile, diameter) = (40.0, 16.0);
    let settings = VolumeSettings {
        film_um: 20.0,
        diameter: Diameter::Fixed(diameter),
        thickness_um: 0.5,
        amount: Amount::Count(1),
        depth: Depth::Uniform {
            top_um: 5.0,
            bottom_um: 6.0,
        },
        tile_um: tile,
        rays: 2 * 64 * 2500,
        layers: 2,
        seed: 9,
        min_weight: 1e-12,
        ..VolumeSettings::default()
    };
    let instrument = Instrument::new(
        vec![0.0],
        DetectorSet::InPlane(vec![0.0]),
        1f64.to_radians(),
    )
    .unwrap();
    let source = OrientationSource::Distribution(Orientation::flat());
    let wavelengths: Vec<f64> = (0..16).map(|k| 400.0 + 20.0 * f64::from(k)).collect();
    let s = spectral_volume_curves(
        &stack_coating("2.6:300"),
        None,
        &wavelengths,
        &instrument,
        &settings,
        &source,
        &|_, _| {},
    )
    .unwrap();
    let rho: f64 = (0.5f64 / 2.5).powi(2);
    let c = std::f64::consts::PI * (0.5 * diameter).powi(2) / (tile * tile);
    let nrays = s.curves[0].rays_per_incidence as f64;
    let proj = instrument.cones()[0].projected_solid_angle();
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for (w, curves) in wavelengths.iter().zip(&s.curves) {
        let r = airy(1.5, 2.6, 300.0, *w);
        let p = c * r;
        let want = (1.0 - rho).powi(2) * p;
        let sd = (1.0 - rho).powi(2) * (p * (1.0 - p) / nrays).sqrt();
        let got = curves.rows[0].single_bounce_brdf * proj;
        eprintln!("{w} nm: R {r:.5}; single {got:.6} expected {want:.6} ± {sd:.1e}");
        assert!(
            (got - want).abs() < 4.0 * sd,
            "{w} nm: {got} vs {want} ± {sd}"
        );
        (lo, hi) = (lo.min(r), hi.max(r));
        let e = &curves.energy[0].1;
        assert!((e.total() - 1.0).abs() < 1e-12);
        assert_eq!(e.absorbed_binder, 0.0);
    }
    // The wavelengths span a fringe: the test sees the shape, not a constant.
    assert!(lo < 1e-3 && hi > 0.2, "R from {lo} to {hi}");
}

fn tinted_run(threads: usize, wavelengths: &[f64]) -> (SpectralVolumeCurves, Vec<f64>) {
    let settings = VolumeSettings {
        film_um: 15.0,
        diameter: Diameter::LogNormal {
            mean_um: 8.0,
            rel_sd: 0.25,
        },
        thickness_um: 0.5,
        amount: Amount::VolumeFraction(0.04),
        tile_um: 120.0,
        rays: 3 * 64 * 40,
        layers: 3,
        seed: 21,
        ..VolumeSettings::default()
    };
    // α rising from 0.01/µm at 380 nm to 0.08/µm at 780 nm (a blue tint).
    let alpha =
        SpectralTable::new(vec![380.0, 780.0], vec![0.01, 0.08], "absorption", 0.0).unwrap();
    let theta_i = vec![0.0, 45f64.to_radians()];
    let ts: Vec<f64> = (-6..=6).map(|k| f64::from(k * 10).to_radians()).collect();
    let instrument = Instrument::new(theta_i, DetectorSet::InPlane(ts), 2f64.to_radians()).unwrap();
    let source = OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(10f64.to_radians())).unwrap(),
    );
    let coating = stack_coating("TiO2:60/SiO2:120/TiO2:60");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let s = pool
        .install(|| {
            spectral_volume_curves(
                &coating,
                Some(&alpha),
                wavelengths,
                &instrument,
                &settings,
                &source,
                &|_, _| {},
            )
        })
        .unwrap();
    // The one-wavelength runs at each wavelength, with the same seed.
    let mut same = Vec::new();
    for (w, c) in wavelengths.iter().zip(&s.curves) {
        let at = coating.at(*w).unwrap();
        let one_settings = VolumeSettings {
            binder_alpha_per_um: alpha.value_at(*w).unwrap(),
            ..settings.clone()
        };
        let one =
            volume_curves(&at.coating, &instrument, &one_settings, &source, &|_, _| {}).unwrap();
        assert_eq!(one.rows, c.rows, "{w} nm");
        assert_eq!(one.energy, c.energy, "{w} nm");
        same.push(*w);
    }
    (s, same)
}

#[test]
fn a_tinted_spectrum_conserves_energy_and_each_wavelength_is_its_own_run() {
    let wavelengths = [420.0, 530.0, 650.0];
    let (one, checked) = tinted_run(1, &wavelengths);
    assert_eq!(checked, wavelengths);
    let (two, _) = tinted_run(2, &wavelengths);
    let mut previous = 0.0;
    for (k, (a, b)) in one.curves.iter().zip(&two.curves).enumerate() {
        assert_eq!(a.rows, b.rows, "threads change {} nm", wavelengths[k]);
        assert_eq!(a.energy, b.energy);
        let alpha = a.settings.binder_alpha_per_um;
        let want = 0.01 + 0.07 * (wavelengths[k] - 380.0) / 400.0;
        assert!((alpha - want).abs() < 1e-15, "α {alpha} vs {want}");
        for (_, e) in &a.energy {
            assert!((e.total() - 1.0).abs() < 1e-12, "{e:?}");
            assert!(e.absorbed_binder > 0.0);
        }
        // More absorption at longer wavelengths: the binder's share grows.
        let binder = a.energy[0].1.absorbed_binder;
        assert!(binder > previous, "{binder} after {previous}");
        previous = binder;
    }
}

#[test]
fn bad_spectral_inputs_are_refused() {
    let settings = VolumeSettings {
        tile_um: 200.0,
        rays: 640,
        layers: 1,
        ..VolumeSettings::default()
    };
    let instrument = Instrument::new(vec![0.0], DetectorSet::InPlane(vec![0.0]), 0.02).unwrap();
    let source = OrientationSource::Distribution(Orientation::flat());
    let alpha =
        SpectralTable::new(vec![400.0, 700.0], vec![0.01, 0.02], "absorption", 0.0).unwrap();
    let run = |waves: &[f64], table: Option<&SpectralTable>| {
        spectral_volume_curves(
            &stack_coating("2.0:300"),
            table,
            waves,
            &instrument,
            &settings,
            &source,
            &|_, _| {},
        )
    };
    for (waves, table, needle) in [
        (vec![], None, "no wavelength"),
        (vec![500.0, 450.0], None, "does not follow"),
        (vec![-5.0], None, "not valid"),
        (
            vec![380.0, 500.0],
            Some(&alpha),
            "binder absorption at 380 nm",
        ),
    ] {
        match run(&waves, table) {
            Err(PipelineError::Spectral(m)) => assert!(m.contains(needle), "{m}"),
            other => panic!("{waves:?}: {other:?}"),
        }
    }
    // A depth-rule absorption (the distribution model's) has no meaning here.
    let mut coating = stack_coating("2.0:300");
    coating.binder = Some(BinderAbsorption {
        alpha_per_um: alpha.clone(),
        depth: FlakeDepth::At { depth_um: 2.0 },
    });
    let r = spectral_volume_curves(
        &coating,
        None,
        &[500.0],
        &instrument,
        &settings,
        &source,
        &|_, _| {},
    );
    match r {
        Err(PipelineError::Spectral(m)) => assert!(m.contains("follows each path"), "{m}"),
        other => panic!("{other:?}"),
    }
}
