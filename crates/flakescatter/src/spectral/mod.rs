//! Spectral models (physics.md §8.1): the distribution and topographic models run once
//! per wavelength with the flake's complex index, the clear coat's index and the
//! binder's absorption at that wavelength; CIELAB per multi-angle geometry from the
//! spectral reflectance factors ([`colour`]); colour differences against measured
//! multi-angle data and the Gaussian width fitted to measured `L*` ([`fit`]).
//!
//! Conventions: wavelengths in vacuum, **nanometres** (`_nm`), angles in radians,
//! lengths in micrometres. At each wavelength the models are the monochromatic ones of
//! physics.md §4–§5 with that wavelength's constants: a run at one wavelength is the
//! monochromatic run with those constants, to the bit (geometric optics has no other
//! wavelength dependence). A coating whose constants do not depend on wavelength
//! ([`SpectralCoating::is_wavelength_independent`]) is computed once and the result
//! used at every wavelength, which changes no number.
//!
//! # Example
//! Aluminium flakes (Rakić's table) under a Cauchy clear coat: the reflectance factor at
//! the 45° specular-adjacent geometry over the visible, and its colour.
//! ```
//! use flakescatter::optics::dispersion::{Cauchy, CoatIndex};
//! use flakescatter::optics::material::ComplexIndexTable;
//! use flakescatter::spectral::{FlakeSpectrum, MultiAngleSource, SpectralCoating, multi_angle_colour};
//! use flakescatter::colour::{GeometrySet, Illuminant, Observer};
//! use flakescatter::stats::{GaussianWidth, Orientation};
//! use flakescatter::{OrientationSource, Settings};
//!
//! let coating = SpectralCoating {
//!     coat: CoatIndex::Cauchy(Cauchy::new(1.49, 0.0045, 0.0)?),
//!     flake: FlakeSpectrum::Table(ComplexIndexTable::aluminium().clone()),
//!     binder: None,
//! };
//! let source = OrientationSource::Distribution(Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians()))?);
//! let wavelengths: Vec<f64> = (0..=30).map(|k| 400.0 + 10.0 * f64::from(k)).collect();
//! let m = multi_angle_colour(
//!     &coating,
//!     &Settings::default(),
//!     MultiAngleSource::Distribution(&source),
//!     &GeometrySet::astm_e2194(),
//!     1.5f64.to_radians(),
//!     &wavelengths,
//!     Illuminant::D65,
//!     flakescatter::colour::Observer::Cie1964TenDegree,
//!     &|_, _| {},
//! )?;
//! // Lightness falls away from specular (metallic flop); aluminium is nearly neutral.
//! let l: Vec<f64> = m.geometries.iter().map(|g| g.lab.l).collect();
//! assert!(l[1] > l[3] && l[3] > l[5] && m.flop_index.is_some());
//! assert!(m.geometries.iter().all(|g| g.lab.chroma() < 3.0));
//! # let _ = Observer::Cie1931TwoDegree;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod colour;
pub mod fit;

pub use colour::{
    ColourDifference, ColourReport, GeometryColour, GeometryDifference, MeasuredGeometry,
    MultiAngleColour, MultiAngleComparison, MultiAngleSource, SpectrumColour, colour_report,
    compare_multi_angle, measured_colours, multi_angle_colour,
};
pub use fit::{LightnessFit, LightnessFitSetup, LightnessFitWarning, fit_lightness};

use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};
use flakescatter_optics::catalogue::MaterialSpec;
use flakescatter_optics::dispersion::{CoatIndex, SpectralTable};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::material::ComplexIndexTable;
use flakescatter_optics::stack_spec::StackSpec;
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_topo::TopoResult;
use rayon::prelude::*;

use crate::PipelineError;
use crate::instrument::Instrument;
use crate::pipeline::{
    Coating, Curves, OrientationSource, Settings, TopoSettings, distribution_curves_of,
    topo_map_base, topographic_curves_of,
};

/// Largest number of wavelengths a spectral run takes.
pub const MAX_WAVELENGTHS: usize = 1000;

/// How the flakes reflect versus wavelength.
#[derive(Debug, Clone, PartialEq)]
pub enum FlakeSpectrum {
    /// The same reflectance at every wavelength (perfect conductor or one complex index).
    Fixed(FlakeReflectance),
    /// A table of `n + i k` versus wavelength (built-in aluminium or a user's file).
    Table(ComplexIndexTable),
    /// Interference flakes: a thin-film stack (physics.md §13), free in the binder or on
    /// an opaque core, resolved at each wavelength with the clear coat's index as the
    /// medium around the flake.
    Stack {
        /// The layers, from the side light arrives on.
        stack: StackSpec,
        /// An opaque core under the layers (`None`: a free flake).
        core: Option<MaterialSpec>,
    },
}

/// The binder's absorption coefficient versus wavelength with the flakes' depth.
#[derive(Debug, Clone, PartialEq)]
pub struct BinderAbsorption {
    /// Napierian absorption coefficient for intensity, µm⁻¹, versus wavelength (nm).
    pub alpha_per_um: SpectralTable,
    /// Where the flakes are in the film.
    pub depth: FlakeDepth,
}

/// A coating described at every wavelength: clear coat, flakes and binder.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralCoating {
    /// The clear coat's real index.
    pub coat: CoatIndex,
    /// The flakes' reflectance.
    pub flake: FlakeSpectrum,
    /// Absorption by the binder along each ray's path inside the film (`None`: a clear
    /// binder).
    pub binder: Option<BinderAbsorption>,
}

/// A coating at one wavelength: the monochromatic coating and the binder's absorption.
#[derive(Debug, Clone, PartialEq)]
pub struct CoatingAt {
    /// Index and flake reflectance at this wavelength.
    pub coating: Coating,
    /// The binder's absorption at this wavelength, if any.
    pub absorption: Option<PathAbsorption>,
}

impl SpectralCoating {
    /// The wavelength-independent coating of a monochromatic run.
    #[must_use]
    pub fn from_coating(coating: &Coating) -> Self {
        Self {
            coat: CoatIndex::Constant(coating.n),
            flake: FlakeSpectrum::Fixed(coating.flake.clone()),
            binder: None,
        }
    }

    /// Whether nothing depends on wavelength (constant index, fixed flake reflectance,
    /// no binder absorption): every wavelength then gives the same result.
    #[must_use]
    pub fn is_wavelength_independent(&self) -> bool {
        self.coat.is_constant()
            && matches!(self.flake, FlakeSpectrum::Fixed(_))
            && self.binder.is_none()
    }

    /// The coating at `wavelength_nm` (nm).
    ///
    /// # Errors
    /// [`PipelineError::Spectral`] naming the wavelength and the table it is outside, or
    /// an index below 1.
    pub fn at(&self, wavelength_nm: f64) -> Result<CoatingAt, PipelineError> {
        let n = self.coat.index_at(wavelength_nm).map_err(|e| {
            PipelineError::Spectral(format!("clear-coat index at {wavelength_nm} nm: {e}"))
        })?;
        let flake = match &self.flake {
            FlakeSpectrum::Fixed(f) => f,
            FlakeSpectrum::Table(t) => &t.flake_at(wavelength_nm).map_err(|e| {
                PipelineError::Spectral(format!(
                    "flake optical constants at {wavelength_nm} nm: {e}"
                ))
            })?,
            FlakeSpectrum::Stack { stack, core } => {
                let spectral = |e: String| {
                    PipelineError::Spectral(format!("flake stack at {wavelength_nm} nm: {e}"))
                };
                let layers = stack
                    .at(wavelength_nm)
                    .map_err(|e| spectral(e.to_string()))?;
                let core = core
                    .as_ref()
                    .map(|c| c.index_at(wavelength_nm))
                    .transpose()
                    .map_err(|e| spectral(format!("core: {e}")))?;
                &FlakeReflectance::stack(layers, wavelength_nm, core)
                    .map_err(|e| spectral(e.to_string()))?
            }
        };
        let absorption = match &self.binder {
            None => None,
            Some(b) => {
                let alpha = b.alpha_per_um.value_at(wavelength_nm).map_err(|e| {
                    PipelineError::Spectral(format!("binder absorption at {wavelength_nm} nm: {e}"))
                })?;
                Some(PathAbsorption::new(alpha, b.depth).map_err(|e| {
                    PipelineError::Spectral(format!("binder absorption at {wavelength_nm} nm: {e}"))
                })?)
            }
        };
        Ok(CoatingAt {
            coating: Coating {
                n,
                flake: flake.clone(),
            },
            absorption,
        })
    }

    /// The coating at every wavelength of `wavelengths_nm`, checked first (so that a
    /// wavelength outside a table is refused before any work).
    ///
    /// # Errors
    /// As [`check_wavelengths`] and [`SpectralCoating::at`].
    pub fn at_all(&self, wavelengths_nm: &[f64]) -> Result<Vec<CoatingAt>, PipelineError> {
        check_wavelengths(wavelengths_nm)?;
        wavelengths_nm.iter().map(|&w| self.at(w)).collect()
    }
}

/// Checks a wavelength list: 1 to [`MAX_WAVELENGTHS`] finite positive wavelengths (nm),
/// strictly increasing.
///
/// # Errors
/// [`PipelineError::Spectral`] naming the first wavelength that breaks a rule.
pub fn check_wavelengths(wavelengths_nm: &[f64]) -> Result<(), PipelineError> {
    if wavelengths_nm.is_empty() {
        return Err(PipelineError::Spectral("no wavelength given".into()));
    }
    if wavelengths_nm.len() > MAX_WAVELENGTHS {
        return Err(PipelineError::Spectral(format!(
            "{} wavelengths is more than the limit of {MAX_WAVELENGTHS}",
            wavelengths_nm.len()
        )));
    }
    for (i, &w) in wavelengths_nm.iter().enumerate() {
        if !(w.is_finite() && w > 0.0) {
            return Err(PipelineError::Spectral(format!(
                "wavelength {w} nm is not valid: expected a finite number > 0"
            )));
        }
        if i > 0 && w <= wavelengths_nm[i - 1] {
            return Err(PipelineError::Spectral(format!(
                "wavelength {w} nm does not follow {} nm: expected strictly increasing wavelengths",
                wavelengths_nm[i - 1]
            )));
        }
    }
    Ok(())
}

/// Curves of one model at each wavelength.
#[derive(Debug, Clone)]
pub struct SpectralCurves {
    /// The wavelengths, nm.
    pub wavelengths_nm: Vec<f64>,
    /// The curves at each wavelength (same order), each with that wavelength's coating.
    pub curves: Vec<Curves>,
    /// The binder's absorption at each wavelength (`None` without a binder).
    pub absorption: Vec<Option<PathAbsorption>>,
    /// The topographic model's totals at each wavelength (empty for the distribution
    /// model).
    pub topo: Vec<TopoResult>,
}

/// The distribution model (physics.md §4) at each wavelength of `wavelengths_nm` (nm)
/// for `coating` seen by `instrument`. Wavelengths are computed in parallel and
/// collected in order (the result does not depend on the number of threads).
///
/// # Errors
/// As [`check_wavelengths`], [`SpectralCoating::at`] and
/// [`crate::distribution_curves`].
pub fn spectral_distribution_curves(
    coating: &SpectralCoating,
    wavelengths_nm: &[f64],
    instrument: &Instrument,
    settings: &Settings,
    source: &OrientationSource,
) -> Result<SpectralCurves, PipelineError> {
    let at = coating.at_all(wavelengths_nm)?;
    let orientation = source.orientation()?;
    let curves: Vec<Curves> = if coating.is_wavelength_independent() {
        let one = distribution_curves_of(&at[0].coating, instrument, settings, orientation, None)?;
        vec![one; wavelengths_nm.len()]
    } else {
        at.par_iter()
            .map(|c| {
                distribution_curves_of(
                    &c.coating,
                    instrument,
                    settings,
                    orientation.clone(),
                    c.absorption,
                )
            })
            .collect::<Result<_, _>>()?
    };
    Ok(SpectralCurves {
        wavelengths_nm: wavelengths_nm.to_vec(),
        curves,
        absorption: at.iter().map(|c| c.absorption).collect(),
        topo: Vec::new(),
    })
}

/// The topographic model (physics.md §5) over `maps` at each wavelength of
/// `wavelengths_nm` (nm). Each wavelength is one run over the maps (exit directions
/// move with the coat's index); `progress(done, total)` counts tiles over all of them.
///
/// # Errors
/// As [`check_wavelengths`], [`SpectralCoating::at`] and
/// [`crate::topographic_curves`].
pub fn spectral_topographic_curves(
    coating: &SpectralCoating,
    wavelengths_nm: &[f64],
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    maps: &[&HeightMap],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<SpectralCurves, PipelineError> {
    let at = coating.at_all(wavelengths_nm)?;
    let runs = if coating.is_wavelength_independent() {
        1
    } else {
        wavelengths_nm.len()
    };
    let base = topo_map_base(&at[0].coating, settings, topo, maps)?;
    let mut curves = Vec::with_capacity(wavelengths_nm.len());
    let mut totals = Vec::with_capacity(wavelengths_nm.len());
    for (k, c) in at.iter().take(runs).enumerate() {
        let step = |done: u64, total: u64| progress(k as u64 * total + done, runs as u64 * total);
        let (cv, r) = topographic_curves_of(
            &c.coating,
            c.absorption,
            instrument,
            settings,
            topo,
            maps,
            base.as_ref(),
            &step,
        )?;
        curves.push(cv);
        totals.push(r);
    }
    if runs == 1 {
        curves = vec![curves[0].clone(); wavelengths_nm.len()];
        totals = vec![totals[0].clone(); wavelengths_nm.len()];
    }
    Ok(SpectralCurves {
        wavelengths_nm: wavelengths_nm.to_vec(),
        curves,
        absorption: at.iter().map(|c| c.absorption).collect(),
        topo: totals,
    })
}
