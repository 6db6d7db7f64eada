//! Colour channels of a measured BRDF table and the flake optics in each.
//!
//! A channel is named as in the table's column `brdf_<name>_per_sr`: `r`, `g`, `b` (the
//! linear RGB channels of an instrument or a renderer), `y` (luminance), or a wavelength
//! in nanometres written `<number>nm` (`550nm`, `632.8nm`). The flake metal's complex
//! index is taken at the channel's wavelength: for a wavelength channel that wavelength;
//! for `r`, `g`, `b` the dominant wavelengths of the sRGB primaries, 612, 547 and 464 nm
//! (CIE 1931, D65 white), for `y` 555 nm, the peak of the photopic curve, and for
//! `value` (the one value column of an in-plane curve file) 550 nm. A per-channel
//! flake reflectance scale (the paint model's) absorbs what a single wavelength cannot
//! say about a broad channel.

use crate::PaintError;

/// Wavelengths taken for the named channels, nanometres.
pub const NAMED_CHANNELS: [(&str, f64); 4] =
    [("r", 612.0), ("g", 547.0), ("b", 464.0), ("y", 555.0)];

/// One colour channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// The name as in `brdf_<name>_per_sr`.
    pub name: String,
    /// The wavelength at which the flake metal's index is taken, nanometres.
    pub wavelength_nm: f64,
}

impl Channel {
    /// The channel of a column name's `<name>` part.
    ///
    /// # Errors
    /// [`PaintError::Channel`] for a name that is neither `r`, `g`, `b`, `y`, `value`
    /// nor a wavelength `<number>nm` within 200–2000 nm.
    pub fn parse(name: &str) -> Result<Self, PaintError> {
        if let Some(&(_, wl)) = NAMED_CHANNELS.iter().find(|(n, _)| *n == name) {
            return Ok(Self {
                name: name.to_string(),
                wavelength_nm: wl,
            });
        }
        let wl = name
            .strip_suffix("nm")
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| (200.0..=2000.0).contains(v));
        match wl {
            Some(wavelength_nm) => Ok(Self {
                name: name.to_string(),
                wavelength_nm,
            }),
            None => Err(PaintError::Channel(format!(
                "unknown channel `{name}`: expected r, g, b, y, value or a wavelength such as 550nm (200-2000 nm)"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_wavelengths() {
        assert_eq!(Channel::parse("g").unwrap().wavelength_nm, 547.0);
        assert_eq!(Channel::parse("632.8nm").unwrap().wavelength_nm, 632.8);
        for bad in ["red", "550", "nm", "5000nm", "-3nm", ""] {
            assert!(Channel::parse(bad).is_err(), "{bad}");
        }
    }
}
