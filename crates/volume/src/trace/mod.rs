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
//! `flakescatter_numerics::simd` picks for the processor, or the portable build alone
//! with `FLAKESCATTER_SIMD=portable` ([`Tracer::with_kernels`]); the arithmetic is the
//! same operations in the same order (no fused multiply–add), so the results do not
//! depend on it.

//!
//! # Where things are
//! This file holds the public API (options, results, [`Tracer`]) and the checks of a
//! run; `ray` the physics of one path and the tally of its escapes; `schedule` the
//! sweeps, chunks and threads; `reduce` the ordered reduction of the batch sums and the
//! values formed from it; `stack` the faces of interference flakes (reflection and
//! transmission); `binder` the binder's absorption along each segment.

mod binder;
mod ray;
mod reduce;
mod schedule;
mod stack;

use flakescatter_optics::detector::{Cone, distinct_apertures, with_specular_cones};
use flakescatter_optics::flake::FlakeReflectance;

use crate::VolumeError;
use crate::grid::FlakeGrid;
use crate::layer::Layer;
use flakescatter_numerics::cone_grid::{self, ConeGrid};
use flakescatter_numerics::simd::Kernels;
use ray::{Run, ray_key, spec};

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
    /// Napierian absorption coefficient of the binder for intensity, µm⁻¹ (default 0, a
    /// clear binder): every stretch of path `ℓ` inside the binder multiplies both
    /// channels by `exp(−α ℓ)` (Beer–Lambert; module `binder`), the rest tallied as
    /// `absorbed_binder`. With 0 nothing is computed and every ray is as without it.
    pub binder_alpha_per_um: f64,
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
            binder_alpha_per_um: 0.0,
        }
    }
}

/// Fractions of the incident power at one incidence (estimates from the traced rays,
/// except `coat_reflected`, which is exact). The seven named in the sum
/// `coat_reflected + escaped_single + escaped_multiple + absorbed_substrate +
/// absorbed_flakes + absorbed_binder + absorbed_other` add up to 1 (to rounding, about
/// 1e-15).
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
    /// Absorbed by the binder along the paths inside the film (0 for a clear binder,
    /// [`TraceOptions::binder_alpha_per_um`] = 0).
    pub absorbed_binder: f64,
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
    /// The sum of the seven disjoint fractions (should be 1). `absorbed_binder` is
    /// added last, so that with a clear binder (0) the sum is the same bits as without
    /// the term.
    #[must_use]
    pub fn total(&self) -> f64 {
        self.coat_reflected
            + self.escaped_single
            + self.escaped_multiple
            + self.absorbed_substrate
            + self.absorbed_flakes
            + self.absorbed_other
            + self.absorbed_binder
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
    /// The kernels the rays run with.
    kernels: Kernels,
}

impl<'a> Tracer<'a> {
    /// A tracer for `layer` with `options`; builds the column grid (columns about one mean
    /// flake diameter wide, the fastest of those measured with the benchmark).
    ///
    /// # Errors
    /// [`VolumeError::Parameter`] naming the invalid option (`n`,
    /// `substrate_reflectance`, `rays`, `max_events`, `min_weight`,
    /// `binder_absorption`);
    /// [`VolumeError::FlakeIndex`] for an invalid complex flake index;
    /// [`VolumeError::TooManyFlakes`] for a layer of `2²⁴` flakes or more;
    /// [`VolumeError::SimdSwitch`] when the environment variable `FLAKESCATTER_SIMD`
    /// holds a value other than `auto` or `portable` ([`Kernels::from_env`]).
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
            kernels: Kernels::from_env().map_err(|e| VolumeError::SimdSwitch(e.0))?,
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
        let a = options.binder_alpha_per_um;
        if !(a.is_finite() && a >= 0.0) {
            return Err(VolumeError::Parameter {
                name: "binder_absorption",
                value: a,
                expected: "a finite absorption coefficient >= 0 per µm",
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

    /// The same tracer running `kernels`: [`Kernels::Portable`] forces the portable
    /// code, whatever `FLAKESCATTER_SIMD` says (the results are the same bits either
    /// way; module docs, "Order of work").
    #[must_use]
    pub fn with_kernels(mut self, kernels: Kernels) -> Self {
        self.kernels = kernels;
        self
    }

    /// The kernels the rays run with.
    #[must_use]
    pub fn kernels(&self) -> Kernels {
        self.kernels
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
            cones: ConeGrid::new(
                &all.iter().map(spec).collect::<Vec<_>>(),
                0.0,
                cone_grid::FINE,
                1.0,
            ),
            ndet: all.len(),
            film: self.layer.film_um(),
            tile: self.layer.tile_um(),
            rays,
            batch_rays,
            // A segment may wrap around the tile a few times; longer ones are cut.
            max_cells: 8 * g + 64,
            key: ray_key(self.options.seed, self.realisation),
            kernels: self.kernels,
            stack: stack::StackFaces::of(&self.options.flake),
        };
        let (acc, segments) = run.trace(theta_i, progress);
        let (points, energy, energy_std_err) =
            reduce::results(&acc, theta_i, cones, &all, &apertures, n, rays);
        Ok(VolumeResult {
            points,
            energy,
            energy_std_err,
            rays_per_incidence: rays,
            segments,
            seed: self.options.seed,
        })
    }
}
