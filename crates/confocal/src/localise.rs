//! Streaming localisation: slices go in one at a time, maps come out.
//!
//! Conventions: the stack has `nx × ny` pixels per slice (row-major, `x = col · dx`,
//! `y = row · dy`, µm, as in `HeightMap`) and `nz` slices a z step `dz` (µm) apart, given
//! in **recording order** (page order). [`SliceOrder`] says whether the first slice is
//! the lowest or the highest; heights come out in µm **above the lowest slice**, `z` up
//! (into the air, `physics.md` §1), whatever the order.
//!
//! Memory: per pixel the localiser keeps the index of its running maximum, the
//! `half_window` samples before it, the `half_window` after it, and a ring of the last
//! `half_window` samples (to fill the left half when a new maximum arrives): `3 H + 2`
//! numbers of 4 bytes, 44 bytes per pixel for the default `H = 3` (5.5 times an `f64`
//! height map), independent of `nz`. A 2048² × 200 stack (1.6 GB of 16-bit samples) is
//! localised in 185 MB. The estimated background threshold ([`MinSignal::Estimated`],
//! [`crate::noise`]) adds the samples of a fixed subset of pixels: at most 2²² samples
//! (16 MB) up to 65536 slices (64 pixels' samples beyond).
//!
//! Each pixel is independent, so slices are processed in parallel over fixed pixel
//! chunks: results are bit-identical for any number of threads.

use flakescatter_stats::heightmap::HeightMap;
use rayon::prelude::*;

use crate::ConfocalError;
use crate::noise::{SignalThreshold, estimate, sampling};
use crate::peak::{Invalid, PeakMethod, fit_window};

/// The largest slice the localiser accepts, in pixels (`nx · ny`): 2²⁶ (8192 × 8192).
pub const MAX_SLICE_PIXELS: usize = 1 << 26;

/// The largest `half_window`.
pub const MAX_HALF_WINDOW: usize = 32;

/// Which end of the stack the first slice is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SliceOrder {
    /// The first slice is the lowest (deepest in the coating); the z of slice `k` is
    /// `k · dz`.
    #[default]
    BottomFirst,
    /// The first slice is the highest; the z of slice `k` is `(nz − 1 − k) · dz`.
    TopFirst,
}

/// Size and spacing of a stack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StackGeometry {
    /// Pixels per row (columns), ≥ 1.
    pub nx: usize,
    /// Rows, ≥ 1.
    pub ny: usize,
    /// Slices, ≥ 3.
    pub nz: usize,
    /// Pixel pitch along `x`, µm (> 0).
    pub dx_um: f64,
    /// Pixel pitch along `y`, µm (> 0).
    pub dy_um: f64,
    /// Distance between slices, µm (> 0).
    pub dz_um: f64,
    /// Which end the first slice is.
    pub order: SliceOrder,
}

/// The background threshold: pixels whose brightest sample is below it are invalid.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum MinSignal {
    /// This level, in the units of the samples (full scale 1 for integer TIFF stacks
    /// read by `io`); `Level(0.0)` or below keeps every pixel with a finite sample.
    Level(f64),
    /// Estimated from the stack's own noise: `b + k σ` ([`crate::noise`]), so that one
    /// background pixel in a thousand passes. The default.
    #[default]
    Estimated,
}

/// How peaks are localised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakOptions {
    /// The estimator (default [`PeakMethod::Gaussian`]).
    pub method: PeakMethod,
    /// Slices within the peak are those at or above `fraction` times the maximum, in
    /// `(0, 1]` (default 0.5: the slices above half maximum). It is also the centroid's
    /// threshold.
    pub fraction: f64,
    /// Pixels whose brightest sample is below this are invalid (default: estimated from
    /// the stack's noise, [`MinSignal::Estimated`]).
    pub min_signal: MinSignal,
    /// Samples kept on each side of the running maximum, in `1..=32` (default 3). It
    /// must cover the slices within the peak: at least `FWHM / (2 dz)` plus one.
    pub half_window: usize,
    /// Samples at or above this level are counted as saturated in the report (`None`:
    /// no saturation level; default `None`). Saturated pixels stay valid: their peak is
    /// clipped and its position less certain.
    pub saturation: Option<f64>,
}

impl Default for PeakOptions {
    fn default() -> Self {
        Self {
            method: PeakMethod::Gaussian,
            fraction: 0.5,
            min_signal: MinSignal::Estimated,
            half_window: 3,
            saturation: None,
        }
    }
}

/// Counts of what happened to the pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PeakReport {
    /// Pixels with a height.
    pub valid: usize,
    /// Invalid: brightest sample below `min_signal` (or none finite).
    pub below_signal: usize,
    /// Invalid: brightest sample on the first slice.
    pub first_slice: usize,
    /// Invalid: brightest sample on the last slice.
    pub last_slice: usize,
    /// Invalid: the fit was impossible (missing or non-positive neighbour, not concave).
    pub not_fittable: usize,
    /// Valid pixels whose slices within the peak reached the window edge (raise
    /// `half_window` if this is more than a few).
    pub window_limited: usize,
    /// Pixels whose brightest sample is at or above the saturation level.
    pub saturated: usize,
}

/// The maps of a localised stack, all `nx × ny` with the stack's pixel pitch.
#[derive(Debug, Clone, PartialEq)]
pub struct PeakMaps {
    /// Height of the peak above the lowest slice, µm; invalid where [`PeakReport`] says.
    pub height: HeightMap,
    /// Brightest sample of each pixel (unit-less, the samples' units); invalid only where
    /// no sample is finite.
    pub intensity: HeightMap,
    /// Full width at half maximum of the axial peak, µm (the fitted width for
    /// `parabolic` and `gaussian`, the interpolated half-maximum width for `argmax` and
    /// `centroid`); invalid where the height is, or where the width is not determined.
    pub width: HeightMap,
    /// What happened to the pixels.
    pub report: PeakReport,
    /// The background threshold used, and how it was estimated.
    pub threshold: SignalThreshold,
}

/// The streaming localiser: [`Localiser::push_slice`] each slice in recording order, then
/// [`Localiser::finish`].
#[derive(Debug, Clone)]
pub struct Localiser {
    geometry: StackGeometry,
    options: PeakOptions,
    h: usize,
    pushed: usize,
    /// Index of the running maximum, per pixel.
    arg: Vec<u32>,
    /// `2h + 1` samples per pixel around the running maximum (NaN = not seen).
    window: Vec<f32>,
    /// The last `h` samples per pixel, slice `k` at position `k % h`.
    ring: Vec<f32>,
    /// Every `stride`-th pixel's samples, slice-major, for the noise estimate (empty
    /// when the threshold is given).
    sampled: Vec<f32>,
    /// `(stride, count)` of the sampled pixels.
    sampling: (usize, usize),
}

/// Pixels per parallel work item (fixed, so the result does not depend on threads; it
/// would not anyway, pixels being independent).
const CHUNK: usize = 4096;

fn bad(name: &'static str, value: f64, expected: &'static str) -> ConfocalError {
    ConfocalError::BadOption {
        name,
        value,
        expected,
    }
}

impl Localiser {
    /// A localiser for a stack of `geometry` with `options`.
    ///
    /// # Errors
    /// [`ConfocalError::BadOption`] naming the first geometry field or option that is out
    /// of range, [`ConfocalError::TooFewSlices`] for `nz < 3`,
    /// [`ConfocalError::TooLarge`] for more than [`MAX_SLICE_PIXELS`] pixels per slice.
    pub fn new(geometry: StackGeometry, options: PeakOptions) -> Result<Self, ConfocalError> {
        let g = geometry;
        if g.nx == 0 || g.ny == 0 {
            return Err(ConfocalError::TooLarge { nx: g.nx, ny: g.ny });
        }
        let n =
            g.nx.checked_mul(g.ny)
                .filter(|&n| n <= MAX_SLICE_PIXELS)
                .ok_or(ConfocalError::TooLarge { nx: g.nx, ny: g.ny })?;
        if g.nz < 3 {
            return Err(ConfocalError::TooFewSlices { nz: g.nz });
        }
        if g.nz > u32::MAX as usize {
            return Err(bad("nz", g.nz as f64, "at most 2^32 - 1 slices"));
        }
        for (name, v) in [("dx_um", g.dx_um), ("dy_um", g.dy_um), ("dz_um", g.dz_um)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, v, "finite and > 0"));
            }
        }
        let o = options;
        if !(o.fraction > 0.0 && o.fraction <= 1.0) {
            return Err(bad("fraction", o.fraction, "in (0, 1]"));
        }
        if let MinSignal::Level(v) = o.min_signal
            && v.is_nan()
        {
            return Err(bad("min_signal", v, "a number"));
        }
        if !(1..=MAX_HALF_WINDOW).contains(&o.half_window) {
            return Err(bad("half_window", o.half_window as f64, "in 1..=32"));
        }
        if let Some(s) = o.saturation
            && s.is_nan()
        {
            return Err(bad("saturation", s, "a number"));
        }
        let h = o.half_window;
        let sampling = sampling(n, g.nz);
        let sampled = match o.min_signal {
            MinSignal::Estimated => Vec::with_capacity(sampling.1 * g.nz),
            MinSignal::Level(_) => Vec::new(),
        };
        Ok(Self {
            geometry,
            options,
            h,
            pushed: 0,
            arg: vec![0; n],
            window: vec![f32::NAN; n * (2 * h + 1)],
            ring: vec![f32::NAN; n * h],
            sampled,
            sampling,
        })
    }

    /// The geometry given to [`Localiser::new`].
    pub fn geometry(&self) -> &StackGeometry {
        &self.geometry
    }

    /// Number of slices pushed so far.
    pub fn slices_pushed(&self) -> usize {
        self.pushed
    }

    /// Feeds the next slice (recording order), `nx · ny` samples row-major. NaN samples
    /// never count as a maximum.
    ///
    /// # Errors
    /// [`ConfocalError::SliceLength`] if `slice` has the wrong length,
    /// [`ConfocalError::TooManySlices`] after `nz` slices.
    pub fn push_slice(&mut self, slice: &[f32]) -> Result<(), ConfocalError> {
        let n = self.arg.len();
        if slice.len() != n {
            return Err(ConfocalError::SliceLength {
                slice: self.pushed,
                expected: n,
                found: slice.len(),
            });
        }
        if self.pushed >= self.geometry.nz {
            return Err(ConfocalError::TooManySlices {
                nz: self.geometry.nz,
            });
        }
        let k = self.pushed;
        let h = self.h;
        let wl = 2 * h + 1;
        self.arg
            .par_chunks_mut(CHUNK)
            .zip(self.window.par_chunks_mut(CHUNK * wl))
            .zip(self.ring.par_chunks_mut(CHUNK * h))
            .zip(slice.par_chunks(CHUNK))
            .for_each(|(((arg, win), ring), s)| {
                for (i, &v) in s.iter().enumerate() {
                    let w = &mut win[i * wl..(i + 1) * wl];
                    let r = &mut ring[i * h..(i + 1) * h];
                    // `!(v <= max)` would let NaN in; `v > max` keeps it out, and the
                    // NaN that marks an empty window loses to every number.
                    if v > w[h] || (w[h].is_nan() && !v.is_nan()) {
                        for (j, wj) in w.iter_mut().enumerate().take(h) {
                            // Offset j − h from slice k, i.e. slice k − h + j.
                            *wj = if k + j >= h {
                                r[(k + j - h) % h]
                            } else {
                                f32::NAN
                            };
                        }
                        w[h] = v;
                        for wj in &mut w[h + 1..] {
                            *wj = f32::NAN;
                        }
                        arg[i] = k as u32;
                    } else {
                        let d = k - arg[i] as usize;
                        if d >= 1 && d <= h {
                            w[h + d] = v;
                        }
                    }
                    r[k % h] = v;
                }
            });
        if self.options.min_signal == MinSignal::Estimated {
            let stride = self.sampling.0;
            self.sampled.extend(slice.iter().step_by(stride));
        }
        self.pushed += 1;
        Ok(())
    }

    /// The maps, once every slice has been pushed.
    ///
    /// # Errors
    /// [`ConfocalError::MissingSlices`] if fewer than `nz` slices were pushed.
    pub fn finish(self) -> Result<PeakMaps, ConfocalError> {
        let g = self.geometry;
        if self.pushed != g.nz {
            return Err(ConfocalError::MissingSlices {
                expected: g.nz,
                found: self.pushed,
            });
        }
        let o = self.options;
        let threshold = match o.min_signal {
            MinSignal::Level(level) => SignalThreshold {
                level,
                estimate: None,
                too_short: false,
            },
            MinSignal::Estimated => match estimate(&self.sampled, self.sampling.1, g.nz, self.h) {
                Some(e) => SignalThreshold {
                    level: e.threshold(),
                    estimate: Some(e),
                    too_short: false,
                },
                None => SignalThreshold {
                    level: 0.0,
                    estimate: None,
                    too_short: true,
                },
            },
        };
        let min_signal = threshold.level;
        let h = self.h;
        let wl = 2 * h + 1;
        let n = self.arg.len();
        let nz = g.nz;
        let results: Vec<(f64, f64, f64, Result<bool, Invalid>)> = (0..n)
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                let w32 = &self.window[i * wl..(i + 1) * wl];
                let mut w = [f64::NAN; 2 * MAX_HALF_WINDOW + 1];
                for (a, &b) in w.iter_mut().zip(w32) {
                    *a = f64::from(b);
                }
                let w = &w[..wl];
                let k = self.arg[i] as usize;
                let max = w[h];
                let outcome = if max.is_nan() || !(max >= min_signal) {
                    Err(Invalid::BelowSignal)
                } else if k == 0 {
                    Err(Invalid::FirstSlice)
                } else if k + 1 == nz {
                    Err(Invalid::LastSlice)
                } else {
                    fit_window(w, h, o.method, o.fraction)
                        .map(|(off, width, lim)| (k as f64 + off, width, lim))
                };
                match outcome {
                    Ok((p, width, lim)) => {
                        let z = match g.order {
                            SliceOrder::BottomFirst => p * g.dz_um,
                            SliceOrder::TopFirst => (nz as f64 - 1.0 - p) * g.dz_um,
                        };
                        (z, width * g.dz_um, max, Ok(lim))
                    }
                    Err(e) => (f64::NAN, f64::NAN, max, Err(e)),
                }
            })
            .collect();
        let mut report = PeakReport::default();
        let mut z = Vec::with_capacity(n);
        let mut width = Vec::with_capacity(n);
        let mut intensity = Vec::with_capacity(n);
        for (zi, wi, max, outcome) in results {
            match outcome {
                Ok(lim) => {
                    report.valid += 1;
                    report.window_limited += usize::from(lim);
                }
                Err(Invalid::BelowSignal) => report.below_signal += 1,
                Err(Invalid::FirstSlice) => report.first_slice += 1,
                Err(Invalid::LastSlice) => report.last_slice += 1,
                Err(Invalid::NotFittable) => report.not_fittable += 1,
            }
            if let Some(s) = o.saturation
                && max >= s
            {
                report.saturated += 1;
            }
            z.push(zi);
            width.push(wi);
            intensity.push(max);
        }
        let height = HeightMap::new(g.nx, g.ny, g.dx_um, g.dy_um, z)?;
        let width = HeightMap::new(g.nx, g.ny, g.dx_um, g.dy_um, width)?;
        let mut intensity = HeightMap::new(g.nx, g.ny, g.dx_um, g.dy_um, intensity)?;
        intensity.set_quantity(flakescatter_stats::heightmap::Quantity::Intensity);
        Ok(PeakMaps {
            height,
            intensity,
            width,
            report,
            threshold,
        })
    }
}
