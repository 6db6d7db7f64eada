//! The Gaussian width (with a common vertical scale, and optionally the clear coat's
//! index) fitted to measured multi-angle lightness `L*` (physics.md §8.1).
//!
//! Conventions: radians. The model is the spectral distribution model at the measured
//! geometries ([`super::multi_angle_colour`]); its reflectance factors are multiplied
//! by a scale `s` (the flake coverage the model, a fully covering layer, does not know;
//! the curve fit's vertical scale), so `XYZ → s · XYZ`. Residuals are
//! `(L*_model − L*_measured)/σ` with `σ` the file's `L_uncertainty` when every geometry
//! has one (> 0), else 1. Levenberg–Marquardt on `(ln hwhm, ln s[, n])` with central
//! differences, `hwhm` in [0.05°, 60°], `s` in [10⁻³, 10³], `n` in [1, 3].
//!
//! Uncertainties as the curve fit's ([`crate::fit`]): the covariance `(JᵀJ)⁻¹` is
//! scaled by `χ²/dof` without stated uncertainties and when `χ²/dof > 1` with them,
//! never down. Warnings: a poor fit (`χ²/dof` above the 99.9 % point of `χ²_dof/dof`
//! with uncertainties; an rms `L*` residual above [`POOR_FIT_RMS_L`] without), a
//! parameter on a bound, fewer than [`crate::fit::MIN_POINTS_PER_PARAMETER`] points per
//! parameter. A geometry whose cone holds the specular direction is refused: the clear
//! coat's reflection there must not be scaled with the flakes' light.

use std::cell::RefCell;
use std::collections::HashMap;

use flakescatter_colour::{Geometry, Illuminant, Lab, Observer, Xyz};
use flakescatter_numerics::lm::{self, LmError};
use flakescatter_optics::dispersion::CoatIndex;
use flakescatter_stats::{GaussianWidth, Orientation};

use super::SpectralCoating;
use flakescatter_io::spectral::MultiAngleFile;

use super::colour::{MeasuredGeometry, MultiAngleSource, measured_colours, multi_angle_colour};
use crate::PipelineError;
use crate::fit::{MIN_POINTS_PER_PARAMETER, UncertaintyBasis, chi2_per_dof_999};
use crate::pipeline::{OrientationSource, Settings};

/// XYZ per geometry and the white point.
type Tristimulus = (Vec<Xyz>, Xyz);

/// Without stated uncertainties, an rms `L*` residual above this earns a
/// [`LightnessFitWarning::PoorFit`] (a convention: twice the ΔL* ≈ 1 that is visible
/// on a metallic panel, several times a multi-angle instrument's repeatability).
pub const POOR_FIT_RMS_L: f64 = 2.0;

/// What the fit uses.
#[derive(Debug, Clone, Copy)]
pub struct LightnessFitSetup<'a> {
    /// The coating (its constant coat index is the start value when `fit_n`).
    pub coating: &'a SpectralCoating,
    /// Model settings.
    pub settings: Settings,
    /// Detector half-angle, radians.
    pub aperture: f64,
    /// Wavelengths of the model's spectra, nm.
    pub wavelengths_nm: &'a [f64],
    /// Illuminant of the colorimetry (as the measured `L*` were computed).
    pub illuminant: Illuminant,
    /// Observer of the colorimetry.
    pub observer: Observer,
    /// Fit the clear coat's (constant) index too.
    pub fit_n: bool,
}

/// Why a lightness fit deserves caution.
#[derive(Debug, Clone, PartialEq)]
pub enum LightnessFitWarning {
    /// `χ²/dof` above `threshold` (module docs).
    PoorFit {
        /// Reduced χ² at the optimum.
        chi2_per_dof: f64,
        /// The threshold it exceeds.
        threshold: f64,
        /// Whether the file gave uncertainties.
        uncertainties_given: bool,
    },
    /// A parameter ended on a bound of its search range.
    AtBound {
        /// `"hwhm"`, `"scale"` or `"n"`.
        parameter: &'static str,
        /// The bound (radians for `hwhm`).
        bound: f64,
    },
    /// Fewer than [`MIN_POINTS_PER_PARAMETER`] geometries per fitted parameter.
    FewPoints {
        /// Geometries used.
        points: usize,
        /// Fitted parameters.
        parameters: usize,
    },
}

impl std::fmt::Display for LightnessFitWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::PoorFit {
                chi2_per_dof,
                threshold,
                uncertainties_given: true,
            } => write!(
                f,
                "poor fit: chi2/dof = {chi2_per_dof:.3} is above {threshold:.3} (the 99.9 % point for these degrees of freedom); the model does not describe the L* within their uncertainties, so the uncertainties were scaled by sqrt(chi2/dof) and the width itself may be biased"
            ),
            Self::PoorFit { chi2_per_dof, .. } => write!(
                f,
                "poor fit: the rms L* residual is {:.3} (above {POOR_FIT_RMS_L}); the model describes the data poorly and the width may be biased",
                chi2_per_dof.sqrt()
            ),
            Self::AtBound { parameter, bound } => {
                let shown = if parameter == "hwhm" {
                    format!("{} degrees", bound.to_degrees())
                } else {
                    format!("{bound}")
                };
                write!(
                    f,
                    "{parameter} stopped at the bound {shown} of its search range: the data want a value outside it, and its uncertainty is not meaningful"
                )
            }
            Self::FewPoints { points, parameters } => write!(
                f,
                "only {points} geometries for {parameters} fitted parameters: fewer than {MIN_POINTS_PER_PARAMETER} per parameter, the uncertainties rest on very few degrees of freedom"
            ),
        }
    }
}

/// Result of the lightness fit.
#[derive(Debug, Clone, PartialEq)]
pub struct LightnessFit {
    /// Fitted hwhm of `p̃`, radians.
    pub hwhm: f64,
    /// Its standard uncertainty, radians.
    pub hwhm_std: f64,
    /// The fitted scale `s` of the reflectance factors.
    pub scale: f64,
    /// Its standard uncertainty.
    pub scale_std: f64,
    /// The clear coat's index (fitted when asked, else as given; `None` for a
    /// dispersive coat that was not fitted).
    pub n: Option<f64>,
    /// Standard uncertainty of `n` when fitted.
    pub n_std: Option<f64>,
    /// `Σ r²` at the optimum.
    pub chi2: f64,
    /// Degrees of freedom (geometries − parameters).
    pub dof: usize,
    /// Geometries used.
    pub points: usize,
    /// Iterations taken.
    pub iterations: usize,
    /// Whether every geometry had an `L*` uncertainty.
    pub uncertainties_given: bool,
    /// What the uncertainties rest on.
    pub uncertainty_basis: UncertaintyBasis,
    /// The factor applied to the standard uncertainties (`sqrt(χ²/dof)` when scaled).
    pub uncertainty_scale: f64,
    /// Per geometry: measured and fitted model CIELAB.
    pub residuals: Vec<(Geometry, Lab, Lab)>,
    /// Cautions (empty when none).
    pub warnings: Vec<LightnessFitWarning>,
}

/// Fit the Gaussian hwhm (start `hwhm_start`, radians), a common scale and, with
/// `fit_n`, the coat's index to the measured `L*` of the multi-angle `file` (its CIELAB,
/// or its spectra through the setup's colorimetry; module docs).
///
/// # Errors
/// As [`measured_colours`]; [`PipelineError::Measurement`] for too few geometries, a geometry that sees the
/// specular reflection, or `fit_n` with a dispersive coat; [`PipelineError::Fit`] when
/// the iteration does not converge or the width is not determined; the model's errors.
pub fn fit_lightness(
    file: &MultiAngleFile,
    setup: &LightnessFitSetup<'_>,
    hwhm_start: f64,
) -> Result<LightnessFit, PipelineError> {
    let measured = &measured_colours(file, setup.illuminant, setup.observer)?[..];
    let (n0, np) = check_lightness_fit(measured, setup)?;
    let have_u = measured
        .iter()
        .all(|m| m.l_uncertainty.is_some_and(|u| u > 0.0));
    let sigma: Vec<f64> = measured
        .iter()
        .map(|m| {
            if have_u {
                m.l_uncertainty.unwrap_or(1.0)
            } else {
                1.0
            }
        })
        .collect();
    let set = flakescatter_colour::GeometrySet::new(
        "measured",
        measured.iter().map(|m| m.geometry).collect(),
    )
    .map_err(|e| PipelineError::Measurement(format!("measured geometries: {e}")))?;

    // XYZ per geometry for (hwhm, n), cached: the scale needs no new model run.
    let cache: RefCell<HashMap<(u64, u64), Tristimulus>> = RefCell::new(HashMap::new());
    let xyz_of = |hwhm: f64, n: Option<f64>| -> Result<Tristimulus, PipelineError> {
        let key = (hwhm.to_bits(), n.map_or(0, f64::to_bits));
        if let Some(v) = cache.borrow().get(&key) {
            return Ok(v.clone());
        }
        let mut coating = setup.coating.clone();
        if let Some(n) = n {
            coating.coat = CoatIndex::Constant(n);
        }
        let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm))
            .map_err(|e| PipelineError::Fit(e.to_string()))?;
        let source = OrientationSource::Distribution(o);
        let m = multi_angle_colour(
            &coating,
            &setup.settings,
            MultiAngleSource::Distribution(&source),
            &set,
            setup.aperture,
            setup.wavelengths_nm,
            setup.illuminant,
            setup.observer,
            &|_, _| {},
        )?;
        let v = (
            m.geometries.iter().map(|g| g.xyz).collect::<Vec<_>>(),
            m.white,
        );
        cache.borrow_mut().insert(key, v.clone());
        Ok(v)
    };
    let labs = |q: &[f64]| -> Result<Vec<Lab>, PipelineError> {
        let (xyz, white) = xyz_of(q[0].exp(), setup.fit_n.then(|| q[2]))?;
        let s = q[1].exp();
        Ok(xyz
            .iter()
            .map(|x| {
                Xyz {
                    x: s * x.x,
                    y: s * x.y,
                    z: s * x.z,
                }
                .to_lab(&white)
            })
            .collect())
    };
    let residuals = |q: &[f64]| -> Result<Vec<f64>, PipelineError> {
        Ok(labs(q)?
            .iter()
            .zip(measured)
            .zip(&sigma)
            .map(|((l, m), s)| (l.l - m.lab.l) / s)
            .collect())
    };
    let bounds = lightness_bounds(setup.fit_n);
    let clamp = |q: &mut Vec<f64>| {
        for (v, (lo, hi, _)) in q.iter_mut().zip(&bounds) {
            *v = v.clamp(*lo, *hi);
        }
    };

    let mut q = vec![hwhm_start.max(1e-4).ln(), 0.0];
    if setup.fit_n {
        q.push(n0.unwrap_or(1.5));
    }
    clamp(&mut q);
    q[1] =
        start_log_scale(&xyz_of(q[0].exp(), setup.fit_n.then(|| q[2]))?, measured).unwrap_or(q[1]);
    clamp(&mut q);
    let m = measured.len();
    let box_: Vec<(f64, f64)> = bounds.iter().map(|&(lo, hi, _)| (lo, hi)).collect();
    let steps: Vec<f64> = (0..np).map(|j| if j == 2 { 1e-5 } else { 1e-4 }).collect();
    let fitted = lm::minimise(
        |q: &[f64]| residuals(q).map(Some),
        &q,
        &box_,
        &steps,
        lm::Settings::default(),
    )
    .map_err(lm_error)?;
    let q = fitted.x.clone();
    let iterations = fitted.iterations;
    let chi2 = fitted.chi2;
    let dof = m - np;
    let cov = fitted.covariance().ok_or_else(|| {
        PipelineError::Fit(
            "the width is not determined by these geometries (singular normal matrix)".into(),
        )
    })?;
    let reduced = chi2 / dof as f64;
    let (basis, factor) = lm::noise_scale(reduced, have_u);
    let std = |j: usize| (cov[(j, j)] * factor).max(0.0).sqrt();
    let warnings = lightness_warnings(reduced, dof, have_u, &q, &bounds, m, np);
    let hwhm = q[0].exp();
    let scale = q[1].exp();
    let fitted = labs(&q)?;
    Ok(LightnessFit {
        hwhm,
        // d(hwhm) = hwhm d(ln hwhm), and likewise for the scale.
        hwhm_std: hwhm * std(0),
        scale,
        scale_std: scale * std(1),
        n: if setup.fit_n { Some(q[2]) } else { n0 },
        n_std: setup.fit_n.then(|| std(2)),
        chi2,
        dof,
        points: m,
        iterations,
        uncertainties_given: have_u,
        uncertainty_basis: basis,
        uncertainty_scale: factor.sqrt(),
        residuals: measured
            .iter()
            .zip(fitted)
            .map(|(mg, l)| (mg.geometry, mg.lab, l))
            .collect(),
        warnings,
    })
}

/// `Y/Yn` of a lightness `L*` (the inverse of the CIE 1976 lightness).
fn inverse_lightness(l: f64) -> f64 {
    let f = (l + 16.0) / 116.0;
    let d = 6.0 / 29.0;
    if f > d {
        f * f * f
    } else {
        3.0 * d * d * (f - 4.0 / 29.0)
    }
}

/// The checks of [`fit_lightness`] before any model run: a constant coat index when `n`
/// is fitted, no geometry with the specular direction inside its cone, more geometries
/// than parameters. Returns the fixed index (`None` for a dispersive coat that is not
/// fitted) and the number of parameters.
fn check_lightness_fit(
    measured: &[MeasuredGeometry],
    setup: &LightnessFitSetup<'_>,
) -> Result<(Option<f64>, usize), PipelineError> {
    let n0 = match (&setup.coating.coat, setup.fit_n) {
        (CoatIndex::Constant(n), _) => Some(*n),
        (_, true) => {
            return Err(PipelineError::Measurement(
                "fitting n fits one constant clear-coat index; the coat is dispersive (Cauchy or a table): fix its dispersion or fit without n".into(),
            ));
        }
        _ => None,
    };
    for m in measured {
        if m.geometry.aspecular().abs() <= setup.aperture {
            return Err(PipelineError::Measurement(format!(
                "line {}: the geometry at {:.6}° aspecular has the specular direction inside its {:.6}° cone; the L* fit scales the flakes' light and would scale the clear coat's reflection with it: leave that geometry out",
                m.line,
                m.geometry.aspecular().to_degrees(),
                setup.aperture.to_degrees()
            )));
        }
    }
    let np = if setup.fit_n { 3 } else { 2 };
    if measured.len() <= np {
        return Err(PipelineError::Measurement(format!(
            "{} geometries are too few to fit {np} parameters (width, scale{})",
            measured.len(),
            if setup.fit_n { ", n" } else { "" }
        )));
    }
    Ok((n0, np))
}

/// The warnings of a finished L* fit: a poor fit (`reduced` χ²/dof above the 99.9 %
/// point with uncertainties, rms above [`POOR_FIT_RMS_L`] without), a parameter on a
/// bound of `bounds` (log-parameters reported as values), too few points per parameter.
fn lightness_warnings(
    reduced: f64,
    dof: usize,
    have_u: bool,
    q: &[f64],
    bounds: &[(f64, f64, &'static str)],
    m: usize,
    np: usize,
) -> Vec<LightnessFitWarning> {
    let mut warnings = Vec::new();
    let threshold = if have_u {
        chi2_per_dof_999(dof)
    } else {
        POOR_FIT_RMS_L * POOR_FIT_RMS_L
    };
    if reduced > threshold {
        warnings.push(LightnessFitWarning::PoorFit {
            chi2_per_dof: reduced,
            threshold,
            uncertainties_given: have_u,
        });
    }
    for (j, (lo, hi, name)) in bounds.iter().enumerate() {
        if q[j] <= *lo || q[j] >= *hi {
            let at = if q[j] <= *lo { *lo } else { *hi };
            warnings.push(LightnessFitWarning::AtBound {
                parameter: name,
                bound: if j < 2 { at.exp() } else { at },
            });
        }
    }
    if m < MIN_POINTS_PER_PARAMETER * np {
        warnings.push(LightnessFitWarning::FewPoints {
            points: m,
            parameters: np,
        });
    }
    warnings
}

/// The start of the log-scale: the mean log ratio of the luminance factors the
/// measured `L*` imply to those of the model `(xyz, white)` at the start width, `None`
/// when no geometry gives a finite positive ratio.
fn start_log_scale((xyz, white): &Tristimulus, measured: &[MeasuredGeometry]) -> Option<f64> {
    let ratios: Vec<f64> = xyz
        .iter()
        .zip(measured)
        .map(|(x, m)| inverse_lightness(m.lab.l) * white.y / x.y)
        .filter(|r| r.is_finite() && *r > 0.0)
        .map(f64::ln)
        .collect();
    (!ratios.is_empty()).then(|| ratios.iter().sum::<f64>() / ratios.len() as f64)
}

/// The bounds of the fitted parameters `(ln hwhm, ln scale[, n])` with their names:
/// hwhm 0.05°–60°, scale 1e-3–1e3, n 1–3.
fn lightness_bounds(fit_n: bool) -> Vec<(f64, f64, &'static str)> {
    let mut b = vec![
        (0.05f64.to_radians().ln(), 60f64.to_radians().ln(), "hwhm"),
        (1e-3f64.ln(), 1e3f64.ln(), "scale"),
    ];
    if fit_n {
        b.push((1.0, 3.0, "n"));
    }
    b
}

/// The minimiser's failure as the fit's error.
fn lm_error(e: LmError<PipelineError>) -> PipelineError {
    match e {
        LmError::Model(e) => e,
        LmError::NotConverged { iterations, x } => PipelineError::Fit(format!(
            "the L* fit did not converge in {iterations} iterations (last hwhm {:.3}°); try another start width",
            x[0].exp().to_degrees()
        )),
        other => PipelineError::Fit(format!("the L* fit failed: {other}")),
    }
}
