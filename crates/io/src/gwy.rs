//! Gwyddion native file (`.gwy`, magic `GWYP`) reader.
//!
//! Layout (Gwyddion's published "GWY file format" description): the 4-byte magic, then
//! one serialized `GwyContainer`. A serialized object is its type name (NUL-terminated),
//! a little-endian `u32` byte size and that many bytes of components; a component is a
//! NUL-terminated name, one type character and the value: `b`/`c` 1 byte, `i` i32,
//! `q` i64, `d` f64, `s` NUL-terminated string, `o` a nested object; the upper-case
//! letters `C I Q D S O` are arrays (a `u32` count, then the items). All little-endian.
//!
//! Conventions: each container key `/N/data` holding a `GwyDataField` is one channel
//! (name from `/N/data/title`, else `N`), listed in increasing `N`. A data field has
//! `xres` columns and `yres` rows, row-major with x fastest (as our maps), physical size
//! `xreal × yreal` in the base unit of `si_unit_xy`, values `data` in the base unit of
//! `si_unit_z` (Gwyddion stores SI base units, so normally `m`). Pitch is
//! `xreal / xres`, `yreal / yres`. Non-finite values are invalid points, and so are the
//! points of the channel's mask `/N/mask` with value > 0.5: Gwyddion's importers put the
//! points an instrument did not measure into that mask (and fill them), so the mask is
//! the file's statement of invalid points.
//!
//! A field that stores no unit (empty `unitstr`) is not silently taken as metres: its
//! heights need `z_unit` (`--z-unit`) and its lateral size needs `pixel_um`
//! (`--pixel-um`). Offsets `xoff`/`yoff` are recorded in the metadata only.
//!
//! Hostile input: every size and count is checked against the bytes that remain before
//! anything is allocated, nesting is limited to 32 levels, and a file that ends early is
//! refused with the byte offset where the missing bytes should be.

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::{f64_le, i32_le, i64_le, u32_le};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};
use crate::units::length_unit_exponent;

/// What is wrong with a GWY file: the binary readers' one error type.
pub type GwyError = crate::format_error::FormatError;

const MAGIC: &[u8; 4] = b"GWYP";
const MAX_DEPTH: usize = 32;

/// Scores `bytes` as GWY: certain for the `GWYP` magic followed by `GwyContainer`.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.starts_with(b"GWYPGwyContainer\0") {
        100
    } else if bytes.starts_with(MAGIC) {
        80
    } else {
        0
    }
}

/// A parsed value; numeric arrays stay as byte slices until used.
#[derive(Debug)]
enum Value<'a> {
    Int(i64),
    Double(f64),
    Str(String),
    Object(Object<'a>),
    Doubles(&'a [u8]),
    Other,
}

#[derive(Debug)]
struct Object<'a> {
    name: String,
    fields: Vec<(String, Value<'a>)>,
}

impl<'a> Object<'a> {
    fn get(&self, key: &str) -> Option<&Value<'a>> {
        self.fields.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }
}

struct Parser<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Parser<'a> {
    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8], GwyError> {
        let left = (self.bytes.len() - self.pos) as u64;
        if n > left {
            return Err(GwyError::Truncated {
                what: what.to_string(),
                offset: self.pos,
                needed: n,
                end: self.bytes.len(),
            });
        }
        let s = &self.bytes[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, GwyError> {
        let b = self.take(4, what)?;
        Ok(u32_le(b, 0))
    }

    fn cstr(&mut self, what: &str) -> Result<String, GwyError> {
        let rest = &self.bytes[self.pos..];
        let Some(n) = rest.iter().position(|&b| b == 0) else {
            return Err(GwyError::Truncated {
                what: format!("{what} (a NUL-terminated string)"),
                offset: self.pos,
                needed: rest.len() as u64 + 1,
                end: self.bytes.len(),
            });
        };
        let s = String::from_utf8_lossy(&rest[..n]).into_owned();
        self.pos += n + 1;
        Ok(s)
    }

    /// An array's count, checked against the bytes left (each item ≥ `min_item` bytes).
    fn count(&mut self, min_item: u64, what: &str) -> Result<u64, GwyError> {
        let at = self.pos;
        let n = u64::from(self.u32(what)?);
        let left = (self.bytes.len() - self.pos) as u64;
        if n * min_item > left {
            return Err(GwyError::Truncated {
                what: format!("{what}: {n} items"),
                offset: at + 4,
                needed: n * min_item,
                end: self.bytes.len(),
            });
        }
        Ok(n)
    }

    fn object(&mut self, depth: usize) -> Result<Object<'a>, GwyError> {
        if depth > MAX_DEPTH {
            return Err(GwyError::At {
                offset: self.pos,
                what: format!("objects nested deeper than {MAX_DEPTH} levels"),
            });
        }
        let name = self.cstr("object name")?;
        let size = u64::from(self.u32(&format!("size of object {name}"))?);
        let body = self.take(size, &format!("object {name} ({size} bytes)"))?;
        let start = self.pos - body.len();
        let mut inner = Parser {
            bytes: &self.bytes[..start + body.len()],
            pos: start,
        };
        let mut fields = Vec::new();
        while inner.pos < start + body.len() {
            let key = inner.cstr("component name")?;
            let at = inner.pos;
            let t = inner.take(1, &format!("type of component {key}"))?[0];
            let what = format!("component {key} of {name}");
            let value = match t {
                b'b' | b'c' => Value::Int(i64::from(inner.take(1, &what)?[0])),
                b'i' => {
                    let b = inner.take(4, &what)?;
                    Value::Int(i64::from(i32_le(b, 0)))
                }
                b'q' => {
                    let b = inner.take(8, &what)?;
                    Value::Int(i64_le(b, 0))
                }
                b'd' => {
                    let b = inner.take(8, &what)?;
                    Value::Double(f64_le(b, 0))
                }
                b's' => Value::Str(inner.cstr(&what)?),
                b'o' => Value::Object(inner.object(depth + 1)?),
                b'C' | b'I' | b'Q' | b'D' => {
                    let width = match t {
                        b'C' => 1,
                        b'I' => 4,
                        _ => 8,
                    };
                    let n = inner.count(width, &what)?;
                    let data = inner.take(n * width, &what)?;
                    if t == b'D' {
                        Value::Doubles(data)
                    } else {
                        Value::Other
                    }
                }
                b'S' => {
                    for _ in 0..inner.count(1, &what)? {
                        inner.cstr(&what)?;
                    }
                    Value::Other
                }
                b'O' => {
                    for _ in 0..inner.count(5, &what)? {
                        inner.object(depth + 1)?;
                    }
                    Value::Other
                }
                other => {
                    return Err(GwyError::At {
                        offset: at,
                        what: format!(
                            "component {key} of {name} has unknown type {:?} (expected one of bcilqdsoCIQDSO)",
                            char::from(other)
                        ),
                    });
                }
            };
            fields.push((key, value));
        }
        Ok(Object { name, fields })
    }
}

fn container(bytes: &[u8]) -> Result<Object<'_>, GwyError> {
    if !bytes.starts_with(MAGIC) {
        return Err(GwyError::At {
            offset: 0,
            what: "the file does not start with the magic GWYP".into(),
        });
    }
    let mut p = Parser { bytes, pos: 4 };
    let top = p.object(0)?;
    if top.name != "GwyContainer" {
        return Err(GwyError::At {
            offset: 4,
            what: format!("top-level object is {:?}, expected GwyContainer", top.name),
        });
    }
    Ok(top)
}

/// One data field, checked.
struct Field<'a> {
    title: String,
    nx: usize,
    ny: usize,
    xreal: f64,
    yreal: f64,
    unit_xy: String,
    unit_z: String,
    data: &'a [u8],
    mask: Option<&'a [u8]>,
    xoff: Option<f64>,
    yoff: Option<f64>,
}

fn unit(obj: &Object<'_>, key: &str) -> String {
    match obj.get(key) {
        Some(Value::Object(u)) => match u.get("unitstr") {
            Some(Value::Str(s)) => s.clone(),
            _ => String::new(),
        },
        _ => String::new(),
    }
}

fn fields<'a>(top: &'a Object<'a>) -> Result<Vec<Field<'a>>, GwyError> {
    let mut found: Vec<(u64, &Object<'a>)> = top
        .fields
        .iter()
        .filter_map(|(k, v)| {
            let id = k
                .strip_prefix('/')?
                .strip_suffix("/data")?
                .parse::<u64>()
                .ok()?;
            match v {
                Value::Object(o) if o.name == "GwyDataField" => Some((id, o)),
                _ => None,
            }
        })
        .collect();
    found.sort_by_key(|(id, _)| *id);
    if found.is_empty() {
        return Err(GwyError::NoData(
            "the file holds no data field (no container key /N/data)",
        ));
    }
    found
        .into_iter()
        .map(|(id, o)| {
            let title = match top.get(&format!("/{id}/data/title")) {
                Some(Value::Str(s)) => s.clone(),
                _ => id.to_string(),
            };
            let err = |what: String| GwyError::Channel {
                channel: title.clone(),
                what,
            };
            let int = |k: &str| match o.get(k) {
                Some(Value::Int(v)) if *v > 0 => usize::try_from(*v)
                    .map_err(|_| err(format!("{k} = {v} does not fit in memory"))),
                Some(Value::Int(v)) => Err(err(format!("{k} = {v}: expected a count > 0"))),
                _ => Err(err(format!("component {k} (an integer) is missing"))),
            };
            let real = |k: &str| match o.get(k) {
                Some(Value::Double(v)) if v.is_finite() && *v > 0.0 => Ok(*v),
                Some(Value::Double(v)) => Err(err(format!("{k} = {v}: expected a size > 0"))),
                _ => Err(err(format!("component {k} (a double) is missing"))),
            };
            let (nx, ny) = (int("xres")?, int("yres")?);
            let (xreal, yreal) = (real("xreal")?, real("yreal")?);
            let Some(Value::Doubles(data)) = o.get("data") else {
                return Err(err("component data (an array of doubles) is missing".into()));
            };
            // xres, yres up to 2⁶³ each (`q` components): the product is checked, not
            // wrapped, so that no size but the true one matches the data.
            let n = (nx as u64).checked_mul(ny as u64);
            if n.and_then(|n| n.checked_mul(8)) != Some(data.len() as u64) {
                let expected = n.map_or_else(|| "more than 2⁶⁴".to_string(), |n| n.to_string());
                return Err(err(format!(
                    "data holds {} values, expected xres {nx} x yres {ny} = {expected}",
                    data.len() / 8
                )));
            }
            let mask = match top.get(&format!("/{id}/mask")) {
                Some(Value::Object(m)) if m.name == "GwyDataField" => match m.get("data") {
                    Some(Value::Doubles(d)) if d.len() == data.len() => Some(*d),
                    _ => {
                        return Err(err(format!(
                            "its mask /{id}/mask does not have xres x yres values"
                        )));
                    }
                },
                _ => None,
            };
            let off = |k: &str| match o.get(k) {
                Some(Value::Double(v)) => Some(*v),
                _ => None,
            };
            Ok(Field {
                nx,
                ny,
                xreal,
                yreal,
                unit_xy: unit(o, "si_unit_xy"),
                unit_z: unit(o, "si_unit_z"),
                data,
                mask,
                xoff: off("xoff"),
                yoff: off("yoff"),
                title,
            })
        })
        .collect()
}

/// Pitch in µm: from the file's lateral unit, or `None` if it stores none.
fn pitch_um(f: &Field<'_>) -> Result<Option<(f64, f64)>, GwyError> {
    if f.unit_xy.is_empty() {
        return Ok(None);
    }
    let e = length_unit_exponent(&f.unit_xy).ok_or_else(|| GwyError::Channel {
        channel: f.title.clone(),
        what: format!(
            "lateral unit {:?} is not a length unit (m, mm, µm, nm)",
            f.unit_xy
        ),
    })?;
    let s = 10f64.powi(e);
    Ok(Some((f.xreal / f.nx as f64 * s, f.yreal / f.ny as f64 * s)))
}

/// The channels of a GWY file: every `/N/data` data field, with its title and units.
///
/// # Errors
/// [`GwyError`] naming the byte offset or the channel at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, GwyError> {
    let top = container(bytes)?;
    fields(&top)?
        .iter()
        .map(|f| {
            Ok(Channel {
                name: f.title.clone(),
                unit: (!f.unit_z.is_empty()).then(|| f.unit_z.clone()),
                nx: f.nx,
                ny: f.ny,
                pitch_um: pitch_um(f)?,
            })
        })
        .collect()
}

/// Reads one channel (`options.channel`, default the first) of a GWY file: heights in
/// µm from the field's z unit (or `options.z_unit` if the file stores none), or
/// intensities as stored.
///
/// # Errors
/// [`GwyError`] naming the byte offset or the channel at fault, including a channel
/// without units when no `z_unit` / `pixel_um` is given.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, GwyError> {
    let top = container(bytes)?;
    let all = fields(&top)?;
    let index = options.channel.unwrap_or(0);
    let Some(f) = all.get(index) else {
        return Err(GwyError::Channel {
            channel: index.to_string(),
            what: format!("no such channel; the file has {}", all.len()),
        });
    };
    let err = |what: String| GwyError::Channel {
        channel: f.title.clone(),
        what,
    };
    let (dx, dy) = match (pitch_um(f)?, options.pixel_um) {
        (_, Some(p)) => p,
        (Some(p), None) => p,
        (None, None) => {
            return Err(err(
                "it stores no lateral unit, so its size is not calibrated; give the pixel pitch (--pixel-um)".into(),
            ));
        }
    };
    let z_exp = match kind {
        ValueKind::Intensity => 0,
        ValueKind::Height => match (f.unit_z.as_str(), options.z_unit) {
            ("", Some(u)) => u.exponent_to_um(),
            ("", None) => {
                return Err(err(
                    "it stores no z unit, so its heights are not calibrated; give the unit (--z-unit)".into(),
                ));
            }
            (u, Some(_)) => {
                return Err(err(format!(
                    "it stores its z unit ({u}); leave out --z-unit"
                )));
            }
            (u, None) => length_unit_exponent(u).ok_or_else(|| {
                err(format!(
                    "z unit {u:?} is not a length unit, so this channel is not a height map (read it as intensity)"
                ))
            })?,
        },
    };
    let scale = 10f64.powi(z_exp);
    let z: Vec<f64> = f
        .data
        .chunks_exact(8)
        .map(|c| f64_le(c, 0) * scale)
        .collect();
    let mut map = match f.mask {
        Some(m) => {
            let valid = m.chunks_exact(8).map(|c| f64_le(c, 0) <= 0.5).collect();
            HeightMap::with_mask(f.nx, f.ny, dx, dy, z, valid)
        }
        None => HeightMap::new(f.nx, f.ny, dx, dy, z),
    }
    .map_err(GwyError::Map)?;
    map.set_metadata("gwy.channel", f.title.clone());
    map.set_metadata("gwy.channel_index", index.to_string());
    map.set_metadata("gwy.si_unit_xy", f.unit_xy.clone());
    map.set_metadata("gwy.si_unit_z", f.unit_z.clone());
    map.set_metadata("gwy.xreal", f.xreal.to_string());
    map.set_metadata("gwy.yreal", f.yreal.to_string());
    if let Some(x) = f.xoff {
        map.set_metadata("gwy.xoff", x.to_string());
    }
    if let Some(y) = f.yoff {
        map.set_metadata("gwy.yoff", y.to_string());
    }
    if f.mask.is_some() {
        map.set_metadata("gwy.mask", "applied: mask points > 0.5 are invalid");
    }
    if options.z_unit.is_some() && kind == ValueKind::Height {
        map.set_metadata("z_unit_source", "option");
    }
    Ok(map)
}
