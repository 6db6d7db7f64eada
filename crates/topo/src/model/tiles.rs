//! The statistics tiles of the plain model, the scheduler that traces them in
//! parallel and the ordered reduction of their sums (the module docs of [`super`],
//! "Uncertainty" and "Determinism"): input checks, the internal detectors, batches of
//! tiles traced with rayon while the previous batch is reduced in tile order, Welford
//! sums of the tile sums ([`TileStats`]).

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
        if maps.is_empty() {
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
        for (i, map) in maps.iter().enumerate() {
            self.check_map(i, map)?;
        }
        Ok(())
    }

    /// The statistics tiles of a map, row-major.
    pub(crate) fn tiles(&self, map: &HeightMap) -> Vec<Rect> {
        let tc = ((self.block_um / map.dx()).round() as usize).max(1);
        let tr = ((self.block_um / map.dy()).round() as usize).max(1);
        let mut out = Vec::new();
        for r0 in (0..map.ny()).step_by(tr) {
            for c0 in (0..map.nx()).step_by(tc) {
                out.push(Rect {
                    r0,
                    r1: (r0 + tr).min(map.ny()),
                    c0,
                    c1: (c0 + tc).min(map.nx()),
                });
            }
        }
        out
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
        let n = self.options.n;

        // Internal detectors: the user's cones, then one specular cone per incidence and
        // distinct aperture (for `relative`).
        let apertures = distinct_apertures(cones);
        let all = with_specular_cones(cones, theta_i, &apertures).map_err(TopoError::Detector)?;
        let ndet = all.len();
        let scale: Vec<f64> = all
            .iter()
            .map(|c| printed_scale(self.options.weighting, c, n))
            .collect();
        let incs: Vec<Inc> = theta_i.iter().map(|&t| Inc::new(t, n)).collect();
        let setup = Setup {
            incs,
            index: ConeIndex::new(&all),
            cones: &all,
            unit: self.absorption.is_none() && scale.iter().all(|&s| s == 1.0),
            scale,
            ndet,
            options: &self.options,
            absorption: self.absorption,
            kernels: self.kernels,
        };

        let jobs: Vec<(usize, Rect)> = maps
            .iter()
            .enumerate()
            .flat_map(|(i, m)| self.tiles(m).into_iter().map(move |r| (i, r)))
            .collect();
        let total_tiles = jobs.len() as u64;
        let channels = acc.channels();
        let nslots = theta_i.len() * ndet * channels;
        // Ordered reduction: plain sums, Welford mean/M2 of the tile sums, ray counts.
        let mut stats = TileStats::new(nslots);
        let mut rays = vec![0u64; theta_i.len() * ndet];
        let (mut usable, mut lost_tir, mut lost_down) = (0u64, 0u64, 0u64);
        // Each batch's partial sums are reduced, in tile order, while the next batch is
        // traced (`rayon::join`), so that the reduction does not leave the other cores
        // idle; `progress` is called between the joins, on the calling thread
        // (`run_with_progress`), with the tiles reduced so far.
        let mut reduce = |partials: Vec<Partial>| {
            for p in partials {
                stats.add(&p.sums[..nslots]);
                usable += p.usable;
                lost_tir += p.lost_tir;
                lost_down += p.lost_down;
                for (r, &c) in rays.iter_mut().zip(&p.counts) {
                    *r += u64::from(c);
                }
            }
            stats.count()
        };
        let trace = |batch: &[(usize, Rect)]| -> Vec<Partial> {
            batch
                .par_iter()
                .map_init(TraceScratch::default, |scratch, &(mi, rect)| {
                    trace_tile(&setup, maps[mi], rect, scratch, acc)
                })
                .collect()
        };
        let mut pending = Vec::new();
        for batch in jobs.chunks(BATCH) {
            let done = std::mem::take(&mut pending);
            let reduced;
            (reduced, pending) = rayon::join(|| reduce(done), || trace(batch));
            progress(reduced, total_tiles);
        }
        progress(reduce(pending), total_tiles);

        let pixels: u64 = maps.iter().map(|m| m.len() as u64).sum();
        if usable == 0 {
            return Err(TopoError::NoUsablePixels {
                window: self.options.window,
                valid: maps.iter().map(|m| m.valid_count()).sum(),
                pixels: pixels as usize,
            });
        }
        let t = total_tiles as f64;
        // No spread to estimate from with one tile (module docs): None, not NaN.
        let se_factor = (total_tiles > 1).then(|| t / (t - 1.0));
        let incs = setup.incs;
        let (sum, m2) = stats.into_sum_and_m2();
        Ok(Accumulated {
            all,
            apertures,
            ndet,
            sum,
            m2,
            rays,
            incs,
            inv_n: 1.0 / pixels as f64,
            se_factor,
            totals: TopoResult {
                points: Vec::new(),
                maps: maps.len(),
                pixels,
                usable_pixels: usable,
                rays_traced: usable * theta_i.len() as u64,
                rays_lost_tir: lost_tir,
                rays_lost_down: lost_down,
                tiles: total_tiles,
                block_um: self.block_um,
                warnings: tile_warnings(total_tiles),
            },
        })
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
fn trace_tile<A: Accumulator>(
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
