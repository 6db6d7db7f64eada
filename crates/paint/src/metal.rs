//! What the flakes are made of, and their reflectance in each colour channel: a metal
//! (aluminium's tables, a perfect conductor, one complex index) or an interference
//! flake, a thin-film stack on an optional opaque core (physics.md §13).
//!
//! A channel's flake optics are taken at the channel's one wavelength
//! ([`Channel::wavelength_nm`]): 612, 547 and 464 nm for `r`, `g`, `b`. For a metal the
//! per-channel flake scale absorbs what one wavelength cannot say about a broad channel;
//! for a stack it also stands for the band: an interference flake's reflectance at the
//! channel's wavelength is not its average over the channel's band, which varies more
//! slowly with angle (physics.md §12.7 says what this means for the fits), unless the
//! stack is given a band ([`FlakeMetal::with_band`]): then each named channel sees the
//! power-weighted mean over a Gaussian band about its wavelength ([`channel_band`],
//! `flakescatter_optics::band`).
//!
//! The light a stack flake transmits (`T = 1 − R − A`) goes down to the base. The paint
//! model does not follow it separately: the fitted base amplitude `(1 − c)² ρ_k` carries
//! it with the light that passes between the flakes (its angular dependence through the
//! flakes' `T` is neglected; physics.md §12.7), unless the flakes are piled: `N` free
//! stack flakes lying parallel one under the other ([`StackFlakes::layers`], physics.md
//! §12.8) reflect as Stokes' pile of plates ([`flakescatter_optics::pile`]).

use std::sync::Arc;

use flakescatter_optics::catalogue::MaterialSpec;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::material::ComplexIndexTable;
use flakescatter_optics::stack_spec::StackSpec;

use crate::PaintError;
use crate::channel::Channel;

/// An interference flake: its layers from the side light arrives on, in the coat's
/// binder, and an optional opaque core under them (`None`: a free flake, the binder on
/// both sides).
#[derive(Debug, Clone, PartialEq)]
pub struct StackFlakes {
    /// The layers (materials and thicknesses, nm).
    pub stack: StackSpec,
    /// The opaque core, if any.
    pub core: Option<MaterialSpec>,
    /// The flakes piled one under another (`1..=1000`; 1: one flake, as without piles;
    /// more only for a free stack, `core == None`): each flake's reflectance is the
    /// pile's (physics.md §12.8). Set through [`FlakeMetal::with_layers`].
    pub layers: u32,
    /// The full width at half maximum of each colour channel's band, nm: `None` takes
    /// the flakes at the channel's one wavelength; a width averages them over a
    /// Gaussian band about it ([`channel_band`], physics.md §12.7). Set through
    /// [`FlakeMetal::with_band`].
    pub band_fwhm_nm: Option<f64>,
}

/// Spacing of a channel band's wavelengths, nm.
pub const BAND_STEP_NM: f64 = 5.0;
/// The widest channel band, nm (full width at half maximum).
pub const MAX_BAND_FWHM_NM: f64 = 400.0;

/// The wavelengths (nm) and weights of the band of full width at half maximum
/// `fwhm_nm` about `centre_nm`: every [`BAND_STEP_NM`] from the centre out to one full
/// width on each side, kept within 380–780 nm (what a colour channel sees), weighted by
/// the Gaussian `exp(−(λ − λc)²/(2σ²))`, `σ = fwhm/(2 sqrt(2 ln 2))`, normalised to sum
/// to 1.
#[must_use]
pub fn channel_band(centre_nm: f64, fwhm_nm: f64) -> Vec<(f64, f64)> {
    let sigma = fwhm_nm / (2.0 * (2.0 * std::f64::consts::LN_2).sqrt());
    let k = (fwhm_nm / BAND_STEP_NM).floor() as i64;
    let nodes: Vec<(f64, f64)> = (-k..=k)
        .map(|j| centre_nm + j as f64 * BAND_STEP_NM)
        .filter(|wl| (380.0..=780.0).contains(wl))
        .map(|wl| {
            (
                wl,
                (-(wl - centre_nm).powi(2) / (2.0 * sigma * sigma)).exp(),
            )
        })
        .collect();
    let total: f64 = nodes.iter().map(|(_, w)| w).sum();
    nodes.into_iter().map(|(wl, w)| (wl, w / total)).collect()
}

/// What the flakes are made of.
#[derive(Debug, Clone, PartialEq)]
pub enum FlakeMetal {
    /// Aluminium, the built-in optical constants (Rakić 1995) at each channel's
    /// wavelength.
    Aluminium,
    /// A perfect conductor (`|r| = 1`, the paper's flakes).
    PerfectConductor,
    /// One complex index `n + ik` for every channel.
    Index {
        /// Real part.
        n: f64,
        /// Imaginary part (≥ 0).
        k: f64,
    },
    /// Interference flakes, the stack taken at each channel's wavelength.
    Stack(Arc<StackFlakes>),
}

impl FlakeMetal {
    /// Interference flakes of `stack` on `core`.
    #[must_use]
    pub fn stack(stack: StackSpec, core: Option<MaterialSpec>) -> Self {
        Self::Stack(Arc::new(StackFlakes {
            stack,
            core,
            layers: 1,
            band_fwhm_nm: None,
        }))
    }

    /// The same flakes seen through colour channels of band width `fwhm_nm` (nm, full
    /// width at half maximum; `None`: one wavelength per channel). Only the named
    /// channels `r`, `g`, `b`, `y` have a band; a channel named by its wavelength stays
    /// monochromatic.
    ///
    /// # Errors
    /// [`PaintError::Parameter`] for flakes that are not a stack (a metal's reflectance
    /// changes slowly with wavelength: its channel scale carries the band) or a width
    /// that is not finite and in (0, 400] nm.
    pub fn with_band(&self, fwhm_nm: Option<f64>) -> Result<Self, PaintError> {
        let Self::Stack(s) = self else {
            return match fwhm_nm {
                None => Ok(self.clone()),
                Some(_) => Err(PaintError::Parameter(
                    "a channel band is for interference flakes (a flake stack): a metal's reflectance changes slowly across a channel, and its channel scale carries the band".into(),
                )),
            };
        };
        if let Some(w) = fwhm_nm
            && !(w.is_finite() && w > 0.0 && w <= MAX_BAND_FWHM_NM)
        {
            return Err(PaintError::Parameter(format!(
                "channel band {w} nm: expected a full width at half maximum in (0, {MAX_BAND_FWHM_NM}] nm"
            )));
        }
        let mut s = (**s).clone();
        s.band_fwhm_nm = fwhm_nm;
        Ok(Self::Stack(Arc::new(s)))
    }

    /// The channel band's full width at half maximum, nm (`None`: one wavelength).
    #[must_use]
    pub fn band_fwhm_nm(&self) -> Option<f64> {
        match self {
            Self::Stack(s) => s.band_fwhm_nm,
            _ => None,
        }
    }

    /// The same flakes piled `layers` deep (physics.md §12.8); `layers == 1` is one
    /// flake, as without piles.
    ///
    /// # Errors
    /// [`PaintError::Parameter`] for `layers` outside 1–1000, or more than one layer of
    /// flakes that transmit nothing (a metal, or a stack on a core: their pile is the
    /// top flake).
    pub fn with_layers(&self, layers: u32) -> Result<Self, PaintError> {
        let bad = |why: &str| {
            Err(PaintError::Parameter(format!(
                "flake layers = {layers}: {why}"
            )))
        };
        if !(1..=flakescatter_optics::flake::MAX_PILE).contains(&layers) {
            return bad("expected a whole number from 1 to 1000");
        }
        match self {
            Self::Stack(s) if s.core.is_none() || layers == 1 => {
                let mut s = (**s).clone();
                s.layers = layers;
                Ok(Self::Stack(Arc::new(s)))
            }
            _ if layers == 1 => Ok(self.clone()),
            _ => bad(
                "a pile of flakes that transmit nothing (a metal, or a stack on an opaque core) is the top flake itself; piles are of free interference flakes (a flake stack without a core)",
            ),
        }
    }

    /// How many flakes are piled (1 for a metal or an unpiled stack).
    #[must_use]
    pub fn layers(&self) -> u32 {
        match self {
            Self::Stack(s) => s.layers,
            _ => 1,
        }
    }

    /// The flake reflectance in `channel`, in a coat of index `n` (a band's tables are
    /// built for it).
    ///
    /// # Errors
    /// [`PaintError::Parameter`] for an invalid index or a wavelength outside the
    /// aluminium table or a layer's or the core's table (named).
    pub fn at(&self, channel: &Channel, n: f64) -> Result<FlakeReflectance, PaintError> {
        if let Self::Stack(s) = self
            && let Some(w) = s.band_fwhm_nm
            && crate::channel::NAMED_CHANNELS
                .iter()
                .any(|(name, _)| *name == channel.name)
        {
            let members = channel_band(channel.wavelength_nm, w)
                .into_iter()
                .map(|(wl, weight)| {
                    let one = Channel {
                        name: channel.name.clone(),
                        wavelength_nm: wl,
                    };
                    Ok((weight, self.at_one(&one)?))
                })
                .collect::<Result<Vec<_>, PaintError>>()?;
            return FlakeReflectance::band(members, n).map_err(|e| {
                PaintError::Parameter(format!("flake stack at channel `{}`: {e}", channel.name))
            });
        }
        self.at_one(channel)
    }

    /// The flake reflectance at `channel`'s one wavelength.
    fn at_one(&self, channel: &Channel) -> Result<FlakeReflectance, PaintError> {
        let wl = channel.wavelength_nm;
        let at = |what: &str, e: &dyn std::fmt::Display| {
            PaintError::Parameter(format!(
                "{what} at channel `{}` ({wl} nm): {e}",
                channel.name
            ))
        };
        match self {
            Self::PerfectConductor => Ok(FlakeReflectance::PerfectConductor),
            Self::Index { n, k } => FlakeReflectance::complex(*n, *k)
                .map_err(|e| PaintError::Parameter(format!("flake index: {e}"))),
            Self::Aluminium => ComplexIndexTable::aluminium()
                .flake_at(wl)
                .map_err(|e| at("aluminium", &e)),
            Self::Stack(s) => {
                let layers = s.stack.at(wl).map_err(|e| at("flake stack", &e))?;
                let core = s
                    .core
                    .as_ref()
                    .map(|c| c.index_at(wl))
                    .transpose()
                    .map_err(|e| at("flake core", &e))?;
                FlakeReflectance::stack(layers, wl, core)
                    .and_then(|f| f.pile(s.layers))
                    .map_err(|e| at("flake stack", &e))
            }
        }
    }

    /// The same flakes with the stack's `layers` (numbered from 1) `thickness_nm` thick.
    ///
    /// # Errors
    /// [`PaintError::Parameter`] for flakes that are not a stack, a layer the stack
    /// does not have or a thickness that is not finite and > 0.
    pub fn with_thickness(&self, layers: &[usize], thickness_nm: f64) -> Result<Self, PaintError> {
        let Self::Stack(s) = self else {
            return Err(PaintError::Parameter(
                "a layer thickness is a parameter of interference flakes only (a flake stack)"
                    .into(),
            ));
        };
        let stack = s
            .stack
            .with_thickness(layers, thickness_nm)
            .map_err(|e| PaintError::Parameter(format!("flake stack: {e}")))?;
        Ok(Self::Stack(Arc::new(StackFlakes {
            stack,
            core: s.core.clone(),
            layers: s.layers,
            band_fwhm_nm: s.band_fwhm_nm,
        })))
    }

    /// The thickness of layer `layer` (numbered from 1) of a stack, nm; `None` for a
    /// metal or a layer the stack does not have.
    #[must_use]
    pub fn thickness(&self, layer: usize) -> Option<f64> {
        match self {
            Self::Stack(s) => layer
                .checked_sub(1)
                .and_then(|i| s.stack.layers().get(i))
                .map(|(_, d)| *d),
            _ => None,
        }
    }
}
