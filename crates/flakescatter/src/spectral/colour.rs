//! CIELAB per multi-angle geometry from the spectral models, and colour differences
//! against measured multi-angle data (physics.md §8, §8.1).
//!
//! Conventions: radians, wavelengths in nm. A geometry `(θi, aspecular)` is the in-plane
//! detector `θs = −θi + aspecular` (physics.md §1) with a cone of half-angle `aperture`;
//! its spectral **reflectance factor** is `R(λ) = π × BRDF(λ)` averaged over the cone
//! (1 for the perfect diffuser), XYZ from `R(λ)` with ASTM E308 weights at the model's
//! own wavelengths ([`flakescatter_colour::TristimulusWeights`]), CIELAB relative to the
//! perfect reflector through the same weights. The flop index is the colorimetry
//! crate's (45° incidence, 15°, 45° and 110° aspecular in the set; `None` otherwise).
//!
//! **Uncertainty of `L*`** (topographic model): the tile standard errors of `R(λ)` are
//! taken as fully correlated between wavelengths (the same rays reach a detector at
//! every wavelength, so the map's sampling moves the whole spectrum together):
//! `σ_Y = Σ_λ W_y(λ) σ_R(λ)`, `σ_L* = (dL*/dY) σ_Y`, an upper bound for errors that are
//! not fully correlated. The distribution model's is its quadrature error estimate
//! propagated the same way.
//!
//! **Differences** against a measurement: the measurement is the standard (reference)
//! and the model the sample, `ΔL* = L*_model − L*_measured`; ΔE*94 weights come from the
//! measured chroma.

use flakescatter_colour::{
    Cie94, Geometry, GeometrySet, Illuminant, Lab, Observer, TristimulusWeights, Xyz, delta_e_94,
    delta_e_2000, delta_e_ab,
};
use flakescatter_io::spectral::{
    MAX_LIGHTNESS, MultiAngleData, MultiAngleFile, SpectraFile, min_lightness,
};
use flakescatter_stats::heightmap::HeightMap;

use super::{SpectralCoating, spectral_distribution_curves, spectral_topographic_curves};
use crate::PipelineError;
use crate::instrument::{DetectorSet, Instrument};
use crate::pipeline::{OrientationSource, Settings, TopoSettings};

/// Which model computes the spectra.
#[derive(Debug, Clone, Copy)]
pub enum MultiAngleSource<'a> {
    /// The distribution model with this orientation source.
    Distribution(&'a OrientationSource),
    /// The topographic model over these maps (masks applied).
    Topographic {
        /// Window and tile settings.
        topo: &'a TopoSettings,
        /// The height maps.
        maps: &'a [&'a HeightMap],
    },
}

/// The colour of one geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryColour {
    /// The geometry.
    pub geometry: Geometry,
    /// Reflectance factor `π × BRDF` over the cone at each wavelength.
    pub reflectance: Vec<f64>,
    /// Standard error of each reflectance factor (`None` where not estimable).
    pub reflectance_std_err: Vec<Option<f64>>,
    /// Rays counted in the detector at the first wavelength (topographic model only).
    pub rays: Option<u64>,
    /// CIE XYZ (`Y = 100` for the perfect diffuser).
    pub xyz: Xyz,
    /// CIELAB.
    pub lab: Lab,
    /// Luminance factor `Y/Yn` (the `Y`-weighted mean reflectance factor; the reflectance
    /// factor itself for a flat spectrum).
    pub luminance_factor: f64,
    /// Standard uncertainty of `L*` (module docs); `None` when a wavelength has none.
    pub lightness_std_err: Option<f64>,
}

/// CIELAB per geometry of a set, with the flop index.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiAngleColour {
    /// Which model (`distribution` or `topographic`).
    pub model: &'static str,
    /// The geometry set.
    pub set: GeometrySet,
    /// Detector half-angle, radians.
    pub aperture: f64,
    /// Wavelengths of the spectra, nm.
    pub wavelengths_nm: Vec<f64>,
    /// Illuminant of the colorimetry.
    pub illuminant: Illuminant,
    /// Observer of the colorimetry.
    pub observer: Observer,
    /// The white point through the same weights.
    pub white: Xyz,
    /// One entry per geometry, in the set's order.
    pub geometries: Vec<GeometryColour>,
    /// Flop index (`None` unless the set has 45° incidence with 15°, 45° and 110°
    /// aspecular and `L*15 > L*110`).
    pub flop_index: Option<f64>,
    /// Whether the coating depends on wavelength (else one wavelength was computed and
    /// its result used at all of them).
    pub dispersive: bool,
    /// Cautions (geometries no ray reached, missing standard errors).
    pub warnings: Vec<String>,
}

/// The spectral model's colour at every geometry of `set`: per incidence of the set one
/// spectral run with in-plane detectors at `θs = −θi + aspecular` and half-angle
/// `aperture` (radians, > 0), then XYZ and CIELAB under `illuminant` / `observer`
/// (module docs).
///
/// # Errors
/// [`PipelineError::Instrument`] for a zero aperture; [`PipelineError::Spectral`] for
/// wavelengths colorimetry cannot integrate (they must cover 400–700 nm with steps of at
/// most 20 nm, within 360–830 nm) or outside a table of the coating; the models' errors.
#[allow(clippy::too_many_arguments)]
pub fn multi_angle_colour(
    coating: &SpectralCoating,
    settings: &Settings,
    source: MultiAngleSource<'_>,
    set: &GeometrySet,
    aperture: f64,
    wavelengths_nm: &[f64],
    illuminant: Illuminant,
    observer: Observer,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<MultiAngleColour, PipelineError> {
    if !(aperture > 0.0) {
        return Err(PipelineError::Instrument(
            "multi-angle colour needs detectors with an aperture > 0 (a reflectance factor over the cone)"
                .into(),
        ));
    }
    super::check_wavelengths(wavelengths_nm)?;
    let weights = TristimulusWeights::new(wavelengths_nm, illuminant, observer).map_err(|e| {
        PipelineError::Spectral(format!("colorimetry of the model's wavelengths: {e}"))
    })?;
    coating.at_all(wavelengths_nm)?;
    let white = weights.white_point();
    let geoms = set.geometries();
    let mut out: Vec<Option<GeometryColour>> = vec![None; geoms.len()];
    let mut warnings = Vec::new();
    let incidences = set.incidences();
    let mut model = "distribution";
    for (ii, &ti) in incidences.iter().enumerate() {
        let idx: Vec<usize> = (0..geoms.len())
            .filter(|&k| geoms[k].theta_i() == ti)
            .collect();
        let ts: Vec<f64> = idx.iter().map(|&k| geoms[k].theta_s()).collect();
        let instrument = Instrument::new(vec![ti], DetectorSet::InPlane(ts), aperture)?;
        let spectral = match source {
            MultiAngleSource::Distribution(src) => {
                spectral_distribution_curves(coating, wavelengths_nm, &instrument, settings, src)?
            }
            MultiAngleSource::Topographic { topo, maps } => {
                model = "topographic";
                let n_inc = incidences.len() as u64;
                let step = |d: u64, t: u64| progress(ii as u64 * t + d, n_inc * t);
                spectral_topographic_curves(
                    coating,
                    wavelengths_nm,
                    &instrument,
                    settings,
                    topo,
                    maps,
                    &step,
                )?
            }
        };
        for (j, &k) in idx.iter().enumerate() {
            let rows: Vec<_> = spectral.curves.iter().map(|c| c.rows[j]).collect();
            let reflectance: Vec<f64> =
                rows.iter().map(|r| std::f64::consts::PI * r.brdf).collect();
            let se: Vec<Option<f64>> = rows
                .iter()
                .map(|r| r.std_err.map(|e| std::f64::consts::PI * e))
                .collect();
            let xyz = weights.xyz(&reflectance).map_err(|e| {
                PipelineError::Spectral(format!(
                    "colorimetry of the model's spectrum at θi {}° aspecular {}°: {e}",
                    shown_deg(ti),
                    shown_deg(geoms[k].aspecular())
                ))
            })?;
            let lab = xyz.to_lab(&white);
            let luminance_factor = xyz.y / white.y;
            let sigma_y: Option<f64> = se
                .iter()
                .zip(weights.weights())
                .map(|(s, w)| s.map(|s| w[1] * s))
                .sum();
            let rays = rows[0].rays;
            if rays == Some(0) {
                warnings.push(format!(
                    "geometry θi {}° aspecular {}°: no ray reached the detector; its colour is black (L* = 0)",
                    shown_deg(ti),
                    shown_deg(geoms[k].aspecular())
                ));
            }
            out[k] = Some(GeometryColour {
                geometry: geoms[k],
                reflectance,
                reflectance_std_err: se,
                rays,
                xyz,
                lab,
                luminance_factor,
                lightness_std_err: sigma_y.map(|s| lightness_slope(luminance_factor) * s / white.y),
            });
        }
    }
    let geometries: Vec<GeometryColour> = out.into_iter().flatten().collect();
    debug_assert_eq!(geometries.len(), geoms.len());
    let l: Vec<f64> = geometries.iter().map(|g| g.lab.l).collect();
    if model == "topographic" && geometries.iter().any(|g| g.lightness_std_err.is_none()) {
        warnings.push(
            "the standard error of L* is not estimable at some geometries (fewer than 2 map tiles, or no ray)".into(),
        );
    }
    Ok(MultiAngleColour {
        model,
        set: set.clone(),
        aperture,
        wavelengths_nm: wavelengths_nm.to_vec(),
        illuminant,
        observer,
        white,
        flop_index: set.flop_index(&l),
        geometries,
        dispersive: !coating.is_wavelength_independent(),
        warnings,
    })
}

/// An angle in degrees for messages, rounded to 1e-6° (so `45`, not `45.00000000000001`).
fn shown_deg(rad: f64) -> f64 {
    let d = (rad.to_degrees() * 1e6).round() / 1e6;
    if d == 0.0 { 0.0 } else { d }
}

/// `dL*/d(Y/Yn)` (CIE 1976 lightness): `(116/3) t^(−2/3)` above `(6/29)³`,
/// `116 / (3 (6/29)²)` below.
fn lightness_slope(t: f64) -> f64 {
    let d = 6.0 / 29.0;
    if t > d * d * d {
        116.0 / 3.0 * t.powf(-2.0 / 3.0)
    } else {
        116.0 / (3.0 * d * d)
    }
}

/// One measured geometry: its colour (from the file's CIELAB, or from its spectrum
/// through the colorimetry) and its `L*` uncertainty when the file gives one.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredGeometry {
    /// The geometry.
    pub geometry: Geometry,
    /// CIELAB.
    pub lab: Lab,
    /// Standard uncertainty of `L*`, if given.
    pub l_uncertainty: Option<f64>,
    /// The measured spectrum `(wavelengths nm, reflectance factors)` when the file is
    /// spectral.
    pub spectrum: Option<(Vec<f64>, Vec<f64>)>,
    /// 1-based line of the file where the geometry starts.
    pub line: u64,
}

/// The measured geometries of a multi-angle file: CIELAB as given (measured under
/// `illuminant` / `observer`, which the file does not say), or computed from each
/// geometry's spectrum at its own wavelengths (ASTM E308 weights).
///
/// A colour target is a surface colour: [`min_lightness`] `≤ L* ≤` [`MAX_LIGHTNESS`] and `|a*|, |b*| ≤`
/// [`MAX_LIGHTNESS`] (the file's, or computed from its spectrum), and a stated
/// `L_uncertainty` is `> 0`, as [`flakescatter_io::spectral::read_multiangle`] checks
/// when it reads a file; a [`MultiAngleFile`] built in code is held to the same rules.
///
/// # Errors
/// [`PipelineError::Measurement`] naming the file and line (and column) for a spectrum
/// colorimetry cannot integrate, a colour or uncertainty outside those rules, or a
/// geometry that is not valid.
pub fn measured_colours(
    file: &MultiAngleFile,
    illuminant: Illuminant,
    observer: Observer,
) -> Result<Vec<MeasuredGeometry>, PipelineError> {
    let geometry = |ti: f64, asp: f64, line: u64| {
        Geometry::new(ti, asp)
            .map_err(|e| PipelineError::Measurement(format!("{}, line {line}: {e}", file.file)))
    };
    match &file.data {
        MultiAngleData::Lab(rows) => rows
            .iter()
            .map(|r| {
                let bad = |column: &str, what: String| {
                    PipelineError::Measurement(format!(
                        "{}, line {}, column {column}: {what}",
                        file.file, r.line
                    ))
                };
                if let Some(u) = r.l_uncertainty
                    && !(u > 0.0 && u.is_finite())
                {
                    return Err(bad(
                        "L_uncertainty",
                        format!("{u}: expected a standard uncertainty of L* > 0"),
                    ));
                }
                let lab = Lab::new(r.l, r.a, r.b).map_err(|e| bad("L, a, b", e.to_string()))?;
                if let Some((column, what)) = implausible(&lab, r.l_uncertainty) {
                    return Err(bad(column, what));
                }
                Ok(MeasuredGeometry {
                    geometry: geometry(r.theta_i, r.aspecular, r.line)?,
                    lab,
                    l_uncertainty: r.l_uncertainty,
                    spectrum: None,
                    line: r.line,
                })
            })
            .collect(),
        MultiAngleData::Spectral(spectra) => spectra
            .iter()
            .map(|s| {
                let line = s.lines[0];
                let (Some(ti), Some(asp)) = (s.theta_i, s.aspecular) else {
                    return Err(PipelineError::Measurement(format!(
                        "{}, line {line}: a spectrum without its geometry",
                        file.file
                    )));
                };
                let lab = TristimulusWeights::new(&s.wavelengths_nm, illuminant, observer)
                    .and_then(|w| w.lab(&s.reflectance))
                    .map_err(|e| {
                        PipelineError::Measurement(format!(
                            "{}: the spectrum of the geometry starting on line {line}: {e}",
                            file.file
                        ))
                    })?;
                if let Some((_, what)) = implausible(&lab, None) {
                    return Err(PipelineError::Measurement(format!(
                        "{}: the spectrum of the geometry starting on line {line} (column reflectance_factor) gives {what}",
                        file.file
                    )));
                }
                Ok(MeasuredGeometry {
                    geometry: geometry(ti, asp, line)?,
                    lab,
                    l_uncertainty: None,
                    spectrum: Some((s.wavelengths_nm.clone(), s.reflectance.clone())),
                    line,
                })
            })
            .collect(),
    }
}

/// The first coordinate of `lab` outside a surface colour's range (module docs of
/// [`measured_colours`]), as `(column, what was expected)`.
fn implausible(lab: &Lab, l_uncertainty: Option<f64>) -> Option<(&'static str, String)> {
    let lo = min_lightness(l_uncertainty);
    if !(lo..=MAX_LIGHTNESS).contains(&lab.l) {
        return Some((
            "L",
            format!(
                "L* = {}: expected a CIELAB lightness from {lo} to {MAX_LIGHTNESS} (a surface's L* is never negative, below 0 only by measurement noise: max(1, 5 L_uncertainty); above {MAX_LIGHTNESS} its luminance factor would exceed about 640)",
                lab.l
            ),
        ));
    }
    for (column, v) in [("a", lab.a), ("b", lab.b)] {
        if v.abs() > MAX_LIGHTNESS {
            return Some((
                column,
                format!("{column}* = {v}: expected -{MAX_LIGHTNESS} to {MAX_LIGHTNESS}"),
            ));
        }
    }
    None
}

/// Model against measurement at one geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeometryDifference {
    /// The geometry.
    pub geometry: Geometry,
    /// Measured CIELAB (the standard).
    pub measured: Lab,
    /// Model CIELAB (the sample).
    pub model: Lab,
    /// `L*_model − L*_measured`.
    pub delta_l: f64,
    /// `a*_model − a*_measured`.
    pub delta_a: f64,
    /// `b*_model − b*_measured`.
    pub delta_b: f64,
    /// ΔE*ab.
    pub delta_e_ab: f64,
    /// ΔE*94 (graphic-arts constants; weights from the measured chroma).
    pub delta_e_94: f64,
    /// CIEDE2000.
    pub delta_e_2000: f64,
}

impl GeometryDifference {
    /// The differences of `sample` from `standard` at `geometry`.
    #[must_use]
    pub fn new(geometry: Geometry, standard: Lab, sample: Lab) -> Self {
        Self {
            geometry,
            measured: standard,
            model: sample,
            delta_l: sample.l - standard.l,
            delta_a: sample.a - standard.a,
            delta_b: sample.b - standard.b,
            delta_e_ab: delta_e_ab(&standard, &sample),
            delta_e_94: delta_e_94(&standard, &sample, Cie94::GRAPHIC_ARTS),
            delta_e_2000: delta_e_2000(&standard, &sample),
        }
    }
}

/// A model's multi-angle colour against a measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiAngleComparison {
    /// The measured geometries and colours, in the file's order.
    pub measured: Vec<MeasuredGeometry>,
    /// The model's colour at the measured geometries.
    pub model: MultiAngleColour,
    /// Per geometry, in the file's order.
    pub rows: Vec<GeometryDifference>,
    /// Mean CIEDE2000 over the geometries.
    pub mean_delta_e_2000: f64,
    /// Largest CIEDE2000 and its geometry's index.
    pub max_delta_e_2000: (f64, usize),
    /// Flop index of the measurement (same rule as the model's).
    pub measured_flop_index: Option<f64>,
}

/// The spectral model at the geometries of the measured multi-angle `file` (the set is
/// the file's, in its order), against the measured colours ([`measured_colours`] under
/// the same illuminant and observer).
///
/// # Errors
/// As [`measured_colours`] and [`multi_angle_colour`].
#[allow(clippy::too_many_arguments)]
pub fn compare_multi_angle(
    file: &MultiAngleFile,
    coating: &SpectralCoating,
    settings: &Settings,
    source: MultiAngleSource<'_>,
    aperture: f64,
    wavelengths_nm: &[f64],
    illuminant: Illuminant,
    observer: Observer,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<MultiAngleComparison, PipelineError> {
    let measured = measured_colours(file, illuminant, observer)?;
    let set = GeometrySet::new("measured", measured.iter().map(|m| m.geometry).collect())
        .map_err(|e| PipelineError::Measurement(format!("measured geometries: {e}")))?;
    let model = multi_angle_colour(
        coating,
        settings,
        source,
        &set,
        aperture,
        wavelengths_nm,
        illuminant,
        observer,
        progress,
    )?;
    let rows: Vec<GeometryDifference> = measured
        .iter()
        .zip(&model.geometries)
        .map(|(m, g)| GeometryDifference::new(m.geometry, m.lab, g.lab))
        .collect();
    let mean = rows.iter().map(|r| r.delta_e_2000).sum::<f64>() / rows.len() as f64;
    let max = rows
        .iter()
        .enumerate()
        .fold((f64::NEG_INFINITY, 0), |acc, (k, r)| {
            if r.delta_e_2000 > acc.0 {
                (r.delta_e_2000, k)
            } else {
                acc
            }
        });
    let l: Vec<f64> = measured.iter().map(|m| m.lab.l).collect();
    Ok(MultiAngleComparison {
        measured_flop_index: set.flop_index(&l),
        measured,
        model,
        rows,
        mean_delta_e_2000: mean,
        max_delta_e_2000: max,
    })
}

/// The colour differences of a sample from a standard (reference).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourDifference {
    /// `L*_sample − L*_standard`.
    pub delta_l: f64,
    /// `a*_sample − a*_standard`.
    pub delta_a: f64,
    /// `b*_sample − b*_standard`.
    pub delta_b: f64,
    /// ΔE*ab.
    pub delta_e_ab: f64,
    /// ΔE*94 (graphic-arts constants; weights from the standard's chroma).
    pub delta_e_94: f64,
    /// CIEDE2000.
    pub delta_e_2000: f64,
}

impl ColourDifference {
    /// The differences of `sample` from `standard`.
    #[must_use]
    pub fn new(standard: &Lab, sample: &Lab) -> Self {
        Self {
            delta_l: sample.l - standard.l,
            delta_a: sample.a - standard.a,
            delta_b: sample.b - standard.b,
            delta_e_ab: delta_e_ab(standard, sample),
            delta_e_94: delta_e_94(standard, sample, Cie94::GRAPHIC_ARTS),
            delta_e_2000: delta_e_2000(standard, sample),
        }
    }
}

/// The colour of one spectrum of a file, with its reference and difference.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumColour {
    /// The geometry, when the file has geometry columns.
    pub geometry: Option<Geometry>,
    /// CIE XYZ.
    pub xyz: Xyz,
    /// CIELAB.
    pub lab: Lab,
    /// The reference's XYZ and CIELAB at the same geometry, when a reference is given.
    pub reference: Option<(Xyz, Lab)>,
    /// The sample's difference from the reference.
    pub difference: Option<ColourDifference>,
    /// 1-based line where the spectrum starts.
    pub line: u64,
}

/// What `colour` reports: every spectrum's colour, and the flop indices of
/// multi-angle files.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourReport {
    /// One entry per spectrum of the sample file, in its order.
    pub spectra: Vec<SpectrumColour>,
    /// The sample's flop index (`None` without the 45° / 15°, 45°, 110° geometries).
    pub flop_index: Option<f64>,
    /// The reference's flop index.
    pub reference_flop_index: Option<f64>,
    /// Cautions: spectra whose colour lies beyond any surface colour (`L*` above
    /// [`MAX_LIGHTNESS`]), where CIELAB and the differences are computed (finite, never
    /// a spurious 0) but rest on the rounding of numbers that large.
    pub warnings: Vec<String>,
}

/// One spectrum's geometry, XYZ, CIELAB and first line.
type Colour = (Option<Geometry>, Xyz, Lab, u64);

/// XYZ and CIELAB of each spectrum of `file` at its own sampling (ASTM E308 weights).
fn colours_of(
    file: &SpectraFile,
    illuminant: Illuminant,
    observer: Observer,
) -> Result<Vec<Colour>, PipelineError> {
    file.spectra
        .iter()
        .map(|s| {
            let line = s.lines[0];
            let err = |e: String| {
                PipelineError::Measurement(format!(
                    "{}: the spectrum starting on line {line}: {e}",
                    file.file
                ))
            };
            let w = TristimulusWeights::new(&s.wavelengths_nm, illuminant, observer)
                .map_err(|e| err(e.to_string()))?;
            let xyz = w.xyz(&s.reflectance).map_err(|e| err(e.to_string()))?;
            let geometry = match (s.theta_i, s.aspecular) {
                (Some(t), Some(a)) => Some(Geometry::new(t, a).map_err(|e| err(e.to_string()))?),
                _ => None,
            };
            Ok((geometry, xyz, xyz.to_lab(&w.white_point()), line))
        })
        .collect()
}

/// The flop index of a list of geometries with their lightness (`None` without
/// geometries or the needed ones).
fn flop_of(rows: &[Colour]) -> Option<f64> {
    let geoms: Option<Vec<Geometry>> = rows.iter().map(|r| r.0).collect();
    let set = GeometrySet::new("file", geoms?).ok()?;
    set.flop_index(&rows.iter().map(|r| r.2.l).collect::<Vec<_>>())
}

/// The colour of every spectrum of `sample` under `illuminant` / `observer`, and with
/// `reference` the differences of each from the reference spectrum at the same geometry
/// (files without geometry columns hold one spectrum each).
///
/// # Errors
/// [`PipelineError::Measurement`] naming the file and line for a spectrum colorimetry
/// cannot integrate (coverage 400–700 nm, steps ≤ 20 nm, within 360–830 nm), a
/// reference with or without geometry columns where the sample has the other, or a
/// geometry of the sample missing from the reference.
pub fn colour_report(
    sample: &SpectraFile,
    reference: Option<&SpectraFile>,
    illuminant: Illuminant,
    observer: Observer,
) -> Result<ColourReport, PipelineError> {
    let rows = colours_of(sample, illuminant, observer)?;
    let refs = reference
        .map(|r| colour_ref(sample, r, illuminant, observer))
        .transpose()?;
    let mut spectra = Vec::with_capacity(rows.len());
    for (geometry, xyz, lab, line) in &rows {
        let matched = match (&refs, geometry) {
            (None, _) => None,
            (Some((r, _)), None) => Some(r[0]),
            (Some((r, file)), Some(g)) => Some(
                r.iter()
                    .find(|x| x.0 == Some(*g))
                    .copied()
                    .ok_or_else(|| {
                        PipelineError::Measurement(format!(
                            "{file}: no spectrum at the geometry θi {}° aspecular {}° of {} (line {line})",
                            shown_deg(g.theta_i()),
                            shown_deg(g.aspecular()),
                            sample.file
                        ))
                    })?,
            ),
        };
        spectra.push(SpectrumColour {
            geometry: *geometry,
            xyz: *xyz,
            lab: *lab,
            reference: matched.map(|m| (m.1, m.2)),
            difference: matched.map(|m| ColourDifference::new(&m.2, lab)),
            line: *line,
        });
    }
    let mut warnings = far_beyond(&sample.file, &rows);
    if let (Some((r, _)), Some(file)) = (&refs, reference) {
        warnings.extend(far_beyond(&file.file, r));
    }
    Ok(ColourReport {
        flop_index: flop_of(&rows),
        reference_flop_index: refs.as_ref().and_then(|(r, _)| flop_of(r)),
        spectra,
        warnings,
    })
}

/// A caution per spectrum of `file` whose `L*` exceeds [`MAX_LIGHTNESS`].
fn far_beyond(file: &str, rows: &[Colour]) -> Vec<String> {
    rows.iter()
        .filter(|r| r.2.l > MAX_LIGHTNESS)
        .map(|r| {
            format!(
                "{file}: the spectrum starting on line {} has L* = {:.4e} (Y = {:.4e}), far beyond any surface colour (L* <= {MAX_LIGHTNESS}); its a*, b*, hue and colour differences are computed but rest on rounding at that scale",
                r.3, r.2.l, r.1.y
            )
        })
        .collect()
}

/// The reference's colours, checked to match the sample's layout.
fn colour_ref(
    sample: &SpectraFile,
    reference: &SpectraFile,
    illuminant: Illuminant,
    observer: Observer,
) -> Result<(Vec<Colour>, String), PipelineError> {
    if sample.has_geometry != reference.has_geometry {
        let (with, without) = if sample.has_geometry {
            (&sample.file, &reference.file)
        } else {
            (&reference.file, &sample.file)
        };
        return Err(PipelineError::Measurement(format!(
            "{with} has geometry columns (theta_i_deg, aspecular_deg) and {without} has not: compare spectra of the same kind"
        )));
    }
    Ok((
        colours_of(reference, illuminant, observer)?,
        reference.file.clone(),
    ))
}
