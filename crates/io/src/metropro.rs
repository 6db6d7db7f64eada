//! Zygo MetroPro (`.dat`) reader: phase maps of Zygo's interferometers.
//!
//! Layout (big-endian; Zygo's MetroPro reference guide OMP-0347, "data file format"):
//! a magic (`88 1B 03 6F`, `…70` or `…71` for header formats 1, 2, 3), `header_format`
//! (u16, byte 4), `header_size` (u32, byte 6: 834 for formats 1 and 2, 4096 for 3), then
//! the header fields this reader uses:
//!
//! | byte | field |
//! | --- | --- |
//! | 12 | software date (30 bytes of text) |
//! | 52, 54, 56 / 60 | intensity frame width, height, buckets (u16) / its size in bytes (u32) |
//! | 68, 70 / 72 | phase frame width, height (u16) / its size in bytes (u32) |
//! | 76 | time stamp (i32, seconds since 1970) |
//! | 80 | comment (82 bytes) |
//! | 164, 168, 172, 176, 180, 184 | `intf_scale_factor` S, `wavelength_in` W (m), numerical aperture, `obliquity_factor` O, magnification, `lateral_res` (m per pixel) (f32) |
//! | 218 | `phase_res` (i16): 0, 1, 2 → R = 4096, 32768, 131072 |
//! | 246 / 258 | objective name (12) / part name (40) |
//!
//! After the header: the intensity frames (u16, `ac_n_bytes` bytes), then the phase
//! frame (i32, `cn_width × cn_height`, row-major, x fastest).
//!
//! Conventions: a height is `raw × S × W × O / R` metres (converted to µm); raw values
//! ≥ 2147483640 are invalid points (MetroPro's "no data"). The pitch is `lateral_res`
//! in x and y; a file with `lateral_res = 0` is uncalibrated and needs `pixel_um`.
//! Channels: `phase` (heights, m), then, when the file has an intensity frame, the
//! intensity channel `intensity` (`a.u.`, `ac_width × ac_height`, u16 as stored; one
//! bucket) or `intensity0`, `intensity1`, ... (one per bucket, listed but refused when
//! read: the order of several buckets' samples is not confirmed by an independent
//! reader here). The value 65535 marks an invalid intensity point (surfalize's constant
//! for MetroPro's intensity no-data; none in `metropro-1.dat`, whose frame Gwyddion
//! 2.62 and surfalize 0.19.2 both read with the same values as this reader). The
//! intensity frame has the phase frame's pitch. Metadata keys `metropro.*`.
//!
//! Not read: the coordinate origins, the header-format-3 extension beyond byte 834.

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::{f32_be, i32_be, u16_be, u32_be};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};

/// What is wrong with a METROPRO file: the binary readers' one error type.
pub type MetroProError = crate::format_error::FormatError;

const MAGIC: [u8; 3] = [0x88, 0x1b, 0x03];
const BASE_HEADER: usize = 834;
const NO_DATA: i32 = 2_147_483_640;

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).trim().to_string()
}

/// Scores `bytes` as MetroPro: certain for one of the three magics with a matching
/// header format number.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.len() < 6 || bytes[..3] != MAGIC || !(0x6f..=0x71).contains(&bytes[3]) {
        return 0;
    }
    if u16::from(bytes[3] - 0x6e) == u16_be(bytes, 4) {
        100
    } else {
        70
    }
}

struct Header {
    size: usize,
    ac_bytes: u64,
    /// Intensity frame width, height, buckets.
    ac: (usize, usize, usize),
    nx: usize,
    ny: usize,
    scale_m: f64,
    lateral_m: f64,
}

fn header(bytes: &[u8]) -> Result<Header, MetroProError> {
    let end = bytes.len();
    if end < BASE_HEADER {
        return Err(MetroProError::Truncated {
            what: "the header".into(),
            offset: 0,
            needed: BASE_HEADER as u64,
            end,
        });
    }
    let format = u16_be(bytes, 4);
    let size = u32_be(bytes, 6);
    let expected_size = if format == 3 { 4096 } else { 834 };
    if !(1..=3).contains(&format) {
        return Err(MetroProError::Field {
            field: "header_format",
            offset: 4,
            value: format.to_string(),
            expected: "1, 2 or 3",
        });
    }
    if size != expected_size {
        return Err(MetroProError::Field {
            field: "header_size",
            offset: 6,
            value: size.to_string(),
            expected: "834 (header formats 1, 2) or 4096 (format 3)",
        });
    }
    let size = size as usize;
    if end < size {
        return Err(MetroProError::Truncated {
            what: "the header".into(),
            offset: 0,
            needed: size as u64,
            end,
        });
    }
    let ac_n =
        u64::from(u16_be(bytes, 52)) * u64::from(u16_be(bytes, 54)) * u64::from(u16_be(bytes, 56));
    let ac_bytes = u64::from(u32_be(bytes, 60));
    if ac_bytes != 2 * ac_n {
        return Err(MetroProError::Field {
            field: "ac_n_bytes",
            offset: 60,
            value: ac_bytes.to_string(),
            expected: "2 × intensity width × height × buckets",
        });
    }
    let (nx, ny) = (u16_be(bytes, 68), u16_be(bytes, 70));
    let cn_bytes = u64::from(u32_be(bytes, 72));
    if nx == 0 || ny == 0 {
        return Err(MetroProError::Field {
            field: "cn_width x cn_height",
            offset: 68,
            value: format!("{nx} x {ny}"),
            expected: "a phase frame of at least 1 x 1 points",
        });
    }
    let n = u64::from(nx) * u64::from(ny);
    if cn_bytes != 4 * n {
        return Err(MetroProError::Field {
            field: "cn_n_bytes",
            offset: 72,
            value: cn_bytes.to_string(),
            expected: "4 × phase width × height",
        });
    }
    let need = size as u64 + ac_bytes + cn_bytes;
    if (end as u64) < need {
        return Err(MetroProError::Truncated {
            what: format!("the phase frame ({nx} x {ny} i32 after {ac_bytes} bytes of intensity)"),
            offset: size + ac_bytes as usize,
            needed: cn_bytes,
            end,
        });
    }
    let r = match u16_be(bytes, 218) as i16 {
        0 => 4096.0,
        1 => 32768.0,
        2 => 131072.0,
        other => {
            return Err(MetroProError::Field {
                field: "phase_res",
                offset: 218,
                value: other.to_string(),
                expected: "0, 1 or 2 (R = 4096, 32768, 131072)",
            });
        }
    };
    let (s, w, o) = (
        f64::from(f32_be(bytes, 164)),
        f64::from(f32_be(bytes, 168)),
        f64::from(f32_be(bytes, 176)),
    );
    let scale_m = s * w * o / r;
    if !scale_m.is_finite() || scale_m <= 0.0 {
        return Err(MetroProError::Field {
            field: "intf_scale_factor × wavelength_in × obliquity_factor",
            offset: 164,
            value: format!("{s} × {w} × {o}"),
            expected: "finite factors whose product is > 0",
        });
    }
    Ok(Header {
        size,
        ac_bytes,
        ac: (
            usize::from(u16_be(bytes, 52)),
            usize::from(u16_be(bytes, 54)),
            usize::from(u16_be(bytes, 56)),
        ),
        nx: usize::from(nx),
        ny: usize::from(ny),
        scale_m,
        lateral_m: f64::from(f32_be(bytes, 184)),
    })
}

fn pitch_um(h: &Header) -> Option<(f64, f64)> {
    let p = h.lateral_m * 1e6;
    (p.is_finite() && p > 0.0).then_some((p, p))
}

/// The names of the intensity channels (none when the file has no intensity frame).
fn intensity_names(h: &Header) -> Vec<String> {
    match h.ac {
        _ if h.ac_bytes == 0 => Vec::new(),
        (_, _, 1) => vec!["intensity".into()],
        (_, _, b) => (0..b).map(|k| format!("intensity{k}")).collect(),
    }
}

/// The channels of a MetroPro file: `phase` (heights in m), then its intensity
/// channels (`a.u.`; module notes).
///
/// # Errors
/// [`MetroProError`] naming the header field or byte offset at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, MetroProError> {
    let h = header(bytes)?;
    let mut out = vec![Channel {
        name: "phase".into(),
        unit: Some("m".into()),
        nx: h.nx,
        ny: h.ny,
        pitch_um: pitch_um(&h),
    }];
    out.extend(intensity_names(&h).into_iter().map(|name| Channel {
        name,
        unit: Some("a.u.".into()),
        nx: h.ac.0,
        ny: h.ac.1,
        pitch_um: pitch_um(&h),
    }));
    Ok(out)
}

/// Reads a MetroPro channel (`options.channel`, default 0 = `phase`): the phase frame
/// as heights in µm, or the intensity frame's values as stored (see the module notes).
/// The phase read as intensity, or the intensity as heights, is refused.
///
/// # Errors
/// [`MetroProError`] naming the header field or byte offset at fault.
pub fn read(
    bytes: &[u8],
    options: &ReadOptions,
    kind: ValueKind,
) -> Result<HeightMap, MetroProError> {
    let h = header(bytes)?;
    let names = intensity_names(&h);
    let index = options.channel.unwrap_or(0);
    if index > names.len() {
        return Err(MetroProError::Field {
            field: "ac_n_buckets",
            offset: 56,
            value: names.len().to_string(),
            expected: "more intensity buckets than the channel asked for",
        });
    }
    match (index, kind) {
        (0, ValueKind::Intensity) => {
            return Err(MetroProError::ChannelHolds {
                channel: "phase".into(),
                what: "heights (m), not an intensity image; the intensity is the channel `intensity`",
            });
        }
        (0, ValueKind::Height) => {}
        (i, ValueKind::Height) => {
            return Err(MetroProError::ChannelHolds {
                channel: names[i - 1].clone(),
                what: "an intensity frame (a.u.), not heights; read it as the intensity map (--intensity-channel)",
            });
        }
        (i, ValueKind::Intensity) => return read_intensity(bytes, &h, &names[i - 1], options),
    }
    let (dx, dy) = pitch_or(&h, options)?;
    let start = h.size + h.ac_bytes as usize;
    let scale_um = h.scale_m * 1e6;
    let z: Vec<f64> = bytes[start..start + 4 * h.nx * h.ny]
        .chunks_exact(4)
        .map(|c| {
            let raw = i32_be(c, 0);
            if raw >= NO_DATA {
                f64::NAN
            } else {
                f64::from(raw) * scale_um
            }
        })
        .collect();
    let mut map = HeightMap::new(h.nx, h.ny, dx, dy, z).map_err(MetroProError::Map)?;
    metadata(&mut map, bytes);
    Ok(map)
}

/// The file's pitch, or the `pixel_um` override; an uncalibrated file needs the latter.
fn pitch_or(h: &Header, options: &ReadOptions) -> Result<(f64, f64), MetroProError> {
    match (pitch_um(h), options.pixel_um) {
        (_, Some(p)) | (Some(p), None) => Ok(p),
        (None, None) => Err(MetroProError::Field {
            field: "lateral_res",
            offset: 184,
            value: h.lateral_m.to_string(),
            expected: "a pitch > 0 in metres (or give the pixel pitch, --pixel-um)",
        }),
    }
}

fn metadata(map: &mut HeightMap, bytes: &[u8]) {
    map.set_metadata("metropro.software_date", text(&bytes[12..42]));
    map.set_metadata(
        "metropro.time_stamp",
        (u32_be(bytes, 76) as i32).to_string(),
    );
    map.set_metadata("metropro.comment", text(&bytes[80..162]));
    map.set_metadata("metropro.wavelength_m", f32_be(bytes, 168).to_string());
    map.set_metadata(
        "metropro.numerical_aperture",
        f32_be(bytes, 172).to_string(),
    );
    map.set_metadata("metropro.magnification", f32_be(bytes, 180).to_string());
    map.set_metadata("metropro.objective", text(&bytes[246..258]));
    map.set_metadata("metropro.part_name", text(&bytes[258..298]));
    map.set_metadata(
        "metropro.phase_res",
        (u16_be(bytes, 218) as i16).to_string(),
    );
}

/// The intensity frame (one bucket) as stored: u16, 65535 an invalid point.
fn read_intensity(
    bytes: &[u8],
    h: &Header,
    name: &str,
    options: &ReadOptions,
) -> Result<HeightMap, MetroProError> {
    let (nx, ny, buckets) = h.ac;
    if buckets != 1 {
        return Err(MetroProError::ChannelHolds {
            channel: name.into(),
            what: "one bucket of several, whose sample order is not confirmed here; only single-bucket intensity frames are read",
        });
    }
    let (dx, dy) = pitch_or(h, options)?;
    let frame = &bytes[h.size..h.size + 2 * nx * ny];
    let z: Vec<f64> = frame
        .chunks_exact(2)
        .map(|c| match u16_be(c, 0) {
            u16::MAX => f64::NAN,
            v => f64::from(v),
        })
        .collect();
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(MetroProError::Map)?;
    metadata(&mut map, bytes);
    map.set_metadata("metropro.channel", name);
    map.set_metadata("metropro.ac_range", (u16_be(bytes, 58) as i16).to_string());
    Ok(map)
}
