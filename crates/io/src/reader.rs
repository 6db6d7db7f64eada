//! What every height-map reader shares: the options a caller gives ([`ReadOptions`]),
//! what the values are ([`ValueKind`]), how sure a reader is that bytes are its format
//! ([`Confidence`]) and what a file holds before it is loaded ([`Channel`]).
//!
//! Each format is one module (`x3p`, `sdf`, `text`) with the same three functions, and
//! imports only this module and [`crate::units`]; the dispatcher in [`crate::map`] calls
//! them, never the other way round:
//!
//! * `detect(bytes) -> Confidence` — from the content alone (magic bytes, header
//!   fields), never the file name;
//! * `channels(bytes, options) -> Result<Vec<Channel>, Error>` — what the file holds
//!   (name, unit, size, pitch) without converting the data where the format allows it;
//! * `read(bytes, options, kind) -> Result<HeightMap, Error>` — one channel as a
//!   [`HeightMap`](flakescatter_stats::heightmap::HeightMap): heights in µm (or
//!   intensities as stored), pitch in µm, row-major with `x` along columns.
//!
//! Units are converted once, at the reader's edge; the file's own unit and scale stay in
//! the map's metadata.

use crate::units::ZUnit;

/// How decimal numbers are written in a plain-text matrix.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum DecimalMark {
    /// Decide from the content when that is unambiguous (`1,5;2,5` or `1,5 2,5` use
    /// decimal commas, `1.5 2.5` and `1, 2, 3` decimal points) and refuse otherwise.
    #[default]
    Auto,
    /// Decimal points (`1.5`); commas, semicolons and whitespace separate values.
    Point,
    /// Decimal commas (`1,5`, German exports); semicolons and whitespace separate values.
    Comma,
}

impl DecimalMark {
    /// `auto`, `point` or `comma`.
    pub fn name(self) -> &'static str {
        match self {
            DecimalMark::Auto => "auto",
            DecimalMark::Point => "point",
            DecimalMark::Comma => "comma",
        }
    }
}

/// Options for reading height maps.
///
/// Construct with `ReadOptions { field: value, ..ReadOptions::default() }`: fields are
/// added as formats need them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ReadOptions {
    /// Pixel pitch `(dx, dy)` in µm. Overrides the file's calibration in every format;
    /// required for plain-text matrices that declare no size. `None` = use the file's.
    pub pixel_um: Option<(f64, f64)>,
    /// Unit of the heights in plain-text matrices. Overrides a unit the file declares;
    /// required when it declares none. Refused for X3P and SDF heights, which are
    /// calibrated; ignored for intensity images, which are unit-less.
    pub z_unit: Option<ZUnit>,
    /// Accept an X3P file whose MD5 checksums do not match (or are missing); the mismatch
    /// is then recorded in the metadata key `x3p.md5_mismatch` instead of failing.
    pub accept_md5_mismatch: bool,
    /// Decimal mark of plain-text matrices (the command line's `--decimal-comma`).
    /// [`DecimalMark::Auto`] detects it and records what was used in `text.decimal_mark`;
    /// another value is refused for X3P and SDF heights.
    pub decimal: DecimalMark,
    /// Which channel to read (0-based, in the order of [`crate::list_channels`]);
    /// `None` = the file's first (for every format read so far, its only) channel.
    pub channel: Option<usize>,
    /// Read a map as the quantity its file declares (an intensity image written as
    /// such: [`crate::quantity`]) instead of as the quantity asked for (which a file
    /// that declares nothing is still read as); what `convert` and `info` use.
    /// Otherwise a file that declares another quantity than the one asked for is
    /// refused.
    pub as_stored: bool,
}

/// What the values of a map are, which decides the unit conversion: the map's own
/// [`Quantity`](flakescatter_stats::heightmap::Quantity) — `Height` (converted to µm; a
/// length unit is required) or `Intensity` (returned as the file stores them,
/// unit-less; any unit label, `a.u.` or none, is accepted). Every read sets the map's
/// quantity to the kind it was read as.
pub use flakescatter_stats::heightmap::Quantity as ValueKind;

/// Power of ten applied to values the file gives in metres: 6 for heights (m → µm),
/// 0 for intensities (as stored).
pub(crate) fn metre_shift(kind: ValueKind) -> i32 {
    match kind {
        ValueKind::Height => 6,
        ValueKind::Intensity => 0,
    }
}

/// How sure a reader is that bytes are its format, 0 (not at all) to 100 (certain);
/// the dispatcher takes the highest score and the file extension only breaks ties.
pub type Confidence = u8;

/// One channel (data field) of a file, as listed before loading it.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// The channel's name in the file (`Z`, `height`, the Gwyddion `Channel` header).
    pub name: String,
    /// The unit of its values as the file states it (`m`, `µm`, `a.u.`), if it does.
    pub unit: Option<String>,
    /// Number of columns (points along `x`).
    pub nx: usize,
    /// Number of rows (points along `y`).
    pub ny: usize,
    /// Pixel pitch `(dx, dy)` in µm, if the file gives it.
    pub pitch_um: Option<(f64, f64)>,
}

/// Splits text into lines at `\n`, `\r\n` or a lone `\r` (old Mac files), so that line
/// numbers are right whatever the line endings; the terminators are not returned.
pub(crate) fn split_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(text);
    std::iter::from_fn(move || {
        let s = rest?;
        match s.find(['\n', '\r']) {
            None => {
                rest = None;
                // No empty last line after a final terminator.
                (!s.is_empty()).then_some(s)
            }
            Some(i) => {
                let skip = if s[i..].starts_with("\r\n") { 2 } else { 1 };
                rest = Some(&s[i + skip..]);
                Some(&s[..i])
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::split_lines;

    #[test]
    fn lines_split_at_every_convention() {
        let v: Vec<&str> = split_lines("a\nb\r\nc\rd\r\n\ne").collect();
        assert_eq!(v, ["a", "b", "c", "d", "", "e"]);
        assert_eq!(split_lines("a\n").count(), 1);
        assert_eq!(split_lines("").count(), 0);
        assert_eq!(split_lines("\n").collect::<Vec<_>>(), [""]);
    }
}
