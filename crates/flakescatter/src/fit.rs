//! Fitting the flake orientation distribution to a measured curve (physics.md §7):
//! the Gaussian width (with the vertical scale, and optionally the index) by
//! Levenberg–Marquardt on log values, and a non-parametric tabulated `p̃` by
//! regularised non-negative least squares — the paper's "estimate the distribution
//! that can give rise to a measured reflectance curve".
//!
//! Conventions: radians; the points used are those whose aspecular distance
//! `|θs + θi|` lies in the fit region (default 5°–40°: the specular peak of the clear
//! coat is excluded). Residuals are `(ln y − ln(s·m))/σ` with `σ = u/y` when the file
//! gives uncertainties `u`, else 1. The vertical scale `s` is profiled out in closed form
//! (weighted mean of log ratios), per incidence or common to all.
//!
//! Uncertainties of the Gaussian fit: the covariance `(JᵀJ)⁻¹` at the optimum is scaled
//! by the reduced `χ²/dof` when the file gives no uncertainties (the residual scatter is
//! then the only noise estimate) **and** when it gives uncertainties but `χ²/dof > 1`
//! (the stated uncertainties are too small for the scatter seen, or the model misses
//! something: either way the scatter is the better estimate). It is never scaled down.
//! [`GaussianFit::uncertainty_basis`] says which; a seeded simulation in the facade's
//! tests checks that the reported 68 % interval covers the truth when the stated
//! uncertainties are 3× too small. [`GaussianFit::warnings`] flags a poor fit (`χ²/dof`
//! above the 99.9 % point of `χ²_dof/dof` with uncertainties, Wilson–Hilferty; an rms
//! log residual above [`POOR_FIT_RMS_LOG`] without), a parameter held at a bound of its
//! search range, and fewer than [`MIN_POINTS_PER_PARAMETER`] points per fitted
//! parameter (scales included).

use flakescatter_io::measured::MeasuredCurve;
use flakescatter_stats::{GaussianWidth, Orientation};
use nalgebra::{DMatrix, DVector};

use crate::PipelineError;
use crate::compare::{MeasuredKind, ModelPoint, distribution_points};
use crate::pipeline::{Coating, Settings};
use flakescatter_numerics::lm::{self, LmError};
pub use flakescatter_numerics::lm::{UncertaintyBasis, chi2_per_dof_999};
use flakescatter_numerics::nnls::nnls;

/// What the fit uses.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSetup {
    /// The coating (its `n` is the start value when `fit_n`).
    pub coating: Coating,
    /// Model settings (clear coat, Fresnel, weighting, cone method).
    pub settings: Settings,
    /// Detector half-angle of the measurement, radians.
    pub aperture: f64,
    /// What the measured values are.
    pub kind: MeasuredKind,
    /// Aspecular range of the points used, radians (default 5°–40°).
    pub region: (f64, f64),
    /// One vertical scale for all incidences (`true`) or one per incidence.
    pub common_scale: bool,
}

impl FitSetup {
    /// Defaults: 5°–40° region, one scale per incidence.
    #[must_use]
    pub fn new(coating: Coating, settings: Settings, aperture: f64, kind: MeasuredKind) -> Self {
        Self {
            coating,
            settings,
            aperture,
            kind,
            region: (crate::compare::SPECULAR_REGION, crate::compare::FAR_REGION),
            common_scale: false,
        }
    }
}

/// A point used by a fit.
#[derive(Debug, Clone, Copy)]
struct Used {
    theta_i: f64,
    theta_s: f64,
    ln_y: f64,
    sigma: f64,
    group: usize,
}

/// Select the points of `measured` in the fit region; error when nothing is left.
fn select(
    measured: &MeasuredCurve,
    setup: &FitSetup,
) -> Result<(Vec<Used>, Vec<f64>, bool), PipelineError> {
    if setup.common_scale && setup.kind == MeasuredKind::Relative {
        return Err(PipelineError::Measurement(format!(
            "{}: relative values are normalised per incidence; a common scale needs brdf or reflectance-factor data",
            measured.file
        )));
    }
    let incidences = measured.incidences();
    let mut used = Vec::new();
    let mut have_u = true;
    for p in &measured.points {
        let d = (p.theta_s + p.theta_i).abs();
        if d < setup.region.0 - 1e-12 || d > setup.region.1 + 1e-12 {
            continue;
        }
        if !(p.value > 0.0) {
            return Err(PipelineError::Measurement(format!(
                "{}, line {}: value {} is not positive; a log fit needs positive values",
                measured.file, p.line, p.value
            )));
        }
        // A curve with an uncertainty column has one > 0 on every point (the reader
        // refuses others); a zero in a curve built in code is refused here too, not read
        // as "no uncertainties" for the whole curve.
        let sigma = match p.uncertainty {
            Some(u) if u > 0.0 && u.is_finite() => u / p.value,
            Some(u) => {
                return Err(PipelineError::Measurement(format!(
                    "{}, line {}, column uncertainty: {u} is not a positive finite standard uncertainty",
                    measured.file, p.line
                )));
            }
            None => {
                have_u = false;
                1.0
            }
        };
        let group = if setup.common_scale {
            0
        } else {
            incidences.iter().position(|&t| t == p.theta_i).unwrap_or(0)
        };
        used.push(Used {
            theta_i: p.theta_i,
            theta_s: p.theta_s,
            ln_y: p.value.ln(),
            sigma,
            group,
        });
    }
    // Only incidences with points in the region get a scale (and count as parameters).
    let incidences: Vec<f64> = incidences
        .into_iter()
        .filter(|&t| used.iter().any(|u| u.theta_i == t))
        .collect();
    for u in &mut used {
        if !setup.common_scale {
            u.group = incidences.iter().position(|&t| t == u.theta_i).unwrap_or(0);
        }
    }
    if used.is_empty() {
        return Err(PipelineError::Measurement(format!(
            "{}: no measured point between {:.1}° and {:.1}° from specular; widen the fit region or measure there",
            measured.file,
            setup.region.0.to_degrees(),
            setup.region.1.to_degrees()
        )));
    }
    Ok((used, incidences, have_u))
}

/// Model values (in the measured kind) at the used points for a given distribution and
/// index.
fn model_values(
    used: &[Used],
    incidences: &[f64],
    setup: &FitSetup,
    orientation: &Orientation,
    n: f64,
    pick: &dyn Fn(&ModelPoint) -> f64,
) -> Result<Vec<f64>, PipelineError> {
    let coating = Coating {
        n,
        ..setup.coating.clone()
    };
    let mut out = vec![0.0; used.len()];
    for &ti in incidences {
        let idx: Vec<usize> = (0..used.len()).filter(|&k| used[k].theta_i == ti).collect();
        if idx.is_empty() {
            continue;
        }
        let ts: Vec<f64> = idx.iter().map(|&k| used[k].theta_s).collect();
        let pts = distribution_points(
            &coating,
            &setup.settings,
            setup.aperture,
            orientation,
            ti,
            &ts,
        )?;
        for (k, p) in idx.iter().zip(pts) {
            out[*k] = pick(&p);
        }
    }
    Ok(out)
}

/// Weighted residuals and log scales, or `None` where the model vanishes.
type Residuals = Option<(Vec<f64>, Vec<f64>)>;

/// Weighted residuals with the scales profiled out; returns `(residuals, ln scales)`.
fn residuals(used: &[Used], model: &[f64], groups: usize) -> Residuals {
    let mut num = vec![0.0; groups];
    let mut den = vec![0.0; groups];
    for (u, &m) in used.iter().zip(model) {
        if !(m > 0.0) {
            return None;
        }
        let w = 1.0 / (u.sigma * u.sigma);
        num[u.group] += w * (u.ln_y - m.ln());
        den[u.group] += w;
    }
    let ln_s: Vec<f64> = num
        .iter()
        .zip(&den)
        .map(|(n, d)| if *d > 0.0 { n / d } else { 0.0 })
        .collect();
    let r = used
        .iter()
        .zip(model)
        .map(|(u, &m)| (u.ln_y - ln_s[u.group] - m.ln()) / u.sigma)
        .collect();
    Some((r, ln_s))
}

/// Fewer points than this per fitted parameter (width, index, scales) earn a
/// [`FitWarning::FewPoints`].
pub const MIN_POINTS_PER_PARAMETER: usize = 3;

/// Without stated uncertainties, an rms residual of `ln y` above this (about 35 %
/// scatter) earns a [`FitWarning::PoorFit`].
pub const POOR_FIT_RMS_LOG: f64 = 0.3;

/// Why a fit result deserves caution.
#[derive(Debug, Clone, PartialEq)]
pub enum FitWarning {
    /// The model does not describe the data: `χ²/dof` above `threshold` (the 99.9 % point
    /// of `χ²_dof/dof` with stated uncertainties; `POOR_FIT_RMS_LOG²` without).
    PoorFit {
        /// Reduced χ² at the optimum.
        chi2_per_dof: f64,
        /// The threshold it exceeds.
        threshold: f64,
        /// Whether the file gave uncertainties.
        uncertainties_given: bool,
    },
    /// A parameter ended on a bound of its search range, where its uncertainty means
    /// little (`hwhm` in [0.05°, 60°], `n` in [1, 3]).
    AtBound {
        /// `"hwhm"` or `"n"`.
        parameter: &'static str,
        /// The bound, radians for `hwhm`.
        bound: f64,
    },
    /// Fewer than [`MIN_POINTS_PER_PARAMETER`] points per fitted parameter.
    FewPoints {
        /// Points used.
        points: usize,
        /// Fitted parameters (width, index, scales).
        parameters: usize,
    },
}

impl std::fmt::Display for FitWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::PoorFit {
                chi2_per_dof,
                threshold,
                uncertainties_given: true,
            } => write!(
                f,
                "poor fit: chi2/dof = {chi2_per_dof:.3} is above {threshold:.3} (the 99.9 % point for these degrees of freedom); the model does not describe the data within their uncertainties, so the width's uncertainty was scaled by sqrt(chi2/dof) and the width itself may be biased"
            ),
            Self::PoorFit { chi2_per_dof, .. } => write!(
                f,
                "poor fit: the rms residual of ln(value) is {:.3} (above {POOR_FIT_RMS_LOG}); the model describes the data poorly and the width may be biased",
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
                "only {points} points for {parameters} fitted parameters (width, index, scales): fewer than {MIN_POINTS_PER_PARAMETER} per parameter, the uncertainties rest on very few degrees of freedom"
            ),
        }
    }
}

/// Result of the Gaussian width fit.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussianFit {
    /// Fitted half-width at half-maximum of `p̃`, radians.
    pub hwhm: f64,
    /// Its standard uncertainty, radians (scaled as [`GaussianFit::uncertainty_basis`]
    /// says).
    pub hwhm_std: f64,
    /// Clear-coat index (fitted when asked, else as given).
    pub n: f64,
    /// Standard uncertainty of `n` when fitted.
    pub n_std: Option<f64>,
    /// Fitted vertical scales `(θi, scale)` (one entry with `θi = NaN` when common).
    pub scales: Vec<(f64, f64)>,
    /// `Σ r²` at the optimum.
    pub chi2: f64,
    /// Degrees of freedom (points − parameters − scales).
    pub dof: usize,
    /// Points used.
    pub points: usize,
    /// Levenberg–Marquardt iterations taken.
    pub iterations: usize,
    /// Whether uncertainties came from the file.
    pub uncertainties_given: bool,
    /// What the uncertainties rest on (module docs).
    pub uncertainty_basis: UncertaintyBasis,
    /// The factor applied to the standard uncertainties from `(JᵀJ)⁻¹`: `sqrt(χ²/dof)`
    /// when scaled, else 1.
    pub uncertainty_scale: f64,
    /// Cautions about this result (empty when none).
    pub warnings: Vec<FitWarning>,
}

/// Fit a Gaussian `p̃` (its `hwhm`, the vertical scale(s), and `n` when `fit_n`) to the
/// measured curve, starting from `hwhm_start` (radians).
///
/// # Errors
/// [`PipelineError::Measurement`] for unusable data; [`PipelineError::Fit`] when the
/// iteration does not converge or the problem is degenerate.
pub fn fit_gaussian(
    measured: &MeasuredCurve,
    setup: &FitSetup,
    hwhm_start: f64,
    fit_n: bool,
) -> Result<GaussianFit, PipelineError> {
    let (used, incidences, have_u) = select(measured, setup)?;
    let groups = if setup.common_scale {
        1
    } else {
        incidences.len()
    };
    let np = if fit_n { 2 } else { 1 };
    if used.len() <= np + groups {
        return Err(PipelineError::Measurement(format!(
            "{}: {} points in the fit region are too few for {} parameters and {} scale(s)",
            measured.file,
            used.len(),
            np,
            groups
        )));
    }
    let (w_lo, w_hi) = (0.05f64.to_radians().ln(), 60f64.to_radians().ln());
    let mut bounds = vec![(w_lo, w_hi)];
    let mut steps = vec![1e-4];
    if fit_n {
        bounds.push((1.0, 3.0));
        steps.push(1e-5);
    }
    let eval = |q: &[f64]| -> Result<Residuals, PipelineError> {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(q[0].exp()))
            .map_err(|e| PipelineError::Fit(e.to_string()))?;
        let n = if fit_n { q[1] } else { setup.coating.n };
        let m = model_values(&used, &incidences, setup, &o, n, &|p| p.in_kind(setup.kind))?;
        Ok(residuals(&used, &m, groups))
    };
    let mut q0 = vec![hwhm_start.max(1e-4).ln()];
    if fit_n {
        q0.push(setup.coating.n);
    }
    let fitted = lm::minimise(
        |q: &[f64]| Ok(eval(q)?.map(|(r, _)| r)),
        &q0,
        &bounds,
        &steps,
        lm::Settings::default(),
    )
    .map_err(|e| match e {
        LmError::Model(e) => e,
        LmError::VanishedAtStart => PipelineError::Fit(
            "the model is zero at some fitted point for the start value; try another --hwhm-start"
                .into(),
        ),
        LmError::VanishedDifferentiating => PipelineError::Fit(
            "the model vanished at a fitted point while differentiating".into(),
        ),
        LmError::NotConverged { iterations, x } => PipelineError::Fit(format!(
            "the width fit did not converge in {iterations} iterations (last hwhm {:.3}°); try another --hwhm-start or a narrower region",
            x[0].exp().to_degrees()
        )),
        LmError::Arguments(m) => PipelineError::Fit(m),
    })?;
    let q = &fitted.x;
    let iterations = fitted.iterations;
    let (_, ln_s) =
        eval(q)?.ok_or_else(|| PipelineError::Fit("model vanished at the optimum".into()))?;
    let chi2 = fitted.chi2;
    let dof = used.len() - np - groups;
    let cov = fitted.covariance().ok_or_else(|| {
        PipelineError::Fit(
            "the width is not determined by these points (singular normal matrix)".into(),
        )
    })?;
    let reduced = chi2 / dof as f64;
    let (basis, factor) = lm::noise_scale(reduced, have_u);
    let mut warnings = Vec::new();
    let threshold = if have_u {
        chi2_per_dof_999(dof)
    } else {
        POOR_FIT_RMS_LOG * POOR_FIT_RMS_LOG
    };
    if reduced > threshold {
        warnings.push(FitWarning::PoorFit {
            chi2_per_dof: reduced,
            threshold,
            uncertainties_given: have_u,
        });
    }
    for (j, (lo, hi, name)) in [(w_lo, w_hi, "hwhm"), (1.0, 3.0, "n")]
        .into_iter()
        .enumerate()
        .take(np)
    {
        if q[j] <= lo || q[j] >= hi {
            let at = if q[j] <= lo { lo } else { hi };
            warnings.push(FitWarning::AtBound {
                parameter: name,
                bound: if j == 0 { at.exp() } else { at },
            });
        }
    }
    if used.len() < MIN_POINTS_PER_PARAMETER * (np + groups) {
        warnings.push(FitWarning::FewPoints {
            points: used.len(),
            parameters: np + groups,
        });
    }
    let w = q[0].exp();
    let scales = if setup.common_scale {
        vec![(f64::NAN, ln_s[0].exp())]
    } else {
        incidences
            .iter()
            .zip(&ln_s)
            .map(|(&t, &l)| (t, l.exp()))
            .collect()
    };
    Ok(GaussianFit {
        hwhm: w,
        hwhm_std: w * (cov[(0, 0)] * factor).sqrt(),
        n: if fit_n { q[1] } else { setup.coating.n },
        n_std: fit_n.then(|| (cov[(1, 1)] * factor).sqrt()),
        scales,
        chi2,
        dof,
        points: used.len(),
        iterations,
        uncertainties_given: have_u,
        uncertainty_basis: basis,
        uncertainty_scale: factor.sqrt(),
        warnings,
    })
}

/// Result of the non-parametric inversion.
#[derive(Debug, Clone)]
pub struct NonParametricFit {
    /// Bin edges, radians.
    pub edges: Vec<f64>,
    /// Area fraction per bin (sums to 1).
    pub area_fractions: Vec<f64>,
    /// `p̃` per bin, normalised so that `∫ p̃ sin θ dθ = 1`.
    pub p_tilde: Vec<f64>,
    /// Regularisation weight used (relative to the data rows' scale).
    pub lambda: f64,
    /// Weighted `Σ r²` of the data rows at the solution (relative residuals).
    pub chi2: f64,
    /// Points used.
    pub points: usize,
    /// The estimate as a tabulated distribution.
    pub orientation: Orientation,
}

/// Estimate a tabulated `p̃` on the bins `edges` (radians, increasing, within
/// `[0, π/2]`) from the measured curve: the model is linear in the bin masses (up to the
/// scale), so the masses solve a non-negative least-squares problem with a second-
/// difference smoothness penalty of relative weight `lambda` on `p̃`. Per-incidence
/// scales (when not common) are found by alternating with the NNLS solve.
///
/// # Errors
/// [`PipelineError::Measurement`] for unusable data, [`PipelineError::Fit`] for bad
/// bins or a failed solve.
pub fn fit_nonparametric(
    measured: &MeasuredCurve,
    setup: &FitSetup,
    edges: &[f64],
    lambda: f64,
) -> Result<NonParametricFit, PipelineError> {
    if edges.len() < 2
        || edges.windows(2).any(|w| !(w[1] > w[0]))
        || edges[0] < 0.0
        || edges[edges.len() - 1] > std::f64::consts::FRAC_PI_2
    {
        return Err(PipelineError::Fit(
            "bin edges must increase within [0, 90°]".into(),
        ));
    }
    if !(lambda.is_finite() && lambda >= 0.0) {
        return Err(PipelineError::Fit(format!(
            "regularisation {lambda} must be finite and >= 0"
        )));
    }
    let (used, incidences, _) = select(measured, setup)?;
    let nb = edges.len() - 1;
    let groups = if setup.common_scale {
        1
    } else {
        incidences.len()
    };
    // Column b: the model for all flakes in bin b, times that bin's ⟨cos θn⟩, so that a
    // mixture with masses μ_b and scale s is Σ_b x_b A_b with x_b = s μ_b / ⟨cos⟩.
    // Columns must be linear in the bin masses: no clear-coat term (a constant in the
    // specular cone), and for relative data the un-normalised collected power (each
    // column's own specular value is not the mixture's; the per-incidence scale absorbs
    // the normalisation).
    let columns = FitSetup {
        settings: Settings {
            clearcoat: false,
            ..setup.settings
        },
        ..setup.clone()
    };
    let kind = setup.kind;
    let pick = move |p: &ModelPoint| match kind {
        MeasuredKind::Relative => p.power,
        other => p.in_kind(other),
    };
    let mut a = DMatrix::<f64>::zeros(used.len(), nb);
    for b in 0..nb {
        let mut mass = vec![0.0; nb];
        mass[b] = 1.0;
        let o = Orientation::tabulated(edges.to_vec(), mass)
            .map_err(|e| PipelineError::Fit(e.to_string()))?;
        let col = model_values(&used, &incidences, &columns, &o, setup.coating.n, &pick)?;
        for (k, v) in col.iter().enumerate() {
            a[(k, b)] = v * o.mean_cos();
        }
    }
    let y: Vec<f64> = used.iter().map(|u| u.ln_y.exp()).collect();
    let dcos: Vec<f64> = (0..nb)
        .map(|b| edges[b].cos() - edges[b + 1].cos())
        .collect();
    // Relative residuals: row k divided by σ_k y_k.
    let wrow: Vec<f64> = used
        .iter()
        .zip(&y)
        .map(|(u, y)| 1.0 / (u.sigma * y))
        .collect();
    let mut scale_g = vec![1.0; groups];
    let mut x = DVector::<f64>::zeros(nb);
    let nrows = used.len() + nb.saturating_sub(2);
    for _ in 0..(if groups > 1 { 30 } else { 1 }) {
        let mut m = DMatrix::<f64>::zeros(nrows, nb);
        let mut rhs = DVector::<f64>::zeros(nrows);
        for k in 0..used.len() {
            let s = scale_g[used[k].group] * wrow[k];
            for b in 0..nb {
                m[(k, b)] = a[(k, b)] * s;
            }
            rhs[k] = y[k] * wrow[k];
        }
        // Smoothness of p̃_b ∝ x_b / Δcos_b, scaled to the data block.
        let data_norm = m.rows(0, used.len()).norm() / (used.len() as f64).sqrt();
        for b in 1..nb.saturating_sub(1) {
            let r = used.len() + b - 1;
            let l = lambda * data_norm * dcos[b];
            m[(r, b - 1)] = l / dcos[b - 1];
            m[(r, b)] = -2.0 * l / dcos[b];
            m[(r, b + 1)] = l / dcos[b + 1];
        }
        x = nnls(&m, &rhs).ok_or_else(|| {
            PipelineError::Fit("the non-negative least-squares solve did not converge".into())
        })?;
        if groups == 1 {
            break;
        }
        // Per-group scales (closed form weighted least squares), normalised to the first.
        let ax = &a * &x;
        for (g, sc) in scale_g.iter_mut().enumerate() {
            let (mut num, mut den) = (0.0, 0.0);
            for k in (0..used.len()).filter(|&k| used[k].group == g) {
                let w2 = wrow[k] * wrow[k];
                num += w2 * y[k] * ax[k];
                den += w2 * ax[k] * ax[k];
            }
            if den > 0.0 {
                *sc = num / den;
            }
        }
    }
    let total: f64 = x.iter().sum();
    if !(total > 0.0) {
        return Err(PipelineError::Fit("the inversion found no flakes (all bin masses zero); check the fit region and the data".into()));
    }
    let fractions: Vec<f64> = x.iter().map(|v| v / total).collect();
    let p_tilde: Vec<f64> = fractions.iter().zip(&dcos).map(|(f, d)| f / d).collect();
    let ax = &a * &x;
    let chi2 = (0..used.len())
        .map(|k| ((y[k] - scale_g[used[k].group] * ax[k]) * wrow[k]).powi(2))
        .sum();
    let orientation = Orientation::tabulated(edges.to_vec(), fractions.clone())
        .map_err(|e| PipelineError::Fit(e.to_string()))?;
    Ok(NonParametricFit {
        edges: edges.to_vec(),
        area_fractions: fractions,
        p_tilde,
        lambda,
        chi2,
        points: used.len(),
        orientation,
    })
}
