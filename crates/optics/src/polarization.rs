//! How Fresnel factors combine along a ray, and how rays are weighted
//! (physics.md §4, §5, §6, §11).
//!
//! A ray crosses the coating surface twice (entry at `θi`, exit at `θo`) and reflects
//! once from a flake. `exact-unpolarized`, `s` and `p` are exact in every direction:
//! the models take them from the first row `(m00, m01)` of the ray's Mueller matrix
//! ([`crate::jones`], [`Transmission::from_first_row`]), because out of the plane of
//! incidence the tilted flake rotates the polarisation frame and s and p mix. In the
//! plane of incidence they do not mix for a conducting flake, and the same factors are
//! the products of powers of [`Transmission::path_factor`]:
//! `½[Ts,i Rs Ts,o + Tp,i Rp Tp,o]`, `Ts,i Rs Ts,o`, `Tp,i Rp Tp,o`. The paper instead
//! applies eq. 10 at each crossing, `T_av,i · T_av,o · R_av` (`paper`, a product of
//! averages in every direction), which in the plane is lower than `exact-unpolarized`
//! by `(Ts,i − Tp,i)(Ts,o − Tp,o)/4` for a perfect conductor (up to 2.9 % at θi = 75°,
//! n = 1.5).

use std::fmt;
use std::str::FromStr;

use crate::fresnel::FresnelPower;

/// Which polarisation bookkeeping to use for the Fresnel factors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Transmission {
    /// Unpolarised beam, exact: `m00` of the ray's Mueller matrix; in the plane of
    /// incidence `½[Ts Rs Ts' + Tp Rp Tp']` (default).
    #[default]
    ExactUnpolarized,
    /// The paper: eq. 10 average at each crossing, `T_av T_av' R_av`.
    Paper,
    /// s-polarised beam, every polarisation detected: `m00 + m01`; in the plane
    /// `Ts Rs Ts'`.
    S,
    /// p-polarised beam, every polarisation detected: `m00 − m01`; in the plane
    /// `Tp Rp Tp'`.
    P,
}

impl Transmission {
    /// All variants, in documentation order.
    pub const ALL: [Self; 4] = [Self::ExactUnpolarized, Self::Paper, Self::S, Self::P];

    /// The command-line name (`exact-unpolarized`, `paper`, `s`, `p`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::ExactUnpolarized => "exact-unpolarized",
            Self::Paper => "paper",
            Self::S => "s",
            Self::P => "p",
        }
    }

    /// Fraction of the beam that survives entry, flake reflection `(Rs, Rp)` and exit,
    /// as a product of powers: exact in the plane of incidence, and the definition of
    /// `paper` everywhere. Out of the plane the models use
    /// [`Transmission::from_first_row`] for the other three.
    #[must_use]
    pub fn path_factor(self, entry: &FresnelPower, flake: (f64, f64), exit: &FresnelPower) -> f64 {
        let (rs, rp) = flake;
        match self {
            Self::ExactUnpolarized => 0.5 * (entry.ts * rs * exit.ts + entry.tp * rp * exit.tp),
            Self::Paper => entry.t_av() * 0.5 * (rs + rp) * exit.t_av(),
            Self::S => entry.ts * rs * exit.ts,
            Self::P => entry.tp * rp * exit.tp,
        }
    }

    /// The exact path factor from the first row `(m00, m01)` of the ray's Mueller
    /// matrix ([`crate::jones::Transfer::first_row`]): `m00` for an unpolarised beam,
    /// `m00 + m01` for s, `m00 − m01` for p (every polarisation detected); `None` for
    /// `paper`, which is its own approximation ([`Transmission::path_factor`]).
    #[must_use]
    #[inline]
    pub fn from_first_row(self, first_row: (f64, f64)) -> Option<f64> {
        let (m00, m01) = first_row;
        match self {
            Self::ExactUnpolarized => Some(m00),
            Self::S => Some(m00 + m01),
            Self::P => Some(m00 - m01),
            Self::Paper => None,
        }
    }

    /// Fraction of the beam that enters the coating (`T_in`).
    #[must_use]
    pub fn entry_factor(self, entry: &FresnelPower) -> f64 {
        match self {
            Self::ExactUnpolarized | Self::Paper => entry.t_av(),
            Self::S => entry.ts,
            Self::P => entry.tp,
        }
    }

    /// Fraction of the beam the clear coat's top surface reflects specularly
    /// (physics.md §6): `R_av = (Rs + Rp)/2` unpolarised, `Rs` or `Rp` polarised.
    #[must_use]
    pub fn clearcoat_reflectance(self, entry: &FresnelPower) -> f64 {
        match self {
            Self::ExactUnpolarized | Self::Paper => entry.r_av(),
            Self::S => entry.rs,
            Self::P => entry.rp,
        }
    }
}

impl fmt::Display for Transmission {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error for an unknown option name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} `{given}`: expected one of {expected}")]
pub struct UnknownOption {
    /// Which option.
    pub what: &'static str,
    /// What was given.
    pub given: String,
    /// The accepted names.
    pub expected: &'static str,
}

impl FromStr for Transmission {
    type Err = UnknownOption;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| UnknownOption {
                what: "transmission",
                given: s.to_owned(),
                expected: "exact-unpolarized, paper, s, p",
            })
    }
}

/// How rays are weighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Weighting {
    /// Physically consistent weights: the collected power is a fraction of the incident
    /// beam and energy is conserved (default).
    #[default]
    Physical,
    /// The printed eqs. 9/13/14 with the extra cosine ratio `cos θ2 / cos θo`
    /// (distribution model) or `(cos ϑ'/cos ϑ) T_av γ` (topographic model). It
    /// double-counts the beam cross-section change and breaks energy conservation; offered
    /// only to reproduce the shapes of the paper's figures.
    PaperPrinted,
}

impl Weighting {
    /// The command-line name (`physical`, `paper-printed`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Physical => "physical",
            Self::PaperPrinted => "paper-printed",
        }
    }
}

impl fmt::Display for Weighting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Weighting {
    type Err = UnknownOption;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "physical" => Ok(Self::Physical),
            "paper-printed" => Ok(Self::PaperPrinted),
            _ => Err(UnknownOption {
                what: "weighting",
                given: s.to_owned(),
                expected: "physical, paper-printed",
            }),
        }
    }
}
