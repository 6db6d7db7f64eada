//! Stokes vectors of a beam and the ideal analysers in front of a detector
//! (physics.md §11; the basis is that of [`crate::mueller`]).
//!
//! A Stokes vector is checked and **normalised to unit power on construction**: the
//! four numbers are first divided by the largest of their magnitudes (exactly, in
//! floating point, whatever their size), so that a subnormal `(1e-310, 1e-310, 0, 0)`
//! and a huge `(1e200, 1e200, 0, 0)` are the s-polarised beam `(1, 1, 0, 0)` like
//! `(1, 1, 0, 0)` itself; nothing is squared before that scaling, so nothing overflows
//! or underflows to a wrong zero. What is refused is only what cannot be a beam:
//! a non-finite number, `S0 ≤ 0`, or a degree of polarisation
//! `sqrt(S1² + S2² + S3²)/S0` above 1 by more than [`STOKES_TOL`].
//!
//! **Rounding tolerance.** A degree of polarisation within [`STOKES_TOL`] = 1e-9 of 1
//! counts as exactly 1 (a beam's polarised part is then scaled to DoP 1, an analyser
//! accepted as fully polarised): Stokes parameters typed to 10 significant digits,
//! e.g. `1,0.7071067812,0.7071067812,0` (DoP 1 + 1.9e-11), describe a fully polarised
//! state. Beyond it a vector is refused with its degree of polarisation shown to the
//! digits that differ from 1 (`1.0000000100`, i.e. `1 + 1.0e-8`), never rounded to a
//! self-contradicting `1.000000 > 1`.

use crate::OpticsError;

/// Tolerance on the degree of polarisation: within this of 1 it is 1 (module docs).
pub const STOKES_TOL: f64 = 1e-9;

/// A Stokes vector `(S0, S1, S2, S3)` of a physical beam, normalised to `S0 = 1`
/// (module docs): finite, `S1² + S2² + S3² ≤ 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stokes([f64; 4]);

impl Default for Stokes {
    /// Unpolarised light.
    fn default() -> Self {
        Self::UNPOLARIZED
    }
}

impl Stokes {
    /// Unpolarised light, `(1, 0, 0, 0)`.
    pub const UNPOLARIZED: Self = Self([1.0, 0.0, 0.0, 0.0]);
    /// s-polarised light, `(1, 1, 0, 0)`.
    pub const S: Self = Self([1.0, 1.0, 0.0, 0.0]);
    /// p-polarised light, `(1, −1, 0, 0)`.
    pub const P: Self = Self([1.0, -1.0, 0.0, 0.0]);

    /// The beam with the Stokes parameters `s`, normalised to unit power (module docs).
    ///
    /// # Errors
    /// [`OpticsError::InvalidStokes`] unless all four are finite and `S0 > 0`;
    /// [`OpticsError::OverPolarizedStokes`] when the degree of polarisation exceeds 1 by
    /// more than [`STOKES_TOL`].
    pub fn new(s: [f64; 4]) -> Result<Self, OpticsError> {
        if !s.iter().all(|v| v.is_finite()) {
            return Err(OpticsError::InvalidStokes {
                s,
                expected: "four finite numbers",
            });
        }
        if !(s[0] > 0.0) {
            return Err(OpticsError::InvalidStokes {
                s,
                expected: "S0 (the power) > 0",
            });
        }
        // Scale by the largest magnitude (> 0, as S0 > 0): every |t| ≤ 1, exact for
        // subnormals and for numbers near the largest double alike.
        let m = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let t = s.map(|v| v / m);
        let dop = t[1].hypot(t[2]).hypot(t[3]) / t[0];
        if !(dop <= 1.0 + STOKES_TOL) {
            return Err(OpticsError::OverPolarizedStokes { s, dop });
        }
        // Within the tolerance of 1: exactly (to rounding) fully polarised.
        let k = if dop > 1.0 {
            1.0 / (t[0] * dop)
        } else {
            1.0 / t[0]
        };
        Ok(Self([1.0, t[1] * k, t[2] * k, t[3] * k]))
    }

    /// The four parameters, normalised: `S0 = 1`.
    #[must_use]
    pub fn parameters(&self) -> [f64; 4] {
        self.0
    }

    /// The same state with unit power, `S / S0` (every [`Stokes`] already is).
    #[must_use]
    pub fn normalized(&self) -> Self {
        *self
    }

    /// Degree of polarisation `sqrt(S1² + S2² + S3²)/S0`, in `[0, 1]`.
    #[must_use]
    pub fn dop(&self) -> f64 {
        let s = &self.0;
        s[1].hypot(s[2]).hypot(s[3]).min(1.0)
    }
}

/// What stands in front of the detector.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Analyzer {
    /// Nothing: every polarisation is detected (reads `S0`).
    #[default]
    None,
    /// An ideal polariser that passes the fully polarised state given by its Stokes
    /// vector (in the basis of the detector's direction) and blocks the orthogonal one.
    Polarizer(Stokes),
}

impl Analyzer {
    /// An ideal polariser passing `state`, which must be fully polarised.
    ///
    /// # Errors
    /// [`OpticsError::NotFullyPolarized`] when the degree of polarisation of `state`
    /// is below 1 by more than [`STOKES_TOL`]: an ideal polariser passes one pure state.
    pub fn polarizer(state: Stokes) -> Result<Self, OpticsError> {
        let dop = state.dop();
        if 1.0 - dop > STOKES_TOL {
            return Err(OpticsError::NotFullyPolarized { s: state.0, dop });
        }
        Ok(Self::Polarizer(state))
    }

    /// The row `a` with which a detector behind this analyser reads a Stokes vector
    /// `S`, `a · S`: `(1, 0, 0, 0)` without an analyser, `½(1, ŝ)` for a polariser
    /// passing the unit direction `ŝ = (S1, S2, S3)/|(S1, S2, S3)|` (the first row of
    /// its Mueller matrix).
    #[must_use]
    pub fn row(&self) -> [f64; 4] {
        match self {
            Self::None => [1.0, 0.0, 0.0, 0.0],
            Self::Polarizer(s) => {
                let p = s.0;
                let norm = p[1].hypot(p[2]).hypot(p[3]);
                let k = 0.5 / norm;
                [0.5, p[1] * k, p[2] * k, p[3] * k]
            }
        }
    }
}

/// A degree of polarisation for messages, with the digits that tell it from 1: `2`,
/// `0.5`, `1.0000000100 (1 + 1.0e-8)`, `0.99999999 (1 - 1.0e-8)`.
#[must_use]
pub fn dop_text(dop: f64) -> String {
    if !dop.is_finite() {
        return "infinite (S0 is negligible beside S1, S2, S3)".into();
    }
    let d = dop - 1.0;
    if d == 0.0 {
        return "1".into();
    }
    if d.abs() >= 1e-3 {
        return format!("{dop:.6}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_owned();
    }
    // Two significant digits of the difference from 1.
    let places = (-d.abs().log10()).ceil() as usize + 1;
    let sign = if d > 0.0 { '+' } else { '-' };
    format!("{dop:.p$} (1 {sign} {:.1e})", d.abs(), p = places.min(17))
}
