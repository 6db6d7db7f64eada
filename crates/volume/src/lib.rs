//! A three-dimensional flake layer with multiple scattering (`docs/physics.md`,
//! "Volume model").
//!
//! Both of the paper's models follow one reflection per ray. This crate places thin
//! circular flakes in a film of real index `n` under a smooth top interface and follows
//! every ray until it escapes or is absorbed, so that shadowing, flake-to-flake
//! reflections and light trapped by the film are in the answer.
//!
//! # Geometry
//! * Radians and micrometres. Right-handed frame, `z` the film normal pointing into the
//!   air, the source on the `−x` side (`flakescatter_optics` conventions).
//! * The film occupies `−film ≤ z ≤ 0`; its top interface `z = 0` is flat and smooth.
//!   The substrate at `z = −film` is black by default, or a mirror, or a Lambertian
//!   reflector of reflectance `R` ([`Substrate`]).
//! * The tile `[0, L)²` is periodic: a ray leaving one side re-enters on the opposite
//!   side; flakes cut by a side continue on the other.
//! * Flakes are solid thin cylinders ([`Flake`]): diameter fixed or log-normal
//!   (truncated to `[mean/4, 3 mean]`, [`Diameter`]), thickness `t`, normals drawn from
//!   a `flakescatter_stats` [`Orientation`](flakescatter_stats::Orientation)
//!   (area-weighted, independent of diameter). The amount is a volume fraction, a mass
//!   loading (aluminium 2.70 g/cm³, binder density given; conversion in [`Amount`]) or
//!   a count. Centre depths are uniform over the film, uniform in `[A, B]`, or follow
//!   a piecewise-constant profile ([`Depth`]), always restricted per flake so that the
//!   flake lies wholly inside the film. A flake taller than the film at its tilt keeps
//!   its normal and gets a diameter that fits; one the depth rule cannot put inside the
//!   film goes to the nearest depth that is (module [`inside`], counted in
//!   [`LayerStats`]); only a film or depth rule that cannot hold a typical flake is
//!   an error ([`VolumeError::DepthRange`]).
//! * No interpenetration: random sequential addition with an exact (GJK) cylinder
//!   overlap test and a bounded number of position attempts per flake (module
//!   [`layer`]); too high a loading is an error ([`VolumeError::LoadingTooHigh`]).
//!
//! # Rays
//! * A collimated beam over the whole tile: entry points uniform on the tile, the
//!   refracted direction from Snell's law. The first-surface reflection
//!   `R_av(θi) = ½(Rs + Rp)` is the `coat` part, added exactly.
//! * Polarisation: the ray carries two weights, an s and a p channel, starting at
//!   `½ Ts(θi)` and `½ Tp(θi)`; every interaction multiplies each channel by its own
//!   Fresnel power coefficient **in that interaction's local plane of incidence**. This
//!   is exact when every interaction of a path shares one plane of incidence (flat
//!   flakes, in-plane paths), and reduces to the distribution model's
//!   `exact-unpolarized` factor for single reflections; otherwise it neglects the
//!   rotation of the s/p frame between interactions (a Mueller treatment is the exact
//!   extension). Diffuse events (Lambertian substrate, diffuse rims) depolarise: both
//!   channels leave with the mean weight.
//! * Flake faces (both faces of every flake) reflect specularly with the perfect
//!   conductor's `|r|² = 1` or the complex-index Fresnel reflectances of
//!   `flakescatter_optics::flake` at the local angle; the rest is `absorbed_flakes`.
//!   A free interference (thin-film stack) flake also transmits: its faces reflect `R`,
//!   absorb `A` (`absorbed_flakes`) and pass `T` on through the flake along the same
//!   line (lateral shift 0); reflection or transmission is chosen by one draw of the
//!   ray's generator with weights that keep the estimate unbiased and the ray's weight
//!   whole (`trace` module `stack`, physics.md §10). A stack on an opaque core reflects
//!   like a metal: its transmitted share is absorbed by the core.
//! * Rims: [`RimRule`] — absorb (the default), ignore (transparent), or diffuse.
//! * A tinted binder ([`TraceOptions::binder_alpha_per_um`] `α > 0`) takes
//!   `1 − exp(−α ℓ)` of the weight over every stretch `ℓ` of path inside the binder
//!   (Beer–Lambert; the stretch a ray runs through a free stack flake is not binder),
//!   tallied as `absorbed_binder`. With `α = 0` (the default) nothing is computed.
//! * At the top interface from inside, Fresnel splits each channel into an escaping part
//!   (tallied into the detectors, then gone) and an internally reflected part that the
//!   path continues with (all of it beyond the critical angle, total internal
//!   reflection). No branching and no Russian roulette: one path per ray with exact
//!   weights (the one random choice, at a free stack flake's face, is weighted). A path ends when absorbed (black substrate, rim), when its weight falls
//!   below `min_weight`, or after `max_events` interactions; what is left then is
//!   `cut_off`, part of `absorbed_other`, so the energy balance sums to 1.
//!
//! # Tallies
//! Escapes are counted into detector cones (`flakescatter_optics::detector::Cone`,
//! half-angle `α`, signed in-plane `θs` or out-of-plane `(θr, φr)`) as fractions of the
//! incident power and as BRDF averaged over the cone (sr⁻¹), split by history:
//! `coat` (first surface), `single_bounce` (exactly one flake-face reflection and
//! nothing else, no internal reflection) and `multiple_bounce` (every other escaping
//! history: two or more interactions, or any internal reflection at the top). The
//! energy balance ([`EnergyBalance`]) gives `coat_reflected`, `escaped_single`,
//! `escaped_multiple`, `absorbed_substrate`, `absorbed_flakes`, `absorbed_binder` and
//! `absorbed_other` (`absorbed_rims + cut_off`), summing to 1. One layer's standard errors come from 64
//! fixed batches of rays (module [`trace`]); every ray has its own generator
//! (Xoshiro256++ from the seed and the ray's index), so a ray is the same whichever
//! thread traces it, and results are bit-identical for any thread count. Those errors
//! leave out the scatter between layers, which dominates cones fed by few flakes:
//! [`run_layers`] traces several independent layers of one seed and states the standard
//! error of their mean, split into its ray and between-layer parts, with Student's t
//! intervals (module [`layers`]); [`run_layers_each`] traces the same layers with
//! several option sets (one per wavelength of a spectrum, same seed: common random
//! numbers).
//!
//! # Acceleration
//! A periodic uniform grid of columns (module [`grid`]): the film is a thin slab, so a
//! segment crosses few columns, and wrapping is index arithmetic.
//!
//! # Example
//! A dilute layer of flat 8 µm flakes: the coat reflection is exact, and the light the
//! flakes return into the specular cone is close to their coverage times `T(0)²`:
//! ```
//! use flakescatter_optics::detector::Cone;
//! use flakescatter_stats::Orientation;
//! use flakescatter_volume::{Amount, Depth, Diameter, Layer, LayerParams, LayerSpec, TraceOptions, Tracer};
//!
//! let mut spec = LayerSpec::new(Orientation::flat(), 200.0, 7);
//! spec.diameter = Diameter::Fixed(8.0);
//! spec.amount = Amount::Count(50);
//! spec.depth = Depth::Uniform { top_um: 2.0, bottom_um: 3.0 };
//! let layer = Layer::generate(&LayerParams::new(spec)?)?;
//! let tracer = Tracer::new(&layer, TraceOptions { rays: 20_000, ..TraceOptions::default() })?;
//! let cone = Cone::in_plane(0.0, 2f64.to_radians())?;
//! let result = tracer.run(&[0.0], &[cone])?;
//! let e = &result.energy[0];
//! assert!((e.coat_reflected - 0.04).abs() < 1e-12); // ((n − 1)/(n + 1))² at n = 1.5
//! assert!((e.total() - 1.0).abs() < 1e-12);
//! let c = layer.stats().projected_coverage;
//! assert!((e.escaped_single - c * 0.96 * 0.96).abs() < 0.1 * c);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod grid;
pub mod inside;
pub mod layer;
pub mod layers;
pub mod params;
pub mod trace;

pub use flakescatter_numerics::simd::Kernels;
pub use layer::{Flake, Layer, LayerStats};
pub use layers::{
    LayeredError, LayeredPoint, LayeredResult, MAX_LAYERS, run_layers, run_layers_each,
};
pub use params::{
    ALUMINIUM_DENSITY_G_CM3, Amount, Depth, Diameter, LayerParams, LayerSpec,
    TYPICAL_BINDER_DENSITY_G_CM3,
};
pub use trace::{
    BATCHES, EnergyBalance, RimRule, Substrate, TraceOptions, Tracer, VolumePoint, VolumeResult,
};

/// Errors of the volume model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VolumeError {
    /// A parameter outside its range.
    #[error("{name} = {value}: expected {expected}")]
    Parameter {
        /// The parameter's name (as the command line spells it, with underscores).
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
    /// The tile cannot hold a flake without it touching its own periodic image.
    #[error(
        "tile_um = {tile_um} is too small: the largest flake spans {flake_extent_um} µm (diameter + thickness); the tile must be larger"
    )]
    TileTooSmall {
        /// Tile side, µm.
        tile_um: f64,
        /// Largest flake diameter plus thickness, µm.
        flake_extent_um: f64,
    },
    /// Not even a flat flake fits in the film.
    #[error("film_um = {film_um} is too thin for flakes {needed_um} µm thick")]
    FilmTooThin {
        /// Film thickness, µm.
        film_um: f64,
        /// Flake thickness, µm.
        needed_um: f64,
    },
    /// A flake could not be placed.
    #[error(
        "loading too high: flake {placed} found no free position in {attempts} attempts (placed {placed} flakes, volume fraction {volume_fraction:.4}); lower the loading, thicken the film or widen the depth range"
    )]
    LoadingTooHigh {
        /// Flakes placed before the failure.
        placed: usize,
        /// Volume fraction reached.
        volume_fraction: f64,
        /// Attempts allowed per flake.
        attempts: u32,
    },
    /// The film or the depth rule cannot hold a typical flake: the median diameter at
    /// the median tilt (module [`inside`]; flakes beyond it are resized or moved).
    #[error(
        "depth_um: a typical flake (the median diameter {diameter_um:.4} µm at the median tilt {tilt:.4} rad) needs its centre between {min_depth_um:.4} and {max_depth_um:.4} µm deep to lie inside the film, which {reason} it"
    )]
    DepthRange {
        /// The median diameter, µm.
        diameter_um: f64,
        /// The median tilt, radians.
        tilt: f64,
        /// Shallowest centre depth inside the film, µm.
        min_depth_um: f64,
        /// Deepest centre depth inside the film, µm.
        max_depth_um: f64,
        /// What cannot hold it.
        reason: &'static str,
    },
    /// The amount asks for too many flakes.
    #[error(
        "the loading asks for about {requested:.3e} flakes, more than the {max} allowed; use a smaller tile"
    )]
    TooManyFlakes {
        /// Flakes the amount implies (estimate).
        requested: f64,
        /// The limit.
        max: usize,
    },
    /// A flake given to [`Layer::from_flakes`] is not valid.
    #[error("flake {index}: {reason}")]
    BadFlake {
        /// Index of the flake.
        index: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// Two given flakes overlap.
    #[error("flakes {first} and {second} overlap")]
    Overlap {
        /// The earlier flake.
        first: usize,
        /// The later flake.
        second: usize,
    },
    /// The complex flake index is not valid.
    #[error("flake index: {0}")]
    FlakeIndex(flakescatter_optics::OpticsError),
    /// A detector could not be built.
    #[error("detector: {0}")]
    Detector(flakescatter_optics::OpticsError),
    /// Incidence angle outside `[0, π/2)`.
    #[error("incidence angle {0} rad is out of range: expected [0, pi/2)")]
    Incidence(f64),
    /// A cone of aperture 0, which rays cannot enter.
    #[error("detector {0} has aperture 0: rays are counted into cones, the aperture must be > 0")]
    PointDetector(usize),
    /// Nothing to compute.
    #[error("{0} list is empty")]
    Empty(&'static str),
    /// A geometric query failed (should not happen).
    #[error("geometry: {0}")]
    Geometry(String),
    /// The environment variable `FLAKESCATTER_SIMD` holds a value other than `auto` or
    /// `portable` ([`Kernels::from_env`]); the value, lossily decoded.
    #[error(
        "environment variable FLAKESCATTER_SIMD={0:?} is not valid: expected `auto` (or unset) for the processor's best instruction set, or `portable` for the portable code"
    )]
    SimdSwitch(String),
}
