//! Writing a height map (and an intensity image) as a Zarr v3 store.

use std::path::Path;
use std::sync::Arc;

use flakescatter_stats::heightmap::{HeightMap, Quantity};
use zarrs::array::ArrayBuilder;
use zarrs::array::codec::ZstdCodec;
use zarrs::filesystem::FilesystemStore;

use super::error::{ZarrError, ZarrProblem};
use super::{DEFAULT_CHUNK, HEIGHT, INTENSITY};

/// How [`write_zarr`] lays out the arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ZarrWriteOptions {
    /// Rows and columns of one chunk (edge chunks are partial: stored whole, the part
    /// outside the map holding the fill value NaN). Default [`DEFAULT_CHUNK`] ×
    /// [`DEFAULT_CHUNK`].
    pub chunk: (usize, usize),
    /// The zstd level of each chunk (`None`: chunks stored uncompressed). Default 3,
    /// the level zarr-python uses.
    pub zstd_level: Option<i32>,
}

impl Default for ZarrWriteOptions {
    fn default() -> Self {
        Self {
            chunk: (DEFAULT_CHUNK, DEFAULT_CHUNK),
            zstd_level: Some(3),
        }
    }
}

/// Writes `map` as the Zarr v3 store `dir` (created if missing; it must be empty):
/// the root group with the attributes `pitch_x_um`, `pitch_y_um` and `height_unit`
/// (`"um"`), the array `height` (float64 µm, NaN at invalid points) and, if given,
/// `intensity` (float64 values as stored, NaN where invalid; the same size and pitch
/// as `map`). A map whose [`HeightMap::quantity`] is an intensity is written as the
/// `intensity` array alone (and `intensity` must then be `None`). Valid values are
/// written bit for bit. The store is written in place: callers that need an atomic
/// write build it in a temporary directory and rename it.
///
/// # Errors
/// [`ZarrProblem::Write`] naming what failed (an intensity of another size or pitch, a
/// non-empty directory, a file-system error).
pub fn write_zarr(
    map: &HeightMap,
    intensity: Option<&HeightMap>,
    dir: impl AsRef<Path>,
    options: &ZarrWriteOptions,
) -> Result<(), ZarrError> {
    let dir = dir.as_ref();
    write_checked(map, intensity, dir, options).map_err(|reason| ZarrError {
        store: dir.to_path_buf(),
        problem: ZarrProblem::Write { reason },
    })
}

fn write_checked(
    map: &HeightMap,
    intensity: Option<&HeightMap>,
    dir: &Path,
    options: &ZarrWriteOptions,
) -> Result<(), String> {
    let is_intensity = map.quantity() == Quantity::Intensity;
    if is_intensity && intensity.is_some() {
        return Err("the map is itself an intensity image; give no second intensity".into());
    }
    if let Some(i) = intensity
        && (i.nx(), i.ny(), i.dx(), i.dy()) != (map.nx(), map.ny(), map.dx(), map.dy())
    {
        return Err(format!(
            "the intensity image is {} x {} points at {} x {} µm, the map {} x {} at {} x {} µm",
            i.nx(),
            i.ny(),
            i.dx(),
            i.dy(),
            map.nx(),
            map.ny(),
            map.dx(),
            map.dy()
        ));
    }
    if options.chunk.0 == 0 || options.chunk.1 == 0 {
        return Err(format!(
            "chunk shape {} x {} has an empty side",
            options.chunk.0, options.chunk.1
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    if std::fs::read_dir(dir)
        .map_err(|e| e.to_string())?
        .next()
        .is_some()
    {
        return Err("the directory is not empty".into());
    }
    let store = Arc::new(FilesystemStore::new(dir).map_err(|e| e.to_string())?);
    let mut attributes = serde_json::Map::new();
    attributes.insert("pitch_x_um".into(), map.dx().into());
    attributes.insert("pitch_y_um".into(), map.dy().into());
    if !is_intensity {
        attributes.insert("height_unit".into(), "um".into());
    }
    attributes.insert("written_by".into(), "flakescatter".into());
    zarrs::group::GroupBuilder::new()
        .attributes(attributes)
        .build(store.clone(), "/")
        .map_err(|e| e.to_string())?
        .store_metadata()
        .map_err(|e| e.to_string())?;
    if is_intensity {
        return write_array(&store, INTENSITY, map, options);
    }
    write_array(&store, HEIGHT, map, options)?;
    if let Some(i) = intensity {
        write_array(&store, INTENSITY, i, options)?;
    }
    Ok(())
}

/// Writes the values of `map` (NaN where invalid) as the float64 array `name`.
fn write_array(
    store: &Arc<FilesystemStore>,
    name: &str,
    map: &HeightMap,
    options: &ZarrWriteOptions,
) -> Result<(), String> {
    let (nx, ny) = (map.nx(), map.ny());
    let (cy, cx) = options.chunk;
    let mut builder = ArrayBuilder::new(
        vec![ny as u64, nx as u64],
        vec![cy as u64, cx as u64],
        zarrs::array::data_type::float64(),
        f64::NAN,
    );
    builder.dimension_names(["y", "x"].into());
    if let Some(level) = options.zstd_level {
        builder.bytes_to_bytes_codecs(vec![Arc::new(ZstdCodec::new(level, false))]);
    }
    let array = builder
        .build(store.clone(), &format!("/{name}"))
        .map_err(|e| e.to_string())?;
    array.store_metadata().map_err(|e| e.to_string())?;
    let (z, valid) = (map.heights(), map.valid());
    let mut chunk = vec![f64::NAN; cy * cx];
    for (i, y0) in (0..ny).step_by(cy).enumerate() {
        for (j, x0) in (0..nx).step_by(cx).enumerate() {
            chunk.fill(f64::NAN);
            let w = cx.min(nx - x0);
            for r in 0..cy.min(ny - y0) {
                let from = (y0 + r) * nx + x0;
                for (c, out) in chunk[r * cx..r * cx + w].iter_mut().enumerate() {
                    if valid[from + c] {
                        *out = z[from + c];
                    }
                }
            }
            array
                .store_chunk(&[i as u64, j as u64], chunk.as_slice())
                .map_err(|e| format!("array `{name}`, chunk [{i}, {j}]: {e}"))?;
        }
    }
    Ok(())
}
