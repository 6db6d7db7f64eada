//! Reading and writing height maps, with the format recognised from the file's content.
//!
//! Conventions: every reader returns a [`HeightMap`] with heights in micrometres and pixel
//! pitch in micrometres, row-major with `x` along columns (X fastest in the file) and `y`
//! along rows. Points the file marks invalid (NaN, `valid.bin`, non-finite values) are
//! invalid in the map's mask. Format-specific header fields go into the map's metadata
//! under `format` and keys prefixed with the format name (`x3p.creator`, `sdf.ManufacID`,
//! `text.channel`, ...).

use std::fmt;
use std::path::{Path, PathBuf};

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::sdf::{self, SdfError};
use crate::text::{self, TextError};
use crate::units::ZUnit;
use crate::x3p::{self, X3pError};

/// The height-map file formats this crate understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapFormat {
    /// ISO 25178-72 XML 3D surface profile (a zip archive).
    X3p,
    /// ISO 25178-71 surface data file, text (`aISO-1.0`) or binary (`bISO-1.0`, `bISO-2.0`).
    Sdf,
    /// Plain-text matrix (whitespace or comma separated), Gwyddion `#` headers understood.
    Text,
}

impl MapFormat {
    /// Recognises the format from the first bytes of a file: zip magic → X3P,
    /// `aISO`/`bISO` → SDF, anything else → text.
    pub fn detect(bytes: &[u8]) -> Self {
        if bytes.starts_with(b"PK\x03\x04") || bytes.starts_with(b"PK\x05\x06") {
            MapFormat::X3p
        } else if bytes.starts_with(b"aISO") || bytes.starts_with(b"bISO") {
            MapFormat::Sdf
        } else {
            MapFormat::Text
        }
    }

    /// Short lower-case name: `x3p`, `sdf` or `text`.
    pub fn name(self) -> &'static str {
        match self {
            MapFormat::X3p => "x3p",
            MapFormat::Sdf => "sdf",
            MapFormat::Text => "text",
        }
    }
}

impl fmt::Display for MapFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Options for reading height maps.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ReadOptions {
    /// Pixel pitch `(dx, dy)` in µm. Overrides the file's calibration in every format;
    /// required for plain-text matrices that declare no size. `None` = use the file's.
    pub pixel_um: Option<(f64, f64)>,
    /// Unit of the heights in plain-text matrices. Overrides a unit the file declares;
    /// required when it declares none. Ignored for X3P and SDF, which are calibrated.
    pub z_unit: Option<ZUnit>,
    /// Accept an X3P file whose MD5 checksums do not match (or are missing); the mismatch
    /// is then recorded in the metadata key `x3p.md5_mismatch` instead of failing.
    pub accept_md5_mismatch: bool,
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
    /// The pitch override is not usable.
    #[error("pixel pitch option: {0}")]
    Pitch(HeightMapError),
}

impl From<X3pError> for MapError {
    fn from(e: X3pError) -> Self {
        MapError::X3p(e)
    }
}

impl From<SdfError> for MapError {
    fn from(e: SdfError) -> Self {
        MapError::Sdf(e)
    }
}

impl From<TextError> for MapError {
    fn from(e: TextError) -> Self {
        MapError::Text(e)
    }
}

/// Error from [`read_map`]: the file and what went wrong.
#[derive(Debug, Error)]
pub enum ReadMapError {
    /// The file could not be read at all.
    #[error("cannot read height map {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The file was read but its content is not a usable height map.
    #[error("height map {}: {error}", path.display())]
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
    #[error("cannot write height map {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The zip container could not be assembled.
    #[error("cannot build X3P archive: {0}")]
    Zip(String),
}

/// Reads a height map from memory, recognising the format from the content.
///
/// # Errors
/// [`MapError`] naming the format and what is wrong (member, header field, line).
pub fn read_map_bytes(
    bytes: &[u8],
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), MapError> {
    read_bytes(bytes, options, false)
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
    read_bytes(bytes, options, true)
}

fn read_bytes(
    bytes: &[u8],
    options: &ReadOptions,
    intensity: bool,
) -> Result<(HeightMap, MapFormat), MapError> {
    // Check the pitch override first, so a bad option is reported as such in every format.
    if let Some((dx, dy)) = options.pixel_um {
        for (axis, value) in [("dx", dx), ("dy", dy)] {
            if !value.is_finite() || value <= 0.0 {
                return Err(MapError::Pitch(HeightMapError::BadPitch { axis, value }));
            }
        }
    }
    // Heights go to µm (10^6 per metre); intensities stay as stored (10^0).
    let z_shift = if intensity { 0 } else { 6 };
    // Text intensities are taken as stored by declaring them "µm" (a factor of 1).
    let text_options = if intensity {
        ReadOptions {
            z_unit: Some(ZUnit::Um),
            ..*options
        }
    } else {
        *options
    };
    let format = MapFormat::detect(bytes);
    let mut map = match format {
        MapFormat::X3p => x3p::read_x3p_scaled(bytes, options, z_shift)?,
        MapFormat::Sdf => sdf::read_sdf_scaled(bytes, z_shift)?,
        MapFormat::Text => text::read_text_bytes(bytes, &text_options)?,
    };
    if let Some((dx, dy)) = options.pixel_um {
        map.set_pitch(dx, dy).map_err(MapError::Pitch)?;
        map.set_metadata("pitch_source", "option");
    } else if !map.metadata().contains_key("pitch_source") {
        map.set_metadata("pitch_source", "file");
    }
    map.set_metadata("format", format.name());
    if intensity {
        map.set_metadata("values", "intensity as stored in the file (unit-less)");
    }
    Ok((map, format))
}

/// Reads a height map file (X3P, SDF or plain text, recognised from the content).
///
/// # Errors
/// [`ReadMapError::Io`] if the file cannot be read, [`ReadMapError::Format`] naming the
/// file and the problem otherwise.
pub fn read_map(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), ReadMapError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ReadMapError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_map_bytes(&bytes, options).map_err(|error| ReadMapError::Format {
        path: path.to_path_buf(),
        error,
    })
}

/// Reads an intensity image (e.g. a confocal microscope's maximum-intensity map) for use
/// with [`HeightMap::apply_intensity_cutoff`]. Values are returned as the file stores
/// them, unit-less: `Offset + raw × Increment` for X3P, `raw × Zscale` for SDF, the
/// numbers themselves for text (no unit is required or applied; `options.z_unit` is
/// ignored). The pitch rules are those of [`read_map`].
///
/// # Errors
/// As [`read_map`].
pub fn read_intensity(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(HeightMap, MapFormat), ReadMapError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ReadMapError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_intensity_bytes(&bytes, options).map_err(|error| ReadMapError::Format {
        path: path.to_path_buf(),
        error,
    })
}

/// Writes an intensity image (unit-less values) to `path` as X3P (Z `Increment` 1) or
/// plain text (no value unit), so that [`read_intensity`] returns exactly the values
/// written. Writing [`MapFormat::Sdf`] is not supported and returns an error saying so.
///
/// # Errors
/// [`WriteMapError`] naming the file.
pub fn write_intensity(
    map: &HeightMap,
    path: impl AsRef<Path>,
    format: MapFormat,
) -> Result<(), WriteMapError> {
    write_with(map, path.as_ref(), format, true)
}

/// Writes `map` to `path` as X3P (float64 heights in metres, `valid.bin` when some point
/// is invalid) or plain text (µm, with pitch header lines). Writing [`MapFormat::Sdf`] is
/// not supported and returns an error saying so.
///
/// # Errors
/// [`WriteMapError`] naming the file.
pub fn write_map(
    map: &HeightMap,
    path: impl AsRef<Path>,
    format: MapFormat,
) -> Result<(), WriteMapError> {
    write_with(map, path.as_ref(), format, false)
}

fn write_with(
    map: &HeightMap,
    path: &Path,
    format: MapFormat,
    intensity: bool,
) -> Result<(), WriteMapError> {
    let bytes = match (format, intensity) {
        (MapFormat::X3p, false) => x3p::write_x3p_bytes(map)?,
        (MapFormat::X3p, true) => x3p::write_intensity_x3p_bytes(map)?,
        (MapFormat::Text, false) => text::write_text_string(map).into_bytes(),
        (MapFormat::Text, true) => text::write_intensity_text_string(map).into_bytes(),
        (MapFormat::Sdf, _) => {
            return Err(WriteMapError::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::Unsupported,
                    "writing SDF is not supported; use X3P or text",
                ),
            });
        }
    };
    std::fs::write(path, bytes).map_err(|source| WriteMapError::Io {
        path: path.to_path_buf(),
        source,
    })
}
