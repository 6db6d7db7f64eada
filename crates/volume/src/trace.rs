//! Rays through the flake layer, tallied into detector cones and an energy balance.
//!
//! Conventions: radians, µm, the frame and detector conventions of
//! `flakescatter_optics` (source on the `−x` side, signed in-plane `θs`, cones of
//! half-angle `α`). See the crate docs for the ray rules; this module implements them.
//!
//! # Estimators
//! For each incidence, `N` rays enter at points drawn uniformly over the tile; ray `r`
//! of incidence `i` draws its random numbers from its own generator, Xoshiro256++
//! started from the run's seed and the ray's index `i·N + r` (`ray_rng`), so every ray
//! is reproducible by itself. A ray carries one weight per
//! polarisation channel, starting at `½ Ts(θi)` and `½ Tp(θi)` (fractions of the
//! incident power `1/N` per ray). The clear coat's first-surface reflection
//! `R_av(θi) = ½(Rs + Rp)` is added exactly to each cone that contains the specular
//! direction. A detector's reflectance is `ρ = Σ w / N` over the escapes into its cone
//! and its cone-averaged BRDF `ρ / (cos θj π sin²α)` (sr⁻¹). The rays are cut into
//! [`BATCHES`] batches of equal size (ray `r` in batch `r / (N / BATCHES)`): with `s_b`
//! a batch's sum, `se(ρ) = sqrt(B/(B−1) Σ_b (s_b − s̄)²) / N`. The standard errors
//! are those of the ray sampling **for this layer**: the scatter between layers drawn
//! with other seeds is not included (run several seeds to see it).
//!
//! # Order of work
//! The rays of an incidence (in sweeps of at most 2²⁰) are traced in the order of
//! their entry points along a Z-order curve (`Run::sorted`), so that rays entering side
//! by side run one after another and find the grid columns and flakes their
//! neighbours loaded still in the cache; the order changes no ray. The sorted rays are
//! cut into chunks of 4096; the chunks of consecutive sweeps (several incidences when
//! each has few rays) are handed out to the threads one at a time; each ray adds to
//! its own batch's sums within its chunk, and the chunks are added into the batches in
//! chunk order, so results are bit-identical for any number of threads. A chunk's
//! rays run in the instruction-set build (SSE2, AVX2 or AVX-512 encodings) that
//! `pulp` picks for the processor; the arithmetic is the same operations in the same
//! order (no fused multiply–add), so the results do not depend on it.

use flakescatter_optics::detector::{
    self, Cone, distinct_apertures, orthonormal_frame, with_specular_cones,
};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::{UnitVec3, Vec3, refraction};
use rand::{Rng, RngExt, SeedableRng};
use rand_xoshiro::{SplitMix64, Xoshiro256PlusPlus};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

use rayon::prelude::*;

use crate::VolumeError;
use crate::grid::{FlakeGrid, Next, Surface};
use crate::layer::{Flake, Layer};

/// Number of batches the rays of one incidence are cut into for the standard errors.
pub const BATCHES: u64 = 64;

/// Default largest number of interactions (flake, rim, substrate, top interface) of one
/// path; the weight left when a path reaches it is tallied as `cut_off`.
pub const DEFAULT_MAX_EVENTS: u32 = 1000;

/// Default weight (fraction of the ray's incident power) below which a path ends; the
/// weight left is tallied as `cut_off`.
pub const DEFAULT_MIN_WEIGHT: f64 = 1e-6;

/// Largest number of rays per incidence.
pub const MAX_RAYS: u64 = 1 << 40;

/// What the substrate under the film does.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Substrate {
    /// Absorbs everything (the default).
    #[default]
    Black,
    /// A mirror of reflectance `R ∈ [0, 1]` for both polarisations.
    Specular(f64),
    /// A Lambertian (cosine-law) reflector of albedo `R ∈ [0, 1]`; it depolarises (both
    /// channels leave with the mean of the two incoming weights times `R`).
    Lambertian(f64),
}

/// What a flake's rim (side wall) does to a ray that meets it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RimRule {
    /// Absorbs the ray (the default): broken flake edges are not mirrors, and the
    /// absorbed share is reported (`absorbed_rims`) so its size is known.
    #[default]
    Absorb,
    /// Transparent: a ray that meets the rim passes through the flake unaffected.
    Ignore,
    /// Reflects diffusely (cosine law about the rim's outward normal) with the flake's
    /// unpolarised reflectance at normal incidence as albedo; depolarises.
    Diffuse,
}

impl RimRule {
    /// The command-line name (`absorb`, `ignore`, `diffuse`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Absorb => "absorb",
            Self::Ignore => "ignore",
            Self::Diffuse => "diffuse",
        }
    }
}

/// Options of the tracer.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceOptions {
    /// Film (binder) refractive index, real, ≥ 1 (default 1.5).
    pub n: f64,
    /// Flake reflectance (default perfect conductor).
    pub flake: FlakeReflectance,
    /// Substrate (default black).
    pub substrate: Substrate,
    /// Rim rule (default absorb).
    pub rims: RimRule,
    /// Rays per incidence, rounded up to a multiple of [`BATCHES`] (default 10⁶).
    pub rays: u64,
    /// Seed of the rays' random numbers (default 1).
    pub seed: u64,
    /// Largest number of interactions per path (default [`DEFAULT_MAX_EVENTS`]).
    pub max_events: u32,
    /// Weight below which a path ends (default [`DEFAULT_MIN_WEIGHT`]); 0 keeps paths
    /// until `max_events` or absorption.
    pub min_weight: f64,
}

impl Default for TraceOptions {
    fn default() -> Self {
        Self {
            n: 1.5,
            flake: FlakeReflectance::PerfectConductor,
            substrate: Substrate::Black,
            rims: RimRule::Absorb,
            rays: 1_000_000,
            seed: 1,
            max_events: DEFAULT_MAX_EVENTS,
            min_weight: DEFAULT_MIN_WEIGHT,
        }
    }
}

/// Fractions of the incident power at one incidence (estimates from the traced rays,
/// except `coat_reflected`, which is exact). The six named in the sum
/// `coat_reflected + escaped_single + escaped_multiple + absorbed_substrate +
/// absorbed_flakes + absorbed_other` add up to 1 (to rounding, about 1e-15).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyBalance {
    /// First-surface (clear coat) reflection `R_av(θi)`.
    pub coat_reflected: f64,
    /// Escaped after exactly one flake-face reflection and nothing else.
    pub escaped_single: f64,
    /// Escaped after any other history (two or more interactions, or an internal
    /// reflection at the top interface).
    pub escaped_multiple: f64,
    /// Absorbed by the substrate.
    pub absorbed_substrate: f64,
    /// Absorbed by flake faces (complex index; 0 for perfect conductors).
    pub absorbed_flakes: f64,
    /// `absorbed_rims + cut_off`.
    pub absorbed_other: f64,
    /// Absorbed at flake rims (the rim rule, including the `1 − albedo` of diffuse rims).
    pub absorbed_rims: f64,
    /// Weight left when paths were cut (events or weight limit, or a ray running
    /// parallel to the film over more than a few tile widths).
    pub cut_off: f64,
    /// Part of `escaped_multiple` whose path met the substrate (not in the sum).
    pub escaped_via_substrate: f64,
}

impl EnergyBalance {
    /// The sum of the six disjoint fractions (should be 1).
    #[must_use]
    pub fn total(&self) -> f64 {
        self.coat_reflected
            + self.escaped_single
            + self.escaped_multiple
            + self.absorbed_substrate
            + self.absorbed_flakes
            + self.absorbed_other
    }
}

/// One incidence × one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumePoint {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// The detector.
    pub cone: Cone,
    /// Total cone-averaged BRDF (coat + single + multiple), sr⁻¹.
    pub brdf: f64,
    /// Its standard error, sr⁻¹.
    pub brdf_std_err: f64,
    /// First-surface part, sr⁻¹ (exact).
    pub coat_brdf: f64,
    /// Single-bounce part, sr⁻¹.
    pub single_brdf: f64,
    /// Its standard error, sr⁻¹.
    pub single_std_err: f64,
    /// Multiple-bounce part, sr⁻¹.
    pub multiple_brdf: f64,
    /// Its standard error, sr⁻¹.
    pub multiple_std_err: f64,
    /// Total fraction of the incident power collected.
    pub reflectance: f64,
    /// Its standard error.
    pub reflectance_std_err: f64,
    /// `reflectance` over that of a cone of the same aperture at the specular direction
    /// (NaN when that is 0).
    pub relative: f64,
    /// The reflectance of that specular cone (the denominator of `relative`).
    pub specular_reflectance: f64,
    /// Escapes counted in the cone (rays, not weight).
    pub rays: u64,
}

/// A run's result.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeResult {
    /// Rows, incidence-major then detector.
    pub points: Vec<VolumePoint>,
    /// Energy balance per incidence (same order as the incidences).
    pub energy: Vec<EnergyBalance>,
    /// Standard errors of the energy balance (0 for `coat_reflected`).
    pub energy_std_err: Vec<EnergyBalance>,
    /// Rays traced per incidence (the request rounded up to a multiple of [`BATCHES`]).
    pub rays_per_incidence: u64,
    /// Straight segments traced (one per nearest-surface query), all incidences.
    pub segments: u64,
    /// The seed of the rays.
    pub seed: u64,
}

/// A layer ready to be traced: its flakes and column grid.
#[derive(Debug, Clone)]
pub struct Tracer<'a> {
    layer: &'a Layer,
    grid: FlakeGrid,
    options: TraceOptions,
    /// Which realisation's rays (module `layers`; 0 for a single layer).
    realisation: u64,
}

// Energy slots of a batch.
const E_SINGLE: usize = 0;
const E_MULTI: usize = 1;
const E_VIA_SUB: usize = 2;
const E_SUB: usize = 3;
const E_FLAKES: usize = 4;
const E_RIMS: usize = 5;
const E_CUT: usize = 6;
const E_SLOTS: usize = 7;

/// Sums of one batch (or of a batch's rays within one chunk).
struct Partial {
    /// `[single, multiple]` per internal detector.
    cones: Vec<[f64; 2]>,
    counts: Vec<u64>,
    energy: [f64; E_SLOTS],
    segments: u64,
}

impl Partial {
    fn new(ndet: usize) -> Self {
        Self {
            cones: vec![[0.0; 2]; ndet],
            counts: vec![0; ndet],
            energy: [0.0; E_SLOTS],
            segments: 0,
        }
    }

    /// Adds `other`'s sums to these.
    fn merge(&mut self, other: &Partial) {
        for (a, b) in self.cones.iter_mut().zip(&other.cones) {
            a[0] += b[0];
            a[1] += b[1];
        }
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        for (a, b) in self.energy.iter_mut().zip(other.energy) {
            *a += b;
        }
        self.segments += other.segments;
    }
}

/// Most rays whose entry points are sorted together (a sweep).
const SWEEP_RAYS: u64 = 1 << 20;

/// Rays per chunk of a sorted sweep (the unit of work handed to a thread).
const CHUNK_RAYS: usize = 4096;

/// One cone as the escape test needs it.
#[derive(Debug, Clone, Copy)]
struct ConeEntry {
    axis: [f64; 3],
    cos_alpha: f64,
    index: u32,
}

/// Cones listed by cells of `(k.x, k.y) ∈ [−1, 1]²`: a direction inside a cone of
/// half-angle `α` about `r` is within the chord `2 sin(α/2)` of `r`, so its `(x, y)`
/// lies within that distance of `(r.x, r.y)` in each component.
struct ConeCells {
    side: usize,
    inv_cell: f64,
    offsets: Vec<u32>,
    entries: Vec<ConeEntry>,
}

impl ConeCells {
    fn new(cones: &[Cone]) -> Self {
        let chord = |c: &Cone| 2.0 * (0.5 * c.half_angle()).sin();
        let min_chord = cones.iter().map(chord).fold(f64::INFINITY, f64::min);
        let side = ((2.0 / min_chord.max(2.0 / 512.0)).ceil() as usize).clamp(4, 512);
        let inv_cell = side as f64 / 2.0;
        let to_cell = |v: f64| (((v + 1.0) * inv_cell).floor().max(0.0) as usize).min(side - 1);
        let mut lists: Vec<Vec<ConeEntry>> = vec![Vec::new(); side * side];
        for (j, c) in cones.iter().enumerate() {
            let a = c.axis();
            let half = chord(c) * (1.0 + 1e-9) + 1e-12;
            let e = ConeEntry {
                axis: [a.x, a.y, a.z],
                cos_alpha: c.cos_half_angle(),
                index: j as u32,
            };
            for iy in to_cell(a.y - half)..=to_cell(a.y + half) {
                for ix in to_cell(a.x - half)..=to_cell(a.x + half) {
                    lists[iy * side + ix].push(e);
                }
            }
        }
        let mut offsets = vec![0u32];
        let mut entries = Vec::new();
        for l in lists {
            entries.extend(l);
            offsets.push(entries.len() as u32);
        }
        Self {
            side,
            inv_cell,
            offsets,
            entries,
        }
    }

    fn candidates(&self, x: f64, y: f64) -> &[ConeEntry] {
        let ix = (((x + 1.0) * self.inv_cell) as usize).min(self.side - 1);
        let iy = (((y + 1.0) * self.inv_cell) as usize).min(self.side - 1);
        let c = iy * self.side + ix;
        &self.entries[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }
}

/// Everything fixed during a run.
struct Run<'r> {
    flakes: &'r [Flake],
    grid: &'r FlakeGrid,
    options: &'r TraceOptions,
    cones: ConeCells,
    ndet: usize,
    film: f64,
    tile: f64,
    rays: u64,
    batch_rays: u64,
    max_cells: u64,
    /// The rays' key, from the seed (see [`ray_rng`]).
    key: [u64; 2],
}

impl<'a> Tracer<'a> {
    /// A tracer for `layer` with `options`; builds the column grid (columns about one mean
    /// flake diameter wide, the fastest of those measured with the benchmark).
    ///
    /// # Errors
    /// [`VolumeError::Parameter`] naming the invalid option (`n`,
    /// `substrate_reflectance`, `rays`, `max_events`, `min_weight`);
    /// [`VolumeError::FlakeIndex`] for an invalid complex flake index;
    /// [`VolumeError::TooManyFlakes`] for a layer of `2²⁴` flakes or more.
    pub fn new(layer: &'a Layer, options: TraceOptions) -> Result<Self, VolumeError> {
        let cell = if layer.mean_diameter_um() > 0.0 {
            layer.mean_diameter_um()
        } else {
            layer.tile_um()
        };
        Self::with_cell(layer, options, cell)
    }

    /// As [`Tracer::new`] with columns about `cell_um` wide (clamped to between
    /// `L/2048` and `L`), for measuring the grid.
    ///
    /// # Errors
    /// As [`Tracer::new`], and [`VolumeError::Parameter`] (`cell_um`) unless `cell_um`
    /// is finite and positive.
    pub fn with_cell(
        layer: &'a Layer,
        options: TraceOptions,
        cell_um: f64,
    ) -> Result<Self, VolumeError> {
        if !(cell_um.is_finite() && cell_um > 0.0) {
            return Err(VolumeError::Parameter {
                name: "cell_um",
                value: cell_um,
                expected: "a finite column width > 0 µm",
            });
        }
        Self::check(&options)?;
        // The grid keeps a flake's index in 24 bits.
        let flakes = layer.flakes().len();
        if flakes >= crate::grid::MAX_GRID_FLAKES {
            return Err(VolumeError::TooManyFlakes {
                requested: flakes as f64,
                max: crate::grid::MAX_GRID_FLAKES - 1,
            });
        }
        Ok(Self {
            layer,
            grid: FlakeGrid::new(layer.flakes(), layer.tile_um(), cell_um),
            options,
            realisation: 0,
        })
    }

    fn check(options: &TraceOptions) -> Result<(), VolumeError> {
        flakescatter_optics::check_index(options.n).map_err(|_| VolumeError::Parameter {
            name: "n",
            value: options.n,
            expected: "a finite real index >= 1",
        })?;
        if let FlakeReflectance::Complex { n, k } = options.flake {
            FlakeReflectance::complex(n, k).map_err(VolumeError::FlakeIndex)?;
        }
        if matches!(options.flake, FlakeReflectance::Stack(_)) {
            return Err(VolumeError::StackFlake);
        }
        if let Substrate::Specular(r) | Substrate::Lambertian(r) = options.substrate
            && !(r.is_finite() && (0.0..=1.0).contains(&r))
        {
            return Err(VolumeError::Parameter {
                name: "substrate_reflectance",
                value: r,
                expected: "a reflectance in [0, 1]",
            });
        }
        if options.rays == 0 || options.rays > MAX_RAYS {
            return Err(VolumeError::Parameter {
                name: "rays",
                value: options.rays as f64,
                expected: "between 1 and 2^40 rays per incidence",
            });
        }
        if options.max_events == 0 {
            return Err(VolumeError::Parameter {
                name: "max_events",
                value: 0.0,
                expected: "at least 1",
            });
        }
        if !(options.min_weight.is_finite() && (0.0..1.0).contains(&options.min_weight)) {
            return Err(VolumeError::Parameter {
                name: "min_weight",
                value: options.min_weight,
                expected: "a weight in [0, 1)",
            });
        }
        Ok(())
    }

    /// Bytes held by the layer's flakes and the column grid. For the paper's coating
    /// (16 µm flakes, columns one diameter wide) about 87 bytes per flake: 64 for the
    /// flake, the rest the grid's entries and offsets, so 87 MB for 10⁶ flakes (measured
    /// by the `volume` benchmark's setup).
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        self.layer.memory_bytes() + self.grid.memory_bytes()
    }

    /// The rays of realisation `k` of a layered run (module `layers`): their generators
    /// start from the key of `(seed, k)`, independent of those of other realisations;
    /// `k = 0` is a single layer's.
    #[must_use]
    pub(crate) fn with_realisation(mut self, k: u64) -> Self {
        self.realisation = k;
        self
    }

    /// Columns per side of the grid.
    #[must_use]
    pub fn grid_side(&self) -> usize {
        self.grid.side()
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &TraceOptions {
        &self.options
    }

    /// Traces every incidence `theta_i` (radians, `[0, π/2)`) into every cone.
    ///
    /// # Errors
    /// As [`Tracer::run_with_progress`].
    pub fn run(&self, theta_i: &[f64], cones: &[Cone]) -> Result<VolumeResult, VolumeError> {
        self.run_with_progress(theta_i, cones, &|_, _| {})
    }

    /// As [`Tracer::run`], calling `progress(done, total)` (in chunks of rays, over all
    /// incidences) from the calling thread as chunks finish.
    ///
    /// # Errors
    /// [`VolumeError::Empty`] for an empty list, [`VolumeError::Incidence`] for an angle
    /// outside `[0, π/2)`, [`VolumeError::PointDetector`] for a cone of aperture 0.
    pub fn run_with_progress(
        &self,
        theta_i: &[f64],
        cones: &[Cone],
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<VolumeResult, VolumeError> {
        if theta_i.is_empty() {
            return Err(VolumeError::Empty("incidence angle"));
        }
        if cones.is_empty() {
            return Err(VolumeError::Empty("detector"));
        }
        for &t in theta_i {
            if !(t.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&t)) {
                return Err(VolumeError::Incidence(t));
            }
        }
        if let Some(j) = cones.iter().position(|c| c.half_angle() <= 0.0) {
            return Err(VolumeError::PointDetector(j));
        }
        let n = self.options.n;
        // Internal detectors: the user's cones, then one specular cone per incidence and
        // distinct aperture (for `relative`).
        let apertures = distinct_apertures(cones);
        let all = with_specular_cones(cones, theta_i, &apertures).map_err(VolumeError::Detector)?;
        let batch_rays = self.options.rays.div_ceil(BATCHES);
        let rays = batch_rays * BATCHES;
        let g = self.grid.side() as u64;
        let run = Run {
            flakes: self.layer.flakes(),
            grid: &self.grid,
            options: &self.options,
            cones: ConeCells::new(&all),
            ndet: all.len(),
            film: self.layer.film_um(),
            tile: self.layer.tile_um(),
            rays,
            batch_rays,
            // A segment may wrap around the tile a few times; longer ones are cut.
            max_cells: 8 * g + 64,
            key: ray_key(self.options.seed, self.realisation),
        };
        let ni = theta_i.len();
        let nd = run.ndet;
        // Ordered reduction (Welford over batches) per incidence and slot.
        let mut acc: Vec<Acc> = (0..ni).map(|_| Acc::new(nd)).collect();
        let mut segments = 0u64;
        // Progress in chunks, over all incidences.
        let sweeps: Vec<(u64, u64)> = (0..rays.div_ceil(SWEEP_RAYS))
            .map(|s| (s * SWEEP_RAYS, ((s + 1) * SWEEP_RAYS).min(rays)))
            .collect();
        let chunks_in = |first: u64, end: u64| (end - first).div_ceil(CHUNK_RAYS as u64);
        let chunks_per_incidence: u64 = sweeps.iter().map(|&(a, b)| chunks_in(a, b)).sum();
        let total = chunks_per_incidence * ni as u64;
        let mut done = 0u64;
        // Every sweep of every incidence, in order; they are traced in rounds of
        // consecutive sweeps, enough for several chunks per thread (so that runs of many
        // incidences with few rays each keep every thread busy), at most 2²⁰ rays after
        // the first. Each round: its sweeps sorted, then all their chunks handed out
        // together and reduced in order. An incidence's batch sums (`totals`) are added
        // up in chunk order whatever the rounds, and go into its `Acc` when its last
        // chunk is in.
        let work: Vec<(usize, u64, u64)> = (0..ni)
            .flat_map(|ii| sweeps.iter().map(move |&(a, b)| (ii, a, b)))
            .collect();
        let enough = 8 * rayon::current_num_threads() as u64;
        let mut totals: Vec<Option<Vec<Partial>>> = (0..ni).map(|_| None).collect();
        let mut chunks_left: Vec<u64> = vec![chunks_per_incidence; ni];
        let mut k = 0;
        while k < work.len() {
            let (mut round_rays, mut round_chunks) = (0u64, 0u64);
            let mut end = k;
            while end < work.len()
                && (end == k || (round_chunks < enough && round_rays < SWEEP_RAYS))
            {
                round_rays += work[end].2 - work[end].1;
                round_chunks += chunks_in(work[end].1, work[end].2);
                end += 1;
            }
            let round = &work[k..end];
            let orders: Vec<Vec<u32>> = round
                .par_iter()
                .map(|&(ii, first, stop)| run.sorted(ii as u64, first, stop))
                .collect();
            // (sweep of the round, its chunk) per job.
            let jobs: Vec<(usize, usize)> = orders
                .iter()
                .enumerate()
                .flat_map(|(s, o)| (0..o.len().div_ceil(CHUNK_RAYS)).map(move |c| (s, c)))
                .collect();
            let chunk = |(s, c): (usize, usize)| {
                let o = &orders[s];
                &o[c * CHUNK_RAYS..o.len().min((c + 1) * CHUNK_RAYS)]
            };
            ordered_jobs(
                jobs.len(),
                |j| {
                    let (ii, first, _) = round[jobs[j].0];
                    run.chunk(theta_i[ii], ii as u64, first, chunk(jobs[j]))
                },
                |j, parts| {
                    let ii = round[jobs[j].0].0;
                    let t = totals[ii]
                        .get_or_insert_with(|| (0..BATCHES).map(|_| Partial::new(nd)).collect());
                    for (t, p) in t.iter_mut().zip(&parts) {
                        t.merge(p);
                    }
                    done += 1;
                    progress(done, total);
                    chunks_left[ii] -= 1;
                    if chunks_left[ii] == 0
                        && let Some(t) = totals[ii].take()
                    {
                        for t in &t {
                            acc[ii].add(t);
                            segments += t.segments;
                        }
                    }
                },
            );
            k = end;
        }
        debug_assert!(chunks_left.iter().all(|&c| c == 0));

        let nf = rays as f64;
        let b = BATCHES as f64;
        let se = |m2: f64| (b / (b - 1.0) * m2).max(0.0).sqrt() / nf;
        let mut points = Vec::with_capacity(ni * cones.len());
        let mut energy = Vec::with_capacity(ni);
        let mut energy_se = Vec::with_capacity(ni);
        for (ii, &ti) in theta_i.iter().enumerate() {
            let a = &acc[ii];
            let entry = fresnel::air_to_coating(ti, n);
            let coat = entry.r_av();
            let specular = detector::specular_direction(ti);
            let value = |d: usize| {
                let coat_seen = if all[d].contains(&specular) {
                    coat
                } else {
                    0.0
                };
                coat_seen + (a.sum[d][0] + a.sum[d][1]) / nf
            };
            for (j, cone) in cones.iter().enumerate() {
                let proj = cone.projected_solid_angle();
                let coat_seen = if cone.contains(&specular) { coat } else { 0.0 };
                let single = a.sum[j][0] / nf;
                let multiple = a.sum[j][1] / nf;
                let total = coat_seen + single + multiple;
                let ap = apertures
                    .iter()
                    .position(|&x| x == cone.half_angle())
                    .unwrap_or(0);
                let spec = value(cones.len() + ii * apertures.len() + ap);
                let total_se = se(a.m2[j][2]);
                points.push(VolumePoint {
                    theta_i: ti,
                    cone: *cone,
                    brdf: total / proj,
                    brdf_std_err: total_se / proj,
                    coat_brdf: coat_seen / proj,
                    single_brdf: single / proj,
                    single_std_err: se(a.m2[j][0]) / proj,
                    multiple_brdf: multiple / proj,
                    multiple_std_err: se(a.m2[j][1]) / proj,
                    reflectance: total,
                    reflectance_std_err: total_se,
                    relative: if spec > 0.0 { total / spec } else { f64::NAN },
                    specular_reflectance: spec,
                    rays: a.counts[j],
                });
            }
            let e = |k: usize| a.energy[k] / nf;
            let es = |k: usize| se(a.energy_m2[k]);
            energy.push(EnergyBalance {
                coat_reflected: coat,
                escaped_single: e(E_SINGLE),
                escaped_multiple: e(E_MULTI),
                absorbed_substrate: e(E_SUB),
                absorbed_flakes: e(E_FLAKES),
                absorbed_other: e(E_RIMS) + e(E_CUT),
                absorbed_rims: e(E_RIMS),
                cut_off: e(E_CUT),
                escaped_via_substrate: e(E_VIA_SUB),
            });
            energy_se.push(EnergyBalance {
                coat_reflected: 0.0,
                escaped_single: es(E_SINGLE),
                escaped_multiple: es(E_MULTI),
                absorbed_substrate: es(E_SUB),
                absorbed_flakes: es(E_FLAKES),
                absorbed_other: se(a.other_m2),
                absorbed_rims: es(E_RIMS),
                cut_off: es(E_CUT),
                escaped_via_substrate: es(E_VIA_SUB),
            });
        }
        Ok(VolumeResult {
            points,
            energy,
            energy_std_err: energy_se,
            rays_per_incidence: rays,
            segments,
            seed: self.options.seed,
        })
    }
}

/// One chunk's rays, handed to [`pulp::Arch::dispatch`] (a closure would be kept out of
/// line, without the target features).
struct ChunkRays<'a, 'r> {
    run: &'a Run<'r>,
    ii: u64,
    first: u64,
    order: &'a [u32],
    k1: &'a Vec3,
    entry: &'a FresnelPower,
    parts: &'a mut [Partial],
}

impl pulp::WithSimd for ChunkRays<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        self.run.chunk_rays(
            self.ii, self.first, self.order, self.k1, self.entry, self.parts,
        );
    }
}

/// Runs `work(0..n)` on the threads of the current rayon pool and hands each result to
/// `take` on the calling thread, in job order. Jobs are handed out one at a time from a
/// shared counter, so no thread waits for another until the last job; results that
/// come early are kept until their turn. Outside a rayon pool the calling thread only
/// reduces, and the pool's threads work; inside one (a caller's `install`) it is one
/// of them and works too, reducing between its jobs, so that it never waits on the
/// others while holding work they might need (a pool of one thread would otherwise
/// stall).
fn ordered_jobs<T: Send>(
    n: usize,
    work: impl Fn(usize) -> T + Sync,
    mut take: impl FnMut(usize, T),
) {
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(usize, T)>();
    let mut early: Vec<Option<T>> = (0..n).map(|_| None).collect();
    let mut reduced = 0usize;
    let mut keep = |j: usize, t: T| {
        early[j] = Some(t);
        while let Some(t) = early.get_mut(reduced).and_then(Option::take) {
            take(reduced, t);
            reduced += 1;
        }
    };
    let work_loop = |tx: &mpsc::Sender<(usize, T)>| loop {
        let j = next.fetch_add(1, Ordering::Relaxed);
        if j >= n || tx.send((j, work(j))).is_err() {
            break;
        }
    };
    let inside = rayon::current_thread_index().is_some();
    let helpers = rayon::current_num_threads() - usize::from(inside);
    rayon::in_place_scope(|s| {
        for _ in 0..helpers.min(n) {
            let tx = tx.clone();
            let work_loop = &work_loop;
            s.spawn(move |_| work_loop(&tx));
        }
        if inside {
            loop {
                let j = next.fetch_add(1, Ordering::Relaxed);
                if j >= n {
                    break;
                }
                keep(j, work(j));
                for (j, t) in rx.try_iter() {
                    keep(j, t);
                }
            }
        } else {
            drop(tx);
            // Ends when every helper has finished (a helper's panic then propagates
            // from the scope).
            for (j, t) in &rx {
                keep(j, t);
            }
        }
    });
    // What the helpers sent after this thread's last job (inside a pool).
    for (j, t) in rx.try_iter() {
        keep(j, t);
    }
    debug_assert_eq!(reduced, n);
}

/// Ordered accumulation over batches: sums and Welford `M2` of the batch sums.
struct Acc {
    seen: f64,
    sum: Vec<[f64; 2]>,
    /// `[single, multiple, total]`.
    mean: Vec<[f64; 3]>,
    m2: Vec<[f64; 3]>,
    counts: Vec<u64>,
    energy: [f64; E_SLOTS],
    energy_mean: [f64; E_SLOTS],
    energy_m2: [f64; E_SLOTS],
    other_mean: f64,
    other_m2: f64,
}

fn welford(mean: &mut f64, m2: &mut f64, v: f64, inv_seen: f64) {
    let delta = v - *mean;
    *mean += delta * inv_seen;
    *m2 += delta * (v - *mean);
}

impl Acc {
    fn new(nd: usize) -> Self {
        Self {
            seen: 0.0,
            sum: vec![[0.0; 2]; nd],
            mean: vec![[0.0; 3]; nd],
            m2: vec![[0.0; 3]; nd],
            counts: vec![0; nd],
            energy: [0.0; E_SLOTS],
            energy_mean: [0.0; E_SLOTS],
            energy_m2: [0.0; E_SLOTS],
            other_mean: 0.0,
            other_m2: 0.0,
        }
    }

    fn add(&mut self, p: &Partial) {
        self.seen += 1.0;
        let inv = 1.0 / self.seen;
        for d in 0..self.sum.len() {
            let [s, m] = p.cones[d];
            self.sum[d][0] += s;
            self.sum[d][1] += m;
            let (mean, m2) = (&mut self.mean[d], &mut self.m2[d]);
            for (k, v) in [s, m, s + m].into_iter().enumerate() {
                welford(&mut mean[k], &mut m2[k], v, inv);
            }
            self.counts[d] += p.counts[d];
        }
        for k in 0..E_SLOTS {
            self.energy[k] += p.energy[k];
            welford(
                &mut self.energy_mean[k],
                &mut self.energy_m2[k],
                p.energy[k],
                inv,
            );
        }
        welford(
            &mut self.other_mean,
            &mut self.other_m2,
            p.energy[E_RIMS] + p.energy[E_CUT],
            inv,
        );
    }
}

/// The two words every ray's generator starts from: SplitMix64 of the seed, the second
/// word XORed with SplitMix64's finaliser of the realisation `k` (a bijection with
/// `0 ↦ 0`, so realisation 0 is a single layer's key and distinct `k` give distinct
/// keys).
fn ray_key(seed: u64, k: u64) -> [u64; 2] {
    let mut sm = SplitMix64::seed_from_u64(seed);
    let mut z = k;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    [sm.next_u64(), sm.next_u64() ^ z]
}

/// The generator of the ray with index `stream` (`i·N + r`: incidence `i`, ray `r` of
/// `N`): Xoshiro256++ started from the state `(k₀ ⊕ s₀, k₁ ⊕ s₁, s₂, s₃)`, the key `k`
/// of the seed ([`ray_key`]) and `s` the first four outputs of SplitMix64 seeded with
/// `stream`. Each ray's numbers depend only on the seed and its index (any thread, any
/// order); distinct `(seed, stream)` give distinct states (SplitMix64's outputs are a
/// bijection of its seed); the period is `2²⁵⁶ − 1`.
fn ray_rng(key: [u64; 2], stream: u64) -> Xoshiro256PlusPlus {
    let mut sm = SplitMix64::seed_from_u64(stream);
    let words = [
        key[0] ^ sm.next_u64(),
        key[1] ^ sm.next_u64(),
        sm.next_u64(),
        sm.next_u64(),
    ];
    let mut bytes = [0u8; 32];
    for (b, w) in bytes.chunks_exact_mut(8).zip(words) {
        b.copy_from_slice(&w.to_le_bytes());
    }
    Xoshiro256PlusPlus::from_seed(bytes)
}

/// The bits of `v` moved to the even positions (bit `k` to bit `2k`): one coordinate of
/// a Morton index.
fn spread_bits(v: u32) -> u64 {
    let mut x = u64::from(v);
    x = (x | (x << 16)) & 0x0000_ffff_0000_ffff;
    x = (x | (x << 8)) & 0x00ff_00ff_00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333_3333_3333;
    x = (x | (x << 1)) & 0x5555_5555_5555_5555;
    x
}

/// `x` moved into `[0, l)` by whole tiles.
#[inline]
fn wrap(x: f64, l: f64) -> f64 {
    if (0.0..l).contains(&x) {
        return x;
    }
    let w = x - l * (x / l).floor();
    if (0.0..l).contains(&w) { w } else { 0.0 }
}

/// A cosine-law direction about the unit normal `nrm`.
fn cosine_direction(nrm: &Vec3, rng: &mut Xoshiro256PlusPlus) -> Vec3 {
    let u1: f64 = rng.random();
    let u2: f64 = rng.random();
    let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
    let rho = u1.sqrt();
    let z = (1.0 - u1).max(0.0).sqrt();
    let axis = UnitVec3::new_unchecked(*nrm);
    let (u, v) = orthonormal_frame(&axis);
    u.into_inner() * (rho * c) + v.into_inner() * (rho * s) + nrm * z
}

impl Run<'_> {
    /// The rays `first..end` of incidence number `ii` in the order they are traced, as
    /// offsets from `first`: sorted (stably, by counting) by the Z-order (Morton) index
    /// of the cell of their entry point in a `2^b × 2^b` grid over the tile, with
    /// `4^b` about the number of rays. Rays that enter side by side then run one after
    /// another and find the grid columns and flakes their neighbours loaded still in the
    /// cache (with independent random entry points in ray order each ray's first query
    /// waited on memory; on the paper's coating with 10⁵ flakes this order is about
    /// 1.4× faster). The order changes no ray, only the order of the sums.
    fn sorted(&self, ii: u64, first: u64, end: u64) -> Vec<u32> {
        let l = self.tile;
        let n = end - first;
        // Bits per axis: 4^b ≥ n (about one ray per cell), at most 2^20 cells.
        let mut b = 1u32;
        while b < 10 && (1u64 << (2 * b)) < n {
            b += 1;
        }
        let side = f64::from(1u32 << b);
        let codes: Vec<u32> = (first..end)
            .into_par_iter()
            .map(|q| {
                let (_, x, y) = self.ray_start(ii, q);
                let cell = |v: f64| ((v / l * side) as u32).min((1 << b) - 1);
                (spread_bits(cell(x)) | spread_bits(cell(y)) << 1) as u32
            })
            .collect();
        let mut starts = vec![0u32; (1 << (2 * b)) + 1];
        for &c in &codes {
            starts[c as usize + 1] += 1;
        }
        for c in 1..starts.len() {
            starts[c] += starts[c - 1];
        }
        let mut order = vec![0u32; codes.len()];
        for (q, &c) in codes.iter().enumerate() {
            order[starts[c as usize] as usize] = q as u32;
            starts[c as usize] += 1;
        }
        order
    }

    /// Ray `q` of incidence number `ii`: its generator (stream `ii·N + q`) after its
    /// first two numbers, and the entry point `(x, y)` they give (µm, uniform on
    /// `[0, L)²`).
    #[inline(always)]
    fn ray_start(&self, ii: u64, q: u64) -> (Xoshiro256PlusPlus, f64, f64) {
        let l = self.tile;
        let mut rng = ray_rng(self.key, ii * self.rays + q);
        let x = l * rng.random::<f64>();
        let y = l * rng.random::<f64>();
        (rng, x, y)
    }

    /// Traces the rays `first + o` for the offsets `o` of `order` (from [`Run::sorted`])
    /// of incidence number `ii` at angle `theta_i`, in that order; each ray adds to the
    /// sums of its batch (`q / batch_rays`).
    fn chunk(&self, theta_i: f64, ii: u64, first: u64, order: &[u32]) -> Vec<Partial> {
        let n = self.options.n;
        let k_in = detector::incident_direction(theta_i);
        let k1 = refraction::into_coating(&k_in, n).into_inner();
        let entry = fresnel::air_to_coating(theta_i, n);
        let mut parts: Vec<Partial> = (0..BATCHES).map(|_| Partial::new(self.ndet)).collect();
        pulp::Arch::new().dispatch(ChunkRays {
            run: self,
            ii,
            first,
            order,
            k1: &k1,
            entry: &entry,
            parts: &mut parts,
        });
        parts
    }

    /// The loop of [`Run::chunk`], inlined into the instruction-set build that
    /// [`pulp::Arch::dispatch`] chose (with what is inlined into it: the ray loop and
    /// the grid walk; a few small helpers of other crates stay out of line).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn chunk_rays(
        &self,
        ii: u64,
        first: u64,
        order: &[u32],
        k1: &Vec3,
        entry: &FresnelPower,
        parts: &mut [Partial],
    ) {
        for &o in order {
            let q = first + u64::from(o);
            let (mut rng, x, y) = self.ray_start(ii, q);
            let b = (q / self.batch_rays) as usize;
            self.ray(Vec3::new(x, y, 0.0), k1, entry, &mut rng, &mut parts[b]);
        }
    }

    /// One path from the entry point `pos` (on the top interface) until it has no
    /// weight left.
    #[inline(always)]
    fn ray(
        &self,
        mut pos: Vec3,
        k1: &Vec3,
        entry: &FresnelPower,
        rng: &mut Xoshiro256PlusPlus,
        p: &mut Partial,
    ) {
        let opts = self.options;
        let n = opts.n;
        let l = self.tile;
        let mut k = *k1;
        let (mut ws, mut wp) = (0.5 * entry.ts, 0.5 * entry.tp);
        let mut flake_hits = 0u32;
        let mut other_events = 0u32;
        let mut internal = false;
        let mut via_substrate = false;
        let mut events = 0u32;
        let mut last: Option<u32> = None;
        loop {
            let w = ws + wp;
            if w <= 0.0 {
                return;
            }
            if events >= opts.max_events || w < opts.min_weight || k.z.abs() < 1e-12 {
                p.energy[E_CUT] += w;
                return;
            }
            events += 1;
            p.segments += 1;
            let tau_max = if k.z > 0.0 {
                -pos.z / k.z
            } else {
                (-self.film - pos.z) / k.z
            };
            let next = self.grid.nearest(
                self.flakes,
                &pos,
                &k,
                tau_max,
                last,
                opts.rims == RimRule::Ignore,
                self.max_cells,
            );
            match next {
                Next::TooLong => {
                    p.energy[E_CUT] += w;
                    return;
                }
                Next::Boundary if k.z > 0.0 => {
                    // The top interface from inside: escape by Fresnel, the rest reflects.
                    pos += tau_max * k;
                    pos.z = 0.0;
                    let s2 = n * n * (k.x * k.x + k.y * k.y);
                    if s2 < 1.0 {
                        let out = Vec3::new(n * k.x, n * k.y, (1.0 - s2).sqrt());
                        let f = fresnel::power_from_cosines(out.z, k.z, n);
                        let esc = ws * f.ts + wp * f.tp;
                        let single = flake_hits == 1 && other_events == 0 && !internal;
                        self.tally(&out, esc, single, via_substrate, p);
                        ws *= f.rs;
                        wp *= f.rp;
                    }
                    internal = true;
                    k.z = -k.z;
                    last = None;
                }
                Next::Boundary => {
                    pos += tau_max * k;
                    pos.z = -self.film;
                    match opts.substrate {
                        Substrate::Black => {
                            p.energy[E_SUB] += w;
                            return;
                        }
                        Substrate::Specular(r) => {
                            p.energy[E_SUB] += w * (1.0 - r);
                            ws *= r;
                            wp *= r;
                            k.z = -k.z;
                        }
                        Substrate::Lambertian(r) => {
                            p.energy[E_SUB] += w * (1.0 - r);
                            ws = 0.5 * w * r;
                            wp = ws;
                            k = cosine_direction(&Vec3::z(), rng);
                        }
                    }
                    other_events += 1;
                    via_substrate = true;
                    last = None;
                }
                Next::Flake(h) => {
                    pos += h.tau * k;
                    last = Some(h.flake);
                    match h.surface {
                        Surface::Top | Surface::Bottom => {
                            let cos_iota = -k.dot(&h.normal);
                            let (rs, rp) = opts.flake.power(cos_iota, n);
                            p.energy[E_FLAKES] += ws * (1.0 - rs) + wp * (1.0 - rp);
                            ws *= rs;
                            wp *= rp;
                            k += 2.0 * cos_iota * h.normal;
                            // Keep the direction a unit vector against rounding drift.
                            k /= k.norm();
                            flake_hits += 1;
                        }
                        Surface::Rim => match opts.rims {
                            RimRule::Diffuse => {
                                let albedo = opts.flake.average(1.0, n);
                                p.energy[E_RIMS] += w * (1.0 - albedo);
                                ws = 0.5 * w * albedo;
                                wp = ws;
                                k = cosine_direction(&h.normal, rng);
                                other_events += 1;
                            }
                            RimRule::Absorb | RimRule::Ignore => {
                                p.energy[E_RIMS] += w;
                                return;
                            }
                        },
                    }
                }
            }
            // Back into the tile.
            pos.x = wrap(pos.x, l);
            pos.y = wrap(pos.y, l);
        }
    }

    /// Adds an escape with weight `w` along `out` to every cone that contains it.
    #[inline(always)]
    fn tally(&self, out: &Vec3, w: f64, single: bool, via_substrate: bool, p: &mut Partial) {
        let cat = usize::from(!single);
        p.energy[if single { E_SINGLE } else { E_MULTI }] += w;
        if via_substrate {
            p.energy[E_VIA_SUB] += w;
        }
        for e in self.cones.candidates(out.x, out.y) {
            if e.axis[0] * out.x + e.axis[1] * out.y + e.axis[2] * out.z > e.cos_alpha {
                let d = e.index as usize;
                p.cones[d][cat] += w;
                p.counts[d] += 1;
            }
        }
    }
}
