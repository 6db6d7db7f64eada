//! The statistics tiles of a run over [`HeightSource`]s and the band driver that reads
//! them (module docs of [`super`], "Streaming"): each map is cut into tiles of
//! `block_um` (rounded to whole pixels, the last row and column of tiles cut by the
//! map's edge), numbered row-major, map after map; a range of those numbers is traced
//! band by band, a band being a run of whole tile rows (as many as fit in the source's
//! [`HeightSource::band_rows`]) read with `h = ⌊k/2⌋` rows of halo above and below
//! (clipped at the map's edges) and every column.
//!
//! **Why a band gives the very numbers of the whole map.** A tile's pixels get slopes
//! only from the points of their `k × k` windows, and [`tile_slopes`](crate::normals)
//! decides which pixels have a whole window from the edges of the map it is given.
//! The band holds every column, so its left and right edges are the map's; its top
//! edge is the map's when the band starts at row 0, and otherwise lies `h` rows above
//! the tile's first row, so every pixel of the tile still has its window inside the
//! band, and a pixel in the map's top `h` rows never lies in such a band's tiles
//! (likewise at the bottom). The tile's region (its rows and columns with the halo) is
//! the same points in the band as in the map, so the reference height, the window
//! sums and their order, and hence every bit, are the same.

use std::ops::Range;

use flakescatter_stats::HeightMap;
use rayon::prelude::*;

use super::TopoModel;
use crate::TopoError;
use crate::normals::Rect;
use crate::source::{HeightSource, SourceError};

/// The tile layout of one map: `tc × tr` pixels per tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TileGrid {
    pub nx: usize,
    pub ny: usize,
    /// Tile columns and rows, pixels.
    pub tc: usize,
    pub tr: usize,
}

impl TileGrid {
    /// Tiles across a row of tiles.
    pub fn across(&self) -> usize {
        self.nx.div_ceil(self.tc)
    }

    /// Rows of tiles.
    pub fn down(&self) -> usize {
        self.ny.div_ceil(self.tr)
    }

    /// Number of tiles.
    pub fn count(&self) -> u64 {
        (self.across() * self.down()) as u64
    }

    /// Tile `t` (row-major) in map coordinates.
    pub fn rect(&self, t: usize) -> Rect {
        let (r0, c0) = ((t / self.across()) * self.tr, (t % self.across()) * self.tc);
        Rect {
            r0,
            r1: (r0 + self.tr).min(self.ny),
            c0,
            c1: (c0 + self.tc).min(self.nx),
        }
    }
}

impl TopoModel {
    /// The tile layout of a map of `nx × ny` pixels of pitch `dx × dy` µm.
    pub(crate) fn grid(&self, (nx, ny): (usize, usize), (dx, dy): (f64, f64)) -> TileGrid {
        TileGrid {
            nx,
            ny,
            tc: ((self.block_um / dx).round() as usize).max(1),
            tr: ((self.block_um / dy).round() as usize).max(1),
        }
    }

    /// The tile layout of a source.
    pub(crate) fn grid_of(&self, source: &dyn HeightSource) -> TileGrid {
        self.grid(source.size(), source.pitch())
    }

    /// Number of statistics tiles over all `sources` (the numbers a range of
    /// [`TopoModel::trace_tiles`] counts in: maps in order, each row-major).
    #[must_use]
    pub fn tile_count(&self, sources: &[&dyn HeightSource]) -> u64 {
        sources.iter().map(|s| self.grid_of(*s).count()).sum()
    }

    /// Calls `batch(map_index, band, rects)` for the tiles numbered `range` (over all
    /// `sources`, module docs), in tile order, at most `per_batch` at a time, each
    /// tile's rectangle translated into `band`, the band read from its source (halo
    /// rows included, module docs). Returns the valid points of each map's tiles of
    /// the range (their own pixels, not the halo).
    ///
    /// # Errors
    /// [`TopoError::Source`] when a source cannot give a band, or gives one of another
    /// size or pitch than it states.
    pub(crate) fn for_each_batch(
        &self,
        sources: &[&dyn HeightSource],
        range: Range<u64>,
        per_batch: usize,
        mut batch: impl FnMut(usize, &HeightMap, &[Rect]),
    ) -> Result<Vec<u64>, TopoError> {
        let h = self.options.window / 2;
        let mut valid = vec![0u64; sources.len()];
        let mut first = 0u64;
        let mut rects = Vec::new();
        for (mi, source) in sources.iter().enumerate() {
            let grid = self.grid_of(*source);
            let n = grid.count();
            let (lo, hi) = (range.start.max(first), range.end.min(first + n));
            first += n;
            if lo >= hi {
                continue;
            }
            // Local tile numbers of this map.
            let (lo, hi) = ((lo - (first - n)) as usize, (hi - (first - n)) as usize);
            let across = grid.across();
            let per = (source.band_rows() / grid.tr).max(1);
            let mut row = lo / across;
            while row * across < hi {
                let end = (row + per).min(hi.div_ceil(across));
                let read = (row * grid.tr).saturating_sub(h)..(end * grid.tr + h).min(grid.ny);
                let band = read_band(*source, mi, read.clone())?;
                let tiles = (row * across).max(lo)..(end * across).min(hi);
                rects.clear();
                rects.extend(tiles.map(|t| {
                    let r = grid.rect(t);
                    Rect {
                        r0: r.r0 - read.start,
                        r1: r.r1 - read.start,
                        ..r
                    }
                }));
                valid[mi] += rects
                    .par_iter()
                    .map(|&r| count_valid(&band, r))
                    .sum::<u64>();
                for part in rects.chunks(per_batch) {
                    batch(mi, &band, part);
                }
                row = end;
            }
        }
        Ok(valid)
    }
}

/// Rows `rows` of `source` (map `map`), checked against the size and pitch it states.
fn read_band<'a>(
    source: &'a dyn HeightSource,
    map: usize,
    rows: Range<usize>,
) -> Result<std::borrow::Cow<'a, HeightMap>, TopoError> {
    let fail = |error| TopoError::Source {
        map,
        error: SourceError::new(error),
    };
    let band = source.rows(rows.start, rows.end).map_err(fail)?;
    let ((nx, _), pitch) = (source.size(), source.pitch());
    if (band.nx(), band.ny()) != (nx, rows.len()) || (band.dx(), band.dy()) != pitch {
        return Err(fail(
            format!(
                "the source gave rows {}..{} as {} x {} points of {} x {} µm, expected {nx} x {} of {} x {} µm",
                rows.start,
                rows.end,
                band.nx(),
                band.ny(),
                band.dx(),
                band.dy(),
                rows.len(),
                pitch.0,
                pitch.1
            )
            .into(),
        ));
    }
    Ok(band)
}

/// Valid points of the tile `r` (band rows) in `band`.
fn count_valid(band: &HeightMap, r: Rect) -> u64 {
    let (nx, valid) = (band.nx(), band.valid());
    (r.r0..r.r1)
        .map(|row| {
            let span = row * nx + r.c0..row * nx + r.c1;
            valid[span].iter().filter(|&&v| v).count() as u64
        })
        .sum()
}
