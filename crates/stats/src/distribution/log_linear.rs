//! The log-linear table (`ln p̃` linear between knots; parent module docs): its
//! normalisation on Gauss–Legendre panels and its sampling.

use flakescatter_numerics::legendre as quad;

/// Precomputed log-linear member.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LogLinear {
    /// Knots, radians, `0 = θ0 < … < θK ≤ π/2`.
    pub(super) knots: Vec<f64>,
    /// `ln p̃` at the knots as given.
    pub(super) ln_p_tilde: Vec<f64>,
    /// `ln p̃` at the knots, normalised (`∫ p̃ sin θ dθ = 1`).
    pub(super) ln_norm: Vec<f64>,
    /// Mass of each segment (sums to 1) and cumulative masses.
    pub(super) masses: Vec<f64>,
    pub(super) cdf: Vec<f64>,
    pub(super) mean_cos: f64,
}

/// Panels of the Gauss–Legendre rule on a log-linear segment from `ln p̃ = la` to `lb`:
/// one per unit change of `ln p̃` (the rule is exact to rounding for `e^(bθ) sin θ` over
/// such a panel).
pub(super) fn log_linear_panels(la: f64, lb: f64) -> usize {
    ((lb - la).abs().ceil() as usize).clamp(1, 4096)
}

impl LogLinear {
    /// Normalised `p̃(θ)`, zero outside `[0, θK)`.
    #[inline]
    pub(super) fn p_tilde(&self, theta: f64) -> f64 {
        let last = *self.knots.last().expect("knots");
        if !(theta >= 0.0 && theta < last) {
            return 0.0;
        }
        let j = self.knots.partition_point(|&k| k <= theta) - 1;
        let (a, b) = (self.knots[j], self.knots[j + 1]);
        let (la, lb) = (self.ln_norm[j], self.ln_norm[j + 1]);
        (la + (lb - la) * ((theta - a) / (b - a))).exp()
    }

    /// Area fraction of segment `j` between `a` and `b` (within the segment).
    pub(super) fn partial(&self, j: usize, a: f64, b: f64) -> f64 {
        let (ka, kb) = (self.knots[j], self.knots[j + 1]);
        let (la, lb) = (self.ln_norm[j], self.ln_norm[j + 1]);
        let slope = (lb - la) / (kb - ka);
        let panels = log_linear_panels(la + slope * (a - ka), la + slope * (b - ka));
        quad::integrate(|t| (la + slope * (t - ka)).exp() * t.sin(), a, b, panels)
    }

    /// The polar angle with area-weighted CDF `v`: the segment from the cumulative
    /// masses, then Newton (bracketed) on the exact partial integral.
    pub(super) fn sample_theta(&self, v: f64) -> f64 {
        let j = self
            .cdf
            .partition_point(|&c| c <= v)
            .min(self.masses.len() - 1);
        let before = if j == 0 { 0.0 } else { self.cdf[j - 1] };
        let target = v - before;
        let (a, b) = (self.knots[j], self.knots[j + 1]);
        let (mut lo, mut hi) = (a, b);
        let mut t = a + (b - a) * (target / self.masses[j].max(1e-300)).clamp(0.0, 1.0);
        for _ in 0..60 {
            let f = self.partial(j, a, t) - target;
            if f.abs() <= 1e-16 {
                break;
            }
            if f > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let d = self.p_tilde(t) * t.sin();
            let next = if d > 0.0 { t - f / d } else { f64::NAN };
            t = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
            if hi - lo < 1e-15 {
                break;
            }
        }
        t
    }
}
