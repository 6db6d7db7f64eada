//! Absorption by the binder along a ray's path inside the film (physics.md §8.1).
//!
//! Conventions: lengths in **micrometres**; `alpha_per_um` is the Napierian (base-e)
//! absorption coefficient of the binder for intensity, µm⁻¹ (Beer–Lambert:
//! `I = I₀ exp(−α s)` after a path `s`; a decadic absorbance `A₁₀` per µm is
//! `α = A₁₀ ln 10`). Depths are measured down from the top surface of the film.
//! `cos_t = cos θt` is the cosine of the refracted incident ray's polar angle inside
//! (`−k1.z`), `cos_2 = cos θ2` that of the reflected ray (`k2.z`), both in `(0, 1]`.
//!
//! A flake at depth `d`: the ray goes down `d / cos θt` and back up `d / cos θ2`, so the
//! power it carries is multiplied by
//!
//! `A_d = exp(−α d L)`, `L = 1/cos θt + 1/cos θ2` (path length per unit depth).
//!
//! Flakes spread uniformly over the depths `[0, T]` of a film of thickness `T` (each
//! depth holding the same flake area per unit depth): the mean of `A_d` over `d`,
//!
//! `A_T = (1/T) ∫₀ᵀ exp(−α L d) dd = (1 − exp(−x)) / x`, `x = α T L`
//!
//! (`→ 1 − x/2` for small `x`; evaluated as `−expm1(−x)/x`, accurate for every `x`).
//!
//! What this leaves out: the binder's imaginary index `κ = α λ/(4π)` in Snell's law and
//! in the Fresnel factors (`κ ≈ 0.04` for `α = 1 µm⁻¹` at 500 nm, against `n ≈ 1.5`),
//! shadowing of deeper flakes by upper ones, and light scattered by pigment particles
//! (the binder is a clear absorber: a dye, not a scatterer).

/// Where the flakes sit in the film.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlakeDepth {
    /// Every flake at depth `d` (µm) below the top surface.
    At {
        /// Depth, µm (≥ 0).
        depth_um: f64,
    },
    /// Flakes uniformly spread over the depths `[0, T]` of a film `T` µm thick.
    UniformInFilm {
        /// Film thickness `T`, µm (> 0).
        film_um: f64,
    },
}

/// Why an absorption was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AbsorptionError {
    /// A negative or non-finite absorption coefficient.
    #[error("absorption coefficient {0} per µm is not valid: expected a finite number >= 0")]
    Coefficient(f64),
    /// A negative or non-finite depth, or a film thickness that is not positive.
    #[error("{name} {value} µm is not valid: expected {expected}")]
    Depth {
        /// `flake depth` or `film thickness`.
        name: &'static str,
        /// The value given, µm.
        value: f64,
        /// The accepted range.
        expected: &'static str,
    },
}

/// The binder's absorption at one wavelength with the flakes' depth: the per-ray
/// factor of the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathAbsorption {
    alpha_per_um: f64,
    depth: FlakeDepth,
}

impl PathAbsorption {
    /// Absorption coefficient `alpha_per_um` (µm⁻¹, Napierian) with flakes at `depth`.
    ///
    /// # Errors
    /// [`AbsorptionError`] for a negative or non-finite coefficient or depth, or a film
    /// thickness that is not positive.
    pub fn new(alpha_per_um: f64, depth: FlakeDepth) -> Result<Self, AbsorptionError> {
        if !(alpha_per_um.is_finite() && alpha_per_um >= 0.0) {
            return Err(AbsorptionError::Coefficient(alpha_per_um));
        }
        match depth {
            FlakeDepth::At { depth_um } if !(depth_um.is_finite() && depth_um >= 0.0) => {
                return Err(AbsorptionError::Depth {
                    name: "flake depth",
                    value: depth_um,
                    expected: "a finite depth >= 0",
                });
            }
            FlakeDepth::UniformInFilm { film_um } if !(film_um.is_finite() && film_um > 0.0) => {
                return Err(AbsorptionError::Depth {
                    name: "film thickness",
                    value: film_um,
                    expected: "a finite thickness > 0",
                });
            }
            _ => {}
        }
        Ok(Self {
            alpha_per_um,
            depth,
        })
    }

    /// The absorption coefficient, µm⁻¹.
    #[must_use]
    pub fn alpha_per_um(&self) -> f64 {
        self.alpha_per_um
    }

    /// Where the flakes are.
    #[must_use]
    pub fn depth(&self) -> FlakeDepth {
        self.depth
    }

    /// The fraction of a ray's power left after its path inside the film, for the
    /// inside cosines `cos_t` (down) and `cos_2` (up) (module docs). 1 when `α = 0`;
    /// tends to 0 as either cosine tends to 0.
    #[must_use]
    #[inline]
    pub fn factor(&self, cos_t: f64, cos_2: f64) -> f64 {
        let per_depth = 1.0 / cos_t + 1.0 / cos_2;
        match self.depth {
            FlakeDepth::At { depth_um } => (-self.alpha_per_um * depth_um * per_depth).exp(),
            FlakeDepth::UniformInFilm { film_um } => {
                let x = self.alpha_per_um * film_um * per_depth;
                if x > 0.0 { -(-x).exp_m1() / x } else { 1.0 }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals() {
        let at = |d| FlakeDepth::At { depth_um: d };
        assert!(PathAbsorption::new(-0.1, at(1.0)).is_err());
        assert!(PathAbsorption::new(f64::NAN, at(1.0)).is_err());
        assert!(PathAbsorption::new(0.1, at(-1.0)).is_err());
        assert!(PathAbsorption::new(0.1, FlakeDepth::UniformInFilm { film_um: 0.0 }).is_err());
        assert!(PathAbsorption::new(0.0, at(0.0)).is_ok());
    }

    #[test]
    fn no_absorption_is_exactly_one() {
        for depth in [
            FlakeDepth::At { depth_um: 7.0 },
            FlakeDepth::UniformInFilm { film_um: 20.0 },
        ] {
            let a = PathAbsorption::new(0.0, depth).unwrap();
            assert_eq!(a.factor(0.8, 0.3), 1.0);
        }
    }
}
