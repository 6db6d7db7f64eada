//! Area-weighted histograms of flake polar angles (paper Figs. 6, 7) and the slope
//! conversion of eq. 8.
//!
//! Conventions: angles in **radians**, areas in **µm²**. Bins are `[lo, hi)` of equal
//! width `Δθ` from `θ = 0`; the last bin is cut at `π/2` and also holds `θn = π/2`.
//!
//! Normalisation of the three per-bin values. With `m_i` the bin's share of the total
//! flake area (`Σ m_i = 1`):
//! * `area_fraction = m_i`;
//! * `p per rad = m_i/Δθ_i`, the bin average of `p(θ)` (`∫ p dθ` over the bin is `m_i`);
//! * `p̃ = m_i/(cos lo − cos hi)`. Derivation: `p̃ = 2π p2`, and with `p2` constant over
//!   the bin, `m_i = ∫ p2 dΩ = 2π p2 ∫_lo^hi sin θ dθ = 2π p2 (cos lo − cos hi)`. This is
//!   the exact solid-angle normalisation; dividing `p` by `sin` of the bin centre instead
//!   would blow up the first bin (`sin 0.5° ≈ 0.0087` for 1° bins) and bias the rest.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

use thiserror::Error;

use crate::distribution::{DistributionError, Orientation, cos_diff};
use crate::flake::Flake;
use flakescatter_numerics::legendre as quad;

/// Errors from building a histogram or converting slope statistics.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HistogramError {
    /// The bin width is not finite, `≤ 0` or `> π/4` (45°).
    #[error("bin width {0} rad must be finite, > 0 and <= π/4 (45°)")]
    BadBinWidth(f64),
    /// No flakes.
    #[error("no flakes to histogram")]
    Empty,
    /// A flake area is not finite or not positive.
    #[error("flake {index}: area {value} µm² must be finite and > 0")]
    BadArea {
        /// Index of the flake in the input.
        index: usize,
        /// The area, µm².
        value: f64,
    },
    /// A polar angle is NaN or outside `[0, π/2]`.
    #[error("flake {index}: polar angle {value} rad must lie in [0, π/2]")]
    BadTheta {
        /// Index of the flake in the input.
        index: usize,
        /// The angle, radians.
        value: f64,
    },
    /// The resulting tabulated distribution is invalid.
    #[error(transparent)]
    Distribution(#[from] DistributionError),
}

/// One row of an [`AreaHistogram`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistogramBin {
    /// Lower edge, radians.
    pub theta_lo: f64,
    /// Upper edge, radians.
    pub theta_hi: f64,
    /// Share of the total flake area in the bin.
    pub area_fraction: f64,
    /// `area_fraction/(θhi − θlo)`, per radian: the bin average of `p`.
    pub p_per_rad: f64,
    /// `area_fraction/(cos θlo − cos θhi)`: `p̃ = 2π p2` with `p2` constant in the bin.
    pub p_tilde: f64,
}

/// Area-weighted histogram of flake polar angles `θn` (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct AreaHistogram {
    edges: Vec<f64>,
    fractions: Vec<f64>,
    total_area_um2: f64,
    flakes: usize,
}

/// Bin edges `0, Δθ, 2Δθ, …` up to `π/2` (the last bin cut at `π/2`).
///
/// When `Δθ` is a decimal number of degrees converted to radians (`1.5f64.to_radians()`,
/// as every width from the command line, a manifest or Python is), edge `i` is the exact
/// decimal `i × 1.5°` converted ([`crate::decimal::bin_edges`]), so the edges read back
/// as `0, 1.5, 3, 4.5, …` degrees, not `1.5000000000000002`, `3.0000000000000004`;
/// otherwise `i × Δθ`.
///
/// # Errors
/// [`HistogramError::BadBinWidth`] unless `0 < Δθ ≤ π/4`.
pub fn bin_edges(bin_width: f64) -> Result<Vec<f64>, HistogramError> {
    if !(bin_width.is_finite() && bin_width > 0.0 && bin_width <= FRAC_PI_4 * (1.0 + 1e-12)) {
        return Err(HistogramError::BadBinWidth(bin_width));
    }
    let w_deg = crate::decimal::typed_degrees(bin_width);
    if w_deg.to_radians() == bin_width
        && let Some(edges) = crate::decimal::bin_edges(w_deg, 90.0)
    {
        let mut edges: Vec<f64> = edges.iter().map(|d| d.to_radians()).collect();
        if let Some(last) = edges.last_mut() {
            *last = FRAC_PI_2;
        }
        return Ok(edges);
    }
    // Guard against 90/Δ landing a hair above an integer through rounding.
    let n = ((FRAC_PI_2 / bin_width) * (1.0 - 1e-12)).ceil().max(1.0) as usize;
    let mut edges: Vec<f64> = (0..n).map(|i| i as f64 * bin_width).collect();
    edges.push(FRAC_PI_2);
    Ok(edges)
}

impl AreaHistogram {
    /// Histogram of `(θn, area)` pairs (radians, µm²) with bins of width `bin_width`
    /// radians.
    ///
    /// # Errors
    /// [`HistogramError::BadBinWidth`], [`HistogramError::Empty`],
    /// [`HistogramError::BadArea`], [`HistogramError::BadTheta`].
    pub fn new(
        samples: impl IntoIterator<Item = (f64, f64)>,
        bin_width: f64,
    ) -> Result<Self, HistogramError> {
        let edges = bin_edges(bin_width)?;
        let nb = edges.len() - 1;
        let mut areas = vec![0.0; nb];
        let mut total = 0.0;
        let mut flakes = 0;
        for (index, (theta, area)) in samples.into_iter().enumerate() {
            if !(area.is_finite() && area > 0.0) {
                return Err(HistogramError::BadArea { index, value: area });
            }
            if !(0.0..=FRAC_PI_2).contains(&theta) {
                return Err(HistogramError::BadTheta {
                    index,
                    value: theta,
                });
            }
            // The bin whose [lo, hi) holds θ, by the edges themselves.
            let mut i = ((theta / bin_width) as usize).min(nb - 1);
            while i + 1 < nb && theta >= edges[i + 1] {
                i += 1;
            }
            while i > 0 && theta < edges[i] {
                i -= 1;
            }
            areas[i] += area;
            total += area;
            flakes += 1;
        }
        if flakes == 0 {
            return Err(HistogramError::Empty);
        }
        Ok(Self {
            edges,
            fractions: areas.iter().map(|a| a / total).collect(),
            total_area_um2: total,
            flakes,
        })
    }

    /// Histogram of flakes (their `θn` and area).
    ///
    /// # Errors
    /// As [`AreaHistogram::new`].
    pub fn from_flakes(flakes: &[Flake], bin_width: f64) -> Result<Self, HistogramError> {
        Self::new(flakes.iter().map(|f| (f.theta_n(), f.area_um2)), bin_width)
    }

    /// Bin edges, radians (`bins + 1` values).
    pub fn edges(&self) -> &[f64] {
        &self.edges
    }

    /// Area fraction per bin (sums to 1).
    pub fn area_fractions(&self) -> &[f64] {
        &self.fractions
    }

    /// Total flake area, µm².
    pub fn total_area_um2(&self) -> f64 {
        self.total_area_um2
    }

    /// Number of flakes counted.
    pub fn flakes(&self) -> usize {
        self.flakes
    }

    /// The rows: edges, area fraction, `p` per radian and `p̃` (module docs).
    pub fn bins(&self) -> Vec<HistogramBin> {
        self.fractions
            .iter()
            .enumerate()
            .map(|(i, &m)| {
                let (lo, hi) = (self.edges[i], self.edges[i + 1]);
                HistogramBin {
                    theta_lo: lo,
                    theta_hi: hi,
                    area_fraction: m,
                    p_per_rad: m / (hi - lo),
                    p_tilde: m / cos_diff(lo, hi),
                }
            })
            .collect()
    }

    /// The histogram as a tabulated [`Orientation`] (same edges and masses).
    ///
    /// # Errors
    /// Never for a histogram built by this type; the `Result` is passed through.
    pub fn to_orientation(&self) -> Result<Orientation, HistogramError> {
        Ok(Orientation::tabulated(
            self.edges.clone(),
            self.fractions.clone(),
        )?)
    }
}

/// Paper eq. 8 in its derived form: the flake-**area** density `p̃(θ)`, up to a constant,
/// from the density `P(ζ)` of slope magnitude `ζ = tan θ` for points drawn uniformly in
/// the `xy`-plane: `p̃(θ) ∝ P(tan θ)/(sin θ cos³ θ)`.
///
/// Derivation (`physics.md` §3): projected area with slope in `dζ` is `P(ζ) dζ`; the
/// true area is larger by `1/cos θ`, and `dζ = dθ/cos² θ`, so the area per `dθ` is
/// `p(θ) ∝ P(tan θ)/cos³ θ` and `p̃ = p/sin θ`. The constant is `1/⟨sec θ⟩`, the
/// projected-to-true area ratio.
///
/// The paper prints `P(tan θ)/(sin θ cos θ)`, which misses the factor `1/cos² θ`: its
/// area density falls too slowly at large tilts (by `cos² θ`, 12 % at 20°). The sampling
/// test in `tests/flake.rs` shows which form holds. `theta_n` in `(0, π/2)`, radians.
pub fn p_tilde_from_slope_pdf(slope_pdf: impl Fn(f64) -> f64, theta_n: f64) -> f64 {
    let (s, c) = theta_n.sin_cos();
    slope_pdf(theta_n.tan()) / (s * c * c * c)
}

/// Tabulated area-weighted distribution from the slope-magnitude density `P(ζ)` (points
/// uniform in `xy`, see [`p_tilde_from_slope_pdf`]), on the given bin edges (radians,
/// strictly increasing in `[0, π/2]`). Bin masses `∫ P(tan θ)/cos³ θ dθ` by 16-point
/// Gauss–Legendre on 8 panels per bin, renormalised over the covered range.
///
/// # Errors
/// [`HistogramError::Distribution`] for bad edges or if all masses vanish.
pub fn orientation_from_slope_pdf(
    slope_pdf: impl Fn(f64) -> f64,
    edges_rad: Vec<f64>,
) -> Result<Orientation, HistogramError> {
    let masses = edges_rad
        .windows(2)
        .map(|w| {
            let hi = w[1].min(FRAC_PI_2 * (1.0 - 1e-12));
            if hi > w[0] {
                quad::integrate(
                    |t| {
                        let c = t.cos();
                        slope_pdf(t.tan()) / (c * c * c)
                    },
                    w[0],
                    hi,
                    8,
                )
            } else {
                0.0
            }
        })
        .collect();
    Ok(Orientation::tabulated(edges_rad, masses)?)
}
