//! Distributions of flake normals (paper eqs. 3, 4; `physics.md` §3).
//!
//! Conventions:
//! * Angles in **radians**. `θn ∈ [0, π/2]` is the polar angle of a flake normal from the
//!   coating normal `z` (pointing into the air); `φn` is its azimuth from `x`, and every
//!   distribution here is azimuthally isotropic.
//! * All densities are **area-weighted**: they describe where the flake *area* points, not
//!   the flake count.
//! * `p2(θn)`: flake area fraction per steradian of normals, `∫ p2 dΩ = 1` over the upper
//!   hemisphere (`dΩ = sin θ dθ dφ`).
//! * `p(θn) = 2π sin θn p2(θn)` (eq. 3): per radian of polar angle, `∫_0^{π/2} p dθ = 1`.
//! * `p̃(θn) = p/sin θn = 2π p2(θn)` (eq. 4): finite at `θn = 0`, `∫_0^{π/2} p̃ sin θ dθ = 1`.
//! * `D(θn) = p2/⟨cos θn⟩` (macro-area density, Germer–Marx facet model):
//!   `∫ D cos θ dΩ = 1`, flake area per unit coating area per steradian.
//! * The Gaussian family is `p̃(θ) ∝ exp(-θ²/(2s²))` on `[0, π/2)`, normalised exactly on
//!   that interval (16-point Gauss–Legendre on panels of at most `s/2`, exact to rounding;
//!   no small-angle approximation). Its width is given as exactly one of
//!   [`GaussianWidth::Hwhm`] `w = s·sqrt(2 ln 2)`, [`GaussianWidth::Sigma`] `s`, or
//!   [`GaussianWidth::RmsTilt`] `σt = s·√2`.
//! * The Pearson VII family (heavy-tailed; physics.md §3) is Student-t distributed
//!   slopes: `D(θ) = (1 + tan²θ/(γ α²))^(−(γ+1)) / (π α² cos⁴θ)`, which satisfies
//!   `∫ D cos θ dΩ = 1` exactly over the hemisphere, with width `α` (the slope scale) and
//!   shape `γ > 1/2`; `γ = 1` is Trowbridge–Reitz (GGX), `γ → ∞` Beckmann. `⟨cos θn⟩ =
//!   1/∫ D dΩ` is computed by quadrature in the slopes' tail probability (relative error
//!   below 1e-12).
//! * The log-linear table (a smooth tabulated `p̃`, for fits) gives `ln p̃` at knots
//!   `0 = θ0 < … < θK ≤ π/2`, linear in between, zero beyond `θK`; normalised by
//!   Gauss–Legendre on each segment (exact to rounding against the closed form
//!   `∫ e^(a+bθ) sin θ dθ = e^(a+bθ)(b sin θ − cos θ)/(1 + b²)`).

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Unit, Vector3};
use rand::RngExt;
use thiserror::Error;

use flakescatter_numerics::legendre as quad;

mod log_linear;
mod pearson;
mod tabulated;
mod width;

use log_linear::{LogLinear, log_linear_panels};
use pearson::Pearson;
use tabulated::Tabulated;
pub use width::{GaussianWidth, HWHM_PER_SIGMA, MIN_GAUSSIAN_WIDTH};

/// Errors from building an [`Orientation`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DistributionError {
    /// A Gaussian width is not finite, below [`MIN_GAUSSIAN_WIDTH`], or not below π/2.
    #[error(
        "Gaussian {kind} = {value} rad ({} degrees) must be finite, at least 1e-10 rad (5.7e-9 degrees; a narrower distribution is the all-flat limit to double precision) and below pi/2 (90 degrees)",
        .value.to_degrees()
    )]
    BadWidth {
        /// `"hwhm"`, `"sigma"` or `"rms-tilt"`.
        kind: &'static str,
        /// The value given, radians.
        value: f64,
    },
    /// The numbers of edges and masses do not match (`edges = masses + 1`, at least one
    /// bin).
    #[error(
        "tabulated distribution needs n + 1 edges for n >= 1 bins, got {edges} edges and {masses} masses"
    )]
    BinCount {
        /// Number of edges given.
        edges: usize,
        /// Number of masses given.
        masses: usize,
    },
    /// An edge is outside `[0, π/2]` or not finite.
    #[error("bin edge {index} = {value} rad is outside [0, π/2]")]
    EdgeOutOfRange {
        /// Index of the edge.
        index: usize,
        /// Its value, radians.
        value: f64,
    },
    /// Edges are not strictly increasing.
    #[error("bin edges must increase strictly: edge {index} = {value} rad follows {previous} rad")]
    EdgesNotIncreasing {
        /// Index of the offending edge.
        index: usize,
        /// Its value, radians.
        value: f64,
        /// The edge before it, radians.
        previous: f64,
    },
    /// A mass is negative or not finite.
    #[error("area fraction of bin {index} = {value} must be finite and >= 0")]
    BadMass {
        /// Index of the bin.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// Every mass is zero.
    #[error("tabulated distribution has zero total area")]
    ZeroTotal,
    /// A Pearson VII width `α` (a slope scale) that is not finite and positive, or a
    /// shape outside `[MIN_PEARSON_SHAPE, MAX_PEARSON_SHAPE]`.
    #[error(
        "Pearson VII alpha = {alpha} (a slope, tan of an angle) must be finite and in [1e-6, 100], and shape = {shape} in [0.55, 1e4] (at 1/2 and below the flake area diverges)"
    )]
    BadPearson {
        /// The width given.
        alpha: f64,
        /// The shape given.
        shape: f64,
    },
    /// Knots of a log-linear table that are not `0 = θ0 < θ1 < … ≤ π/2`, at least two,
    /// with one finite `ln p̃` each.
    #[error("log-linear table: {0}")]
    BadKnots(String),
    /// A bin that carries area is so narrow that its solid angle underflows (its density
    /// would be infinite).
    #[error(
        "bin {index} [{lo} rad, {hi} rad] carries area but is too narrow for double precision (its solid angle underflows)"
    )]
    BinTooNarrow {
        /// Index of the bin.
        index: usize,
        /// Its lower edge, radians.
        lo: f64,
        /// Its upper edge, radians.
        hi: f64,
    },
}

/// The smallest Pearson VII shape accepted: at `γ ≤ 1/2` the flake area `∫ D dΩ`
/// diverges (the tail of `D sin θ` near the horizon is `cos^(2γ−2) θ`).
pub const MIN_PEARSON_SHAPE: f64 = 0.55;

/// The largest Pearson VII shape accepted; beyond it the family is Beckmann to 1e-3.
pub const MAX_PEARSON_SHAPE: f64 = 1e4;

/// Precomputed Gaussian member.
#[derive(Debug, Clone, PartialEq)]
struct Gaussian {
    width: GaussianWidth,
    /// `s`, radians.
    sigma: f64,
    /// `-1/(2 s²)`.
    neg_half_inv_s2: f64,
    /// `C` such that `p̃ = C exp(-θ²/(2s²))`.
    p_tilde_norm: f64,
    /// `C/(2π)`, the `p2` prefactor.
    p2_norm: f64,
    mean_cos: f64,
}

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    Gaussian(Gaussian),
    Tabulated(Tabulated),
    Pearson(Pearson),
    LogLinear(LogLinear),
    Flat,
}

/// An azimuthally isotropic, area-weighted distribution of flake normals (see the module
/// docs for `p2`, `p`, `p̃`, `D` and their normalisations).
#[derive(Debug, Clone, PartialEq)]
pub struct Orientation {
    kind: Kind,
}

/// `cos lo − cos hi` written as `2 sin((hi + lo)/2) sin((hi − lo)/2)`: no cancellation
/// for narrow bins (the plain difference loses all digits for a bin of 1e-8 rad near 0).
#[must_use]
#[inline]
pub fn cos_diff(lo: f64, hi: f64) -> f64 {
    2.0 * (0.5 * (hi + lo)).sin() * (0.5 * (hi - lo)).sin()
}

/// `sqrt(2·745.2)`: `exp(-θ²/(2s²))` underflows to exactly 0 in `f64` beyond
/// `θ = GAUSSIAN_ZERO_BEYOND · s` (`exp(x) = 0` for `x < −745.14`), rounded up.
const GAUSSIAN_ZERO_BEYOND: f64 = 38.7;

/// Panels for the Gaussian integrals: upper limit `min(π/2, 12 s)` (the tail beyond
/// `12 s` is below `e^{-72}` of the peak), panel width at most `s/2`.
fn gaussian_limits(sigma: f64) -> (f64, usize) {
    let b = FRAC_PI_2.min(12.0 * sigma);
    let panels = ((b / (0.5 * sigma)).ceil() as usize).clamp(8, 64);
    (b, panels)
}

impl Orientation {
    /// A Gaussian `p̃(θ) ∝ exp(-θ²/(2 s²))` on `[0, π/2)`, normalised exactly.
    ///
    /// # Errors
    /// [`DistributionError::BadWidth`] unless the given value is finite, at least
    /// [`MIN_GAUSSIAN_WIDTH`] and `< π/2`.
    pub fn gaussian(width: GaussianWidth) -> Result<Self, DistributionError> {
        let v = width.value();
        if !(MIN_GAUSSIAN_WIDTH..FRAC_PI_2).contains(&v) {
            return Err(DistributionError::BadWidth {
                kind: width.name(),
                value: v,
            });
        }
        let sigma = width.sigma();
        let k = -0.5 / (sigma * sigma);
        let (b, panels) = gaussian_limits(sigma);
        let z = quad::integrate(|t| (k * t * t).exp() * t.sin(), 0.0, b, panels);
        let zc = quad::integrate(|t| (k * t * t).exp() * t.sin() * t.cos(), 0.0, b, panels);
        let c = 1.0 / z;
        Ok(Self {
            kind: Kind::Gaussian(Gaussian {
                width,
                sigma,
                neg_half_inv_s2: k,
                p_tilde_norm: c,
                p2_norm: c / (2.0 * PI),
                mean_cos: zc / z,
            }),
        })
    }

    /// A tabulated distribution: `n + 1` strictly increasing bin edges in `[0, π/2]`
    /// (radians) and `n` non-negative area masses, renormalised to sum to 1. `p2` is
    /// constant within a bin, `mass / (2π (cos lo − cos hi))` (exact solid-angle bin
    /// normalisation), and zero outside `[edges[0], edges[n])`.
    ///
    /// # Errors
    /// [`DistributionError::BinCount`], [`DistributionError::EdgeOutOfRange`],
    /// [`DistributionError::EdgesNotIncreasing`], [`DistributionError::BadMass`],
    /// [`DistributionError::ZeroTotal`], [`DistributionError::BinTooNarrow`].
    pub fn tabulated(
        edges_rad: Vec<f64>,
        area_fractions: Vec<f64>,
    ) -> Result<Self, DistributionError> {
        if area_fractions.is_empty() || edges_rad.len() != area_fractions.len() + 1 {
            return Err(DistributionError::BinCount {
                edges: edges_rad.len(),
                masses: area_fractions.len(),
            });
        }
        for (index, &value) in edges_rad.iter().enumerate() {
            if !(0.0..=FRAC_PI_2).contains(&value) {
                return Err(DistributionError::EdgeOutOfRange { index, value });
            }
            if index > 0 && value <= edges_rad[index - 1] {
                return Err(DistributionError::EdgesNotIncreasing {
                    index,
                    value,
                    previous: edges_rad[index - 1],
                });
            }
        }
        for (index, &value) in area_fractions.iter().enumerate() {
            if !(value.is_finite() && value >= 0.0) {
                return Err(DistributionError::BadMass { index, value });
            }
        }
        let total: f64 = area_fractions.iter().sum();
        if total <= 0.0 || !total.is_finite() {
            return Err(DistributionError::ZeroTotal);
        }
        let masses: Vec<f64> = area_fractions.iter().map(|m| m / total).collect();
        let mut cdf = Vec::with_capacity(masses.len());
        let mut acc = 0.0;
        for m in &masses {
            acc += m;
            cdf.push(acc);
        }
        *cdf.last_mut().expect("at least one bin") = 1.0;
        let mut p2 = Vec::with_capacity(masses.len());
        let mut mean_cos = 0.0;
        for (i, m) in masses.iter().enumerate() {
            let (clo, chi) = (edges_rad[i].cos(), edges_rad[i + 1].cos());
            let density = if *m == 0.0 {
                0.0
            } else {
                m / (2.0 * PI * cos_diff(edges_rad[i], edges_rad[i + 1]))
            };
            if !density.is_finite() {
                return Err(DistributionError::BinTooNarrow {
                    index: i,
                    lo: edges_rad[i],
                    hi: edges_rad[i + 1],
                });
            }
            p2.push(density);
            // Within a bin p2 is constant, so cos θ is uniform on [cos hi, cos lo].
            mean_cos += m * 0.5 * (clo + chi);
        }
        Ok(Self {
            kind: Kind::Tabulated(Tabulated {
                edges: edges_rad,
                masses,
                cdf,
                p2,
                mean_cos,
            }),
        })
    }

    /// All flakes flat: a delta at `θn = 0`. Its densities ([`Orientation::p2`],
    /// [`Orientation::p`], [`Orientation::p_tilde`], [`Orientation::macro_density`]) are
    /// reported as 0 everywhere (a delta has no finite density; check
    /// [`Orientation::is_delta`]); `⟨cos θn⟩ = 1` and sampling always returns `z`.
    pub fn flat() -> Self {
        Self { kind: Kind::Flat }
    }

    /// The Pearson VII family (heavy-tailed, Student-t slopes; module docs):
    /// `D(θ) = (1 + tan²θ/(γ α²))^(−(γ+1)) / (π α² cos⁴θ)`, slope scale `alpha`
    /// (dimensionless, `tan` of an angle) and shape `shape = γ`. `γ = 1` is
    /// Trowbridge–Reitz (GGX): [`Orientation::trowbridge_reitz`].
    ///
    /// # Errors
    /// [`DistributionError::BadPearson`] unless `alpha ∈ [1e-6, 100]` and
    /// `shape ∈ [MIN_PEARSON_SHAPE, MAX_PEARSON_SHAPE]`.
    pub fn pearson_vii(alpha: f64, shape: f64) -> Result<Self, DistributionError> {
        if !((1e-6..=100.0).contains(&alpha)
            && (MIN_PEARSON_SHAPE..=MAX_PEARSON_SHAPE).contains(&shape))
        {
            return Err(DistributionError::BadPearson { alpha, shape });
        }
        let mut p = Pearson {
            alpha,
            shape,
            inv_ga2: 1.0 / (shape * alpha * alpha),
            mean_cos: 1.0,
            cdf: std::sync::OnceLock::new(),
        };
        // ∫ D dΩ = ∫_0^1 sqrt(1 + s(u)²) du in the slopes' tail probability u, taken as
        // u = w^k so that the integrand, ~ u^(−1/(2γ)) at u → 0, is bounded in w.
        p.mean_cos = 1.0 / p.area_integral(0.0, 1.0);
        Ok(Self {
            kind: Kind::Pearson(p),
        })
    }

    /// Trowbridge–Reitz (GGX) flake normals of slope scale `alpha`:
    /// `D(θ) = α² / (π cos⁴θ (α² + tan²θ)²)`, the Pearson VII family at shape 1.
    ///
    /// # Errors
    /// As [`Orientation::pearson_vii`].
    pub fn trowbridge_reitz(alpha: f64) -> Result<Self, DistributionError> {
        Self::pearson_vii(alpha, 1.0)
    }

    /// A smooth tabulated distribution: `ln p̃` given at `knots` (radians,
    /// `0 = θ0 < θ1 < … < θK ≤ π/2`, at least two), linear in `θ` between them, zero
    /// beyond `θK`; normalised so that `∫ p̃ sin θ dθ = 1` (only differences of the given
    /// values matter).
    ///
    /// # Errors
    /// [`DistributionError::BadKnots`] for knots that do not start at 0, do not increase
    /// strictly, end beyond π/2, or values that are not finite or not one per knot.
    pub fn log_linear(knots: Vec<f64>, ln_p_tilde: Vec<f64>) -> Result<Self, DistributionError> {
        let bad = |m: String| Err(DistributionError::BadKnots(m));
        if knots.len() < 2 || knots.len() != ln_p_tilde.len() {
            return bad(format!(
                "{} knots and {} values: need at least two knots and one value each",
                knots.len(),
                ln_p_tilde.len()
            ));
        }
        if knots[0] != 0.0 {
            return bad(format!("the first knot is {} rad, not 0", knots[0]));
        }
        if let Some(i) = (1..knots.len()).find(|&i| !(knots[i] > knots[i - 1])) {
            return bad(format!(
                "knot {i} = {} rad does not exceed knot {} = {} rad",
                knots[i],
                i - 1,
                knots[i - 1]
            ));
        }
        if !(knots[knots.len() - 1] <= FRAC_PI_2) {
            return bad(format!(
                "the last knot {} rad is beyond pi/2",
                knots[knots.len() - 1]
            ));
        }
        if let Some(i) = ln_p_tilde.iter().position(|v| !v.is_finite()) {
            return bad(format!("ln p~ at knot {i} is {}", ln_p_tilde[i]));
        }
        let top = ln_p_tilde.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let shifted: Vec<f64> = ln_p_tilde.iter().map(|v| v - top).collect();
        let segs = knots.len() - 1;
        let mut masses = Vec::with_capacity(segs);
        let mut cos_moment = 0.0;
        for j in 0..segs {
            let (a, b, la, lb) = (knots[j], knots[j + 1], shifted[j], shifted[j + 1]);
            let panels = log_linear_panels(la, lb);
            let slope = (lb - la) / (b - a);
            masses.push(quad::integrate(
                |t| (la + slope * (t - a)).exp() * t.sin(),
                a,
                b,
                panels,
            ));
            cos_moment += quad::integrate(
                |t| (la + slope * (t - a)).exp() * t.sin() * t.cos(),
                a,
                b,
                panels,
            );
        }
        let z: f64 = masses.iter().sum();
        if !(z > 0.0 && z.is_finite()) {
            return bad(format!("the total area {z} is not positive"));
        }
        let ln_z = z.ln();
        let ln_norm: Vec<f64> = shifted.iter().map(|v| v - ln_z).collect();
        let masses: Vec<f64> = masses.iter().map(|m| m / z).collect();
        let mut cdf = Vec::with_capacity(segs);
        let mut acc = 0.0;
        for m in &masses {
            acc += m;
            cdf.push(acc);
        }
        *cdf.last_mut().expect("at least one segment") = 1.0;
        Ok(Self {
            kind: Kind::LogLinear(LogLinear {
                knots,
                ln_p_tilde,
                ln_norm,
                masses,
                cdf,
                mean_cos: cos_moment / z,
            }),
        })
    }

    /// Pearson VII parameters `(α, γ)`, if this is one.
    pub fn pearson_vii_params(&self) -> Option<(f64, f64)> {
        match &self.kind {
            Kind::Pearson(p) => Some((p.alpha, p.shape)),
            _ => None,
        }
    }

    /// Knots (radians) and `ln p̃` as given, if this is a log-linear table.
    pub fn log_linear_knots(&self) -> Option<(&[f64], &[f64])> {
        match &self.kind {
            Kind::LogLinear(t) => Some((&t.knots, &t.ln_p_tilde)),
            _ => None,
        }
    }

    /// Flake area per steradian of normals at polar angle `theta_n` (radians);
    /// `∫ p2 dΩ = 1` over the upper hemisphere. Zero outside the support (negative,
    /// `≥ π/2` for a Gaussian, outside the edges for a table, NaN) and for [`Orientation::flat`].
    #[inline]
    pub fn p2(&self, theta_n: f64) -> f64 {
        match &self.kind {
            Kind::Gaussian(g) => {
                if (0.0..FRAC_PI_2).contains(&theta_n) {
                    g.p2_norm * (g.neg_half_inv_s2 * theta_n * theta_n).exp()
                } else {
                    0.0
                }
            }
            Kind::Tabulated(t) => t.bin_of(theta_n).map_or(0.0, |i| t.p2[i]),
            Kind::Pearson(p) => {
                if (0.0..FRAC_PI_2).contains(&theta_n) {
                    p.macro_density(theta_n) * p.mean_cos
                } else {
                    0.0
                }
            }
            Kind::LogLinear(t) => t.p_tilde(theta_n) / (2.0 * PI),
            Kind::Flat => 0.0,
        }
    }

    /// `p(θn) = 2π sin θn p2(θn)`, area fraction per radian of polar angle,
    /// `∫_0^{π/2} p dθ = 1` (eq. 3).
    pub fn p(&self, theta_n: f64) -> f64 {
        2.0 * PI * theta_n.sin() * self.p2(theta_n)
    }

    /// `p̃(θn) = 2π p2(θn)` (eq. 4), `∫_0^{π/2} p̃ sin θ dθ = 1`.
    pub fn p_tilde(&self, theta_n: f64) -> f64 {
        2.0 * PI * self.p2(theta_n)
    }

    /// `⟨cos θn⟩ = ∫ p2 cos θ dΩ`, the projected area of the flakes per unit flake area
    /// (exact: quadrature for the Gaussian, closed form per bin for a table, 1 for flat).
    pub fn mean_cos(&self) -> f64 {
        match &self.kind {
            Kind::Gaussian(g) => g.mean_cos,
            Kind::Tabulated(t) => t.mean_cos,
            Kind::Pearson(p) => p.mean_cos,
            Kind::LogLinear(t) => t.mean_cos,
            Kind::Flat => 1.0,
        }
    }

    /// Macro-area density `D = p2/⟨cos θn⟩`, per steradian, `∫ D cos θ dΩ = 1`
    /// (Germer–Marx facet model normalisation). Zero for [`Orientation::flat`].
    pub fn macro_density(&self, theta_n: f64) -> f64 {
        self.p2(theta_n) / self.mean_cos()
    }

    /// Upper end of the support, radians: π/2 for a Gaussian, the last edge for a table,
    /// 0 for flat.
    pub fn max_theta(&self) -> f64 {
        match &self.kind {
            Kind::Gaussian(_) | Kind::Pearson(_) => FRAC_PI_2,
            Kind::Tabulated(t) => *t.edges.last().expect("at least two edges"),
            Kind::LogLinear(t) => *t.knots.last().expect("at least two knots"),
            Kind::Flat => 0.0,
        }
    }

    /// `true` for [`Orientation::flat`] (a delta; densities are reported as 0).
    pub fn is_delta(&self) -> bool {
        matches!(self.kind, Kind::Flat)
    }

    /// The narrowest angular feature that carries light, radians: what a quadrature over
    /// exit directions must resolve. `s` for a Gaussian; 0 for flat. For a table, the
    /// smaller of the width of its support (first to last bin with area) and the width
    /// of its narrowest *isolated* bin, one with area whose `p2` exceeds twice that of
    /// each neighbour (a spike or a thin ring). Steps between comparable neighbouring
    /// bins are not features in this sense: they hold no concentrated light, and rules
    /// that do not locate them resolve them to ~1e-3 with an error estimate that says so.
    pub fn narrowest_feature(&self) -> f64 {
        match &self.kind {
            Kind::Gaussian(g) => g.sigma,
            Kind::Tabulated(t) => {
                let first = t.masses.iter().position(|m| *m > 0.0).unwrap_or(0);
                let mut feature = self.support_end() - t.edges[first];
                let n = t.masses.len();
                for i in (0..n).filter(|&i| t.masses[i] > 0.0) {
                    let left = if i > 0 { t.p2[i - 1] } else { 0.0 };
                    let right = if i + 1 < n { t.p2[i + 1] } else { 0.0 };
                    if t.p2[i] > 2.0 * left.max(right) {
                        feature = feature.min(t.edges[i + 1] - t.edges[i]);
                    }
                }
                feature
            }
            // The slope scale, as an angle.
            Kind::Pearson(p) => p.alpha.atan(),
            // The shortest e-folding length of p̃ over the segments that carry light.
            Kind::LogLinear(t) => {
                let mut feature = *t.knots.last().expect("knots");
                for j in (0..t.masses.len()).filter(|&j| t.masses[j] > 1e-9) {
                    let h = t.knots[j + 1] - t.knots[j];
                    let dl = (t.ln_norm[j + 1] - t.ln_norm[j]).abs();
                    feature = feature.min(h / dl.max(1.0));
                }
                feature
            }
            Kind::Flat => 0.0,
        }
    }

    /// The polar angle beyond which [`Orientation::p2`] is exactly zero, radians: for a
    /// Gaussian `min(π/2, 38.7 s)` (where `exp(−θ²/(2s²))` underflows in `f64`), for a
    /// table the upper edge of the last bin that carries area, 0 for flat.
    pub fn support_end(&self) -> f64 {
        match &self.kind {
            Kind::Gaussian(g) => FRAC_PI_2.min(GAUSSIAN_ZERO_BEYOND * g.sigma),
            Kind::Tabulated(t) => t
                .masses
                .iter()
                .rposition(|m| *m > 0.0)
                .map_or(0.0, |i| t.edges[i + 1]),
            Kind::Pearson(_) => FRAC_PI_2,
            Kind::LogLinear(t) => *t.knots.last().expect("knots"),
            Kind::Flat => 0.0,
        }
    }

    /// The bin edges of a tabulated distribution (radians), where `p2` jumps; `None`
    /// for the other kinds.
    pub fn bin_edges(&self) -> Option<&[f64]> {
        match &self.kind {
            Kind::Tabulated(t) => Some(&t.edges),
            _ => None,
        }
    }

    /// The Gaussian width as given, if this is a Gaussian.
    pub fn gaussian_width(&self) -> Option<GaussianWidth> {
        match &self.kind {
            Kind::Gaussian(g) => Some(g.width),
            _ => None,
        }
    }

    /// Area fraction with `θn` in `[lo, hi]` (radians), `∫_lo^hi p dθ`. Exact for a table
    /// and for flat (1 if `lo ≤ 0 ≤ hi`); 16-point Gauss–Legendre on panels of at most
    /// `s/2` for a Gaussian.
    pub fn mass_between(&self, lo: f64, hi: f64) -> f64 {
        let lo = lo.max(0.0);
        let hi = hi.min(self.max_theta());
        match &self.kind {
            Kind::Flat => {
                if lo <= 0.0 && hi >= 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            _ if hi.is_nan() || lo.is_nan() || hi <= lo => 0.0,
            Kind::Gaussian(g) => {
                // The density is exactly zero in f64 beyond GAUSSIAN_ZERO_BEYOND · s, so
                // the panels (at most s/2 wide) only cover where it is not.
                let hi = hi.min(GAUSSIAN_ZERO_BEYOND * g.sigma);
                if hi <= lo {
                    return 0.0;
                }
                let n = ((hi - lo) / (0.5 * g.sigma)).ceil().clamp(1.0, 1e4) as usize;
                let k = g.neg_half_inv_s2;
                g.p_tilde_norm * quad::integrate(|t| (k * t * t).exp() * t.sin(), lo, hi, n)
            }
            Kind::Tabulated(t) => {
                // Within bin i the mass between a and b is p2_i · 2π (cos a − cos b).
                let mut m = 0.0;
                for i in 0..t.masses.len() {
                    let a = t.edges[i].max(lo);
                    let b = t.edges[i + 1].min(hi);
                    if b > a {
                        m += t.p2[i] * 2.0 * PI * cos_diff(a, b);
                    }
                }
                m
            }
            Kind::Pearson(p) => {
                // θ ∈ [lo, hi] is w ∈ [w(hi), w(lo)] (w decreases with the slope).
                let (wa, wb) = (p.w_of_theta(hi), p.w_of_theta(lo));
                p.area_integral(wa, wb) * p.mean_cos
            }
            Kind::LogLinear(t) => (0..t.masses.len())
                .map(|j| {
                    let a = t.knots[j].max(lo);
                    let b = t.knots[j + 1].min(hi);
                    if b > a { t.partial(j, a, b) } else { 0.0 }
                })
                .sum(),
        }
    }

    /// Draws one flake normal, area-weighted: `θn` from `p`, `φn` uniform on `[0, 2π)`,
    /// `z ≥ 0`. Exact: rejection from a Rayleigh proposal (acceptance `sin θ/θ`) for the
    /// Gaussian, inverse CDF in `cos θ` within a bin for a table, `z` for flat.
    pub fn sample_normal<R: rand::Rng + ?Sized>(&self, rng: &mut R) -> Unit<Vector3<f64>> {
        let theta = match &self.kind {
            Kind::Flat => return Vector3::z_axis(),
            Kind::Gaussian(g) => loop {
                // Rayleigh density ∝ θ exp(-θ²/(2s²)); the target is ∝ sin θ exp(..),
                // so accept with probability sin θ / θ ≤ 1.
                let u: f64 = rng.random();
                let t = g.sigma * (-2.0 * (1.0 - u).ln()).sqrt();
                if t >= FRAC_PI_2 {
                    continue;
                }
                let v: f64 = rng.random();
                if t == 0.0 || v * t < t.sin() {
                    break t;
                }
            },
            Kind::Tabulated(t) => {
                let u: f64 = rng.random();
                let i = t.cdf.partition_point(|&c| c <= u).min(t.masses.len() - 1);
                // cos θ uniform within the bin, written with 1 − cos θ = 2 sin²(θ/2) so
                // that narrow bins near the normal keep their digits.
                let (lo, hi) = (t.edges[i], t.edges[i + 1]);
                let v: f64 = rng.random();
                let h_lo = (0.5 * lo).sin().powi(2);
                let h = h_lo + v * 0.5 * cos_diff(lo, hi);
                2.0 * h.clamp(0.0, 1.0).sqrt().asin()
            }
            Kind::Pearson(p) => p.sample_theta(rng.random()),
            Kind::LogLinear(t) => t.sample_theta(rng.random()),
        };
        let phi = 2.0 * PI * rng.random::<f64>();
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        Unit::new_unchecked(Vector3::new(st * cp, st * sp, ct))
    }
}
