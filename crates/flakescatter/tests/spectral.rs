//! The spectral models (physics.md §8.1) against an independent calculation, the
//! monochromatic runs they must reduce to, and the neutral limit.
//!
//! `data/spectral/` holds spectra and CIELAB computed outside the project (numpy's own
//! in-plane point BRDF with its own Fresnel and Gaussian normalisation, colour-science
//! 0.4.7 for the colorimetry); its README says how.

use std::collections::HashMap;

use flakescatter::colour::{
    GeometrySet, Illuminant, Lab, Observer, TristimulusWeights, delta_e_ab,
};
use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::optics::absorption::FlakeDepth;
use flakescatter::optics::dispersion::{Cauchy, CoatIndex, SpectralTable};
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::material::ComplexIndexTable;
use flakescatter::spectral::{
    BinderAbsorption, FlakeSpectrum, MultiAngleSource, SpectralCoating, multi_angle_colour,
    spectral_distribution_curves, spectral_topographic_curves,
};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, Settings, TopoSettings,
    distribution_curves, topographic_curves,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/spectral");
const E2194: [f64; 6] = [-15.0, 15.0, 25.0, 45.0, 75.0, 110.0];

fn gaussian(hwhm_deg: f64) -> OrientationSource {
    OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap(),
    )
}

/// `k` evenly spaced wavelengths from `a` to `b` nm.
fn grid(a: f64, b: f64, step: f64) -> Vec<f64> {
    let n = ((b - a) / step).round() as usize;
    (0..=n).map(|i| a + step * i as f64).collect()
}

/// The E2194 detectors at 45° incidence as an instrument of half-angle `aperture_deg`.
fn e2194_instrument(aperture_deg: f64) -> Instrument {
    let ts = E2194.iter().map(|a| (a - 45.0f64).to_radians()).collect();
    Instrument::new(
        vec![45f64.to_radians()],
        DetectorSet::InPlane(ts),
        aperture_deg.to_radians(),
    )
    .unwrap()
}

fn binder_table() -> SpectralTable {
    let text = std::fs::read_to_string(format!("{DATA}/binder_alpha.csv")).unwrap();
    let (mut w, mut a) = (Vec::new(), Vec::new());
    for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let v: Vec<f64> = line.split(',').map(|s| s.parse().unwrap()).collect();
        w.push(v[0]);
        a.push(v[1]);
    }
    SpectralTable::new(w, a, "absorption coefficient", 0.0).unwrap()
}

/// The three configurations of `data/spectral/README.md`.
fn config(name: &str) -> (SpectralCoating, Vec<f64>, Illuminant, Observer) {
    match name {
        "rakic_n1.5_hwhm6" => (
            SpectralCoating {
                coat: CoatIndex::Constant(1.5),
                flake: FlakeSpectrum::Table(ComplexIndexTable::aluminium_rakic_1995().clone()),
                binder: None,
            },
            grid(380.0, 780.0, 10.0),
            Illuminant::D65,
            Observer::Cie1964TenDegree,
        ),
        "mcpeak_cauchy_depth5" => (
            SpectralCoating {
                coat: CoatIndex::Cauchy(Cauchy::new(1.49, 0.0045, 0.0).unwrap()),
                flake: FlakeSpectrum::Table(ComplexIndexTable::aluminium_mcpeak_2015().clone()),
                binder: Some(BinderAbsorption {
                    alpha_per_um: binder_table(),
                    depth: FlakeDepth::At { depth_um: 5.0 },
                }),
            },
            grid(400.0, 700.0, 5.0),
            Illuminant::D50,
            Observer::Cie1931TwoDegree,
        ),
        "rakic_cauchy_film20" => (
            SpectralCoating {
                coat: CoatIndex::Cauchy(Cauchy::new(1.49, 0.0045, 0.0001).unwrap()),
                flake: FlakeSpectrum::Table(ComplexIndexTable::aluminium_rakic_1995().clone()),
                binder: Some(BinderAbsorption {
                    alpha_per_um: binder_table(),
                    depth: FlakeDepth::UniformInFilm { film_um: 20.0 },
                }),
            },
            grid(380.0, 780.0, 10.0),
            Illuminant::D65,
            Observer::Cie1964TenDegree,
        ),
        other => panic!("unknown configuration {other}"),
    }
}

/// Wavelengths (nm) and reflectance factors.
type Spectrum = (Vec<f64>, Vec<f64>);

/// `config → aspecular → spectrum` of the reference spectra.
fn reference_spectra() -> HashMap<String, HashMap<i64, Spectrum>> {
    let text = std::fs::read_to_string(format!("{DATA}/reference_spectra.csv")).unwrap();
    let mut out: HashMap<String, HashMap<i64, Spectrum>> = HashMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let e = out
            .entry(f[0].to_string())
            .or_default()
            .entry(f[1].parse().unwrap())
            .or_default();
        e.0.push(f[2].parse().unwrap());
        e.1.push(f[3].parse().unwrap());
    }
    out
}

/// `(config, aspecular, Lab)` of the reference CIELAB.
fn reference_lab() -> Vec<(String, i64, Lab)> {
    let text = std::fs::read_to_string(format!("{DATA}/reference_lab.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (
                f[0].to_string(),
                f[1].parse().unwrap(),
                Lab {
                    l: v(7),
                    a: v(8),
                    b: v(9),
                },
            )
        })
        .collect()
}

#[test]
fn spectra_and_colour_match_the_independent_calculation() {
    let spectra = reference_spectra();
    let labs = reference_lab();
    let mut worst_r: f64 = 0.0;
    let mut worst_de: f64 = 0.0;
    for name in [
        "rakic_n1.5_hwhm6",
        "mcpeak_cauchy_depth5",
        "rakic_cauchy_film20",
    ] {
        let (coating, wl, ill, obs) = config(name);
        // Point detectors: π × the point BRDF, what the reference computes.
        let s = spectral_distribution_curves(
            &coating,
            &wl,
            &e2194_instrument(0.0),
            &Settings::default(),
            &gaussian(6.0),
        )
        .unwrap();
        let weights = TristimulusWeights::new(&wl, ill, obs).unwrap();
        for (j, asp) in E2194.iter().enumerate() {
            let r: Vec<f64> = s
                .curves
                .iter()
                .map(|c| std::f64::consts::PI * c.rows[j].brdf)
                .collect();
            let (ref_wl, ref_r) = &spectra[name][&(*asp as i64)];
            assert_eq!(ref_wl, &wl);
            for (a, b) in r.iter().zip(ref_r) {
                let rel = (a - b).abs() / b.abs();
                worst_r = worst_r.max(rel);
                assert!(rel < 1e-12, "{name} {asp}°: {a} vs {b}");
            }
            let lab = weights.lab(&r).unwrap();
            let (_, _, want) = labs
                .iter()
                .find(|(c, a, _)| c == name && *a == *asp as i64)
                .unwrap();
            let de = delta_e_ab(want, &lab);
            worst_de = worst_de.max(de);
            // The colorimetry itself agrees with colour-science to ~0.001 (crate colour).
            assert!(de < 0.002, "{name} {asp}°: {lab:?} vs {want:?}, ΔE*ab {de}");
        }
    }
    println!("worst relative spectrum difference {worst_r:e}, worst ΔE*ab {worst_de:.2e}");
}

#[test]
fn aluminium_gives_a_small_bluish_green_tint() {
    // Rakić aluminium under n = 1.5, hwhm 6°, D65/10°: the reference says a* ≈ −0.57 and
    // b* ≈ −1.36 at 15° aspecular (C* ≈ 1.5, hue ≈ 247°), shrinking with lightness.
    let (coating, wl, ill, obs) = config("rakic_n1.5_hwhm6");
    let m = multi_angle_colour(
        &coating,
        &Settings::default(),
        MultiAngleSource::Distribution(&gaussian(6.0)),
        &GeometrySet::astm_e2194(),
        0.1f64.to_radians(),
        &wl,
        ill,
        obs,
        &|_, _| {},
    )
    .unwrap();
    let labs = reference_lab();
    for (g, asp) in m.geometries.iter().zip(E2194) {
        let (_, _, point) = labs
            .iter()
            .find(|(c, a, _)| c == "rakic_n1.5_hwhm6" && *a == asp as i64)
            .unwrap();
        // A 0.1° cone averages the point value over a patch much narrower than the
        // flake light (tens of degrees wide): second-order, far below 0.02.
        let de = delta_e_ab(point, &g.lab);
        assert!(de < 0.02, "{asp}°: cone {:?} vs point {point:?}", g.lab);
        if g.lab.l > 40.0 {
            assert!(g.lab.a < -0.1 && g.lab.b < -0.3, "{asp}°: {:?}", g.lab);
        }
    }
    assert!(m.dispersive && m.flop_index.is_some());
}

#[test]
fn one_wavelength_is_the_monochromatic_run_to_the_bit() {
    // McPeak's row at 550 nm (the data file's own numbers) and the Cauchy index there by
    // hand: 1.49 + 0.0045/0.55² = 1.504876033057851.
    let (n_flake, k_flake) = (0.789, 5.852);
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../optics/data/aluminium_mcpeak2015.csv"
    ))
    .unwrap();
    let row = text.lines().find(|l| l.starts_with("550,")).unwrap();
    let v: Vec<f64> = row.split(',').map(|s| s.trim().parse().unwrap()).collect();
    assert!((v[1] - n_flake).abs() < 5e-4 && (v[2] - k_flake).abs() < 5e-4);
    let n_coat = 1.49 + 0.0045 / (0.55f64 * 0.55);
    let spectral = SpectralCoating {
        coat: CoatIndex::Cauchy(Cauchy::new(1.49, 0.0045, 0.0).unwrap()),
        flake: FlakeSpectrum::Table(ComplexIndexTable::aluminium_mcpeak_2015().clone()),
        binder: None,
    };
    // The spectral path's constants at 550 nm are the hand values …
    let at = spectral.at(550.0).unwrap();
    assert!((at.coating.n - n_coat).abs() <= 1e-15 * n_coat && at.absorption.is_none());
    assert_eq!(
        at.coating.flake,
        FlakeReflectance::complex(v[1], v[2]).unwrap()
    );
    // … and with them the monochromatic run gives the same numbers to the bit.
    let mono = at.coating;
    let settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let instrument = Instrument::default_in_plane();
    let s =
        spectral_distribution_curves(&spectral, &[550.0], &instrument, &settings, &gaussian(6.0))
            .unwrap();
    let m = distribution_curves(&mono, &instrument, &settings, &gaussian(6.0)).unwrap();
    assert_eq!(s.curves[0].rows, m.rows);

    // The topographic model on a shipped synthetic map, the same way.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
    let opts = ReadOptions::default();
    let (mut map, _) = read_map(format!("{dir}/synth-hwhm6-rough.height.x3p"), &opts).unwrap();
    let (intensity, _) =
        read_intensity(format!("{dir}/synth-hwhm6-rough.intensity.x3p"), &opts).unwrap();
    map.apply_intensity_cutoff(&intensity, 0.49).unwrap();
    let maps: Vec<&HeightMap> = vec![&map];
    let inst = Instrument::new(
        vec![45f64.to_radians()],
        DetectorSet::InPlane((-70..=70).map(|d| f64::from(d).to_radians()).collect()),
        1.5f64.to_radians(),
    )
    .unwrap();
    let topo = TopoSettings::default();
    let s = spectral_topographic_curves(
        &spectral,
        &[550.0],
        &inst,
        &settings,
        &topo,
        &maps,
        &|_, _| {},
    )
    .unwrap();
    let (m, _) = topographic_curves(&mono, &inst, &settings, &topo, &maps, &|_, _| {}).unwrap();
    assert_eq!(s.curves[0].rows, m.rows);
}

#[test]
fn perfect_conductor_under_a_clear_coat_is_neutral_at_every_geometry() {
    let wl = grid(380.0, 780.0, 10.0);
    // Once as the wavelength-independent coating (computed once), once with a binder
    // that absorbs nothing, which sends every wavelength through its own run.
    let zero = SpectralTable::new(vec![300.0, 900.0], vec![0.0, 0.0], "alpha", 0.0).unwrap();
    let coatings = [
        SpectralCoating::from_coating(&Coating::default()),
        SpectralCoating {
            binder: Some(BinderAbsorption {
                alpha_per_um: zero,
                depth: FlakeDepth::UniformInFilm { film_um: 20.0 },
            }),
            ..SpectralCoating::from_coating(&Coating::default())
        },
    ];
    let sets = [
        GeometrySet::astm_e2194(),
        GeometrySet::custom(
            30f64.to_radians(),
            &[-10.0, 15.0, 45.0, 80.0].map(f64::to_radians),
        )
        .unwrap(),
    ];
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
    let (map, _) = read_map(
        format!("{dir}/synth-hwhm6-rough.height.x3p"),
        &ReadOptions::default(),
    )
    .unwrap();
    let maps: Vec<&HeightMap> = vec![&map];
    let topo = TopoSettings::default();
    for coating in &coatings {
        for set in &sets {
            for source in [
                MultiAngleSource::Distribution(&gaussian(6.0)),
                MultiAngleSource::Topographic {
                    topo: &topo,
                    maps: &maps,
                },
            ] {
                let m = multi_angle_colour(
                    coating,
                    &Settings::default(),
                    source,
                    set,
                    1.5f64.to_radians(),
                    &wl,
                    Illuminant::D65,
                    Observer::Cie1964TenDegree,
                    &|_, _| {},
                )
                .unwrap();
                for g in &m.geometries {
                    assert!(
                        g.lab.a.abs() < 1e-6 && g.lab.b.abs() < 1e-6,
                        "{} {}: {:?}",
                        m.model,
                        set.name(),
                        g.lab
                    );
                }
            }
        }
    }
}
