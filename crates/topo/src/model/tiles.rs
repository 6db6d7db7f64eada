//! The statistics tiles of the plain model, the scheduler that traces them in
//! parallel and the ordered reduction of their sums (the module docs of [`super`],
//! "Uncertainty" and "Determinism"): input checks, the internal detectors, batches of
//! tiles traced with rayon while the previous batch is reduced in tile order, Welford
//! sums of the tile sums ([`TileStats`]).

use std::ops::Range;

use flakescatter_optics::absorption::PathAbsorption;
use flakescatter_optics::detector::{Cone, distinct_apertures, with_specular_cones};
use flakescatter_stats::HeightMap;
use rayon::prelude::*;

use super::chunk::{Chunk, RAY_CHUNK, trace_chunk};
use super::physics::{Accumulator, Inc, printed_scale};
use super::{TopoModel, TopoOptions, TopoResult, tile_warnings};
use crate::TopoError;
use crate::index::ConeIndex;
use crate::normals::{Rect, Scratch, tile_slopes};
use crate::simd::{Kernels, LANES, dispatch};
use crate::source::HeightSource;

/// Tiles traced between two progress reports. Two batches' partial sums are held in
/// memory at once: one being reduced while the next is traced.
const BATCH: usize = 256;

/// Sums of one tile.
#[derive(Debug)]
pub(crate) struct Partial {
    /// Per (incidence, internal detector, channel), then [`LANES`] slots of padding.
    pub sums: Vec<f64>,
    /// Rays per (incidence, internal detector), then [`LANES`] slots of padding.
    pub counts: Vec<u32>,
    pub usable: u64,
    pub lost_tir: u64,
    pub lost_down: u64,
}

/// Everything fixed during a run.
pub(crate) struct Setup<'a> {
    pub incs: Vec<Inc>,
    pub index: ConeIndex,
    /// The internal detectors.
    pub cones: &'a [Cone],
    /// Per internal detector: 1 (physical) or `cos ϑ'/cos ϑ` (paper-printed).
    pub scale: Vec<f64>,
    /// Whether every ray adds its weight unchanged: every `scale` is 1 and there is no
    /// binder absorption.
    pub unit: bool,
    pub ndet: usize,
    pub options: &'a TopoOptions,
    pub absorption: Option<PathAbsorption>,
    /// The kernels the rays run with.
    pub kernels: Kernels,
}

/// What the tiles of a run add up to, before the per-detector values are formed.
pub(crate) struct Accumulated {
    /// The user's cones, then one specular cone per incidence and distinct aperture.
    pub all: Vec<Cone>,
    /// The distinct apertures of the user's cones, in order of appearance.
    pub apertures: Vec<f64>,
    /// Internal detectors per incidence.
    pub ndet: usize,
    /// Sums per (incidence, internal detector, channel), unnormalised.
    pub sum: Vec<f64>,
    /// Welford M2 of the tile sums, same layout.
    pub m2: Vec<f64>,
    /// Rays per (incidence, internal detector).
    pub rays: Vec<u64>,
    /// Per-incidence constants.
    pub incs: Vec<Inc>,
    /// `1/N_pixels`.
    pub inv_n: f64,
    /// `T/(T − 1)` for `T` tiles (`None` for one tile: no spread to estimate from).
    pub se_factor: Option<f64>,
    /// The totals of the run (with `points` empty).
    pub totals: TopoResult,
}

impl TopoModel {
    pub(crate) fn check_map(&self, i: usize, map: &HeightMap) -> Result<(), TopoError> {
        let k = self.options.window;
        if k > map.nx() || k > map.ny() {
            return Err(TopoError::WindowTooLarge {
                window: k,
                map: i,
                nx: map.nx(),
                ny: map.ny(),
            });
        }
        if !map.valid().iter().any(|&v| v) {
            return Err(TopoError::NoValidPixels {
                map: i,
                pixels: map.len(),
            });
        }
        Ok(())
    }

    /// The input checks of [`TopoModel::run`] (and of the isotropic and Mueller runs).
    pub(crate) fn check_run(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<(), TopoError> {
        check_lists(maps.len(), theta_i, cones)?;
        for (i, map) in maps.iter().enumerate() {
            self.check_map(i, map)?;
        }
        Ok(())
    }

    /// The input checks of a run over sources that need no data: the lists, angles and
    /// apertures, and each map's size against the window ([`TopoError::WindowTooLarge`]).
    /// Maps without a valid point are found as they are traced.
    pub(crate) fn check_sources(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<(), TopoError> {
        check_lists(sources.len(), theta_i, cones)?;
        let k = self.options.window;
        for (i, s) in sources.iter().enumerate() {
            let (nx, ny) = s.size();
            if k > nx || k > ny {
                return Err(TopoError::WindowTooLarge {
                    window: k,
                    map: i,
                    nx,
                    ny,
                });
            }
        }
        Ok(())
    }

    /// The statistics tiles of a map, row-major (`bands::TileGrid`).
    pub(crate) fn tiles(&self, map: &HeightMap) -> Vec<Rect> {
        let grid = self.grid((map.nx(), map.ny()), (map.dx(), map.dy()));
        (0..grid.count() as usize).map(|t| grid.rect(t)).collect()
    }

    /// The internal detectors of a run at `theta_i` with the user's `cones`.
    pub(crate) fn detectors(
        &self,
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<Detectors, TopoError> {
        // The user's cones, then one specular cone per incidence and distinct aperture
        // (for `relative`).
        let apertures = distinct_apertures(cones);
        let all = with_specular_cones(cones, theta_i, &apertures).map_err(TopoError::Detector)?;
        Ok(Detectors { all, apertures })
    }

    /// What is fixed during a run over the detectors `det` at `theta_i`.
    pub(crate) fn setup<'a>(&'a self, det: &'a Detectors, theta_i: &[f64]) -> Setup<'a> {
        let n = self.options.n;
        let scale: Vec<f64> = det
            .all
            .iter()
            .map(|c| printed_scale(self.options.weighting, c, n))
            .collect();
        Setup {
            incs: theta_i.iter().map(|&t| Inc::new(t, n)).collect(),
            index: ConeIndex::new(&det.all),
            cones: &det.all,
            unit: self.absorption.is_none() && scale.iter().all(|&s| s == 1.0),
            scale,
            ndet: det.all.len(),
            options: &self.options,
            absorption: self.absorption,
            kernels: self.kernels,
        }
    }

    /// Validates the input, builds the internal detectors (the user's cones, then one
    /// specular cone per incidence and distinct aperture, for `relative`), traces every
    /// tile with `acc` and reduces the tile sums in tile order (module docs).
    ///
    /// # Errors
    /// As [`TopoModel::run`].
    pub(crate) fn accumulate<A: Accumulator>(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
        progress: &(dyn Fn(u64, u64) + Sync),
        acc: &A,
    ) -> Result<Accumulated, TopoError> {
        self.check_run(maps, theta_i, cones)?;
        let sources: Vec<&dyn HeightSource> = maps.iter().map(|&m| m as _).collect();
        self.accumulate_sources(&sources, theta_i, cones, progress, acc)
    }

    /// As [`TopoModel::accumulate`] over sources read band by band (module docs,
    /// "Streaming"); a map without a valid point is refused once traced.
    ///
    /// # Errors
    /// As [`TopoModel::run_sources`].
    pub(crate) fn accumulate_sources<A: Accumulator>(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        progress: &(dyn Fn(u64, u64) + Sync),
        acc: &A,
    ) -> Result<Accumulated, TopoError> {
        self.check_sources(sources, theta_i, cones)?;
        let det = self.detectors(theta_i, cones)?;
        let setup = self.setup(&det, theta_i);
        let nslots = theta_i.len() * setup.ndet * acc.channels();
        let mut red = Reduction::new(nslots, theta_i.len() * setup.ndet);
        let total = self.tile_count(sources);
        let valid = self.trace_range(sources, &setup, 0..total, progress, acc, &mut |p| {
            red.add_partial(&p);
        })?;
        let incs = setup.incs;
        self.accumulated(sources, det, incs, red, &valid)
    }

    /// Traces the tiles numbered `range` (module docs, "Streaming") with `acc`, band by
    /// band, each band's tiles in parallel in batches, and hands every tile's sums to
    /// `take` in tile order (each batch while the next is traced); `progress(done,
    /// total)` in tiles of the range, from the calling thread. Returns the valid points
    /// of each map's tiles of the range.
    pub(crate) fn trace_range<A: Accumulator>(
        &self,
        sources: &[&dyn HeightSource],
        setup: &Setup<'_>,
        range: Range<u64>,
        progress: &(dyn Fn(u64, u64) + Sync),
        acc: &A,
        take: &mut (dyn FnMut(Partial) + Send),
    ) -> Result<Vec<u64>, TopoError> {
        let total = range.end - range.start;
        let mut reduced = 0u64;
        // Each batch's partial sums are reduced, in tile order, while the next batch is
        // traced (`rayon::join`), so that the reduction does not leave the other cores
        // idle; `progress` is called between the joins, on the calling thread, with the
        // tiles reduced so far.
        let mut reduce = |partials: Vec<Partial>| {
            for p in partials {
                take(p);
                reduced += 1;
            }
            reduced
        };
        let trace = |map: &HeightMap, batch: &[Rect]| -> Vec<Partial> {
            batch
                .par_iter()
                .map_init(TraceScratch::default, |scratch, &rect| {
                    trace_tile(setup, map, rect, scratch, acc)
                })
                .collect()
        };
        let mut pending = Vec::new();
        let valid = self.for_each_batch(sources, range, BATCH, |_, map, batch| {
            let done = std::mem::take(&mut pending);
            let r;
            (r, pending) = rayon::join(|| reduce(done), || trace(map, batch));
            progress(r, total);
        })?;
        progress(reduce(pending), total);
        Ok(valid)
    }

    /// The sums of a run reduced into `red`, with the totals, after the checks that
    /// need the data: a map without a valid point (`valid` per map), no usable pixel.
    pub(crate) fn accumulated(
        &self,
        sources: &[&dyn HeightSource],
        det: Detectors,
        incs: Vec<Inc>,
        red: Reduction,
        valid: &[u64],
    ) -> Result<Accumulated, TopoError> {
        let pixels = self.check_valid(sources, valid, red.usable)?;
        let ninc = incs.len() as u64;
        let total_tiles = red.stats.count();
        let t = total_tiles as f64;
        // No spread to estimate from with one tile (module docs): None, not NaN.
        let se_factor = (total_tiles > 1).then(|| t / (t - 1.0));
        let ndet = det.all.len();
        let (sum, m2) = red.stats.into_sum_and_m2();
        Ok(Accumulated {
            all: det.all,
            apertures: det.apertures,
            ndet,
            sum,
            m2,
            rays: red.rays,
            incs,
            inv_n: 1.0 / pixels as f64,
            se_factor,
            totals: TopoResult {
                points: Vec::new(),
                maps: sources.len(),
                pixels,
                usable_pixels: red.usable,
                rays_traced: red.usable * ninc,
                rays_lost_tir: red.lost_tir,
                rays_lost_down: red.lost_down,
                tiles: total_tiles,
                valid_pixels: valid.to_vec(),
                block_um: self.block_um,
                warnings: tile_warnings(total_tiles),
            },
        })
    }

    /// The checks of a run that need the data, once traced: a map whose tiles held no
    /// valid point ([`TopoError::NoValidPixels`], the first in map order), no usable
    /// pixel at all ([`TopoError::NoUsablePixels`]). Returns `N_pixels`, all pixels of
    /// all maps (from their sizes).
    pub(crate) fn check_valid(
        &self,
        sources: &[&dyn HeightSource],
        valid: &[u64],
        usable: u64,
    ) -> Result<u64, TopoError> {
        let sizes: Vec<u64> = sources
            .iter()
            .map(|s| {
                let (nx, ny) = s.size();
                (nx * ny) as u64
            })
            .collect();
        if let Some(map) = valid.iter().position(|&v| v == 0) {
            return Err(TopoError::NoValidPixels {
                map,
                pixels: sizes[map] as usize,
            });
        }
        let pixels: u64 = sizes.iter().sum();
        if usable == 0 {
            return Err(TopoError::NoUsablePixels {
                window: self.options.window,
                valid: valid.iter().sum::<u64>() as usize,
                pixels: pixels as usize,
            });
        }
        Ok(pixels)
    }
}

/// The checks of the lists and angles of a run over `maps` maps.
fn check_lists(maps: usize, theta_i: &[f64], cones: &[Cone]) -> Result<(), TopoError> {
    if maps == 0 {
        return Err(TopoError::Empty("height map"));
    }
    if theta_i.is_empty() {
        return Err(TopoError::Empty("incidence angle"));
    }
    if cones.is_empty() {
        return Err(TopoError::Empty("detector"));
    }
    for &t in theta_i {
        if !(t.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&t)) {
            return Err(TopoError::Incidence(t));
        }
    }
    if let Some(j) = cones.iter().position(|c| c.half_angle() <= 0.0) {
        return Err(TopoError::PointDetector(j));
    }
    Ok(())
}

/// The internal detectors of a run: the user's cones, then one specular cone per
/// incidence and distinct aperture.
pub(crate) struct Detectors {
    pub all: Vec<Cone>,
    /// The distinct apertures of the user's cones, in order of appearance.
    pub apertures: Vec<f64>,
}

/// The ordered reduction of a run's tile sums: plain sums and Welford mean/M2 of the
/// tile sums per slot, ray counts, usable pixels and lost rays.
pub(crate) struct Reduction {
    pub stats: TileStats,
    pub rays: Vec<u64>,
    pub usable: u64,
    pub lost_tir: u64,
    pub lost_down: u64,
}

impl Reduction {
    /// Nothing yet, for `nslots` sums and `nrays` ray counts.
    pub fn new(nslots: usize, nrays: usize) -> Self {
        Self {
            stats: TileStats::new(nslots),
            rays: vec![0; nrays],
            usable: 0,
            lost_tir: 0,
            lost_down: 0,
        }
    }

    /// The next tile's sums (`sums`, one per slot), in tile order.
    pub fn add_sums(&mut self, sums: &[f64]) {
        self.stats.add(&sums[..self.stats.sum().len()]);
    }

    /// The next tile, in tile order.
    pub fn add_partial(&mut self, p: &Partial) {
        self.add_sums(&p.sums);
        self.usable += p.usable;
        self.lost_tir += p.lost_tir;
        self.lost_down += p.lost_down;
        for (r, &c) in self.rays.iter_mut().zip(&p.counts) {
            *r += u64::from(c);
        }
    }
}

/// The ordered reduction of per-tile sums, slot by slot: their total, and Welford's
/// running mean and `m2` (sum of squared deviations) of the tile sums, from which the
/// standard errors come (one implementation, in `numerics`).
pub(crate) type TileStats = flakescatter_numerics::welford::Welford;

/// Reusable buffers of [`trace_tile`]: the normals' window sums, a chunk of slopes and
/// what [`trace_chunk`] keeps per normal of a chunk.
#[derive(Debug, Default)]
pub(crate) struct TraceScratch {
    normals: Scratch,
    /// Slopes `(a, b)` of the chunk's usable pixels.
    slopes: Vec<[f64; 2]>,
    chunk: Chunk,
}

/// Normals of one tile, then one ray per usable pixel and incidence.
///
/// The sums of each (incidence, detector) take the rays in pixel order whatever the
/// chunking, so the result is that of one ray at a time, bit for bit.
pub(crate) fn trace_tile<A: Accumulator>(
    setup: &Setup<'_>,
    map: &HeightMap,
    rect: Rect,
    scratch: &mut TraceScratch,
    acc: &A,
) -> Partial {
    let ndet = setup.ndet;
    let channels = acc.channels();
    let mut p = Partial {
        // `LANES` slots of padding: the scalar model adds to eight consecutive
        // detectors at once (`trace_chunk`).
        sums: vec![0.0; setup.incs.len() * ndet * channels + LANES],
        counts: vec![0; setup.incs.len() * ndet + LANES],
        usable: 0,
        lost_tir: 0,
        lost_down: 0,
    };
    let TraceScratch {
        normals,
        slopes,
        chunk,
    } = scratch;
    slopes.clear();
    let kernels = setup.kernels;
    let mut trace = |slopes: &[[f64; 2]], p: &mut Partial| {
        dispatch!(kernels, |lanes| trace_chunk(
            setup, slopes, chunk, acc, p, lanes
        ));
    };
    let usable = tile_slopes::<false>(
        map,
        setup.options.window / 2,
        rect,
        normals,
        kernels,
        |_, _, a, b| {
            slopes.push([a, b]);
            if slopes.len() == RAY_CHUNK {
                trace(slopes, &mut p);
                slopes.clear();
            }
        },
    );
    trace(slopes, &mut p);
    p.usable = usable as u64;
    p
}
