//! Reading and writing height maps: the one place that knows every format. It scores
//! the content with each format's `detect`, checks the file extension against the
//! winner, and calls that format's reader (see [`crate::reader`] for the contract each
//! format module fulfils). Readers never call back into this module.
//!
//! Conventions: every reader returns a [`HeightMap`] with heights in micrometres and pixel
//! pitch in micrometres, row-major with `x` along columns (X fastest in the file) and `y`
//! along rows. Points the file marks invalid (NaN, `valid.bin`, non-finite values) are
//! invalid in the map's mask. Format-specific header fields go into the map's metadata
//! under `format` and keys prefixed with the format name (`x3p.creator`, `sdf.ManufacID`,
//! `text.channel`, ...).
//!
//! Adding a format: a module with `detect`, `channels` and `read` (as [`crate::x3p`]), a
//! [`MapFormat`] variant, a [`MapError`] variant, and one row in `FORMATS`.

use std::fmt;
use std::io::{Read, Seek};
use std::path::{Path, PathBuf};

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::al3d::{self, Al3dError};
use crate::channel::{ChannelError, ChannelSelector};
use crate::frt::{self, FrtError};
use crate::gwy::{self, GwyError};
use crate::metropro::{self, MetroProError};
use crate::opd::{self, OpdError};
use crate::plu::{self, PluError};
use crate::reader::{Channel, Confidence, DecimalMark, ReadOptions, ValueKind};
use crate::sdf::{self, SdfError};
use crate::sur::{self, SurError};
use crate::text::{self, TextError};
use crate::x3p::{self, ArchiveError, X3pError};

/// The height-map file formats this crate understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapFormat {
    /// ISO 25178-72 XML 3D surface profile (a zip archive).
    X3p,
    /// ISO 25178-71 surface data file, text (`aISO-1.0`, `aISO-2.0`) or binary
    /// (`bISO-1.0`, `bISO-2.0`).
    Sdf,
    /// Plain-text matrix (whitespace, comma or semicolon separated), Gwyddion `#`
    /// headers understood.
    Text,
    /// Gwyddion native file (`GWYP` magic), one channel per data field.
    Gwy,
    /// Sensofar PLu topography (no magic; recognised from its header).
    Plu,
    /// Zygo MetroPro phase map (`.dat`).
    MetroPro,
    /// Wyko / Bruker Vision OPD (`.opd`).
    Opd,
    /// Digital Surf SUR (MountainsMap), one channel per object.
    Sur,
    /// Alicona AL3D depth image (focus variation).
    Al3d,
    /// FRT MicroProf (`.frt`), one channel per image (topography, intensity, ...).
    Frt,
}

/// One format: how to recognise it, list its channels and read it.
struct Spec {
    format: MapFormat,
    detect: fn(&[u8]) -> Confidence,
    channels: fn(&[u8], &ReadOptions) -> Result<Vec<Channel>, MapError>,
    read: fn(&[u8], &ReadOptions, ValueKind) -> Result<HeightMap, MapError>,
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

fn spec(format: MapFormat) -> &'static Spec {
    FORMATS
        .iter()
        .find(|s| s.format == format)
        .unwrap_or(&FORMATS[0])
}

impl MapFormat {
    /// Every format, in detection order.
    pub const ALL: [MapFormat; 10] = [
        MapFormat::X3p,
        MapFormat::Sdf,
        MapFormat::Text,
        MapFormat::Gwy,
        MapFormat::Plu,
        MapFormat::MetroPro,
        MapFormat::Opd,
        MapFormat::Sur,
        MapFormat::Al3d,
        MapFormat::Frt,
    ];

    /// Recognises the format from the content alone: the format whose `detect` scores
    /// highest, `None` if none scores above 0 (empty or unknown binary content).
    pub fn detect(bytes: &[u8]) -> Option<Self> {
        best(bytes, None)
    }

    /// How sure this format's reader is that `bytes` are its format (0–100).
    pub fn confidence(self, bytes: &[u8]) -> Confidence {
        (spec(self).detect)(bytes)
    }

    /// Short lower-case name: `x3p`, `sdf` or `text`.
    pub fn name(self) -> &'static str {
        match self {
            MapFormat::X3p => "x3p",
            MapFormat::Sdf => "sdf",
            MapFormat::Text => "text",
            MapFormat::Gwy => "gwy",
            MapFormat::Al3d => "al3d",
            MapFormat::Sur => "sur",
            MapFormat::Opd => "opd",
            MapFormat::MetroPro => "metropro",
            MapFormat::Plu => "plu",
            MapFormat::Frt => "frt",
        }
    }

    /// What a file of this format is, for messages: `an X3P file`, ...
    pub fn description(self) -> &'static str {
        match self {
            MapFormat::X3p => "an X3P file (ISO 25178-72)",
            MapFormat::Sdf => "an SDF file (ISO 25178-71)",
            MapFormat::Text => "a plain-text matrix",
            MapFormat::Gwy => "a Gwyddion GWY file",
            MapFormat::Al3d => "an Alicona AL3D file",
            MapFormat::Sur => "a Digital Surf SUR file",
            MapFormat::Opd => "a Wyko OPD file",
            MapFormat::MetroPro => "a Zygo MetroPro DAT file",
            MapFormat::Plu => "a Sensofar PLU file",
            MapFormat::Frt => "an FRT MicroProf file",
        }
    }

    /// What content of this format must look like, for messages.
    fn signature(self) -> &'static str {
        match self {
            MapFormat::X3p => "it is not a zip archive, so not an X3P file",
            MapFormat::Sdf => {
                "it does not start with aISO- or bISO-, so not an ISO 25178-71 SDF file"
            }
            MapFormat::Text => "it holds bytes that do not occur in text, so not a text matrix",
            MapFormat::Gwy => "it does not start with GWYP, so not a Gwyddion GWY file",
            MapFormat::Al3d => "it does not start with AliconaImaging, so not an Alicona AL3D file",
            MapFormat::Sur => "it does not start with DIGITAL SURF, so not a Digital Surf SUR file",
            MapFormat::Opd => {
                "it does not have the OPD Directory block at byte 2, so not a Wyko OPD file"
            }
            MapFormat::MetroPro => {
                "it does not start with a MetroPro magic (88 1B 03 6F..71), so not a Zygo MetroPro file"
            }
            MapFormat::Plu => {
                "it lacks the PLU header (a date, a topography type and matching sizes), so not a Sensofar PLU file"
            }
            MapFormat::Frt => "it does not start with FRTM_GLIDERV, so not an FRT MicroProf file",
        }
    }

    /// File extensions (lower case, without the dot) that name this format.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            MapFormat::X3p => &["x3p"],
            MapFormat::Sdf => &["sdf"],
            MapFormat::Text => &["txt", "csv", "asc", "tsv"],
            MapFormat::Gwy => &["gwy"],
            MapFormat::Al3d => &["al3d"],
            MapFormat::Sur => &["sur"],
            MapFormat::Opd => &["opd"],
            // `.dat` is also common for text matrices: the content alone decides.
            MapFormat::MetroPro => &[],
            MapFormat::Plu => &["plu", "apx"],
            MapFormat::Frt => &["frt"],
        }
    }

    /// The format an extension names (case-insensitive, without the dot), if any.
    pub fn from_extension(ext: &str) -> Option<Self> {
        let ext = ext.to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|f| f.extensions().contains(&ext.as_str()))
    }
}

impl fmt::Display for MapFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The best-scoring format for `bytes`; ties go to `preferred`, then to table order.
fn best(bytes: &[u8], preferred: Option<MapFormat>) -> Option<MapFormat> {
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
fn describe(bytes: &[u8]) -> String {
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

/// What went wrong inside a height-map file, by format.
#[derive(Debug, Error)]
pub enum MapError {
    /// An X3P problem.
    #[error("X3P: {0}")]
    X3p(X3pError),
    /// An SDF problem.
    #[error("SDF: {0}")]
    Sdf(SdfError),
    /// A plain-text matrix problem.
    #[error("text matrix: {0}")]
    Text(TextError),
    /// A Gwyddion GWY problem.
    #[error("GWY: {0}")]
    Gwy(GwyError),
    /// An Alicona AL3D problem.
    #[error("AL3D: {0}")]
    Al3d(Al3dError),
    /// A Digital Surf SUR problem.
    #[error("SUR: {0}")]
    Sur(SurError),
    /// A Wyko OPD problem.
    #[error("OPD: {0}")]
    Opd(OpdError),
    /// A Zygo MetroPro problem.
    #[error("MetroPro: {0}")]
    MetroPro(MetroProError),
    /// A Sensofar PLU problem.
    #[error("PLU: {0}")]
    Plu(PluError),
    /// An FRT MicroProf problem.
    #[error("FRT: {0}")]
    Frt(FrtError),
    /// The pitch override is not usable.
    #[error("pixel pitch option: {0}")]
    Pitch(HeightMapError),
    /// The file has no bytes at all.
    #[error("the file is empty (0 bytes){}", match expected {
        Some(f) => format!(", so not {}", f.description()),
        None => String::new(),
    })]
    Empty {
        /// The format the file's extension names, if any.
        expected: Option<MapFormat>,
    },
    /// The content is no format this crate reads.
    #[error(
        "not a height-map format this crate reads (see MapFormat::ALL: X3P, SDF, plain text and the instrument formats): {content}"
    )]
    Unrecognised {
        /// What the content is.
        content: String,
    },
    /// The extension names one format and the content is not that format.
    #[error("the extension .{extension} says {}, but {reason}", format.description())]
    NotThisFormat {
        /// The file's extension.
        extension: String,
        /// The format it names.
        format: MapFormat,
        /// Why the content is not that format, and what it is instead.
        reason: String,
    },
    /// An option that only plain-text matrices use was given for a calibrated format.
    #[error(
        "option {option} applies to plain-text matrices only, and this is {}, {why}; leave it out",
        format.description()
    )]
    NotApplicable {
        /// The option, with its command-line flag.
        option: &'static str,
        /// The format of the file.
        format: MapFormat,
        /// Why the format does not need it.
        why: &'static str,
    },
    /// The channel asked for does not exist, or a name matches none or several
    /// (the message lists every channel: index, name, unit, size).
    #[error("{0}")]
    Channel(#[from] ChannelError),
    /// The file declares another quantity than the one asked for ([`crate::quantity`]):
    /// an intensity image where heights are expected, or the reverse.
    #[error(
        "the file holds {} ({}), not {}: {}",
        plural(declared.quantity), declared.by, plural(*wanted),
        match wanted {
            ValueKind::Height => "give it where an intensity image is expected (--intensity, \
                `maps.intensity`), or read it as it is with `convert` or `info`",
            ValueKind::Intensity => "an intensity image is expected here; give the height \
                map as the map itself",
        }
    )]
    Quantity {
        /// What the file declares, and where.
        declared: crate::quantity::Declared,
        /// What was asked for.
        wanted: ValueKind,
    },
    /// A height-only option was given for a file read as the intensities it declares.
    #[error(
        "option {option} applies to heights, and this file holds intensities ({by}); leave it out"
    )]
    HeightOption {
        /// The option, with its command-line flag.
        option: &'static str,
        /// Where the file says it holds intensities.
        by: String,
    },
}

/// `heights` or `intensities`.
fn plural(kind: ValueKind) -> &'static str {
    match kind {
        ValueKind::Height => "heights",
        ValueKind::Intensity => "intensities",
    }
}

/// Error from [`read_map`] and [`read_intensity`]: the file and what went wrong.
#[derive(Debug, Error)]
pub enum ReadMapError {
    /// The file could not be read at all.
    #[error("cannot read map {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The file was read but its content is not a usable map (heights, or an
    /// intensity image where one is read).
    #[error("map {}: {error}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// The problem found in it.
        error: MapError,
    },
}

/// Error from the writers: the file and what went wrong.
#[derive(Debug, Error)]
pub enum WriteMapError {
    /// The file could not be written.
    #[error("cannot write map {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The zip container could not be assembled.
    #[error("cannot write map {}: {source}", path.display())]
    Archive {
        /// The file.
        path: PathBuf,
        /// What the zip writer reported.
        source: ArchiveError,
    },
    /// The format cannot be written.
    #[error("cannot write map {}: writing {format} is not supported; use X3P, SDF or text", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// The format asked for.
        format: MapFormat,
    },
}

fn extension(path: &Path) -> Option<&str> {
    path.extension().and_then(|e| e.to_str())
}

/// Which format to read `bytes` with, given the file's extension (if any).
fn choose(bytes: &[u8], extension: Option<&str>) -> Result<MapFormat, MapError> {
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

/// Reads a map from memory: the general entry point behind [`read_map`],
/// [`read_intensity`] and their `_bytes` forms. `extension` (without the dot) is the
/// file's, if known: one that names a format the content is not is an error.
///
/// # Errors
/// [`MapError`] naming the format and what is wrong (member, header field, line), or
/// why the content is not the format the extension names.
pub fn read_bytes(
    bytes: &[u8],
    extension: Option<&str>,
    options: &ReadOptions,
    kind: ValueKind,
) -> Result<(HeightMap, MapFormat), MapError> {
    check_pitch(options)?;
    let format = choose(bytes, extension)?;
    let declared = declared_bytes(format, bytes).map_err(MapError::X3p)?;
    let kind = quantity(declared, options, kind)?;
    check_flags(format, options, kind)?;
    let spec = spec(format);
    if let Some(requested) = options.channel {
        ChannelSelector::Index(requested).resolve(&(spec.channels)(bytes, options)?)?;
    }
    let map = (spec.read)(bytes, options, kind)?;
    Ok((finish(map, format, options, kind)?, format))
}

/// The quantity to read a file as, from what it declares ([`crate::quantity::resolve`]);
/// a height-only option is refused for a file read as the intensities it declares.
fn quantity(
    declared: Option<crate::quantity::Declared>,
    options: &ReadOptions,
    wanted: ValueKind,
) -> Result<ValueKind, MapError> {
    let by = declared.as_ref().map(|d| d.by.clone()).unwrap_or_default();
    let kind = crate::quantity::resolve(declared, wanted, options.as_stored)
        .map_err(|(declared, wanted)| MapError::Quantity { declared, wanted })?;
    if options.as_stored && kind == ValueKind::Intensity && options.z_unit.is_some() {
        return Err(MapError::HeightOption {
            option: "z_unit (`--z-unit` on the command line)",
            by,
        });
    }
    Ok(kind)
}

/// The pitch override, checked first, so that a bad option is reported as such in every
/// format.
fn check_pitch(options: &ReadOptions) -> Result<(), MapError> {
    if let Some((dx, dy)) = options.pixel_um {
        for (axis, value) in [("dx", dx), ("dy", dy)] {
            if !value.is_finite() || value <= 0.0 {
                return Err(MapError::Pitch(HeightMapError::BadPitch { axis, value }));
            }
        }
    }
    Ok(())
}

/// A flag is honoured or refused: the text-only options are refused for the calibrated
/// formats (intensity reads share the height map's flags and ignore them).
fn check_flags(format: MapFormat, options: &ReadOptions, kind: ValueKind) -> Result<(), MapError> {
    if kind == ValueKind::Height && format != MapFormat::Text {
        // GWY data fields may store no unit; the GWY reader then needs (and otherwise
        // refuses) `z_unit` itself.
        if options.z_unit.is_some() && format != MapFormat::Gwy {
            return Err(MapError::NotApplicable {
                option: "z_unit (`--z-unit` on the command line)",
                format,
                why: "whose heights are calibrated in metres",
            });
        }
        if options.decimal != DecimalMark::Auto {
            return Err(MapError::NotApplicable {
                option: "decimal (`--decimal-comma`, `--decimal-point` on the command line)",
                format,
                why: "which stores no decimal text",
            });
        }
    }
    Ok(())
}

/// What every read does last: the pitch override and the metadata of how the map was
/// read.
fn finish(
    mut map: HeightMap,
    format: MapFormat,
    options: &ReadOptions,
    kind: ValueKind,
) -> Result<HeightMap, MapError> {
    if let Some((dx, dy)) = options.pixel_um {
        map.set_pitch(dx, dy).map_err(MapError::Pitch)?;
        map.set_metadata("pitch_source", "option");
    } else if !map.metadata().contains_key("pitch_source") {
        map.set_metadata("pitch_source", "file");
    }
    map.set_metadata("format", format.name());
    map.set_quantity(kind);
    if kind == ValueKind::Intensity {
        map.set_metadata("values", "intensity as stored in the file (unit-less)");
    }
    Ok(map)
}

/// Reads a height map from memory, recognising the format from the content.
///
/// # Errors
/// [`MapError`] naming the format and what is wrong (member, header field, line).
pub fn read_map_bytes(
    bytes: &[u8],
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), MapError> {
    read_bytes(bytes, None, options, ValueKind::Height)
}

/// Reads an intensity image from memory: values as the file stores them (see
/// [`read_intensity`]).
///
/// # Errors
/// As [`read_map_bytes`].
pub fn read_intensity_bytes(
    bytes: &[u8],
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), MapError> {
    read_bytes(bytes, None, options, ValueKind::Intensity)
}

/// Files at least this long that start like a zip archive are read as X3P straight
/// from the file ([`Source::open`]).
const STREAM_FILE_MIN: u64 = 8 << 20;

/// Where a map file is read from: its bytes in memory, or, for a large X3P file, the
/// file itself through a buffered reader, inflated as it is read.
pub(crate) enum Source<'a> {
    /// The whole file's bytes and its extension.
    Bytes {
        bytes: &'a [u8],
        extension: Option<&'a str>,
    },
    /// An X3P file of at least [`STREAM_FILE_MIN`] bytes.
    X3pFile(std::io::BufReader<std::fs::File>),
}

impl<'a> Source<'a> {
    /// Opens `path`: an X3P file of at least [`STREAM_FILE_MIN`] bytes whose extension
    /// names X3P or no format stays a file; any other file is read into `buf`.
    ///
    /// Content that starts like a zip archive scores 0 in every other format's `detect`
    /// and at least 60 in X3P's, so [`choose`] would pick X3P from the whole file's
    /// bytes: such a file is read as it is inflated (the inflate then reads the file,
    /// overlapped with the checksum of the data on a second thread) instead of being
    /// read whole first, and its bytes are never held.
    pub(crate) fn open(path: &'a Path, buf: &'a mut Vec<u8>) -> std::io::Result<Self> {
        let mut file = std::fs::File::open(path)?;
        let len = file.metadata()?.len();
        let extension = extension(path);
        let named = extension.and_then(MapFormat::from_extension);
        buf.clear();
        if len >= STREAM_FILE_MIN && named.is_none_or(|f| f == MapFormat::X3p) {
            let mut head = [0u8; 4];
            file.read_exact(&mut head)?;
            if x3p::is_zip(&head) {
                file.rewind()?;
                return Ok(Self::X3pFile(std::io::BufReader::with_capacity(
                    1 << 20,
                    file,
                )));
            }
            buf.extend_from_slice(&head);
        }
        file.read_to_end(buf)?;
        Ok(Self::Bytes {
            bytes: buf,
            extension,
        })
    }

    /// The file's channels and format, as [`list_channels_bytes`] gives them.
    pub(crate) fn channels(
        &mut self,
        options: &ReadOptions,
    ) -> Result<(Vec<Channel>, MapFormat), MapError> {
        match self {
            Self::Bytes { bytes, extension } => list_channels_bytes(bytes, *extension, options),
            Self::X3pFile(reader) => Ok((x3p_file_channels(reader, options)?, MapFormat::X3p)),
        }
    }

    /// The map, as [`read_bytes`] gives it.
    pub(crate) fn read(
        &mut self,
        options: &ReadOptions,
        kind: ValueKind,
    ) -> Result<(HeightMap, MapFormat), MapError> {
        match self {
            Self::Bytes { bytes, extension } => read_bytes(bytes, *extension, options, kind),
            Self::X3pFile(reader) => {
                let format = MapFormat::X3p;
                check_pitch(options)?;
                rewind(reader)?;
                let declared =
                    crate::quantity::x3p(&x3p::main_xml(&mut *reader).map_err(MapError::X3p)?);
                let kind = quantity(declared, options, kind)?;
                check_flags(format, options, kind)?;
                if let Some(requested) = options.channel {
                    ChannelSelector::Index(requested)
                        .resolve(&x3p_file_channels(reader, options)?)?;
                }
                rewind(reader)?;
                let map = x3p::read_from(&mut *reader, options, kind).map_err(MapError::X3p)?;
                Ok((finish(map, format, options, kind)?, format))
            }
        }
    }
}

/// The channels of an X3P file read through `reader`, from its start.
fn x3p_file_channels(
    reader: &mut std::io::BufReader<std::fs::File>,
    options: &ReadOptions,
) -> Result<Vec<Channel>, MapError> {
    rewind(reader)?;
    x3p::channels_from(&mut *reader, options).map_err(MapError::X3p)
}

/// Back to the start of a file read more than once ([`Source`]).
fn rewind(reader: &mut std::io::BufReader<std::fs::File>) -> Result<(), MapError> {
    reader.rewind().map_err(|e| {
        MapError::X3p(X3pError::Read {
            what: "the file's start (seeking back to it)".into(),
            reason: e.to_string(),
        })
    })
}

fn read_file(
    path: &Path,
    options: &ReadOptions,
    kind: ValueKind,
) -> Result<(HeightMap, MapFormat), ReadMapError> {
    let mut buf = Vec::new();
    Source::open(path, &mut buf)
        .map_err(|source| ReadMapError::Io {
            path: path.to_path_buf(),
            source: crate::files::explain_open_error(path, source),
        })?
        .read(options, kind)
        .map_err(|error| ReadMapError::Format {
            path: path.to_path_buf(),
            error,
        })
}

/// Reads a height map file (X3P, SDF or plain text, recognised from the content; an
/// extension that names another format is an error).
///
/// # Errors
/// [`ReadMapError::Io`] if the file cannot be read, [`ReadMapError::Format`] naming the
/// file and the problem otherwise.
pub fn read_map(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), ReadMapError> {
    read_file(path.as_ref(), options, ValueKind::Height)
}

/// Reads an intensity image (e.g. a confocal microscope's maximum-intensity map) for use
/// with [`HeightMap::apply_intensity_cutoff`]. Values are returned as the file stores
/// them, unit-less: `Offset + raw × Increment` for X3P, `raw × Zscale` for SDF, the
/// numbers themselves for text (no unit is required or applied, `a.u.` or none is fine;
/// `options.z_unit` is ignored). The pitch rules are those of [`read_map`].
///
/// # Errors
/// As [`read_map`].
pub fn read_intensity(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), ReadMapError> {
    read_file(path.as_ref(), options, ValueKind::Intensity)
}

/// Lists the channels of a map held in memory (name, unit, size, pitch) without
/// converting its data where the format allows; `extension` as in [`read_bytes`].
///
/// # Errors
/// As [`read_bytes`].
pub fn list_channels_bytes(
    bytes: &[u8],
    extension: Option<&str>,
    options: &ReadOptions,
) -> Result<(Vec<Channel>, MapFormat), MapError> {
    let format = choose(bytes, extension)?;
    let mut channels = (spec(format).channels)(bytes, options)?;
    if let Ok(Some(d)) = declared_bytes(format, bytes)
        && d.quantity == ValueKind::Intensity
        && matches!(format, MapFormat::X3p | MapFormat::Sdf)
    {
        // The ISO formats' `Z` is in metres only for heights.
        for c in &mut channels {
            c.name = "intensity".into();
            c.unit = None;
        }
    }
    Ok((channels, format))
}

/// Lists the channels of a map file (see [`list_channels_bytes`]).
///
/// # Errors
/// As [`read_map`].
pub fn list_channels(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(Vec<Channel>, MapFormat), ReadMapError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ReadMapError::Io {
        path: path.to_path_buf(),
        source: crate::files::explain_open_error(path, source),
    })?;
    list_channels_bytes(&bytes, extension(path), options).map_err(|error| ReadMapError::Format {
        path: path.to_path_buf(),
        error,
    })
}

/// Writes an intensity image (unit-less values) to `path` as X3P (Z `Increment` 1), SDF
/// (text, `Zscale` 1) or plain text (no value unit), so that [`read_intensity`] returns
/// exactly the values written. The instrument formats cannot be written (an error says
/// so).
///
/// # Errors
/// [`WriteMapError`] naming the file.
pub fn write_intensity(
    map: &HeightMap,
    path: impl AsRef<Path>,
    format: MapFormat,
) -> Result<(), WriteMapError> {
    write_with(map, path.as_ref(), format, ValueKind::Intensity)
}

/// Writes `map` to `path` as X3P (float64 heights in metres, `valid.bin` when some point
/// is invalid), SDF (text `aISO-1.0`, exact decimals, `BAD` for invalid points; see
/// [`sdf::write_sdf_text`], and [`sdf::write_sdf_binary`] for the binary form) or plain
/// text (µm, with pitch header lines). A map whose [`HeightMap::quantity`] is an
/// intensity is written as [`write_intensity`] writes it (the quantity is carried,
/// [`crate::quantity`]). The instrument formats cannot be written (an error says so).
///
/// # Errors
/// [`WriteMapError`] naming the file.
pub fn write_map(
    map: &HeightMap,
    path: impl AsRef<Path>,
    format: MapFormat,
) -> Result<(), WriteMapError> {
    write_with(map, path.as_ref(), format, map.quantity())
}

fn write_with(
    map: &HeightMap,
    path: &Path,
    format: MapFormat,
    kind: ValueKind,
) -> Result<(), WriteMapError> {
    let archive = |source| WriteMapError::Archive {
        path: path.to_path_buf(),
        source,
    };
    let bytes = match (format, kind) {
        (MapFormat::X3p, ValueKind::Height) => x3p::write_x3p_bytes(map).map_err(archive)?,
        (MapFormat::X3p, ValueKind::Intensity) => {
            x3p::write_intensity_x3p_bytes(map).map_err(archive)?
        }
        (MapFormat::Text, ValueKind::Height) => text::write_text_string(map).into_bytes(),
        (MapFormat::Text, ValueKind::Intensity) => {
            text::write_intensity_text_string(map).into_bytes()
        }
        (MapFormat::Sdf, kind) => sdf::write_sdf_text(map, kind).into_bytes(),
        (
            MapFormat::Gwy
            | MapFormat::Plu
            | MapFormat::MetroPro
            | MapFormat::Opd
            | MapFormat::Sur
            | MapFormat::Al3d
            | MapFormat::Frt,
            _,
        ) => {
            return Err(WriteMapError::Unsupported {
                path: path.to_path_buf(),
                format,
            });
        }
    };
    std::fs::write(path, bytes).map_err(|source| WriteMapError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// What a file of `format` held in memory declares ([`crate::quantity`]).
fn declared_bytes(
    format: MapFormat,
    bytes: &[u8],
) -> Result<Option<crate::quantity::Declared>, X3pError> {
    Ok(match format {
        MapFormat::X3p => crate::quantity::x3p(&x3p::main_xml(std::io::Cursor::new(bytes))?),
        MapFormat::Sdf => crate::quantity::sdf(bytes),
        MapFormat::Text => crate::quantity::text(bytes),
        _ => None,
    })
}
