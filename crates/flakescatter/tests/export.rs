//! The spectral export's colour (`flakescatter::export::SpectralSource`): its linear-sRGB
//! weights against colour-science's (tests/data/export, made independently; README
//! there), and a table of flakes whose reflectance does not depend on wavelength coming
//! out grey, equal to the monochromatic model's BRDF (the D65 white is sRGB's white).

use std::f64::consts::FRAC_PI_2;

use flakescatter::export::{BrdfSource, SpectralSource, bin_value};
use flakescatter::io::merl::Bin;
use flakescatter::optics::dispersion::CoatIndex;
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::material::ComplexIndexTable;
use flakescatter::pipeline::distribution_model;
use flakescatter::spectral::{FlakeSpectrum, SpectralCoating};
use flakescatter::stats::GaussianWidth;
use flakescatter::stats::Orientation;
use flakescatter::{Coating, Settings};

fn wavelengths() -> Vec<f64> {
    (0..41).map(|i| 380.0 + 10.0 * f64::from(i)).collect()
}

fn colour_science_weights() -> Vec<[f64; 3]> {
    let text = include_str!("data/export/srgb_weights_380_780_10.csv");
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("wavelength"))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[1], v[2], v[3]]
        })
        .collect()
}

fn orientation() -> Orientation {
    Orientation::gaussian(GaussianWidth::Hwhm(7f64.to_radians())).unwrap()
}

fn coating(flake: FlakeSpectrum) -> SpectralCoating {
    SpectralCoating {
        coat: CoatIndex::Constant(1.5),
        flake,
        binder: None,
    }
}

#[test]
fn srgb_weights_match_colour_science() {
    let s = SpectralSource::new(
        &coating(FlakeSpectrum::Table(
            ComplexIndexTable::aluminium_rakic_1995().clone(),
        )),
        &orientation(),
        &Settings::default(),
        &wavelengths(),
    )
    .unwrap();
    let theirs = colour_science_weights();
    assert_eq!(theirs.len(), s.weights().len());
    let mut worst: f64 = 0.0;
    for (w, t) in s.weights().iter().zip(&theirs) {
        for c in 0..3 {
            worst = worst.max((w[c] - t[c]).abs());
        }
    }
    // The weights are up to ~0.06; the matrices differ in the fifth digit.
    assert!(worst < 2e-4, "largest weight difference {worst}");
    // Smooth spectra: their colours agree to 1e-3 of the white.
    for f in [
        |l: f64| 0.2 + 0.6 * ((l - 380.0) / 400.0),
        |l: f64| (-((l - 520.0) / 40.0).powi(2)).exp(),
        |l: f64| 1.0 - 0.5 * (-((l - 450.0) / 60.0).powi(2)).exp(),
    ] {
        let spectrum: Vec<f64> = wavelengths().into_iter().map(f).collect();
        let ours = spectrum
            .iter()
            .zip(s.weights())
            .fold([0.0; 3], |a, (v, w)| [0, 1, 2].map(|c| a[c] + v * w[c]));
        let want = spectrum
            .iter()
            .zip(&theirs)
            .fold([0.0; 3], |a, (v, w)| [0, 1, 2].map(|c| a[c] + v * w[c]));
        for c in 0..3 {
            assert!((ours[c] - want[c]).abs() < 1e-3, "{ours:?} vs {want:?}");
        }
    }
}

#[test]
fn flakes_of_one_reflectance_at_every_wavelength_export_grey() {
    let flake = FlakeReflectance::complex(1.2, 7.0).unwrap();
    let s = SpectralSource::new(
        &coating(FlakeSpectrum::Fixed(flake.clone())),
        &orientation(),
        &Settings::default(),
        &wavelengths(),
    )
    .unwrap();
    let grey = distribution_model(
        &Coating { n: 1.5, flake },
        &Settings::default(),
        orientation(),
    )
    .unwrap();
    let mut checked = 0;
    for i in (0..90 * 90 * 180).step_by(997) {
        let bin = Bin::from_index(i).unwrap();
        let Some(rgb) = bin_value(&BrdfSource::Spectral(&s), bin).unwrap() else {
            continue;
        };
        let g = bin_value(&BrdfSource::Distribution(&grey), bin)
            .unwrap()
            .unwrap()[0];
        // M · (Xn, Yn, Zn) of D65 is (1, 1, 1) to the matrix's four decimals.
        for c in 0..3 {
            assert!(
                (rgb[c] - g).abs() <= 3e-4 * g,
                "bin {bin:?}: {rgb:?} vs {g}"
            );
        }
        checked += 1;
    }
    assert!(checked > 800, "{checked}");
    // Not every bin is near zero: the comparison saw the peak.
    let peak = Bin::new(0, 20, 0).unwrap();
    let centre = peak.centre();
    assert!(centre.theta_d < FRAC_PI_2);
    let g = bin_value(&BrdfSource::Distribution(&grey), peak)
        .unwrap()
        .unwrap()[0];
    assert!(g > 1.0, "{g}");
}
