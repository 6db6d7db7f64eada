//! The joint fit's result: estimates with their uncertainties and intervals, the
//! coverage chosen, the warnings (module docs of [`super`]).

use flakescatter_numerics::lm::{self, UncertaintyBasis};
use nalgebra::DMatrix;
use statrs::distribution::{ContinuousCDF, StudentsT};

use super::FitOptions;
use super::data::{Measurement, Point};
use super::layout::{Amplitudes, Family, Layout};
use super::report::{Evidence, GroupResidual, group_residuals};
use super::solve::Solved;
use crate::PaintError;
use crate::model::{ChannelParams, PaintParams};

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
    /// Another thickness of the flake stack fits almost as well (module docs of
    /// [`super::thickness`]): interference repeats with optical thickness.
    AmbiguousThickness {
        /// The thickness fitted, nm.
        fitted_nm: f64,
        /// The other local minimum of the scan, nm.
        other_nm: f64,
        /// Its scan `χ²` above the scan's lowest, in units of the fit's `χ²/dof`.
        delta: f64,
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
            Self::AmbiguousThickness {
                fitted_nm,
                other_nm,
                delta,
            } => write!(
                f,
                "the flake stack's thickness is ambiguous: in the scan, {other_nm:.0} nm fits almost as well as the order of the {fitted_nm:.1} nm fitted (chi2 higher by only {delta:.2} chi2/dof); interference repeats with thickness, so check the scan"
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
    /// With a fitted stack thickness: the scan that started it, `(thickness nm, χ²)`
    /// with the shape and coat held (module docs of [`super::thickness`]).
    pub thickness_scan: Option<Vec<(f64, f64)>>,
    /// Whether the binder's tint was fitted ([`super::FitExtras::tint`]; the tints are
    /// then in [`PaintFit::fitted`], [`PaintFit::physical`] as `tint <channel>`, and in
    /// the paint's channels).
    pub tint_fitted: bool,
    /// Cautions.
    pub warnings: Vec<PaintFitWarning>,
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

/// The uncertainties of a solution: the scaled covariance, its diagonal's square roots
/// (NaN where not estimated) and the Student's t of the 95 % intervals.
struct Uncertainty {
    cov: DMatrix<f64>,
    std: Vec<f64>,
    t: f64,
}

impl Uncertainty {
    /// An estimate of a fitted entry `j` mapped by `f` (monotone increasing), its
    /// standard uncertainty `f'(q) σ`, and the interval of `f` over `q ± tσ` clamped to
    /// `clamp`.
    fn estimate(
        &self,
        name: &str,
        q: f64,
        j: usize,
        f: impl Fn(f64) -> f64,
        slope: f64,
        clamp: (f64, f64),
    ) -> Estimate {
        let s = self.std[j];
        // Not `f64::max`/`min`: an interval not estimated (σ NaN) stays NaN.
        let (lo, hi) = (q - self.t * s, q + self.t * s);
        Estimate {
            name: name.to_string(),
            value: f(q),
            std: slope * s,
            lo95: f(if lo < clamp.0 { clamp.0 } else { lo }),
            hi95: f(if hi > clamp.1 { clamp.1 } else { hi }),
        }
    }
}

/// The fitted entries as estimates, and their correlations.
fn fitted_estimates(l: &Layout, q: &[f64], u: &Uncertainty) -> (Vec<Estimate>, Vec<Vec<f64>>) {
    let np = q.len();
    let fitted = (0..np)
        .map(|j| {
            u.estimate(
                &l.names[j],
                q[j],
                j,
                |x| x,
                1.0,
                (f64::NEG_INFINITY, f64::INFINITY),
            )
        })
        .collect();
    let correlation = (0..np)
        .map(|i| {
            (0..np)
                .map(|j| {
                    let d = u.std[i] * u.std[j];
                    if d > 0.0 { u.cov[(i, j)] / d } else { f64::NAN }
                })
                .collect()
        })
        .collect();
    (fitted, correlation)
}

/// The physical parameters (exp of a logarithm, or the entry itself) and each channel's
/// flake scale and base albedo at the coverage `c`.
fn physical_estimates(
    l: &Layout,
    q: &[f64],
    u: &Uncertainty,
    m: &Measurement,
    c: f64,
) -> (Vec<Estimate>, Vec<ChannelParams>) {
    let unbounded = (f64::NEG_INFINITY, f64::INFINITY);
    let exp_of = |name: &str, j: usize| u.estimate(name, q[j], j, f64::exp, q[j].exp(), unbounded);
    let lin_of = |name: &str, j: usize| u.estimate(name, q[j], j, |x| x, 1.0, l.bounds[j]);
    let mut physical = Vec::new();
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
    if let Some(i) = l.thickness_index() {
        physical.push(lin_of("thickness (nm)", i));
    }
    let scaled = |e: &Estimate, f: f64, name: String| Estimate {
        name,
        value: e.value * f,
        std: e.std * f,
        lo95: e.lo95 * f,
        hi95: e.hi95 * f,
    };
    let mut channels = Vec::with_capacity(l.channels);
    for (k, ch) in m.channels.iter().enumerate() {
        let i = l.amplitude_index(k);
        let (fa, fb) = (
            exp_of(&format!("flake amplitude {}", ch.name), i),
            exp_of(&format!("base amplitude {}", ch.name), i + l.channels),
        );
        // Amplitudes a = c s and b = (1 − c)² ρ, from the fitted entries either way.
        let gap2 = (1.0 - c) * (1.0 - c);
        let (a, b, sc, rho) = match l.amplitudes {
            Amplitudes::Free => (
                fa.clone(),
                fb.clone(),
                scaled(&fa, if c > 0.0 { 1.0 / c } else { f64::NAN }, String::new()),
                scaled(
                    &fb,
                    if c < 1.0 { 1.0 / gap2 } else { f64::NAN },
                    String::new(),
                ),
            ),
            Amplitudes::Coverage(cc) => (
                scaled(&fa, cc, fa.name.clone()),
                scaled(&fb, (1.0 - cc) * (1.0 - cc), fb.name.clone()),
                fa.clone(),
                fb.clone(),
            ),
        };
        let sc = Estimate {
            name: format!("flake scale {}", ch.name),
            ..sc
        };
        let rho = Estimate {
            name: format!("base albedo {}", ch.name),
            ..rho
        };
        // The binder's tint over the flakes (physics.md §12.9), when fitted.
        let tint = l
            .tint_index()
            .map(|i| lin_of(&format!("tint {}", ch.name), i + k));
        channels.push(ChannelParams {
            channel: ch.clone(),
            flake_scale: sc.value.clamp(0.0, 1.0),
            base_albedo: rho.value.clamp(0.0, 1.0),
            tint: tint.as_ref().map_or(0.0, |e| e.value.max(0.0)),
        });
        physical.extend([a, b, sc, rho]);
        physical.extend(tint);
    }
    (physical, channels)
}

/// The warnings a solution earns (module docs of [`super`]).
fn warnings_of(
    l: &Layout,
    q: &[f64],
    u: &Uncertainty,
    physical: &[Estimate],
    points: usize,
    warnings: &mut Vec<PaintFitWarning>,
) {
    let np = q.len();
    for (j, (&v, &(lo, hi))) in q.iter().zip(&l.bounds).enumerate() {
        let shape_entry = j < l.family.shape_len() && matches!(l.family, Family::LogLinear { .. });
        // A log-linear value on its floor is a knot beyond the data (the penalty holds
        // it), not a result.
        if (v <= lo || v >= hi) && !shape_entry {
            warnings.push(PaintFitWarning::AtBound {
                parameter: l.names[j].clone(),
                bound: if v <= lo { lo } else { hi },
            });
        } else if u.std[j].is_nan() && v > lo && v < hi {
            warnings.push(PaintFitWarning::Undetermined {
                parameter: l.names[j].clone(),
            });
        }
    }
    if points < 3 * np {
        warnings.push(PaintFitWarning::FewPoints {
            points,
            parameters: np,
        });
    }
    for e in physical {
        let rel = e.std / e.value.abs();
        if e.value != 0.0 && rel > 0.5 {
            warnings.push(PaintFitWarning::Shaky {
                parameter: e.name.clone(),
                relative: rel,
            });
        }
    }
}

/// The outcome of model selection, before its uncertainties are worked out.
pub(super) struct Selected {
    /// The solution kept.
    pub(super) solved: Solved,
    /// Its coverage interval and the coverage used.
    pub(super) coverage: CoverageChoice,
    /// Every family tried, for the report.
    pub(super) candidates: Vec<Candidate>,
    /// Warnings raised while selecting.
    pub(super) warnings: Vec<PaintFitWarning>,
    /// The thickness scan, when the thickness is fitted.
    pub(super) thickness_scan: Option<Vec<(f64, f64)>>,
}

/// Uncertainties, physical parameters, groups and warnings of the solution kept.
pub(super) fn finish(
    m: &Measurement,
    points: Vec<Point>,
    have_u: bool,
    selected: Selected,
    opts: &FitOptions,
) -> Result<PaintFit, PaintError> {
    let Selected {
        solved: s,
        coverage,
        candidates,
        mut warnings,
        thickness_scan,
    } = selected;
    let l = &s.layout;
    let q = &s.fit.x;
    let dof = points.len() - l.len();
    let reduced = s.evidence.chi2 / dof as f64;
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
    let (basis, factor) = lm::noise_scale(reduced, have_u);
    let cov = covariance(&s.fit.jacobian, q, &l.bounds) * factor;
    // NaN: held on a bound or not determined (see `covariance`).
    let std = (0..q.len())
        .map(|j| {
            let v = cov[(j, j)];
            if v.is_nan() {
                f64::NAN
            } else {
                v.max(0.0).sqrt()
            }
        })
        .collect();
    let t = StudentsT::new(0.0, 1.0, dof as f64)
        .map_err(|e| PaintError::Fit(e.to_string()))?
        .inverse_cdf(0.975);
    let u = Uncertainty { cov, std, t };
    let (fitted, correlation) = fitted_estimates(l, q, &u);
    let (physical, channels) = physical_estimates(l, q, &u, m, coverage.used);
    warnings_of(l, q, &u, &physical, points.len(), &mut warnings);
    let flake_metal = match (l.thickness(q), &opts.thickness) {
        (Some(d), Some(t)) => {
            if let Some(profile) = &thickness_scan {
                for (other, delta) in super::thickness::ambiguous_minima(profile, d, reduced) {
                    warnings.push(PaintFitWarning::AmbiguousThickness {
                        fitted_nm: d,
                        other_nm: other,
                        delta,
                    });
                }
            }
            opts.flake_metal.with_thickness(&t.layers, d)?
        }
        _ => opts.flake_metal.clone(),
    };
    let params = PaintParams {
        coat: l.coat(q),
        orientation: s.orientation.clone(),
        coverage: coverage.used,
        flake_metal,
        channels,
    };
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
        thickness_scan,
        tint_fitted: l.tint_index().is_some(),
    })
}
