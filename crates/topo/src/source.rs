//! Height maps as sources of bands of rows, so that a map larger than memory can be
//! traced band by band ([`TopoModel::run_sources`](crate::TopoModel::run_sources) and the
//! other `*_sources` runs; module docs of [`crate::model`], "Streaming").
//!
//! The model crates do no I/O: whoever holds the map (a file reader in the facade, or a
//! map already in memory) implements [`HeightSource`], which gives the map's size and
//! pitch and, on request, a band of whole rows as a [`HeightMap`] (heights in µm,
//! validity including any intensity cutoff). A [`HeightMap`] is itself a source whose
//! band of all rows is the map, borrowed: the in-memory runs go through the same code
//! without copying.
//!
//! Conventions: sizes `(nx, ny)` = (columns, rows), pitch `(dx, dy)` in µm, rows
//! numbered from 0 at the top as in [`HeightMap`].

use std::borrow::Cow;
use std::sync::Arc;

use flakescatter_stats::HeightMap;

/// Why a source could not give a band: the reader's own error (it names the file).
pub type BoxedError = Box<dyn std::error::Error + Send + Sync>;

/// A height map that can be read a band of whole rows at a time.
pub trait HeightSource: Sync {
    /// `(nx, ny)`: columns and rows of the whole map.
    fn size(&self) -> (usize, usize);

    /// `(dx, dy)`: the pitch along x (between columns) and y (between rows), µm.
    fn pitch(&self) -> (f64, f64);

    /// Rows `r0..r1` of the map (`r0 < r1 ≤ ny`), every column, as a map of
    /// `nx × (r1 − r0)` points with the map's pitch: heights in µm, a point valid when
    /// it was measured and passes any intensity cutoff (row 0 of the band is row `r0`
    /// of the map).
    ///
    /// # Errors
    /// Whatever reading the band failed with (naming the file and what went wrong).
    fn rows(&self, r0: usize, r1: usize) -> Result<Cow<'_, HeightMap>, BoxedError>;

    /// About how many rows one read should span: the model reads bands of whole tile
    /// rows, as many as fit in this (at least one). A chunked store gives its chunk
    /// height (or what fits its memory budget); the default, `usize::MAX`, reads the
    /// whole map at once (a map in memory).
    fn band_rows(&self) -> usize {
        usize::MAX
    }
}

impl HeightSource for HeightMap {
    fn size(&self) -> (usize, usize) {
        (self.nx(), self.ny())
    }

    fn pitch(&self) -> (f64, f64) {
        (self.dx(), self.dy())
    }

    /// The map itself, borrowed, for all rows; a copy of the rows otherwise.
    fn rows(&self, r0: usize, r1: usize) -> Result<Cow<'_, HeightMap>, BoxedError> {
        if r0 == 0 && r1 == self.ny() {
            return Ok(Cow::Borrowed(self));
        }
        let nx = self.nx();
        let span = r0 * nx..r1 * nx;
        let band = HeightMap::with_mask(
            nx,
            r1 - r0,
            self.dx(),
            self.dy(),
            self.heights()[span.clone()].to_vec(),
            self.valid()[span].to_vec(),
        )?;
        Ok(Cow::Owned(band))
    }
}

/// A source's read error, shared (so that [`crate::TopoError`] stays `Clone`); equal
/// when the messages are.
#[derive(Debug, Clone)]
pub struct SourceError(pub Arc<dyn std::error::Error + Send + Sync>);

impl SourceError {
    /// Wraps a reader's error.
    #[must_use]
    pub fn new(error: BoxedError) -> Self {
        Self(Arc::from(error))
    }
}

impl std::fmt::Display for SourceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl PartialEq for SourceError {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.0.to_string() == other.0.to_string()
    }
}
