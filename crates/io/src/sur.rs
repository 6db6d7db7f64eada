//! Digital Surf SUR (`.sur`) reader: MountainsMap's native format, also written
//! directly by several instruments.
//!
//! Layout (little-endian; Digital Surf's published SUR description as Gwyddion
//! `surffile.c`, SurfaceTopography `SUR.py` and surfalize `sur.py` read it, checked on
//! `sur-2.sur` and `sur-3.sur`): one or more objects, each a 512-byte header, a comment
//! and a private zone (their sizes at bytes 334 and 336), then the data. Header fields
//! used (offsets within the object):
//!
//! | byte | field |
//! | --- | --- |
//! | 0 | code: `DIGITAL SURF` (or `DSCOMPRESSED`, zlib data: not read yet) |
//! | 14, 16, 18 | number of objects, version, studiable type (i16) |
//! | 20, 50 | object name, operator / instrument name (30 bytes each) |
//! | 82, 86 | acquisition type, "non-measured points present" flag (i16) |
//! | 98 | bits per point (16 or 32) |
//! | 100, 104 | minimum, maximum raw value (i32) |
//! | 108, 112, 116 | points per line, lines, total points (i32) |
//! | 120, 124, 128 | spacing x, y, z (f32, in the step units) |
//! | 164 | name of z (16 bytes) |
//! | 180, 196, 212 | step units of x, y, z (16 bytes each, `mm`, `µm`, `nm`, `m`) |
//! | 290 | inversion: 0 none, 1 z inverted, 2 z inverted and x mirrored, 3 z inverted and y mirrored |
//! | 306 … 316 | second, minute, hour, day, month, year (i16) |
//! | 474 | z offset (f32) |
//!
//! Data: `lines × points per line` integers (i16 or i32), line after line (rows along
//! y, x fastest). Conventions: height = raw × spacing z in the z step unit (converted to
//! µm), negated when the inversion flag says so; pitch = spacing x, y in their step
//! units. When the non-measured flag is 1, raw = minimum − 2 marks an invalid point.
//! The z offset is **not** added (it is recorded as `sur.offset_z`): SurfaceTopography
//! and Gwyddion do not add it, and surfalize adds it in the wrong unit (see the test).
//! Each object is one channel, named by its z name. Metadata keys `sur.*`.

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::{f32_le, i16_le, i32_le};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};
use crate::units::length_unit_exponent;

/// What is wrong with a SUR file: the binary readers' one error type.
pub type SurError = crate::format_error::FormatError;

const HEADER: usize = 512;

/// Scores `bytes` as SUR: certain for the code `DIGITAL SURF` or `DSCOMPRESSED`.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.starts_with(b"DIGITAL SURF") || bytes.starts_with(b"DSCOMPRESSED") {
        100
    } else {
        0
    }
}

/// Text of a fixed-size field; µ may be Latin-1 (0xB5) or DOS (0xE6).
fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    b[..end]
        .iter()
        .map(|&c| match c {
            0xb5 | 0xe6 => 'µ',
            c => char::from(c),
        })
        .collect::<String>()
        .trim()
        .to_string()
}

struct Object {
    at: usize,
    nx: usize,
    ny: usize,
    bits: usize,
    data: usize,
}

fn objects(bytes: &[u8]) -> Result<Vec<Object>, SurError> {
    let end = bytes.len();
    let mut at = 0;
    let mut out = Vec::new();
    let mut count = 1;
    while out.len() < count {
        let k = out.len();
        if end - at < HEADER {
            return Err(SurError::Truncated {
                what: format!("the header of object {k}"),
                offset: at,
                needed: HEADER as u64,
                end,
            });
        }
        let h = &bytes[at..at + HEADER];
        let i16_at = |a: usize| i16_le(h, a);
        let i32_at = |a: usize| i32_le(h, a);
        let bad = |field, a: usize, value: String, expected| SurError::ObjectField {
            object: k,
            field,
            offset: at + a,
            value,
            expected,
        };
        if h.starts_with(b"DSCOMPRESSED") {
            return Err(bad(
                "code",
                0,
                "DSCOMPRESSED".into(),
                "DIGITAL SURF (compressed SUR files are not read yet)",
            ));
        }
        if !h.starts_with(b"DIGITAL SURF") {
            return Err(bad("code", 0, text(&h[..12]), "DIGITAL SURF"));
        }
        if k == 0 {
            let n = i16_at(14);
            if n < 1 {
                return Err(bad("number of objects", 14, n.to_string(), "at least 1"));
            }
            count = n as usize;
        }
        let bits = i16_at(98);
        if !matches!(bits, 16 | 32) {
            return Err(bad("bits per point", 98, bits.to_string(), "16 or 32"));
        }
        let (nx, ny, total) = (i32_at(108), i32_at(112), i32_at(116));
        if nx < 1 || ny < 1 || i64::from(nx) * i64::from(ny) != i64::from(total) {
            return Err(bad(
                "points per line x lines",
                108,
                format!("{nx} x {ny} (total {total})"),
                "sizes > 0 whose product is the total at byte 116",
            ));
        }
        let zones = i16_at(334).max(0) as usize + i16_at(336).max(0) as usize;
        let data = at + HEADER + zones;
        let need = (nx as u64) * (ny as u64) * (bits as u64 / 8);
        if (end as u64) < data as u64 + need {
            return Err(SurError::Truncated {
                what: format!("the data of object {k} ({nx} x {ny} x {bits} bits)"),
                offset: data.min(end),
                needed: need,
                end,
            });
        }
        out.push(Object {
            at,
            nx: nx as usize,
            ny: ny as usize,
            bits: bits as usize,
            data,
        });
        at = data + need as usize;
    }
    Ok(out)
}

/// A spacing × its step unit, in µm.
fn step_um(
    b: &[u8],
    o: &Object,
    k: usize,
    spacing: usize,
    unit: usize,
    field: &'static str,
) -> Result<f64, SurError> {
    let s = f64::from(f32_le(b, o.at + spacing));
    let u = text(&b[o.at + unit..o.at + unit + 16]);
    let e = length_unit_exponent(&u).ok_or_else(|| SurError::ObjectField {
        object: k,
        field,
        offset: o.at + unit,
        value: format!("{u:?}"),
        expected: "a length unit (m, mm, µm, nm)",
    })?;
    let v = s * 10f64.powi(e);
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(SurError::ObjectField {
            object: k,
            field,
            offset: o.at + spacing,
            value: s.to_string(),
            expected: "a spacing > 0",
        })
    }
}

/// The objects of a SUR file, one channel each (named by the z name).
///
/// # Errors
/// [`SurError`] naming the object, field or byte offset at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, SurError> {
    objects(bytes)?
        .iter()
        .enumerate()
        .map(|(k, o)| {
            let name = text(&bytes[o.at + 164..o.at + 180]);
            let pitch = match (
                step_um(bytes, o, k, 120, 180, "spacing x"),
                step_um(bytes, o, k, 124, 196, "spacing y"),
            ) {
                (Ok(x), Ok(y)) => Some((x, y)),
                _ => None,
            };
            let unit = text(&bytes[o.at + 212..o.at + 228]);
            Ok(Channel {
                name: if name.is_empty() {
                    format!("object{k}")
                } else {
                    name
                },
                unit: (!unit.is_empty()).then_some(unit),
                nx: o.nx,
                ny: o.ny,
                pitch_um: pitch,
            })
        })
        .collect()
}

/// Reads one object (`options.channel`, default the first) of a SUR file: heights in µm
/// (see the module notes), or values as stored (raw × spacing z) for intensity.
///
/// # Errors
/// [`SurError`] naming the object, field or byte offset at fault.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, SurError> {
    let all = objects(bytes)?;
    let k = options.channel.unwrap_or(0);
    let Some(o) = all.get(k) else {
        return Err(SurError::ObjectField {
            object: 0,
            field: "number of objects",
            offset: 14,
            value: all.len().to_string(),
            expected: "more objects than the channel asked for",
        });
    };
    let h = &bytes[o.at..o.at + HEADER];
    let i16_at = |a: usize| i16_le(h, a);
    let i32_at = |a: usize| i32_le(h, a);
    let (dx, dy) = match options.pixel_um {
        Some(p) => p,
        None => (
            step_um(bytes, o, k, 120, 180, "spacing x")?,
            step_um(bytes, o, k, 124, 196, "spacing y")?,
        ),
    };
    let inversion = i16_at(290);
    let sz = f64::from(f32_le(h, 128));
    let scale = match kind {
        ValueKind::Intensity => sz,
        ValueKind::Height => {
            let u = text(&h[212..228]);
            let e = length_unit_exponent(&u).ok_or_else(|| SurError::ObjectField {
                object: k,
                field: "step unit of z",
                offset: o.at + 212,
                value: format!("{u:?}"),
                expected: "a length unit (m, mm, µm, nm); this object is not a height map",
            })?;
            let sign = if matches!(inversion, 1..=3) {
                -1.0
            } else {
                1.0
            };
            sign * sz * 10f64.powi(e)
        }
    };
    if !(scale.is_finite() && scale != 0.0) {
        return Err(SurError::ObjectField {
            object: k,
            field: "spacing z",
            offset: o.at + 128,
            value: sz.to_string(),
            expected: "a finite, non-zero scale",
        });
    }
    let invalid = (i16_at(86) == 1).then(|| i64::from(i32_at(100)) - 2);
    let (nx, ny) = (o.nx, o.ny);
    let width = o.bits / 8;
    let mut z = vec![0.0; nx * ny];
    for row in 0..ny {
        for col in 0..nx {
            let a = o.data + (row * nx + col) * width;
            let raw = if width == 2 {
                i64::from(i16_le(bytes, a))
            } else {
                i64::from(i32_le(bytes, a))
            };
            let (c, r) = match inversion {
                2 => (nx - 1 - col, row),
                3 => (col, ny - 1 - row),
                _ => (col, row),
            };
            z[r * nx + c] = if Some(raw) == invalid {
                f64::NAN
            } else {
                raw as f64 * scale
            };
        }
    }
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(SurError::Map)?;
    map.set_metadata("sur.object", k.to_string());
    map.set_metadata("sur.object_name", text(&h[20..50]));
    map.set_metadata("sur.operator", text(&h[50..80]));
    map.set_metadata("sur.studiable_type", i16_at(18).to_string());
    map.set_metadata("sur.acquisition_type", i16_at(82).to_string());
    map.set_metadata("sur.name_z", text(&h[164..180]));
    map.set_metadata("sur.unit_z", text(&h[212..228]));
    map.set_metadata("sur.inversion", inversion.to_string());
    map.set_metadata("sur.offset_z", f32_le(h, 474).to_string());
    let year = i16_at(316);
    if year > 0 {
        map.set_metadata(
            "sur.date",
            format!(
                "{year:04}-{:02}-{:02} {:02}:{:02}:{:02}",
                i16_at(314),
                i16_at(312),
                i16_at(310),
                i16_at(308),
                i16_at(306)
            ),
        );
    }
    let comment_len = i16_at(334).max(0) as usize;
    if comment_len > 0 {
        map.set_metadata(
            "sur.comment",
            text(&bytes[o.at + HEADER..o.at + HEADER + comment_len]),
        );
    }
    Ok(map)
}
