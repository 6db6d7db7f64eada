//! Thin-film optics: a stack of plane-parallel layers between two media (physics.md
//! §13), for interference (pearlescent) flakes.
//!
//! # Conventions
//! * Time dependence `exp(−iωt)`, so an absorbing medium has index `N = n + i k` with
//!   `k ≥ 0` and a wave travelling down `z` is `exp(+i q z 2π/λ)`, `q = N cos θ`.
//! * Layers are listed **from the incidence side**. The incidence medium (the
//!   *ambient*, the binder around a flake) has a real index `n₀ > 0`; the exit medium
//!   (the binder again for a free flake, or an opaque *substrate* such as an aluminium
//!   core) may absorb.
//! * Snell's invariant `s = n₀ sin θ₀` is shared by every medium; in medium `j`,
//!   `q_j = N_j cos θ_j = sqrt(N_j² − s²)` on the principal branch, which is the
//!   forward wave: `Im q ≥ 0` (decays forward in an absorbing or evanescent layer) and
//!   `Re q ≥ 0`. This is the `tmm` package's (Byrnes) choice too.
//! * Amplitude coefficients are those of the flake (module `flake`) and of the Jones
//!   matrices (module `jones`): for s,
//!   `r = (q_i − q_j)/(q_i + q_j)`, `t = 2 q_i/(q_i + q_j)`; for p (field amplitudes,
//!   `p = k × s`), `r = (N_j² q_i − N_i² q_j)/(N_j² q_i + N_i² q_j)`,
//!   `t = 2 N_i N_j q_i/(N_j² q_i + N_i² q_j)`. At normal incidence `r_p = −r_s`; a
//!   perfect conductor has `(r_s, r_p) = (−1, +1)`. These are `tmm`'s conventions.
//! * The stack is combined from the exit side up (Rouard's recursion, equivalent to the
//!   transfer-matrix product but with `exp(2iδ)` factors that decay in absorbing
//!   layers, so thick metal layers neither overflow nor lose precision):
//!   `r ← (r_{j−1,j} + r e^{2iδ_j}) / (1 + r_{j−1,j} r e^{2iδ_j})`,
//!   `t ← t_{j−1,j} t e^{iδ_j} / (1 + r_{j−1,j} r e^{2iδ_j})`,
//!   with the phase thickness `δ_j = 2π q_j d_j / λ`.
//! * Powers: `R = |r|²`; `T_s = |t|² Re(q_out)/q₀`;
//!   `T_p = |t|² Re(N_out q̄_out / N̄_out)/q₀` (the normal Poynting flux into the exit
//!   medium; into an absorbing substrate it is the power the substrate absorbs).
//!   `A = 1 − R − T` is absorbed in the layers. At grazing incidence (`cos θ₀ = 0`)
//!   `R = 1`, `T = 0`.
//!
//! Thicknesses in **nanometres**, wavelengths in vacuum, **nanometres**.
//!
//! # Example
//! A quarter-wave TiO2-like layer (n = 2.5) in a binder of 1.5 at normal incidence: the
//! Airy formula gives `R = ((n₀n₂ − n₁²)/(n₀n₂ + n₁²))²` with `n₀ = n₂ = 1.5`.
//! ```
//! use flakescatter_optics::nalgebra::Complex;
//! use flakescatter_optics::thinfilm::{FilmStack, Layer};
//!
//! let lambda = 550.0;
//! let layer = Layer::new(Complex::new(2.5, 0.0), lambda / (4.0 * 2.5)).unwrap();
//! let stack = FilmStack::new(vec![layer]).unwrap();
//! let resp = stack.response(1.5, Complex::new(1.5, 0.0), 1.0, lambda).unwrap();
//! let closed = ((1.5f64 * 1.5 - 6.25) / (1.5 * 1.5 + 6.25)).powi(2);
//! assert!((resp.r_s() - closed).abs() < 1e-12);
//! assert!((resp.r_s() + resp.t_s() - 1.0).abs() < 1e-12); // no absorption
//! ```

mod solve;

use nalgebra::Complex;

pub(crate) use solve::response as solve_unchecked;
pub use solve::{Polarization, Response};

/// Most layers a stack may have (a spec with more is refused).
pub const MAX_LAYERS: usize = 200;

/// Errors from building or evaluating a thin-film stack. Layers are numbered from 1, from
/// the incidence side.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThinFilmError {
    /// A layer index with a non-finite part, `n ≤ 0` or `k < 0`.
    #[error("layer {layer}: index {n} + {k}i is not valid: expected finite n > 0 and k >= 0")]
    InvalidIndex {
        /// Layer (1-based); 0 for a layer not yet placed in a stack.
        layer: usize,
        /// Real part.
        n: f64,
        /// Extinction coefficient.
        k: f64,
    },
    /// A thickness that is not finite and positive.
    #[error("layer {layer}: thickness {value} nm is not valid: expected a finite number > 0")]
    InvalidThickness {
        /// Layer (1-based); 0 for a layer not yet placed in a stack.
        layer: usize,
        /// The value given, nm.
        value: f64,
    },
    /// More layers than [`MAX_LAYERS`].
    #[error("{0} layers: expected at most {MAX_LAYERS}")]
    TooManyLayers(usize),
    /// The incidence medium's index is not real, finite and positive.
    #[error("ambient index {0} is not valid: expected a finite real number > 0")]
    InvalidAmbient(f64),
    /// The exit medium's index is not valid.
    #[error("exit-medium index {n} + {k}i is not valid: expected finite n > 0 and k >= 0")]
    InvalidExit {
        /// Real part.
        n: f64,
        /// Extinction coefficient.
        k: f64,
    },
    /// A wavelength that is not finite and positive.
    #[error("wavelength {0} nm is not valid: expected a finite number > 0")]
    InvalidWavelength(f64),
    /// An incidence cosine outside `[0, 1]`.
    #[error("incidence cosine {0} is not valid: expected a number in [0, 1]")]
    InvalidCosine(f64),
}

/// One homogeneous layer: complex index relative to vacuum and thickness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    pub(crate) index: Complex<f64>,
    pub(crate) thickness_nm: f64,
}

impl Layer {
    /// A layer of index `index = n + i k` (finite, `n > 0`, `k ≥ 0`) and thickness
    /// `thickness_nm > 0`.
    ///
    /// # Errors
    /// [`ThinFilmError::InvalidIndex`] or [`ThinFilmError::InvalidThickness`] (layer 0).
    pub fn new(index: Complex<f64>, thickness_nm: f64) -> Result<Self, ThinFilmError> {
        check_index(index).map_err(|(n, k)| ThinFilmError::InvalidIndex { layer: 0, n, k })?;
        if !(thickness_nm.is_finite() && thickness_nm > 0.0) {
            return Err(ThinFilmError::InvalidThickness {
                layer: 0,
                value: thickness_nm,
            });
        }
        Ok(Self {
            index,
            thickness_nm,
        })
    }

    /// Complex index `n + i k`.
    #[must_use]
    pub fn index(&self) -> Complex<f64> {
        self.index
    }

    /// Thickness, nm.
    #[must_use]
    pub fn thickness_nm(&self) -> f64 {
        self.thickness_nm
    }
}

/// `Ok` for a finite index with `n > 0`, `k ≥ 0`; else its parts.
fn check_index(index: Complex<f64>) -> Result<(), (f64, f64)> {
    if index.re.is_finite() && index.im.is_finite() && index.re > 0.0 && index.im >= 0.0 {
        Ok(())
    } else {
        Err((index.re, index.im))
    }
}

/// A validated stack of at most [`MAX_LAYERS`] layers, listed from the incidence side
/// (an empty stack is a bare interface between the two media).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FilmStack {
    pub(crate) layers: Vec<Layer>,
}

impl FilmStack {
    /// A stack of `layers`, from the incidence side.
    ///
    /// # Errors
    /// [`ThinFilmError::TooManyLayers`] above [`MAX_LAYERS`]. (Each [`Layer`] is valid by
    /// construction.)
    pub fn new(layers: Vec<Layer>) -> Result<Self, ThinFilmError> {
        if layers.len() > MAX_LAYERS {
            return Err(ThinFilmError::TooManyLayers(layers.len()));
        }
        Ok(Self { layers })
    }

    /// The layers, from the incidence side.
    #[must_use]
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// The same stack seen from the other side (layers in reverse order).
    #[must_use]
    pub fn reversed(&self) -> Self {
        let mut layers = self.layers.clone();
        layers.reverse();
        Self { layers }
    }

    /// Total thickness, nm.
    #[must_use]
    pub fn thickness_nm(&self) -> f64 {
        self.layers.iter().map(|l| l.thickness_nm).sum()
    }

    /// Amplitudes and powers for light arriving from an ambient of real index `n_ambient`
    /// at incidence cosine `cos_theta ∈ [0, 1]` (measured in the ambient) and vacuum
    /// wavelength `wavelength_nm`, leaving into an exit medium of index `n_exit`.
    ///
    /// # Errors
    /// [`ThinFilmError`] for an invalid ambient, exit index, wavelength or cosine.
    pub fn response(
        &self,
        n_ambient: f64,
        n_exit: Complex<f64>,
        cos_theta: f64,
        wavelength_nm: f64,
    ) -> Result<Response, ThinFilmError> {
        if !(n_ambient.is_finite() && n_ambient > 0.0) {
            return Err(ThinFilmError::InvalidAmbient(n_ambient));
        }
        check_index(n_exit).map_err(|(n, k)| ThinFilmError::InvalidExit { n, k })?;
        if !(wavelength_nm.is_finite() && wavelength_nm > 0.0) {
            return Err(ThinFilmError::InvalidWavelength(wavelength_nm));
        }
        if !(0.0..=1.0).contains(&cos_theta) {
            return Err(ThinFilmError::InvalidCosine(cos_theta));
        }
        Ok(solve::response(
            &self.layers,
            n_ambient,
            n_exit,
            cos_theta,
            wavelength_nm,
        ))
    }
}
