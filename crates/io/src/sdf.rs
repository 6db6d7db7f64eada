//! ISO 25178-71 surface data file (SDF) reader, text (`aISO-1.0`, `aISO-2.0`) and binary
//! (`bISO-1.0`, `bISO-2.0`).
//!
//! Conventions: `NumPoints` points per profile along X (the map's columns), `NumProfiles`
//! profiles along Y (rows), X fastest; `Xscale`, `Yscale` are the pitches in metres and a
//! height is `raw × Zscale` metres (converted here to micrometres). All three scales must
//! be finite and > 0 (a zero `Zscale` would make every height 0) and both counts > 0.
//! Non-finite values and the text token `BAD` (written by MountainsMap and sdfio for
//! non-measured points) are invalid points. The file holds one channel, `Z`.
//!
//! * Text: `key = value` header lines up to a line `*`, then the values (whitespace
//!   separated), then optionally `*` and a free-form trailer. Line endings may be `\n`,
//!   `\r\n` or `\r`. A header key given twice is an error (which one would be meant?).
//! * Binary: an 81-byte little-endian header — magic (8 bytes), `ManufacID` (10),
//!   `CreateDate` (12), `ModDate` (12), `NumPoints` (u16), `NumProfiles` (u16), `Xscale`,
//!   `Yscale`, `Zscale`, `Zresolution` (f64 each), `Compression`, `DataType`, `CheckType`
//!   (u8 each) — then the data. `DataType` codes: 0 u8, 1 u16, 2 u32, 3 f32, 4 i8, 5 i16,
//!   6 i32, 7 f64. `bISO-2.0` is read with the same header layout, and `aISO-2.0` with
//!   the `aISO-1.0` one. Compressed data (`Compression` ≠ 0) is not supported.

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::bytes::{f32_le, f64_le, i16_le, i32_le, u16_le, u32_le};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind, split_lines};
use crate::units::parse_scaled;

/// What is wrong with an SDF file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SdfError {
    /// The file ends before the header does.
    #[error("file ends inside the header: it has {found} bytes, the binary header needs {needed}")]
    TruncatedHeader {
        /// Bytes found.
        found: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// The magic is not one this reader knows.
    #[error(
        "unknown SDF version {0:?}: expected aISO-1.0, aISO-2.0, bISO-1.0 or bISO-2.0 \
         (the first 8 bytes of an ISO 25178-71 file)"
    )]
    Version(String),
    /// A required header field is missing.
    #[error("header field {0} is missing")]
    MissingField(&'static str),
    /// A header field is given more than once.
    #[error("header field {field} is given twice, on lines {first} and {second}")]
    DuplicateField {
        /// The field.
        field: String,
        /// 1-based line of the first occurrence.
        first: usize,
        /// 1-based line of the second.
        second: usize,
    },
    /// A header field has an unusable value.
    #[error("header field {field} = {value:?}: expected {expected}")]
    BadField {
        /// The field.
        field: String,
        /// The value found.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// A text header line is not `key = value`.
    #[error("line {line}: expected `key = value` or `*`, found {text:?}")]
    BadHeaderLine {
        /// 1-based line number.
        line: usize,
        /// The line.
        text: String,
    },
    /// A data value is not a number.
    #[error("line {line}: data value {token:?} is not a number (or BAD for a missing point)")]
    BadNumber {
        /// 1-based line number.
        line: usize,
        /// The token.
        token: String,
    },
    /// The data section holds the wrong number of values or bytes.
    #[error("data section has {found} {unit}, expected {expected} ({detail})")]
    DataLength {
        /// Values or bytes found.
        found: usize,
        /// Values or bytes expected.
        expected: usize,
        /// `"values"` or `"bytes"`.
        unit: &'static str,
        /// How the expectation was computed.
        detail: String,
    },
    /// A binary file ends before its data does.
    #[error(
        "file is truncated: it ends at byte {end}, but the data ({detail}) starts at byte \
         {start} and needs bytes up to {needed_end}"
    )]
    TruncatedData {
        /// File length in bytes.
        end: usize,
        /// Byte offset where the data starts.
        start: usize,
        /// Byte offset where the data would end.
        needed_end: u64,
        /// How the size was computed.
        detail: String,
    },
    /// The header's numbers do not make a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

fn bad_field(field: &str, value: String, expected: &'static str) -> SdfError {
    SdfError::BadField {
        field: field.to_string(),
        value,
        expected,
    }
}

/// A binary scale (f64 metres) times `10^shift`, finite and > 0.
fn scale_um(field: &'static str, value: f64, shift: i32) -> Result<f64, SdfError> {
    // Binary scales are already f64 metres; one multiplication is the best available.
    let um = if shift == 0 {
        value
    } else {
        value * 10f64.powi(shift)
    };
    if um.is_finite() && um > 0.0 {
        Ok(um)
    } else {
        Err(bad_field(
            field,
            value.to_string(),
            "a finite scale > 0 in metres",
        ))
    }
}

fn count_positive(field: &'static str, n: usize, value: &str) -> Result<usize, SdfError> {
    if n == 0 {
        return Err(bad_field(
            field,
            value.to_string(),
            "a positive integer (number of points)",
        ));
    }
    Ok(n)
}

/// Scores `bytes` as SDF: certain for an `aISO-`/`bISO-` magic (an unknown version is
/// then reported by the reader), likely for `aISO`/`bISO` alone.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.starts_with(b"aISO-") || bytes.starts_with(b"bISO-") {
        100
    } else if bytes.starts_with(b"aISO") || bytes.starts_with(b"bISO") {
        80
    } else {
        0
    }
}

/// Reads an SDF file held in memory (text or binary, chosen by the magic).
///
/// # Errors
/// [`SdfError`] naming the header field, line or data size at fault.
pub fn read_sdf_bytes(bytes: &[u8]) -> Result<HeightMap, SdfError> {
    read(bytes, &ReadOptions::default(), ValueKind::Height)
}

fn magic(bytes: &[u8]) -> String {
    String::from_utf8_lossy(&bytes[..bytes.len().min(8)]).into_owned()
}

/// Reads an SDF file held in memory: heights (`raw × Zscale` metres, in µm) or
/// intensities (`raw × Zscale` as stored). The pitch override of `options` is applied
/// by the caller; the file's scales are checked either way.
///
/// # Errors
/// [`SdfError`] naming the header field, line or data size at fault.
pub fn read(bytes: &[u8], _options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, SdfError> {
    let magic = magic(bytes);
    let z_shift = crate::reader::metre_shift(kind);
    match magic.as_str() {
        "aISO-1.0" | "aISO-2.0" => read_text(bytes, &magic, z_shift),
        "bISO-1.0" | "bISO-2.0" => read_binary(bytes, &magic, z_shift),
        _ => Err(SdfError::Version(magic)),
    }
}

/// The one channel of an SDF file (`Z`, unit `m`), from its header.
///
/// # Errors
/// As [`read`], for the header.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, SdfError> {
    let magic = magic(bytes);
    let h = match magic.as_str() {
        "aISO-1.0" | "aISO-2.0" => text_header(&String::from_utf8_lossy(bytes), 6)?.0,
        "bISO-1.0" | "bISO-2.0" => binary_header(bytes, 6)?,
        _ => return Err(SdfError::Version(magic)),
    };
    Ok(vec![Channel {
        name: "Z".into(),
        unit: Some("m".into()),
        nx: h.nx,
        ny: h.ny,
        pitch_um: Some((h.dx, h.dy)),
    }])
}

/// The checked numbers of an SDF header.
struct Header {
    nx: usize,
    ny: usize,
    dx: f64,
    dy: f64,
    zs: f64,
}

/// The header of a text SDF, its `key = value` pairs, and the lines after its `*`.
type TextHeader<'t> = (Header, Vec<(String, String)>, Vec<(usize, &'t str)>);

fn text_header(text: &str, z_shift: i32) -> Result<TextHeader<'_>, SdfError> {
    let mut lines = split_lines(text).enumerate().skip(1);
    let mut header: Vec<(String, String, usize)> = Vec::new();
    // Keys (lower case) with their line: a hash map, as a header may be long.
    let mut seen: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for (i, line) in lines.by_ref() {
        let line = line.trim();
        if line == "*" {
            break;
        }
        if line.is_empty() {
            continue;
        }
        let (k, v) = line
            .split_once('=')
            .ok_or_else(|| SdfError::BadHeaderLine {
                line: i + 1,
                text: line.to_string(),
            })?;
        let (k, v) = (k.trim(), v.trim());
        if let Some(first) = seen.insert(k.to_ascii_lowercase(), i + 1) {
            return Err(SdfError::DuplicateField {
                field: k.to_string(),
                first,
                second: i + 1,
            });
        }
        header.push((k.to_string(), v.to_string(), i + 1));
    }
    let get = |name: &'static str| {
        header
            .iter()
            .find(|(k, _, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v, _)| v.as_str())
            .ok_or(SdfError::MissingField(name))
    };
    let count = |name: &'static str| -> Result<usize, SdfError> {
        let v = get(name)?;
        let n = v
            .parse()
            .map_err(|_| bad_field(name, v.to_string(), "a positive integer (number of points)"))?;
        count_positive(name, n, v)
    };
    let scale = |name: &'static str, shift: i32| -> Result<f64, SdfError> {
        let v = get(name)?;
        parse_scaled(v, shift)
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| bad_field(name, v.to_string(), "a finite number > 0 in metres"))
    };
    let h = Header {
        nx: count("NumPoints")?,
        ny: count("NumProfiles")?,
        dx: scale("Xscale", 6)?,
        dy: scale("Yscale", 6)?,
        zs: scale("Zscale", z_shift)?,
    };
    if let Ok(c) = get("Compression")
        && c != "0"
    {
        return Err(bad_field("Compression", c.into(), "0 (uncompressed)"));
    }
    let pairs = header.into_iter().map(|(k, v, _)| (k, v)).collect();
    Ok((h, pairs, lines.map(|(i, l)| (i + 1, l)).collect()))
}

fn read_text(bytes: &[u8], magic: &str, z_shift: i32) -> Result<HeightMap, SdfError> {
    // The values are ASCII; free text in another encoding is kept as well as it goes.
    let text = String::from_utf8_lossy(bytes);
    let (h, header, rest) = text_header(&text, z_shift)?;
    let Header { nx, ny, dx, dy, zs } = h;
    let n = nx
        .checked_mul(ny)
        .ok_or(SdfError::Map(HeightMapError::TooLarge { nx, ny }))?;
    // Each value takes at least two bytes (a digit and a separator): no more room than
    // the file itself can fill is reserved, whatever the header claims.
    let mut z = Vec::with_capacity(n.min(bytes.len() / 2 + 1));
    let mut trailer = Vec::new();
    let mut in_trailer = false;
    for (line_no, line) in rest {
        if in_trailer {
            trailer.push(line.trim());
            continue;
        }
        if line.trim() == "*" {
            in_trailer = true;
            continue;
        }
        for token in line.split_whitespace() {
            let v: f64 = if token.eq_ignore_ascii_case("BAD") {
                f64::NAN
            } else {
                token.parse().map_err(|_| SdfError::BadNumber {
                    line: line_no,
                    token: token.to_string(),
                })?
            };
            if z.len() == n {
                return Err(SdfError::DataLength {
                    found: n + 1,
                    expected: n,
                    unit: "values",
                    detail: format!(
                        "NumPoints {nx} x NumProfiles {ny}; value {} is on line {line_no}",
                        n + 1
                    ),
                });
            }
            z.push(v * zs);
        }
    }
    if z.len() != n {
        return Err(SdfError::DataLength {
            found: z.len(),
            expected: n,
            unit: "values",
            detail: format!("NumPoints {nx} x NumProfiles {ny}"),
        });
    }
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(SdfError::Map)?;
    map.set_metadata("sdf.version", magic);
    for (k, v) in &header {
        map.set_metadata(format!("sdf.{k}"), v.as_str());
    }
    let trailer = trailer.join(" ").trim().to_string();
    if !trailer.is_empty() {
        map.set_metadata("sdf.trailer", trailer);
    }
    Ok(map)
}

const BIN_HEADER: usize = 81;

fn binary_header(bytes: &[u8], z_shift: i32) -> Result<Header, SdfError> {
    if bytes.len() < BIN_HEADER {
        return Err(SdfError::TruncatedHeader {
            found: bytes.len(),
            needed: BIN_HEADER,
        });
    }
    let u16_at = |a: usize| usize::from(u16_le(bytes, a));
    let (nx, ny) = (u16_at(42), u16_at(44));
    Ok(Header {
        nx: count_positive("NumPoints", nx, &nx.to_string())?,
        ny: count_positive("NumProfiles", ny, &ny.to_string())?,
        dx: scale_um("Xscale", f64_le(bytes, 46), 6)?,
        dy: scale_um("Yscale", f64_le(bytes, 54), 6)?,
        zs: scale_um("Zscale", f64_le(bytes, 62), z_shift)?,
    })
}

fn read_binary(bytes: &[u8], magic: &str, z_shift: i32) -> Result<HeightMap, SdfError> {
    let Header { nx, ny, dx, dy, zs } = binary_header(bytes, z_shift)?;
    let text = |a: usize, b: usize| {
        String::from_utf8_lossy(&bytes[a..b])
            .trim_end_matches(['\0', ' '])
            .to_string()
    };
    let manufacturer = text(8, 18);
    let created = text(18, 30);
    let modified = text(30, 42);
    let zres = f64_le(bytes, 70);
    let compression = bytes[78];
    let dtype = bytes[79];
    if compression != 0 {
        return Err(bad_field(
            "Compression",
            compression.to_string(),
            "0 (uncompressed)",
        ));
    }
    let width = match dtype {
        0 | 4 => 1,
        1 | 5 => 2,
        2 | 3 | 6 => 4,
        7 => 8,
        _ => {
            return Err(bad_field(
                "DataType",
                dtype.to_string(),
                "0..=7 (u8, u16, u32, f32, i8, i16, i32, f64)",
            ));
        }
    };
    // At most 65535² points of 8 bytes: no overflow in u64.
    let n = nx * ny;
    let need = n as u64 * width as u64;
    let data = &bytes[BIN_HEADER..];
    let detail = format!("NumPoints {nx} x NumProfiles {ny} x {width} bytes");
    // Extra bytes after the data may hold a trailer; fewer is an error.
    if (data.len() as u64) < need {
        return Err(SdfError::TruncatedData {
            end: bytes.len(),
            start: BIN_HEADER,
            needed_end: BIN_HEADER as u64 + need,
            detail,
        });
    }
    let z: Vec<f64> = data[..n * width]
        .chunks_exact(width)
        .map(|c| {
            let raw = match dtype {
                0 => f64::from(c[0]),
                4 => f64::from(c[0] as i8),
                1 => f64::from(u16_le(c, 0)),
                5 => f64::from(i16_le(c, 0)),
                2 => f64::from(u32_le(c, 0)),
                3 => f64::from(f32_le(c, 0)),
                6 => f64::from(i32_le(c, 0)),
                _ => f64_le(c, 0),
            };
            raw * zs
        })
        .collect();
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(SdfError::Map)?;
    map.set_metadata("sdf.version", magic);
    map.set_metadata("sdf.ManufacID", manufacturer);
    map.set_metadata("sdf.CreateDate", created);
    map.set_metadata("sdf.ModDate", modified);
    map.set_metadata("sdf.Zresolution", zres.to_string());
    map.set_metadata("sdf.DataType", dtype.to_string());
    Ok(map)
}

/// Why a map cannot be written as SDF.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SdfWriteError {
    /// The binary header stores the counts as u16.
    #[error(
        "{nx} x {ny} points do not fit the binary SDF header (NumPoints and NumProfiles \
         are 16-bit, at most 65535); write the text form (aISO-1.0) instead"
    )]
    TooLarge {
        /// Columns.
        nx: usize,
        /// Rows.
        ny: usize,
    },
}

/// The `key = value` header lines both writers share, from the map's `sdf.*` metadata
/// where it has them (a file read from SDF keeps its ManufacID and dates).
/// Without one, `ManufacID` and `CreateDate` come from what the map's metadata says of
/// another format's file ([`crate::provenance`]).
fn field(map: &HeightMap, key: &str, default: &str, width: usize) -> String {
    let carried = || {
        let p = crate::provenance::Provenance::of(map);
        match key {
            "ManufacID" => p.manufacturer,
            "CreateDate" => p.sdf_date(),
            _ => None,
        }
    };
    let v = map
        .metadata()
        .get(&format!("sdf.{key}"))
        .cloned()
        .or_else(carried)
        .unwrap_or_else(|| default.to_string());
    v.chars()
        .filter(|c| c.is_ascii_graphic())
        .take(width)
        .collect()
}

/// Writes `map` as a text SDF (`aISO-1.0`, ISO 25178-71): pitches and heights as the
/// shortest decimals that read back to the same `f64` (µm, with `Xscale`, `Yscale`
/// written as `<µm>e-6` metres and `Zscale = 1e-6` for heights, 1 for intensities), so
/// that [`read`] returns exactly the map written; invalid points are written `BAD`. An
/// intensity image gets the trailer line [`crate::quantity::SDF_INTENSITY_LINE`].
#[must_use]
pub fn write_sdf_text(map: &HeightMap, kind: ValueKind) -> String {
    use std::fmt::Write as _;
    let mut s = String::with_capacity(64 * 8 + map.len() * 12);
    s.push_str("aISO-1.0\n");
    let _ = writeln!(
        s,
        "ManufacID   = {}",
        field(
            map,
            "ManufacID",
            crate::provenance::SDF_DEFAULT_MANUFACTURER,
            10
        )
    );
    let _ = writeln!(
        s,
        "CreateDate  = {}",
        field(map, "CreateDate", "010119700000", 12)
    );
    let _ = writeln!(
        s,
        "ModDate     = {}",
        field(map, "ModDate", "010119700000", 12)
    );
    let _ = writeln!(s, "NumPoints   = {}", map.nx());
    let _ = writeln!(s, "NumProfiles = {}", map.ny());
    let _ = writeln!(s, "Xscale      = {}e-6", map.dx());
    let _ = writeln!(s, "Yscale      = {}e-6", map.dy());
    let zscale = match kind {
        ValueKind::Height => "1e-6",
        ValueKind::Intensity => "1",
    };
    let _ = writeln!(s, "Zscale      = {zscale}");
    s.push_str("Zresolution = -1\nCompression = 0\nDataType    = 7\nCheckType   = 0\n*\n");
    for row in 0..map.ny() {
        for col in 0..map.nx() {
            if col > 0 {
                s.push(' ');
            }
            match map.get(col, row) {
                Some(z) => {
                    let _ = write!(s, "{z}");
                }
                None => s.push_str("BAD"),
            }
        }
        s.push('\n');
    }
    s.push_str("*\n");
    if kind == ValueKind::Intensity {
        // The trailer says what the values are (crate::quantity).
        s.push_str(crate::quantity::SDF_INTENSITY_LINE);
        s.push('\n');
    }
    s
}

/// Writes `map` as a binary SDF (`bISO-1.0`, ISO 25178-71): the 81-byte little-endian
/// header, then float64 values (`DataType` 7), heights in µm with `Zscale = 1e-6` m
/// (intensities with 1), invalid points as NaN. The scales are binary f64 metres, so the
/// pitch read back is `(dx × 1e-6) × 1e6`, within one unit in the last place of the
/// pitch written; heights are exact (1e-6 × 1e6 is exactly 1 in f64). Use
/// [`write_sdf_text`] for an exact pitch.
///
/// # Errors
/// [`SdfWriteError::TooLarge`] above 65535 points per axis.
pub fn write_sdf_binary(map: &HeightMap, kind: ValueKind) -> Result<Vec<u8>, SdfWriteError> {
    let (nx, ny) = (map.nx(), map.ny());
    let (Ok(px), Ok(py)) = (u16::try_from(nx), u16::try_from(ny)) else {
        return Err(SdfWriteError::TooLarge { nx, ny });
    };
    let mut b = Vec::with_capacity(BIN_HEADER + 8 * map.len());
    b.extend_from_slice(b"bISO-1.0");
    let fixed = |s: String, n: usize| {
        let mut v = s.into_bytes();
        v.resize(n, 0);
        v
    };
    b.extend(fixed(
        field(
            map,
            "ManufacID",
            crate::provenance::SDF_DEFAULT_MANUFACTURER,
            10,
        ),
        10,
    ));
    b.extend(fixed(field(map, "CreateDate", "010119700000", 12), 12));
    b.extend(fixed(field(map, "ModDate", "010119700000", 12), 12));
    b.extend_from_slice(&px.to_le_bytes());
    b.extend_from_slice(&py.to_le_bytes());
    let zscale = match kind {
        ValueKind::Height => 1e-6,
        ValueKind::Intensity => 1.0,
    };
    for v in [map.dx() * 1e-6, map.dy() * 1e-6, zscale, -1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&[0, 7, 0]);
    debug_assert_eq!(b.len(), BIN_HEADER);
    for row in 0..ny {
        for col in 0..nx {
            b.extend_from_slice(&map.get(col, row).unwrap_or(f64::NAN).to_le_bytes());
        }
    }
    if kind == ValueKind::Intensity {
        // A trailer after the data says what the values are (crate::quantity).
        b.extend_from_slice(crate::quantity::SDF_INTENSITY_LINE.as_bytes());
        b.push(b'\n');
    }
    Ok(b)
}
