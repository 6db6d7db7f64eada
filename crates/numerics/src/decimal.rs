//! Grids of decimal numbers that come out as they were typed.
//!
//! A range `start:stop:step` or the edges `0, w, 2w, …` of histogram bins computed as
//! `start + k·step` in floating point drift from the decimals the user gave
//! (`3 × 1.5 = 4.5` but `0.1 + 2 × 0.1 = 0.30000000000000004`, and `2 × (1.5°
//! in radians)` is not `3°` in radians). Here every grid point is the double nearest the
//! **exact** decimal `start + k·step`: the numbers are taken as the shortest decimals that
//! read back as them (Rust's `{}`: `0.1` is `1 × 10⁻¹`, `1e-7` is `1 × 10⁻⁷`), brought
//! to common decimal places, and stepped on integers; the decimal text of the result is
//! then parsed (correctly rounded). The count of a range is exact too: `0:0.3:0.1` has
//! four points. Where the integers would not fit 128 bits (more than ~38 significant
//! digits between the extremes), the grid falls back to `start + k·step` in floating
//! point, the count with a 1e-9-step slack.
//!
//! [`typed_degrees`] / [`degrees_text`] go the other way for angles kept in radians: the
//! shortest decimal number of degrees whose conversion is the given radians, so that a
//! grid made here and converted with `to_radians` prints back as typed.

/// A finite number as the shortest decimal that reads back as it: `digits × 10^−places`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Decimal {
    digits: i128,
    places: u32,
}

impl Decimal {
    /// `None` for non-finite numbers and for more digits than 128 bits hold.
    fn of(x: f64) -> Option<Self> {
        if !x.is_finite() {
            return None;
        }
        let text = format!("{x}");
        let (int, frac) = text.split_once('.').unwrap_or((&text, ""));
        let digits: i128 = format!("{int}{frac}").parse().ok()?;
        Some(Self {
            digits,
            places: u32::try_from(frac.len()).ok()?,
        })
    }

    /// The digits at `places` (≥ `self.places`) decimal places, if they fit.
    fn at(self, places: u32) -> Option<i128> {
        10i128
            .checked_pow(places - self.places)?
            .checked_mul(self.digits)
    }
}

/// The double nearest `digits × 10^−places` (parsed from its decimal text).
fn from_digits(digits: i128, places: u32) -> f64 {
    let sign = if digits < 0 { "-" } else { "" };
    let mut s = digits.unsigned_abs().to_string();
    let p = places as usize;
    if s.len() <= p {
        s = format!("{}{s}", "0".repeat(p + 1 - s.len()));
    }
    let (int, frac) = s.split_at(s.len() - p);
    let v: f64 = format!("{sign}{int}.{frac}0").parse().unwrap_or(f64::NAN);
    // -0 prints as 0.
    v + 0.0
}

/// The number of points of a range that has no exact decimal form:
/// `⌊(stop − start)/step + 1e-9⌋ + 1`, or `u128::MAX` when that is beyond 10³⁰ or not
/// a number (the width overflows the doubles).
fn fallback_len(start: f64, stop: f64, step: f64) -> u128 {
    let n = ((stop - start) / step + 1e-9).floor();
    if n < 1e30 { n as u128 + 1 } else { u128::MAX }
}

/// An inclusive range `start:stop:step` of decimals (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecimalRange {
    start: f64,
    step: f64,
    /// `(start digits, step digits, places)` when exact.
    exact: Option<(i128, i128, u32)>,
    len: u128,
}

impl DecimalRange {
    /// The points `start, start + step, …` up to and including `stop` where it lies on
    /// the grid. `None` unless all three are finite, `step > 0` and `stop ≥ start`.
    #[must_use]
    pub fn new(start: f64, stop: f64, step: f64) -> Option<Self> {
        if !(start.is_finite() && stop.is_finite() && step.is_finite() && step > 0.0)
            || stop < start
        {
            return None;
        }
        let exact = (|| {
            let (a, b, c) = (Decimal::of(start)?, Decimal::of(stop)?, Decimal::of(step)?);
            let places = a.places.max(b.places).max(c.places);
            let (a, b, c) = (a.at(places)?, b.at(places)?, c.at(places)?);
            let len = u128::try_from(b.checked_sub(a)? / c).ok()? + 1;
            Some(((a, c, places), len))
        })();
        Some(match exact {
            Some((e, len)) => Self {
                start,
                step,
                exact: Some(e),
                len,
            },
            None => Self {
                start,
                step,
                exact: None,
                len: fallback_len(start, stop, step),
            },
        })
    }

    /// The number of points (at least 1; `u128::MAX` stands for any count beyond 10³⁰,
    /// e.g. a step of 1e-300 over a unit range or a range wider than the doubles, so
    /// that a caller's limit refuses it).
    #[must_use]
    pub fn len(&self) -> u128 {
        self.len
    }

    /// Always false: a range holds at least its start.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Point `k` (`0 ≤ k < len`): the double nearest the decimal `start + k·step`.
    #[must_use]
    pub fn get(&self, k: u128) -> f64 {
        if let Some((a, c, places)) = self.exact
            && let Some(d) = i128::try_from(k)
                .ok()
                .and_then(|k| k.checked_mul(c))
                .and_then(|kc| kc.checked_add(a))
        {
            return from_digits(d, places);
        }
        self.start + self.step * k as f64
    }

    /// All points, in order.
    pub fn iter(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.len).map(|k| self.get(k))
    }
}

/// The multiples `0, w, 2w, …` of `w` below `limit` (`w > 0`), each the double nearest
/// its exact decimal, then `limit` itself: the edges of bins of width `w` from 0 cut at
/// `limit` (`bin_edges(1.5, 90)` = `0, 1.5, 3, …, 88.5, 90`). `None` unless `w` and
/// `limit` are finite and positive.
#[must_use]
pub fn bin_edges(w: f64, limit: f64) -> Option<Vec<f64>> {
    if !(w.is_finite() && w > 0.0 && limit.is_finite() && limit > 0.0) {
        return None;
    }
    let range = DecimalRange::new(0.0, limit, w)?;
    let mut edges: Vec<f64> = range.iter().filter(|&e| e < limit).collect();
    edges.push(limit);
    Some(edges)
}

/// The angle `rad` (radians) as the number of degrees it was typed as: the shortest
/// decimal `d` (at most 15 places) with `d.to_radians() == rad`, so `30f64.to_radians()`
/// gives 30, not `29.999999999999996`; other values their degrees in full.
#[must_use]
pub fn typed_degrees(rad: f64) -> f64 {
    if rad == 0.0 {
        return 0.0;
    }
    let d = rad.to_degrees();
    for p in 0..=15 {
        if let Ok(v) = format!("{d:.p$}").parse::<f64>()
            && v.to_radians() == rad
        {
            return v + 0.0;
        }
    }
    d
}

/// [`typed_degrees`] as text (shortest form, `-0` as `0`).
#[must_use]
pub fn degrees_text(rad: f64) -> String {
    format!("{}", typed_degrees(rad) + 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_are_the_exact_decimals() {
        let r = DecimalRange::new(0.0, 0.3, 0.1).unwrap();
        assert_eq!(r.len(), 4);
        assert_eq!(r.iter().collect::<Vec<_>>(), [0.0, 0.1, 0.2, 0.3]);
        let r = DecimalRange::new(-80.0, 80.0, 0.1).unwrap();
        assert_eq!(r.len(), 1601);
        for (k, v) in r.iter().enumerate() {
            let want: f64 = format!("{:.1}", -80.0 + 0.1 * k as f64).parse().unwrap();
            assert_eq!(v, want + 0.0, "{k}");
        }
        // Exponent notation is a decimal too.
        let r = DecimalRange::new(1e-1, 1.0, 1e-1).unwrap();
        assert_eq!(r.get(6), 0.7);
        assert_eq!(r.len(), 10);
        // Stop off the grid: the last point below it.
        assert_eq!(DecimalRange::new(0.0, 1.0, 0.3).unwrap().len(), 4);
        assert!(DecimalRange::new(1.0, 0.0, 0.1).is_none());
        assert!(DecimalRange::new(0.0, 1.0, 0.0).is_none());
        assert_eq!(
            bin_edges(1.5, 90.0).unwrap()[..6],
            [0.0, 1.5, 3.0, 4.5, 6.0, 7.5]
        );
        assert_eq!(bin_edges(7.0, 90.0).unwrap().last(), Some(&90.0));
        assert_eq!(bin_edges(7.0, 90.0).unwrap().len(), 14);
    }

    #[test]
    fn counts_beyond_any_limit_saturate() {
        // 1/1e-300 = 1e300 points and a width beyond the doubles (1e308 − (−1e308) is
        // infinite): both have no exact decimal form, and both are "more than any
        // limit" (they once overflowed the count, panicking in debug builds and
        // wrapping to 0 points in release).
        assert_eq!(
            DecimalRange::new(0.0, 1.0, 1e-300).unwrap().len(),
            u128::MAX
        );
        assert_eq!(
            DecimalRange::new(-1e308, 1e308, 1.0).unwrap().len(),
            u128::MAX
        );
        assert_eq!(DecimalRange::new(0.0, 1e39, 1.0).unwrap().len(), u128::MAX);
        // Below the cap the count is the closed form ⌊(stop − start)/step⌋ + 1.
        assert_eq!(
            DecimalRange::new(0.0, 1e20, 1.0).unwrap().len(),
            100_000_000_000_000_000_001
        );
    }

    #[test]
    fn degrees_come_back_as_typed() {
        for typed in [
            "30",
            "-69.5",
            "0.3",
            "12.345678",
            "89.99",
            "1e-7",
            "1.5",
            "7.5",
        ] {
            let v: f64 = typed.parse().unwrap();
            assert_eq!(typed_degrees(v.to_radians()), v, "{typed}");
        }
        assert_eq!(degrees_text(3f64.to_radians()), "3");
        assert_eq!(degrees_text((-0.0f64).to_radians()), "0");
    }
}
