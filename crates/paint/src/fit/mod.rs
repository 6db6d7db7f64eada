//! The joint fit of a paint to a measured BRDF table (physics.md §12.5): one parameter
//! set for every incidence and every row, in and out of the plane.
//!
//! The orientation distribution, the coat surface (and index, optionally) are shared by
//! every channel; each channel has a flake and a base amplitude. Residuals are
//! `(ln m − ln y)/σ` with `σ = u/y` from the table's uncertainty columns, or `σ = 1` for
//! every point without them (relative weighting: every point counts the same in log).
//! The minimiser is [`flakescatter_numerics::lm`]. The log-linear table adds penalty rows
//! `λ · Δ(d ln p̃/dθ)` at its inner knots (`λ` = [`FitOptions::smoothing`]).
//!
//! **Coverage.** The BRDF depends on the coverage `c` only through `c s_k` and
//! `(1 − c)² ρ_k` (physics.md §12.5): a table cannot tell more flakes of a duller metal
//! from fewer bright ones. So the fit estimates these amplitudes, reports the interval
//! of `c` in which every `s_k ≤ 1` and `ρ_k ≤ 1`, and gives `s_k`, `ρ_k` at a coverage:
//! the one given ([`FitOptions::coverage`], e.g. measured on a confocal map), or the
//! interval's middle. When the interval is empty the fit is repeated at the coverage
//! closest to both conditions with `s_k`, `ρ_k` held in `[0, 1]`, and warns.
//!
//! **Uncertainties.** `(JᵀJ)⁻¹` at the optimum, scaled by `χ²/dof` as
//! [`flakescatter_numerics::lm::noise_scale`] says; 95 % intervals are
//! `estimate ± t(0.975, dof) σ` in the fitted (mostly logarithmic) parameters, mapped to
//! the physical ones (so they are asymmetric for `ln` parameters); correlations of the
//! fitted parameters. Warnings flag a poor fit, a parameter on a bound, few points per
//! parameter, an empty coverage interval and parameters known to less than ±50 %.

pub mod data;
mod engine;
mod layout;
pub mod report;

use flakescatter_numerics::lm::{self, LmError, UncertaintyBasis};
use flakescatter_numerics::nnls::nnls;
use flakescatter_stats::Orientation;
use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::PaintError;
use crate::coat::CoatParams;
use crate::model::{ChannelParams, FlakeMetal, PaintParams};
pub use data::{Measurement, Observation, Point, Selection, select};
use engine::Engine;
pub use layout::Family;
use layout::{Amplitudes, Layout};
pub use report::{Evidence, GroupResidual, Region, group_residuals};

/// Options of the joint fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Families to fit; the one with the lowest BIC is kept (all are reported).
    pub families: Vec<Family>,
    /// Coat index (the start value when fitted).
    pub n: f64,
    /// Fit the coat index too.
    pub fit_n: bool,
    /// The flakes' coverage, if known (module docs); `None`: the middle of the interval
    /// the data allow.
    pub coverage: Option<f64>,
    /// The flake metal.
    pub flake_metal: FlakeMetal,
    /// The points used.
    pub selection: Selection,
    /// Fit a haze population of the coat surface (default on).
    pub haze: bool,
    /// `λ` of the log-linear table's smoothness penalty (default 0.01).
    pub smoothing: f64,
}

impl FitOptions {
    /// Defaults: every family, `n` = 1.5 fixed, aluminium flakes, the default selection,
    /// haze fitted, `λ` = 0.01.
    #[must_use]
    pub fn new() -> Self {
        Self {
            families: Family::all(),
            n: 1.5,
            fit_n: false,
            coverage: None,
            flake_metal: FlakeMetal::Aluminium,
            selection: Selection::default(),
            haze: true,
            smoothing: 0.01,
        }
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        Self::new()
    }
}

/// A fitted or derived parameter with its uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Its name, with its unit where it has one (`"coat roughness"`, `"hwhm (rad)"`).
    pub name: String,
    /// The value.
    pub value: f64,
    /// Standard uncertainty (linearised); NaN for a parameter held on a bound of its
    /// range or not determined by the points (a warning says which).
    pub std: f64,
    /// Lower end of the 95 % interval.
    pub lo95: f64,
    /// Upper end of the 95 % interval.
    pub hi95: f64,
}

/// How the coverage was chosen (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoverageChoice {
    /// The coverage of [`PaintFit::params`].
    pub used: f64,
    /// The smallest coverage with every flake scale `≤ 1`.
    pub min: f64,
    /// The largest coverage with every base albedo `≤ 1`.
    pub max: f64,
    /// `true` when it was given, not chosen.
    pub given: bool,
}

/// Why a fit deserves caution.
#[derive(Debug, Clone, PartialEq)]
pub enum PaintFitWarning {
    /// `χ²/dof` above `threshold` (the 99.9 % point with stated uncertainties; an rms
    /// `ln` residual of 0.3 without).
    PoorFit {
        /// Reduced χ².
        chi2_per_dof: f64,
        /// The threshold.
        threshold: f64,
        /// Whether the table gave uncertainties.
        uncertainties_given: bool,
    },
    /// A parameter ended on a bound of its range.
    AtBound {
        /// Its name.
        parameter: String,
        /// The bound (in the fitted parameter's own units).
        bound: f64,
    },
    /// Fewer than three points per parameter.
    FewPoints {
        /// Points.
        points: usize,
        /// Parameters.
        parameters: usize,
    },
    /// No coverage makes every flake scale and base albedo physical.
    CoverageInfeasible {
        /// Flakes need at least this coverage.
        min: f64,
        /// The base needs at most this one.
        max: f64,
    },
    /// A free parameter the points do not determine (the others explain its effect).
    Undetermined {
        /// Its name.
        parameter: String,
    },
    /// A parameter known to less than ±50 % (relative standard uncertainty).
    Shaky {
        /// Its name.
        parameter: String,
        /// `σ/|value|`.
        relative: f64,
    },
}

impl std::fmt::Display for PaintFitWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::PoorFit {
                chi2_per_dof,
                threshold,
                uncertainties_given: true,
            } => write!(
                f,
                "poor fit: chi2/dof = {chi2_per_dof:.3} is above {threshold:.3} (the 99.9 % point): the model does not describe the table within its uncertainties; the uncertainties were scaled by sqrt(chi2/dof)"
            ),
            Self::PoorFit { chi2_per_dof, .. } => write!(
                f,
                "poor fit: the rms residual of ln(value) is {:.3} (above 0.3): the model describes the table poorly",
                chi2_per_dof.sqrt()
            ),
            Self::AtBound { parameter, bound } => write!(
                f,
                "{parameter} stopped at the bound {bound} of its range: the data want a value outside it, and its uncertainty means little"
            ),
            Self::FewPoints { points, parameters } => write!(
                f,
                "only {points} points for {parameters} parameters: fewer than 3 per parameter"
            ),
            Self::CoverageInfeasible { min, max } => write!(
                f,
                "no flake coverage explains the table with physical flakes and base: the flakes need a coverage of at least {min:.4} (flake scale <= 1), the base at most {max:.4} (albedo <= 1); refitted at the closest coverage with both held physical"
            ),
            Self::Undetermined { parameter } => write!(
                f,
                "{parameter} is not determined by these points (other parameters explain its effect); its uncertainty is not given"
            ),
            Self::Shaky {
                parameter,
                relative,
            } => write!(
                f,
                "{parameter} is poorly determined: its standard uncertainty is {:.0} % of its value",
                100.0 * relative
            ),
        }
    }
}

/// The fit of one family.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The family.
    pub family: Family,
    /// Its evidence.
    pub evidence: Evidence,
}

/// The result of the joint fit.
#[derive(Debug, Clone)]
pub struct PaintFit {
    /// The family kept (lowest BIC).
    pub family: Family,
    /// The fitted paint, at the coverage of [`PaintFit::coverage`].
    pub params: PaintParams,
    /// The fitted parameters as fitted (mostly logarithms), with 95 % intervals.
    pub fitted: Vec<Estimate>,
    /// Correlations of [`PaintFit::fitted`], row-major.
    pub correlation: Vec<Vec<f64>>,
    /// The physical parameters derived from them, with 95 % intervals.
    pub physical: Vec<Estimate>,
    /// The coverage.
    pub coverage: CoverageChoice,
    /// Evidence of the family kept.
    pub evidence: Evidence,
    /// Every family fitted, in order.
    pub candidates: Vec<Candidate>,
    /// Degrees of freedom (points − parameters).
    pub dof: usize,
    /// Whether every point used had a stated uncertainty (else relative weighting).
    pub uncertainties_given: bool,
    /// What the uncertainties rest on, and the factor applied to `(JᵀJ)⁻¹`.
    pub uncertainty_basis: UncertaintyBasis,
    /// `sqrt` of that factor.
    pub uncertainty_scale: f64,
    /// The points used.
    pub points: Vec<Point>,
    /// The model at each point, sr⁻¹.
    pub model: Vec<f64>,
    /// Residual groups over the points used.
    pub groups: Vec<GroupResidual>,
    /// Levenberg–Marquardt iterations of the family kept.
    pub iterations: usize,
    /// Cautions.
    pub warnings: Vec<PaintFitWarning>,
}

/// One family's converged fit.
struct Solved {
    layout: Layout,
    fit: lm::Fit,
    orientation: Orientation,
    model: Vec<f64>,
    evidence: Evidence,
}

/// Fit `m` (module docs).
///
/// # Errors
/// [`PaintError::Data`] for unusable data (named file, line, column), too few points;
/// [`PaintError::Parameter`] for bad options; [`PaintError::Fit`] when no family
/// converges.
pub fn fit_paint(m: &Measurement, opts: &FitOptions) -> Result<PaintFit, PaintError> {
    if opts.families.is_empty() {
        return Err(PaintError::Parameter("no orientation family to fit".into()));
    }
    if let Some(c) = opts.coverage
        && !(0.0..=1.0).contains(&c)
    {
        return Err(PaintError::Parameter(format!(
            "coverage = {c}: expected a fraction in [0, 1]"
        )));
    }
    if !(opts.smoothing.is_finite() && opts.smoothing >= 0.0) {
        return Err(PaintError::Parameter(format!(
            "smoothing = {}: expected a finite value >= 0",
            opts.smoothing
        )));
    }
    CoatParams::flat(opts.n).validate()?;
    let (points, have_u) = select(m, &opts.selection)?;
    let names: Vec<String> = m.channels.iter().map(|c| c.name.clone()).collect();
    let amplitudes = opts.coverage.map_or(Amplitudes::Free, Amplitudes::Coverage);

    // Families in order, each starting from the best result so far; the log-linear
    // table and Pearson VII start from a Trowbridge–Reitz fit when there is none.
    let mut order = opts.families.clone();
    let needs_start = order
        .iter()
        .any(|f| matches!(f, Family::LogLinear { .. } | Family::PearsonVii));
    if needs_start && !order.contains(&Family::TrowbridgeReitz) {
        order.insert(0, Family::TrowbridgeReitz);
    }
    order.sort_by_key(|f| match f {
        Family::Gaussian => 0,
        Family::TrowbridgeReitz => 1,
        Family::PearsonVii => 2,
        Family::LogLinear { .. } => 3,
    });
    let mut candidates = Vec::new();
    let mut best: Option<Solved> = None;
    let mut last_error = None;
    for family in order {
        let layout = Layout::new(
            family.clone(),
            opts.haze,
            opts.fit_n,
            opts.n,
            &names,
            amplitudes,
        );
        match solve(m, &points, have_u, layout, opts, best.as_ref()) {
            Ok(s) => {
                if opts.families.contains(&family) {
                    candidates.push(Candidate {
                        family: family.clone(),
                        evidence: s.evidence,
                    });
                }
                let better = best.as_ref().is_none_or(|b| {
                    !opts.families.contains(&b.layout.family) || s.evidence.bic < b.evidence.bic
                });
                if better || !opts.families.contains(&family) && best.is_none() {
                    best = Some(s);
                }
            }
            Err(e) => last_error = Some(e),
        }
    }
    let Some(mut solved) = best.filter(|b| opts.families.contains(&b.layout.family)) else {
        return Err(last_error.unwrap_or_else(|| PaintError::Fit("no family converged".into())));
    };

    let mut warnings = Vec::new();
    // Coverage (module docs).
    let coverage = match opts.coverage {
        Some(c) => coverage_bounds(&solved, c, true),
        None => {
            let mut choice = coverage_bounds(&solved, 0.0, false);
            if choice.min <= choice.max {
                choice.used = 0.5 * (choice.min + choice.max);
            } else {
                warnings.push(PaintFitWarning::CoverageInfeasible {
                    min: choice.min,
                    max: choice.max,
                });
                let c = (0.5 * (choice.min + choice.max)).clamp(0.0, 1.0);
                let layout = Layout::new(
                    solved.layout.family.clone(),
                    opts.haze,
                    opts.fit_n,
                    opts.n,
                    &names,
                    Amplitudes::Coverage(c),
                );
                let refit = solve(m, &points, have_u, layout, opts, Some(&solved))?;
                solved = refit;
                choice.used = c;
            }
            choice
        }
    };
    finish(
        m, points, have_u, solved, coverage, candidates, warnings, opts,
    )
}

/// The coverage interval of a solution; `used` is `c` (or filled in by the caller).
fn coverage_bounds(s: &Solved, c: f64, given: bool) -> CoverageChoice {
    let q = &s.fit.x;
    let l = &s.layout;
    let (mut min, mut max) = (0.0f64, 1.0f64);
    for k in 0..l.channels {
        min = min.max(l.flake_amplitude(q, k));
        max = max.min(1.0 - l.base_amplitude(q, k).sqrt());
    }
    CoverageChoice {
        used: c,
        min,
        max,
        given,
    }
}

/// Fit one layout from `start` (another family's solution) or the defaults.
fn solve(
    m: &Measurement,
    points: &[Point],
    have_u: bool,
    layout: Layout,
    opts: &FitOptions,
    start: Option<&Solved>,
) -> Result<Solved, PaintError> {
    let np = layout.len();
    if points.len() <= np {
        return Err(PaintError::Data(format!(
            "{}: {} points are too few for {np} parameters",
            m.file,
            points.len()
        )));
    }
    let engine = Engine::new(m, points, &layout, opts.flake_metal, opts.smoothing);
    let mut q0 = vec![0.0; np];
    // Shape.
    let shape = match start {
        Some(s) => layout.shape_from(&s.orientation),
        None => match layout.family {
            Family::Gaussian => vec![8f64.to_radians().ln()],
            Family::TrowbridgeReitz => vec![0.15f64.ln()],
            Family::PearsonVii => vec![0.15f64.ln(), 0.0],
            Family::LogLinear { .. } => {
                let o = Orientation::trowbridge_reitz(0.15)
                    .map_err(|e| PaintError::Fit(e.to_string()))?;
                layout.shape_from(&o)
            }
        },
    };
    q0[..shape.len()].copy_from_slice(&shape);
    // Coat (and n) from the start, or defaults.
    let ci = layout.coat_index();
    match start {
        Some(s) => {
            let c = s.layout.coat(&s.fit.x);
            q0[ci] = c.roughness.max(1e-3).ln();
            if layout.haze {
                q0[ci + 1] = c.haze;
                q0[ci + 2] = c.haze_roughness.max(0.02).ln();
            }
            if let Some(i) = layout.n_index() {
                q0[i] = c.n;
            }
        }
        None => {
            q0[ci] = 0.01f64.ln();
            if layout.haze {
                q0[ci + 1] = 0.1;
                q0[ci + 2] = 0.3f64.ln();
            }
            if let Some(i) = layout.n_index() {
                q0[i] = opts.n;
            }
        }
    }
    // Amplitudes: non-negative least squares on relative residuals per channel, with
    // the shape and coat of q0 (the model is linear in them up to the base's small
    // denominator), unless the start has them.
    start_amplitudes(&engine, &layout, points, &mut q0, start)?;
    let fit = lm::minimise(
        |q: &[f64]| engine.residuals(q),
        &q0,
        &layout.bounds,
        &layout.steps,
        lm::Settings {
            max_iterations: 400,
            max_tries: 30,
            // A thousandth of what one parameter fitting noise would take off χ².
            min_relative_decrease: Some(1e-3 / (points.len() - np) as f64),
        },
    )
    .map_err(|e| match e {
        LmError::Model(e) => e,
        LmError::NotConverged { iterations, .. } => PaintError::Fit(format!(
            "the {} fit did not converge in {iterations} iterations",
            layout.family.name()
        )),
        other => PaintError::Fit(format!("the {} fit failed: {other}", layout.family.name())),
    })?;
    let model = engine.values(&fit.x)?;
    let chi2: f64 = fit.residuals[..points.len()].iter().map(|r| r * r).sum();
    let orientation = layout.orientation(&fit.x)?;
    let evidence = Evidence::new(chi2, points.len(), np, have_u);
    Ok(Solved {
        layout,
        fit,
        orientation,
        model,
        evidence,
    })
}

/// Start values of the amplitudes (see [`solve`]).
fn start_amplitudes(
    engine: &Engine<'_>,
    layout: &Layout,
    points: &[Point],
    q0: &mut [f64],
    start: Option<&Solved>,
) -> Result<(), PaintError> {
    let nc = layout.channels;
    if let Some(s) = start
        && s.layout.channels == nc
    {
        for k in 0..nc {
            let (a, b) = (
                s.layout.flake_amplitude(&s.fit.x, k),
                s.layout.base_amplitude(&s.fit.x, k),
            );
            let (fa, fb) = match layout.amplitudes {
                Amplitudes::Free => (a, b),
                Amplitudes::Coverage(c) => (
                    if c > 0.0 { a / c } else { 1.0 },
                    if c < 1.0 {
                        b / ((1.0 - c) * (1.0 - c))
                    } else {
                        1.0
                    },
                ),
            };
            let i = layout.amplitude_index(k);
            q0[i] = fa
                .max(1e-300)
                .ln()
                .clamp(layout.bounds[i].0, layout.bounds[i].1);
            let j = i + nc;
            q0[j] = fb
                .max(1e-300)
                .ln()
                .clamp(layout.bounds[j].0, layout.bounds[j].1);
        }
        return Ok(());
    }
    // Columns: the flakes alone (flake amplitude 1, base at its floor) and the base alone.
    let lo = |i: usize| layout.bounds[i].0;
    let mut q = q0.to_vec();
    for k in 0..nc {
        q[layout.amplitude_index(k)] = 0.0;
        q[layout.amplitude_index(k) + nc] = lo(layout.amplitude_index(k) + nc);
    }
    let flakes = engine.values(&q)?;
    for k in 0..nc {
        q[layout.amplitude_index(k)] = lo(layout.amplitude_index(k));
        q[layout.amplitude_index(k) + nc] = (0.1f64).ln();
    }
    let base = engine.values(&q)?;
    for k in 0..nc {
        q[layout.amplitude_index(k)] = lo(layout.amplitude_index(k));
        q[layout.amplitude_index(k) + nc] = lo(layout.amplitude_index(k) + nc);
    }
    let coat = engine.values(&q)?;
    for k in 0..nc {
        let idx: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].channel == k)
            .collect();
        let a = DMatrix::from_fn(idx.len(), 2, |r, c| {
            let i = idx[r];
            let v = if c == 0 {
                flakes[i] - coat[i]
            } else {
                base[i] - coat[i]
            };
            v / points[i].value
        });
        let b = DVector::from_iterator(
            idx.len(),
            idx.iter()
                .map(|&i| (points[i].value - coat[i]) / points[i].value),
        );
        let x = nnls(&a, &b).unwrap_or_else(|| DVector::from_vec(vec![0.1, 0.1]));
        let i = layout.amplitude_index(k);
        // The base column was made at amplitude 0.1.
        let (fa, fb) = (x[0], 0.1 * x[1]);
        let (fa, fb) = match layout.amplitudes {
            Amplitudes::Free => (fa, fb),
            Amplitudes::Coverage(c) => (
                if c > 0.0 { fa / c } else { 1.0 },
                if c < 1.0 {
                    fb / ((1.0 - c) * (1.0 - c))
                } else {
                    1.0
                },
            ),
        };
        q0[i] = fa
            .max(1e-300)
            .ln()
            .clamp(layout.bounds[i].0, layout.bounds[i].1);
        let j = i + nc;
        q0[j] = fb
            .max(1e-300)
            .ln()
            .clamp(layout.bounds[j].0, layout.bounds[j].1);
    }
    Ok(())
}

/// `(JᵀJ)⁻¹` over the parameters that are free at the optimum; a parameter on a bound is
/// held there (its variance and covariances NaN: not estimated). Where the free
/// parameters are still not all determined (a column of `J` that the others explain),
/// the pseudo-inverse gives the determined combinations and the undetermined parameters
/// get NaN too.
fn covariance(jac: &DMatrix<f64>, q: &[f64], bounds: &[(f64, f64)]) -> DMatrix<f64> {
    let np = q.len();
    let free: Vec<usize> = (0..np)
        .filter(|&j| q[j] > bounds[j].0 && q[j] < bounds[j].1)
        .collect();
    let mut cov = DMatrix::from_element(np, np, f64::NAN);
    if free.is_empty() {
        return cov;
    }
    let jf = DMatrix::from_fn(jac.nrows(), free.len(), |r, c| jac[(r, free[c])]);
    let jtj = jf.transpose() * &jf;
    let inv = jtj
        .clone()
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()));
    let (inv, undetermined) = match inv {
        Some(m) => (m, vec![false; free.len()]),
        None => {
            let svd = jtj.clone().svd(true, true);
            let top = svd.singular_values.max();
            // A parameter is undetermined when the null space reaches it.
            let v_t = svd.v_t.clone().expect("computed");
            let und = (0..free.len())
                .map(|c| {
                    (0..free.len())
                        .any(|k| svd.singular_values[k] <= 1e-12 * top && v_t[(k, c)].abs() > 1e-6)
                })
                .collect();
            let pinv = svd
                .pseudo_inverse(1e-12 * top)
                .unwrap_or_else(|_| DMatrix::from_element(free.len(), free.len(), f64::NAN));
            (pinv, und)
        }
    };
    for (a, &i) in free.iter().enumerate() {
        for (b, &j) in free.iter().enumerate() {
            if !undetermined[a] && !undetermined[b] {
                cov[(i, j)] = inv[(a, b)];
            }
        }
    }
    cov
}

/// Uncertainties, physical parameters, groups and warnings of the solution kept.
#[allow(clippy::too_many_arguments)]
fn finish(
    m: &Measurement,
    points: Vec<Point>,
    have_u: bool,
    s: Solved,
    coverage: CoverageChoice,
    candidates: Vec<Candidate>,
    mut warnings: Vec<PaintFitWarning>,
    opts: &FitOptions,
) -> Result<PaintFit, PaintError> {
    let l = &s.layout;
    let q = &s.fit.x;
    let np = l.len();
    let dof = points.len() - np;
    let reduced = s.evidence.chi2 / dof as f64;
    let (basis, factor) = lm::noise_scale(reduced, have_u);
    let cov = covariance(&s.fit.jacobian, q, &l.bounds) * factor;
    let t = StudentsT::new(0.0, 1.0, dof as f64)
        .map_err(|e| PaintError::Fit(e.to_string()))?
        .inverse_cdf(0.975);
    // NaN: held on a bound or not determined (see `covariance`).
    let std: Vec<f64> = (0..np)
        .map(|j| {
            let v = cov[(j, j)];
            if v.is_nan() {
                f64::NAN
            } else {
                v.max(0.0).sqrt()
            }
        })
        .collect();
    let fitted: Vec<Estimate> = (0..np)
        .map(|j| Estimate {
            name: l.names[j].clone(),
            value: q[j],
            std: std[j],
            lo95: q[j] - t * std[j],
            hi95: q[j] + t * std[j],
        })
        .collect();
    let correlation: Vec<Vec<f64>> = (0..np)
        .map(|i| {
            (0..np)
                .map(|j| {
                    let d = std[i] * std[j];
                    if d > 0.0 { cov[(i, j)] / d } else { f64::NAN }
                })
                .collect()
        })
        .collect();
    // Physical parameters: exp of a logarithm, or the parameter itself.
    let mut physical = Vec::new();
    let exp_of = |name: &str, j: usize| Estimate {
        name: name.to_string(),
        value: q[j].exp(),
        std: q[j].exp() * std[j],
        lo95: (q[j] - t * std[j]).exp(),
        hi95: (q[j] + t * std[j]).exp(),
    };
    let lin_of = |name: &str, j: usize| Estimate {
        name: name.to_string(),
        value: q[j],
        std: std[j],
        lo95: (q[j] - t * std[j]).max(l.bounds[j].0),
        hi95: (q[j] + t * std[j]).min(l.bounds[j].1),
    };
    match &l.family {
        Family::Gaussian => physical.push(exp_of("hwhm (rad)", 0)),
        Family::TrowbridgeReitz => physical.push(exp_of("alpha", 0)),
        Family::PearsonVii => {
            physical.push(exp_of("alpha", 0));
            physical.push(exp_of("shape", 1));
        }
        Family::LogLinear { .. } => {}
    }
    let ci = l.coat_index();
    physical.push(exp_of("coat roughness", ci));
    if l.haze {
        physical.push(lin_of("haze", ci + 1));
        physical.push(exp_of("haze roughness", ci + 2));
    }
    if let Some(i) = l.n_index() {
        physical.push(lin_of("n", i));
    }
    let c = coverage.used;
    let mut channels = Vec::with_capacity(l.channels);
    for (k, ch) in m.channels.iter().enumerate() {
        let i = l.amplitude_index(k);
        let j = i + l.channels;
        let (mut a, mut b) = (
            exp_of(&format!("flake amplitude {}", ch.name), i),
            exp_of(&format!("base amplitude {}", ch.name), j),
        );
        let (mut sc, mut rho) = (a.clone(), b.clone());
        match l.amplitudes {
            Amplitudes::Free => {
                // s = a/c, ρ = b/(1 − c)² at the coverage used.
                let fs = if c > 0.0 { 1.0 / c } else { f64::NAN };
                let fr = if c < 1.0 {
                    1.0 / ((1.0 - c) * (1.0 - c))
                } else {
                    f64::NAN
                };
                for (e, f) in [(&mut sc, fs), (&mut rho, fr)] {
                    e.value *= f;
                    e.std *= f;
                    e.lo95 *= f;
                    e.hi95 *= f;
                }
            }
            Amplitudes::Coverage(cc) => {
                let fa = cc;
                let fb = (1.0 - cc) * (1.0 - cc);
                for (e, f) in [(&mut a, fa), (&mut b, fb)] {
                    e.value *= f;
                    e.std *= f;
                    e.lo95 *= f;
                    e.hi95 *= f;
                }
            }
        }
        sc.name = format!("flake scale {}", ch.name);
        rho.name = format!("base albedo {}", ch.name);
        channels.push(ChannelParams {
            channel: ch.clone(),
            flake_scale: sc.value.clamp(0.0, 1.0),
            base_albedo: rho.value.clamp(0.0, 1.0),
        });
        physical.extend([a, b, sc, rho]);
    }
    let params = PaintParams {
        coat: l.coat(q),
        orientation: s.orientation.clone(),
        coverage: c,
        flake_metal: opts.flake_metal,
        channels,
    };
    // Warnings.
    let threshold = if have_u {
        lm::chi2_per_dof_999(dof)
    } else {
        0.3 * 0.3
    };
    if reduced > threshold {
        warnings.push(PaintFitWarning::PoorFit {
            chi2_per_dof: reduced,
            threshold,
            uncertainties_given: have_u,
        });
    }
    for (j, (&v, &(lo, hi))) in q.iter().zip(&l.bounds).enumerate() {
        let shape_entry = j < l.family.shape_len() && matches!(l.family, Family::LogLinear { .. });
        // A log-linear value on its floor is a knot beyond the data (the penalty holds
        // it), not a result.
        if (v <= lo || v >= hi) && !shape_entry {
            warnings.push(PaintFitWarning::AtBound {
                parameter: l.names[j].clone(),
                bound: if v <= lo { lo } else { hi },
            });
        }
    }
    if points.len() < 3 * np {
        warnings.push(PaintFitWarning::FewPoints {
            points: points.len(),
            parameters: np,
        });
    }
    for (j, name) in l.names.iter().enumerate() {
        if std[j].is_nan() && q[j] > l.bounds[j].0 && q[j] < l.bounds[j].1 {
            warnings.push(PaintFitWarning::Undetermined {
                parameter: name.clone(),
            });
        }
    }
    for e in &physical {
        let rel = e.std / e.value.abs();
        if e.value != 0.0 && rel > 0.5 {
            warnings.push(PaintFitWarning::Shaky {
                parameter: e.name.clone(),
                relative: rel,
            });
        }
    }
    let groups = group_residuals(m, &points, &s.model);
    Ok(PaintFit {
        family: l.family.clone(),
        params,
        fitted,
        correlation,
        physical,
        coverage,
        evidence: s.evidence,
        candidates,
        dof,
        uncertainties_given: have_u,
        uncertainty_basis: basis,
        uncertainty_scale: factor.sqrt(),
        model: s.model,
        points,
        groups,
        iterations: s.fit.iterations,
        warnings,
    })
}

/// The model `model` at the points of `m` within `sel` (no fit): the points, and the
/// model's value at each, sr⁻¹.
///
/// # Errors
/// As [`select`]; [`PaintError::Data`] when a channel of `m` is not in the model (named),
/// [`PaintError::Geometry`] for an incidence out of range.
pub fn evaluate(
    model: &crate::PaintModel,
    m: &Measurement,
    sel: &Selection,
) -> Result<(Vec<Point>, Vec<f64>), PaintError> {
    let index: Vec<usize> = m
        .channels
        .iter()
        .map(|c| {
            model.channel_index(&c.name).ok_or_else(|| {
                PaintError::Data(format!(
                    "{}: channel `{}` (column brdf_{}_per_sr) is not in the paint's parameters, which have {}",
                    m.file,
                    c.name,
                    c.name,
                    model
                        .params()
                        .channels
                        .iter()
                        .map(|c| c.channel.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    let (points, _) = select(m, sel)?;
    let mut incidences: Vec<(f64, crate::PaintIncidence)> = Vec::new();
    let mut values = Vec::with_capacity(points.len());
    for p in &points {
        let o = &m.rows[p.row];
        let inc = match incidences.iter().position(|(t, _)| *t == o.theta_i) {
            Some(i) => i,
            None => {
                incidences.push((o.theta_i, model.incidence(o.theta_i)?));
                incidences.len() - 1
            }
        };
        values.push(model.brdf(&incidences[inc].1, &o.direction(), index[p.channel]));
    }
    Ok((points, values))
}
