//! Parsing of command-line values (angle lists, pairs, whole numbers) and the display
//! of angles exactly as they were given.
//!
//! Degrees here, radians from the flag structs on. An angle typed as `30` becomes
//! `30f64.to_radians()`; [`deg`] turns such a value back into the shortest decimal that
//! converts to the same radians, so outputs show `30`, never `29.999999999999996`.

use anyhow::bail;
use flakescatter::stats::decimal::{DecimalRange, degrees_text, typed_degrees};

/// Largest number of angles a list may expand to.
pub const MAX_ANGLES: usize = 1_000_000;

/// Parse `0,30,60`, `-70:70:0.5` (inclusive) or a comma-separated mix, in degrees (or
/// the unit of the flag). Range values are the exact decimals `start + k·step`
/// ([`DecimalRange`]), so that `0:1:0.1` gives `0.3`, not `0.30000000000000004`, and
/// `1e-1:1:1e-1` the same.
pub fn angles(flag: &str, text: &str) -> anyhow::Result<Vec<f64>> {
    let mut out = Vec::new();
    if text.trim().is_empty() {
        bail!(
            "{flag} `{text}`: empty list; expected numbers like `0,30,60` or a range `start:stop:step`"
        );
    }
    for item in text.split(',') {
        let item = item.trim();
        if item.is_empty() {
            bail!(
                "{flag} `{text}`: empty item; expected numbers like `0,30,60` or a range `start:stop:step`"
            );
        }
        let num = |s: &str| -> anyhow::Result<f64> {
            let s = s.trim();
            let v: f64 = s
                .parse()
                .map_err(|_| anyhow::anyhow!("{flag} `{text}`: `{s}` is not a number"))?;
            if !v.is_finite() {
                bail!("{flag} `{text}`: `{s}` is not a finite number");
            }
            Ok(v)
        };
        let parts: Vec<&str> = item.split(':').collect();
        match parts.as_slice() {
            [one] => out.push(num(one)?),
            [a, b, c] => {
                let (start, stop, step) = (num(a)?, num(b)?, num(c)?);
                if step <= 0.0 {
                    bail!("{flag} `{item}`: the step must be > 0");
                }
                if stop < start {
                    bail!("{flag} `{item}`: the range is empty (stop < start)");
                }
                // Inclusive, stepped on the decimals as typed (numerics::decimal):
                // `0:0.3:0.1` is 0, 0.1, 0.2, 0.3, never 0.30000000000000004.
                let Some(range) = DecimalRange::new(start, stop, step) else {
                    bail!("{flag} `{item}`: expected `start:stop:step` with finite numbers");
                };
                if range.len().saturating_add(out.len() as u128) > MAX_ANGLES as u128 {
                    bail!("{flag} `{item}`: more than {MAX_ANGLES} angles");
                }
                out.extend(range.iter());
            }
            _ => bail!("{flag} `{item}`: expected a number or `start:stop:step`"),
        }
        if out.len() > MAX_ANGLES {
            bail!("{flag}: more than {MAX_ANGLES} angles");
        }
    }
    Ok(out)
}

/// Angles in degrees within a range, or an error naming the flag and the range:
/// `lo_open`/`hi_open` say whether the ends are excluded.
pub fn check_range(
    flag: &str,
    values: &[f64],
    lo: f64,
    hi: f64,
    lo_open: bool,
    hi_open: bool,
) -> anyhow::Result<()> {
    check_range_in(flag, values, (lo, hi), (lo_open, hi_open), ("°", "degrees"))
}

/// [`check_range`] for values in another unit: `unit` is `(after a value, the unit's
/// name)`, e.g. `(" nm", "nanometres")` gives "0 nm is outside (0, inf) nanometres".
pub fn check_range_in(
    flag: &str,
    values: &[f64],
    (lo, hi): (f64, f64),
    (lo_open, hi_open): (bool, bool),
    (symbol, name): (&str, &str),
) -> anyhow::Result<()> {
    for &v in values {
        let above = if lo_open { v > lo } else { v >= lo };
        let below = if hi_open { v < hi } else { v <= hi };
        if !(above && below) {
            bail!(
                "{flag}: {}{symbol} is outside {}{lo}, {hi}{} {name}",
                shortest(v),
                if lo_open { "(" } else { "[" },
                if hi_open { ")" } else { "]" }
            );
        }
    }
    Ok(())
}

/// `A` or `A,B` as a pair (`A,A` for one value), each parsed by `parse`.
pub fn pair<T: Copy>(
    flag: &str,
    text: &str,
    what: &str,
    parse: impl Fn(&str) -> Option<T>,
) -> anyhow::Result<(T, T)> {
    let one = |p: &str| {
        parse(p.trim())
            .ok_or_else(|| anyhow::anyhow!("{flag} {text}: `{}` is not {what}", p.trim()))
    };
    match text.split(',').collect::<Vec<_>>().as_slice() {
        [a] => {
            let a = one(a)?;
            Ok((a, a))
        }
        [a, b] => Ok((one(a)?, one(b)?)),
        _ => bail!("{flag} {text}: expected one value or two separated by a comma"),
    }
}

/// A whole number ≥ 0 for clap (`-1` and `2.5` are refused with this message).
pub fn whole(s: &str) -> Result<usize, String> {
    match s.trim().parse::<i128>() {
        Ok(v) if v < 0 => Err("expected a whole number >= 0".into()),
        Ok(v) => usize::try_from(v).map_err(|_| "too large".into()),
        Err(_) => Err("expected a whole number >= 0".into()),
    }
}

/// A whole number in `[LO, HI]`, for clap: `0`, `-1`, `1.5`, `1e20` and text all get the
/// same message, "expected a whole number from LO to HI" (issue 52, item 23: `volume
/// --rays` gave one message for 0 and another for −1, 1e20 and 1.5).
pub fn whole_in<const LO: u64, const HI: u64>(s: &str) -> Result<u64, String> {
    whole_between(s, u128::from(LO), u128::from(HI), u128::from(u64::MAX)).map(|v| v as u64)
}

/// [`whole_in`] for counts held as `usize`.
pub fn count_in<const LO: usize, const HI: usize>(s: &str) -> Result<usize, String> {
    whole_between(s, LO as u128, HI as u128, usize::MAX as u128).map(|v| v as usize)
}

/// `s` as a whole number in `[lo, hi]` (`hi == max`: no upper bound is stated).
fn whole_between(s: &str, lo: u128, hi: u128, max: u128) -> Result<u128, String> {
    match s.trim().parse::<u128>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ if hi == max => Err(format!("expected a whole number >= {lo}")),
        _ => Err(format!("expected a whole number from {lo} to {hi}")),
    }
}

/// An odd whole number ≥ 3, for clap (least-squares windows): `4`, `1`, `-1`, `2.5` all
/// get "expected an odd whole number of pixels >= 3".
pub fn odd_window(s: &str) -> Result<usize, String> {
    match s.trim().parse::<i128>() {
        Ok(v) if v >= 3 && v % 2 == 1 => usize::try_from(v).map_err(|_| "too large".into()),
        _ => Err("expected an odd whole number of pixels >= 3".into()),
    }
}

/// A whole number ≥ 0 that fits 64 bits, for clap (seeds).
pub fn whole_u64(s: &str) -> Result<u64, String> {
    match s.trim().parse::<i128>() {
        Ok(v) if v < 0 => Err("expected a whole number >= 0".into()),
        Ok(v) => u64::try_from(v).map_err(|_| "expected a whole number below 2^64".into()),
        Err(_) => Err("expected a whole number >= 0".into()),
    }
}

/// The shortest decimal text of `x` that reads back as `x` (Rust's `{}`), with `-0`
/// shown as `0`.
pub fn shortest(x: f64) -> String {
    if x == 0.0 { "0".into() } else { format!("{x}") }
}

/// An angle in radians as the degrees that were typed: the shortest decimal `d` with
/// `d.to_radians() == rad` (so `30f64.to_radians()` shows as `30`). Other values show
/// their degrees to full precision.
pub fn deg(rad: f64) -> String {
    degrees_text(rad)
}

/// [`deg`] as a number (for JSON).
pub fn deg_num(rad: f64) -> f64 {
    typed_degrees(rad)
}

/// A number rounded for display to `decimals` places, without a `-0.000`; from 1e15
/// on in exponent form with 4 significant digits (`1.160e102`, not 103 digits).
pub fn fixed(x: f64, decimals: usize) -> String {
    if x.is_finite() && x.abs() >= 1e15 {
        return format!("{x:.3e}");
    }
    let s = format!("{x:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_angles_come_back_as_typed() {
        for typed in ["30", "-69.5", "0.3", "12.345678", "89.99", "1e-7", "45"] {
            let v: f64 = typed.parse().unwrap();
            assert_eq!(deg(v.to_radians()).parse::<f64>().unwrap(), v, "{typed}");
        }
        assert_eq!(deg(30f64.to_radians()), "30");
        assert_eq!(deg((-0.0f64).to_radians()), "0");
        // 30° through radians and back is 29.999999999999996 in floating point.
        assert_ne!(30f64.to_radians().to_degrees(), 30.0);
    }

    #[test]
    fn ranges_take_the_decimals_of_their_inputs() {
        let v = angles("--x", "0:1:0.1").unwrap();
        assert_eq!(v.len(), 11);
        assert_eq!(v[3], 0.3);
        assert_eq!(v[10], 1.0);
        assert_eq!(angles("--x", "-70:70:0.5").unwrap().len(), 281);
        assert!(angles("--x", "").is_err());
        assert!(angles("--x", "1,,2").is_err());
        assert!(angles("--x", "nan").is_err());
        assert!(angles("--x", "0:1e9:0.0001").is_err());
    }

    #[test]
    fn display_rounding_has_no_negative_zero() {
        assert_eq!(fixed(-0.00001, 4), "0.0000");
        assert_eq!(fixed(-0.5, 2), "-0.50");
        assert_eq!(shortest(-0.0), "0");
    }

    #[test]
    fn whole_numbers_refuse_signs_and_fractions() {
        assert_eq!(whole("5"), Ok(5));
        assert!(whole("-1").is_err());
        assert!(whole("2.5").is_err());
        assert!(whole_u64("-3").is_err());
    }
}
