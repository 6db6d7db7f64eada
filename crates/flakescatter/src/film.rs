//! Thin-film flakes on their own (`flakescatter film`): the amplitude and power
//! reflection and transmission of a layer stack over angles and wavelengths
//! (physics.md §13).
//!
//! Conventions: angles in the ambient (the binder around the flake), **radians**;
//! wavelengths in vacuum, **nm**; layers from the incidence side. Without a substrate
//! the flake is free: the ambient on both sides. With one (an opaque core such as
//! aluminium), the exit medium is the substrate and `T` is the power it absorbs.
//!
//! # Example
//! ```
//! use flakescatter::film::{FilmSetup, film_table};
//! use flakescatter::optics::catalogue::Catalogue;
//!
//! let setup = FilmSetup::parse("TiO2:120/mica:400/TiO2:120", 1.5, None, &Catalogue::builtin()).unwrap();
//! let rows = film_table(&setup, &[0.0, 0.5], &[450.0, 550.0, 650.0]).unwrap();
//! assert_eq!(rows.len(), 6);
//! // A free lossless flake: R + T = 1.
//! for r in &rows {
//!     assert!((r.response.r_s() + r.response.t_s() - 1.0).abs() < 1e-12);
//! }
//! ```

use flakescatter_optics::catalogue::{Catalogue, CatalogueError, MaterialSpec};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::stack_spec::{StackSpec, StackSpecError};
use flakescatter_optics::thinfilm::{FilmStack, Response, ThinFilmError};

/// Errors of a thin-film table. The messages name the inputs as [`FilmSetup::parse`]
/// does (`stack`, `substrate`, `ambient`); a caller with other names for them (the
/// command line's flags) matches on the variant.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilmError {
    /// The stack spec, or a layer's table at a wavelength.
    #[error("stack: {0}")]
    Stack(#[from] StackSpecError),
    /// The substrate.
    #[error("substrate: {0}")]
    Substrate(CatalogueError),
    /// The ambient index.
    #[error("ambient {0}: expected a finite real index >= 1")]
    Ambient(f64),
    /// An angle outside `[0, π/2]`.
    #[error("angle {0} rad is out of range: expected 0 to pi/2 (0 to 90 degrees) in the ambient")]
    Angle(f64),
    /// A wavelength that is not finite and positive.
    #[error("wavelength {0} nm is not valid: expected a finite number > 0")]
    Wavelength(f64),
    /// The solver refused its inputs (not expected after the checks above).
    #[error("{0}")]
    Solve(#[from] ThinFilmError),
}

/// A stack between an ambient and an optional substrate.
#[derive(Debug, Clone, PartialEq)]
pub struct FilmSetup {
    /// The layers.
    pub stack: StackSpec,
    /// The ambient's real index (the binder), ≥ 1.
    pub ambient: f64,
    /// An opaque core under the stack; `None` for a free flake (ambient on both sides).
    pub substrate: Option<MaterialSpec>,
}

impl FilmSetup {
    /// Parse a stack spec and a substrate name against `catalogue` and check the ambient.
    ///
    /// # Errors
    /// [`FilmError`] naming the bad part.
    pub fn parse(
        stack: &str,
        ambient: f64,
        substrate: Option<&str>,
        catalogue: &Catalogue,
    ) -> Result<Self, FilmError> {
        if !(ambient.is_finite() && ambient >= 1.0) {
            return Err(FilmError::Ambient(ambient));
        }
        let stack = StackSpec::parse(stack, catalogue)?;
        let substrate = substrate
            .map(|s| catalogue.parse(s))
            .transpose()
            .map_err(FilmError::Substrate)?;
        Ok(Self {
            stack,
            ambient,
            substrate,
        })
    }

    /// The wavelengths where every layer (and the substrate) has an index, nm.
    #[must_use]
    pub fn range_nm(&self) -> (f64, f64) {
        let (lo, hi) = self.stack.range_nm();
        match &self.substrate {
            None => (lo, hi),
            Some(s) => {
                let (a, b) = s.range_nm();
                (lo.max(a), hi.min(b))
            }
        }
    }

    /// The response at one angle (radians, in the ambient) and wavelength (nm).
    ///
    /// # Errors
    /// [`FilmError`] for a wavelength outside a table, or a bad angle or wavelength.
    pub fn response(&self, theta: f64, wavelength_nm: f64) -> Result<Response, FilmError> {
        check_angle(theta)?;
        check_wavelength(wavelength_nm)?;
        let (stack, exit) = self.at(wavelength_nm)?;
        solve(self.ambient, &stack, exit, theta, wavelength_nm)
    }

    /// The layers and the exit medium's index at `wavelength_nm`: a table that does not
    /// cover it is refused first, then a wavelength that is not finite and positive.
    fn at(&self, wavelength_nm: f64) -> Result<(FilmStack, Complex<f64>), FilmError> {
        let stack = self.stack.at(wavelength_nm)?;
        let exit = match &self.substrate {
            None => Complex::new(self.ambient, 0.0),
            Some(s) => s.index_at(wavelength_nm).map_err(FilmError::Substrate)?,
        };
        check_wavelength(wavelength_nm)?;
        Ok((stack, exit))
    }
}

/// `Ok` for a finite wavelength > 0 nm.
fn check_wavelength(wavelength_nm: f64) -> Result<(), FilmError> {
    if wavelength_nm.is_finite() && wavelength_nm > 0.0 {
        Ok(())
    } else {
        Err(FilmError::Wavelength(wavelength_nm))
    }
}

/// `Ok` for an angle in `[0, π/2]`.
fn check_angle(theta: f64) -> Result<(), FilmError> {
    if (0.0..=std::f64::consts::FRAC_PI_2).contains(&theta) {
        Ok(())
    } else {
        Err(FilmError::Angle(theta))
    }
}

/// The stack's response at a checked angle `theta` (radians, in the ambient).
fn solve(
    ambient: f64,
    stack: &FilmStack,
    exit: Complex<f64>,
    theta: f64,
    wavelength_nm: f64,
) -> Result<Response, FilmError> {
    // cos(π/2) is 6e-17, not 0: grazing incidence is exactly 0.
    let cos = if theta == std::f64::consts::FRAC_PI_2 {
        0.0
    } else {
        theta.cos()
    };
    Ok(stack.response(ambient, exit, cos, wavelength_nm)?)
}

/// Why [`stack_flake`] could not build a flake: which of its three inputs is at fault,
/// so that each caller names its own flag or keyword.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StackFlakeError {
    /// The wavelength is not finite and positive.
    #[error("wavelength {0} nm is not valid: expected a finite number > 0")]
    Wavelength(f64),
    /// The stack spec does not parse.
    #[error("{0}")]
    Spec(StackSpecError),
    /// A layer's table does not cover the wavelength.
    #[error("{0}")]
    AtWavelength(StackSpecError),
    /// The core is not a known material or has no index at the wavelength.
    #[error("{0}")]
    Core(CatalogueError),
}

/// An interference flake at one wavelength from text: the stack spec (against the
/// built-in catalogue) and an optional opaque core, as `--flake-stack` and
/// `--flake-core` give them. Checked in this order: the wavelength, the spec, the
/// layers' tables at the wavelength, the core.
///
/// # Errors
/// [`StackFlakeError`] saying which input is at fault.
pub fn stack_flake(
    stack: &str,
    core: Option<&str>,
    wavelength_nm: f64,
) -> Result<FlakeReflectance, StackFlakeError> {
    if !(wavelength_nm.is_finite() && wavelength_nm > 0.0) {
        return Err(StackFlakeError::Wavelength(wavelength_nm));
    }
    let catalogue = Catalogue::builtin();
    let spec = StackSpec::parse(stack, &catalogue).map_err(StackFlakeError::Spec)?;
    let layers = spec
        .at(wavelength_nm)
        .map_err(StackFlakeError::AtWavelength)?;
    let core = core
        .map(|c| catalogue.parse(c).and_then(|m| m.index_at(wavelength_nm)))
        .transpose()
        .map_err(StackFlakeError::Core)?;
    // The wavelength was checked above and the catalogue gives only valid indices, so
    // the constructor's own checks cannot fail here.
    FlakeReflectance::stack(layers, wavelength_nm, core)
        .map_err(|_| StackFlakeError::Wavelength(wavelength_nm))
}

/// One row of a film table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilmRow {
    /// Vacuum wavelength, nm.
    pub wavelength_nm: f64,
    /// Incidence angle in the ambient, radians.
    pub theta: f64,
    /// Amplitudes and powers.
    pub response: Response,
}

/// The response at every wavelength (outer loop) and angle (inner loop).
///
/// # Errors
/// [`FilmError`] for the first wavelength or angle that cannot be evaluated (checked
/// before any row is computed).
pub fn film_table(
    setup: &FilmSetup,
    thetas: &[f64],
    wavelengths_nm: &[f64],
) -> Result<Vec<FilmRow>, FilmError> {
    for &t in thetas {
        check_angle(t)?;
    }
    // Every wavelength's layers and exit medium first, so that a wavelength outside a
    // table is refused before any row is computed; then each is solved at every angle.
    let media = wavelengths_nm
        .iter()
        .map(|&w| setup.at(w))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::with_capacity(thetas.len() * wavelengths_nm.len());
    for (&w, (stack, exit)) in wavelengths_nm.iter().zip(&media) {
        for &t in thetas {
            rows.push(FilmRow {
                wavelength_nm: w,
                theta: t,
                response: solve(setup.ambient, stack, *exit, t, w)?,
            });
        }
    }
    Ok(rows)
}
