//! Alicona AL3D (`.al3d`) reader: depth images of Alicona / Bruker Alicona
//! focus-variation instruments.
//!
//! Layout (Alicona's "AL3D File Format Specification" as SurfaceTopography `AL3D.py` and
//! surfalize `al3d.py` read it, checked on `al3d-1.al3d`): the 17-byte magic
//! `AliconaImaging\0\r\n`, then 52-byte tags — key (20 bytes), value (30 bytes), both
//! NUL-terminated Latin-1 text, and `\r\n` — first `Version`, then `TagCount` (the number
//! of tags that follow). The depth image starts at `DepthImageOffset`: `Rows` lines of
//! `Cols` little-endian f32 depths in metres, each line padded to a multiple of 8 bytes
//! (the last line's padding may be missing).
//!
//! Conventions: pitch `PixelSizeXMeter`, `PixelSizeYMeter`; a depth that is not below
//! `InvalidPixelValue` (default 3e15, and any NaN) is an invalid point; so is a point
//! whose repeatability is above the filter, when the file has a repeatability plane
//! (`DepthImageResPtr`, `DepthResFilterVal`, and planes at `TextureImageOffset`, one
//! byte per point, `Cols` padded to 8): code × `DepthResShiftVal` + `DepthResMinVal` >
//! `DepthResFilterVal`. Metadata `al3d.*` (every tag with text).
//!
//! Channels: `depth` (m), then, when the file has a texture (`TexturePtr` lists its
//! planes, `;`-separated: one for grey, three for R, G, B; `NumberOfPlanes` planes at
//! `TextureImageOffset`, one byte per point, `Cols` padded to 8), the intensity channel
//! `texture` (`a.u.`: the mean of the texture planes' bytes, the grey level itself for
//! one plane) and, for three planes, `texture-r`, `texture-g`, `texture-b` (each plane's
//! bytes as stored). Gwyddion 2.62 imports the three planes of `al3d-1.al3d` as
//! "Texture (R)", "(G)", "(B)" scaled by 1/256; ×256 they are this reader's values.
//! Every texture point is valid.
//!
//! Not read: the icon, the repeatability plane as a channel of its own (it masks the
//! depths).

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::f32_le;
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};

/// What is wrong with a AL3D file: the binary readers' one error type.
pub type Al3dError = crate::format_error::FormatError;

const MAGIC: &[u8; 17] = b"AliconaImaging\0\r\n";
const TAG: usize = 52;

/// Scores `bytes` as AL3D: certain for the magic `AliconaImaging\0\r\n`.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.starts_with(MAGIC) {
        100
    } else if bytes.starts_with(b"AliconaImaging") {
        80
    } else {
        0
    }
}

fn latin1(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    b[..end].iter().map(|&c| char::from(c)).collect()
}

fn tags(bytes: &[u8]) -> Result<Vec<(String, String)>, Al3dError> {
    let end = bytes.len();
    let tag_at = |i: usize| -> Result<(String, String), Al3dError> {
        let at = MAGIC.len() + i * TAG;
        if end < at + TAG {
            return Err(Al3dError::Truncated {
                what: format!("tag {i}"),
                offset: at,
                needed: TAG as u64,
                end,
            });
        }
        let t = &bytes[at..at + TAG];
        if &t[50..] != b"\r\n" {
            return Err(Al3dError::Tag {
                tag: latin1(&t[..20]),
                what: format!("tag {i} at byte {at} does not end in CR LF"),
            });
        }
        Ok((latin1(&t[..20]), latin1(&t[20..50])))
    };
    if !bytes.starts_with(MAGIC) {
        return Err(Al3dError::Truncated {
            what: "the magic AliconaImaging\\0\\r\\n".into(),
            offset: 0,
            needed: MAGIC.len() as u64,
            end,
        });
    }
    let version = tag_at(0)?;
    let count = tag_at(1)?;
    if version.0 != "Version" || count.0 != "TagCount" {
        return Err(Al3dError::Tag {
            tag: format!("{} / {}", version.0, count.0),
            what: "the first two tags must be Version and TagCount".into(),
        });
    }
    let n: usize = count.1.trim().parse().map_err(|_| Al3dError::Tag {
        tag: "TagCount".into(),
        what: format!("{:?} is not a count", count.1),
    })?;
    // Each tag is 52 bytes of the file: check before reading them (a count of 20 digits
    // would overflow the product, so it saturates: no file holds that many bytes).
    let need = (n as u64).saturating_add(2).saturating_mul(TAG as u64);
    if ((end - MAGIC.len()) as u64) < need {
        return Err(Al3dError::Truncated {
            what: format!("{n} tags"),
            offset: MAGIC.len(),
            needed: need,
            end,
        });
    }
    let mut out = vec![version, count];
    for i in 0..n {
        out.push(tag_at(i + 2)?);
    }
    Ok(out)
}

fn get<'a>(t: &'a [(String, String)], key: &str) -> Option<&'a str> {
    t.iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.trim())
        .filter(|v| !v.is_empty())
}

fn number<T: std::str::FromStr>(t: &[(String, String)], key: &str) -> Result<T, Al3dError> {
    let v = get(t, key).ok_or_else(|| Al3dError::Tag {
        tag: key.into(),
        what: "is missing".into(),
    })?;
    v.parse().map_err(|_| Al3dError::Tag {
        tag: key.into(),
        what: format!("{v:?} is not a number"),
    })
}

struct Header {
    nx: usize,
    ny: usize,
    dx: f64,
    dy: f64,
    offset: usize,
    stride: usize,
}

fn header(bytes: &[u8], t: &[(String, String)]) -> Result<Header, Al3dError> {
    let nx: usize = number(t, "Cols")?;
    let ny: usize = number(t, "Rows")?;
    if nx == 0 || ny == 0 || nx > u32::MAX as usize || ny > u32::MAX as usize {
        return Err(Al3dError::Tag {
            tag: "Cols / Rows".into(),
            what: format!("{nx} x {ny}: expected sizes > 0"),
        });
    }
    let pitch = |key: &str| -> Result<f64, Al3dError> {
        let v: f64 = number(t, key)?;
        if v.is_finite() && v > 0.0 {
            Ok(v * 1e6)
        } else {
            Err(Al3dError::Tag {
                tag: key.into(),
                what: format!("{v}: expected a pitch > 0 in metres"),
            })
        }
    };
    let (dx, dy) = (pitch("PixelSizeXMeter")?, pitch("PixelSizeYMeter")?);
    let offset: usize = number(t, "DepthImageOffset")?;
    let stride = (nx * 4).div_ceil(8) * 8;
    // Cols and Rows up to 2³² each and any offset: the sums saturate instead of
    // overflowing (a saturated size is larger than any file, so it is refused).
    let need = (stride as u64)
        .saturating_mul(ny as u64 - 1)
        .saturating_add(nx as u64 * 4);
    if (bytes.len() as u64) < (offset as u64).saturating_add(need) {
        return Err(Al3dError::Truncated {
            what: format!("the depth image ({nx} x {ny} f32, lines of {stride} bytes)"),
            offset: offset.min(bytes.len()),
            needed: need,
            end: bytes.len(),
        });
    }
    Ok(Header {
        nx,
        ny,
        dx,
        dy,
        offset,
        stride,
    })
}

/// Start of byte plane `plane` of the block at `offset` (lines of `nx` bytes padded to
/// 8, `ny` lines per plane), checked to lie inside the file; `what` names the plane in
/// the error. Saturating: a hostile plane number or offset must not overflow the check.
fn byte_plane(
    bytes: &[u8],
    h: &Header,
    offset: usize,
    plane: usize,
    what: &str,
) -> Result<usize, Al3dError> {
    let line = h.nx.div_ceil(8) * 8;
    let start =
        (offset as u64).saturating_add((plane as u64).saturating_mul(line as u64 * h.ny as u64));
    let need = (line as u64) * (h.ny as u64 - 1) + h.nx as u64;
    if (bytes.len() as u64) < start.saturating_add(need) {
        return Err(Al3dError::Truncated {
            what: format!("{what} plane {plane}"),
            offset: (start as usize).min(bytes.len()),
            needed: need,
            end: bytes.len(),
        });
    }
    Ok(start as usize)
}

/// The texture channels: each name with the start of every plane it averages.
fn textures(
    bytes: &[u8],
    t: &[(String, String)],
    h: &Header,
) -> Result<Vec<(String, Vec<usize>)>, Al3dError> {
    let (Some(ptr), Some(offset)) = (get(t, "TexturePtr"), get(t, "TextureImageOffset")) else {
        return Ok(Vec::new());
    };
    let offset: usize = offset.parse().map_err(|_| Al3dError::Tag {
        tag: "TextureImageOffset".into(),
        what: format!("{offset:?} is not a byte offset"),
    })?;
    if offset == 0 {
        return Ok(Vec::new());
    }
    let planes: usize = number(t, "NumberOfPlanes")?;
    let mut starts = Vec::new();
    for p in ptr.split(';') {
        let plane: usize = p.trim().parse().ok().filter(|&p| p < planes).ok_or_else(|| Al3dError::Tag {
            tag: "TexturePtr".into(),
            what: format!("{ptr:?}: expected plane numbers below NumberOfPlanes = {planes}, separated by ;"),
        })?;
        starts.push(byte_plane(bytes, h, offset, plane, "texture")?);
    }
    let mut out = vec![("texture".to_string(), starts.clone())];
    if starts.len() == 3 {
        for (c, s) in ["r", "g", "b"].iter().zip(&starts) {
            out.push((format!("texture-{c}"), vec![*s]));
        }
    }
    Ok(out)
}

/// The channels of an AL3D file: `depth` (m), then its texture channels (`a.u.`;
/// module notes).
///
/// # Errors
/// [`Al3dError`] naming the tag or byte offset at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, Al3dError> {
    let t = tags(bytes)?;
    let h = header(bytes, &t)?;
    let mut out = vec![Channel {
        name: "depth".into(),
        unit: Some("m".into()),
        nx: h.nx,
        ny: h.ny,
        pitch_um: Some((h.dx, h.dy)),
    }];
    out.extend(
        textures(bytes, &t, &h)?
            .into_iter()
            .map(|(name, _)| Channel {
                name,
                unit: Some("a.u.".into()),
                nx: h.nx,
                ny: h.ny,
                pitch_um: Some((h.dx, h.dy)),
            }),
    );
    Ok(out)
}

/// Reads a channel of an AL3D file (`options.channel`, default 0 = `depth`): the depth
/// image as heights in µm, or a texture channel's values (see the module notes). The
/// depth read as intensity, or a texture as heights, is refused.
///
/// # Errors
/// [`Al3dError`] naming the tag or byte offset at fault.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, Al3dError> {
    let t = tags(bytes)?;
    let h = header(bytes, &t)?;
    let index = options.channel.unwrap_or(0);
    let tex = textures(bytes, &t, &h)?;
    match (index, kind) {
        (0, ValueKind::Height) => {}
        (0, ValueKind::Intensity) => {
            return Err(Al3dError::Tag {
                tag: "depth".into(),
                what: "the depth channel holds heights (m), not an intensity image; the texture is the channel `texture`".into(),
            });
        }
        (i, kind) => {
            let Some((name, planes)) = tex.get(i - 1) else {
                return Err(Al3dError::Tag {
                    tag: "TexturePtr".into(),
                    what: format!(
                        "channel {i} asked for, the file has {} channel(s)",
                        tex.len() + 1
                    ),
                });
            };
            if kind == ValueKind::Height {
                return Err(Al3dError::Tag {
                    tag: "TexturePtr".into(),
                    what: format!(
                        "channel {name} is an intensity image (a.u.), not heights; read it as the intensity map (--intensity-channel)"
                    ),
                });
            }
            return read_texture(bytes, &t, &h, name, planes);
        }
    }
    let limit = match get(&t, "InvalidPixelValue").map(str::parse::<f64>) {
        Some(Ok(v)) if v.is_finite() => v,
        _ => f64::from(3.0e15_f32),
    };
    // Repeatability plane, when the file has one (all of its tags present).
    let plane: Option<(usize, f64, f64, f64)> = match (
        get(&t, "DepthImageResPtr"),
        get(&t, "DepthResFilterVal"),
        get(&t, "TextureImageOffset"),
    ) {
        (Some(p), Some(_), Some(o)) => {
            let p: usize = p.parse().map_err(|_| Al3dError::Tag {
                tag: "DepthImageResPtr".into(),
                what: format!("{p:?} is not a plane number"),
            })?;
            let o: usize = o.parse().unwrap_or(0);
            let shift: f64 =
                get(&t, "DepthResShiftVal").map_or(Ok(0.0), |_| number(&t, "DepthResShiftVal"))?;
            let min: f64 =
                get(&t, "DepthResMinVal").map_or(Ok(0.0), |_| number(&t, "DepthResMinVal"))?;
            if o == 0 {
                None
            } else {
                let start = byte_plane(bytes, &h, o, p, "repeatability")?;
                Some((start, shift, min, number(&t, "DepthResFilterVal")?))
            }
        }
        _ => None,
    };
    let line = h.nx.div_ceil(8) * 8;
    let mut z = Vec::with_capacity(h.nx * h.ny);
    let mut valid = Vec::with_capacity(h.nx * h.ny);
    for row in 0..h.ny {
        for col in 0..h.nx {
            let a = h.offset + row * h.stride + col * 4;
            let v = f64::from(f32_le(bytes, a));
            let repeatable = plane.is_none_or(|(start, shift, min, filter)| {
                f64::from(bytes[start + row * line + col]) * shift + min <= filter
            });
            valid.push(v < limit && repeatable);
            z.push(v * 1e6);
        }
    }
    let mut map = HeightMap::with_mask(h.nx, h.ny, h.dx, h.dy, z, valid).map_err(Al3dError::Map)?;
    for (k, v) in &t {
        if !k.is_empty() && v.chars().all(|c| c.is_ascii_graphic() || c == ' ') {
            map.set_metadata(format!("al3d.{k}"), v.trim());
        }
    }
    if plane.is_some() {
        map.set_metadata("al3d.repeatability_mask", "applied");
    }
    Ok(map)
}

/// A texture channel: the mean of its planes' bytes at every point.
fn read_texture(
    bytes: &[u8],
    t: &[(String, String)],
    h: &Header,
    name: &str,
    planes: &[usize],
) -> Result<HeightMap, Al3dError> {
    let line = h.nx.div_ceil(8) * 8;
    let n = planes.len() as f64;
    let mut z = Vec::with_capacity(h.nx * h.ny);
    for row in 0..h.ny {
        for col in 0..h.nx {
            let sum: f64 = planes
                .iter()
                .map(|p| f64::from(bytes[p + row * line + col]))
                .sum();
            z.push(sum / n);
        }
    }
    let mut map = HeightMap::new(h.nx, h.ny, h.dx, h.dy, z).map_err(Al3dError::Map)?;
    for (k, v) in t {
        if !k.is_empty() && v.chars().all(|c| c.is_ascii_graphic() || c == ' ') {
            map.set_metadata(format!("al3d.{k}"), v.trim());
        }
    }
    map.set_metadata("al3d.channel", name);
    Ok(map)
}
