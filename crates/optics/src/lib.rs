//! Optics primitives for flake-pigment coatings (NIST ray model, Sung et al. 2002).
//!
//! A metallic coating is modelled as a flat clear coat of real index `n ≥ 1` over
//! mirror-like aluminium flakes. A ray refracts into the coating, reflects specularly
//! from a flake and refracts back out. This crate holds the pieces every model needs:
//!
//! * [`refraction`]: Snell's law at the flat coating surface, both ways;
//! * [`fresnel`]: exact Fresnel amplitudes and power coefficients, the paper's `T_av`
//!   (eq. 10);
//! * [`reflection`]: mirror reflection by a flake, the internal half vector (eq. 1),
//!   the obliquity `γ` (eq. 2, corrected) and the solid-angle Jacobians;
//! * [`detector`]: incidence, specular and detector directions, detector cones;
//! * [`flake`]: flake reflectance (perfect conductor or complex index);
//! * [`material`]: optical constants of flake metals versus wavelength (built-in
//!   aluminium tables, user tables);
//! * [`stack_spec`]: thin-film stacks written as text, `TiO2:120/mica:400/TiO2:120`;
//! * [`catalogue`]: named layer materials (TiO2, Fe2O3, SiO2, Al2O3, mica, Al, Cr, Ag;
//!   sources in `data/README.md`), constants `n+ki` and user tables;
//! * [`dispersion`]: the clear coat's real index versus wavelength (constant, Cauchy,
//!   table) and tables of real quantities versus wavelength;
//! * [`absorption`]: the binder's absorption along a ray's path inside the film;
//! * [`polarization`]: how Fresnel factors combine (`exact-unpolarized`, `paper`, `s`,
//!   `p`), the `physical` vs `paper-printed` weighting, and the clear coat's own
//!   specular reflectance (physics.md §6);
//! * [`jones`]: the Jones matrix of a ray's whole path (entry, flake, exit, with the
//!   frame rotations between the planes of incidence) in SCATMECH's `(s, p)` bases, and
//!   of the clear coat's specular reflection (physics.md §11);
//! * [`pile`]: Stokes' pile of plates, identical flakes stacked incoherently;
//! * [`thinfilm`]: thin-film stacks (interference flakes): amplitude and power
//!   reflection and transmission for s and p by Rouard's recursion (physics.md §13);
//! * [`mueller`]: Mueller matrices and the non-depolarisation and realisability
//!   checks; [`stokes`]: Stokes vectors (normalised on construction) and analysers.
//!
//! # Conventions (physics.md §1)
//! * Right-handed frame, `z` = macroscopic coating normal pointing into the air, `x` in
//!   the plane of incidence. Angles are **radians** everywhere in this crate.
//! * Vectors are unit **propagation** directions: incident `k_in` (`z < 0`), refracted
//!   `k1` (`z < 0`), reflected by a flake `k2` (`z > 0`), leaving `k_out` (`z > 0`).
//! * The source is on the `-x` side: `k_in = (sin θi, 0, -cos θi)`; the specular
//!   direction is `(sin θi, 0, cos θi)`.
//! * Signed in-plane scattering angle `θs`: `θs = -θi` is specular, `θs > 0` is on the
//!   source side; the detector axis is `r(θs) = (-sin θs, 0, cos θs)`.
//!
//! # Example
//! Follow one ray through the coating and check that a flat flake sends it to the
//! specular direction, with the power Fresnel lets through:
//! ```
//! use flakescatter_optics::{detector, fresnel, reflection, refraction, Vec3, UnitVec3};
//!
//! let n = 1.5;
//! let theta_i = 30f64.to_radians();
//! let k_in = detector::incident_direction(theta_i);
//! let k1 = refraction::into_coating(&k_in, n);
//! let flat = UnitVec3::new_normalize(Vec3::z());
//! let k2 = reflection::reflect(&k1, &flat);
//! let k_out = refraction::out_of_coating(&k2, n).expect("no total internal reflection");
//! assert!((k_out.into_inner() - detector::specular_direction(theta_i).into_inner()).norm() < 1e-12);
//!
//! // Normal-incidence transmittance 4n/(n+1)^2 = 0.96 for n = 1.5.
//! let t0 = fresnel::air_to_coating(0.0, n).t_av();
//! assert!((t0 - 0.96).abs() < 1e-12);
//! ```

pub mod absorption;
pub mod band;
pub mod catalogue;
pub mod detector;
pub mod dispersion;
pub mod flake;
pub mod fresnel;
pub mod jones;
pub mod material;
pub mod mueller;
pub mod pile;
pub mod polarization;
pub mod reflection;
pub mod refraction;
pub mod stack_spec;
pub mod stokes;
pub mod thinfilm;

pub use nalgebra;

pub use flakescatter_numerics::{UnitVec3, Vec3};

/// Errors from validating optical parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OpticsError {
    /// The clear-coat index must be real, finite and at least 1.
    #[error("refractive index {0} is not valid: expected a finite real number >= 1")]
    InvalidIndex(f64),
    /// A complex flake index must have finite parts, a positive real part and a
    /// non-negative imaginary part.
    #[error("complex flake index {n} + {k}i is not valid: expected finite n > 0 and k >= 0")]
    InvalidComplexIndex {
        /// Real part.
        n: f64,
        /// Imaginary part (extinction coefficient).
        k: f64,
    },
    /// A Stokes vector that no beam (or no ideal analyser) has.
    #[error("Stokes vector ({}, {}, {}, {}) is not valid: expected {expected}", .s[0], .s[1], .s[2], .s[3])]
    InvalidStokes {
        /// The parameters given, `(S0, S1, S2, S3)`.
        s: [f64; 4],
        /// What a valid one looks like, in words.
        expected: &'static str,
    },
    /// A Stokes vector whose degree of polarisation is above 1 beyond the rounding
    /// tolerance [`mueller::STOKES_TOL`].
    #[error(
        "Stokes vector ({}, {}, {}, {}) is not the Stokes vector of a beam: its degree of polarisation sqrt(S1^2 + S2^2 + S3^2)/S0 is {}, above 1 (within {:e} of 1 counts as 1)",
        .s[0], .s[1], .s[2], .s[3], stokes::dop_text(*.dop), mueller::STOKES_TOL
    )]
    OverPolarizedStokes {
        /// The parameters given, `(S0, S1, S2, S3)`.
        s: [f64; 4],
        /// Their degree of polarisation (> 1 + the tolerance; may be infinite).
        dop: f64,
    },
    /// An analyser state that is not fully polarised.
    #[error(
        "Stokes vector ({}, {}, {}, {}) cannot be an ideal polariser: it passes one fully polarised state, so S1^2 + S2^2 + S3^2 must equal S0^2, and this one has degree of polarisation {} (within {:e} of 1 counts as 1)",
        .s[0], .s[1], .s[2], .s[3], stokes::dop_text(*.dop), mueller::STOKES_TOL
    )]
    NotFullyPolarized {
        /// The state, normalised to `S0 = 1`.
        s: [f64; 4],
        /// Its degree of polarisation (< 1 − the tolerance).
        dop: f64,
    },
    /// A pile of flakes that cannot be made (the message says why).
    #[error("{0}")]
    InvalidPile(String),
    /// A band of wavelengths that cannot be made (the message says why).
    #[error("channel band: {0}")]
    InvalidBand(String),
    /// A wavelength that is not finite and positive.
    #[error("wavelength {0} nm is not valid: expected a finite number > 0")]
    InvalidWavelength(f64),
    /// An angle outside the range where it has a meaning.
    #[error("{name} = {value} rad is out of range: expected {expected}")]
    AngleOutOfRange {
        /// Which angle.
        name: &'static str,
        /// The value given, radians.
        value: f64,
        /// The accepted range in words.
        expected: &'static str,
    },
}

/// Check that `n` is a valid clear-coat index (finite, `n ≥ 1`).
///
/// # Errors
/// [`OpticsError::InvalidIndex`] otherwise.
pub fn check_index(n: f64) -> Result<f64, OpticsError> {
    if n.is_finite() && n >= 1.0 {
        Ok(n)
    } else {
        Err(OpticsError::InvalidIndex(n))
    }
}
