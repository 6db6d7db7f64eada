//! Welford's running mean and sum of squared deviations, slot by slot, for ordered
//! reductions of per-tile or per-batch sums (the standard errors of the ray models).
//!
//! For the values `v₁ … v_k` added to a slot so far, [`Welford`] keeps their sum
//! `Σ vᵢ`, their mean `v̄` and `M2 = Σ (vᵢ − v̄)²` (the unbiased variance is
//! `M2/(k − 1)`; the standard error of the sum of `k` values is `√(k/(k − 1) · M2)`).
//! Each value is added by Welford's update: with `δ = v − v̄_{k−1}`,
//! `v̄_k = v̄_{k−1} + δ/k` (as `δ · (1/k)`) and `M2_k = M2_{k−1} + δ (v − v̄_k)`, which
//! avoids the cancellation of `Σ v² − (Σ v)²/k`. The operations and their order are
//! fixed (no fused multiply–add, `1/k` formed once per addition), so that a reduction in
//! a fixed order gives the same bits on every processor and thread count.

/// The running sums, means and `M2` of a fixed number of slots (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Welford {
    sum: Vec<f64>,
    mean: Vec<f64>,
    m2: Vec<f64>,
    count: u64,
}

impl Welford {
    /// No values yet, in `slots` slots.
    #[must_use]
    pub fn new(slots: usize) -> Self {
        Self {
            sum: vec![0.0; slots],
            mean: vec![0.0; slots],
            m2: vec![0.0; slots],
            count: 0,
        }
    }

    /// Adds one value per slot: `v[s]` to slot `s` (`v` as long as the slots; extra
    /// values are ignored, missing ones leave their slots behind the count).
    #[inline]
    pub fn add(&mut self, v: &[f64]) {
        debug_assert_eq!(v.len(), self.sum.len());
        self.count += 1;
        let inv_seen = 1.0 / self.count as f64;
        for (((s, m), q), &v) in self
            .sum
            .iter_mut()
            .zip(self.mean.iter_mut())
            .zip(self.m2.iter_mut())
            .zip(v)
        {
            *s += v;
            let delta = v - *m;
            *m += delta * inv_seen;
            *q += delta * (v - *m);
        }
    }

    /// How many times [`Welford::add`] was called.
    #[must_use]
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Per slot, the sum of its values.
    #[must_use]
    pub fn sum(&self) -> &[f64] {
        &self.sum
    }

    /// Per slot, the mean of its values (0 before any).
    #[must_use]
    pub fn mean(&self) -> &[f64] {
        &self.mean
    }

    /// Per slot, `M2`: the sum of squared deviations of its values from their mean.
    #[must_use]
    pub fn m2(&self) -> &[f64] {
        &self.m2
    }

    /// The sums and the `M2` of the slots, taken out.
    #[must_use]
    pub fn into_sum_and_m2(self) -> (Vec<f64>, Vec<f64>) {
        (self.sum, self.m2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small integers: every step is exact, so the running values are the closed forms
    /// `Σ v`, `Σ v / k` and `Σ (v − v̄)²` exactly. For 2, 4, 4, 4, 5, 5, 7, 9: sum 40,
    /// mean 5, `M2 = 9+1+1+1+0+0+4+16 = 32` (population variance 4).
    #[test]
    fn integers_give_the_closed_forms_exactly() {
        let mut w = Welford::new(2);
        for v in [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0] {
            w.add(&[v, -2.0 * v]);
        }
        assert_eq!(w.count(), 8);
        assert_eq!(w.sum(), &[40.0, -80.0]);
        assert_eq!(w.mean(), &[5.0, -10.0]);
        // Scaling the values by −2 scales M2 by 4.
        assert_eq!(w.m2(), &[32.0, 128.0]);
        let (sum, m2) = w.into_sum_and_m2();
        assert_eq!((sum, m2), (vec![40.0, -80.0], vec![32.0, 128.0]));
    }

    /// A large offset (1e9) over a small spread: the two-pass variance of the values
    /// (numpy's `((v - v.mean())**2).sum()`: `v = 1e9 + [4, 7, 13, 16]`, mean `1e9 + 10`,
    /// `M2 = 36 + 9 + 9 + 36 = 90`) is kept to 1e-12 relative, where the one-pass
    /// `Σ v² − (Σ v)²/k` loses every digit (its terms are 4e18, rounded to 512).
    #[test]
    fn a_large_offset_keeps_the_variance() {
        let mut w = Welford::new(1);
        let vals = [4.0, 7.0, 13.0, 16.0].map(|d| 1e9 + d);
        for v in vals {
            w.add(&[v]);
        }
        assert!((w.m2()[0] - 90.0).abs() < 90.0 * 1e-12, "{}", w.m2()[0]);
        assert_eq!(w.mean()[0], 1e9 + 10.0);
        let naive =
            vals.iter().map(|v| v * v).sum::<f64>() - vals.iter().sum::<f64>().powi(2) / 4.0;
        assert!((naive - 90.0).abs() > 1.0, "{naive}");
    }

    /// The update itself, written out for one value after one: `δ = v₂ − v₁`,
    /// `v̄ = v₁ + δ/2`, `M2 = δ (v₂ − v̄) = δ²/2`, bit for bit for values whose
    /// operations round (0.1 and 0.7); and a slot that only ever gets one value has
    /// `M2 = 0`.
    #[test]
    fn one_value_after_another_follows_the_update() {
        let mut w = Welford::new(2);
        w.add(&[0.1, 3.0]);
        assert_eq!(w.m2(), &[0.0, 0.0]);
        w.add(&[0.7, 3.0]);
        let delta: f64 = 0.7 - 0.1;
        let mean = 0.1 + delta * 0.5;
        assert_eq!(w.mean()[0].to_bits(), mean.to_bits());
        assert_eq!(w.m2()[0].to_bits(), (delta * (0.7 - mean)).to_bits());
        assert!((w.m2()[0] - 0.18).abs() < 1e-15);
        assert_eq!(w.sum()[0], 0.1 + 0.7);
        assert_eq!(w.m2()[1], 0.0);
    }
}
