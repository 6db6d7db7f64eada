//! Reading a height map or listing its channels, from memory or from a file (a large
//! X3P file streamed from disk).

use std::io::{Read, Seek};
use std::path::Path;

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};

use crate::channel::ChannelSelector;
use crate::reader::{Channel, DecimalMark, ReadOptions, ValueKind};
use crate::x3p::{self, X3pError};
use crate::zarr::{self, ZarrMap, ZarrProblem};

use super::dispatch::{choose, extension, spec};
use super::error::{MapError, ReadMapError};
use super::format::MapFormat;

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
                why: if format == MapFormat::Zarr {
                    "whose heights are stated in µm (`height_unit`)"
                } else {
                    "whose heights are calibrated in metres"
                },
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
    /// A Zarr v3 store (a directory), opened.
    Zarr(Box<ZarrMap>),
}

impl<'a> Source<'a> {
    /// Opens `path`: a Zarr store ([`crate::zarr::is_store`]) as one, anything else as
    /// [`Source::open`] does.
    pub(crate) fn open_path(path: &'a Path, buf: &'a mut Vec<u8>) -> Result<Self, ReadMapError> {
        if crate::zarr::is_store(path) {
            return ZarrMap::open(path)
                .map(|z| Self::Zarr(Box::new(z)))
                .map_err(|e| ReadMapError::Format {
                    path: path.to_path_buf(),
                    error: MapError::Zarr(e.problem),
                });
        }
        Self::open(path, buf).map_err(|source| ReadMapError::Io {
            path: path.to_path_buf(),
            source: crate::files::explain_open_error(path, source),
        })
    }

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
            Self::Zarr(store) => Ok((
                zarr_channels(store).into_iter().map(|(c, _)| c).collect(),
                MapFormat::Zarr,
            )),
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
            Self::Zarr(store) => Ok((read_zarr(store, options, kind)?, MapFormat::Zarr)),
        }
    }
}

/// The channels of a Zarr store: `height` (µm), then `intensity` (unit-less), those it
/// has, each with the quantity it holds.
fn zarr_channels(store: &ZarrMap) -> Vec<(Channel, ValueKind)> {
    let (ny, nx) = store.shape();
    let channel = |name: &str, unit: Option<&str>| Channel {
        name: name.into(),
        unit: unit.map(Into::into),
        nx,
        ny,
        pitch_um: Some(store.pitch()),
    };
    let mut out = Vec::new();
    if store.has_height() {
        out.push((channel(zarr::HEIGHT, Some("µm")), ValueKind::Height));
    }
    if store.has_intensity() {
        out.push((channel(zarr::INTENSITY, None), ValueKind::Intensity));
    }
    out
}

/// Reads the channel of a Zarr store that `options.channel` names, else the first that
/// holds `wanted`; the quantity is the array's own (`height` or `intensity`), checked
/// against `wanted` as a declared quantity is.
fn read_zarr(
    store: &ZarrMap,
    options: &ReadOptions,
    wanted: ValueKind,
) -> Result<HeightMap, MapError> {
    check_pitch(options)?;
    let channels = zarr_channels(store);
    let listed: Vec<Channel> = channels.iter().map(|(c, _)| c.clone()).collect();
    let index = match options.channel {
        Some(i) => ChannelSelector::Index(i).resolve(&listed)?,
        None => channels.iter().position(|(_, k)| *k == wanted).unwrap_or(0),
    };
    let holds = channels[index].1;
    let declared = crate::quantity::Declared {
        quantity: holds,
        by: format!("its array `{}`", channels[index].0.name),
    };
    let kind = quantity(Some(declared), options, wanted)?;
    check_flags(MapFormat::Zarr, options, kind)?;
    let problem = |e: crate::zarr::ZarrError| MapError::Zarr(e.problem);
    let map = match holds {
        ValueKind::Height => store.read().map_err(problem)?,
        ValueKind::Intensity => store
            .read_intensity()
            .map_err(problem)?
            .ok_or(MapError::Zarr(ZarrProblem::NoArray))?,
    };
    finish(map, MapFormat::Zarr, options, kind)
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
    Source::open_path(path, &mut buf)?
        .read(options, kind)
        .map_err(|error| ReadMapError::Format {
            path: path.to_path_buf(),
            error,
        })
}

/// Reads a height map file (X3P, SDF, plain text or an instrument format, recognised
/// from the content; an extension that names another format is an error) or a Zarr v3
/// store (a directory holding `zarr.json` or named `*.zarr`: [`crate::zarr`]).
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
/// `options.z_unit` is ignored), the `intensity` array of a Zarr store. The pitch rules are those of [`read_map`].
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
    if crate::zarr::is_store(path) {
        let mut buf = Vec::new();
        return Source::open_path(path, &mut buf)?
            .channels(options)
            .map_err(|error| ReadMapError::Format {
                path: path.to_path_buf(),
                error,
            });
    }
    let bytes = std::fs::read(path).map_err(|source| ReadMapError::Io {
        path: path.to_path_buf(),
        source: crate::files::explain_open_error(path, source),
    })?;
    list_channels_bytes(&bytes, extension(path), options).map_err(|error| ReadMapError::Format {
        path: path.to_path_buf(),
        error,
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
