//! Each format's reader in one table: detection by content, the choice of reader
//! (content against extension) and the calls to the format modules.

use std::path::Path;

use flakescatter_stats::heightmap::HeightMap;

use crate::al3d;
use crate::frt;
use crate::gwy;
use crate::metropro;
use crate::opd;
use crate::plu;
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};
use crate::sdf;
use crate::sur;
use crate::text;
use crate::x3p;

use super::error::MapError;
use super::format::MapFormat;

/// One format: how to recognise it, list its channels and read it.
pub(super) struct Spec {
    pub(super) format: MapFormat,
    pub(super) detect: fn(&[u8]) -> Confidence,
    pub(super) channels: fn(&[u8], &ReadOptions) -> Result<Vec<Channel>, MapError>,
    pub(super) read: fn(&[u8], &ReadOptions, ValueKind) -> Result<HeightMap, MapError>,
}

/// Every format, in the order ties of confidence are broken when no extension decides.
const FORMATS: [Spec; 10] = [
    Spec {
        format: MapFormat::X3p,
        detect: x3p::detect,
        channels: |b, o| x3p::channels(b, o).map_err(MapError::X3p),
        read: |b, o, k| x3p::read(b, o, k).map_err(MapError::X3p),
    },
    Spec {
        format: MapFormat::Sdf,
        detect: sdf::detect,
        channels: |b, o| sdf::channels(b, o).map_err(MapError::Sdf),
        read: |b, o, k| sdf::read(b, o, k).map_err(MapError::Sdf),
    },
    Spec {
        format: MapFormat::Text,
        detect: text::detect,
        channels: |b, o| text::channels(b, o).map_err(MapError::Text),
        read: |b, o, k| text::read(b, o, k).map_err(MapError::Text),
    },
    Spec {
        format: MapFormat::Gwy,
        detect: gwy::detect,
        channels: |b, o| gwy::channels(b, o).map_err(MapError::Gwy),
        read: |b, o, k| gwy::read(b, o, k).map_err(MapError::Gwy),
    },
    Spec {
        format: MapFormat::Plu,
        detect: plu::detect,
        channels: |b, o| plu::channels(b, o).map_err(MapError::Plu),
        read: |b, o, k| plu::read(b, o, k).map_err(MapError::Plu),
    },
    Spec {
        format: MapFormat::MetroPro,
        detect: metropro::detect,
        channels: |b, o| metropro::channels(b, o).map_err(MapError::MetroPro),
        read: |b, o, k| metropro::read(b, o, k).map_err(MapError::MetroPro),
    },
    Spec {
        format: MapFormat::Opd,
        detect: opd::detect,
        channels: |b, o| opd::channels(b, o).map_err(MapError::Opd),
        read: |b, o, k| opd::read(b, o, k).map_err(MapError::Opd),
    },
    Spec {
        format: MapFormat::Sur,
        detect: sur::detect,
        channels: |b, o| sur::channels(b, o).map_err(MapError::Sur),
        read: |b, o, k| sur::read(b, o, k).map_err(MapError::Sur),
    },
    Spec {
        format: MapFormat::Al3d,
        detect: al3d::detect,
        channels: |b, o| al3d::channels(b, o).map_err(MapError::Al3d),
        read: |b, o, k| al3d::read(b, o, k).map_err(MapError::Al3d),
    },
    Spec {
        format: MapFormat::Frt,
        detect: frt::detect,
        channels: |b, o| frt::channels(b, o).map_err(MapError::Frt),
        read: |b, o, k| frt::read(b, o, k).map_err(MapError::Frt),
    },
];

pub(super) fn spec(format: MapFormat) -> &'static Spec {
    FORMATS
        .iter()
        .find(|s| s.format == format)
        .unwrap_or(&FORMATS[0])
}

impl MapFormat {
    /// Recognises the format from the content alone: the format whose `detect` scores
    /// highest, `None` if none scores above 0 (empty or unknown binary content).
    pub fn detect(bytes: &[u8]) -> Option<Self> {
        best(bytes, None)
    }

    /// How sure this format's reader is that `bytes` are its format (0–100).
    pub fn confidence(self, bytes: &[u8]) -> Confidence {
        if self == MapFormat::Zarr {
            // A directory, never a file's bytes.
            return 0;
        }
        (spec(self).detect)(bytes)
    }
}

/// The best-scoring format for `bytes`; ties go to `preferred`, then to table order.
pub(super) fn best(bytes: &[u8], preferred: Option<MapFormat>) -> Option<MapFormat> {
    let mut winner: Option<(Confidence, bool, MapFormat)> = None;
    for s in &FORMATS {
        let score = (s.detect)(bytes);
        let pref = preferred == Some(s.format);
        if score > 0 && winner.is_none_or(|(b, p, _)| (score, pref) > (b, p)) {
            winner = Some((score, pref, s.format));
        }
    }
    winner.map(|(_, _, f)| f)
}

/// What the content is, in a few words, for messages about a wrong extension.
pub(super) fn describe(bytes: &[u8]) -> String {
    if bytes.is_empty() {
        return "the file is empty (0 bytes)".into();
    }
    match best(bytes, None) {
        Some(MapFormat::Text) => {
            let first: String = String::from_utf8_lossy(&bytes[..bytes.len().min(200)])
                .lines()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("")
                .chars()
                .take(40)
                .collect();
            format!("the content is plain text, starting {:?}", first.trim())
        }
        Some(f) => format!("the content is {}", f.description()),
        None => {
            let (offset, byte) = bytes
                .iter()
                .enumerate()
                .find(|(_, b)| **b < 0x20 && !b.is_ascii_whitespace())
                .map_or((0, bytes[0]), |(i, b)| (i, *b));
            format!(
                "the content is binary data of no format this crate reads (byte {offset} is 0x{byte:02x})"
            )
        }
    }
}

pub(super) fn extension(path: &Path) -> Option<&str> {
    path.extension().and_then(|e| e.to_str())
}

/// Which format to read `bytes` with, given the file's extension (if any).
pub(super) fn choose(bytes: &[u8], extension: Option<&str>) -> Result<MapFormat, MapError> {
    let named = extension.and_then(MapFormat::from_extension);
    if bytes.is_empty() {
        return Err(MapError::Empty { expected: named });
    }
    let found = best(bytes, named);
    match (named, found) {
        (Some(n), Some(f)) if n == f => Ok(f),
        (Some(n), found) => {
            let content = describe(bytes);
            let reason = if n == MapFormat::Text && found.is_some() {
                content
            } else {
                format!("{} ({content})", n.signature())
            };
            Err(MapError::NotThisFormat {
                extension: extension.unwrap_or_default().to_string(),
                format: n,
                reason,
            })
        }
        (None, Some(f)) => Ok(f),
        (None, None) => Err(MapError::Unrecognised {
            content: describe(bytes),
        }),
    }
}
