//! Writing a height map or an intensity image in one of the formats that can be written.

use std::path::Path;

use flakescatter_stats::heightmap::HeightMap;

use crate::reader::ValueKind;
use crate::sdf;
use crate::text;
use crate::x3p;

use super::error::WriteMapError;
use super::format::MapFormat;

/// Writes an intensity image (unit-less values) to `path` as X3P (Z `Increment` 1), SDF
/// (text, `Zscale` 1), plain text (no value unit) or a Zarr v3 store (its `intensity`
/// array alone), so that
/// [`read_intensity`](super::read_intensity) returns exactly the values written. The
/// instrument formats cannot be written (an error says so).
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
/// text (µm, with pitch header lines), or as a Zarr v3 store (the directory `path`,
/// which must be missing or empty: [`crate::zarr::write_zarr`] with its default
/// options). A map whose [`HeightMap::quantity`] is an
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
    if format == MapFormat::Zarr {
        // Copied only when written as another quantity than it says it is.
        let mut map = std::borrow::Cow::Borrowed(map);
        if map.quantity() != kind {
            map.to_mut().set_quantity(kind);
        }
        return crate::zarr::write_zarr(
            &map,
            None,
            path,
            &crate::zarr::ZarrWriteOptions::default(),
        )
        .map_err(WriteMapError::Zarr);
    }
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
            | MapFormat::Frt
            | MapFormat::Zarr,
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
