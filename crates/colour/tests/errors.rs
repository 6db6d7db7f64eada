//! Bad spectra and colours get a typed error that names the sample and what was
//! expected; nothing panics and nothing returns a number.

use flakescatter_colour::{ColourError, Illuminant, Observer, TristimulusWeights, spectrum_to_lab};

fn ten_nm() -> Vec<f64> {
    (0..=30).map(|i| 400.0 + 10.0 * f64::from(i)).collect()
}

fn weights(wl: &[f64]) -> Result<TristimulusWeights, ColourError> {
    TristimulusWeights::new(wl, Illuminant::D65, Observer::Cie1964TenDegree)
}

#[test]
fn bad_wavelengths_are_refused_with_the_offending_sample() {
    let mut wl = ten_nm();
    wl[3] = f64::NAN;
    let e = weights(&wl).unwrap_err();
    assert!(
        matches!(e, ColourError::NonFiniteWavelength { index: 3, .. }),
        "{e}"
    );

    let mut wl = ten_nm();
    wl[5] = wl[4];
    let e = weights(&wl).unwrap_err();
    assert!(
        matches!(e, ColourError::NotIncreasing { index: 5, .. }),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("#5 (440 nm) does not follow #4 (440 nm)"),
        "{e}"
    );

    let mut wl = ten_nm();
    wl.swap(7, 8);
    assert!(matches!(
        weights(&wl).unwrap_err(),
        ColourError::NotIncreasing { index: 8, .. }
    ));

    let mut wl = ten_nm();
    wl.insert(0, 350.0);
    let e = weights(&wl).unwrap_err();
    assert!(
        matches!(e, ColourError::WavelengthOutOfRange { index: 0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("360 to 830 nm"), "{e}");

    let e = weights(&[550.0]).unwrap_err();
    assert_eq!(e, ColourError::TooFewSamples { got: 1, min: 2 });

    let short: Vec<f64> = (0..=20).map(|i| 450.0 + 10.0 * f64::from(i)).collect();
    let e = weights(&short).unwrap_err();
    assert!(matches!(e, ColourError::InsufficientCoverage { .. }), "{e}");
    assert!(e.to_string().contains("450 to 650 nm"), "{e}");

    let mut wl = ten_nm();
    wl.remove(10); // 490 → 510 is 20 nm: still accepted
    assert!(weights(&wl).is_ok());
    wl.remove(10); // 490 → 520 is 30 nm
    let e = weights(&wl).unwrap_err();
    assert!(matches!(e, ColourError::GapTooLarge { .. }), "{e}");
    assert!(
        e.to_string().contains("490 nm and 520 nm are 30 nm apart"),
        "{e}"
    );
}

#[test]
fn bad_reflectance_factors_are_refused_at_their_wavelength() {
    let wl = ten_nm();
    let w = weights(&wl).unwrap();
    let e = w.xyz(&[0.5; 10]).unwrap_err();
    assert_eq!(
        e,
        ColourError::LengthMismatch {
            wavelengths: 31,
            values: 10
        }
    );

    let mut r = vec![0.5; 31];
    r[12] = f64::INFINITY;
    let e = w.lab(&r).unwrap_err();
    assert!(e.to_string().contains("520 nm"), "{e}");

    let mut r = vec![0.5; 31];
    r[2] = -0.01;
    let e = w.xyz(&r).unwrap_err();
    assert!(matches!(e, ColourError::NegativeReflectance { .. }), "{e}");
    assert!(e.to_string().contains("420 nm is -0.01"), "{e}");

    // Above 1 is fine (metallic coatings near specular).
    let bright = spectrum_to_lab(
        &wl,
        &vec![2.5; 31],
        Illuminant::D65,
        Observer::Cie1964TenDegree,
    )
    .unwrap();
    assert!(bright.l > 100.0);
}
