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

use nalgebra::Complex;

use crate::OpticsError;

/// How a flake reflects.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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
        match *self {
            Self::PerfectConductor => (1.0, 1.0),
            Self::Complex { .. } => {
                let (rs, rp) = self.amplitudes(cos_iota, n_medium);
                (rs.norm_sqr(), rp.norm_sqr())
            }
        }
    }

    /// Amplitude reflection coefficients `(rs, rp)` at local incidence cosine
    /// `cos_iota ∈ [0, 1]` inside a medium of real index `n_medium`, in the convention
    /// of [`crate::jones`] (`p = k × s` for the incoming and the reflected wave, time
    /// dependence `exp(−iωt)`): `(−1, +1)` for the perfect conductor, the module-doc
    /// formulas for a complex index.
    #[must_use]
    #[inline]
    pub fn amplitudes(&self, cos_iota: f64, n_medium: f64) -> (Complex<f64>, Complex<f64>) {
        match *self {
            Self::PerfectConductor => (Complex::new(-1.0, 0.0), Complex::new(1.0, 0.0)),
            Self::Complex { n, k } => {
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
