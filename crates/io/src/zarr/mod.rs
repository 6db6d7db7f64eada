//! Zarr v3 stores as height maps (a directory of chunk files, readable window by window
//! so that a map larger than memory can be streamed; docs/formats.md "Zarr v3 maps").
//!
//! Layout (`map.zarr/`):
//!
//! * `zarr.json`: the root **group**, whose attributes (or those of the `height` array,
//!   which win) state `pitch_x_um` and `pitch_y_um` (the pitch in µm along x, between
//!   columns, and along y, between rows; positive finite numbers) and `"height_unit":
//!   "um"`.
//! * `height/`: a float64 array of shape `[ny, nx]`, row-major, `y` down the rows and `x`
//!   along the columns, heights in µm, NaN (or any non-finite value) at invalid points,
//!   on a regular chunk grid.
//! * `mask/` (optional): bool or uint8, the shape of `height`; `true` / non-zero = valid.
//!   A point is valid when its mask says so and its height is finite.
//! * `intensity/` (optional): float64, the shape of `height`: the intensity image
//!   (values as stored, unit-less), read where an intensity image is expected. A store
//!   with only this array is an intensity image.
//!
//! Chunks may be uncompressed or zstd-compressed (zarr-python's default); a chunk that
//! is missing reads as the fill value (NaN: invalid points). [`write_zarr`] writes
//! chunks of [`DEFAULT_CHUNK`] × [`DEFAULT_CHUNK`] points (partial at the right and
//! bottom edges), zstd level 3.
//!
//! [`ZarrMap`] opens a store and reads it whole or by windows ([`ZarrMap::read_window`]
//! reads only the chunks a window touches):
//!
//! ```
//! use flakescatter_io::zarr::{ZarrMap, ZarrWriteOptions, write_zarr};
//! use flakescatter_stats::heightmap::HeightMap;
//!
//! let dir = std::env::temp_dir().join(format!("doc-{}.zarr", std::process::id()));
//! # let _ = std::fs::remove_dir_all(&dir);
//! // 3 columns x 2 rows, 0.5 µm x 0.25 µm pixels, one invalid point.
//! let map = HeightMap::new(3, 2, 0.5, 0.25, vec![0.0, 1.5, f64::NAN, -2.0, 0.25, 3.0])?;
//! let options = ZarrWriteOptions { chunk: (1, 2), ..ZarrWriteOptions::default() };
//! write_zarr(&map, None, &dir, &options)?;
//! let store = ZarrMap::open(&dir)?;
//! assert_eq!((store.shape(), store.pitch()), ((2, 3), (0.5, 0.25)));
//! // Rows 0..2 of column 2: the invalid point is NaN.
//! let column = store.read_window(0, 2, 2, 1)?;
//! assert!(column[0].is_nan() && column[1] == 3.0);
//! assert_eq!(store.read()?.heights()[..2], [0.0, 1.5]);
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod read;
mod write;

use std::path::Path;

pub use error::{ZarrError, ZarrProblem};
pub use read::ZarrMap;
pub use write::{ZarrWriteOptions, write_zarr};

/// The heights array's name.
pub const HEIGHT: &str = "height";
/// The mask array's name.
pub const MASK: &str = "mask";
/// The intensity array's name.
pub const INTENSITY: &str = "intensity";
/// Rows and columns of a chunk written by default.
pub const DEFAULT_CHUNK: usize = 1024;

/// Whether `path` is to be read as a Zarr store: a directory holding `zarr.json`, or a
/// directory whose name ends in `.zarr` (any case; [`ZarrMap::open`] then says what is
/// missing).
#[must_use]
pub fn is_store(path: impl AsRef<Path>) -> bool {
    let path = path.as_ref();
    path.is_dir() && (path.join("zarr.json").is_file() || has_zarr_extension(path))
}

/// Whether the name of `path` ends in `.zarr` (any case).
#[must_use]
pub fn has_zarr_extension(path: impl AsRef<Path>) -> bool {
    path.as_ref()
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
}
