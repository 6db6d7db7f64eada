//! Plain-text height matrices: one row of the map per line, values separated by
//! whitespace, commas or semicolons; `NaN` (or any non-finite value) marks an invalid point.
//!
//! Conventions: the first data line is row 0 (`y = 0`), the first value of a line is column
//! 0 (`x = 0`). Lines end in `\n`, `\r\n` or a lone `\r`. The text is UTF-8 (a byte-order
//! mark is skipped), UTF-16 with a byte-order mark, or else read as Latin-1 (Windows
//! exports of `Höhe` and `µm`); `text.encoding` says which. Leading `#` lines are a header
//! in Gwyddion's style, `# Key: value`, with English or German keys:
//! * `Width`/`Breite` and `Height`/`Höhe`: the physical size of the whole image with a
//!   unit (`12.34 µm`); the pitch is `width / nx`, `height / ny` (Gwyddion's convention).
//! * `Pitch x`, `Pitch y` (written by this crate): the pitch itself, which reproduces it
//!   exactly; these take precedence over width and height.
//! * `Value units`/`Z units`/`Werteinheiten`: the unit of the values (`m`, `mm`, `µm`, `nm`).
//!
//! A file that carries no pitch needs [`ReadOptions::pixel_um`]; a height map that
//! carries no length unit needs [`ReadOptions::z_unit`] (the command line's `--pixel-um`
//! and `--z-unit`). Nothing is silently assumed. Intensity images need no unit: any
//! `Value units` (`a.u.`, empty) is recorded in `text.value_units` and the numbers are
//! taken as they are.
//!
//! **Decimal marks** ([`ReadOptions::decimal`]). German exports write `1,5` for 1.5, with
//! whitespace or `;` between values. With [`DecimalMark::Auto`] the reader decides from
//! the whole data section: `;` between values with commas inside them, or several
//! whitespace-separated values of the form `1,5` on a line, mean decimal commas; a `.`
//! in a number, or commas next to spaces (`1, 2`), mean decimal points with commas as
//! separators. When the content allows both readings (every line one token `10,20`, or
//! both kinds of evidence) it refuses, naming `--decimal-comma`; with an explicit mark it
//! refuses content that contradicts it. `text.decimal_mark` records what was used and
//! why. An empty value between two separators (`1,,3`) is an error, not a dropped column.
//!
//! A two-column table whose first line names an `x` column (`X_(microns),y1`) is read as a
//! single profile (`ny = 1`): the second column holds the heights and the pitch is the
//! mean spacing of the `x` column, whose unit is taken from its name.

use std::borrow::Cow;

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::reader::{Channel, Confidence, DecimalMark, ReadOptions, ValueKind, split_lines};
use crate::units::{length_unit_exponent, parse_scaled};

/// What is wrong with a plain-text height matrix.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TextError {
    /// The file is empty or holds only header lines.
    #[error("no data rows found")]
    Empty,
    /// The file contains bytes that do not occur in text.
    #[error(
        "byte {offset} is 0x{byte:02x}, which does not occur in text: binary content, not a \
         text matrix"
    )]
    Binary {
        /// Offset of the first such byte.
        offset: usize,
        /// The byte.
        byte: u8,
    },
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
    /// Two separators with nothing between them.
    #[error(
        "line {line}, column {column}: empty value between two separators (write NaN for a \
         missing point)"
    )]
    EmptyValue {
        /// 1-based line number.
        line: usize,
        /// 1-based column of the missing value.
        column: usize,
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
    #[error("line {line}: header {key:?} = {value:?}: expected {expected}")]
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
    /// The same header key is given twice.
    #[error("header {key:?} is given twice, on lines {first} and {second}")]
    DuplicateHeader {
        /// The key.
        key: String,
        /// 1-based line of the first.
        first: usize,
        /// 1-based line of the second.
        second: usize,
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
    /// The file's value unit is not a length, and the map is read as heights.
    #[error(
        "line {line}: the values' unit is {unit:?}, not a length: a height map needs a \
         length unit (m, mm, µm, nm, pm); if the values are heights, give their unit \
         (option z_unit, `--z-unit um|nm|m` on the command line)"
    )]
    NotALength {
        /// 1-based line of the unit header.
        line: usize,
        /// The unit the file gives.
        unit: String,
    },
    /// The decimal mark cannot be decided from the content.
    #[error(
        "line {line}: {token:?} can be read with a decimal comma or as numbers separated by \
         commas, and the file does not settle which ({why}); say which: option decimal, \
         `--decimal-comma` (or `--decimal-point`) on the command line"
    )]
    AmbiguousDecimal {
        /// 1-based line of the first ambiguous token.
        line: usize,
        /// The token.
        token: String,
        /// Why the content does not decide it.
        why: &'static str,
    },
    /// The content contradicts the decimal mark that was asked for.
    #[error("line {line}: {token:?} contradicts the decimal {mark} asked for: {why}")]
    DecimalContradiction {
        /// 1-based line.
        line: usize,
        /// The token.
        token: String,
        /// `comma` or `point`.
        mark: &'static str,
        /// What the content shows instead.
        why: &'static str,
    },
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
    /// The three columns are a list of `x y z` points on a grid, not a height matrix.
    #[error(
        "line {line}: the 3 columns look like an x, y, z point list ({nx} x values times {ny} y \
         values, one row each), not a height matrix with 3 columns; point lists are not \
         read: export the map as a matrix (one row of heights per line)"
    )]
    PointList {
        /// 1-based line of the first data row.
        line: usize,
        /// Distinct values of the first column.
        nx: usize,
        /// Distinct values of the second column.
        ny: usize,
    },
    /// The profile's `x` column does not increase.
    #[error(
        "line {line}: the x column must increase from row to row (it runs from {first} to {last})"
    )]
    ProfileNotIncreasing {
        /// 1-based line of the first data row.
        line: usize,
        /// First x value.
        first: f64,
        /// Last x value.
        last: f64,
    },
    /// The numbers do not make a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

/// Whether a byte can occur in a text file (anything but C0 controls other than tab,
/// line feed, form feed and carriage return, and DEL).
fn text_byte(b: u8) -> bool {
    !(b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0c) || b == 0x7f)
}

fn utf16_bom(bytes: &[u8]) -> Option<bool> {
    if bytes.starts_with(&[0xff, 0xfe]) {
        Some(true)
    } else if bytes.starts_with(&[0xfe, 0xff]) {
        Some(false)
    } else {
        None
    }
}

/// Scores `bytes` as a text matrix: low (20), as the format of last resort, when every
/// byte can occur in text (or the file is UTF-16 with a byte-order mark); 0 otherwise.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.is_empty() {
        return 0;
    }
    if utf16_bom(bytes).is_some() {
        return 20;
    }
    if bytes.iter().all(|&b| text_byte(b)) {
        20
    } else {
        0
    }
}

/// The text and the encoding it was decoded from.
pub(crate) fn decode(bytes: &[u8]) -> Result<(Cow<'_, str>, &'static str), TextError> {
    if let Some(little) = utf16_bom(bytes) {
        let units: Vec<u16> = bytes[2..]
            .chunks(2)
            .map(|c| {
                let pair = [c[0], *c.get(1).unwrap_or(&0)];
                if little {
                    u16::from_le_bytes(pair)
                } else {
                    u16::from_be_bytes(pair)
                }
            })
            .collect();
        let text = String::from_utf16_lossy(&units);
        let name = if little { "UTF-16LE" } else { "UTF-16BE" };
        return Ok((Cow::Owned(text), name));
    }
    if let Some(offset) = bytes.iter().position(|&b| !text_byte(b)) {
        return Err(TextError::Binary {
            offset,
            byte: bytes[offset],
        });
    }
    match std::str::from_utf8(bytes) {
        Ok(s) => Ok((
            Cow::Borrowed(s.strip_prefix('\u{feff}').unwrap_or(s)),
            "UTF-8",
        )),
        // Not UTF-8: Latin-1, where every byte is the code point of the same number.
        Err(_) => Ok((
            Cow::Owned(bytes.iter().map(|&b| char::from(b)).collect()),
            "Latin-1",
        )),
    }
}

/// A number as written in the file, with a decimal comma when `comma`.
fn parse_number(token: &str, comma: bool) -> Option<f64> {
    if comma {
        if token.contains('.') {
            return None;
        }
        token.replacen(',', ".", 1).parse().ok()
    } else {
        token.parse().ok()
    }
}

/// `"12.34 µm"` (or `"12,34 µm"` when `comma`) → 12.34 in µm (exactly rounded).
fn length_um(value: &str, comma: bool) -> Option<f64> {
    let mut parts = value.split_whitespace();
    let number = parts.next()?;
    let unit = parts.next()?;
    if parts.next().is_some() {
        return None;
    }
    let number: Cow<str> = if comma && !number.contains('.') && number.matches(',').count() == 1 {
        Cow::Owned(number.replace(',', "."))
    } else {
        Cow::Borrowed(number)
    };
    parse_scaled(&number, length_unit_exponent(unit)?).filter(|v| v.is_finite() && *v > 0.0)
}

/// Splits a data line into its values. `commas_separate`: commas are separators (decimal
/// points); otherwise only whitespace and `;` separate. An explicit separator followed
/// by nothing but another separator is an empty value (`Err(column)`); one at the end
/// of the line is allowed (spreadsheets write them).
fn fields(line: &str, commas_separate: bool) -> Result<Vec<&str>, usize> {
    let is_sep = |c: char| c == ';' || (commas_separate && c == ',');
    let parts: Vec<&str> = line.split(is_sep).collect();
    let mut out = Vec::new();
    let last = parts.len() - 1;
    for (k, part) in parts.iter().enumerate() {
        let before = out.len();
        out.extend(part.split_whitespace());
        if out.len() == before && parts.len() > 1 && k != last {
            return Err(out.len() + 1);
        }
    }
    Ok(out)
}

/// `[+-]digits` (at least one digit).
fn is_int(s: &str) -> bool {
    let d = s.strip_prefix(['+', '-']).unwrap_or(s);
    !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit())
}

/// `digits[e[+-]digits]`.
fn is_fraction(s: &str) -> bool {
    let (digits, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    };
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) && exp.is_none_or(is_int)
}

/// `1,5`, `-0,25`, `1,5e-3`: a number with one decimal comma.
fn is_comma_decimal(token: &str) -> bool {
    match token.split_once(',') {
        Some((a, b)) => is_int(a) && is_fraction(b),
        None => false,
    }
}

/// How the decimal mark was decided, for the metadata.
struct Decision {
    comma: bool,
    how: &'static str,
}

/// Decides the decimal mark from the data lines (after any profile header).
fn decide_decimal(lines: &[(usize, &str)], mark: DecimalMark) -> Result<Decision, TextError> {
    let semicolons = lines.iter().any(|(_, l)| l.contains(';'));
    // Evidence, each with its first occurrence (line, token).
    let mut comma_decimal: Option<(usize, &str)> = None; // `1,5` inside a value
    let mut multi_on_line = false; // a line with `1,5` among several values
    let mut separator: Option<(usize, &str, &'static str)> = None; // commas separating
    let mut point: Option<(usize, &str)> = None; // `1.5`
    let mut mixed: Option<(usize, &str, bool)> = None; // `1.000,5` (, several on the line)
    let mut any_comma: Option<(usize, &str)> = None;
    for &(no, line) in lines {
        let tokens: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ';')
            .filter(|t| !t.is_empty())
            .collect();
        for &t in &tokens {
            if t.contains('.') && point.is_none() {
                point = Some((no, t));
            }
            let commas = t.matches(',').count();
            if commas == 0 {
                continue;
            }
            any_comma.get_or_insert((no, t));
            if t.contains('.') {
                if mixed.is_none_or(|m| !m.2 && tokens.len() > 1) {
                    mixed = Some((no, t, tokens.len() > 1));
                }
            } else if is_comma_decimal(t) {
                comma_decimal.get_or_insert((no, t));
                if tokens.len() > 1 {
                    multi_on_line = true;
                }
            } else if t.starts_with(',') || t.ends_with(',') {
                separator.get_or_insert((no, t, "a comma next to a space separates values"));
            } else if commas > 1 {
                separator.get_or_insert((no, t, "more than one comma in a value"));
            }
        }
    }
    let ambiguous = |(line, token): (usize, &str), why| {
        Err(TextError::AmbiguousDecimal {
            line,
            token: token.into(),
            why,
        })
    };
    match mark {
        DecimalMark::Comma => {
            if let Some((line, token)) = point {
                return Err(TextError::DecimalContradiction {
                    line,
                    token: token.into(),
                    mark: "comma",
                    why: "it has a decimal point",
                });
            }
            if let Some((line, token, why)) = separator {
                return Err(TextError::DecimalContradiction {
                    line,
                    token: token.into(),
                    mark: "comma",
                    why,
                });
            }
            Ok(Decision {
                comma: true,
                how: "comma (option)",
            })
        }
        DecimalMark::Point => {
            if semicolons && let Some((line, token)) = any_comma {
                return Err(TextError::DecimalContradiction {
                    line,
                    token: token.into(),
                    mark: "point",
                    why: "values are separated by `;` and this one holds a comma",
                });
            }
            Ok(Decision {
                comma: false,
                how: "point (option)",
            })
        }
        DecimalMark::Auto if semicolons => {
            if let Some((line, token, _)) = mixed {
                return ambiguous(
                    (line, token),
                    "values are separated by `;` and some hold both `.` and `,`",
                );
            }
            if let Some((line, token, _)) = separator {
                return ambiguous(
                    (line, token),
                    "values are separated by `;` and some hold commas that look like separators",
                );
            }
            Ok(if comma_decimal.is_some() {
                Decision {
                    comma: true,
                    how: "comma (detected: `;` separates values)",
                }
            } else {
                Decision {
                    comma: false,
                    how: "point (detected)",
                }
            })
        }
        DecimalMark::Auto => {
            if let Some((line, token, true)) = mixed {
                return ambiguous(
                    (line, token),
                    "whitespace separates values and some hold both `.` and `,`",
                );
            }
            let Some(first) = comma_decimal else {
                return Ok(Decision {
                    comma: false,
                    how: "point (detected)",
                });
            };
            if point.is_some() {
                if multi_on_line {
                    return ambiguous(
                        first,
                        "some values have a decimal point, others look like decimal commas",
                    );
                }
                // `1.5,2.5` and `3,4`: decimal points, so commas separate.
                return Ok(Decision {
                    comma: false,
                    how: "point (detected: `.` in numbers, commas separate values)",
                });
            }
            if separator.is_some() {
                return ambiguous(first, "other lines use commas to separate values");
            }
            if multi_on_line {
                return Ok(Decision {
                    comma: true,
                    how: "comma (detected: whitespace separates values like `1,5`)",
                });
            }
            ambiguous(first, "every line holds a single token")
        }
    }
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

/// A header value as found, with its line.
#[derive(Clone)]
struct Found<T> {
    line: usize,
    value: T,
}

/// A parsed file before calibration: header, decimal decision and numbers.
struct Parsed {
    width: Option<Found<String>>,
    height: Option<Found<String>>,
    pitch_x: Option<Found<String>>,
    pitch_y: Option<Found<String>>,
    value_unit: Option<Found<String>>,
    channel: Option<String>,
    meta: Vec<(String, String)>,
    /// `(header line, x column name)` of a profile table.
    profile: Option<(usize, String)>,
    /// `(line, values)` per data row.
    rows: Vec<(usize, Vec<f64>)>,
    columns: usize,
    comma: bool,
    /// Header lengths may be written with a decimal comma (unless decimal points were
    /// asked for): `12,34 µm` cannot be two numbers.
    header_comma: bool,
}

fn parse(bytes: &[u8], options: &ReadOptions) -> Result<Parsed, TextError> {
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
fn point_list_check(rows: &[(usize, Vec<f64>)]) -> Result<(), TextError> {
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

fn header_length(
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
fn file_pitch(p: &Parsed, nx: usize, ny: usize) -> Result<Option<(f64, f64)>, TextError> {
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

/// The channel of a text matrix: its `Channel` header (or `values`), the `Value units`
/// it declares, its size and, if the header gives it, its pitch.
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault.
pub fn channels(bytes: &[u8], options: &ReadOptions) -> Result<Vec<Channel>, TextError> {
    let p = parse(bytes, options)?;
    let (nx, ny) = if p.profile.is_some() {
        (p.rows.len(), 1)
    } else {
        (p.columns, p.rows.len())
    };
    let pitch_um = if p.profile.is_some() {
        None
    } else {
        file_pitch(&p, nx, ny)?
    };
    Ok(vec![Channel {
        name: p.channel.clone().unwrap_or_else(|| "values".into()),
        unit: p.value_unit.as_ref().map(|f| f.value.clone()),
        nx,
        ny,
        pitch_um,
    }])
}

/// Reads a plain-text matrix held in memory as heights (µm).
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault, or the missing calibration.
pub fn read_text_bytes(bytes: &[u8], options: &ReadOptions) -> Result<HeightMap, TextError> {
    read(bytes, options, ValueKind::Height)
}

/// Reads a plain-text matrix held in memory: heights (converted to µm from the unit the
/// file or `options.z_unit` gives) or intensities (the numbers as written).
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault, or the missing calibration.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, TextError> {
    let mut p = parse(bytes, options)?;
    let z_exp = match kind {
        ValueKind::Intensity => 0,
        ValueKind::Height => match (options.z_unit, &p.value_unit) {
            (Some(u), _) => u.exponent_to_um(),
            (None, Some(f)) => length_unit_exponent(&f.value).ok_or_else(|| {
                if f.value.is_empty() {
                    TextError::MissingZUnit
                } else {
                    TextError::NotALength {
                        line: f.line,
                        unit: f.value.clone(),
                    }
                }
            })?,
            (None, None) => return Err(TextError::MissingZUnit),
        },
    };
    if let Some(f) = &p.value_unit {
        p.meta.push(("text.value_units".into(), f.value.clone()));
    }
    let z_factor = 10f64.powi(z_exp);

    let rows = std::mem::take(&mut p.rows);
    if p.profile.is_none() {
        point_list_check(&rows)?;
    }
    let (nx, ny, z, pitch) = if let Some((header_line, x_name)) = &p.profile {
        let xs: Vec<f64> = rows.iter().map(|r| r.1[0]).collect();
        let z: Vec<f64> = rows.iter().map(|r| r.1[1] * z_factor).collect();
        let n = xs.len();
        let pitch = if n >= 2 {
            let mean = (xs[n - 1] - xs[0]) / (n - 1) as f64;
            if !(mean.is_finite() && mean > 0.0) {
                return Err(TextError::ProfileNotIncreasing {
                    line: rows[0].0,
                    first: xs[0],
                    last: xs[n - 1],
                });
            }
            for (k, w) in xs.windows(2).enumerate() {
                let step = w[1] - w[0];
                // Tolerate rounding of printed coordinates (5 % of the step).
                let even = (step - mean).abs() <= 0.05 * mean.abs();
                if !even {
                    return Err(TextError::UnevenProfile {
                        line: rows.get(k + 1).map_or(header_line + k + 2, |r| r.0),
                        step,
                        mean,
                    });
                }
            }
            unit_from_name(x_name)
                .map(|e| mean * 10f64.powi(e))
                .filter(|p| p.is_finite() && *p > 0.0)
        } else {
            None
        };
        (n, 1, z, pitch.map(|p| (p, p)))
    } else {
        let (nx, ny) = (p.columns, rows.len());
        let pitch = file_pitch(&p, nx, ny)?;
        let z: Vec<f64> = rows
            .into_iter()
            .flat_map(|(_, r)| r)
            .map(|v| v * z_factor)
            .collect();
        (nx, ny, z, pitch)
    };

    let (dx, dy) = match (options.pixel_um, pitch) {
        (Some(p), _) | (None, Some(p)) => p,
        (None, None) => return Err(TextError::MissingPitch),
    };
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(TextError::Map)?;
    for (k, v) in p.meta {
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
