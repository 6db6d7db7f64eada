//! Multi-angle readouts as portable multi-angle spectrophotometers report them
//! (ASTM E2194 style geometry): incidence 45°, detectors at aspecular angles −15°, 15°,
//! 25°, 45°, 75° and 110° (measured from the specular direction, positive toward the
//! normal, so `θs = −45° + aspecular`), values as reflectance factors `R = π × BRDF`
//! averaged over the detector cone, and an optional flop index.
//!
//! **Flop index** (the X-Rite/DuPont formula):
//! `FI = 2.69 (L*15 − L*110)^1.11 / (L*45)^0.86`, with `L* = 116 f(Y) − 16`,
//! `f(Y) = Y^(1/3)` above `(6/29)³` and `Y/(3 (6/29)²) + 4/29` below (CIE 1976 lightness,
//! white `Yn = 1`). **Single-wavelength approximation**: the model is monochromatic
//! (550 nm by default for the complex aluminium index), so the reflectance factor at that
//! wavelength stands in for the luminance factor `Y`, which is a weighted integral over
//! the visible spectrum. For neutral (grey) aluminium coatings the spectrum is nearly flat
//! and the approximation is fair; for coloured coatings it is not a colorimetric value.
//! The spectral readout with real colorimetry (what `flakescatter model --multi-angle`
//! computes) is [`crate::spectral::multi_angle_colour`].

use crate::PipelineError;
use crate::instrument::{DetectorSet, Instrument};
use crate::pipeline::{Coating, OrientationSource, Settings, distribution_curves};

/// Incidence angle of the multi-angle geometry, radians (45°).
pub const INCIDENCE: f64 = std::f64::consts::FRAC_PI_4;

/// Aspecular angles of the readout, degrees (the flop index uses 15°, 45° and 110°).
pub const ASPECULAR_DEG: [f64; 6] = crate::colour::geometry::ASTM_E2194_ASPECULAR_DEG;

/// One readout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readout {
    /// Aspecular angle, radians.
    pub aspecular: f64,
    /// The in-plane detector angle, radians (`θs = −45° + aspecular`).
    pub theta_s: f64,
    /// Reflectance factor `π × BRDF` (cone average), dimensionless.
    pub reflectance_factor: f64,
    /// CIE lightness `L*` of the reflectance factor (single-wavelength approximation).
    pub lightness: f64,
}

/// The readouts and the flop index.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiAngle {
    /// Incidence, radians (45° for the standard geometry).
    pub theta_i: f64,
    /// Detector half-angle used, radians.
    pub aperture: f64,
    /// The six readouts in [`ASPECULAR_DEG`] order.
    pub readouts: Vec<Readout>,
    /// Flop index, or `None` when `L*15 ≤ L*110` (the formula needs a positive
    /// difference).
    pub flop_index: Option<f64>,
}

/// CIE 1976 lightness of a luminance factor `y` (white = 1); the colorimetry crate's
/// [`crate::colour::lightness`].
#[must_use]
pub fn lightness(y: f64) -> f64 {
    crate::colour::lightness(y)
}

/// Flop index from `L*` at 15°, 45° and 110° aspecular, `None` when `L15 ≤ L110` or
/// `L45 ≤ 0`; the colorimetry crate's [`crate::colour::flop_index`].
#[must_use]
pub fn flop_index(l15: f64, l45: f64, l110: f64) -> Option<f64> {
    crate::colour::flop_index(l15, l45, l110)
}

/// The distribution model's multi-angle readout for `source` at the standard 45°
/// incidence with detectors of half-angle `aperture` (radians, > 0).
///
/// # Errors
/// As [`multi_angle_at`].
pub fn multi_angle(
    coating: &Coating,
    settings: &Settings,
    source: &OrientationSource,
    aperture: f64,
) -> Result<MultiAngle, PipelineError> {
    multi_angle_at(coating, settings, source, INCIDENCE, aperture)
}

/// The readout at incidence `theta_i` (radians) instead of 45°: the same aspecular
/// angles, `θs = −θi + aspecular`, all of which must stay above the horizon (for these
/// angles `20° < θi < 75°`). The flop index is the same formula on the same aspecular
/// angles; it is standardised for 45° only.
///
/// # Errors
/// As [`distribution_curves`]; [`PipelineError::Instrument`] for a zero aperture (a
/// reflectance factor needs a cone) or a detector beyond the horizon.
pub fn multi_angle_at(
    coating: &Coating,
    settings: &Settings,
    source: &OrientationSource,
    theta_i: f64,
    aperture: f64,
) -> Result<MultiAngle, PipelineError> {
    if aperture <= 0.0 {
        return Err(PipelineError::Instrument(
            "multi-angle readouts need detectors with an aperture > 0".into(),
        ));
    }
    let asp: Vec<f64> = ASPECULAR_DEG.iter().map(|a| a.to_radians()).collect();
    let ts: Vec<f64> = asp.iter().map(|a| a - theta_i).collect();
    if let Some(k) = ts
        .iter()
        .position(|t| t.abs() >= std::f64::consts::FRAC_PI_2)
    {
        return Err(PipelineError::Instrument(format!(
            "at θi = {:.6}° the aspecular angle {}° is θs = {:.6}°, beyond the horizon: multi-angle readouts need 20° < θi < 75°",
            theta_i.to_degrees(),
            ASPECULAR_DEG[k],
            ts[k].to_degrees()
        )));
    }
    let instrument = Instrument::new(vec![theta_i], DetectorSet::InPlane(ts.clone()), aperture)?;
    let curves = distribution_curves(coating, &instrument, settings, source)?;
    let readouts: Vec<Readout> = curves
        .rows
        .iter()
        .map(|r| {
            let rf = std::f64::consts::PI * r.brdf;
            Readout {
                aspecular: asp[r.detector],
                theta_s: ts[r.detector],
                reflectance_factor: rf,
                lightness: lightness(rf),
            }
        })
        .collect();
    let l = |k: usize| readouts[k].lightness;
    Ok(MultiAngle {
        theta_i,
        aperture,
        flop_index: flop_index(l(1), l(3), l(5)),
        readouts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lightness_closed_forms() {
        // L*(1) = 100; L*(0.18) = 49.5 (mid grey); the linear branch at Y = 0.001:
        // 116 (0.001/(3 (6/29)²) + 4/29) − 16 = 0.9033.
        assert!((lightness(1.0) - 100.0).abs() < 1e-12);
        assert!((lightness(0.18) - 49.496).abs() < 1e-3);
        assert!((lightness(0.001) - 0.9033).abs() < 1e-4);
        // Continuity at the branch point (6/29)³.
        let e = (6.0f64 / 29.0).powi(3);
        assert!((lightness(e * (1.0 + 1e-12)) - lightness(e * (1.0 - 1e-12))).abs() < 1e-9);
    }

    #[test]
    fn flop_index_closed_form() {
        // L15 = 110, L45 = 40, L110 = 20: 2.69 × 90^1.11 / 40^0.86 = 19.71 (by hand).
        let fi = flop_index(110.0, 40.0, 20.0).unwrap();
        let by_hand = 2.69 * (90f64.ln() * 1.11).exp() / (40f64.ln() * 0.86).exp();
        assert!((fi - by_hand).abs() < 1e-12);
        assert!(flop_index(20.0, 40.0, 30.0).is_none());
    }

    #[test]
    fn readouts_are_at_the_documented_geometry() {
        let o = flakescatter_stats::Orientation::gaussian(flakescatter_stats::GaussianWidth::Hwhm(
            6f64.to_radians(),
        ))
        .unwrap();
        let m = multi_angle(
            &Coating::default(),
            &Settings::default(),
            &OrientationSource::Distribution(o),
            1.5f64.to_radians(),
        )
        .unwrap();
        let ts: Vec<f64> = m
            .readouts
            .iter()
            .map(|r| r.theta_s.to_degrees().round())
            .collect();
        assert_eq!(ts, vec![-60.0, -30.0, -20.0, 0.0, 30.0, 65.0]);
        // Metallic flop: lightness falls away from specular (15° > 45° > 110°).
        assert!(
            m.readouts[1].lightness > m.readouts[3].lightness
                && m.readouts[3].lightness > m.readouts[5].lightness
        );
        assert!(m.flop_index.unwrap() > 0.0);
        assert!(
            multi_angle(
                &Coating::default(),
                &Settings::default(),
                &OrientationSource::Distribution(flakescatter_stats::Orientation::flat()),
                0.0
            )
            .is_err()
        );
    }
}
