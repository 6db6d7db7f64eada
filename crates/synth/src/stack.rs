//! Confocal z-stacks of a synthetic layer, with a known surface.
//!
//! Conventions: lengths in µm, `z` up (into the air), heights from the substrate as in
//! the layer; slice `k` is focused at `z_k = z_first + k · Δ` (slice 0 the lowest); map
//! axes as in `HeightMap` (row-major, `x = col · dx`, `y = row · dy`). Samples are
//! integer detector counts, full scale `2^bits − 1`.
//!
//! Model, per pixel with surface height `h` (the layer's height map, which must be exact:
//! no z quantisation and no height noise in the layer's `Confocal` settings):
//!
//! * **Axial response** of a reflecting surface, a function of defocus `u = z_k − h`
//!   normalised to 1 in focus ([`AxialResponse`]): a Gaussian
//!   `exp(−4 ln 2 · u² / W²)` or the paraxial plane-mirror response of a confocal
//!   microscope, `sinc²(a u) = (sin(a u) / (a u))²` (Wilson & Sheppard; Corle & Kino,
//!   *Confocal Scanning Optical Microscopy*, 1996), with `a = 2.78311 / W` so that its
//!   FWHM is `W` (`sinc²(x) = ½` at `x = 1.39156`). Only the surface seen from above
//!   responds; lateral blur, out-of-focus light from deeper flakes and multiple
//!   reflections are not modelled.
//! * **Amplitude** `A = N · L · T(θ)`: `N` photoelectrons for a level-1 untilted mirror in
//!   focus ([`StackSpec::photons`]), `L` the layer's intensity level (flake or
//!   background, [`IntensityLevels`](crate::IntensityLevels)), and the **tilt factor**
//!   `T(θ)` of a flake whose normal is tilted by `θ`: the objective's illumination cone
//!   (half-angle `α`, `s = sin α` in the medium around the flakes) comes back deflected by
//!   `2θ`, and the returned light is the overlap of two discs of radius `s` whose centres
//!   are `d = sin 2θ` apart in direction-cosine space:
//!   `T = (2/π) (acos q − q √(1 − q²))`, `q = d / (2s)`, `T = 0` for `q ≥ 1` or
//!   `θ ≥ 45°`. (The paper's 100×/1.3 oil objective in a coat of index 1.5 gives
//!   `s = 1.3/1.5`; `T(5°) = 0.87`, `T(15°) = 0.64`.) Background pixels have `T = 1`.
//! * **Noise**: each sample is `Poisson(A · R(u))` photoelectrons plus Gaussian read
//!   noise of sd [`StackSpec::read_noise`] electrons, converted to counts with
//!   `full_scale / N` counts per electron, rounded and clipped to `[0, full_scale]`
//!   (a level-1 mirror in focus fills the scale).
//!
//! Randomness: one ChaCha8 stream per (stack seed, slice, row), so any slice can be
//! rendered on its own, in any order, with any number of threads, bit for bit.

use std::f64::consts::PI;

use rand_distr::{Distribution, Poisson, StandardNormal};
use rayon::prelude::*;

use crate::SynthError;
use crate::field::{Stream, stream_rng};
use crate::generate::SyntheticLayer;
use crate::params::{LayerParams, Param};

/// `sinc²(x) = ½` at `x = 1.391557…` (the root of `sin x = x / √2`).
const SINC2_HALF: f64 = 1.391_557_378_251_51;

/// Axial response of a reflecting surface, normalised to 1 in focus (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AxialResponse {
    /// `exp(−4 ln 2 · u² / W²)`, full width at half maximum `fwhm_um`.
    Gaussian {
        /// FWHM `W`, µm.
        fwhm_um: f64,
    },
    /// `sinc²(a u)`, `a = 2 · 1.39156 / W`, full width at half maximum `fwhm_um`.
    Sinc2 {
        /// FWHM `W`, µm.
        fwhm_um: f64,
    },
}

impl AxialResponse {
    /// The response at defocus `u_um` (µm), in `[0, 1]`, 1 at `u = 0`.
    pub fn at(&self, u_um: f64) -> f64 {
        match *self {
            Self::Gaussian { fwhm_um } => {
                let r = u_um / fwhm_um;
                (-4.0 * std::f64::consts::LN_2 * r * r).exp()
            }
            Self::Sinc2 { fwhm_um } => {
                let x = 2.0 * SINC2_HALF * u_um / fwhm_um;
                if x.abs() < 1e-8 {
                    1.0
                } else {
                    let s = x.sin() / x;
                    s * s
                }
            }
        }
    }

    /// Full width at half maximum, µm.
    pub fn fwhm_um(&self) -> f64 {
        match *self {
            Self::Gaussian { fwhm_um } | Self::Sinc2 { fwhm_um } => fwhm_um,
        }
    }
}

/// Bits per sample of a rendered stack.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BitDepth {
    /// 8-bit counts, full scale 255.
    Eight,
    /// 16-bit counts, full scale 65535.
    Sixteen,
}

impl BitDepth {
    /// `2^bits − 1`.
    pub fn full_scale(self) -> u16 {
        match self {
            Self::Eight => 255,
            Self::Sixteen => 65535,
        }
    }
}

/// How a stack is recorded. Build with [`StackSpec::new`] and adjust the fields.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StackSpec {
    /// Distance between slices `Δ`, µm (> 0; default 0.3, the paper's).
    pub z_step_um: f64,
    /// Number of slices, ≥ 3 (default 40).
    pub slices: usize,
    /// Height of slice 0 (the lowest) above the substrate, µm (default 0).
    pub z_first_um: f64,
    /// Axial response (default Gaussian, FWHM 0.6 µm).
    pub axial: AxialResponse,
    /// Photoelectrons for a level-1, untilted mirror in focus, > 0 (default 2000: 2.2 %
    /// shot noise at the peak).
    pub photons: f64,
    /// Read noise, sd in electrons, ≥ 0 (default 4).
    pub read_noise: f64,
    /// Sample depth (default 16-bit).
    pub bit_depth: BitDepth,
    /// `sin α` of the objective's half-angle in the medium around the flakes, in (0, 1]
    /// (default 1.3 / 1.5: the paper's 100×/1.3 oil objective in a coat of index 1.5).
    pub aperture_sin: f64,
    /// Seed of the noise; equal seeds give bit-identical stacks.
    pub seed: u64,
}

impl StackSpec {
    /// `slices` slices `z_step_um` apart from `z_first_um` up, every other field at its
    /// documented default.
    pub fn new(z_step_um: f64, slices: usize, z_first_um: f64, seed: u64) -> Self {
        Self {
            z_step_um,
            slices,
            z_first_um,
            axial: AxialResponse::Gaussian { fwhm_um: 0.6 },
            photons: 2000.0,
            read_noise: 4.0,
            bit_depth: BitDepth::Sixteen,
            aperture_sin: 1.3 / 1.5,
            seed,
        }
    }
}

/// The tilt factor `T(θ)` of the module docs for a flake tilted by `theta` (radians)
/// under an objective of `sin α = aperture_sin`.
pub fn tilt_factor(theta: f64, aperture_sin: f64) -> f64 {
    if !(theta.abs() < PI / 4.0) {
        return 0.0;
    }
    let q = (2.0 * theta).sin().abs() / (2.0 * aperture_sin);
    if q >= 1.0 {
        return 0.0;
    }
    (2.0 / PI) * (q.acos() - q * (1.0 - q * q).sqrt())
}

/// A renderable stack of a layer: the surface and the expected in-focus signal per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticStack {
    spec: StackSpec,
    nx: usize,
    ny: usize,
    dx_um: f64,
    dy_um: f64,
    /// Surface height per pixel, µm.
    surface: Vec<f64>,
    /// Expected photoelectrons in focus per pixel.
    amplitude: Vec<f64>,
}

fn invalid(param: Param, value: f64, expected: &'static str) -> SynthError {
    SynthError::InvalidParameter {
        param,
        value,
        expected,
    }
}

impl SyntheticStack {
    /// Prepares the stack of `layer` (generated from `params`) as `spec` records it.
    ///
    /// # Errors
    /// [`SynthError::InvalidParameter`] for a spec field out of range, or when the layer
    /// was generated with z quantisation or height noise (`z_step_um`,
    /// `height_noise_sd_um`: the stack samples and blurs z itself, so the layer must be
    /// exact).
    pub fn new(
        spec: &StackSpec,
        params: &LayerParams,
        layer: &SyntheticLayer,
    ) -> Result<Self, SynthError> {
        let c = params.spec().confocal;
        if c.z_step_um != 0.0 {
            return Err(invalid(
                Param::ZStepUm,
                c.z_step_um,
                "0 in the layer rendered as a stack (the stack samples z itself)",
            ));
        }
        if c.noise_sd_um != 0.0 {
            return Err(invalid(
                Param::HeightNoiseSdUm,
                c.noise_sd_um,
                "0 in the layer rendered as a stack (the stack adds its own noise)",
            ));
        }
        let s = spec;
        if !(s.z_step_um.is_finite() && s.z_step_um > 0.0) {
            return Err(invalid(Param::StackZStepUm, s.z_step_um, "finite and > 0"));
        }
        if s.slices < 3 || s.slices > 100_000 {
            return Err(invalid(
                Param::StackSlices,
                s.slices as f64,
                "in 3..=100000",
            ));
        }
        if !s.z_first_um.is_finite() {
            return Err(invalid(Param::StackZFirstUm, s.z_first_um, "finite"));
        }
        let w = s.axial.fwhm_um();
        if !(w.is_finite() && w > 0.0) {
            return Err(invalid(Param::AxialFwhmUm, w, "finite and > 0"));
        }
        if !(s.photons.is_finite() && s.photons > 0.0) {
            return Err(invalid(Param::Photons, s.photons, "finite and > 0"));
        }
        if !(s.read_noise.is_finite() && s.read_noise >= 0.0) {
            return Err(invalid(Param::ReadNoise, s.read_noise, "finite and >= 0"));
        }
        if !(s.aperture_sin > 0.0 && s.aperture_sin <= 1.0) {
            return Err(invalid(Param::ApertureSin, s.aperture_sin, "in (0, 1]"));
        }
        let map = &layer.height;
        let levels = params.spec().intensity;
        let amplitude = layer
            .labels
            .iter()
            .map(|&l| {
                if l == 0 {
                    s.photons * levels.background
                } else {
                    let f = &layer.truth[l as usize - 1];
                    s.photons * levels.flake * tilt_factor(f.theta_n, s.aperture_sin)
                }
            })
            .collect();
        Ok(Self {
            spec: *spec,
            nx: map.nx(),
            ny: map.ny(),
            dx_um: map.dx(),
            dy_um: map.dy(),
            surface: map.heights().to_vec(),
            amplitude,
        })
    }

    /// The recording spec.
    pub fn spec(&self) -> &StackSpec {
        &self.spec
    }

    /// `(nx, ny, nz)`.
    pub fn size(&self) -> (usize, usize, usize) {
        (self.nx, self.ny, self.spec.slices)
    }

    /// Pixel pitch `(dx, dy)`, µm.
    pub fn pitch_um(&self) -> (f64, f64) {
        (self.dx_um, self.dy_um)
    }

    /// Height of slice `k` above the substrate, µm.
    pub fn slice_z_um(&self, k: usize) -> f64 {
        self.spec.z_first_um + k as f64 * self.spec.z_step_um
    }

    /// The true surface height of each pixel above the substrate, µm (row-major).
    pub fn surface_um(&self) -> &[f64] {
        &self.surface
    }

    /// Expected in-focus signal of each pixel, in counts (row-major).
    pub fn expected_peak_counts(&self) -> Vec<f64> {
        let g = f64::from(self.spec.bit_depth.full_scale()) / self.spec.photons;
        self.amplitude.iter().map(|a| a * g).collect()
    }

    /// The counts of slice `k` (`k < slices`; row-major), noise included.
    ///
    /// # Errors
    /// [`SynthError::InvalidParameter`] for `k ≥ slices`.
    pub fn slice(&self, k: usize) -> Result<Vec<u16>, SynthError> {
        if k >= self.spec.slices {
            return Err(invalid(
                Param::Slice,
                k as f64,
                "below the number of slices",
            ));
        }
        let s = self.spec;
        let z = self.slice_z_um(k);
        let full = f64::from(s.bit_depth.full_scale());
        let gain = full / s.photons;
        let mut out = vec![0u16; self.nx * self.ny];
        out.par_chunks_mut(self.nx)
            .zip(self.surface.par_chunks(self.nx))
            .zip(self.amplitude.par_chunks(self.nx))
            .enumerate()
            .for_each(|(row, ((o, h), a))| {
                let stream = (k as u64) * (self.ny as u64) + row as u64;
                let mut rng = stream_rng(s.seed, Stream::StackNoise, stream);
                for ((o, &h), &a) in o.iter_mut().zip(h).zip(a) {
                    let lambda = a * s.axial.at(z - h);
                    let photons = if lambda > 0.0 {
                        Poisson::new(lambda).map_or(lambda, |p| p.sample(&mut rng))
                    } else {
                        0.0
                    };
                    let read: f64 = StandardNormal.sample(&mut rng);
                    let counts = ((photons + s.read_noise * read) * gain).round();
                    *o = counts.clamp(0.0, full) as u16;
                }
            });
        Ok(out)
    }
}
