//! Spectral reflectance factor → CIE XYZ tristimulus values, the ASTM E308 way.
//!
//! Conventions: wavelengths in **nanometres** (any regular or irregular, strictly
//! increasing list within 360–830 nm); a reflectance factor is dimensionless, `1` for the
//! perfect reflecting diffuser, may exceed 1 (metallic coatings near specular) and may
//! not be negative. Tristimulus values are scaled so that the perfect reflecting
//! diffuser has `Y = 100`:
//!
//! `X = k Σᵢ Wₓ,ᵢ Rᵢ` (and `Y`, `Z` alike), `k = 100 / Σᵢ W_ȳ,ᵢ`,
//!
//! where the weights `Wᵢ` carry the illuminant × colour-matching function that belongs
//! to sample `i`. The weights are built from the CIE 1 nm tables, at the spectrum's own
//! sampling, so a coarse spectrum is never interpolated linearly (which biases ΔE*ab by
//! up to 0.19 for the 5 nm test spectra of `tests/data`, against ≤ 0.015 here):
//!
//! * **Summation** ([`Integration::Summation`]): wavelengths on whole nanometres with one
//!   constant step of 1 to 5 nm. `Wᵢ = S(λᵢ) x̄(λᵢ) Δλ` from the 1 nm tables at the
//!   sample wavelengths: the 1 nm sum itself, and for 5 nm the selection of every fifth
//!   value that ASTM E308 prescribes for 5 nm data (and CIE 015 uses for its tables).
//! * **Lagrange weights** ([`Integration::Lagrange`]): any other sampling (10 nm, 20 nm,
//!   off-grid or irregular wavelengths). The spectrum is taken as the local Lagrange
//!   polynomial through its samples — cubic through the four nearest samples, quadratic
//!   in the first and last interval — and integrated against the 1 nm tables:
//!   `Wᵢ = Σ_λ S(λ) x̄(λ) Lᵢ(λ)` over the 1 nm grid, `Lᵢ` the Lagrange basis polynomial of
//!   sample `i`. For 10 and 20 nm spectra this is the method of ASTM E2022 by which the
//!   ASTM E308 weighting tables (the tables for bandpass-corrected data) are made; here it
//!   also serves irregular spacings. A perfect reflector gets exactly the 1 nm white point.
//!
//! The spectrum is assumed free of bandpass error (corrected by the instrument, ASTM
//! E2729); no bandpass correction is applied.
//!
//! Outside the spectrum's range the 1 nm tables still reach 360 and 830 nm. By default
//! ([`Ends::Extend`], ASTM E308) the spectrum is continued with its end values: the
//! sample grid is extended at its first and last spacing toward 360 and 830 nm, the
//! extended grid is weighted as above, and the weights of the added samples (with
//! Lagrange weights also any 1 nm rows beyond the last whole step) go to the end
//! samples, as E308 adds the weights outside the measured range to the end weights.
//! [`Ends::Truncate`] sums only
//! over the spectrum's own range (the practice behind CIE 015's tabulated white points,
//! which sum 380–780 nm at 5 nm).
//!
//! Accepted spectra: at least two samples, finite, strictly increasing, within 360–830
//! nm, covering at least [`MIN_COVERAGE_NM`], no two neighbours more than
//! [`MAX_SPACING_NM`] apart (ASTM E308's coarsest interval).

use crate::error::ColourError;
use crate::lab::{Lab, Xyz};
use crate::tables::{END_NM, Illuminant, Observer, START_NM};

/// The spectrum must start at or below the first and end at or above the second
/// wavelength, nm (the range multi-angle spectrophotometers report).
pub const MIN_COVERAGE_NM: (f64, f64) = (400.0, 700.0);

/// Largest accepted spacing of neighbouring samples, nm (ASTM E308 tabulates up to 20 nm).
pub const MAX_SPACING_NM: f64 = 20.0;

/// Wavelengths within this distance of a whole nanometre count as on the 1 nm grid, nm.
const GRID_TOL_NM: f64 = 1e-9;

/// How the spectrum is continued beyond its first and last sample, up to 360 and 830 nm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Ends {
    /// Hold the end values constant (ASTM E308: the weights outside the measured range
    /// are added to the end weights). The default.
    #[default]
    Extend,
    /// Sum only over the spectrum's own range (CIE 015's practice for its tables).
    Truncate,
}

/// Which integration rule a set of weights uses (see the module header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integration {
    /// Sum of the 1 nm tables at the sample wavelengths (1–5 nm steps on whole nm).
    Summation,
    /// Weights from local Lagrange interpolation integrated at 1 nm (ASTM E2022).
    Lagrange,
}

/// Tristimulus weighting factors for one wavelength sampling, illuminant and observer.
///
/// Build once, apply to many spectra sampled at the same wavelengths (each application
/// costs three dot products).
#[derive(Debug, Clone, PartialEq)]
pub struct TristimulusWeights {
    wavelengths_nm: Vec<f64>,
    /// Per sample `[Wx, Wy, Wz]`, already multiplied by `k` (so `Σ Wy = 100`).
    weights: Vec<[f64; 3]>,
    white: Xyz,
    illuminant: Illuminant,
    observer: Observer,
    integration: Integration,
    ends: Ends,
}

impl TristimulusWeights {
    /// Weights for spectra sampled at `wavelengths_nm` (nm), with ASTM E308 end
    /// handling ([`Ends::Extend`]).
    ///
    /// # Errors
    /// [`ColourError`] naming the first wavelength that is not finite, not increasing,
    /// outside 360–830 nm, too far from its neighbour, or a range that does not cover
    /// [`MIN_COVERAGE_NM`].
    pub fn new(
        wavelengths_nm: &[f64],
        illuminant: Illuminant,
        observer: Observer,
    ) -> Result<Self, ColourError> {
        Self::with_ends(wavelengths_nm, illuminant, observer, Ends::Extend)
    }

    /// As [`TristimulusWeights::new`] with an explicit end handling.
    ///
    /// # Errors
    /// As [`TristimulusWeights::new`].
    pub fn with_ends(
        wavelengths_nm: &[f64],
        illuminant: Illuminant,
        observer: Observer,
        ends: Ends,
    ) -> Result<Self, ColourError> {
        check_wavelengths(wavelengths_nm)?;
        let cmf = observer.colour_matching_functions();
        let spd = illuminant.relative_spd();
        // Illuminant × colour-matching functions on the 1 nm grid, index 0 = 360 nm.
        let product = |nm: usize| {
            let c = cmf[nm];
            let s = spd[nm];
            [s * c[0], s * c[1], s * c[2]]
        };
        let (raw, integration) = match regular_grid_step(wavelengths_nm) {
            Some(step) => (
                summation_weights(wavelengths_nm, step, ends, &product),
                Integration::Summation,
            ),
            None => (
                lagrange_weights(wavelengths_nm, ends, &product),
                Integration::Lagrange,
            ),
        };
        let sum_y: f64 = raw.iter().map(|w| w[1]).sum();
        let k = 100.0 / sum_y;
        let weights: Vec<[f64; 3]> = raw.iter().map(|w| [k * w[0], k * w[1], k * w[2]]).collect();
        let mut out = Self {
            wavelengths_nm: wavelengths_nm.to_vec(),
            weights,
            white: Xyz {
                x: 0.0,
                y: 0.0,
                z: 0.0,
            },
            illuminant,
            observer,
            integration,
            ends,
        };
        // The white point is the perfect reflector through the very same sums, so that
        // R = 1 gives X/Xn = Y/Yn = Z/Zn = 1 exactly.
        out.white = out.apply(|_| 1.0);
        Ok(out)
    }

    /// CIE XYZ (`Y = 100` for the perfect reflecting diffuser) of the reflectance factors
    /// `reflectance`, one per wavelength.
    ///
    /// The sums are scaled by the largest reflectance factor when they would overflow
    /// on the way, so every spectrum whose XYZ are doubles gets them.
    ///
    /// # Errors
    /// [`ColourError::LengthMismatch`], [`ColourError::NonFiniteReflectance`],
    /// [`ColourError::NegativeReflectance`] (naming the wavelength);
    /// [`ColourError::TristimulusOverflow`] when X, Y or Z exceeds the largest double.
    pub fn xyz(&self, reflectance: &[f64]) -> Result<Xyz, ColourError> {
        if reflectance.len() != self.wavelengths_nm.len() {
            return Err(ColourError::LengthMismatch {
                wavelengths: self.wavelengths_nm.len(),
                values: reflectance.len(),
            });
        }
        for (&value, &wavelength_nm) in reflectance.iter().zip(&self.wavelengths_nm) {
            if !value.is_finite() {
                return Err(ColourError::NonFiniteReflectance {
                    wavelength_nm,
                    value,
                });
            }
            if value < 0.0 {
                return Err(ColourError::NegativeReflectance {
                    wavelength_nm,
                    value,
                });
            }
        }
        let xyz = self.apply(|i| reflectance[i]);
        if finite(&xyz) {
            return Ok(xyz);
        }
        // A sum overflowed: scale by the largest factor (> 0, or the sums were 0), sum
        // again, and scale back; what still overflows has no XYZ in doubles.
        let (at, top) = reflectance
            .iter()
            .enumerate()
            .fold((0, 0.0f64), |m, (i, &r)| if r > m.1 { (i, r) } else { m });
        let inv = 1.0 / top;
        let s = self.apply(|i| reflectance[i] * inv);
        let xyz = Xyz {
            x: s.x * top,
            y: s.y * top,
            z: s.z * top,
        };
        if finite(&xyz) {
            Ok(xyz)
        } else {
            Err(ColourError::TristimulusOverflow {
                wavelength_nm: self.wavelengths_nm[at],
                value: top,
            })
        }
    }

    /// CIELAB of the reflectance factors, white point from the same illuminant, observer
    /// and weights. Every XYZ that is a double has a finite CIELAB (`L*` at most about
    /// `1.4e104`).
    ///
    /// # Errors
    /// As [`TristimulusWeights::xyz`].
    pub fn lab(&self, reflectance: &[f64]) -> Result<Lab, ColourError> {
        Ok(self.xyz(reflectance)?.to_lab(&self.white))
    }

    /// The white point `(Xn, Yn = 100, Zn)`: the perfect reflector through these weights.
    #[must_use]
    pub fn white_point(&self) -> Xyz {
        self.white
    }

    /// The wavelengths these weights are for, nm.
    #[must_use]
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// The normalised weights `[Wx, Wy, Wz]` per sample (`Σ Wy = 100`).
    #[must_use]
    pub fn weights(&self) -> &[[f64; 3]] {
        &self.weights
    }

    /// The illuminant.
    #[must_use]
    pub fn illuminant(&self) -> Illuminant {
        self.illuminant
    }

    /// The observer.
    #[must_use]
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// The integration rule chosen for this sampling.
    #[must_use]
    pub fn integration(&self) -> Integration {
        self.integration
    }

    /// The end handling.
    #[must_use]
    pub fn ends(&self) -> Ends {
        self.ends
    }

    fn apply(&self, r: impl Fn(usize) -> f64) -> Xyz {
        let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
        for (i, w) in self.weights.iter().enumerate() {
            let ri = r(i);
            x += w[0] * ri;
            y += w[1] * ri;
            z += w[2] * ri;
        }
        Xyz { x, y, z }
    }
}

fn finite(xyz: &Xyz) -> bool {
    xyz.x.is_finite() && xyz.y.is_finite() && xyz.z.is_finite()
}

/// CIE XYZ of one spectrum (convenience for [`TristimulusWeights`]; build the weights
/// once when many spectra share a sampling).
///
/// # Errors
/// As [`TristimulusWeights::new`] and [`TristimulusWeights::xyz`].
pub fn spectrum_to_xyz(
    wavelengths_nm: &[f64],
    reflectance: &[f64],
    illuminant: Illuminant,
    observer: Observer,
) -> Result<Xyz, ColourError> {
    TristimulusWeights::new(wavelengths_nm, illuminant, observer)?.xyz(reflectance)
}

/// CIELAB of one spectrum (white point from the same illuminant and observer).
///
/// # Errors
/// As [`spectrum_to_xyz`].
pub fn spectrum_to_lab(
    wavelengths_nm: &[f64],
    reflectance: &[f64],
    illuminant: Illuminant,
    observer: Observer,
) -> Result<Lab, ColourError> {
    TristimulusWeights::new(wavelengths_nm, illuminant, observer)?.lab(reflectance)
}

fn check_wavelengths(wl: &[f64]) -> Result<(), ColourError> {
    if wl.len() < 2 {
        return Err(ColourError::TooFewSamples {
            got: wl.len(),
            min: 2,
        });
    }
    for (index, &value) in wl.iter().enumerate() {
        if !value.is_finite() {
            return Err(ColourError::NonFiniteWavelength { index, value });
        }
        if value < f64::from(START_NM) || value > f64::from(END_NM) {
            return Err(ColourError::WavelengthOutOfRange { index, value });
        }
        if index > 0 && value <= wl[index - 1] {
            return Err(ColourError::NotIncreasing {
                index,
                previous: wl[index - 1],
                value,
            });
        }
    }
    let (first, last) = (wl[0], wl[wl.len() - 1]);
    if first > MIN_COVERAGE_NM.0 || last < MIN_COVERAGE_NM.1 {
        return Err(ColourError::InsufficientCoverage {
            first,
            last,
            need_first: MIN_COVERAGE_NM.0,
            need_last: MIN_COVERAGE_NM.1,
        });
    }
    if let Some(p) = wl.windows(2).find(|p| p[1] - p[0] > MAX_SPACING_NM) {
        return Err(ColourError::GapTooLarge {
            from: p[0],
            to: p[1],
            max: MAX_SPACING_NM,
        });
    }
    Ok(())
}

/// The step (1–5 nm) when every wavelength is a whole nanometre and the step is
/// constant; `None` otherwise.
fn regular_grid_step(wl: &[f64]) -> Option<usize> {
    let on_grid = wl.iter().all(|w| (w - w.round()).abs() <= GRID_TOL_NM);
    if !on_grid {
        return None;
    }
    let step = (wl[1].round() - wl[0].round()) as i64;
    let regular = wl
        .windows(2)
        .all(|p| (p[1].round() - p[0].round()) as i64 == step);
    (regular && (1..=5).contains(&step)).then_some(step as usize)
}

/// Index into the 1 nm tables (0 = 360 nm) of a whole-nanometre wavelength.
fn grid_index(nm: f64) -> usize {
    (nm.round() - f64::from(START_NM)) as usize
}

fn summation_weights(
    wl: &[f64],
    step: usize,
    ends: Ends,
    product: &impl Fn(usize) -> [f64; 3],
) -> Vec<[f64; 3]> {
    let h = step as f64;
    let mut w: Vec<[f64; 3]> = wl
        .iter()
        .map(|&l| scale(product(grid_index(l)), h))
        .collect();
    if ends == Ends::Extend {
        let last = w.len() - 1;
        // The sample grid continued at the same step down to 360 nm and up to 830 nm,
        // carrying the end values.
        let first_idx = grid_index(wl[0]);
        let mut idx = first_idx;
        while idx >= step {
            idx -= step;
            add(&mut w[0], scale(product(idx), h));
        }
        let max_idx = grid_index(f64::from(END_NM));
        let mut idx = grid_index(wl[last]) + step;
        while idx <= max_idx {
            add(&mut w[last], scale(product(idx), h));
            idx += step;
        }
    }
    w
}

fn lagrange_weights(wl: &[f64], ends: Ends, product: &impl Fn(usize) -> [f64; 3]) -> Vec<[f64; 3]> {
    let n = wl.len();
    if ends == Ends::Truncate {
        return lagrange_on_nodes(wl, ends, product);
    }
    // ASTM E308's end practice: continue the sample grid at its end spacings down to
    // 360 nm and up to 830 nm with the end values held, weight the extended grid, and
    // add the weights of the added nodes to the end samples. (The interpolating cubics
    // then run smoothly across the first and last sample.)
    let (h_lo, h_hi) = (wl[1] - wl[0], wl[n - 1] - wl[n - 2]);
    let below = ((wl[0] - f64::from(START_NM)) / h_lo + GRID_TOL_NM).floor() as usize;
    let above = ((f64::from(END_NM) - wl[n - 1]) / h_hi + GRID_TOL_NM).floor() as usize;
    let mut nodes: Vec<f64> = (1..=below).rev().map(|k| wl[0] - h_lo * k as f64).collect();
    nodes.extend_from_slice(wl);
    nodes.extend((1..=above).map(|k| wl[n - 1] + h_hi * k as f64));
    let extended = lagrange_on_nodes(&nodes, Ends::Extend, product);
    let mut w = extended[below..below + n].to_vec();
    for v in &extended[..below] {
        add(&mut w[0], *v);
    }
    for v in &extended[below + n..] {
        add(&mut w[n - 1], *v);
    }
    w
}

/// Weights of local Lagrange interpolation through `wl` integrated on the 1 nm grid;
/// 1 nm wavelengths outside `wl` go to the end nodes ([`Ends::Extend`]) or are dropped.
fn lagrange_on_nodes(
    wl: &[f64],
    ends: Ends,
    product: &impl Fn(usize) -> [f64; 3],
) -> Vec<[f64; 3]> {
    let n = wl.len();
    let mut w = vec![[0.0; 3]; n];
    // `j` is the interval [wl[j], wl[j+1]] holding the current 1 nm wavelength.
    let mut j = 0;
    for idx in 0..=grid_index(f64::from(END_NM)) {
        let lambda = f64::from(START_NM) + idx as f64;
        let c = product(idx);
        if lambda < wl[0] - GRID_TOL_NM {
            if ends == Ends::Extend {
                add(&mut w[0], c);
            }
            continue;
        }
        if lambda > wl[n - 1] + GRID_TOL_NM {
            if ends == Ends::Extend {
                add(&mut w[n - 1], c);
            }
            continue;
        }
        while j + 1 < n - 1 && wl[j + 1] < lambda - GRID_TOL_NM {
            j += 1;
        }
        // On a sample (to rounding): the polynomial passes through it.
        if let Some(m) = [j, j + 1]
            .into_iter()
            .find(|&m| (wl[m] - lambda).abs() <= GRID_TOL_NM)
        {
            add(&mut w[m], c);
            continue;
        }
        // Nodes: cubic through j-1..=j+2 inside, quadratic in the end intervals.
        let (lo, hi) = if n == 2 {
            (0, 1)
        } else if j == 0 {
            (0, 2)
        } else if j == n - 2 {
            (n - 3, n - 1)
        } else {
            (j - 1, j + 2)
        };
        for m in lo..=hi {
            let mut basis = 1.0;
            for l in lo..=hi {
                if l != m {
                    basis *= (lambda - wl[l]) / (wl[m] - wl[l]);
                }
            }
            add(&mut w[m], scale(c, basis));
        }
    }
    w
}

fn scale(v: [f64; 3], s: f64) -> [f64; 3] {
    [v[0] * s, v[1] * s, v[2] * s]
}

fn add(acc: &mut [f64; 3], v: [f64; 3]) {
    acc[0] += v[0];
    acc[1] += v[1];
    acc[2] += v[2];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_detection() {
        let five: Vec<f64> = (0..=80).map(|i| 380.0 + 5.0 * f64::from(i)).collect();
        assert_eq!(regular_grid_step(&five), Some(5));
        let ten: Vec<f64> = (0..=30).map(|i| 400.0 + 10.0 * f64::from(i)).collect();
        assert_eq!(regular_grid_step(&ten), None);
        let off: Vec<f64> = (0..=60).map(|i| 400.5 + 5.0 * f64::from(i)).collect();
        assert_eq!(regular_grid_step(&off), None);
    }

    #[test]
    fn lagrange_basis_reproduces_cubics() {
        // The weights integrate any cubic (within the interior intervals) exactly like
        // the 1 nm sum of the cubic itself: Σ W_i p(λ_i) = Σ_λ c(λ) p(λ). Check with a
        // flat "illuminant × CMF" of 1 on an irregular grid, using p = 1 and p = λ
        // (linear: exact in every interval, the end intervals included).
        let wl: Vec<f64> = vec![
            400.0, 407.5, 419.0, 430.0, 444.4, 458.0, 470.0, 489.0, 500.0, 515.0, 530.0, 548.0,
            560.0, 575.0, 590.0, 605.0, 620.0, 633.0, 650.0, 668.0, 685.0, 700.0,
        ];
        let flat = |_: usize| [1.0, 1.0, 1.0];
        let w = lagrange_weights(&wl, Ends::Truncate, &flat);
        let total: f64 = w.iter().map(|v| v[0]).sum();
        assert!((total - 301.0).abs() < 1e-9, "{total}");
        let first_moment: f64 = w.iter().zip(&wl).map(|(v, l)| v[0] * l).sum();
        let exact: f64 = (400..=700).map(f64::from).sum();
        assert!((first_moment - exact).abs() < 1e-7 * exact);
    }
}
