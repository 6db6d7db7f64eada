//! Reflectance of a flake surface seen from inside the coating.
//!
//! Conventions: `cos_iota` is the cosine of the local incidence angle `ι` on the flake
//! (`cos ι = γ`, the obliquity of [`crate::reflection::obliquity`]); `n_medium` is the
//! real index of the coating around the flake. A complex flake index `N = n + i k`
//! (aluminium at 550 nm is about `0.96 + 6.69i`) is used relative to the medium,
//! `N/n_medium`, in the exact Fresnel amplitudes for an absorbing medium:
//! `rs = (cos ι − w)/(cos ι + w)`, `rp = (N² cos ι − w)/(N² cos ι + w)`,
//! `w = sqrt(N² − sin² ι)` (principal branch). The paper's assumption is a perfect
//! conductor, `|r|² = 1` for both polarisations.
//!
//! An interference flake ([`FlakeReflectance::Stack`], physics.md §13) is a thin-film
//! stack at one wavelength, in the medium around it (`n_medium` is the ambient on its
//! incidence side and, for a free flake, below it) or on an opaque core. Its amplitudes
//! are the stack's `(r_s, r_p)` in the same convention; the power it transmits
//! (`T = 1 − R − A`) leaves the flake downward and is not part of this reflectance (each
//! model states where it goes).

use std::sync::Arc;

use nalgebra::Complex;

use crate::OpticsError;
use crate::thinfilm::{FilmStack, solve_unchecked};

/// A thin-film flake at one wavelength: its layers (from the side light arrives on),
/// the wavelength, and an opaque core under the layers (`None`: a free flake, the
/// medium around it on both sides). Built, and checked, by [`FlakeReflectance::stack`].
#[derive(Debug, Clone, PartialEq)]
pub struct StackFlake {
    stack: FilmStack,
    wavelength_nm: f64,
    core: Option<Complex<f64>>,
}

impl StackFlake {
    /// The layers.
    #[must_use]
    pub fn stack(&self) -> &FilmStack {
        &self.stack
    }

    /// Vacuum wavelength, nm (> 0, finite).
    #[must_use]
    pub fn wavelength_nm(&self) -> f64 {
        self.wavelength_nm
    }

    /// The core's complex index, or `None` for a free flake.
    #[must_use]
    pub fn core(&self) -> Option<Complex<f64>> {
        self.core
    }
}

/// How a flake reflects.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum FlakeReflectance {
    /// Perfect conductor: `Rs = Rp = 1` (the paper's assumption; the default).
    #[default]
    PerfectConductor,
    /// A metal of complex index `n + i k` relative to vacuum.
    Complex {
        /// Real part of the index.
        n: f64,
        /// Extinction coefficient (imaginary part), `≥ 0`.
        k: f64,
    },
    /// A thin-film (interference) flake at one wavelength.
    Stack(Arc<StackFlake>),
}

impl FlakeReflectance {
    /// A metal flake of complex index `n + i k`.
    ///
    /// # Errors
    /// [`OpticsError::InvalidComplexIndex`] unless `n > 0`, `k ≥ 0`, both finite.
    pub fn complex(n: f64, k: f64) -> Result<Self, OpticsError> {
        if n.is_finite() && k.is_finite() && n > 0.0 && k >= 0.0 {
            Ok(Self::Complex { n, k })
        } else {
            Err(OpticsError::InvalidComplexIndex { n, k })
        }
    }

    /// Aluminium at 550 nm, `0.96 + 6.69i` (physics.md §2).
    #[must_use]
    pub fn aluminium_550nm() -> Self {
        Self::Complex { n: 0.96, k: 6.69 }
    }

    /// Power reflectances `(Rs, Rp)` at local incidence cosine `cos_iota ∈ [0, 1]`
    /// inside a medium of real index `n_medium`.
    #[must_use]
    #[inline]
    pub fn power(&self, cos_iota: f64, n_medium: f64) -> (f64, f64) {
        match self {
            Self::PerfectConductor => (1.0, 1.0),
            Self::Complex { .. } | Self::Stack(_) => {
                let (rs, rp) = self.amplitudes(cos_iota, n_medium);
                (rs.norm_sqr(), rp.norm_sqr())
            }
        }
    }

    /// A thin-film flake: `stack` at `wavelength_nm`, free (`core = None`) or on an
    /// opaque core of index `core`.
    ///
    /// # Errors
    /// [`OpticsError::InvalidComplexIndex`] for a bad core index,
    /// [`OpticsError::InvalidWavelength`] for a wavelength that is not finite and > 0.
    pub fn stack(
        stack: FilmStack,
        wavelength_nm: f64,
        core: Option<Complex<f64>>,
    ) -> Result<Self, OpticsError> {
        if !(wavelength_nm.is_finite() && wavelength_nm > 0.0) {
            return Err(OpticsError::InvalidWavelength(wavelength_nm));
        }
        if let Some(c) = core {
            Self::complex(c.re, c.im)?;
        }
        Ok(Self::Stack(Arc::new(StackFlake {
            stack,
            wavelength_nm,
            core,
        })))
    }

    /// Power transmittances `(Ts, Tp)` through the flake (into the medium below it, or
    /// absorbed by its core): 0 for a metal or perfect conductor.
    #[must_use]
    pub fn transmitted(&self, cos_iota: f64, n_medium: f64) -> (f64, f64) {
        match self {
            Self::PerfectConductor | Self::Complex { .. } => (0.0, 0.0),
            Self::Stack(f) => {
                let r = self.stack_response(f, cos_iota, n_medium);
                (r.t_s(), r.t_p())
            }
        }
    }

    fn stack_response(
        &self,
        f: &StackFlake,
        cos_iota: f64,
        n_medium: f64,
    ) -> crate::thinfilm::Response {
        let exit = f.core.unwrap_or(Complex::new(n_medium, 0.0));
        solve_unchecked(
            f.stack.layers(),
            n_medium,
            exit,
            cos_iota.clamp(0.0, 1.0),
            f.wavelength_nm,
        )
    }

    /// Amplitude reflection coefficients `(rs, rp)` at local incidence cosine
    /// `cos_iota ∈ [0, 1]` inside a medium of real index `n_medium`, in the convention
    /// of [`crate::jones`] (`p = k × s` for the incoming and the reflected wave, time
    /// dependence `exp(−iωt)`): `(−1, +1)` for the perfect conductor, the module-doc
    /// formulas for a complex index.
    #[must_use]
    #[inline]
    pub fn amplitudes(&self, cos_iota: f64, n_medium: f64) -> (Complex<f64>, Complex<f64>) {
        match self {
            Self::PerfectConductor => (Complex::new(-1.0, 0.0), Complex::new(1.0, 0.0)),
            &Self::Complex { n, k } => {
                let c = cos_iota.clamp(0.0, 1.0);
                let sin2 = 1.0 - c * c;
                let big_n = Complex::new(n, k) / n_medium;
                let n2 = big_n * big_n;
                let w = (n2 - Complex::new(sin2, 0.0)).sqrt();
                let cc = Complex::new(c, 0.0);
                let rs = (cc - w) / (cc + w);
                let rp = (n2 * cc - w) / (n2 * cc + w);
                (rs, rp)
            }
            Self::Stack(f) => {
                let r = self.stack_response(f, cos_iota, n_medium);
                (r.rs, r.rp)
            }
        }
    }

    /// Unpolarised reflectance `(Rs + Rp)/2`.
    #[must_use]
    pub fn average(&self, cos_iota: f64, n_medium: f64) -> f64 {
        let (rs, rp) = self.power(cos_iota, n_medium);
        0.5 * (rs + rp)
    }

    /// Whether this is the perfect conductor (reflectance 1 at every angle).
    #[must_use]
    pub fn is_perfect(&self) -> bool {
        matches!(self, Self::PerfectConductor)
    }
}
