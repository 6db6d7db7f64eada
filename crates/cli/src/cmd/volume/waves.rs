//! `volume`'s wavelengths and tinted binder: which wavelengths a run has (none, one with
//! `--wavelength`, several with `--wavelengths` or a stack's default), and the binder's
//! absorption coefficient (`--binder-absorption`, a constant or a table) at them. Every
//! refusal names its flag.

use anyhow::{Context, bail};
use flakescatter::optics::dispersion::SpectralTable;
use serde_json::{Value, json};

use super::Args;
use crate::flags::{DEFAULT_WAVELENGTHS, binder_table, constant_alpha, parse_wavelengths};

/// The wavelengths of a run.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Waves {
    /// Nothing depends on wavelength (no stack, no absorption table).
    None,
    /// `--wavelength NM`: one wavelength, the outputs as without it.
    One(f64),
    /// Several: `--wavelengths`, or a stack's default; nm and the text they came from.
    Many { nm: Vec<f64>, text: String },
}

impl Waves {
    /// The one wavelength, if the run has exactly one from `--wavelength`.
    pub(super) fn one(&self) -> Option<f64> {
        match self {
            Self::One(w) => Some(*w),
            _ => None,
        }
    }
}

/// `--binder-absorption` read: the coefficient versus wavelength and its JSON echo.
#[derive(Debug, Clone)]
pub(super) struct Binder {
    /// µm⁻¹ versus nm (a constant table for a number).
    pub(super) table: SpectralTable,
    /// `{"constant_per_um": …}` or `{"file": …}`, with the units.
    pub(super) echo: Value,
    /// Whether the flag is a number (the same coefficient at every wavelength).
    pub(super) constant: bool,
}

impl Args {
    /// `--binder-absorption`, read and checked (a negative or non-finite constant, a
    /// file that is missing or not a table of coefficients >= 0 is refused).
    pub(super) fn binder(&self) -> anyhow::Result<Option<Binder>> {
        let Some(path) = &self.binder_absorption else {
            return Ok(None);
        };
        let (table, mut echo) = binder_table(path)?;
        echo["alpha"] = json!("Napierian, 1/um, along every path inside the film");
        Ok(Some(Binder {
            table,
            echo,
            constant: constant_alpha(path).is_some(),
        }))
    }

    /// The run's wavelengths (module docs). Refuses a wavelength flag with nothing that
    /// depends on wavelength, a bad wavelength or list, and an absorption table with no
    /// wavelength to read it at.
    pub(super) fn waves(&self, binder: Option<&Binder>) -> anyhow::Result<Waves> {
        let flag = match (self.wavelength, &self.wavelengths) {
            (Some(_), _) => Some("--wavelength"),
            (None, Some(_)) => Some("--wavelengths"),
            (None, None) => None,
        };
        if let Some(flag) = flag
            && self.flake_stack.is_none()
            && binder.is_none()
        {
            bail!(
                "{flag} applies to --flake-stack or --binder-absorption, the inputs of the volume model that depend on wavelength; give one of them or leave {flag} out"
            );
        }
        if let Some(text) = &self.wavelengths {
            return Ok(Waves::Many {
                nm: parse_wavelengths(text)?,
                text: text.clone(),
            });
        }
        if let Some(w) = self.wavelength {
            if !(w.is_finite() && w > 0.0) {
                bail!("--wavelength {w}: expected a finite wavelength > 0 nm");
            }
            return Ok(Waves::One(w));
        }
        if self.flake_stack.is_some() {
            // A stack has no single-wavelength meaning: its runs are spectral by default.
            return Ok(Waves::Many {
                nm: parse_wavelengths(DEFAULT_WAVELENGTHS)?,
                text: DEFAULT_WAVELENGTHS.to_owned(),
            });
        }
        if let Some(b) = binder
            && !b.constant
        {
            bail!(
                "--binder-absorption {}: a table of the absorption versus wavelength needs the run's wavelength: give --wavelength NM or --wavelengths LIST",
                self.binder_path()
            );
        }
        Ok(Waves::None)
    }

    /// The binder's coefficient at wavelength `w` (nm; `None` only for a constant, which
    /// is the same at every wavelength), µm⁻¹.
    pub(super) fn alpha_at(&self, b: &Binder, w: Option<f64>) -> anyhow::Result<f64> {
        let at = w.unwrap_or(550.0);
        b.table
            .value_at(at)
            .with_context(|| format!("--binder-absorption {} at {at} nm", self.binder_path()))
    }

    /// `--binder-absorption` as typed.
    pub(super) fn binder_path(&self) -> String {
        self.binder_absorption
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    }
}
