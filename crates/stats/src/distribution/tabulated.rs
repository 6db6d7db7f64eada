//! The tabulated member (area fractions in bins of `θn`; parent module docs): bin
//! look-up, masses between angles and sampling.

/// Precomputed tabulated member.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Tabulated {
    /// `n + 1` strictly increasing edges in `[0, π/2]`, radians.
    pub(super) edges: Vec<f64>,
    /// `n` area fractions summing to 1.
    pub(super) masses: Vec<f64>,
    /// Cumulative masses, `cdf[i] = Σ_{j<=i} masses[j]`, last entry set to exactly 1.
    pub(super) cdf: Vec<f64>,
    /// `p2` in each bin, per steradian.
    pub(super) p2: Vec<f64>,
    pub(super) mean_cos: f64,
}

impl Tabulated {
    /// Bin containing `theta` (`lo ≤ θ < hi`), `None` outside `[edges[0], edges[n])`.
    #[inline]
    pub(super) fn bin_of(&self, theta: f64) -> Option<usize> {
        let first = self.edges[0];
        let last = *self.edges.last()?;
        if !(theta >= first && theta < last) {
            return None;
        }
        let i = self.edges.partition_point(|&e| e <= theta);
        Some(i - 1)
    }
}
