//! [`ZarrMap`]: a Zarr v3 height-map store opened for reading, whole or by windows.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use flakescatter_stats::heightmap::HeightMap;
use zarrs::array::Array;
use zarrs::array::data_type::{BoolDataType, Float64DataType, UInt8DataType};
use zarrs::filesystem::FilesystemStore;

use super::error::{ZarrError, ZarrProblem};
use super::{HEIGHT, INTENSITY, MASK};

type StoreArray = Array<FilesystemStore>;

/// The mask's data type: `bool` (true = valid) or `uint8` (0 = invalid, else valid).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MaskType {
    Bool,
    UInt8,
}

/// A Zarr v3 height-map store (layout in the [module docs](super)), opened: its
/// metadata read and checked, no chunk read yet. [`ZarrMap::read_window`] reads only
/// the chunks a window touches.
pub struct ZarrMap {
    store: PathBuf,
    height: Option<StoreArray>,
    mask: Option<(StoreArray, MaskType)>,
    intensity: Option<StoreArray>,
    /// Rows, columns.
    shape: (u64, u64),
    /// µm along x (columns), along y (rows).
    pitch: (f64, f64),
    /// Chunk rows, chunk columns.
    chunks: (u64, u64),
}

impl std::fmt::Debug for ZarrMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZarrMap")
            .field("store", &self.store)
            .field("shape", &self.shape)
            .field("pitch", &self.pitch)
            .field("chunks", &self.chunks)
            .field("mask", &self.mask.is_some())
            .field("intensity", &self.intensity.is_some())
            .finish_non_exhaustive()
    }
}

impl ZarrMap {
    /// Opens the store `path` and checks its layout: the `height` array (float64, 2-D,
    /// non-empty, a regular chunk grid), the pitch and unit attributes, and the optional
    /// `mask` (bool or uint8) and `intensity` (float64) arrays of the same shape. A store
    /// holding only an `intensity` array opens too (an intensity image); reading its
    /// heights is then an error.
    ///
    /// # Errors
    /// [`ZarrError`] naming the store and the array or attribute at fault.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, ZarrError> {
        let store = path.as_ref().to_path_buf();
        let fail = |problem| ZarrError {
            store: store.clone(),
            problem,
        };
        open_checked(&store).map_err(fail)
    }

    /// The store's directory.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.store
    }

    /// `(rows, columns)` = `(ny, nx)` of the map.
    #[must_use]
    pub fn shape(&self) -> (usize, usize) {
        (to_usize(self.shape.0), to_usize(self.shape.1))
    }

    /// `(dx, dy)`: the pitch in µm along x (between columns) and along y (between rows).
    #[must_use]
    pub fn pitch(&self) -> (f64, f64) {
        self.pitch
    }

    /// `(rows, columns)` of one chunk (edge chunks are cut to the map).
    #[must_use]
    pub fn chunk_shape(&self) -> (usize, usize) {
        (to_usize(self.chunks.0), to_usize(self.chunks.1))
    }

    /// Whether the store has a `height` array.
    #[must_use]
    pub fn has_height(&self) -> bool {
        self.height.is_some()
    }

    /// Whether the store has an `intensity` array.
    #[must_use]
    pub fn has_intensity(&self) -> bool {
        self.intensity.is_some()
    }

    /// Whether the store has a `mask` array.
    #[must_use]
    pub fn has_mask(&self) -> bool {
        self.mask.is_some()
    }

    fn fail(&self, problem: ZarrProblem) -> ZarrError {
        ZarrError {
            store: self.store.clone(),
            problem,
        }
    }

    /// The heights (µm) of the window of `ny` rows × `nx` columns whose first point is
    /// row `y0`, column `x0`, row-major (`index = (row - y0) * nx + (col - x0)`), NaN
    /// where the point is invalid (NaN or non-finite in `height`, or false / 0 in
    /// `mask`). Only the chunks the window touches are read.
    ///
    /// # Errors
    /// [`ZarrProblem::Window`] if the window reaches outside the map (or is empty),
    /// [`ZarrProblem::NoHeight`] for a store without heights, [`ZarrProblem::Array`]
    /// if a chunk cannot be read or decoded (e.g. a chunk file of the wrong size).
    pub fn read_window(
        &self,
        y0: usize,
        x0: usize,
        ny: usize,
        nx: usize,
    ) -> Result<Vec<f64>, ZarrError> {
        let window = self.window(y0, x0, ny, nx)?;
        let height = self.height.as_ref().ok_or_else(|| {
            self.fail(ZarrProblem::NoHeight {
                has_intensity: self.has_intensity(),
            })
        })?;
        let mut z: Vec<f64> =
            retrieve(height, &window).map_err(|r| self.array(HEIGHT, within(&window, &r)))?;
        if let Some((mask, kind)) = &self.mask {
            let valid: Vec<bool> = match kind {
                MaskType::Bool => retrieve(mask, &window),
                MaskType::UInt8 => retrieve::<Vec<u8>>(mask, &window)
                    .map(|m| m.into_iter().map(|v| v != 0).collect()),
            }
            .map_err(|r| self.array(MASK, within(&window, &r)))?;
            for (z, ok) in z.iter_mut().zip(valid) {
                if !ok {
                    *z = f64::NAN;
                }
            }
        }
        Ok(z)
    }

    /// [`ZarrMap::read_window`] as a [`HeightMap`] of `nx × ny` points with the store's
    /// pitch (µm).
    ///
    /// # Errors
    /// As [`ZarrMap::read_window`].
    pub fn read_window_map(
        &self,
        y0: usize,
        x0: usize,
        ny: usize,
        nx: usize,
    ) -> Result<HeightMap, ZarrError> {
        let z = self.read_window(y0, x0, ny, nx)?;
        self.to_map(nx, ny, z)
    }

    /// The `intensity` values (as stored, NaN = no value; the mask is not applied) of
    /// the window of `ny` rows × `nx` columns whose first point is row `y0`, column
    /// `x0`, row-major as [`ZarrMap::read_window`]; `None` when the store has no
    /// `intensity` array. Only the chunks the window touches are read.
    ///
    /// # Errors
    /// As [`ZarrMap::read_window`].
    pub fn read_intensity_window(
        &self,
        y0: usize,
        x0: usize,
        ny: usize,
        nx: usize,
    ) -> Result<Option<Vec<f64>>, ZarrError> {
        let Some(intensity) = &self.intensity else {
            return Ok(None);
        };
        let window = self.window(y0, x0, ny, nx)?;
        retrieve(intensity, &window)
            .map(Some)
            .map_err(|r| self.array(INTENSITY, within(&window, &r)))
    }

    /// The whole height map (µm, mask applied), with the metadata `zarr.chunks`.
    ///
    /// # Errors
    /// As [`ZarrMap::read_window`].
    pub fn read(&self) -> Result<HeightMap, ZarrError> {
        let (ny, nx) = self.shape();
        let mut map = self.read_window_map(0, 0, ny, nx)?;
        self.describe(&mut map);
        Ok(map)
    }

    /// The `intensity` array as stored (unit-less; NaN = no value), with the store's
    /// pitch; `None` when the store has none. The mask is not applied (it is the
    /// heights' validity).
    ///
    /// # Errors
    /// [`ZarrProblem::Array`] if a chunk cannot be read or decoded.
    pub fn read_intensity(&self) -> Result<Option<HeightMap>, ZarrError> {
        let Some(intensity) = &self.intensity else {
            return Ok(None);
        };
        let (ny, nx) = self.shape();
        let window = self.window(0, 0, ny, nx)?;
        let v: Vec<f64> =
            retrieve(intensity, &window).map_err(|r| self.array(INTENSITY, within(&window, &r)))?;
        let mut map = self.to_map(nx, ny, v)?;
        self.describe(&mut map);
        Ok(Some(map))
    }

    fn describe(&self, map: &mut HeightMap) {
        map.set_metadata(
            "zarr.chunks",
            format!("{} x {}", self.chunks.0, self.chunks.1),
        );
    }

    fn to_map(&self, nx: usize, ny: usize, z: Vec<f64>) -> Result<HeightMap, ZarrError> {
        HeightMap::new(nx, ny, self.pitch.0, self.pitch.1, z).map_err(|e| {
            self.fail(ZarrProblem::Array {
                array: HEIGHT,
                reason: e.to_string(),
            })
        })
    }

    fn array(&self, array: &'static str, reason: String) -> ZarrError {
        self.fail(ZarrProblem::Array { array, reason })
    }

    /// The window as array ranges, checked against the map.
    fn window(
        &self,
        y0: usize,
        x0: usize,
        ny: usize,
        nx: usize,
    ) -> Result<[std::ops::Range<u64>; 2], ZarrError> {
        let (y0, x0, ny, nx) = (y0 as u64, x0 as u64, ny as u64, nx as u64);
        let (rows, cols) = self.shape;
        let inside = ny > 0
            && nx > 0
            && y0.checked_add(ny).is_some_and(|e| e <= rows)
            && x0.checked_add(nx).is_some_and(|e| e <= cols);
        if !inside {
            return Err(self.fail(ZarrProblem::Window {
                y0,
                x0,
                ny,
                nx,
                rows,
                cols,
            }));
        }
        Ok([y0..y0 + ny, x0..x0 + nx])
    }
}

fn to_usize(v: u64) -> usize {
    usize::try_from(v).unwrap_or(usize::MAX)
}

/// A read error with the window it happened in.
fn within(window: &[std::ops::Range<u64>; 2], reason: &str) -> String {
    format!(
        "reading rows {}..{}, columns {}..{}: {reason}",
        window[0].start, window[0].end, window[1].start, window[1].end
    )
}

/// The elements of `window` of `array`, or zarrs's message.
fn retrieve<T: zarrs::array::FromArrayBytes>(
    array: &StoreArray,
    window: &[std::ops::Range<u64>; 2],
) -> Result<T, String> {
    array
        .retrieve_array_subset::<T>(window)
        .map_err(|e| e.to_string())
}

/// Whether `node` of the store `root` exists (has a `zarr.json`).
fn has_node(root: &Path, node: &str) -> bool {
    root.join(node).join("zarr.json").is_file()
}

fn open_checked(root: &Path) -> Result<ZarrMap, ZarrProblem> {
    if !root.is_dir() {
        return Err(ZarrProblem::NotAStore {
            reason: "it is not a directory".into(),
        });
    }
    if !root.join("zarr.json").is_file() {
        return Err(ZarrProblem::NotAStore {
            reason: "the directory has no zarr.json (Zarr v2 stores, with .zgroup/.zarray, are not read)".into(),
        });
    }
    let fs = FilesystemStore::new(root).map_err(|e| ZarrProblem::NotAStore {
        reason: e.to_string(),
    })?;
    let fs = Arc::new(fs);
    let group = zarrs::group::Group::open(fs.clone(), "/").map_err(|e| ZarrProblem::NotAStore {
        reason: format!("its root zarr.json is not a Zarr v3 group: {e}"),
    })?;
    let open = |name: &'static str| -> Result<Option<StoreArray>, ZarrProblem> {
        if !has_node(root, name) {
            return Ok(None);
        }
        Array::open(fs.clone(), &format!("/{name}"))
            .map(Some)
            .map_err(|e| ZarrProblem::Array {
                array: name,
                reason: e.to_string(),
            })
    };
    let height = open(HEIGHT)?;
    let intensity = open(INTENSITY)?;
    let mask = open(MASK)?;
    let Some(first) = height.as_ref().or(intensity.as_ref()) else {
        return Err(ZarrProblem::NoArray);
    };
    let first_name = if height.is_some() { HEIGHT } else { INTENSITY };
    let shape = check_2d(first, first_name)?;
    let chunks = check_chunks(first, first_name)?;
    for (array, name) in [(&height, HEIGHT), (&intensity, INTENSITY)] {
        if let Some(a) = array {
            if !a.data_type().is::<Float64DataType>() {
                return Err(ZarrProblem::DataType {
                    array: name,
                    found: a.data_type().to_string(),
                    expected: "float64",
                });
            }
            same_shape(a, name, first_name, shape)?;
            check_chunks(a, name)?;
        }
    }
    let mask = match mask {
        None => None,
        Some(m) => {
            let kind = if m.data_type().is::<BoolDataType>() {
                MaskType::Bool
            } else if m.data_type().is::<UInt8DataType>() {
                MaskType::UInt8
            } else {
                return Err(ZarrProblem::DataType {
                    array: MASK,
                    found: m.data_type().to_string(),
                    expected: "bool or uint8",
                });
            };
            same_shape(&m, MASK, first_name, shape)?;
            check_chunks(&m, MASK)?;
            Some((m, kind))
        }
    };
    let attrs = |key: &str| {
        height
            .as_ref()
            .and_then(|h| h.attributes().get(key))
            .or_else(|| group.attributes().get(key))
            .cloned()
    };
    let pitch = (
        pitch_attribute("pitch_x_um", attrs("pitch_x_um"))?,
        pitch_attribute("pitch_y_um", attrs("pitch_y_um"))?,
    );
    if height.is_some() {
        match attrs("height_unit") {
            Some(serde_json::Value::String(u)) if u == "um" || u == "µm" => {}
            other => {
                return Err(ZarrProblem::Attribute {
                    attribute: "height_unit",
                    found: shown(other.as_ref()),
                    expected: "\"um\" (heights in micrometres)",
                });
            }
        }
    }
    Ok(ZarrMap {
        store: root.to_path_buf(),
        height,
        mask,
        intensity,
        shape,
        pitch,
        chunks,
    })
}

/// A JSON value for messages, `missing` for none.
fn shown(value: Option<&serde_json::Value>) -> String {
    value.map_or_else(|| "missing".into(), ToString::to_string)
}

fn pitch_attribute(
    attribute: &'static str,
    value: Option<serde_json::Value>,
) -> Result<f64, ZarrProblem> {
    match value.as_ref().and_then(serde_json::Value::as_f64) {
        Some(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(ZarrProblem::Attribute {
            attribute,
            found: shown(value.as_ref()),
            expected: "a positive finite number (µm)",
        }),
    }
}

/// `(rows, columns)` of a 2-D, non-empty array.
fn check_2d(array: &StoreArray, name: &'static str) -> Result<(u64, u64), ZarrProblem> {
    match array.shape() {
        [rows, cols] if *rows > 0 && *cols > 0 => Ok((*rows, *cols)),
        other => Err(ZarrProblem::Shape {
            array: name,
            found: other.to_vec(),
            expected: "two non-zero dimensions [ny, nx]".into(),
        }),
    }
}

fn same_shape(
    array: &StoreArray,
    name: &'static str,
    first: &'static str,
    shape: (u64, u64),
) -> Result<(), ZarrProblem> {
    if array.shape() == [shape.0, shape.1] {
        return Ok(());
    }
    Err(ZarrProblem::Shape {
        array: name,
        found: array.shape().to_vec(),
        expected: format!("[{}, {}], the shape of `{first}`", shape.0, shape.1),
    })
}

/// The chunk shape of a regular 2-D chunk grid covering the array.
fn check_chunks(array: &StoreArray, name: &'static str) -> Result<(u64, u64), ZarrProblem> {
    let bad = |reason: String| ZarrProblem::Chunks {
        array: name,
        reason,
    };
    let chunk = array.chunk_shape(&[0, 0]).map_err(|e| bad(e.to_string()))?;
    let [cy, cx] = chunk.as_slice() else {
        return Err(bad(format!("chunk shape {chunk:?} is not two-dimensional")));
    };
    let (cy, cx) = (cy.get(), cx.get());
    let grid = array.chunk_grid_shape();
    let (rows, cols) = (array.shape()[0], array.shape()[1]);
    if grid != [rows.div_ceil(cy), cols.div_ceil(cx)] {
        return Err(bad(format!(
            "a grid of {grid:?} chunks of {cy} x {cx} does not cover {rows} x {cols} points exactly once"
        )));
    }
    Ok((cy, cx))
}
