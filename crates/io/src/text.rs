//! Plain-text height matrices: one row of the map per line, values separated by
//! whitespace, commas or semicolons; `NaN` (or any non-finite value) marks an invalid point.
//!
//! Conventions: the first data line is row 0 (`y = 0`), the first value of a line is column
//! 0 (`x = 0`). Leading `#` lines are a header in Gwyddion's style, `# Key: value`, with
//! English or German keys:
//! * `Width`/`Breite` and `Height`/`Höhe`: the physical size of the whole image with a
//!   unit (`12.34 µm`); the pitch is `width / nx`, `height / ny` (Gwyddion's convention).
//! * `Pitch x`, `Pitch y` (written by this crate): the pitch itself, which reproduces it
//!   exactly; these take precedence over width and height.
//! * `Value units`/`Z units`/`Werteinheiten`: the unit of the values (`m`, `mm`, `µm`, `nm`).
//!
//! A file that carries no pitch needs [`ReadOptions::pixel_um`]; one that carries no
//! value unit needs [`ReadOptions::z_unit`] (the command line's `--pixel-um` and
//! `--z-unit`). Nothing is silently assumed.
//!
//! A two-column table whose first line names an `x` column (`X_(microns),y1`) is read as a
//! single profile (`ny = 1`): the second column holds the heights and the pitch is the
//! mean spacing of the `x` column, whose unit is taken from its name.

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::map::ReadOptions;
use crate::units::{length_unit_exponent, parse_scaled};

/// What is wrong with a plain-text height matrix.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TextError {
    /// The file is empty or holds only header lines.
    #[error("no data rows found")]
    Empty,
    /// The file contains NUL bytes: it is binary, not a format this crate knows.
    #[error("binary content that is not X3P (zip) or SDF (aISO/bISO): unrecognised format")]
    Binary,
    /// A value is not a number.
    #[error("line {line}, column {column}: {token:?} is not a number")]
    BadNumber {
        /// 1-based line number.
        line: usize,
        /// 1-based column (value index in the line).
        column: usize,
        /// The token.
        token: String,
    },
    /// A row has a different number of values from the first row.
    #[error(
        "line {line}: row has {found} values, expected {expected} (as in the first data row or the column header)"
    )]
    Ragged {
        /// 1-based line number.
        line: usize,
        /// Values in the first row.
        expected: usize,
        /// Values in this row.
        found: usize,
    },
    /// A header size or unit cannot be understood.
    #[error("line {line}: header {key:?} = {value:?}: {expected}")]
    BadHeader {
        /// 1-based line number.
        line: usize,
        /// The header key.
        key: String,
        /// The header value.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The file gives no pitch and none was supplied.
    #[error(
        "the file does not give the pixel pitch: supply it (option pixel_um, \
         `--pixel-um DX[,DY]` on the command line)"
    )]
    MissingPitch,
    /// The file gives no height unit and none was supplied.
    #[error(
        "the file does not give the unit of its heights: supply it (option z_unit, \
         `--z-unit um|nm|m` on the command line)"
    )]
    MissingZUnit,
    /// The profile's `x` column is not evenly spaced.
    #[error("line {line}: x column is not evenly spaced (step {step} vs mean {mean})")]
    UnevenProfile {
        /// 1-based line number.
        line: usize,
        /// The offending step, in the file's x unit.
        step: f64,
        /// Mean step, in the file's x unit.
        mean: f64,
    },
    /// The numbers do not make a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

/// `"12.34 µm"` → 12.34 in µm (exactly rounded), or `None`.
fn length_um(value: &str) -> Option<f64> {
    let mut parts = value.split_whitespace();
    let number = parts.next()?;
    let unit = parts.next()?;
    if parts.next().is_some() {
        return None;
    }
    parse_scaled(number, length_unit_exponent(unit)?).filter(|v| v.is_finite() && *v > 0.0)
}

fn split_values(line: &str) -> impl Iterator<Item = &str> {
    line.split(|c: char| c.is_whitespace() || c == ',' || c == ';')
        .filter(|t| !t.is_empty())
}

/// Unit exponent (to µm) from a column name such as `X_(microns)`, `x [mm]`, `x_um`.
fn unit_from_name(name: &str) -> Option<i32> {
    let lower = name.to_lowercase();
    let inner: String = lower
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || c == 'µ' || c == 'μ' {
                c
            } else {
                ' '
            }
        })
        .collect();
    inner
        .split_whitespace()
        .skip(1)
        .chain(inner.split('_').skip(1))
        .find_map(|w| length_unit_exponent(w.trim()))
}

/// Reads a plain-text matrix held in memory.
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault, or the missing calibration.
pub fn read_text_bytes(bytes: &[u8], options: &ReadOptions) -> Result<HeightMap, TextError> {
    if bytes.contains(&0) {
        return Err(TextError::Binary);
    }
    let text = String::from_utf8_lossy(bytes);
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);

    let mut width = None;
    let mut height = None;
    let mut pitch_x = None;
    let mut pitch_y = None;
    let mut z_exp = None;
    let mut meta: Vec<(String, String)> = Vec::new();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut expected = 0usize;
    let mut profile_header: Option<(usize, String)> = None;

    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(h) = line.strip_prefix('#') {
            let Some((key, value)) = h.split_once(':') else {
                continue;
            };
            let (key, value) = (key.trim(), value.trim());
            let bad = |expected| TextError::BadHeader {
                line: line_no,
                key: key.to_string(),
                value: value.to_string(),
                expected,
            };
            match key.to_lowercase().as_str() {
                "width" | "breite" => {
                    width =
                        Some(length_um(value).ok_or_else(|| bad("a positive length with a unit"))?);
                }
                "height" | "höhe" | "hoehe" => {
                    height =
                        Some(length_um(value).ok_or_else(|| bad("a positive length with a unit"))?);
                }
                "pitch x" => {
                    pitch_x =
                        Some(length_um(value).ok_or_else(|| bad("a positive length with a unit"))?);
                }
                "pitch y" => {
                    pitch_y =
                        Some(length_um(value).ok_or_else(|| bad("a positive length with a unit"))?);
                }
                "value units" | "z units" | "werteinheiten" | "werteinheit" => {
                    z_exp = Some(
                        length_unit_exponent(value)
                            .ok_or_else(|| bad("a length unit: m, mm, µm, nm, pm"))?,
                    );
                }
                other => meta.push((format!("text.{}", other.replace(' ', "_")), value.into())),
            }
            continue;
        }
        // A non-numeric first line naming an x column starts a profile table.
        if rows.is_empty() && profile_header.is_none() {
            let names: Vec<&str> = split_values(line).collect();
            if names.len() == 2
                && names[0].parse::<f64>().is_err()
                && names[0].to_lowercase().starts_with('x')
            {
                profile_header = Some((line_no, names[0].to_string()));
                meta.push(("text.columns".into(), names.join(",")));
                continue;
            }
        }
        let mut row = Vec::with_capacity(expected);
        for (j, token) in split_values(line).enumerate() {
            let v: f64 = token.parse().map_err(|_| TextError::BadNumber {
                line: line_no,
                column: j + 1,
                token: token.to_string(),
            })?;
            row.push(v);
        }
        if rows.is_empty() {
            // A profile table has exactly the two columns its header names.
            expected = if profile_header.is_some() {
                2
            } else {
                row.len()
            };
        }
        if row.len() != expected {
            return Err(TextError::Ragged {
                line: line_no,
                expected,
                found: row.len(),
            });
        }
        rows.push(row);
    }
    if rows.is_empty() || expected == 0 {
        return Err(TextError::Empty);
    }

    let z_exp = match options.z_unit {
        Some(u) => u.exponent_to_um(),
        None => z_exp.ok_or(TextError::MissingZUnit)?,
    };
    let z_factor = 10f64.powi(z_exp);

    let (nx, ny, z, file_pitch) = if let Some((header_line, x_name)) = profile_header {
        let xs: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        let z: Vec<f64> = rows.iter().map(|r| r[1] * z_factor).collect();
        let n = xs.len();
        let pitch = if n >= 2 {
            let mean = (xs[n - 1] - xs[0]) / (n - 1) as f64;
            for (k, w) in xs.windows(2).enumerate() {
                let step = w[1] - w[0];
                // Tolerate rounding of printed coordinates (5 % of the step).
                let even = (step - mean).abs() <= 0.05 * mean.abs();
                if !even {
                    return Err(TextError::UnevenProfile {
                        line: header_line + k + 2,
                        step,
                        mean,
                    });
                }
            }
            unit_from_name(&x_name).map(|e| mean * 10f64.powi(e))
        } else {
            None
        };
        (n, 1, z, pitch.map(|p| (p, p)))
    } else {
        let ny = rows.len();
        let nx = expected;
        let z: Vec<f64> = rows.into_iter().flatten().map(|v| v * z_factor).collect();
        let px = pitch_x.or(width.map(|w| w / nx as f64));
        let py = pitch_y.or(height.map(|h| h / ny as f64));
        let pitch = match (px, py) {
            (Some(x), Some(y)) => Some((x, y)),
            (Some(x), None) if ny == 1 => Some((x, x)),
            _ => None,
        };
        (nx, ny, z, pitch)
    };

    let (dx, dy) = match (options.pixel_um, file_pitch) {
        (Some(p), _) | (None, Some(p)) => p,
        (None, None) => return Err(TextError::MissingPitch),
    };
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(TextError::Map)?;
    for (k, v) in meta {
        map.set_metadata(k, v);
    }
    Ok(map)
}

/// Writes `map` as a plain-text matrix: a `#` header (Gwyddion-style size and units, plus
/// exact `Pitch x`/`Pitch y` lines), then one line per row of heights in µm in Rust's
/// shortest round-trip notation, `NaN` for invalid points. Reading it back gives the same
/// heights (bit for bit), mask and pitch.
pub fn write_text_string(map: &HeightMap) -> String {
    write_text_with(map, "height", "# Value units: µm\n")
}

/// Writes an intensity image (unit-less values) as a plain-text matrix: as
/// [`write_text_string`] but with channel `intensity` and no value unit, so the numbers
/// are the values themselves ([`crate::read_intensity`] reads them back exactly).
pub fn write_intensity_text_string(map: &HeightMap) -> String {
    write_text_with(map, "intensity", "")
}

fn write_text_with(map: &HeightMap, channel: &str, unit_line: &str) -> String {
    let mut out = String::with_capacity(map.len() * 12 + 200);
    out.push_str(&format!(
        "# Channel: {channel}\n# Width: {} µm\n# Height: {} µm\n# Pitch x: {} µm\n# Pitch y: {} µm\n{unit_line}",
        map.dx() * map.nx() as f64,
        map.dy() * map.ny() as f64,
        map.dx(),
        map.dy()
    ));
    for row in 0..map.ny() {
        for col in 0..map.nx() {
            if col > 0 {
                out.push(' ');
            }
            match map.get(col, row) {
                Some(z) => out.push_str(&format!("{z:e}")),
                None => out.push_str("NaN"),
            }
        }
        out.push('\n');
    }
    out
}
