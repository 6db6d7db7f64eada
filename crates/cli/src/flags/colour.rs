//! Colorimetry and multi-angle flags (docs/cli.md "Spectral flags"): the illuminant and
//! observer of a colour computation, and the multi-angle geometry set (a built-in set or
//! `--theta-i` with `--aspecular`).
//!
//! Angles in degrees here; the library gets radians.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::colour::{GeometrySet, Illuminant, Observer};
use serde_json::{Value, json};

use crate::parse::{angles, check_range};

/// The illuminant of `--illuminant`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum IlluminantArg {
    /// CIE D65 (daylight, 6504 K).
    D65,
    /// CIE D50 (horizon daylight, graphic arts).
    D50,
    /// CIE illuminant A (incandescent, 2856 K).
    A,
}

/// The observer of `--observer`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ObserverArg {
    /// CIE 1931 2° standard observer.
    #[value(name = "2")]
    Two,
    /// CIE 1964 10° standard observer.
    #[value(name = "10")]
    Ten,
}

/// Colorimetry flags.
#[derive(Debug, Clone, clap::Args)]
pub struct ColourArgs {
    /// Illuminant of the colorimetry: D65, D50 or A [default: D65].
    #[arg(long, value_enum, value_name = "NAME", ignore_case = true)]
    pub illuminant: Option<IlluminantArg>,
    /// Standard observer: 2 (CIE 1931) or 10 (CIE 1964) [default: 10].
    #[arg(long, value_enum, value_name = "DEG")]
    pub observer: Option<ObserverArg>,
}

impl ColourArgs {
    /// Whether either flag is given.
    pub fn any(&self) -> bool {
        self.illuminant.is_some() || self.observer.is_some()
    }

    /// The illuminant (D65 by default).
    pub fn illuminant(&self) -> Illuminant {
        match self.illuminant.unwrap_or(IlluminantArg::D65) {
            IlluminantArg::D65 => Illuminant::D65,
            IlluminantArg::D50 => Illuminant::D50,
            IlluminantArg::A => Illuminant::A,
        }
    }

    /// The observer (10° by default).
    pub fn observer(&self) -> Observer {
        match self.observer.unwrap_or(ObserverArg::Ten) {
            ObserverArg::Two => Observer::Cie1931TwoDegree,
            ObserverArg::Ten => Observer::Cie1964TenDegree,
        }
    }

    /// The JSON echo.
    pub fn echo(&self) -> Value {
        json!({
            "illuminant": self.illuminant().label(),
            "observer_deg": match self.observer() { Observer::Cie1931TwoDegree => 2, _ => 10 },
        })
    }
}

/// The built-in geometry sets of `--geometry-set`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum GeometrySetArg {
    /// ASTM E2194: 45° incidence, aspecular −15°, 15°, 25°, 45°, 75°, 110°.
    #[value(name = "astm-e2194")]
    AstmE2194,
}

/// Multi-angle geometry flags of `model` and `topo`.
#[derive(Debug, Clone, clap::Args)]
pub struct GeometryArgs {
    /// Multi-angle geometry set: astm-e2194 (45° incidence; with --theta-i X its six
    /// aspecular angles at incidence X). Instrument sets with a second, 15° incidence are
    /// not built in (docs/cli.md); give them in a measured file or as --aspecular.
    #[arg(long, value_enum, value_name = "NAME", conflicts_with = "aspecular")]
    pub geometry_set: Option<GeometrySetArg>,
    /// Custom aspecular angles, degrees (list or range), at the one incidence --theta-i
    /// gives (default 45); measured from the specular direction, positive toward the
    /// normal.
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub aspecular: Option<String>,
    /// --multi-angle: also write the spectra, CSV `theta_i_deg,aspecular_deg,
    /// wavelength_nm,reflectance_factor[,std_err]` (what `colour --reflectance` reads).
    #[arg(long, value_name = "FILE")]
    pub spectra_out: Option<PathBuf>,
}

impl GeometryArgs {
    /// Whether a geometry flag is given.
    pub fn any(&self) -> bool {
        self.geometry_set.is_some() || self.aspecular.is_some() || self.spectra_out.is_some()
    }

    /// The geometry set for the incidence text `theta_i` (degrees; `None`: 45).
    pub fn set(&self, theta_i: Option<&str>) -> anyhow::Result<GeometrySet> {
        let text = theta_i.unwrap_or("45");
        let ti = angles("--theta-i", text)?;
        check_range("--theta-i", &ti, 0.0, 90.0, false, true)?;
        let [theta_i] = ti.as_slice() else {
            bail!(
                "--theta-i {text}: --multi-angle gives one readout; give one incidence (sets with several incidences come from a measured file)"
            );
        };
        let aspecular = match &self.aspecular {
            Some(t) => angles("--aspecular", t)?,
            None => flakescatter::colour::geometry::ASTM_E2194_ASPECULAR_DEG.to_vec(),
        };
        for a in &aspecular {
            let ts = a - theta_i;
            if !(ts.abs() < 90.0) {
                bail!(
                    "--theta-i {text}: the aspecular angle {a}° puts the detector at theta_s = {ts}°, beyond the horizon{}",
                    if self.aspecular.is_none() {
                        " (the ASTM E2194 angles need 20° < theta_i < 75°)"
                    } else {
                        ""
                    }
                );
            }
        }
        let rad: Vec<f64> = aspecular.iter().map(|a| a.to_radians()).collect();
        let set = if self.aspecular.is_none() && *theta_i == 45.0 {
            GeometrySet::astm_e2194()
        } else {
            GeometrySet::custom(theta_i.to_radians(), &rad).with_context(|| {
                format!("--aspecular {}", self.aspecular.as_deref().unwrap_or(""))
            })?
        };
        Ok(set)
    }
}
