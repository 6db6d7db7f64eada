//! A text matrix parsed: its `#` header (size, pitch, units, channel), its data lines
//! (a matrix or a single profile) and the checks on them.

use crate::reader::{DecimalMark, ReadOptions, split_lines};
use crate::units::length_unit_exponent;

use super::encoding::decode;
use super::error::TextError;
use super::numbers::{decide_decimal, fields, length_um, parse_number};

/// Unit exponent (to µm) from a column name such as `X_(microns)`, `x [mm]`, `x_um`.
pub(super) fn unit_from_name(name: &str) -> Option<i32> {
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

/// A header value as found, with its line.
#[derive(Clone)]
pub(super) struct Found<T> {
    pub(super) line: usize,
    pub(super) value: T,
}

/// A parsed file before calibration: header, decimal decision and numbers.
pub(super) struct Parsed {
    pub(super) width: Option<Found<String>>,
    pub(super) height: Option<Found<String>>,
    pub(super) pitch_x: Option<Found<String>>,
    pub(super) pitch_y: Option<Found<String>>,
    pub(super) value_unit: Option<Found<String>>,
    pub(super) channel: Option<String>,
    pub(super) meta: Vec<(String, String)>,
    /// `(header line, x column name)` of a profile table.
    pub(super) profile: Option<(usize, String)>,
    /// `(line, values)` per data row.
    pub(super) rows: Vec<(usize, Vec<f64>)>,
    pub(super) columns: usize,
    pub(super) comma: bool,
    /// Header lengths may be written with a decimal comma (unless decimal points were
    /// asked for): `12,34 µm` cannot be two numbers.
    pub(super) header_comma: bool,
}

pub(super) fn parse(bytes: &[u8], options: &ReadOptions) -> Result<Parsed, TextError> {
    let (text, encoding) = decode(bytes)?;
    let mut p = Parsed {
        width: None,
        height: None,
        pitch_x: None,
        pitch_y: None,
        value_unit: None,
        channel: None,
        meta: vec![("text.encoding".into(), encoding.into())],
        profile: None,
        rows: Vec::new(),
        columns: 0,
        comma: false,
        header_comma: options.decimal != DecimalMark::Point,
    };
    // Header keys seen, with their line (a hash map: a file may hold many header lines).
    let mut seen: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut data: Vec<(usize, &str)> = Vec::new();
    for (i, raw) in split_lines(&text).enumerate() {
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
            let lower = key.to_lowercase();
            let slot = match lower.as_str() {
                "width" | "breite" => Some(&mut p.width),
                "height" | "höhe" | "hoehe" => Some(&mut p.height),
                "pitch x" => Some(&mut p.pitch_x),
                "pitch y" => Some(&mut p.pitch_y),
                "value units" | "z units" | "werteinheiten" | "werteinheit" => {
                    Some(&mut p.value_unit)
                }
                _ => None,
            };
            if let Some(first) = seen.get(&lower) {
                return Err(TextError::DuplicateHeader {
                    key: key.to_string(),
                    first: *first,
                    second: line_no,
                });
            }
            seen.insert(lower.clone(), line_no);
            match slot {
                Some(slot) => {
                    *slot = Some(Found {
                        line: line_no,
                        value: value.to_string(),
                    });
                }
                None => {
                    if matches!(lower.as_str(), "channel" | "kanal") {
                        p.channel = Some(value.to_string());
                    }
                    p.meta
                        .push((format!("text.{}", lower.replace(' ', "_")), value.into()));
                }
            }
            continue;
        }
        // A non-numeric first line naming an x column starts a profile table.
        if data.is_empty() && p.profile.is_none() {
            let names: Vec<&str> = line
                .split(|c: char| c.is_whitespace() || c == ',' || c == ';')
                .filter(|t| !t.is_empty())
                .collect();
            if names.len() == 2
                && names[0].parse::<f64>().is_err()
                && names[0].to_lowercase().starts_with('x')
            {
                p.profile = Some((line_no, names[0].to_string()));
                p.meta.push(("text.columns".into(), names.join(",")));
                continue;
            }
        }
        data.push((line_no, line));
    }

    let decision = decide_decimal(&data, options.decimal)?;
    p.comma = decision.comma;
    p.meta
        .push(("text.decimal_mark".into(), decision.how.to_string()));

    for &(line_no, line) in &data {
        let tokens = fields(line, !p.comma).map_err(|column| TextError::EmptyValue {
            line: line_no,
            column,
        })?;
        let mut row = Vec::with_capacity(p.columns);
        for (j, token) in tokens.iter().enumerate() {
            let v = parse_number(token, p.comma).ok_or_else(|| TextError::BadNumber {
                line: line_no,
                column: j + 1,
                token: token.to_string(),
            })?;
            row.push(v);
        }
        if p.rows.is_empty() {
            // A profile table has exactly the two columns its header names.
            p.columns = if p.profile.is_some() { 2 } else { row.len() };
        }
        if row.len() != p.columns {
            return Err(TextError::Ragged {
                line: line_no,
                expected: p.columns,
                found: row.len(),
            });
        }
        p.rows.push((line_no, row));
    }
    if p.rows.is_empty() || p.columns == 0 {
        return Err(TextError::Empty);
    }
    Ok(p)
}

/// Refuses three columns whose first two enumerate a grid (every pair once, at least 2
/// x 2 distinct values): an `x y z` export, which read as a matrix would be a map of
/// coordinates. A height matrix with 3 columns does not have that structure.
pub(super) fn point_list_check(rows: &[(usize, Vec<f64>)]) -> Result<(), TextError> {
    let coordinates =
        |r: &(usize, Vec<f64>)| r.1.len() == 3 && r.1[..2].iter().all(|v| v.is_finite());
    if rows.len() < 4 || !rows.iter().all(coordinates) {
        return Ok(());
    }
    let distinct = |k: usize| {
        let mut v: Vec<u64> = rows.iter().map(|r| r.1[k].to_bits()).collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let (nx, ny) = (distinct(0), distinct(1));
    let mut pairs: Vec<(u64, u64)> = rows
        .iter()
        .map(|r| (r.1[0].to_bits(), r.1[1].to_bits()))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    if nx >= 2 && ny >= 2 && nx * ny == rows.len() && pairs.len() == rows.len() {
        return Err(TextError::PointList {
            line: rows[0].0,
            nx,
            ny,
        });
    }
    Ok(())
}

pub(super) fn header_length(
    found: &Option<Found<String>>,
    key: &str,
    comma: bool,
) -> Result<Option<f64>, TextError> {
    match found {
        None => Ok(None),
        Some(f) => length_um(&f.value, comma)
            .map(Some)
            .ok_or_else(|| TextError::BadHeader {
                line: f.line,
                key: key.to_string(),
                value: f.value.clone(),
                expected: "a positive length with a unit (e.g. 12.5 µm)",
            }),
    }
}

/// The pitch the file gives, `(dx, dy)` in µm, for a matrix of `nx` x `ny`.
pub(super) fn file_pitch(
    p: &Parsed,
    nx: usize,
    ny: usize,
) -> Result<Option<(f64, f64)>, TextError> {
    let comma = p.header_comma;
    let px = header_length(&p.pitch_x, "Pitch x", comma)?;
    let py = header_length(&p.pitch_y, "Pitch y", comma)?;
    let w = header_length(&p.width, "Width", comma)?;
    let h = header_length(&p.height, "Height", comma)?;
    let px = px.or(w.map(|w| w / nx as f64));
    let py = py.or(h.map(|h| h / ny as f64));
    Ok(match (px, py) {
        (Some(x), Some(y)) => Some((x, y)),
        (Some(x), None) if ny == 1 => Some((x, x)),
        _ => None,
    })
}
