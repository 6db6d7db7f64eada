//! Sub-step localisation of the axial intensity peak of one pixel.
//!
//! Conventions: positions are in **slice-index units** here (slice `k` sits at index `k`,
//! in the order the slices were recorded); the [`crate::Localiser`] converts them to µm
//! with the z step and the page order. Intensities are unit-less and only their ratios
//! matter (the io crate scales integer samples to full scale 1).
//!
//! Every estimator starts from the brightest slice `k` (the first one on a tie) and the
//! **slices within the peak**: the contiguous run around `k` whose intensities are at
//! least `fraction · I(k)`, clipped to the localiser's window of `half_window` slices on
//! each side. The fits use at least `k − 1 ..= k + 1`.
//!
//! * [`PeakMethod::Argmax`]: `k` itself, what microscope software reports. Its error is
//!   uniform on `±Δ/2` (Δ the z step): rms `Δ/√12` (0.087 µm at Δ = 0.3 µm), whatever
//!   the axial response.
//! * [`PeakMethod::Parabolic`]: unweighted least-squares parabola `I = a + b x + c x²`
//!   through the slices within the peak; the vertex `−b/(2c)`.
//! * [`PeakMethod::Gaussian`]: the parabola through `ln I` (three points when only
//!   `k ± 1` are within the peak, otherwise least squares weighted by `I²`, the weights
//!   that make the log fit approximate a fit of `I` itself; Guo, IEEE Signal Process.
//!   Mag. 28(5), 134 (2011)). Exact for a Gaussian axial response without noise.
//! * [`PeakMethod::Centroid`]: `Σ x (I − t) / Σ (I − t)` over the slices within the peak,
//!   `t = fraction · I(k)` (the thresholded centroid).
//!
//! Their systematic errors (the position error as a function of where the true peak
//! falls between two slices) are derived numerically in this crate's tests and listed in
//! `docs/physics.md` §9; Chen et al., Opt. Express 27, 3682 (2019) report the same kind of
//! systematic error for parabolic, Gaussian and sinc² fitting of axial responses.
//!
//! **Width** (the quality measure): the full width at half maximum of the fitted model
//! for `Parabolic` (`2 √(A / (−2c))`, `A` the vertex value) and `Gaussian`
//! (`2 √(2 ln 2) σ`, `σ² = −1/(2c)`); for `Argmax` and `Centroid`, the distance between
//! the two half-maximum crossings found by linear interpolation between slices (NaN when
//! a crossing lies outside the window).

/// How the sub-step position of the axial peak is estimated (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PeakMethod {
    /// The brightest slice (no sub-step estimate).
    Argmax,
    /// Least-squares parabola through the slices within the peak.
    Parabolic,
    /// Parabola through the logarithm of the intensities (Gaussian peak); the default:
    /// it has the smallest systematic error of the four for Gaussian and sinc² axial
    /// responses at 0.4–0.6 steps per FWHM (`docs/physics.md` §9).
    #[default]
    Gaussian,
    /// Thresholded centroid of the slices within the peak.
    Centroid,
}

impl PeakMethod {
    /// Lower-case name: `argmax`, `parabolic`, `gaussian` or `centroid`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Argmax => "argmax",
            Self::Parabolic => "parabolic",
            Self::Gaussian => "gaussian",
            Self::Centroid => "centroid",
        }
    }

    /// The method named `argmax`, `parabolic`, `gaussian` or `centroid`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "argmax" => Some(Self::Argmax),
            "parabolic" => Some(Self::Parabolic),
            "gaussian" => Some(Self::Gaussian),
            "centroid" => Some(Self::Centroid),
            _ => None,
        }
    }
}

impl std::fmt::Display for PeakMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a pixel gets no height.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Invalid {
    /// Its brightest sample is below `min_signal` (or no sample is finite).
    BelowSignal,
    /// Its brightest sample is on the first slice: the peak may lie outside the stack.
    FirstSlice,
    /// Its brightest sample is on the last slice.
    LastSlice,
    /// The fit is impossible: a neighbour of the maximum is missing or not positive (log
    /// fit), or the fitted curve is not concave.
    NotFittable,
}

/// A localised peak, in slice-index units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// Sub-step position of the peak (slice index, fractional).
    pub position: f64,
    /// Full width at half maximum, in slices (see the module docs; may be NaN).
    pub width: f64,
    /// The brightest sample.
    pub max: f64,
    /// The slices within the peak reached the edge of the window (or of the profile):
    /// the window is too short for this peak and the estimate uses a truncated peak.
    pub window_limited: bool,
}

const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949_3; // 2 √(2 ln 2)

/// Localises the peak of a whole axial profile (slice `k` at index `k`), with the rules
/// the [`crate::Localiser`] applies to its window: `fraction` in `(0, 1]`, `min_signal`
/// as in [`crate::PeakOptions`]. The window is the whole profile.
///
/// # Errors
/// [`Invalid`] for a pixel that gets no height.
pub fn locate_peak(
    profile: &[f64],
    method: PeakMethod,
    fraction: f64,
    min_signal: f64,
) -> Result<Peak, Invalid> {
    let mut k = usize::MAX;
    let mut max = f64::NEG_INFINITY;
    for (i, &v) in profile.iter().enumerate() {
        if v > max {
            max = v;
            k = i;
        }
    }
    if k == usize::MAX || !(max >= min_signal) {
        return Err(Invalid::BelowSignal);
    }
    if k == 0 {
        return Err(Invalid::FirstSlice);
    }
    if k + 1 == profile.len() {
        return Err(Invalid::LastSlice);
    }
    let (offset, width, limited) = fit_window(profile, k, method, fraction)?;
    Ok(Peak {
        position: k as f64 + offset,
        width,
        max,
        window_limited: limited,
    })
}

/// The estimate on a window `w` whose brightest sample is `w[c]` (`0 < c < w.len() − 1`
/// is not required: missing neighbours are NaN). Returns the offset of the peak from `c`
/// and its width, in slices, and whether the run within the peak reached the window edge.
pub(crate) fn fit_window(
    w: &[f64],
    c: usize,
    method: PeakMethod,
    fraction: f64,
) -> Result<(f64, f64, bool), Invalid> {
    let max = w[c];
    let t = fraction * max;
    let mut lo = c;
    while lo > 0 && w[lo - 1] >= t {
        lo -= 1;
    }
    let mut hi = c;
    while hi + 1 < w.len() && w[hi + 1] >= t {
        hi += 1;
    }
    let limited = (lo == 0 && c > 0) || hi + 1 == w.len();
    match method {
        PeakMethod::Argmax => Ok((0.0, half_max_width(w, c), limited)),
        PeakMethod::Centroid => {
            let (mut num, mut den) = (0.0, 0.0);
            for (j, &v) in w.iter().enumerate().take(hi + 1).skip(lo) {
                let x = j as f64 - c as f64;
                num += x * (v - t);
                den += v - t;
            }
            // A run of one slice exactly at the threshold (fraction = 1) has den = 0: the
            // centroid is then the brightest slice itself.
            let offset = if den > 0.0 { num / den } else { 0.0 };
            Ok((offset, half_max_width(w, c), limited))
        }
        PeakMethod::Parabolic | PeakMethod::Gaussian => {
            if c == 0 || c + 1 >= w.len() {
                return Err(Invalid::NotFittable);
            }
            let lo = lo.min(c - 1);
            let hi = hi.max(c + 1);
            let log = method == PeakMethod::Gaussian;
            let mut s = [0.0f64; 5];
            let mut r = [0.0f64; 3];
            for (j, &v) in w.iter().enumerate().take(hi + 1).skip(lo) {
                if !v.is_finite() || (log && v <= 0.0) {
                    return Err(Invalid::NotFittable);
                }
                let x = j as f64 - c as f64;
                let (y, wt) = if log { (v.ln(), v * v) } else { (v, 1.0) };
                let mut xp = wt;
                for (n, sn) in s.iter_mut().enumerate() {
                    *sn += xp;
                    if n < 3 {
                        r[n] += xp * y;
                    }
                    xp *= x;
                }
            }
            let [a, b, c2] = solve3(
                [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]],
                r,
            )
            .ok_or(Invalid::NotFittable)?;
            if !(c2 < 0.0) {
                return Err(Invalid::NotFittable);
            }
            let x0 = -b / (2.0 * c2);
            // The vertex of a concave fit through samples whose maximum is at 0 lies within
            // the fitted run; anything else is a degenerate fit.
            if !(x0 >= lo as f64 - c as f64 && x0 <= hi as f64 - c as f64) {
                return Err(Invalid::NotFittable);
            }
            let width = if log {
                FWHM_PER_SIGMA * (-0.5 / c2).sqrt()
            } else {
                let apex = a - b * b / (4.0 * c2);
                if apex > 0.0 {
                    2.0 * (apex / (-2.0 * c2)).sqrt()
                } else {
                    f64::NAN
                }
            };
            Ok((x0, width, limited))
        }
    }
}

/// Distance between the half-maximum crossings on both sides of `w[c]`, linearly
/// interpolated; NaN when a crossing is not inside the window.
fn half_max_width(w: &[f64], c: usize) -> f64 {
    let half = 0.5 * w[c];
    let mut j = c;
    let left = loop {
        if j == 0 || !w[j - 1].is_finite() {
            break f64::NAN;
        }
        if w[j - 1] < half {
            let (a, b) = (w[j - 1], w[j]);
            break (j - 1) as f64 + (half - a) / (b - a);
        }
        j -= 1;
    };
    let mut j = c;
    let right = loop {
        if j + 1 >= w.len() || !w[j + 1].is_finite() {
            break f64::NAN;
        }
        if w[j + 1] < half {
            let (a, b) = (w[j], w[j + 1]);
            break j as f64 + (a - half) / (a - b);
        }
        j += 1;
    };
    right - left
}

/// Solves the 3 × 3 system `m · x = r` by Cramer's rule; `None` if singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    if !(d.abs() > 0.0) || !d.is_finite() {
        return None;
    }
    let mut out = [0.0; 3];
    for (col, o) in out.iter_mut().enumerate() {
        let mut mc = m;
        for row in 0..3 {
            mc[row][col] = r[row];
        }
        *o = det(&mc) / d;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_point_formulas_match_the_closed_forms() {
        // Parabola through (−1, α), (0, β), (1, γ): vertex ½(α − γ)/(α − 2β + γ).
        let (a, b, g) = (0.5, 1.0, 0.8);
        let w = [a, b, g];
        let (x0, _, _) = fit_window(&w, 1, PeakMethod::Parabolic, 0.1).unwrap();
        assert!((x0 - 0.5 * (a - g) / (a - 2.0 * b + g)).abs() < 1e-14);
        let (la, lb, lg) = (a.ln(), b.ln(), g.ln());
        let (x0, _, _) = fit_window(&w, 1, PeakMethod::Gaussian, 0.1).unwrap();
        assert!((x0 - 0.5 * (la - lg) / (la - 2.0 * lb + lg)).abs() < 1e-14);
    }

    #[test]
    fn gaussian_fit_of_a_gaussian_is_exact() {
        // I(x) = exp(−(x − 0.3)² / (2 · 0.9²)) sampled at −3..=3: the weighted log fit is a
        // parabola fit of an exact parabola, so position and σ come back to rounding.
        let s: f64 = 0.9;
        let w: Vec<f64> = (-3..=3)
            .map(|x| (-(f64::from(x) - 0.3).powi(2) / (2.0 * s * s)).exp())
            .collect();
        let (x0, width, limited) = fit_window(&w, 3, PeakMethod::Gaussian, 0.05).unwrap();
        assert!((x0 - 0.3).abs() < 1e-12, "{x0}");
        assert!((width - FWHM_PER_SIGMA * s).abs() < 1e-12, "{width}");
        assert!(!limited);
    }

    #[test]
    fn half_max_width_of_a_triangle() {
        // A triangle of half-width 2 slices (1, 0.5 at ±1, 0 at ±2): FWHM exactly 2.
        let w = [0.0, 0.5, 1.0, 0.5, 0.0];
        // The crossings sit exactly on samples 1 and 3 (value = half is not below half,
        // so the interpolation runs between samples 0 and 1: x = 0 + 0.5/0.5 = 1).
        assert!((half_max_width(&w, 2) - 2.0).abs() < 1e-15);
        let w = [f64::NAN, 0.6, 1.0, 0.2];
        assert!(half_max_width(&w, 2).is_nan());
    }

    #[test]
    fn invalid_cases() {
        assert_eq!(
            locate_peak(&[0.1, 0.2, 0.1], PeakMethod::Gaussian, 0.5, 0.5),
            Err(Invalid::BelowSignal)
        );
        assert_eq!(
            locate_peak(&[f64::NAN; 4], PeakMethod::Gaussian, 0.5, 0.0),
            Err(Invalid::BelowSignal)
        );
        assert_eq!(
            locate_peak(&[1.0, 0.5, 0.1], PeakMethod::Gaussian, 0.5, 0.0),
            Err(Invalid::FirstSlice)
        );
        assert_eq!(
            locate_peak(&[0.1, 0.5, 1.0], PeakMethod::Parabolic, 0.5, 0.0),
            Err(Invalid::LastSlice)
        );
        // A zero neighbour has no logarithm.
        assert_eq!(
            locate_peak(&[0.0, 1.0, 0.5, 0.1], PeakMethod::Gaussian, 0.5, 0.0),
            Err(Invalid::NotFittable)
        );
        // ... but the parabola is fine: vertex ½(0 − 0.5)/(0 − 2 + 0.5) = 1/6.
        let p = locate_peak(&[0.0, 1.0, 0.5, 0.1], PeakMethod::Parabolic, 0.5, 0.0).unwrap();
        assert!((p.position - (1.0 + 1.0 / 6.0)).abs() < 1e-14);
    }

    #[test]
    fn names_round_trip() {
        for m in [
            PeakMethod::Argmax,
            PeakMethod::Parabolic,
            PeakMethod::Gaussian,
            PeakMethod::Centroid,
        ] {
            assert_eq!(PeakMethod::from_name(m.name()), Some(m));
        }
        assert_eq!(PeakMethod::from_name("max"), None);
    }
}
