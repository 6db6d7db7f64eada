//! Wyko / Bruker Vision OPD (`.opd`) reader: white-light interferometer maps.
//!
//! Layout (little-endian; as the independent readers Gwyddion `opdfile.c` and
//! SurfaceTopography `OPD.py` describe it, checked on `opd-1.opd`): a 2-byte prelude,
//! then a directory of 24-byte block headers — name (16 bytes, NUL-padded), type (i16),
//! length (i32), attribute (u16) — whose first entry is `Directory` itself with the
//! directory's total length. The blocks' payloads follow the directory in the same order,
//! each `length` bytes. Block types: 3 array, 5 text, 6 short (i16, or i32 when 4 bytes
//! long), 7 float (f32, or i16 when 2 bytes), 8 double, 12 long (i32); others skipped.
//!
//! An array payload is `nx`, `ny`, item size (u16 each; 1 = u8, 2 = i16, 4 = f32), then
//! `nx × ny` items with y fastest and y reversed (item `x · ny + (ny − 1 − y)` is the
//! point at column x, row y).
//!
//! Conventions: the height arrays are those named `RAW DATA`, `RAW_DATA`, `OPD`, `Raw`
//! or `SAMPLE_DATA`; their values are in waves: height = value × `Wavelength` (nm) /
//! `Mult` (default 1). Pitch: `Pixel_size` (mm) in x, `Pixel_size × Aspect` (default 1)
//! in y. Invalid points: i16 values ≥ 32766, f32 values ≥ 1e38 or non-finite; u8 arrays
//! have none. Channels: every array, the height arrays first, then the others (e.g.
//! `Image`, read as intensity: values as stored). Metadata `opd.*`: date, time,
//! wavelength, magnification, and the other scalar blocks.

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::{f32_le, f64_le, i16_le, i32_le, u16_le};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};

/// What is wrong with a OPD file: the binary readers' one error type.
pub type OpdError = crate::format_error::FormatError;

const HEIGHT_ARRAYS: [&str; 5] = ["RAW DATA", "RAW_DATA", "OPD", "Raw", "SAMPLE_DATA"];
const ENTRY: usize = 24;

/// Scores `bytes` as OPD: certain when the directory entry's name `Directory` is at
/// byte 2.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.len() >= 18 && bytes[2..18].starts_with(b"Directory\0") {
        100
    } else {
        0
    }
}

fn name(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).into_owned()
}

enum Scalar {
    Text(String),
    Number(f64),
}

struct Array {
    name: String,
    nx: usize,
    ny: usize,
    item: usize,
    data: usize,
}

struct File {
    arrays: Vec<Array>,
    scalars: Vec<(String, Scalar)>,
}

impl File {
    fn number(&self, key: &str) -> Option<f64> {
        self.scalars.iter().find_map(|(k, v)| match v {
            Scalar::Number(x) if k == key => Some(*x),
            _ => None,
        })
    }
}

fn parse(bytes: &[u8]) -> Result<File, OpdError> {
    let end = bytes.len();
    let truncated = |what: String, offset: usize, needed: u64| OpdError::Truncated {
        what,
        offset,
        needed,
        end,
    };
    if end < 2 + ENTRY {
        return Err(truncated("the directory entry".into(), 2, ENTRY as u64));
    }
    let i32_at = |a: usize| i32_le(bytes, a);
    let dir_len = i32_at(20);
    if dir_len < ENTRY as i32 || !(dir_len as usize).is_multiple_of(ENTRY) {
        return Err(OpdError::Block {
            block: "Directory".into(),
            offset: 2,
            what: format!("length {dir_len} is not a positive multiple of {ENTRY} bytes"),
        });
    }
    let dir_len = dir_len as usize;
    if end - 2 < dir_len {
        return Err(truncated(
            format!("the directory ({} entries)", dir_len / ENTRY),
            2,
            dir_len as u64,
        ));
    }
    let mut file = File {
        arrays: Vec::new(),
        scalars: Vec::new(),
    };
    let mut pos = 2 + dir_len;
    for i in 1..dir_len / ENTRY {
        let e = 2 + i * ENTRY;
        let block = name(&bytes[e..e + 16]);
        let kind = i16_le(bytes, e + 16);
        let len = i32_at(e + 18);
        if len < 0 {
            return Err(OpdError::Block {
                block: block.into(),
                offset: e,
                what: format!("length {len} is negative"),
            });
        }
        let len = len as usize;
        if len == 0 {
            continue;
        }
        if end - pos < len {
            return Err(truncated(format!("block {block:?}"), pos, len as u64));
        }
        let p = &bytes[pos..pos + len];
        match (kind, len) {
            (3, _) => {
                if len < 6 {
                    return Err(OpdError::Block {
                        block: block.into(),
                        offset: pos,
                        what: format!(
                            "an array block of {len} bytes has no room for its 6-byte size"
                        ),
                    });
                }
                let u = |a: usize| usize::from(u16_le(p, a));
                let (nx, ny, item) = (u(0), u(2), u(4));
                if !matches!(item, 1 | 2 | 4) || nx == 0 || ny == 0 {
                    return Err(OpdError::Block {
                        block: block.into(),
                        offset: pos,
                        what: format!(
                            "array {nx} x {ny} of {item}-byte items: expected sizes > 0 and an item size of 1, 2 or 4"
                        ),
                    });
                }
                if (len - 6) < nx * ny * item {
                    return Err(OpdError::Block {
                        block: block.into(),
                        offset: pos,
                        what: format!(
                            "block length {len} is less than 6 + {nx} x {ny} x {item} bytes"
                        ),
                    });
                }
                file.arrays.push(Array {
                    name: block,
                    nx,
                    ny,
                    item,
                    data: pos + 6,
                });
            }
            (5, _) => file.scalars.push((block, Scalar::Text(name(p)))),
            (6, 2) | (7, 2) => file
                .scalars
                .push((block, Scalar::Number(f64::from(i16_le(p, 0))))),
            (6, 4) | (12, 4..) => file
                .scalars
                .push((block, Scalar::Number(f64::from(i32_le(p, 0))))),
            (7, 4..) => file
                .scalars
                .push((block, Scalar::Number(f64::from(f32_le(p, 0))))),
            (8, 8..) => file.scalars.push((block, Scalar::Number(f64_le(p, 0)))),
            _ => {}
        }
        pos += len;
    }
    // Height arrays first (stable: file order within each group).
    file.arrays
        .sort_by_key(|a| !HEIGHT_ARRAYS.contains(&a.name.as_str()));
    if file.arrays.is_empty() {
        return Err(OpdError::Block {
            block: "Directory".into(),
            offset: 2,
            what: "the file holds no array block".into(),
        });
    }
    Ok(file)
}

fn pitch_um(f: &File) -> Option<(f64, f64)> {
    let p = f.number("Pixel_size")? * 1e3;
    let aspect = f.number("Aspect").unwrap_or(1.0);
    let py = p * aspect;
    (p.is_finite() && p > 0.0 && py.is_finite() && py > 0.0).then_some((p, py))
}

/// The arrays of an OPD file: height arrays first (unit `m` after scaling), then the
/// others (unit-less).
///
/// # Errors
/// [`OpdError`] naming the block or byte offset at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, OpdError> {
    let f = parse(bytes)?;
    let pitch = pitch_um(&f);
    Ok(f.arrays
        .iter()
        .map(|a| Channel {
            name: a.name.clone(),
            unit: HEIGHT_ARRAYS
                .contains(&a.name.as_str())
                .then(|| "m".to_string()),
            nx: a.nx,
            ny: a.ny,
            pitch_um: pitch,
        })
        .collect())
}

/// Reads one array (`options.channel`, default the first height array): heights in µm
/// (waves × `Wavelength` / `Mult`), or any array's values as stored for intensity.
///
/// # Errors
/// [`OpdError`] naming the block or byte offset at fault; a height read of an array
/// that is not a height array, or of a file without `Wavelength`, is refused.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, OpdError> {
    let f = parse(bytes)?;
    let index = options.channel.unwrap_or(0);
    let Some(a) = f.arrays.get(index) else {
        return Err(OpdError::Block {
            block: "Directory".into(),
            offset: 2,
            what: format!(
                "channel {index} asked for, the file has {} arrays",
                f.arrays.len()
            ),
        });
    };
    let scale = match kind {
        ValueKind::Intensity => 1.0,
        ValueKind::Height => {
            if !HEIGHT_ARRAYS.contains(&a.name.as_str()) {
                return Err(OpdError::Block {
                    block: a.name.clone().into(),
                    offset: a.data - 6,
                    what: "is not a height array (RAW DATA, RAW_DATA, OPD, Raw, SAMPLE_DATA); read it as an intensity map".into(),
                });
            }
            let Some(w) = f.number("Wavelength").filter(|w| w.is_finite() && *w > 0.0) else {
                return Err(OpdError::Block {
                    block: "Wavelength".into(),
                    offset: 2,
                    what: "is missing or not > 0, so the heights (in waves) cannot be scaled"
                        .into(),
                });
            };
            let mult = f.number("Mult").unwrap_or(1.0);
            if !(mult.is_finite() && mult != 0.0) {
                return Err(OpdError::Block {
                    block: "Mult".into(),
                    offset: 2,
                    what: format!("= {mult}: expected a non-zero divisor"),
                });
            }
            // nm → µm.
            w / mult * 1e-3
        }
    };
    let (dx, dy) = match (pitch_um(&f), options.pixel_um) {
        (_, Some(p)) | (Some(p), None) => p,
        (None, None) => {
            return Err(OpdError::Block {
                block: "Pixel_size".into(),
                offset: 2,
                what: "is missing or not > 0; give the pixel pitch (--pixel-um)".into(),
            });
        }
    };
    let (nx, ny) = (a.nx, a.ny);
    let item = |i: usize| -> f64 {
        let o = a.data + i * a.item;
        match a.item {
            1 => f64::from(bytes[o]),
            2 => {
                let v = i16_le(bytes, o);
                if v >= 32766 { f64::NAN } else { f64::from(v) }
            }
            _ => {
                let v = f32_le(bytes, o);
                if !v.is_finite() || v >= 1e38 {
                    f64::NAN
                } else {
                    f64::from(v)
                }
            }
        }
    };
    let mut z = Vec::with_capacity(nx * ny);
    for row in 0..ny {
        for col in 0..nx {
            z.push(item(col * ny + (ny - 1 - row)) * scale);
        }
    }
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(OpdError::Map)?;
    map.set_metadata("opd.channel", a.name.clone());
    for (k, v) in &f.scalars {
        let key: String = k
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let value = match v {
            Scalar::Text(s) => s.clone(),
            Scalar::Number(x) => x.to_string(),
        };
        map.set_metadata(format!("opd.{key}"), value);
    }
    Ok(map)
}
