//! Fitting the Gaussian width to flake tilts (maximum likelihood) and to histograms
//! (least squares).
//!
//! Conventions: angles in **radians**, areas in **µm²** (only their ratios matter). The
//! model is the Gaussian family of [`crate::distribution`], `p̃(θ) ∝ exp(-θ²/(2s²))` on
//! `[0, π/2)`, normalised exactly; results are reported as `s` with helpers for the hwhm.
//!
//! Maximum likelihood. Flake `i` has polar angle `θi` and area `ai`; the area-weighted
//! log-likelihood is `ℓ(s) = Σ ai ln p(θi; s)`. With `p(θ; s) = sin θ exp(-θ²/(2s²))/Z(s)`,
//! `ℓ/Σai = −ln Z(s) − m2/(2s²) + const`, where `m2 = Σ ai θi²/Σ ai`. This is an
//! exponential family in `1/s²` with sufficient statistic `θ²`, so `dℓ/ds = 0` reduces to
//! `E_s[θ²] = m2` (moment matching), solved by bisection on `ln s` (`E_s[θ²]` increases
//! with `s`, from `2s²` for small `s` to `π − 2` for a uniform `p̃`).
//!
//! Confidence interval. `m2` is a ratio estimator; its standard error over flakes is the
//! sandwich (delta-method) form `se² = Σ ai² (θi² − m2)² / (Σ ai)²`, robust to the area
//! weights and equal to the inverse Fisher information when all areas are equal. The
//! 95 % interval `m2 ± 1.96 se` is mapped through the monotone `s(m2)`.

use std::f64::consts::{FRAC_PI_2, PI};

use thiserror::Error;

use crate::distribution::{GaussianWidth, HWHM_PER_SIGMA, Orientation, cos_diff};
use crate::histogram::AreaHistogram;
use crate::quad;

/// Errors from width fitting.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    /// No flakes.
    #[error("no flakes to fit")]
    Empty,
    /// Bad input value.
    #[error("flake {index}: {what} = {value} is invalid (need area > 0 and θn in [0, π/2])")]
    BadInput {
        /// Index of the flake.
        index: usize,
        /// `"area"` or `"theta_n"`.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// All flakes are flat (`θn = 0`): the width is zero, no Gaussian fits.
    #[error("all flakes have θn = 0: the width is zero")]
    ZeroWidth,
    /// The tilts are as wide as a uniform `p̃` or wider: no finite width fits.
    #[error(
        "mean square tilt {m2} rad² reaches the uniform limit π − 2: no finite Gaussian width fits"
    )]
    Unbounded {
        /// The area-weighted mean square tilt, rad².
        m2: f64,
    },
    /// The histogram has no mass in any bin with a finite `p̃`.
    #[error("histogram has no usable bins")]
    EmptyHistogram,
}

/// A fitted Gaussian width with its 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WidthFit {
    /// Fitted `s`, radians.
    pub sigma: f64,
    /// 95 % confidence interval of `s`, radians (the upper end is `+∞` when the interval
    /// reaches the uniform limit).
    pub sigma_ci95: (f64, f64),
    /// Number of flakes used.
    pub flakes: usize,
    /// Effective number of flakes `(Σ a)²/Σ a²`.
    pub effective_n: f64,
    /// Area-weighted mean square tilt `m2`, rad².
    pub mean_square_tilt: f64,
}

impl WidthFit {
    /// Fitted hwhm `w = s·sqrt(2 ln 2)`, radians.
    pub fn hwhm(&self) -> f64 {
        self.sigma * HWHM_PER_SIGMA
    }

    /// 95 % confidence interval of the hwhm, radians.
    pub fn hwhm_ci95(&self) -> (f64, f64) {
        (
            self.sigma_ci95.0 * HWHM_PER_SIGMA,
            self.sigma_ci95.1 * HWHM_PER_SIGMA,
        )
    }

    /// The fitted distribution.
    ///
    /// # Errors
    /// When the fitted `s` is not below π/2 (a nearly uniform distribution).
    pub fn orientation(&self) -> Result<Orientation, crate::DistributionError> {
        Orientation::gaussian(GaussianWidth::Sigma(self.sigma))
    }
}

/// `π − 2 = ∫_0^{π/2} θ² sin θ dθ`: `E[θ²]` for a uniform `p̃` (the `s → ∞` limit).
const M2_UNIFORM: f64 = PI - 2.0;

/// `E_s[θ²]` under the truncated Gaussian, by quadrature.
fn mean_square(sigma: f64) -> f64 {
    let k = -0.5 / (sigma * sigma);
    let b = FRAC_PI_2.min(12.0 * sigma);
    let panels = ((b / (0.5 * sigma)).ceil() as usize).clamp(8, 64);
    let z = quad::integrate(|t| (k * t * t).exp() * t.sin(), 0.0, b, panels);
    let z2 = quad::integrate(|t| (k * t * t).exp() * t.sin() * t * t, 0.0, b, panels);
    z2 / z
}

/// Solves `E_s[θ²] = m2` for `s`; `None` if `m2` is not in `(0, π − 2)`.
fn sigma_for_mean_square(m2: f64) -> Option<f64> {
    if !(m2 > 0.0 && m2 < M2_UNIFORM) {
        return None;
    }
    // Bracket in ln s: E ≈ 2 s² for small s, E → π − 2 as s → ∞.
    let (mut lo, mut hi) = ((1e-9f64).ln(), (1e4f64).ln());
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mean_square(mid.exp()) < m2 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-13 {
            break;
        }
    }
    Some((0.5 * (lo + hi)).exp())
}

/// Maximum-likelihood Gaussian width from area-weighted flake polar angles
/// `(θn, area)` (radians, µm²), with a 95 % interval (module docs).
///
/// # Errors
/// [`FitError::Empty`], [`FitError::BadInput`], [`FitError::ZeroWidth`],
/// [`FitError::Unbounded`].
pub fn fit_gaussian_ml(samples: &[(f64, f64)]) -> Result<WidthFit, FitError> {
    if samples.is_empty() {
        return Err(FitError::Empty);
    }
    let (mut sa, mut sa2, mut st) = (0.0, 0.0, 0.0);
    for (index, &(theta, area)) in samples.iter().enumerate() {
        if !(area.is_finite() && area > 0.0) {
            return Err(FitError::BadInput {
                index,
                what: "area",
                value: area,
            });
        }
        if !(0.0..=FRAC_PI_2).contains(&theta) {
            return Err(FitError::BadInput {
                index,
                what: "theta_n",
                value: theta,
            });
        }
        sa += area;
        sa2 += area * area;
        st += area * theta * theta;
    }
    let m2 = st / sa;
    if m2 == 0.0 {
        return Err(FitError::ZeroWidth);
    }
    let sigma = sigma_for_mean_square(m2).ok_or(FitError::Unbounded { m2 })?;
    let var: f64 = samples
        .iter()
        .map(|&(t, a)| {
            let d = t * t - m2;
            a * a * d * d
        })
        .sum::<f64>()
        / (sa * sa);
    let se = var.sqrt();
    let lo_m2 = m2 - 1.96 * se;
    let hi_m2 = m2 + 1.96 * se;
    let lo = if lo_m2 > 0.0 {
        sigma_for_mean_square(lo_m2).unwrap_or(0.0)
    } else {
        0.0
    };
    let hi = sigma_for_mean_square(hi_m2).unwrap_or(f64::INFINITY);
    Ok(WidthFit {
        sigma,
        sigma_ci95: (lo, hi),
        flakes: samples.len(),
        effective_n: sa * sa / sa2,
        mean_square_tilt: m2,
    })
}

/// Result of [`fit_gaussian_histogram`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistogramFit {
    /// Fitted `s`, radians.
    pub sigma: f64,
    /// Fitted amplitude `A` multiplying the normalised model (1 for a perfect
    /// normalised histogram).
    pub amplitude: f64,
    /// Root mean square of the residuals of `p̃` over the bins used.
    pub rms_residual: f64,
}

impl HistogramFit {
    /// Fitted hwhm, radians.
    pub fn hwhm(&self) -> f64 {
        self.sigma * HWHM_PER_SIGMA
    }
}

/// Least-squares fit of `A · p̃_model(s)` to a histogram's `p̃` values, unweighted over
/// all bins. The model value of a bin is its exact bin average
/// `mass(lo, hi; s)/(cos lo − cos hi)` (same normalisation as the histogram), so binning
/// does not bias `s`. For each `s` the best `A` is linear least squares; `s` is found by a
/// scan over `ln s` on `[10⁻³, 1.3]` rad followed by golden-section refinement.
///
/// # Errors
/// [`FitError::EmptyHistogram`] if the histogram has no mass.
pub fn fit_gaussian_histogram(hist: &AreaHistogram) -> Result<HistogramFit, FitError> {
    let bins = hist.bins();
    if bins.iter().all(|b| b.area_fraction == 0.0) {
        return Err(FitError::EmptyHistogram);
    }
    // Residual sum of squares at s with the optimal amplitude; returns (rss, A).
    let eval = |s: f64| -> (f64, f64) {
        let Ok(d) = Orientation::gaussian(GaussianWidth::Sigma(s)) else {
            return (f64::INFINITY, 0.0);
        };
        let g: Vec<f64> = bins
            .iter()
            .map(|b| d.mass_between(b.theta_lo, b.theta_hi) / cos_diff(b.theta_lo, b.theta_hi))
            .collect();
        let gg: f64 = g.iter().map(|x| x * x).sum();
        let gy: f64 = g.iter().zip(&bins).map(|(x, b)| x * b.p_tilde).sum();
        if gg == 0.0 {
            return (f64::INFINITY, 0.0);
        }
        let a = gy / gg;
        let rss = g
            .iter()
            .zip(&bins)
            .map(|(x, b)| (b.p_tilde - a * x).powi(2))
            .sum();
        (rss, a)
    };
    let (l0, l1) = ((1e-3f64).ln(), (1.3f64).ln());
    let n = 80;
    let step = (l1 - l0) / n as f64;
    let mut best = (f64::INFINITY, 0usize);
    for i in 0..=n {
        let r = eval((l0 + i as f64 * step).exp()).0;
        if r < best.0 {
            best = (r, i);
        }
    }
    // Golden-section search within one scan step of the best grid point.
    let mut a = l0 + (best.1 as f64 - 1.0).max(0.0) * step;
    let mut b = l0 + (best.1 as f64 + 1.0).min(n as f64) * step;
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (eval(c.exp()).0, eval(d.exp()).0);
    for _ in 0..80 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = eval(c.exp()).0;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = eval(d.exp()).0;
        }
        if b - a < 1e-10 {
            break;
        }
    }
    let s = (0.5 * (a + b)).exp();
    let (rss, amp) = eval(s);
    Ok(HistogramFit {
        sigma: s,
        amplitude: amp,
        rms_residual: (rss / bins.len() as f64).sqrt(),
    })
}
