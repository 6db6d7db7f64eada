//! Bounded Levenberg–Marquardt least squares: minimise `χ²(x) = Σ r_k(x)²` over a box
//! `lo_j ≤ x_j ≤ hi_j`.
//!
//! The one minimiser of the project's fits (the width of a measured curve, the width
//! fitted to `L*`, the joint fit of a paint). The algorithm, in the form every caller
//! relies on for its results:
//!
//! * the Jacobian by central differences with a step `h_j` per parameter; at a bound the
//!   two points are clamped into the box, so the difference becomes one-sided there;
//! * Marquardt's damping: the step solves `(JᵀJ + λ diag(JᵀJ) + 10⁻¹² I) δ = −Jᵀr` by LU;
//!   `λ` starts at 10⁻³, is divided by 3 (not below 10⁻¹²) after an accepted step and
//!   multiplied by 4 after a rejected one (by 10 when the system is singular or the step
//!   is not finite), at most [`Settings::max_tries`] times per iteration;
//! * a parameter on a bound that the descent direction `−Jᵀr` pushes outward is held
//!   for the iteration (its row and column of the system replaced by the identity, its
//!   step 0): the others then take the step they would take without it;
//! * a trial point is clamped into the box; a step is accepted when `χ²` does not grow
//!   (a trial where the model vanishes, see [`Residuals`], is rejected);
//! * convergence: an accepted step shorter than `10⁻⁹` (Euclidean, in parameter units),
//!   or one shorter than `10⁻⁸` that lowers `χ²` by at most `10⁻¹⁰` of it (or, when
//!   [`Settings::min_relative_decrease`] is set, two successive steps that each lower it
//!   by less than that fraction); or, when no damping finds a lower `χ²`, a gradient
//!   `|Jᵀr| < 10⁻⁶ (1 + χ²)` or `λ > 10¹⁰` (a minimum to numerical precision).
//!   Otherwise at most [`Settings::max_iterations`].
//!
//! The result carries the Jacobian computed at the start of the last iteration (at the
//! optimum up to the last, converged, step), from which [`Fit::covariance`] gives
//! `(JᵀJ)⁻¹`; callers scale it by their own noise estimate.

use nalgebra::{DMatrix, DVector};
use thiserror::Error;

/// What a residual function returns: the residuals, or `None` where the model vanishes
/// (a log residual of a zero model value) so that the point cannot be used.
pub type Residuals = Option<Vec<f64>>;

/// Limits of the iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Most Jacobian evaluations (outer iterations); default 100.
    pub max_iterations: usize,
    /// Most damping increases per iteration before giving up on a lower `χ²`; default 30.
    pub max_tries: usize,
    /// Also converged when two successive accepted steps each lower `χ²` by less than
    /// this fraction of it (default `None`: only the criteria of the module docs). For
    /// many parameters whose finite-difference Jacobian is slightly noisy, the step
    /// criteria can crawl for hundreds of iterations through changes of `χ²` far below
    /// any statistical meaning.
    pub min_relative_decrease: Option<f64>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            max_tries: 30,
            min_relative_decrease: None,
        }
    }
}

/// Why a minimisation failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LmError<E> {
    /// The residual function failed.
    #[error("{0}")]
    Model(E),
    /// The model vanishes at the start point.
    #[error("the model vanishes at some point for the start values")]
    VanishedAtStart,
    /// The model vanished at a point of a finite difference.
    #[error("the model vanished at a point while differentiating")]
    VanishedDifferentiating,
    /// The arguments do not fit together (lengths, an empty or inverted box, a step that
    /// is not positive).
    #[error("bad arguments: {0}")]
    Arguments(String),
    /// No convergence within the iteration limit.
    #[error("no convergence in {iterations} iterations")]
    NotConverged {
        /// Iterations taken.
        iterations: usize,
        /// The last point.
        x: Vec<f64>,
    },
}

/// The minimum found.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The parameters at the minimum.
    pub x: Vec<f64>,
    /// The residuals there.
    pub residuals: Vec<f64>,
    /// `Σ r²` there.
    pub chi2: f64,
    /// The Jacobian `∂r_k/∂x_j` from the start of the last iteration (module docs).
    pub jacobian: DMatrix<f64>,
    /// Iterations taken (Jacobian evaluations).
    pub iterations: usize,
}

impl Fit {
    /// `(JᵀJ)⁻¹`, or `None` when `JᵀJ` is singular (a parameter the residuals do not
    /// determine).
    #[must_use]
    pub fn covariance(&self) -> Option<DMatrix<f64>> {
        (self.jacobian.transpose() * &self.jacobian).try_inverse()
    }
}

/// What a least-squares fit's uncertainties rest on (see [`noise_scale`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UncertaintyBasis {
    /// The file's uncertainties (`χ²/dof ≤ 1`), unscaled.
    Stated,
    /// The file's uncertainties, scaled by `sqrt(χ²/dof) > 1` because the residuals
    /// scatter more than they allow.
    StatedScaledByChi2,
    /// No uncertainty column: the residual scatter (`sqrt(χ²/dof)` in `ln y`).
    ResidualScatter,
}

impl UncertaintyBasis {
    /// A one-line description for reports.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::Stated => "the file's uncertainties",
            Self::StatedScaledByChi2 => {
                "the file's uncertainties scaled by sqrt(chi2/dof) > 1 (the residuals scatter more than they allow)"
            }
            Self::ResidualScatter => "residual scatter (no uncertainty column)",
        }
    }
}

/// The factor on `(JᵀJ)⁻¹` of residuals weighted by their stated uncertainties (or by 1
/// when there are none), and what it rests on: without uncertainties the residual scatter
/// `χ²/dof` is the only noise estimate; with them the covariance is scaled by `χ²/dof`
/// only when that exceeds 1 (the stated uncertainties are too small for the scatter
/// seen, or the model misses something: either way the scatter is the better estimate).
/// It is never scaled down.
#[must_use]
pub fn noise_scale(chi2_per_dof: f64, uncertainties_given: bool) -> (UncertaintyBasis, f64) {
    if !uncertainties_given {
        (UncertaintyBasis::ResidualScatter, chi2_per_dof)
    } else if chi2_per_dof > 1.0 {
        (UncertaintyBasis::StatedScaledByChi2, chi2_per_dof)
    } else {
        (UncertaintyBasis::Stated, 1.0)
    }
}

/// The 99.9 % point of `χ²_k / k` by the Wilson–Hilferty cube approximation
/// `(1 − 2/(9k) + z sqrt(2/(9k)))³`, `z = 3.0902`: above the exact quantile (scipy) by
/// 3.0 % at `k = 1`, 1.2 % at 5, 0.6 % at 10, 0.04 % at 100.
#[must_use]
pub fn chi2_per_dof_999(dof: usize) -> f64 {
    let k = dof as f64;
    let a = 2.0 / (9.0 * k);
    (1.0 - a + 3.090_232_306_167_813 * a.sqrt()).powi(3)
}

/// `Σ r²`.
fn chi2(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Minimise `Σ r(x)²` from `x0` within `bounds` (`(lo, hi)` per parameter; `x0` is
/// clamped into them), with central-difference steps `steps` (module docs).
///
/// # Errors
/// [`LmError::Arguments`] for mismatched lengths, an inverted box or a step that is not
/// positive; [`LmError::Model`] when `residuals` fails; [`LmError::VanishedAtStart`],
/// [`LmError::VanishedDifferentiating`]; [`LmError::NotConverged`].
pub fn minimise<E>(
    mut residuals: impl FnMut(&[f64]) -> Result<Residuals, E>,
    x0: &[f64],
    bounds: &[(f64, f64)],
    steps: &[f64],
    settings: Settings,
) -> Result<Fit, LmError<E>> {
    let np = x0.len();
    if bounds.len() != np || steps.len() != np || np == 0 {
        return Err(LmError::Arguments(format!(
            "{np} parameters, {} bounds, {} steps",
            bounds.len(),
            steps.len()
        )));
    }
    if let Some(j) = (0..np).find(|&j| !(bounds[j].0 <= bounds[j].1) || !(steps[j] > 0.0)) {
        return Err(LmError::Arguments(format!(
            "parameter {j}: bounds ({}, {}) and step {}",
            bounds[j].0, bounds[j].1, steps[j]
        )));
    }
    let clamp = |q: &mut [f64]| {
        for (v, &(lo, hi)) in q.iter_mut().zip(bounds) {
            *v = v.clamp(lo, hi);
        }
    };
    let mut q = x0.to_vec();
    clamp(&mut q);
    let mut r = residuals(&q)
        .map_err(LmError::Model)?
        .ok_or(LmError::VanishedAtStart)?;
    let m = r.len();
    let mut jac = DMatrix::<f64>::zeros(m, np);
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut converged = false;
    let mut small_decreases = 0;
    for it in 0..settings.max_iterations {
        iterations = it + 1;
        for j in 0..np {
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[j] += steps[j];
            qm[j] -= steps[j];
            // One-sided at a bound: keep both points inside the box.
            clamp(&mut qp);
            clamp(&mut qm);
            let h2 = qp[j] - qm[j];
            let rp = residuals(&qp).map_err(LmError::Model)?;
            let rm = residuals(&qm).map_err(LmError::Model)?;
            let (Some(rp), Some(rm)) = (rp, rm) else {
                return Err(LmError::VanishedDifferentiating);
            };
            for k in 0..m {
                jac[(k, j)] = (rp[k] - rm[k]) / h2;
            }
        }
        let jt = jac.transpose();
        let jtj = &jt * &jac;
        let g = &jt * DVector::from_column_slice(&r);
        let c0 = chi2(&r);
        // Parameters on a bound that the descent direction −Jᵀr pushes outward are held
        // for this iteration (an active set), so that the others take the step they
        // would take without them instead of one the clamp cuts short.
        let held: Vec<usize> = (0..np)
            .filter(|&j| (q[j] <= bounds[j].0 && g[j] > 0.0) || (q[j] >= bounds[j].1 && g[j] < 0.0))
            .collect();
        let mut improved = false;
        for _ in 0..settings.max_tries {
            let mut a = jtj.clone();
            for d in 0..np {
                a[(d, d)] *= 1.0 + lambda;
                a[(d, d)] += 1e-12;
            }
            let mut rhs = -&g;
            for &j in &held {
                a.row_mut(j).fill(0.0);
                a.column_mut(j).fill(0.0);
                a[(j, j)] = 1.0;
                rhs[j] = 0.0;
            }
            let Some(step) = a.lu().solve(&rhs) else {
                lambda *= 10.0;
                continue;
            };
            let mut qn: Vec<f64> = q.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            if qn.iter().any(|v| !v.is_finite()) {
                lambda *= 10.0;
                continue;
            }
            clamp(&mut qn);
            if let Some(rn) = residuals(&qn).map_err(LmError::Model)? {
                let c1 = chi2(&rn);
                if c1 <= c0 {
                    // The step actually taken: at a bound the clamp shortens it (to zero
                    // when the data push outward), which is convergence at the bound.
                    let taken = q
                        .iter()
                        .zip(&qn)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt();
                    let small = (c0 - c1) <= 1e-10 * c0.max(1e-300) && taken < 1e-8;
                    if let Some(rel) = settings.min_relative_decrease {
                        if c0 - c1 < rel * c0 {
                            small_decreases += 1;
                        } else {
                            small_decreases = 0;
                        }
                    }
                    q = qn;
                    r = rn;
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = true;
                    converged = small || taken < 1e-9 || small_decreases >= 2;
                    break;
                }
            }
            lambda *= 4.0;
        }
        if !improved {
            // No step lowers χ²: at a (local) minimum to numerical precision.
            converged = g.norm() < 1e-6 * (1.0 + c0) || lambda > 1e10;
            break;
        }
        if converged {
            break;
        }
    }
    if !converged {
        return Err(LmError::NotConverged { iterations, x: q });
    }
    Ok(Fit {
        chi2: chi2(&r),
        x: q,
        residuals: r,
        jacobian: jac,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    type NoError = std::convert::Infallible;

    /// Straight-line data: the minimum and its covariance have closed forms.
    #[test]
    fn linear_least_squares_matches_the_normal_equations() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let ys = [1.1, 2.9, 5.2, 6.8, 9.1, 11.0];
        let f = |p: &[f64]| -> Result<Residuals, NoError> {
            Ok(Some(
                xs.iter()
                    .zip(&ys)
                    .map(|(x, y)| p[0] + p[1] * x - y)
                    .collect(),
            ))
        };
        let fit = minimise(
            f,
            &[0.0, 0.0],
            &[(-100.0, 100.0); 2],
            &[1e-4; 2],
            Settings::default(),
        )
        .unwrap();
        // Closed form: slope = Sxy/Sxx, intercept = ȳ − slope x̄.
        let n = xs.len() as f64;
        let xm = xs.iter().sum::<f64>() / n;
        let ym = ys.iter().sum::<f64>() / n;
        let sxx: f64 = xs.iter().map(|x| (x - xm) * (x - xm)).sum();
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - xm) * (y - ym)).sum();
        let slope = sxy / sxx;
        let intercept = ym - slope * xm;
        assert!((fit.x[1] - slope).abs() < 1e-9, "{} vs {slope}", fit.x[1]);
        assert!((fit.x[0] - intercept).abs() < 1e-9);
        // (JᵀJ)⁻¹ of a line: var(slope) = 1/Sxx, var(intercept) = Σx²/(n Sxx).
        let cov = fit.covariance().unwrap();
        assert!((cov[(1, 1)] - 1.0 / sxx).abs() < 1e-9);
        let sx2: f64 = xs.iter().map(|x| x * x).sum();
        assert!((cov[(0, 0)] - sx2 / (n * sxx)).abs() < 1e-9);
    }

    /// An exponential decay from exact data: the parameters come back.
    #[test]
    fn recovers_a_nonlinear_model_from_exact_data() {
        let ts: Vec<f64> = (0..20).map(|k| f64::from(k) * 0.25).collect();
        let truth = [2.5, 0.7];
        let f = |p: &[f64]| -> Result<Residuals, NoError> {
            Ok(Some(
                ts.iter()
                    .map(|t| p[0] * (-p[1] * t).exp() - truth[0] * (-truth[1] * t).exp())
                    .collect(),
            ))
        };
        let fit = minimise(
            f,
            &[1.0, 0.1],
            &[(0.0, 10.0), (0.0, 10.0)],
            &[1e-6, 1e-6],
            Settings::default(),
        )
        .unwrap();
        assert!((fit.x[0] - truth[0]).abs() < 1e-8, "{:?}", fit.x);
        assert!((fit.x[1] - truth[1]).abs() < 1e-8, "{:?}", fit.x);
        assert!(fit.chi2 < 1e-16);
    }

    /// When the unconstrained minimum lies outside the box, the fit stops on the bound
    /// (the constrained minimum of a convex problem).
    #[test]
    fn stops_on_a_bound() {
        // Σ (p − 3)² over p ≤ 1: minimum at p = 1.
        let f = |p: &[f64]| -> Result<Residuals, NoError> { Ok(Some(vec![p[0] - 3.0; 4])) };
        let fit = minimise(f, &[0.0], &[(-1.0, 1.0)], &[1e-4], Settings::default()).unwrap();
        assert_eq!(fit.x[0], 1.0);
        assert!((fit.chi2 - 16.0).abs() < 1e-12);
    }

    #[test]
    fn errors_are_reported() {
        let vanish = |_: &[f64]| -> Result<Residuals, NoError> { Ok(None) };
        assert_eq!(
            minimise(vanish, &[0.0], &[(-1.0, 1.0)], &[1e-4], Settings::default()),
            Err(LmError::VanishedAtStart)
        );
        let fail = |_: &[f64]| -> Result<Residuals, &'static str> { Err("bad model") };
        assert_eq!(
            minimise(fail, &[0.0], &[(-1.0, 1.0)], &[1e-4], Settings::default()),
            Err(LmError::Model("bad model"))
        );
        let ok = |p: &[f64]| -> Result<Residuals, NoError> { Ok(Some(vec![p[0]])) };
        assert!(matches!(
            minimise(ok, &[0.0], &[(1.0, -1.0)], &[1e-4], Settings::default()),
            Err(LmError::Arguments(_))
        ));
        assert!(matches!(
            minimise(
                ok,
                &[0.0, 1.0],
                &[(-1.0, 1.0)],
                &[1e-4],
                Settings::default()
            ),
            Err(LmError::Arguments(_))
        ));
        // Rosenbrock's valley needs more than two iterations from (−1.2, 1).
        let rosen = |p: &[f64]| -> Result<Residuals, NoError> {
            Ok(Some(vec![10.0 * (p[1] - p[0] * p[0]), 1.0 - p[0]]))
        };
        let few = Settings {
            max_iterations: 2,
            ..Settings::default()
        };
        assert!(matches!(
            minimise(rosen, &[-1.2, 1.0], &[(-5.0, 5.0); 2], &[1e-6; 2], few),
            Err(LmError::NotConverged { iterations: 2, .. })
        ));
        // With the default limit it reaches the minimum (1, 1).
        let fit = minimise(
            rosen,
            &[-1.2, 1.0],
            &[(-5.0, 5.0); 2],
            &[1e-7; 2],
            Settings::default(),
        )
        .unwrap();
        assert!((fit.x[0] - 1.0).abs() < 1e-6 && (fit.x[1] - 1.0).abs() < 1e-6);
    }
}
