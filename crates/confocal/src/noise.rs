//! The background threshold estimated from a stack's own noise (issue 52, item 20):
//! below it, a pixel's brightest sample is what noise alone reaches, and the pixel gets
//! no height.
//!
//! **Model.** A pixel that sees no surface records `nz` samples of the dark level `b`
//! plus independent noise of standard deviation `σ`; its brightest sample is the
//! largest of `nz` such samples. With Gaussian noise,
//! `P(max ≥ b + kσ) = 1 − Φ(k)^nz`, so the threshold
//!
//! `t = b + k σ`, with `k = Φ⁻¹((1 − α)^(1/nz))`,
//!
//! lets a background pixel through with probability `α` ([`FALSE_VALID`] = 0.001: one
//! background pixel in a thousand gets a random height; `k` = 4.06 for 40 slices, 4.42 for
//! 200). A surface pixel is lost only if its peak stands less than `kσ` above the dark
//! level, where its height would be no better than noise.
//!
//! **Estimators**, from a fixed, evenly strided sample of at most [`MAX_SAMPLED`] pixels
//! (all slices of each; at most 2²² samples in all, but at least 64 pixels), each pixel's
//! peak left out — the `half_window` slices on each side of its brightest sample, the
//! slices the localiser fits — so that the surface pixels' peaks do not pass for noise:
//! * `b` = the median of the samples left;
//! * `σ` = 1.4826 · MAD(d) / √2, `d` the differences of successive slices of one pixel,
//!   both left (the MAD of a normal variable is 0.6745 σ; a difference of two independent
//!   samples has sd √2 σ, and a slow drift of the dark level cancels in it). When more
//!   than half the differences are 0 (noise below one quantisation step), `σ` is half
//!   the smallest non-zero |d|, the step. The tails of the peaks beyond the window
//!   inflate the MAD a little: the threshold errs on the high, conservative side.
//!
//! A stack too short to leave [`MIN_DIFFERENCES`] differences outside the peaks (fewer
//! than about `2 · half_window + 3` slices) has no noise to measure: its threshold is
//! then 0 (every pixel with a finite sample passes, as with `min_signal` 0), and
//! [`SignalThreshold`] says so.

use statrs::distribution::{ContinuousCDF, Normal};

/// The probability that a background pixel passes the estimated threshold.
pub const FALSE_VALID: f64 = 1e-3;

/// Largest number of pixels whose samples the estimate uses.
pub const MAX_SAMPLED: usize = 16_384;

/// Most samples kept in all (pixels × slices).
const MAX_SAMPLES: usize = 1 << 22;

/// How the background threshold was chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseEstimate {
    /// Dark level `b`: the median sample (sample units).
    pub baseline: f64,
    /// Noise standard deviation `σ` (sample units).
    pub noise_sd: f64,
    /// `k`: the threshold is `b + k σ`.
    pub k: f64,
    /// `α`: the probability that a background pixel passes ([`FALSE_VALID`]).
    pub false_valid: f64,
    /// Pixels sampled.
    pub pixels: usize,
    /// Slices per pixel.
    pub slices: usize,
}

impl NoiseEstimate {
    /// The threshold `b + k σ`.
    #[must_use]
    pub fn threshold(&self) -> f64 {
        self.baseline + self.k * self.noise_sd
    }
}

/// Fewest differences outside the peaks an estimate needs.
pub const MIN_DIFFERENCES: usize = 32;

/// The background threshold a localisation used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalThreshold {
    /// Pixels whose brightest sample is below this are invalid (sample units).
    pub level: f64,
    /// How it was estimated; `None` when it was given ([`crate::MinSignal::Level`]) or
    /// could not be estimated (`too_short`).
    pub estimate: Option<NoiseEstimate>,
    /// The stack was too short to estimate it (fewer than [`MIN_DIFFERENCES`] sample
    /// differences outside the peaks): the level is 0.
    pub too_short: bool,
}

impl std::fmt::Display for SignalThreshold {
    /// `given` or how it was estimated, e.g. `estimated from the stack's noise: dark
    /// level 0.05 + 4.06 × noise sd 0.01 (one background pixel in 1000 passes; 8192
    /// pixels × 40 slices sampled)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.estimate {
            None if self.too_short => f.write_str(
                "not estimated: the stack is too short to leave slices outside the peaks to measure its noise on, so no threshold (0)",
            ),
            None => f.write_str("given"),
            Some(e) => write!(
                f,
                "estimated from the stack's noise: dark level {:.6} + {:.3} × noise sd {:.6} (one background pixel in {:.0} passes; {} pixels × {} slices sampled)",
                e.baseline,
                e.k,
                e.noise_sd,
                1.0 / e.false_valid,
                e.pixels,
                e.slices
            ),
        }
    }
}

/// The pixels of an `n`-pixel slice whose samples are kept for a stack of `nz` slices:
/// every `stride`-th pixel from 0, `count` of them.
pub(crate) fn sampling(n: usize, nz: usize) -> (usize, usize) {
    let want = (MAX_SAMPLES / nz.max(1))
        .clamp(64, MAX_SAMPLED)
        .min(n)
        .max(1);
    let stride = n.div_ceil(want);
    (stride, n.div_ceil(stride))
}

/// `k = Φ⁻¹((1 − α)^(1/nz))` (module docs).
#[must_use]
pub fn k_for(nz: usize, alpha: f64) -> f64 {
    let p = ((1.0 - alpha).ln() / nz.max(1) as f64).exp();
    Normal::standard().inverse_cdf(p)
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The estimate from `samples`, `pixels` sampled pixels × `nz` slices, slice-major
/// (`samples[k * pixels + j]`, slice `k` of pixel `j`), leaving out each pixel's slices
/// within `half_window` of its brightest sample and non-finite samples; `None` when
/// fewer than [`MIN_DIFFERENCES`] differences are left.
pub(crate) fn estimate(
    samples: &[f32],
    pixels: usize,
    nz: usize,
    half_window: usize,
) -> Option<NoiseEstimate> {
    let at = |k: usize, j: usize| f64::from(samples[k * pixels + j]);
    let mut all: Vec<f64> = Vec::with_capacity(samples.len());
    let mut d: Vec<f64> = Vec::with_capacity(samples.len());
    for j in 0..pixels {
        let mut peak = 0;
        for k in 1..nz {
            if at(k, j) > at(peak, j) || (at(peak, j).is_nan() && !at(k, j).is_nan()) {
                peak = k;
            }
        }
        let kept = |k: usize| k.abs_diff(peak) > half_window && at(k, j).is_finite();
        for k in 0..nz {
            if kept(k) {
                all.push(at(k, j));
                if k > 0 && kept(k - 1) {
                    d.push(at(k, j) - at(k - 1, j));
                }
            }
        }
    }
    if d.len() < MIN_DIFFERENCES {
        return None;
    }
    let baseline = median(&mut all);
    let centre = median(&mut d);
    let mut dev: Vec<f64> = d.iter().map(|x| (x - centre).abs()).collect();
    let mad = median(&mut dev);
    let mut noise_sd = 1.482_602_218_505_602 * mad / std::f64::consts::SQRT_2;
    if !(noise_sd > 0.0) {
        let step = d
            .iter()
            .map(|x| x.abs())
            .filter(|x| *x > 0.0)
            .fold(f64::INFINITY, f64::min);
        noise_sd = if step.is_finite() { step / 2.0 } else { 0.0 };
    }
    Some(NoiseEstimate {
        baseline,
        noise_sd,
        k: k_for(nz, FALSE_VALID),
        false_valid: FALSE_VALID,
        pixels,
        slices: nz,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn k_gives_the_stated_false_valid_rate() {
        // Φ(k)^nz = 1 − α, checked with the normal CDF itself.
        for nz in [3usize, 40, 200, 10_000] {
            let k = k_for(nz, FALSE_VALID);
            let p = Normal::standard().cdf(k).powi(nz as i32);
            assert!((p - (1.0 - FALSE_VALID)).abs() < 1e-9, "nz {nz}: {p}");
        }
        // The values quoted in the module docs (Python: statistics.NormalDist().inv_cdf).
        assert!(
            (k_for(40, 1e-3) - 4.0555).abs() < 1e-3,
            "{}",
            k_for(40, 1e-3)
        );
        assert!(
            (k_for(200, 1e-3) - 4.4171).abs() < 1e-3,
            "{}",
            k_for(200, 1e-3)
        );
    }

    #[test]
    fn sampling_bounds() {
        assert_eq!(sampling(10, 40), (1, 10));
        let (stride, count) = sampling(1 << 20, 40);
        assert!(count <= MAX_SAMPLED && count * 40 <= MAX_SAMPLES + 40 * stride);
        let (_, count) = sampling(1 << 20, 100_000);
        assert!(count >= 64);
    }
}
