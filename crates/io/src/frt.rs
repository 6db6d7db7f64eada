//! FRT MicroProf (`.frt`) reader: maps of FRT's (now FormFactor's) MicroProf
//! profilometers (chromatic white-light and other point sensors on an x/y table).
//!
//! Layout (little-endian; as the independent readers Gwyddion `microprof.c` and
//! SurfaceTopography `FRT.py` describe it, and checked block by block on `frt-1.frt` and
//! `frt-2.frt`): the 12-byte magic `FRTM_GLIDERV`, a 4-byte version (`1.00`: 32-bit
//! block sizes, `1.01`: 64-bit), the number of blocks (u16), then that many blocks, each
//! an id (u16), a payload size (u32 or u64) and the payload. Blocks read:
//!
//! | id | payload |
//! | --- | --- |
//! | `0x0065`, `0x0077` | description, parameter-set name (text) |
//! | `0x0066` | points x, points y, bits per point (u32 × 3) |
//! | `0x0067` | range x, range y, centre offset x, y (f64, m), y/x range ratio (f64), scan direction (u32) |
//! | `0x006c` | measuring-range code (u32), z scale (f64, m per raw unit) |
//! | `0x0070` | first and last valid raw value (u32 × 2) |
//! | `0x0071` | z offset (f64, m; a display setting) |
//! | `0x0072` | measurement start, end (u32, seconds since 1970, UTC), duration (u32, s) |
//! | `0x007d` | four u16 buffer ids, then images: type, points x, points y, bits (u32 × 4), data |
//! | `0x000b` | the single image of old files: points x × y raw values (sizes from `0x0066`) |
//! | `0x006e`, `0x007f`, `0x008e`, `0x00a6` | sensor type code, calibration text, sensor serial, objective name |
//!
//! Every other block is skipped by its size. Image data: `points y` rows of `points x`
//! values (x fastest), u16 for 16 bits per point, i32 for 32; the first stored row is
//! row 0 (`y = 0`), as SurfaceTopography reads it. (Gwyddion flips the rows so that its
//! top-down display matches the instrument's; the statistics are the same either way.)
//!
//! Conventions: pitch = range / points along each axis; heights = raw × z scale (m →
//! µm) for the height image types (topography, thickness, sample thickness, AFM); other
//! types (intensity, phase, camera, …) are read only as intensity maps, values as stored.
//! Invalid points: the raw value 1 (the instrument's "undefined" marker) in every image,
//! and, for 16-bit height images, any raw value outside block `0x0070`'s valid range.
//! `frt-1.frt` needs the second rule: its last row (an interrupted scan, end time
//! `0xFFFFFFFF`) is raw 0, below the first valid value 5; read as heights that row
//! would be 500 points at z = 0 under a surface at 79 µm. (SurfaceTopography and
//! Gwyddion mask only the value 1.) The range is not applied to 32-bit images: no
//! sample file shows what it means for them.
//!
//! Channels: the images of block `0x007d` (which repeats the `0x000b` image as its
//! first), named by type (`Topography`, `Intensity`, … with the sensor and buffer when
//! they are not the first); `0x000b` as `Topography` when there is no `0x007d`. A height
//! read without a channel takes the first height image, an intensity read the first
//! intensity image (else the first image). Metadata keys `frt.*`; the z offset is not
//! added to the heights (SurfaceTopography and Gwyddion do not add it either).
//!
//! Not read: profile (line-scan) files, the drift-correction data, x-position tables,
//! the text export (`HeaderLines=`). The file stores no wavelength.

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::{f64_le, i32_le, u16_le, u32_le};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};

/// What is wrong with a FRT file: the binary readers' one error type.
pub type FrtError = crate::format_error::FormatError;

const MAGIC: &[u8; 12] = b"FRTM_GLIDERV";
/// Magic, version, block count.
const HEADER: usize = 18;
/// The raw value FRT writes for a point without a measurement.
const UNDEFINED: i64 = 1;

/// Image types (low 16 bits of the type word) whose values are heights.
const TOPOGRAPHY: u32 = 0x4;
const HEIGHT_TYPES: u32 = TOPOGRAPHY | 0x80 | 0x800 | 0x1000;
const INTENSITY: u32 = 0x2;

/// Scores `bytes` as FRT: certain for the magic `FRTM_GLIDERV`.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.starts_with(MAGIC) { 100 } else { 0 }
}

/// Latin-1 text up to the first NUL, trimmed.
fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    b[..end]
        .iter()
        .map(|&c| char::from(c))
        .collect::<String>()
        .trim()
        .to_string()
}

/// One block: id, where its header starts, its payload.
struct Block<'a> {
    id: u16,
    at: usize,
    body: usize,
    data: &'a [u8],
}

impl Block<'_> {
    /// The payload, which must be exactly `size` bytes long.
    fn fixed(&self, size: usize, what: &str) -> Result<&[u8], FrtError> {
        if self.data.len() == size {
            Ok(self.data)
        } else {
            Err(FrtError::Block {
                block: self.id.into(),
                offset: self.at,
                what: format!(
                    "{what}: the block holds {} bytes, expected {size}",
                    self.data.len()
                ),
            })
        }
    }
}

/// One image: its type word, size, sample width and where its data starts.
struct Image {
    kind: u32,
    nx: usize,
    ny: usize,
    bits: usize,
    data: usize,
}

impl Image {
    fn is_height(&self) -> bool {
        let t = self.kind & 0xffff;
        t < 0x4000 && t & HEIGHT_TYPES != 0
    }

    /// Name from the type word: base type, then sensor, buffer and flags when not the
    /// defaults (bit layout as Gwyddion documents it).
    fn name(&self) -> String {
        let t = self.kind & 0xffdf;
        let base = if t >= 0x4000 {
            "Fit".to_string()
        } else {
            [
                (TOPOGRAPHY, "Topography"),
                (0x80, "Thickness"),
                (0x800, "Sample thickness"),
                (0x1000, "AFM"),
                (INTENSITY, "Intensity"),
                (0x1, "Piezo"),
                (0x8, "Real part"),
                (0x10, "Imaginary part"),
                (0x40, "Camera"),
                (0x100, "DIB from file"),
                (0x200, "Absolute value"),
                (0x400, "Phase"),
                (0x2000, "Quality"),
            ]
            .iter()
            .find(|(bit, _)| t & bit != 0)
            .map_or_else(
                || format!("type 0x{:08x}", self.kind),
                |(_, n)| n.to_string(),
            )
        };
        let mut name = base;
        match self.kind & 0x3000_0000 {
            0 => {}
            0x1000_0000 => name.push_str(" (bottom sensor)"),
            s => name.push_str(&format!(" (sensor {})", s >> 28)),
        }
        let buffer = (self.kind & 0x0f00_0000) >> 24;
        if buffer > 0 {
            name.push_str(&format!(" {}", buffer + 1));
        }
        for (bit, flag) in [
            (0x1_0000, "extended"),
            (0x2_0000, "computed"),
            (0x20, "filtered"),
        ] {
            if self.kind & bit != 0 {
                name.push_str(&format!(", {flag}"));
            }
        }
        name
    }
}

/// The blocks of a file that this reader interprets, and its images.
struct Frt<'a> {
    version: String,
    blocks: Vec<Block<'a>>,
    images: Vec<Image>,
}

/// The ids this reader interprets (each may occur once).
const READ: [u16; 14] = [
    0x000b, 0x0065, 0x0066, 0x0067, 0x006c, 0x006e, 0x0070, 0x0071, 0x0072, 0x0077, 0x007d, 0x007f,
    0x008e, 0x00a6,
];

impl<'a> Frt<'a> {
    fn block(&self, id: u16) -> Option<&Block<'a>> {
        self.blocks.iter().find(|b| b.id == id)
    }
}

fn parse(bytes: &[u8]) -> Result<Frt<'_>, FrtError> {
    let end = bytes.len();
    if end < HEADER {
        return Err(FrtError::Truncated {
            what: "the file header (magic, version, block count)".into(),
            offset: 0,
            needed: HEADER as u64,
            end,
        });
    }
    if !bytes.starts_with(MAGIC) {
        return Err(FrtError::Field {
            field: "magic",
            offset: 0,
            value: format!("{:?}", text(&bytes[..12])),
            expected: "FRTM_GLIDERV",
        });
    }
    let version = text(&bytes[12..16]);
    let size_width = match &bytes[12..16] {
        b"1.00" => 4,
        b"1.01" => 8,
        _ => {
            return Err(FrtError::Field {
                field: "version",
                offset: 12,
                value: format!("{version:?}"),
                expected: "1.00 or 1.01 (other versions are not read)",
            });
        }
    };
    let count = usize::from(u16_le(bytes, 16));
    let mut at = HEADER;
    let mut blocks: Vec<Block<'_>> = Vec::new();
    for k in 0..count {
        let head = 2 + size_width;
        if end - at < head {
            return Err(FrtError::Truncated {
                what: format!("the header of block {k} of {count}"),
                offset: at,
                needed: head as u64,
                end,
            });
        }
        let id = u16_le(bytes, at);
        let size = if size_width == 4 {
            u64::from(u32_le(bytes, at + 2))
        } else {
            u64::from(u32_le(bytes, at + 2)) | (u64::from(u32_le(bytes, at + 6)) << 32)
        };
        let body = at + head;
        if size > (end - body) as u64 {
            return Err(FrtError::Truncated {
                what: format!("the payload of block 0x{id:04x} ({k} of {count})"),
                offset: body,
                needed: size,
                end,
            });
        }
        let next = body + size as usize;
        if READ.contains(&id) {
            if let Some(first) = blocks.iter().find(|b| b.id == id) {
                return Err(FrtError::Block {
                    block: id.into(),
                    offset: at,
                    what: format!("appears a second time (first at byte {})", first.at),
                });
            }
            blocks.push(Block {
                id,
                at,
                body,
                data: &bytes[body..next],
            });
        }
        at = next;
    }
    let mut frt = Frt {
        version,
        blocks,
        images: Vec::new(),
    };
    frt.images = images(&frt)?;
    Ok(frt)
}

/// Bytes of `nx × ny` points of `bits` bits, if that fits in a `u64`.
fn data_size(nx: u32, ny: u32, bits: u32) -> Option<u64> {
    u64::from(nx)
        .checked_mul(u64::from(ny))?
        .checked_mul(u64::from(bits / 8))
}

/// Checks an image header (size, bits) against the bytes left for its data.
fn image(
    block: &Block<'_>,
    header_at: usize,
    (kind, nx, ny, bits): (u32, u32, u32, u32),
    data: usize,
    left: usize,
) -> Result<Image, FrtError> {
    let bad = |what: String| FrtError::Block {
        block: block.id.into(),
        offset: header_at,
        what,
    };
    if !matches!(bits, 16 | 32) {
        return Err(bad(format!("{bits} bits per point: expected 16 or 32")));
    }
    if nx == 0 || ny == 0 {
        return Err(bad(format!(
            "image of {nx} x {ny} points: expected at least 1 x 1"
        )));
    }
    let need = data_size(nx, ny, bits).unwrap_or(u64::MAX);
    if need > left as u64 {
        return Err(bad(format!(
            "an image of {nx} x {ny} points of {bits} bits needs {need} bytes from byte {data}, the block has {left} left"
        )));
    }
    Ok(Image {
        kind,
        nx: nx as usize,
        ny: ny as usize,
        bits: bits as usize,
        data,
    })
}

fn images(f: &Frt<'_>) -> Result<Vec<Image>, FrtError> {
    let mut out = Vec::new();
    if let Some(b) = f.block(0x007d) {
        if b.data.len() < 8 {
            return Err(FrtError::Block {
                block: b.id.into(),
                offset: b.at,
                what: format!(
                    "the block holds {} bytes, fewer than its 8-byte buffer ids",
                    b.data.len()
                ),
            });
        }
        let mut p = 8;
        while p < b.data.len() {
            let left = b.data.len() - p;
            if left < 16 {
                return Err(FrtError::Block {
                    block: b.id.into(),
                    offset: b.body + p,
                    what: format!(
                        "{left} bytes left at the end of the block: too few for a 16-byte image header"
                    ),
                });
            }
            let d = &b.data[p..p + 16];
            let head = (u32_le(d, 0), u32_le(d, 4), u32_le(d, 8), u32_le(d, 12));
            let img = image(b, b.body + p, head, b.body + p + 16, left - 16)?;
            p += 16 + img.nx * img.ny * img.bits / 8;
            out.push(img);
        }
    }
    if out.is_empty()
        && let Some(b) = f.block(0x000b)
    {
        let Some(size) = f.block(0x0066) else {
            return Err(FrtError::Missing {
                block: 0x0066.into(),
                what: "the image size of the data in block 0x000b",
                hint: "",
            });
        };
        let s = size.fixed(12, "image size")?;
        let head = (TOPOGRAPHY, u32_le(s, 0), u32_le(s, 4), u32_le(s, 8));
        // Bits and sizes checked first (no limit), then the data against them.
        let img = image(size, size.at, head, b.body, usize::MAX)?;
        let need = data_size(head.1, head.2, head.3).unwrap_or(u64::MAX);
        if need != b.data.len() as u64 {
            return Err(FrtError::Block {
                block: b.id.into(),
                offset: b.at,
                what: format!(
                    "holds {} bytes, but block 0x0066 says {} x {} points of {} bits ({need} bytes)",
                    b.data.len(),
                    img.nx,
                    img.ny,
                    img.bits
                ),
            });
        }
        out.push(img);
    }
    if out.is_empty() {
        return Err(FrtError::Missing {
            block: 0x000b.into(),
            what: "the image data",
            hint: ", and block 0x007d holds no image either",
        });
    }
    Ok(out)
}

/// Channel names: unique, the image's index appended where two would be alike.
fn names(images: &[Image]) -> Vec<String> {
    let base: Vec<String> = images.iter().map(Image::name).collect();
    // Counted once (a mutated file may list thousands of 1 x 1 images).
    let mut count = std::collections::HashMap::new();
    for n in &base {
        *count.entry(n.as_str()).or_insert(0usize) += 1;
    }
    base.iter()
        .enumerate()
        .map(|(i, n)| {
            if count[n.as_str()] > 1 {
                format!("{n} [{i}]")
            } else {
                n.clone()
            }
        })
        .collect()
}

/// Pitch in µm: the scan range of block `0x0067` over the image's points.
fn pitch_um(f: &Frt<'_>, img: &Image) -> Result<(f64, f64), FrtError> {
    let Some(b) = f.block(0x0067) else {
        return Err(FrtError::Missing {
            block: 0x0067.into(),
            what: "the scan range",
            hint: ", so the pixel pitch is unknown: give it (--pixel-um)",
        });
    };
    let d = b.fixed(44, "scan range")?;
    let axis = |a: usize, n: usize, name: &str| {
        let range = f64_le(d, a);
        let p = range * 1e6 / n as f64;
        if range.is_finite() && p.is_finite() && p > 0.0 {
            Ok(p)
        } else {
            Err(FrtError::Block {
                block: b.id.into(),
                offset: b.body + a,
                what: format!(
                    "{name} range = {range} m: expected a length > 0 (or give the pitch, --pixel-um)"
                ),
            })
        }
    };
    Ok((axis(0, img.nx, "x")?, axis(8, img.ny, "y")?))
}

/// The channels of an FRT file: its images (see the module notes), heights in `m`.
///
/// # Errors
/// [`FrtError`] naming the block or byte offset at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, FrtError> {
    let f = parse(bytes)?;
    Ok(f.images
        .iter()
        .zip(names(&f.images))
        .map(|(img, name)| Channel {
            name,
            unit: img.is_height().then(|| "m".to_string()),
            nx: img.nx,
            ny: img.ny,
            pitch_um: pitch_um(&f, img).ok(),
        })
        .collect())
}

/// `YYYY-MM-DD hh:mm:ss UTC` of a count of seconds since 1970-01-01 00:00 UTC.
fn utc(seconds: u32) -> String {
    let (year, month, day) = crate::provenance::civil_from_days(i64::from(seconds / 86_400));
    let s = seconds % 86_400;
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

/// Reads one image (`options.channel`, default as the module notes say): heights in µm
/// (raw × z scale), or values as stored for intensity.
///
/// # Errors
/// [`FrtError`] naming the block or byte offset at fault; a height read of an image
/// that is not a height image is refused.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, FrtError> {
    let f = parse(bytes)?;
    let index = match (options.channel, kind) {
        (Some(i), _) => i,
        (None, ValueKind::Height) => f.images.iter().position(Image::is_height).unwrap_or(0),
        (None, ValueKind::Intensity) => f
            .images
            .iter()
            .position(|i| i.kind & 0xffdf == INTENSITY)
            .unwrap_or(0),
    };
    let names = names(&f.images);
    let Some(img) = f.images.get(index) else {
        return Err(FrtError::Block {
            block: 0x007d.into(),
            offset: f.block(0x007d).map_or(16, |b| b.at),
            what: format!(
                "channel {index} asked for, the file has {} image(s)",
                f.images.len()
            ),
        });
    };
    let scale = match kind {
        ValueKind::Intensity => 1.0,
        ValueKind::Height => {
            if !img.is_height() {
                return Err(FrtError::Block {
                    block: 0x007d.into(),
                    offset: img.data.saturating_sub(16),
                    what: format!(
                        "channel {index} ({}, type 0x{:08x}) is not a height image; read it as an intensity map",
                        names[index], img.kind
                    ),
                });
            }
            let Some(b) = f.block(0x006c) else {
                return Err(FrtError::Missing {
                    block: 0x006c.into(),
                    what: "the z scale",
                    hint: ", so the heights cannot be scaled",
                });
            };
            let zscale = f64_le(b.fixed(12, "z scale")?, 4);
            let s = zscale * 1e6;
            if !(zscale.is_finite() && s.is_finite() && s != 0.0) {
                return Err(FrtError::Block {
                    block: b.id.into(),
                    offset: b.body + 4,
                    what: format!("z scale = {zscale} m: expected a finite, non-zero scale"),
                });
            }
            s
        }
    };
    let (dx, dy) = match options.pixel_um {
        Some(p) => p,
        None => pitch_um(&f, img)?,
    };
    let range = match f.block(0x0070) {
        Some(b) => {
            let d = b.fixed(8, "valid range")?;
            Some((i64::from(u32_le(d, 0)), i64::from(u32_le(d, 4))))
        }
        None => None,
    };
    let range_applies = kind == ValueKind::Height && img.bits == 16 && range.is_some();
    let (lo, hi) = match range {
        Some(r) if range_applies => r,
        _ => (i64::MIN, i64::MAX),
    };
    let n = img.nx * img.ny;
    let raw = &bytes[img.data..img.data + n * img.bits / 8];
    let value = |v: i64| {
        if v == UNDEFINED || v < lo || v > hi {
            f64::NAN
        } else {
            v as f64 * scale
        }
    };
    let z: Vec<f64> = if img.bits == 16 {
        raw.chunks_exact(2)
            .map(|c| value(i64::from(u16_le(c, 0))))
            .collect()
    } else {
        raw.chunks_exact(4)
            .map(|c| value(i64::from(i32_le(c, 0))))
            .collect()
    };
    let mut map = HeightMap::new(img.nx, img.ny, dx, dy, z).map_err(FrtError::Map)?;
    metadata(&mut map, &f)?;
    map.set_metadata("frt.channel", names[index].clone());
    map.set_metadata("frt.data_type", format!("0x{:08x}", img.kind));
    map.set_metadata("frt.bits_per_point", img.bits.to_string());
    map.set_metadata(
        "frt.valid_range",
        match range {
            Some((a, b)) if range_applies => format!("{a}..{b} (block 0x0070), and not 1"),
            Some((a, b)) => format!("{a}..{b} in block 0x0070, not applied; only 1 is invalid"),
            None => "no block 0x0070; only 1 is invalid".to_string(),
        },
    );
    Ok(map)
}

/// The cheap metadata: texts, offsets, times, sensor identification.
fn metadata(map: &mut HeightMap, f: &Frt<'_>) -> Result<(), FrtError> {
    map.set_metadata("frt.version", f.version.clone());
    for (id, key) in [
        (0x0065, "frt.description"),
        (0x0077, "frt.parameter_set"),
        (0x007f, "frt.calibration"),
    ] {
        if let Some(b) = f.block(id) {
            let t = text(b.data);
            if !t.is_empty() {
                map.set_metadata(key, t);
            }
        }
    }
    if let Some(b) = f.block(0x0067) {
        let d = b.fixed(44, "scan range")?;
        map.set_metadata("frt.range_x_m", f64_le(d, 0).to_string());
        map.set_metadata("frt.range_y_m", f64_le(d, 8).to_string());
        map.set_metadata("frt.offset_x_m", f64_le(d, 16).to_string());
        map.set_metadata("frt.offset_y_m", f64_le(d, 24).to_string());
        map.set_metadata("frt.scan_direction", u32_le(d, 40).to_string());
    }
    if let Some(b) = f.block(0x006c) {
        let d = b.fixed(12, "z scale")?;
        map.set_metadata("frt.measuring_range_code", u32_le(d, 0).to_string());
        map.set_metadata("frt.z_scale_m", f64_le(d, 4).to_string());
    }
    if let Some(b) = f.block(0x0071) {
        let d = b.fixed(8, "z offset")?;
        map.set_metadata("frt.z_offset_m", f64_le(d, 0).to_string());
    }
    if let Some(b) = f.block(0x006e) {
        let d = b.fixed(12, "hardware")?;
        map.set_metadata("frt.sensor_type", u32_le(d, 0).to_string());
    }
    if let Some(b) = f.block(0x0072) {
        let d = b.fixed(12, "measurement time")?;
        // 0xFFFFFFFF: not recorded (an interrupted measurement).
        for (a, key) in [(0, "frt.measurement_started"), (4, "frt.measurement_ended")] {
            let t = u32_le(d, a);
            if t != u32::MAX {
                map.set_metadata(key, utc(t));
            }
        }
        let t = u32_le(d, 8);
        if t != u32::MAX {
            map.set_metadata("frt.measurement_time_s", t.to_string());
        }
    }
    // Sensor serial: u32 length, then the text, then a date and counts.
    if let Some(b) = f.block(0x008e)
        && b.data.len() >= 4
    {
        let len = u32_le(b.data, 0) as usize;
        if len <= b.data.len() - 4 {
            let t = text(&b.data[4..4 + len]);
            if !t.is_empty() {
                map.set_metadata("frt.sensor_serial", t);
            }
        }
    }
    // Objective: u32 length, the name, a 256-byte correction file, a u32 flag.
    if let Some(b) = f.block(0x00a6)
        && b.data.len() >= 264
    {
        let len = u32_le(b.data, 0) as usize;
        if len == b.data.len() - 264 {
            let t = text(&b.data[4..4 + len]);
            if !t.is_empty() {
                map.set_metadata("frt.objective", t);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_dates() {
        // `date -u -d @N` (GNU coreutils): 0 → 1970-01-01 00:00:00, 951782400 →
        // 2000-02-29 00:00:00, 1678463840 → 2023-03-10 15:57:20, 4294967294 →
        // 2106-02-07 06:28:14.
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(1_678_463_840), "2023-03-10 15:57:20 UTC");
        assert_eq!(utc(4_294_967_294), "2106-02-07 06:28:14 UTC");
    }
}
