//! Maps larger than memory: Zarr v3 stores read band by band while the topographic
//! model traces them (docs/guide.md "Big maps"; `flakescatter_topo::model`, module
//! docs "Streaming").
//!
//! [`ZarrSource`] opens a store ([`crate::io::zarr::ZarrMap`]) as a
//! [`HeightSource`]: each band is read from the chunks it touches, the store's mask
//! applied, and, with a cutoff, the intensity cutoff applied point by point from the
//! store's own `intensity` array or a partner store's, exactly as the in-memory loader
//! applies it (a point is kept when its intensity is finite and at least the cutoff).
//! The runs ([`topographic_curves_streamed`], [`isotropic_curves_streamed`],
//! [`pixel_orientation_streamed`]) give the numbers of [`crate::topographic_curves`],
//! [`crate::isotropic_curves`] and [`crate::pixel_orientation`] on the same maps in
//! memory, bit for bit, holding about one band of [`BAND_BYTES`] of heights at a time.
//!
//! **Split runs** (for workers that each trace a block of tiles, and a client that
//! merges them): [`tile_count`] numbers the tiles (maps in order, each row-major, tiles
//! of `tile_um`); [`trace_tiles`] traces a range of them into per-tile sums
//! ([`TileSums`]); [`finish_topographic`] / [`finish_isotropic`] reduce the parts, in
//! tile order, into exactly the curves of one call. A worker needs only the stores and
//! the settings; the finish reads no band (only the stores' sizes and pitches).

use std::borrow::Cow;
use std::ops::Range;
use std::path::{Path, PathBuf};

use flakescatter_io::zarr::{ZarrError, ZarrMap};
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_topo::{
    BoxedError, HeightSource, IsotropicOptions, IsotropicResult, TileSums, TopoResult,
};
use thiserror::Error;

use crate::PipelineError;
use crate::instrument::Instrument;
use crate::pipeline::{
    Coating, Curves, Settings, TopoSettings, isotropic_curves_of, plain_curves, plain_model,
    topo_model,
};
use crate::pixels::{PixelOrientation, orientation_of};

/// Heights read in one band at most, bytes (64 MiB): a band is as many whole chunk
/// rows of the store as fit in this, or as many rows as fit when one chunk row does
/// not. The peak memory of a streamed run is about twice this (the heights, their
/// validity and, with a cutoff, the intensities of one band) plus the model's tables.
pub const BAND_BYTES: usize = 64 << 20;

/// Where the intensity cutoff of a store comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum StoreCutoff {
    /// No cutoff.
    None,
    /// The store's own `intensity` array, points below `cutoff` masked.
    Own(f64),
    /// The `intensity` array of a second store (same shape and pitch), points below
    /// the cutoff masked.
    Partner(PathBuf, f64),
}

/// Why a store cannot be streamed.
#[derive(Debug, Error)]
pub enum StoreError {
    /// The store (or its partner) cannot be opened, or lacks an array (names the store).
    #[error(transparent)]
    Zarr(#[from] ZarrError),
    /// The store holds no `height` array.
    #[error("Zarr store {}: it has no `height` array to trace", .0.display())]
    NoHeight(PathBuf),
    /// A cutoff without an `intensity` array to apply it with.
    #[error("Zarr store {}: a cutoff of {cutoff} is asked but the store has no `intensity` array", store.display())]
    NoIntensity {
        /// The store that should hold it.
        store: PathBuf,
        /// The cutoff.
        cutoff: f64,
    },
    /// A cutoff that is not a number.
    #[error("Zarr store {}: the cutoff is NaN", .0.display())]
    BadCutoff(PathBuf),
    /// A partner store of another shape or pitch.
    #[error("Zarr store {}: its intensity store {} is {partner:?} points (rows, columns) of {partner_pitch:?} µm, the heights {heights:?} of {pitch:?} µm", store.display(), intensity.display())]
    Grid {
        /// The height store.
        store: PathBuf,
        /// The intensity store.
        intensity: PathBuf,
        /// Its shape.
        partner: (usize, usize),
        /// Its pitch.
        partner_pitch: (f64, f64),
        /// The heights' shape.
        heights: (usize, usize),
        /// The heights' pitch.
        pitch: (f64, f64),
    },
}

/// A Zarr v3 height-map store read band by band (module docs).
#[derive(Debug)]
pub struct ZarrSource {
    store: ZarrMap,
    /// The store holding the intensities (`None`: this one) and the cutoff.
    cutoff: Option<(Option<ZarrMap>, f64)>,
}

impl ZarrSource {
    /// Opens the store `path` (its metadata only) with the intensity cutoff `cutoff`.
    ///
    /// # Errors
    /// [`StoreError`] naming the store: it cannot be opened, has no `height` array, or
    /// the cutoff has no `intensity` array or a partner of another shape or pitch.
    pub fn open(path: impl AsRef<Path>, cutoff: &StoreCutoff) -> Result<Self, StoreError> {
        let path = path.as_ref();
        let store = ZarrMap::open(path)?;
        if !store.has_height() {
            return Err(StoreError::NoHeight(path.to_path_buf()));
        }
        let cutoff = match cutoff {
            StoreCutoff::None => None,
            StoreCutoff::Own(c) => {
                if !store.has_intensity() {
                    return Err(StoreError::NoIntensity {
                        store: path.to_path_buf(),
                        cutoff: *c,
                    });
                }
                Some((None, *c))
            }
            StoreCutoff::Partner(ipath, c) => {
                let partner = ZarrMap::open(ipath)?;
                if !partner.has_intensity() {
                    return Err(StoreError::NoIntensity {
                        store: ipath.clone(),
                        cutoff: *c,
                    });
                }
                let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
                let (p, q) = (partner.pitch(), store.pitch());
                if partner.shape() != store.shape() || !(same(p.0, q.0) && same(p.1, q.1)) {
                    return Err(StoreError::Grid {
                        store: path.to_path_buf(),
                        intensity: ipath.clone(),
                        partner: partner.shape(),
                        partner_pitch: p,
                        heights: store.shape(),
                        pitch: q,
                    });
                }
                Some((Some(partner), *c))
            }
        };
        if let Some((_, c)) = &cutoff
            && c.is_nan()
        {
            return Err(StoreError::BadCutoff(path.to_path_buf()));
        }
        Ok(Self { store, cutoff })
    }

    /// The store's directory.
    #[must_use]
    pub fn path(&self) -> &Path {
        self.store.path()
    }
}

impl HeightSource for ZarrSource {
    fn size(&self) -> (usize, usize) {
        let (ny, nx) = self.store.shape();
        (nx, ny)
    }

    fn pitch(&self) -> (f64, f64) {
        self.store.pitch()
    }

    fn rows(&self, r0: usize, r1: usize) -> Result<Cow<'_, HeightMap>, BoxedError> {
        let (nx, _) = self.size();
        let (dx, dy) = self.pitch();
        let z = self.store.read_window(r0, 0, r1 - r0, nx)?;
        let map = match &self.cutoff {
            None => HeightMap::new(nx, r1 - r0, dx, dy, z)?,
            Some((partner, cutoff)) => {
                let store = partner.as_ref().unwrap_or(&self.store);
                let intensity = store
                    .read_intensity_window(r0, 0, r1 - r0, nx)?
                    .ok_or_else(|| {
                        format!(
                            "Zarr store {}: no `intensity` array",
                            store.path().display()
                        )
                    })?;
                // The in-memory cutoff's rule: an intensity that is finite and at least
                // the cutoff keeps the point.
                let keep = intensity
                    .iter()
                    .map(|&v| v.is_finite() && v >= *cutoff)
                    .collect();
                drop(intensity);
                HeightMap::with_mask(nx, r1 - r0, dx, dy, z, keep)?
            }
        };
        Ok(Cow::Owned(map))
    }

    fn band_rows(&self) -> usize {
        let (nx, _) = self.size();
        let fit = (BAND_BYTES / (nx.max(1) * 8)).max(1);
        let (chunk_rows, _) = self.store.chunk_shape();
        if chunk_rows <= fit {
            fit / chunk_rows * chunk_rows
        } else {
            fit
        }
    }
}

/// [`crate::topographic_curves`] over maps read band by band from `sources` (module
/// docs): the same curves and totals, bit for bit, as the maps in memory.
///
/// # Errors
/// As [`crate::topographic_curves`]; [`PipelineError::Topo`] with
/// `TopoError::Source` when a band cannot be read (the reader's error names the store
/// and the array).
pub fn topographic_curves_streamed(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    sources: &[&dyn HeightSource],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(Curves, TopoResult), PipelineError> {
    let model = plain_model(coating, instrument, settings, topo)?;
    let result = model.run_sources(sources, instrument.theta_i(), instrument.cones(), progress)?;
    Ok((plain_curves(coating, instrument, settings, &result), result))
}

/// [`crate::isotropic_curves`] over maps read band by band from `sources` (module
/// docs): the same curves and totals, bit for bit.
///
/// # Errors
/// As [`crate::isotropic_curves`] and [`topographic_curves_streamed`].
pub fn isotropic_curves_streamed(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    node_spacing: Option<f64>,
    sources: &[&dyn HeightSource],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(Curves, IsotropicResult), PipelineError> {
    let model = plain_model(coating, instrument, settings, topo)?;
    let result = model.run_isotropic_sources(
        sources,
        instrument.theta_i(),
        instrument.cones(),
        &IsotropicOptions { node_spacing },
        progress,
    )?;
    Ok((
        isotropic_curves_of(coating, instrument, settings, &result),
        result,
    ))
}

/// [`crate::pixel_orientation`] over maps read band by band from `sources`: the same
/// distribution and widths, bit for bit. `progress(done, total)` counts tiles.
///
/// # Errors
/// As [`crate::pixel_orientation`] and [`topographic_curves_streamed`].
pub fn pixel_orientation_streamed(
    sources: &[&dyn HeightSource],
    topo: &TopoSettings,
    bin_width: f64,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<PixelOrientation, PipelineError> {
    let tilts = crate::pixels::model(topo)?.pixel_tilts_sources(sources, bin_width, progress)?;
    orientation_of(tilts, bin_width)
}

/// Number of statistics tiles of `sources` with tiles of `topo.tile_um` (the numbers
/// [`trace_tiles`] takes ranges of: maps in order, each row-major).
///
/// # Errors
/// [`PipelineError::Topo`] for invalid settings.
pub fn tile_count(
    coating: &Coating,
    settings: &Settings,
    topo: &TopoSettings,
    sources: &[&dyn HeightSource],
) -> Result<u64, PipelineError> {
    Ok(topo_model(coating, settings, topo)?.tile_count(sources))
}

/// Traces the tiles numbered `tiles` of `sources` (plain model, or isotropic with
/// `isotropic = Some(node_spacing)`) into their per-tile sums, for
/// [`finish_topographic`] / [`finish_isotropic`].
///
/// # Errors
/// As [`topographic_curves_streamed`]; `TopoError::Partials` for a range that is empty
/// or reaches past the last tile.
#[allow(clippy::too_many_arguments)]
pub fn trace_tiles(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    isotropic: Option<Option<f64>>,
    sources: &[&dyn HeightSource],
    tiles: Range<u64>,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<TileSums, PipelineError> {
    let model = plain_model(coating, instrument, settings, topo)?;
    let (theta_i, cones) = (instrument.theta_i(), instrument.cones());
    Ok(match isotropic {
        None => model.trace_tiles(sources, theta_i, cones, tiles, progress)?,
        Some(node_spacing) => model.trace_tiles_isotropic(
            sources,
            theta_i,
            cones,
            &IsotropicOptions { node_spacing },
            tiles,
            progress,
        )?,
    })
}

/// The curves of a plain run from its parts ([`trace_tiles`] over consecutive ranges
/// covering every tile, in tile order): those of [`topographic_curves_streamed`], bit
/// for bit. `sources` give only their sizes and pitches (no band is read).
///
/// # Errors
/// As [`topographic_curves_streamed`]; `TopoError::Partials` for parts out of order,
/// overlapping, leaving tiles out or of another model or instrument.
pub fn finish_topographic(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    sources: &[&dyn HeightSource],
    parts: &[TileSums],
) -> Result<(Curves, TopoResult), PipelineError> {
    let model = plain_model(coating, instrument, settings, topo)?;
    let result = model.finish(sources, instrument.theta_i(), instrument.cones(), parts)?;
    Ok((plain_curves(coating, instrument, settings, &result), result))
}

/// As [`finish_topographic`] for isotropic parts: the curves of
/// [`isotropic_curves_streamed`], bit for bit (but `nodes`, summed over the parts).
///
/// # Errors
/// As [`finish_topographic`].
pub fn finish_isotropic(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    node_spacing: Option<f64>,
    sources: &[&dyn HeightSource],
    parts: &[TileSums],
) -> Result<(Curves, IsotropicResult), PipelineError> {
    let model = plain_model(coating, instrument, settings, topo)?;
    let result = model.finish_isotropic(
        sources,
        instrument.theta_i(),
        instrument.cones(),
        &IsotropicOptions { node_spacing },
        parts,
    )?;
    Ok((
        isotropic_curves_of(coating, instrument, settings, &result),
        result,
    ))
}
