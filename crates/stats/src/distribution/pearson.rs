//! The Pearson VII family (heavy-tailed Student-t slopes; parent module docs): its
//! density, mean cosine and sampling table.

use std::f64::consts::{FRAC_PI_2, PI};

/// Nodes of the CDF table a Pearson VII member samples from.
const CDF_NODES: usize = 512;

/// Precomputed Pearson VII member.
#[derive(Debug, Clone)]
pub(super) struct Pearson {
    /// Slope scale `α`.
    pub(super) alpha: f64,
    /// Shape `γ`.
    pub(super) shape: f64,
    /// `1/(γ α²)`.
    pub(super) inv_ga2: f64,
    /// `⟨cos θn⟩ = 1/∫ D dΩ`; `p2 = D ⟨cos θn⟩`.
    pub(super) mean_cos: f64,
    /// Area-weighted CDF in `w` on [`CDF_NODES`] + 1 nodes, for sampling; built on the
    /// first draw (a fit builds many members and samples none).
    pub(super) cdf: std::sync::OnceLock<Vec<(f64, f64)>>,
}

impl PartialEq for Pearson {
    fn eq(&self, other: &Self) -> bool {
        self.alpha == other.alpha && self.shape == other.shape
    }
}

impl Pearson {
    /// The macro-area density `D(θ)` (module docs), for `θ ∈ [0, π/2)`.
    #[inline]
    pub(super) fn macro_density(&self, theta: f64) -> f64 {
        // In logarithms: the power of (1 + tan²θ/(γα²)) under- or overflows for large γ.
        let c = theta.cos();
        let t = theta.tan();
        (-(self.shape + 1.0) * (t * t * self.inv_ga2).ln_1p() - 4.0 * c.ln()).exp()
            / (PI * self.alpha * self.alpha)
    }

    /// The exponent `k` of `u = w^k`: the integrand `k w^(k−1) sqrt(1 + s²)` is then
    /// `O(w)` at `w → 0`.
    pub(super) fn k(&self) -> f64 {
        (4.0 * self.shape / (2.0 * self.shape - 1.0)).max(2.0)
    }

    /// The slope `|tan θ|` at tail probability `u = w^k` of the projected slopes:
    /// `u = (1 + s²/(γα²))^(−γ)`.
    pub(super) fn slope_of_w(&self, w: f64) -> f64 {
        let u_inv_g = w.powf(-self.k() / self.shape);
        (self.shape * self.alpha * self.alpha * (u_inv_g - 1.0))
            .max(0.0)
            .sqrt()
    }

    /// The `w` of the polar angle `θ` (inverse of [`Pearson::slope_of_w`]).
    pub(super) fn w_of_theta(&self, theta: f64) -> f64 {
        if theta <= 0.0 {
            return 1.0;
        }
        if theta >= FRAC_PI_2 {
            return 0.0;
        }
        let t = theta.tan();
        // ln u = −γ ln(1 + s²/(γα²)), w = u^(1/k).
        (-(self.shape / self.k()) * (t * t * self.inv_ga2).ln_1p()).exp()
    }

    /// The unnormalised integrand in `w`: `k w^(k−1) sqrt(1 + s(w)²)`.
    pub(super) fn integrand(&self, w: f64) -> f64 {
        if w <= 0.0 {
            return 0.0;
        }
        let k = self.k();
        let s = self.slope_of_w(w);
        k * w.powf(k - 1.0) * s.mul_add(s, 1.0).sqrt()
    }

    /// `∫_a^b` of [`Pearson::integrand`] (`0 ≤ a ≤ b ≤ 1`): the area of the normals with
    /// `w` in `[a, b]`, in units of the projected area (adaptive Gauss–Kronrod, relative
    /// tolerance 1e-13).
    pub(super) fn area_integral(&self, a: f64, b: f64) -> f64 {
        if !(b > a) {
            return 0.0;
        }
        // Where the slope passes its scale the integrand bends: a break there.
        let bend = self.w_of_theta(self.alpha.atan());
        flakescatter_numerics::quad::adaptive(
            |w| self.integrand(w),
            a,
            b,
            &[bend],
            1e-300,
            1e-13,
            400,
        )
        .0
    }

    /// The polar angle with area-weighted CDF `v` (the CDF runs from the horizon, `w = 0`,
    /// to the normal, `w = 1`; `θ` of `1 − v` is returned so that `v` small gives small
    /// tilts): the CDF table's node, then Newton on the exact partial integral.
    pub(super) fn sample_theta(&self, v: f64) -> f64 {
        let target = 1.0 - v;
        let cdf = self.cdf.get_or_init(|| {
            let mut cdf = Vec::with_capacity(CDF_NODES + 1);
            let mut acc = 0.0;
            cdf.push((0.0, 0.0));
            for j in 0..CDF_NODES {
                let (a, b) = (
                    j as f64 / CDF_NODES as f64,
                    (j + 1) as f64 / CDF_NODES as f64,
                );
                acc += self.area_integral(a, b) * self.mean_cos;
                cdf.push((b, acc));
            }
            cdf.last_mut().expect("nodes").1 = 1.0;
            cdf
        });
        let j = cdf
            .partition_point(|c| c.1 <= target)
            .clamp(1, cdf.len() - 1);
        let (w0, c0) = cdf[j - 1];
        let (w1, c1) = cdf[j];
        let mut w = if c1 > c0 {
            w0 + (target - c0) / (c1 - c0) * (w1 - w0)
        } else {
            w0
        };
        for _ in 0..8 {
            let f = c0 + self.area_integral(w0, w) * self.mean_cos - target;
            let d = self.integrand(w) * self.mean_cos;
            if !(d > 0.0) {
                break;
            }
            let next = (w - f / d).clamp(w0, w1);
            if (next - w).abs() <= 1e-15 {
                w = next;
                break;
            }
            w = next;
        }
        self.slope_of_w(w).atan()
    }
}
