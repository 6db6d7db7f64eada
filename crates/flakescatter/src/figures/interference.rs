//! Beyond the paper (issue 47): colour travel of TiO2-on-mica interference pigments at
//! the multi-angle geometries, for three TiO2 thicknesses whose first-order colours are
//! the trade's silver, gold and blue pearls (physics.md §13).

use std::fmt::Write as _;

use flakescatter_colour::{GeometrySet, Illuminant, Observer};
use flakescatter_optics::catalogue::Catalogue;
use flakescatter_optics::dispersion::CoatIndex;
use flakescatter_optics::stack_spec::StackSpec;

use super::{APERTURE_DEG, FiguresError, Index, gaussian};
use crate::chart::{Chart, Series, Style};
use crate::pipeline::{OrientationSource, Settings};
use crate::spectral::{
    FlakeSpectrum, MultiAngleColour, MultiAngleSource, SpectralCoating, multi_angle_colour,
};

/// The pigments: name and TiO2 (rutile) thickness, nm.
const PIGMENTS: [(&str, f64); 3] = [("silver", 45.0), ("gold", 78.0), ("blue", 125.0)];
/// Orientation of the flakes: Gaussian hwhm, degrees.
const HWHM_DEG: f64 = 8.0;
/// Clear-coat (binder) index.
const BINDER: f64 = 1.5;

fn figure_error(message: String) -> FiguresError {
    FiguresError::Figure {
        figure: "interference",
        message,
    }
}

/// The multi-angle colour of one pigment: a TiO2 layer of `tio2_nm` on mica.
fn pigment(tio2_nm: f64, wavelengths: &[f64]) -> Result<MultiAngleColour, FiguresError> {
    let catalogue = Catalogue::builtin();
    let stack = StackSpec::parse(&format!("TiO2:{tio2_nm}"), &catalogue)
        .map_err(|e| figure_error(e.to_string()))?;
    let core = catalogue
        .parse("mica")
        .map_err(|e| figure_error(e.to_string()))?;
    let coating = SpectralCoating {
        coat: CoatIndex::Constant(BINDER),
        flake: FlakeSpectrum::Stack {
            stack,
            core: Some(core),
        },
        binder: None,
    };
    let source = OrientationSource::Distribution(gaussian(HWHM_DEG)?);
    Ok(multi_angle_colour(
        &coating,
        &Settings::default(),
        MultiAngleSource::Distribution(&source),
        &GeometrySet::astm_e2194(),
        APERTURE_DEG.to_radians(),
        wavelengths,
        Illuminant::D65,
        Observer::Cie1964TenDegree,
        &|_, _| {},
    )?)
}

/// The figure: `interference.csv` (CIELAB per pigment and geometry),
/// `interference_spectra.csv`, the spectra at 15° aspecular and the a*b* travel charts.
pub(super) fn interference(
    report: &mut super::Report,
    index: &mut Index,
) -> Result<(), FiguresError> {
    let wavelengths: Vec<f64> = (0..=40).map(|k| 380.0 + 10.0 * f64::from(k)).collect();
    let mut lab_csv = String::from(
        "pigment,tio2_nm,theta_i_deg,aspecular_deg,reflectance_factor_y,L,a,b,C,h_deg\n",
    );
    let mut spectra_csv =
        String::from("pigment,tio2_nm,aspecular_deg,wavelength_nm,reflectance_factor\n");
    let (mut spectra, mut travel) = (Vec::new(), Vec::new());
    let mut summary = String::new();
    for (c, &(name, d)) in PIGMENTS.iter().enumerate() {
        let colour = pigment(d, &wavelengths)?;
        let mut ab = Vec::new();
        for g in &colour.geometries {
            let (ti, asp) = (
                g.geometry.theta_i().to_degrees(),
                g.geometry.aspecular().to_degrees(),
            );
            let (ti, asp) = (ti.round(), asp.round());
            let lab = g.lab;
            let _ = writeln!(
                lab_csv,
                "{name},{d},{ti},{asp},{:.6e},{:.4},{:.4},{:.4},{:.4},{:.2}",
                g.luminance_factor,
                lab.l,
                lab.a,
                lab.b,
                lab.chroma(),
                lab.b.atan2(lab.a).to_degrees().rem_euclid(360.0)
            );
            for (w, r) in wavelengths.iter().zip(&g.reflectance) {
                let _ = writeln!(spectra_csv, "{name},{d},{asp},{w},{r:.6e}");
            }
            if asp == 15.0 {
                spectra.push(Series {
                    label: format!("{name} (TiO2 {d} nm), 15° aspecular"),
                    points: wavelengths
                        .iter()
                        .copied()
                        .zip(g.reflectance.iter().copied())
                        .collect(),
                    style: Style::Line,
                    colour: c,
                });
                let _ = write!(
                    summary,
                    "{}{name} L* {:.0}, C* {:.0}, h {:.0}°",
                    if c > 0 { "; " } else { "" },
                    lab.l,
                    lab.chroma(),
                    lab.b.atan2(lab.a).to_degrees().rem_euclid(360.0)
                );
            }
            ab.push((lab.a, lab.b));
        }
        travel.push(Series {
            label: format!("{name} (TiO2 {d} nm): −15° → 110° aspecular"),
            points: ab,
            style: Style::Line,
            colour: c,
        });
    }
    report.text("interference.csv", lab_csv);
    report.text("interference_spectra.csv", spectra_csv);
    let note = format!(
        "TiO2 (rutile) on mica in a binder of {BINDER}, Gaussian hwhm {HWHM_DEG}°, 45° incidence, α = {APERTURE_DEG}°, D65 / 10°"
    );
    report.chart(
        "interference_spectra",
        Chart {
            title: format!("Interference pigments: reflectance factor at 15° aspecular\n{note}"),
            x_label: "wavelength (nm)".into(),
            y_label: "reflectance factor (π × BRDF)".into(),
            log_y: false,
            series: spectra,
        },
    );
    report.chart(
        "interference_travel",
        Chart {
            title: format!("Interference pigments: colour travel in the a*b* plane\n{note}; −15°, 15°, 25°, 45°, 75°, 110° aspecular"),
            x_label: "a* (CIELAB)".into(),
            y_label: "b* (CIELAB)".into(),
            log_y: false,
            series: travel,
        },
    );
    let files: Vec<String> = [
        "interference.csv",
        "interference_spectra.csv",
        "interference_spectra.svg",
        "interference_spectra.png",
        "interference_travel.svg",
        "interference_travel.png",
    ]
    .map(String::from)
    .to_vec();
    index.add(
        "Beyond the paper — interference (pearlescent) flakes",
        &files,
        format!(
            "The paper ends by pointing to pearlescent paints. Here each flake is a TiO2 \
             (rutile, Devore 1951) layer on mica (physics.md §13: the mica is taken as \
             thick, since the spread of mica thicknesses in a real pigment averages out its \
             own fringes), in a binder of {BINDER}, oriented with a Gaussian hwhm of \
             {HWHM_DEG}°, seen at ASTM E2194's six geometries (45° incidence, −15° to 110° \
             aspecular) through {APERTURE_DEG}° cones, spectra at 380–780 nm in 10 nm steps, \
             CIELAB under D65 and the 10° observer. Three TiO2 thicknesses give the first-order \
             interference colours sold as silver ({} nm), gold ({} nm) and blue ({} nm) pearls; at \
             15° aspecular: {summary}. `interference_travel` shows how hue and chroma \
             travel with the aspecular angle; the light a flake transmits is not followed \
             (a black base).",
            PIGMENTS[0].1, PIGMENTS[1].1, PIGMENTS[2].1
        ),
    );
    Ok(())
}
