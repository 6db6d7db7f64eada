//! ISO 25178-71 surface data file (SDF) reader, text (`aISO-1.0`) and binary
//! (`bISO-1.0`, `bISO-2.0`).
//!
//! Conventions: `NumPoints` points per profile along X (the map's columns), `NumProfiles`
//! profiles along Y (rows), X fastest; `Xscale`, `Yscale` are the pitches in metres and a
//! height is `raw × Zscale` metres (converted here to micrometres). Non-finite values are
//! invalid points.
//!
//! * Text: `key = value` header lines up to a line `*`, then the values (whitespace
//!   separated), then optionally `*` and a free-form trailer.
//! * Binary: an 81-byte little-endian header — magic (8 bytes), `ManufacID` (10),
//!   `CreateDate` (12), `ModDate` (12), `NumPoints` (u16), `NumProfiles` (u16), `Xscale`,
//!   `Yscale`, `Zscale`, `Zresolution` (f64 each), `Compression`, `DataType`, `CheckType`
//!   (u8 each) — then the data. `DataType` codes: 0 u8, 1 u16, 2 u32, 3 f32, 4 i8, 5 i16,
//!   6 i32, 7 f64. `bISO-2.0` is read with the same header layout. Compressed data
//!   (`Compression` ≠ 0) is not supported.

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::units::parse_scaled;

/// What is wrong with an SDF file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SdfError {
    /// The file ends before the header does.
    #[error("file ends inside the header ({found} bytes, the binary header needs {needed})")]
    TruncatedHeader {
        /// Bytes found.
        found: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// The magic is not one this reader knows.
    #[error("unknown SDF version {0:?}: expected aISO-1.0, bISO-1.0 or bISO-2.0")]
    Version(String),
    /// A required header field is missing.
    #[error("header field {0} is missing")]
    MissingField(&'static str),
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
    #[error("line {line}: data value {token:?} is not a number")]
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
    /// The header's numbers do not make a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

fn scale_um(field: &'static str, value: f64, shift: i32) -> Result<f64, SdfError> {
    // Binary scales are already f64 metres; one multiplication is the best available.
    let um = if shift == 0 {
        value
    } else {
        value * 10f64.powi(shift)
    };
    if um.is_finite() {
        Ok(um)
    } else {
        Err(SdfError::BadField {
            field: field.to_string(),
            value: value.to_string(),
            expected: "a finite scale in metres",
        })
    }
}

/// Reads an SDF file held in memory (text or binary, chosen by the magic).
///
/// # Errors
/// [`SdfError`] naming the header field, line or data size at fault.
pub fn read_sdf_bytes(bytes: &[u8]) -> Result<HeightMap, SdfError> {
    read_sdf_scaled(bytes, 6)
}

/// As [`read_sdf_bytes`] with Z values `raw × Zscale` multiplied by `10^z_shift` (6 for
/// µm heights, 0 for values as stored).
pub(crate) fn read_sdf_scaled(bytes: &[u8], z_shift: i32) -> Result<HeightMap, SdfError> {
    let magic = String::from_utf8_lossy(&bytes[..bytes.len().min(8)]).into_owned();
    match magic.as_str() {
        "aISO-1.0" => read_text(bytes, z_shift),
        "bISO-1.0" | "bISO-2.0" => read_binary(bytes, &magic, z_shift),
        _ => Err(SdfError::Version(magic)),
    }
}

fn read_text(bytes: &[u8], z_shift: i32) -> Result<HeightMap, SdfError> {
    let text = String::from_utf8_lossy(bytes);
    let mut lines = text.lines().enumerate().skip(1);
    let mut header: Vec<(String, String)> = Vec::new();
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
        header.push((k.trim().to_string(), v.trim().to_string()));
    }
    let get = |name: &'static str| {
        header
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
            .ok_or(SdfError::MissingField(name))
    };
    let count = |name: &'static str| -> Result<usize, SdfError> {
        let v = get(name)?;
        v.parse().map_err(|_| SdfError::BadField {
            field: name.to_string(),
            value: v.to_string(),
            expected: "a non-negative integer",
        })
    };
    let scale = |name: &'static str, shift: i32| -> Result<f64, SdfError> {
        let v = get(name)?;
        parse_scaled(v, shift)
            .filter(|x| x.is_finite())
            .ok_or_else(|| SdfError::BadField {
                field: name.to_string(),
                value: v.to_string(),
                expected: "a finite number in metres",
            })
    };
    let nx = count("NumPoints")?;
    let ny = count("NumProfiles")?;
    let dx = scale("Xscale", 6)?;
    let dy = scale("Yscale", 6)?;
    let zs = scale("Zscale", z_shift)?;
    if let Ok(c) = get("Compression")
        && c != "0"
    {
        return Err(SdfError::BadField {
            field: "Compression".into(),
            value: c.into(),
            expected: "0 (uncompressed)",
        });
    }
    let n = nx
        .checked_mul(ny)
        .ok_or(SdfError::Map(HeightMapError::TooLarge { nx, ny }))?;

    let mut z = Vec::with_capacity(n.min(1 << 24));
    let mut trailer = Vec::new();
    let mut in_trailer = false;
    for (i, line) in lines {
        if in_trailer {
            trailer.push(line.trim());
            continue;
        }
        if line.trim() == "*" {
            in_trailer = true;
            continue;
        }
        for token in line.split_whitespace() {
            let v: f64 = token.parse().map_err(|_| SdfError::BadNumber {
                line: i + 1,
                token: token.to_string(),
            })?;
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
    map.set_metadata("sdf.version", "aISO-1.0");
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

fn read_binary(bytes: &[u8], magic: &str, z_shift: i32) -> Result<HeightMap, SdfError> {
    if bytes.len() < BIN_HEADER {
        return Err(SdfError::TruncatedHeader {
            found: bytes.len(),
            needed: BIN_HEADER,
        });
    }
    let text = |a: usize, b: usize| {
        String::from_utf8_lossy(&bytes[a..b])
            .trim_end_matches(['\0', ' '])
            .to_string()
    };
    let u16_at = |a: usize| usize::from(u16::from_le_bytes([bytes[a], bytes[a + 1]]));
    let f64_at = |a: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[a..a + 8]);
        f64::from_le_bytes(b)
    };
    let manufacturer = text(8, 18);
    let created = text(18, 30);
    let modified = text(30, 42);
    let nx = u16_at(42);
    let ny = u16_at(44);
    let dx = scale_um("Xscale", f64_at(46), 6)?;
    let dy = scale_um("Yscale", f64_at(54), 6)?;
    let zs = scale_um("Zscale", f64_at(62), z_shift)?;
    let zres = f64_at(70);
    let compression = bytes[78];
    let dtype = bytes[79];
    if compression != 0 {
        return Err(SdfError::BadField {
            field: "Compression".into(),
            value: compression.to_string(),
            expected: "0 (uncompressed)",
        });
    }
    let width = match dtype {
        0 | 4 => 1,
        1 | 5 => 2,
        2 | 3 | 6 => 4,
        7 => 8,
        _ => {
            return Err(SdfError::BadField {
                field: "DataType".into(),
                value: dtype.to_string(),
                expected: "0..=7 (u8, u16, u32, f32, i8, i16, i32, f64)",
            });
        }
    };
    let n = nx * ny;
    let data = &bytes[BIN_HEADER..];
    // Extra bytes after the data may hold a trailer; fewer is an error.
    if data.len() < n * width {
        return Err(SdfError::DataLength {
            found: data.len(),
            expected: n * width,
            unit: "bytes",
            detail: format!("NumPoints {nx} x NumProfiles {ny} x {width} bytes"),
        });
    }
    let z: Vec<f64> = data[..n * width]
        .chunks_exact(width)
        .map(|c| {
            let raw = match dtype {
                0 => f64::from(c[0]),
                4 => f64::from(c[0] as i8),
                1 => f64::from(u16::from_le_bytes([c[0], c[1]])),
                5 => f64::from(i16::from_le_bytes([c[0], c[1]])),
                2 => f64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]])),
                3 => f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
                6 => f64::from(i32::from_le_bytes([c[0], c[1], c[2], c[3]])),
                _ => f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]),
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
