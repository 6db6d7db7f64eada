//! A run split into ranges of tiles, each traced on its own into per-tile sums
//! ([`TileSums`]), and an ordered finish that reduces them exactly as one call does
//! (module docs of [`super`], "Ranges and finish"). The plain model's range and finish
//! are here; the isotropic model's in [`crate::isotropic`].

use std::ops::Range;

use flakescatter_optics::detector::Cone;

use super::physics::Scalar;
use super::tiles::{Partial, Reduction};
use super::{TopoModel, TopoResult};
use crate::TopoError;
use crate::source::HeightSource;

/// Which model a [`TileSums`] was traced with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TileSumsKind {
    /// [`TopoModel::trace_tiles`].
    Plain,
    /// [`TopoModel::trace_tiles_isotropic`].
    Isotropic,
}

/// The per-tile sums of a range of tiles: what a worker sends back for the finish
/// ([`TopoModel::finish`], [`TopoModel::finish_isotropic`]). Tile numbers are those of
/// the module docs of [`crate::model`] ("Streaming"): maps in order, each row-major.
///
/// The rows are kept per tile (not summed) because the finish reduces them in tile
/// order, which is what makes a split run equal to one call bit for bit; the integer
/// counts are summed (their order does not matter). Slots are per (incidence, internal
/// detector): the user's cones, then one specular cone per distinct aperture (plain:
/// per incidence and distinct aperture).
#[derive(Debug, Clone, PartialEq)]
pub struct TileSums {
    /// The model traced.
    pub kind: TileSumsKind,
    /// The tile numbers traced.
    pub tiles: Range<u64>,
    /// Numbers per tile in `rows`: plain, the weight sum per slot (unnormalised, before
    /// the division by `N_pixels`); isotropic, the response sum per slot, then the
    /// interpolation-error sum per slot, then the ring fractions lost to total internal
    /// reflection and heading down.
    pub width: usize,
    /// `width` numbers per tile, tiles in order.
    pub rows: Vec<f64>,
    /// Per slot, the rays (plain) or pixels whose ring meets the cone (isotropic)
    /// counted over the range.
    pub counts: Vec<u64>,
    /// Usable pixels (complete window of valid points) of the range.
    pub usable: u64,
    /// Plain: rays lost to total internal reflection (isotropic: 0, the fractions are
    /// in `rows`).
    pub lost_tir: u64,
    /// Plain: rays heading down after reflection (isotropic: 0).
    pub lost_down: u64,
    /// Per map, the valid points of the range's tiles (their own pixels).
    pub valid: Vec<u64>,
    /// Isotropic: table nodes this range evaluated (summed over incidences); 0 plain.
    pub nodes: usize,
}

impl TileSums {
    /// No tile yet.
    pub(crate) fn empty(
        kind: TileSumsKind,
        tiles: Range<u64>,
        width: usize,
        slots: usize,
        maps: usize,
    ) -> Self {
        Self {
            kind,
            rows: Vec::with_capacity(width * (tiles.end - tiles.start) as usize),
            tiles,
            width,
            counts: vec![0; slots],
            usable: 0,
            lost_tir: 0,
            lost_down: 0,
            valid: vec![0; maps],
            nodes: 0,
        }
    }

    fn add_plain(&mut self, p: &Partial) {
        let n = self.width;
        self.rows.extend_from_slice(&p.sums[..n]);
        for (c, &k) in self.counts.iter_mut().zip(&p.counts) {
            *c += u64::from(k);
        }
        self.usable += p.usable;
        self.lost_tir += p.lost_tir;
        self.lost_down += p.lost_down;
    }
}

/// Refuses a range that is empty or reaches past the `total` tiles.
pub(crate) fn check_range(tiles: &Range<u64>, total: u64) -> Result<(), TopoError> {
    if tiles.start >= tiles.end || tiles.end > total {
        return Err(TopoError::Partials(format!(
            "tiles {}..{} is not a non-empty range of the run's {total} tiles",
            tiles.start, tiles.end
        )));
    }
    Ok(())
}

/// Checks that `parts` are of `kind`, with `width` numbers per tile and `slots` counts,
/// one row per tile, and cover the tiles `0..total` in order without overlap; returns
/// the valid points per map (`maps` of them) summed over the parts.
pub(crate) fn check_parts(
    parts: &[TileSums],
    kind: TileSumsKind,
    (width, slots): (usize, usize),
    total: u64,
    maps: usize,
) -> Result<Vec<u64>, TopoError> {
    let mut next = 0;
    let mut valid = vec![0; maps];
    for (i, p) in parts.iter().enumerate() {
        let bad = |what: String| Err(TopoError::Partials(format!("part {i} (0-based): {what}")));
        if p.kind != kind {
            return bad(format!(
                "traced with the {:?} model, finished as {kind:?}",
                p.kind
            ));
        }
        if p.tiles.start != next {
            return bad(format!(
                "starts at tile {}, expected {next}: parts must follow each other in tile order",
                p.tiles.start
            ));
        }
        let tiles = p.tiles.end.saturating_sub(p.tiles.start) as usize;
        if p.width != width
            || p.rows.len() != width * tiles
            || p.counts.len() != slots
            || p.valid.len() != maps
        {
            return bad(format!(
                "holds {} numbers per tile for {tiles} tiles ({} rows), {} counts and {} maps; this run has {width} per tile, {slots} counts and {maps} maps (another instrument or map list?)",
                p.width,
                p.rows.len(),
                p.counts.len(),
                p.valid.len()
            ));
        }
        for (v, &pv) in valid.iter_mut().zip(&p.valid) {
            *v += pv;
        }
        next = p.tiles.end;
    }
    if next != total {
        return Err(TopoError::Partials(format!(
            "the parts cover tiles 0..{next}, the run has {total}"
        )));
    }
    Ok(valid)
}

impl TopoModel {
    /// Traces the tiles numbered `tiles` (of [`TopoModel::tile_count`]) of `sources`
    /// with the plain model and returns their per-tile sums, for
    /// [`TopoModel::finish`]. `progress(done, total)` counts the range's tiles.
    ///
    /// # Errors
    /// As [`TopoModel::run_sources`] (but for the checks that need all tiles, made by
    /// the finish); [`TopoError::Partials`] for a range that is empty or reaches past
    /// the last tile.
    pub fn trace_tiles(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        tiles: Range<u64>,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<TileSums, TopoError> {
        self.check_sources(sources, theta_i, cones)?;
        check_range(&tiles, self.tile_count(sources))?;
        let det = self.detectors(theta_i, cones)?;
        let setup = self.setup(&det, theta_i);
        let nslots = theta_i.len() * setup.ndet;
        let mut out = TileSums::empty(
            TileSumsKind::Plain,
            tiles.clone(),
            nslots,
            nslots,
            sources.len(),
        );
        let valid = self.trace_range(sources, &setup, tiles, progress, &Scalar, &mut |p| {
            out.add_plain(&p);
        })?;
        out.valid = valid;
        Ok(out)
    }

    /// The result of a run from its parts ([`TopoModel::trace_tiles`] over consecutive
    /// ranges covering every tile, given in tile order): the tile rows reduced in tile
    /// order exactly as [`TopoModel::run_sources`] reduces them, so the result is that
    /// of one call, bit for bit. `sources` give only their sizes and pitches here (no
    /// band is read); they, `theta_i` and `cones` must be those the parts were traced
    /// with.
    ///
    /// # Errors
    /// As [`TopoModel::run_sources`]; [`TopoError::Partials`] for parts out of order,
    /// overlapping, leaving tiles out or of another model or detector set.
    pub fn finish(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        parts: &[TileSums],
    ) -> Result<TopoResult, TopoError> {
        self.check_sources(sources, theta_i, cones)?;
        let det = self.detectors(theta_i, cones)?;
        let setup = self.setup(&det, theta_i);
        let nslots = theta_i.len() * setup.ndet;
        let total = self.tile_count(sources);
        let valid = check_parts(
            parts,
            TileSumsKind::Plain,
            (nslots, nslots),
            total,
            sources.len(),
        )?;
        let mut red = Reduction::new(nslots, nslots);
        for p in parts {
            for row in p.rows.chunks_exact(nslots) {
                red.add_sums(row);
            }
            red.usable += p.usable;
            red.lost_tir += p.lost_tir;
            red.lost_down += p.lost_down;
            for (r, &c) in red.rays.iter_mut().zip(&p.counts) {
                *r += c;
            }
        }
        let incs = setup.incs;
        let acc = self.accumulated(sources, det, incs, red, &valid)?;
        Ok(self.result_of(acc, theta_i, cones))
    }
}
