//! Ray tracing over height maps and counting into detector cones (physics.md §5, paper
//! eqs. 14 and 15).
//!
//! Conventions: angles in radians, lengths in micrometres, the frame and signed `θs` of
//! `flakescatter_optics`. Per usable pixel with local normal `m` (from a least-squares
//! plane, [`crate::normals`]) and per incidence `θi`, the beam refracted into the
//! coating is mirror-reflected by the local plane and refracted out; its weight, a
//! fraction of the beam power (`F γ / (m.z cos θt) / N_pixels` with the path factor
//! `F`), is added to every detector cone that contains its exit direction. The
//! equations, step by step, with the `paper-printed` weighting, the clear coat and the
//! binder absorption, are in `model/physics.rs`; the tiles, their scheduling and
//! reduction in `model/tiles.rs`; the vectorised ray pass in `model/chunk.rs`.
//!
//! # Uncertainty
//! Rays are **not** independent: all pixels of one flat flake send their rays into the
//! same direction, so the noise of a detector's value is set by the number of flakes it
//! sees, not the number of rays. The maps are cut into square tiles of side
//! [`DEFAULT_BLOCK_UM`] = 32 µm (about two mean flake diameters; adjustable with
//! [`TopoModel::with_block_um`]), and the tiles of all maps are treated as independent
//! samples. With `s_t` the (unnormalised) sum of weights a detector receives from tile
//! `t` of `T` tiles, the estimate is `ρ = Σ_t s_t / N_pixels` and its standard error is
//! the between-tile estimate `se(ρ) = sqrt(T/(T−1) · Σ_t (s_t − s̄)²) / N_pixels`
//! (identical to the delete-one block jackknife for a sum). Flakes cut by tile edges
//! make neighbouring tiles slightly correlated, which biases `se` low by a few per cent
//! when flakes are much smaller than tiles, more when they are not; use tiles of a few
//! flake diameters.
//!
//! When the standard error cannot be estimated it is `None`, never NaN or 0:
//! * with fewer than 2 tiles (a map smaller than one tile, or a huge tile side) there is
//!   no spread to estimate from: every row's error is `None` and
//!   [`TopoResult::warnings`] holds [`TopoWarning::StdErrNotEstimable`];
//! * a detector that received no ray has nothing to spread either (the between-tile
//!   formula would give 0, a claim of certainty): its error is `None` and `rays = 0`
//!   says why. An upper bound is not given: rays are not independent (one flake sends
//!   hundreds into the same direction), so a Poisson bound on zero rays would need the
//!   number of flakes the detector could have seen, which the map does not tell.
//!
//! With 2 to [`MIN_TILES`]` − 1` tiles the errors are estimated but rest on very few
//! samples; [`TopoWarning::FewTiles`] says so.
//!
//! # Determinism
//! Tiles are fixed by the map size and pitch, each tile is traced sequentially, and the
//! per-tile sums are reduced in tile order: the result is bit-identical for any number of
//! rayon threads. Within a tile the rays are traced 512 pixels at a time, incidence by
//! incidence, under `pulp`'s choice of instruction set (SSE2, AVX2 or AVX-512 encodings
//! of the same operations, no fused multiply–add); every (incidence, detector) sum still
//! takes its rays in pixel order, so neither the chunking nor the processor changes a
//! bit.
//!
//! # Streaming
//! **Tile decomposition.** Each map of `nx × ny` pixels is cut into tiles of
//! `tc × tr` pixels, `tc = max(1, round(block_um/dx))`, `tr = max(1, round(block_um/dy))`,
//! the last column and row of tiles cut by the map's edge. Tiles are numbered row-major
//! within a map (tile `t` is tile row `t / ⌈nx/tc⌉`, column `t mod ⌈nx/tc⌉`), maps in the
//! order given, one number sequence over all maps ([`TopoModel::tile_count`]).
//!
//! **Reduction order.** Every tile's sums are formed on its own (its pixels in raster
//! order) and the tile sums are reduced in tile number order, per slot: the total and
//! Welford's running mean and `M2` (`flakescatter_numerics::welford`); the integer
//! counts (rays, usable pixels, lost rays) are plain sums.
//!
//! **Bands.** A run over [`HeightSource`]s ([`TopoModel::run_sources`],
//! [`TopoModel::run_isotropic_sources`], [`TopoModel::pixel_tilts_sources`]) reads each
//! map a band at a time: whole tile rows, as many as fit in
//! [`HeightSource::band_rows`], with the window's `⌊k/2⌋` rows of halo above and below
//! (clipped at the map's edges) and every column. The band's tiles are traced in
//! parallel and reduced in tile order, then the next band is read, so a run holds one
//! band (plus the tile sums of two batches) whatever the map's size. A band gives every
//! tile the same points, window sums and reference height as the whole map, so the
//! result is the in-memory result bit for bit (`model/bands.rs` says why; a map in memory
//! is a source whose one band is the map itself, borrowed). `N_pixels` comes from the
//! maps' sizes; the valid points are counted per tile as the bands are read, and a map
//! without any is refused once traced ([`TopoError::NoValidPixels`], as in memory).
//!
//! **Ranges and finish.** [`TopoModel::trace_tiles`] traces a range of tile numbers and
//! returns their per-tile sums ([`TileSums`]); [`TopoModel::finish`] takes the parts of a
//! run, in tile order, and reduces them exactly as one call does, so that workers can
//! each trace a block of tile rows and a client merge them into the same result, bit
//! for bit ([`TopoModel::trace_tiles_isotropic`] and
//! [`TopoModel::finish_isotropic`] for the isotropic model).

use flakescatter_optics::absorption::PathAbsorption;
use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::HeightMap;
use rayon::prelude::*;

use crate::TopoError;
use crate::normals::{Normals, Rect, Scratch, tile_slopes};
use crate::simd::Kernels;
use crate::source::HeightSource;

mod bands;
mod chunk;
mod physics;
pub(crate) mod split;
mod tiles;

use physics::Scalar;
pub(crate) use physics::{Accumulator, Inc, Ray, path_factor_of, printed_scale, ray_path};
pub use split::{TileSums, TileSumsKind};
pub(crate) use tiles::TileStats;

/// Side of the square statistics tiles, µm (see the module docs on uncertainty).
pub const DEFAULT_BLOCK_UM: f64 = 32.0;

/// Fewer statistics tiles than this earn a [`TopoWarning::FewTiles`].
pub const MIN_TILES: u64 = 10;

/// Why a result's uncertainties deserve caution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopoWarning {
    /// Fewer than 2 statistics tiles: no standard error can be estimated (all `None`).
    StdErrNotEstimable {
        /// Tiles over all maps.
        tiles: u64,
    },
    /// Between 2 and [`MIN_TILES`]` − 1` tiles: the standard errors rest on few samples.
    FewTiles {
        /// Tiles over all maps.
        tiles: u64,
    },
}

impl std::fmt::Display for TopoWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::StdErrNotEstimable { tiles } => write!(
                f,
                "standard errors not estimable: they come from the spread between map tiles and there is {tiles} tile; use smaller tiles or more or larger maps"
            ),
            Self::FewTiles { tiles } => write!(
                f,
                "standard errors rest on only {tiles} map tiles (fewer than {MIN_TILES}): they are themselves uncertain by about {:.0} % (1/sqrt(2(tiles - 1)))",
                100.0 / (2.0 * (tiles as f64 - 1.0)).sqrt()
            ),
        }
    }
}

/// What the number of statistics tiles says about the standard errors (shared by the
/// plain and the isotropic model).
pub(crate) fn tile_warnings(total_tiles: u64) -> Vec<TopoWarning> {
    if total_tiles < 2 {
        vec![TopoWarning::StdErrNotEstimable { tiles: total_tiles }]
    } else if total_tiles < MIN_TILES {
        vec![TopoWarning::FewTiles { tiles: total_tiles }]
    } else {
        Vec::new()
    }
}

/// Options of the topographic model.
#[derive(Debug, Clone, PartialEq)]
pub struct TopoOptions {
    /// Clear-coat refractive index (real, ≥ 1; default 1.5).
    pub n: f64,
    /// Fresnel bookkeeping (default `exact-unpolarized`).
    pub transmission: Transmission,
    /// Ray weighting (default `physical`; `paper-printed` is the printed eq. 14).
    pub weighting: Weighting,
    /// Flake reflectance (default perfect conductor).
    pub flake: FlakeReflectance,
    /// Add the clear coat's own specular reflection (default off).
    pub clearcoat: bool,
    /// Side `k` of the least-squares window, pixels (odd, ≥ 3; default 5).
    pub window: usize,
}

impl Default for TopoOptions {
    fn default() -> Self {
        Self {
            n: 1.5,
            transmission: Transmission::ExactUnpolarized,
            weighting: Weighting::Physical,
            flake: FlakeReflectance::PerfectConductor,
            clearcoat: false,
            window: 5,
        }
    }
}

/// The topographic model with validated options.
#[derive(Debug, Clone, PartialEq)]
pub struct TopoModel {
    options: TopoOptions,
    block_um: f64,
    absorption: Option<PathAbsorption>,
    kernels: Kernels,
}

/// One incidence × one detector of a [`TopoResult`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopoPoint {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// The detector.
    pub cone: Cone,
    /// Fraction of the incident beam power collected (including the clear coat when it
    /// is on and seen).
    pub reflectance: f64,
    /// Standard error of `reflectance` from the spread between tiles; `None` when it
    /// cannot be estimated (fewer than 2 tiles, or no ray in this detector; module docs).
    pub reflectance_std_err: Option<f64>,
    /// BRDF averaged over the cone: `reflectance / (cos θj · π sin²α)`, sr⁻¹.
    pub brdf: f64,
    /// Standard error of `brdf`, sr⁻¹; `None` as for `reflectance_std_err`.
    pub brdf_std_err: Option<f64>,
    /// Number of rays counted in the detector.
    pub rays: u64,
    /// `reflectance` divided by that of a cone of the same aperture at the specular
    /// direction (`θs = −θi`), computed even when that detector is not in the list; NaN
    /// when the specular detector received nothing.
    pub relative: f64,
    /// The denominator of `relative`: the reflectance of a cone of the same aperture at
    /// the specular direction (`θs = −θi`).
    pub specular_reflectance: f64,
    /// Whether the clear coat's specular reflection was added.
    pub clearcoat_seen: bool,
}

/// What a run of the topographic model gives: one [`TopoPoint`] per incidence × detector
/// (ordered by incidence, then detector) and the totals.
#[derive(Debug, Clone, PartialEq)]
pub struct TopoResult {
    /// Rows, incidence-major.
    pub points: Vec<TopoPoint>,
    /// Number of maps accumulated.
    pub maps: usize,
    /// Pixels over all maps (the normalisation `N_pixels`).
    pub pixels: u64,
    /// Pixels with a normal (complete window of valid points), over all maps.
    pub usable_pixels: u64,
    /// Rays traced: usable pixels × incidences.
    pub rays_traced: u64,
    /// Rays lost to total internal reflection at the top surface.
    pub rays_lost_tir: u64,
    /// Rays lost because they head down after reflection (`k2.z ≤ 0`, including beams
    /// meeting the back of the local plane).
    pub rays_lost_down: u64,
    /// Statistics tiles over all maps.
    pub tiles: u64,
    /// Valid points of each map (measured and passing any intensity cutoff), maps in
    /// order.
    pub valid_pixels: Vec<u64>,
    /// Tile side, µm.
    pub block_um: f64,
    /// Cautions about the uncertainties (empty when none).
    pub warnings: Vec<TopoWarning>,
}

impl TopoResult {
    /// Usable pixels as a fraction of all pixels.
    #[must_use]
    pub fn usable_fraction(&self) -> f64 {
        self.usable_pixels as f64 / self.pixels as f64
    }
}

impl TopoModel {
    /// A model with `options`.
    ///
    /// # Errors
    /// [`TopoError::Index`] for an index that is not a finite real ≥ 1,
    /// [`TopoError::FlakeIndex`] for an invalid complex flake index,
    /// [`TopoError::Window`] for an even window or one below 3,
    /// [`TopoError::SimdSwitch`] when the environment variable `FLAKESCATTER_SIMD` holds
    /// a value other than `auto` or `portable` ([`Kernels::from_env`]).
    pub fn new(options: TopoOptions) -> Result<Self, TopoError> {
        flakescatter_optics::check_index(options.n).map_err(TopoError::Index)?;
        if let FlakeReflectance::Complex { n, k } = options.flake {
            FlakeReflectance::complex(n, k).map_err(TopoError::FlakeIndex)?;
        }
        if options.window < 3 || options.window.is_multiple_of(2) {
            return Err(TopoError::Window(options.window));
        }
        Ok(Self {
            options,
            block_um: DEFAULT_BLOCK_UM,
            absorption: None,
            kernels: Kernels::from_env().map_err(|e| TopoError::SimdSwitch(e.0))?,
        })
    }

    /// The same model running `kernels`: [`Kernels::Portable`] forces the portable
    /// code, whatever `FLAKESCATTER_SIMD` says (the results are the same bits either
    /// way; the crate docs, "Instruction sets").
    #[must_use]
    pub fn with_kernels(mut self, kernels: Kernels) -> Self {
        self.kernels = kernels;
        self
    }

    /// The kernels the model runs.
    #[must_use]
    pub fn kernels(&self) -> Kernels {
        self.kernels
    }

    /// The same model with the binder absorbing along each ray's path inside the film
    /// (physics.md §8.1). The isotropic average refuses a model with absorption.
    #[must_use]
    pub fn with_absorption(mut self, absorption: PathAbsorption) -> Self {
        self.absorption = Some(absorption);
        self
    }

    /// The binder absorption, if any.
    #[must_use]
    pub fn absorption(&self) -> Option<&PathAbsorption> {
        self.absorption.as_ref()
    }

    /// The same model with statistics tiles of side `block_um` µm.
    ///
    /// # Errors
    /// [`TopoError::BlockSize`] unless `block_um` is finite and positive.
    pub fn with_block_um(mut self, block_um: f64) -> Result<Self, TopoError> {
        if !(block_um.is_finite() && block_um > 0.0) {
            return Err(TopoError::BlockSize(block_um));
        }
        self.block_um = block_um;
        Ok(self)
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &TopoOptions {
        &self.options
    }

    /// Side of the statistics tiles, µm.
    #[must_use]
    pub fn block_um(&self) -> f64 {
        self.block_um
    }

    /// Local normals of one map (module [`crate::normals`]): `None` where any point of
    /// the `k × k` window is invalid or outside the map. O(k) additions per pixel.
    ///
    /// # Errors
    /// [`TopoError::WindowTooLarge`] when the window does not fit in the map.
    pub fn normals(&self, map: &HeightMap) -> Result<Normals, TopoError> {
        let k = self.options.window;
        if k > map.nx() || k > map.ny() {
            return Err(TopoError::WindowTooLarge {
                window: k,
                map: 0,
                nx: map.nx(),
                ny: map.ny(),
            });
        }
        // The tiles are row-major, so the tiles of one band of rows are consecutive and
        // write only that band's rows: each band fills its own slice of the output in
        // place (no per-pixel records gathered and copied afterwards). The tiles, and so
        // the window sums and their rounding, are those of `run`.
        let tiles = self.tiles(map);
        let nx = map.nx();
        let band_rows = tiles.first().map_or(map.ny(), |t| t.r1 - t.r0);
        let bands: Vec<&[Rect]> = tiles.chunk_by(|a, b| a.r0 == b.r0).collect();
        // Zeroed memory comes from the allocator untouched; each band writes its pages,
        // each pixel once: the tiles write every pixel whose window lies inside the map
        // (its slopes, or NaN), the band its pixels within `h` of the map's edge (NaN).
        let (ny, h, kernels) = (map.ny(), k / 2, self.kernels);
        let mut slopes = vec![[0.0_f64; 2]; nx * ny];
        let usable: usize = slopes
            .par_chunks_mut(band_rows * nx)
            .zip(bands.par_iter())
            .map_init(Scratch::default, |scratch, (band, band_tiles)| {
                let r0 = band_tiles[0].r0;
                for (i, row) in band.chunks_mut(nx).enumerate() {
                    if r0 + i < h || r0 + i >= ny - h {
                        row.fill([f64::NAN; 2]);
                    } else {
                        row[..h].fill([f64::NAN; 2]);
                        row[nx - h..].fill([f64::NAN; 2]);
                    }
                }
                let mut usable = 0;
                for &rect in *band_tiles {
                    usable += tile_slopes::<true>(map, h, rect, scratch, kernels, |r, c, a, b| {
                        band[(r - r0) * nx + c] = [a, b];
                    });
                }
                usable
            })
            .sum();
        let normals = Normals::from_slopes(map.nx(), map.ny(), k, slopes, usable);
        Ok(normals)
    }

    /// Traces every map at every incidence `theta_i` (radians, `[0, π/2)`) into every
    /// detector of `cones`, accumulating all maps into one result. The maps' validity
    /// masks must already include any intensity cutoff.
    ///
    /// # Errors
    /// [`TopoError::Empty`] for an empty list, [`TopoError::Incidence`] for an angle out
    /// of range, [`TopoError::PointDetector`] for a cone of aperture 0,
    /// [`TopoError::WindowTooLarge`] / [`TopoError::NoValidPixels`] for a map that cannot
    /// be used, [`TopoError::NoUsablePixels`] when no pixel of any map has a complete
    /// window.
    pub fn run(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
    ) -> Result<TopoResult, TopoError> {
        self.run_with_progress(maps, theta_i, cones, &|_, _| {})
    }

    /// As [`TopoModel::run`], calling `progress(done, total)` (in tiles) after each batch
    /// of tiles, from the calling thread, never from inside a parallel section: `done`
    /// counts the tiles reduced so far, one batch behind the tracing (0 at the first
    /// call), and the last call has `done == total`. The library itself never prints.
    ///
    /// # Errors
    /// As [`TopoModel::run`].
    pub fn run_with_progress(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<TopoResult, TopoError> {
        let acc = self.accumulate(maps, theta_i, cones, progress, &Scalar)?;
        Ok(self.result_of(acc, theta_i, cones))
    }

    /// As [`TopoModel::run_with_progress`] over maps read band by band from `sources`
    /// (module docs, "Streaming"): the same numbers, bit for bit, as the maps in
    /// memory, holding about one band of each map at a time.
    ///
    /// # Errors
    /// As [`TopoModel::run`]; [`TopoError::NoValidPixels`] once a map has been traced
    /// and held no valid point; [`TopoError::Source`] when a source cannot give a band.
    pub fn run_sources(
        &self,
        sources: &[&dyn HeightSource],
        theta_i: &[f64],
        cones: &[Cone],
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<TopoResult, TopoError> {
        let acc = self.accumulate_sources(sources, theta_i, cones, progress, &Scalar)?;
        Ok(self.result_of(acc, theta_i, cones))
    }

    /// The rows of a run from its accumulated sums.
    pub(crate) fn result_of(
        &self,
        acc: tiles::Accumulated,
        theta_i: &[f64],
        cones: &[Cone],
    ) -> TopoResult {
        let (inv_n, ndet, all, apertures) = (acc.inv_n, acc.ndet, &acc.all, &acc.apertures);
        let ncones = cones.len();
        let mut points = Vec::with_capacity(theta_i.len() * ncones);
        for (ii, &ti) in theta_i.iter().enumerate() {
            let specular = detector::specular_direction(ti);
            let cc = self
                .options
                .transmission
                .clearcoat_reflectance(&acc.incs[ii].entry);
            let value = |d: usize| {
                let s = ii * ndet + d;
                let seen_cc = self.options.clearcoat && all[d].contains(&specular);
                let rho = acc.sum[s] * inv_n + if seen_cc { cc } else { 0.0 };
                // A detector without rays has no spread either (module docs).
                let se = acc
                    .se_factor
                    .filter(|_| acc.rays[s] > 0)
                    .map(|f| (f * acc.m2[s]).sqrt() * inv_n);
                (rho, se, seen_cc)
            };
            for (j, cone) in cones.iter().enumerate() {
                let (rho, se, seen_cc) = value(j);
                let (spec, _, _) =
                    value(ncones + ii * apertures.len() + aperture_index(apertures, cone));
                let proj = cone.projected_solid_angle();
                points.push(TopoPoint {
                    theta_i: ti,
                    cone: *cone,
                    reflectance: rho,
                    reflectance_std_err: se,
                    brdf: rho / proj,
                    brdf_std_err: se.map(|e| e / proj),
                    rays: acc.rays[ii * ndet + j],
                    relative: if spec > 0.0 { rho / spec } else { f64::NAN },
                    specular_reflectance: spec,
                    clearcoat_seen: seen_cc,
                });
            }
        }
        TopoResult {
            points,
            ..acc.totals
        }
    }
}

/// Position of `cone`'s aperture among `apertures` (0 if absent, which cannot happen
/// for the cones the apertures were collected from).
pub(crate) fn aperture_index(apertures: &[f64], cone: &Cone) -> usize {
    apertures
        .iter()
        .position(|&a| a == cone.half_angle())
        .unwrap_or(0)
}
