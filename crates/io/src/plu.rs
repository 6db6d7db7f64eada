//! Sensofar PLu (`.plu`) reader: topographies of Sensofar's confocal, interferometric and
//! focus-variation profilers (PLu, PLu neox, S neox, DCM).
//!
//! Layout (little-endian; as Sensofar's format is described by the independent readers
//! Gwyddion `sensofar.c` and SurfaceTopography `PLU.py`, and checked byte by byte on
//! `fixtures/real/instruments/plu-1.plu`):
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 128 | acquisition date, text, NUL-padded |
//! | 128 | 4 | time (u32) |
//! | 132 | 256 | comment, text, NUL-padded |
//! | 388 | 4 × 3 | `yres`, `xres`, `N_tall` (u32) |
//! | 400 | 4 × 7 | `dy_multip`, µm per pixel x, µm per pixel y, offset x, offset y, µm per pixel z, offset z (f32) |
//! | 428 | 4 × 5 | measurement type (1 profile, 3 topography), algorithm, method, objective, area type (u32) |
//! | 448 | 40 | scan settings (layout depends on the area type, size does not) |
//! | 488 | 8 + 4 | restore, number of layers, version, hardware, number of images (u8 each), 3 reserved, u32 |
//! | 500 | per layer | `y`, `x` (u32), `x × y` heights (f32, µm, row-major, x fastest), min, max (f32), `3 × x × y × images` bytes of RGB image |
//!
//! Conventions: heights and pitch are in µm as stored; the value 1000001 marks a point
//! that was not measured (an invalid point). Each layer is one channel `layerN` (µm);
//! after every layer, each of its images is one intensity channel `imageK` (`a.u.`,
//! `K` counting the images of all layers in order), listed after all the layers so that
//! the layers keep their indices. An image is 3 bytes per point (R, G, B; row-major, x
//! fastest, as the heights); its intensity is (R + G + B) / 3, the grey level itself in
//! a grey image (R = G = B, as in `plu-1.plu`, whose image Gwyddion 2.62 imports as
//! "Gray" and surfalize 0.19.2 as "Grayscale" with the same values). Every point of an
//! image is valid.
//! Metadata: `plu.date`, `plu.comment`, `plu.objective` / `plu.hardware` /
//! `plu.algorithm` / `plu.method` (Sensofar's numeric codes; the objective's name is
//! not decoded), `plu.version`.
//!
//! Not read: profile files (type 1).
//!
//! Detection: the format has no magic, so the score (60) requires a text date followed
//! only by NULs in the first 128 bytes, a measurement type of 1 or 3, at least one
//! layer, and the first layer's size equal to the calibration's `xres × yres`; a file
//! shorter than the header that starts with such a date scores 30 (a truncated PLU file).

use flakescatter_stats::heightmap::HeightMap;

use crate::bytes::{f32_le, u32_le};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};

/// What is wrong with a PLU file: the binary readers' one error type.
pub type PluError = crate::format_error::FormatError;

const HEADER: usize = 500;
const NOT_MEASURED: f32 = 1_000_001.0;

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).trim().to_string()
}

/// Scores `bytes` as PLU (there is no magic; see the module notes).
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.len() < 128 {
        return 0;
    }
    let date = &bytes[..128];
    let end = date.iter().position(|&c| c == 0).unwrap_or(128);
    let printable = end > 0 && date[..end].iter().all(|c| (0x20..0x7f).contains(c));
    let padded = date[end..].iter().all(|&c| c == 0);
    if !(printable && padded && end < 128) {
        return 0;
    }
    if bytes.len() < HEADER + 8 {
        // A date and NULs, then the file ends: most likely a truncated PLU file, which
        // the reader then reports with the offset.
        return 30;
    }
    let kind = u32_le(bytes, 428);
    let same_size =
        u32_le(bytes, 388) == u32_le(bytes, 500) && u32_le(bytes, 392) == u32_le(bytes, 504);
    if matches!(kind, 1 | 3) && bytes[489] >= 1 && same_size {
        60
    } else {
        0
    }
}

/// One layer: its size, where its heights start and how many images follow them.
struct Layer {
    nx: usize,
    ny: usize,
    data: usize,
    images: usize,
}

impl Layer {
    /// Where image `k` of this layer starts (after the heights, min and max).
    fn image(&self, k: usize) -> usize {
        self.data + 4 * self.nx * self.ny + 8 + 3 * self.nx * self.ny * k
    }
}

/// What channel `index` of a PLU file is.
enum Entry<'a> {
    /// The heights of a layer (its index).
    Heights(usize, &'a Layer),
    /// Image `k` of a layer (its channel name).
    Image(String, &'a Layer, usize),
}

/// The channels in index order: every layer, then every image.
fn entries(h: &Header) -> Vec<Entry<'_>> {
    let mut out: Vec<Entry<'_>> = h
        .layers
        .iter()
        .enumerate()
        .map(|(i, l)| Entry::Heights(i, l))
        .collect();
    for l in &h.layers {
        for k in 0..l.images {
            let j = out.len() - h.layers.len();
            out.push(Entry::Image(format!("image{j}"), l, k));
        }
    }
    out
}

struct Header {
    dx: f64,
    dy: f64,
    layers: Vec<Layer>,
}

fn header(bytes: &[u8]) -> Result<Header, PluError> {
    let end = bytes.len();
    if end < HEADER {
        return Err(PluError::Truncated {
            what: "the header".into(),
            offset: 0,
            needed: HEADER as u64,
            end,
        });
    }
    let kind = u32_le(bytes, 428);
    if kind != 3 {
        return Err(PluError::Field {
            field: "measurement type",
            offset: 428,
            value: kind.to_string(),
            expected: "3 (a topography; 1 = profile is not read)",
        });
    }
    let pitch = |field: &'static str, offset: usize| {
        let v = f64::from(f32_le(bytes, offset));
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(PluError::Field {
                field,
                offset,
                value: v.to_string(),
                expected: "a pitch > 0 in µm",
            })
        }
    };
    let dx = pitch("micrometres per pixel x", 404)?;
    let dy = pitch("micrometres per pixel y", 408)?;
    let n_layers = bytes[489];
    let images = u64::from(bytes[492]);
    if n_layers == 0 {
        return Err(PluError::Field {
            field: "number of layers",
            offset: 489,
            value: "0".into(),
            expected: "at least 1",
        });
    }
    let mut at = HEADER;
    let mut layers = Vec::new();
    for i in 0..n_layers {
        if end - at < 8 {
            return Err(PluError::Truncated {
                what: format!("the size of layer {i}"),
                offset: at,
                needed: 8,
                end,
            });
        }
        let (ny, nx) = (u32_le(bytes, at), u32_le(bytes, at + 4));
        if nx == 0 || ny == 0 {
            return Err(PluError::Field {
                field: "layer size",
                offset: at,
                value: format!("{nx} x {ny}"),
                expected: "at least 1 x 1 points",
            });
        }
        let n = u64::from(nx) * u64::from(ny);
        // Heights, min and max, RGB images: all must be in the file before anything
        // is allocated. u32 × u32 points fit in u64, but 4 or 3 × 255 bytes each do not:
        // the sum saturates (a saturated size is larger than any file, so refused).
        let need = n
            .saturating_mul(4)
            .saturating_add(8)
            .saturating_add(n.saturating_mul(3 * images));
        let left = (end - at - 8) as u64;
        if need > left {
            return Err(PluError::Truncated {
                what: format!("layer {i} ({nx} x {ny} heights, min/max, {images} RGB image(s))"),
                offset: at + 8,
                needed: need,
                end,
            });
        }
        layers.push(Layer {
            nx: nx as usize,
            ny: ny as usize,
            data: at + 8,
            images: images as usize,
        });
        at += 8 + need as usize;
    }
    Ok(Header { dx, dy, layers })
}

/// The channels of a PLU file: one height layer each (`layer0`, ..., in µm), then one
/// intensity image each (`image0`, ..., `a.u.`).
///
/// # Errors
/// [`PluError`] naming the field or byte offset at fault.
pub fn channels(bytes: &[u8], _options: &ReadOptions) -> Result<Vec<Channel>, PluError> {
    let h = header(bytes)?;
    Ok(entries(&h)
        .iter()
        .map(|e| {
            let (name, unit, l) = match e {
                Entry::Heights(i, l) => (format!("layer{i}"), "µm", l),
                Entry::Image(name, l, _) => (name.clone(), "a.u.", l),
            };
            Channel {
                name,
                unit: Some(unit.into()),
                nx: l.nx,
                ny: l.ny,
                pitch_um: Some((h.dx, h.dy)),
            }
        })
        .collect())
}

/// Reads one channel (`options.channel`, default the first) of a PLU file: a layer's
/// heights in µm (as stored, 1000001 as an invalid point), or an image's intensity
/// (R + G + B) / 3. A layer read as intensity, or an image read as heights, is refused.
///
/// # Errors
/// [`PluError`] naming the field or byte offset at fault.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, PluError> {
    let h = header(bytes)?;
    let all = entries(&h);
    let index = options.channel.unwrap_or(0);
    let Some(entry) = all.get(index) else {
        return Err(PluError::Field {
            field: "number of layers",
            offset: 489,
            value: h.layers.len().to_string(),
            expected: "more layers and images than the channel asked for",
        });
    };
    let (layer, name, z) = match (entry, kind) {
        (Entry::Heights(i, layer), ValueKind::Height) => {
            let n = layer.nx * layer.ny;
            let z: Vec<f64> = bytes[layer.data..layer.data + 4 * n]
                .chunks_exact(4)
                .map(|c| {
                    let v = f32_le(c, 0);
                    if v == NOT_MEASURED {
                        f64::NAN
                    } else {
                        f64::from(v)
                    }
                })
                .collect();
            (*layer, format!("layer{i}"), z)
        }
        (Entry::Image(name, layer, k), ValueKind::Intensity) => {
            let (n, at) = (layer.nx * layer.ny, layer.image(*k));
            let z: Vec<f64> = bytes[at..at + 3 * n]
                .chunks_exact(3)
                .map(|c| (f64::from(c[0]) + f64::from(c[1]) + f64::from(c[2])) / 3.0)
                .collect();
            (*layer, name.clone(), z)
        }
        (Entry::Heights(i, _), ValueKind::Intensity) => {
            return Err(PluError::ChannelHolds {
                channel: format!("layer{i}"),
                what: "heights (µm), not an intensity image; the images are the channels image0, ...",
            });
        }
        (Entry::Image(name, _, _), ValueKind::Height) => {
            return Err(PluError::ChannelHolds {
                channel: name.clone(),
                what: "an intensity image (a.u.), not heights; read it as the intensity map (--intensity-channel)",
            });
        }
    };
    let mut map = HeightMap::new(layer.nx, layer.ny, h.dx, h.dy, z).map_err(PluError::Map)?;
    map.set_metadata("plu.date", text(&bytes[..128]));
    map.set_metadata("plu.comment", text(&bytes[132..388]));
    map.set_metadata("plu.algorithm", u32_le(bytes, 432).to_string());
    map.set_metadata("plu.method", u32_le(bytes, 436).to_string());
    map.set_metadata("plu.objective", u32_le(bytes, 440).to_string());
    map.set_metadata("plu.version", bytes[490].to_string());
    map.set_metadata("plu.hardware", bytes[491].to_string());
    map.set_metadata("plu.channel", name);
    Ok(map)
}
