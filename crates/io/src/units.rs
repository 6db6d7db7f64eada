//! Unit conversion at the file boundary: files speak metres (X3P, SDF) or carry their own
//! unit labels (Gwyddion text); the library speaks micrometres.
//!
//! Decimal numbers are converted by shifting their decimal exponent before parsing, so
//! `"2.58e-6"` metres becomes exactly the `f64` nearest to 2.58 µm (one correctly rounded
//! conversion instead of a parse followed by a multiplication). This is what makes
//! `read(write(map))` reproduce the pitch bit for bit.

use std::str::FromStr;

/// The unit of height values in a plain-text matrix that does not declare one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZUnit {
    /// Micrometres (`um`, `µm`).
    Um,
    /// Nanometres (`nm`).
    Nm,
    /// Metres (`m`).
    M,
}

impl ZUnit {
    /// Power of ten that converts a value in this unit to micrometres.
    pub fn exponent_to_um(self) -> i32 {
        match self {
            ZUnit::Um => 0,
            ZUnit::Nm => -3,
            ZUnit::M => 6,
        }
    }

    /// Short name as accepted by [`ZUnit::from_str`]: `um`, `nm` or `m`.
    pub fn name(self) -> &'static str {
        match self {
            ZUnit::Um => "um",
            ZUnit::Nm => "nm",
            ZUnit::M => "m",
        }
    }
}

/// Error for an unknown unit name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown height unit {0:?}: expected um, nm or m")]
pub struct UnknownUnit(pub String);

impl FromStr for ZUnit {
    type Err = UnknownUnit;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match length_unit_exponent(s) {
            Some(0) => Ok(ZUnit::Um),
            Some(-3) => Ok(ZUnit::Nm),
            Some(6) => Ok(ZUnit::M),
            _ => Err(UnknownUnit(s.to_string())),
        }
    }
}

/// Power of ten from a length unit label to micrometres (`m` → 6, `mm` → 3, `µm` → 0,
/// `nm` → -3, `pm` → -6, `Å` → -4); `None` if the label is not a length unit.
pub(crate) fn length_unit_exponent(label: &str) -> Option<i32> {
    match label.trim() {
        "m" => Some(6),
        "mm" => Some(3),
        "um" | "µm" | "μm" | "micron" | "microns" => Some(0),
        "nm" => Some(-3),
        "pm" => Some(-6),
        "Å" | "A" => Some(-4),
        _ => None,
    }
}

/// Parses a decimal number and multiplies it by `10^shift` with a single rounding.
/// Returns `None` if `s` is not a number. Non-finite inputs come back unchanged.
pub(crate) fn parse_scaled(s: &str, shift: i32) -> Option<f64> {
    let s = s.trim();
    let plain: f64 = s.parse().ok()?;
    if !plain.is_finite() || plain == 0.0 || shift == 0 {
        return Some(plain);
    }
    let (mantissa, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().ok()?),
        None => (s, 0),
    };
    let exp = exp.checked_add(shift)?;
    format!("{mantissa}e{exp}").parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_parse_is_exact() {
        // 2.58e-6 m is 2.58 µm: the result must be the f64 nearest to 2.58, which a
        // parse-then-multiply (2.58e-6 * 1e6) does not always give.
        assert_eq!(parse_scaled("2.58e-6", 6), Some(2.58));
        assert_eq!(parse_scaled("0.0000e+000", 6), Some(0.0));
        assert_eq!(parse_scaled("1.0E-6", 6), Some(1.0));
        assert_eq!(parse_scaled("5678.9", -3), Some(5.6789));
        assert_eq!(parse_scaled("12.34", 0), Some(12.34));
        assert_eq!(parse_scaled("-1.5e3", -3), Some(-1.5));
        assert_eq!(parse_scaled("abc", 6), None);
        assert!(parse_scaled("NaN", 6).unwrap().is_nan());
    }

    #[test]
    fn unit_names() {
        assert_eq!("um".parse::<ZUnit>(), Ok(ZUnit::Um));
        assert_eq!("µm".parse::<ZUnit>(), Ok(ZUnit::Um));
        assert_eq!("nm".parse::<ZUnit>(), Ok(ZUnit::Nm));
        assert_eq!("m".parse::<ZUnit>(), Ok(ZUnit::M));
        assert!("mm".parse::<ZUnit>().is_err());
        assert!("furlong".parse::<ZUnit>().is_err());
    }
}
