//! Ray tracing over height maps and counting into detector cones (physics.md §5, paper
//! eqs. 14 and 15).
//!
//! Conventions: angles in radians, lengths in micrometres, the frame and signed `θs` of
//! `flakescatter_optics`. Per usable pixel with local normal `m` and per incidence `θi`:
//!
//! 1. `k1` is the refracted beam (`k1.z = −cos θt < 0`), `γ = −k1·m`;
//!    `k2 = k1 + 2γ m` (paper eq. 1). Rays with `k2.z ≤ 0` (including `γ ≤ 0`, the beam
//!    meeting the back of the local plane) are lost "down"; rays with
//!    `n² (k2.x² + k2.y²) ≥ 1` are lost to total internal reflection.
//! 2. `k_out = (n k2.x, n k2.y, sqrt(1 − n²(k2.x² + k2.y²)))`.
//! 3. Weight, a fraction of the beam power (`physical`, the default):
//!    `w = F · γ / (m.z · cos θt) / N_pixels`, where `F` is the path factor of the ray
//!    (entry Fresnel at `θi`, flake reflectance at `cos ι = γ`, exit Fresnel from the
//!    cosines `k_out.z`, `k2.z`, no trigonometry): for `exact-unpolarized`, `s`, `p` the
//!    exact `m00`, `m00 ± m01` of the ray's Jones matrix
//!    ([`flakescatter_optics::jones`], physics.md §11), for `paper` the product of
//!    averages of [`Transmission::path_factor`]; and
//!    `N_pixels` counts every pixel of every map, valid or not (dark pixels are black
//!    substrate). `γ / m.z` is the pixel's flake area projected onto the beam per unit of
//!    map area; dividing by `cos θt` makes the beam's footprint the unit.
//!    `paper-printed` implements the printed eq. 14 literally,
//!    `I_j += (cos ϑ'_j / cos ϑ_j) T γ`, with `ϑ_j` the polar angle of detector `j`'s
//!    axis in air, `ϑ'_j` the matching inside angle (`sin ϑ_j = n sin ϑ'_j`), `T` the
//!    same Fresnel/flake factor `F` as above (with `--transmission paper` it is the
//!    paper's `T_av` at both crossings), and no `1/(m.z cos θt)`; it is also divided by
//!    `N_pixels`. It is **for shapes only**: it differs from the physical weight by
//!    `(cos ϑ'_j/cos ϑ_j) m.z cos θt` and does not conserve energy.
//! 4. The weight is added to every detector whose cone contains `k_out` (overlapping
//!    cones each count), found through a grid index over `(k_out.x, k_out.y)`.
//! 5. With the clear coat on, `R(θi)` ([`Transmission::clearcoat_reflectance`]) is added
//!    to every cone that contains the specular direction (physics.md §6).
//! 6. With binder absorption ([`TopoModel::with_absorption`], physics.md §8.1) each ray's
//!    contribution (scalar or Mueller) is multiplied by
//!    [`PathAbsorption::factor`]`(cos θt, k2.z)`; the flakes' depth is the absorption's
//!    depth model, not read from the map. Without it nothing is multiplied.
//!
//! On a map of flat flakes whose normals follow a distribution, the pixel normals are
//! projected-area weighted (density `D(m) m.z` per usable pixel), so the expected
//! reflectance is `coverage · ∫ D F γ / cos θt dΩm` over the cone: the distribution
//! model (physics.md §4) times the usable-pixel coverage.
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

use flakescatter_optics::absorption::PathAbsorption;
use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::jones::{self, PathAmplitudes, RayPath};
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_optics::{Vec3, refraction};
use flakescatter_stats::HeightMap;
use rayon::prelude::*;

use crate::TopoError;
use crate::index::{ConeIndex, LANES, Lanes, Portable};
use crate::normals::{Normals, Rect, Scratch, tile_slopes};

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

/// Tiles traced between two progress reports. Two batches' partial sums are held in
/// memory at once: one being reduced while the next is traced.
const BATCH: usize = 256;

/// Options of the topographic model.
#[derive(Debug, Clone, Copy, PartialEq)]
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

/// Per-incidence constants.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Inc {
    /// Incident direction in air, `(sin θi, 0, −cos θi)`.
    pub k_in: Vec3,
    /// Refracted direction `k1 = (k1x, 0, k1z)`, `k1z < 0`.
    pub k1x: f64,
    /// See `k1x`.
    pub k1z: f64,
    /// `cos θt = −k1z`.
    pub cos_t: f64,
    /// Fresnel powers of the entry crossing.
    pub entry: FresnelPower,
    /// Fresnel amplitudes `[rs, rp, ts, tp]` of the entry crossing.
    pub amplitudes: [f64; 4],
}

impl Inc {
    /// The constants of incidence `theta_i` (rad) on a coating of index `n`.
    fn new(theta_i: f64, n: f64) -> Self {
        let k_in = detector::incident_direction(theta_i);
        let k1 = refraction::into_coating(&k_in, n);
        Self {
            k_in: k_in.into_inner(),
            k1x: k1.x,
            k1z: k1.z,
            cos_t: -k1.z,
            entry: fresnel::air_to_coating(theta_i, n),
            amplitudes: fresnel::amplitudes_air_to_coating(theta_i, n),
        }
    }
}

/// One ray that leaves the coating, as the accumulators see it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ray {
    /// Unit flake normal `(m.x, m.y, m.z)` and `1/m.z`.
    pub m: [f64; 4],
    /// Obliquity `γ = −k1·m > 0`.
    pub gamma: f64,
    /// Inside direction after the flake, `k2.z > 0`.
    pub k2: Vec3,
    /// Exit direction in air.
    pub k_out: Vec3,
}

/// What a ray adds to the detectors it enters: `channels()` sums per detector.
/// `weigh` runs once per ray that enters at least one detector, `add` once per
/// detector entered, in a fixed order (the result does not depend on threads).
pub(crate) trait Accumulator: Sync {
    /// What `weigh` computes once per ray.
    type Weight;
    /// Sums per detector.
    fn channels(&self) -> usize;
    /// The ray's contribution before the detector's own factors.
    fn weigh(&self, options: &TopoOptions, inc: &Inc, ray: &Ray) -> Self::Weight;
    /// Adds `weight` to the `channels()` sums of detector `cone` (whose paper-printed
    /// factor is `scale`).
    fn add(&self, weight: &Self::Weight, ray: &Ray, cone: &Cone, scale: f64, sums: &mut [f64]);
    /// The weight as one number, for an accumulator of one channel (`channels() ==
    /// 1`) whose `add` is `sums[0] += weight · scale`; `None` for any other, which then
    /// always goes through `add`.
    #[inline(always)]
    fn plain(&self, _weight: &Self::Weight) -> Option<f64> {
        None
    }
    /// The weights of the rays that enter some cone into `out` (cleared first):
    /// `out[j]` is `weigh` of ray `hits[j].0` of `rays`, whose first `kept` rays are
    /// set (positions increasing, below `kept`). An accumulator may have a faster form
    /// with the same bits (the scalar model's vectorised loop).
    #[inline(always)]
    fn weigh_hits(
        &self,
        options: &TopoOptions,
        inc: &Inc,
        rays: &HitRays,
        _kept: usize,
        hits: &[(u16, u64)],
        out: &mut Vec<Self::Weight>,
    ) {
        out.clear();
        out.extend(
            hits.iter()
                .map(|&(k, _)| self.weigh(options, inc, &rays.get(usize::from(k)))),
        );
    }
}

/// The rays of one chunk of [`trace_chunk`] that may enter some detector, at one
/// incidence, field by field (a structure of arrays, so that a weight loop over them
/// runs in vector registers); slots are overwritten, never cleared.
#[derive(Debug, Default)]
pub(crate) struct HitRays {
    mx: Vec<f64>,
    my: Vec<f64>,
    mz: Vec<f64>,
    q: Vec<f64>,
    gamma: Vec<f64>,
    k2x: Vec<f64>,
    k2y: Vec<f64>,
    k2z: Vec<f64>,
    ox: Vec<f64>,
    oy: Vec<f64>,
    oz: Vec<f64>,
}

impl HitRays {
    /// Makes every field hold at least `len` rays (slots `0..len` may then be set and
    /// read). Each field's length is `len` plus a different odd number of cache lines,
    /// so that the fields of one ray do not all fall in the same cache set (with 512
    /// rays every field would be 4 KiB long, and ray `k`'s eleven fields eleven lines
    /// of one set); [`trace_chunk`] sizes them once, for [`RAY_CHUNK`] rays.
    fn fit(&mut self, len: usize) {
        for (f, v) in [
            &mut self.mx,
            &mut self.my,
            &mut self.mz,
            &mut self.q,
            &mut self.gamma,
            &mut self.k2x,
            &mut self.k2y,
            &mut self.k2z,
            &mut self.ox,
            &mut self.oy,
            &mut self.oz,
        ]
        .into_iter()
        .enumerate()
        {
            let want = len + 8 * (2 * f + 1);
            if v.len() < want {
                v.resize(want, 0.0);
            }
        }
    }

    /// Ray `k`.
    #[inline(always)]
    fn get(&self, k: usize) -> Ray {
        Ray {
            m: [self.mx[k], self.my[k], self.mz[k], self.q[k]],
            gamma: self.gamma[k],
            k2: Vec3::new(self.k2x[k], self.k2y[k], self.k2z[k]),
            k_out: Vec3::new(self.ox[k], self.oy[k], self.oz[k]),
        }
    }

    /// Slots `0..n` of every field, to be set ray by ray.
    #[inline(always)]
    fn slots(&mut self, n: usize) -> HitSlots<'_> {
        HitSlots {
            mx: &mut self.mx[..n],
            my: &mut self.my[..n],
            mz: &mut self.mz[..n],
            q: &mut self.q[..n],
            gamma: &mut self.gamma[..n],
            k2x: &mut self.k2x[..n],
            k2y: &mut self.k2y[..n],
            k2z: &mut self.k2z[..n],
            ox: &mut self.ox[..n],
            oy: &mut self.oy[..n],
            oz: &mut self.oz[..n],
        }
    }
}

/// The first slots of a [`HitRays`], as slices of one length: a loop over them keeps
/// the slices in registers and needs no bounds check per field (through the vectors,
/// every store reloaded the vector's pointer and length).
struct HitSlots<'a> {
    mx: &'a mut [f64],
    my: &'a mut [f64],
    mz: &'a mut [f64],
    q: &'a mut [f64],
    gamma: &'a mut [f64],
    k2x: &'a mut [f64],
    k2y: &'a mut [f64],
    k2z: &'a mut [f64],
    ox: &'a mut [f64],
    oy: &'a mut [f64],
    oz: &'a mut [f64],
}

impl HitSlots<'_> {
    /// Stores `ray` as ray `k`.
    #[inline(always)]
    fn set(&mut self, k: usize, ray: &Ray) {
        self.mx[k] = ray.m[0];
        self.my[k] = ray.m[1];
        self.mz[k] = ray.m[2];
        self.q[k] = ray.m[3];
        self.gamma[k] = ray.gamma;
        self.k2x[k] = ray.k2.x;
        self.k2y[k] = ray.k2.y;
        self.k2z[k] = ray.k2.z;
        self.ox[k] = ray.k_out.x;
        self.oy[k] = ray.k_out.y;
        self.oz[k] = ray.k_out.z;
    }
}

/// The scalar model: one sum per detector, `w = F γ/(m.z cos θt)` (module docs).
struct Scalar;

impl Accumulator for Scalar {
    type Weight = f64;

    fn channels(&self) -> usize {
        1
    }

    #[inline(always)]
    fn weigh(&self, opts: &TopoOptions, inc: &Inc, ray: &Ray) -> f64 {
        let f = path_factor(opts, inc, ray);
        if opts.weighting == Weighting::Physical {
            f * ray.gamma * ray.m[3] * (1.0 / inc.cos_t)
        } else {
            f * ray.gamma
        }
    }

    #[inline]
    fn add(&self, w: &f64, _: &Ray, _: &Cone, scale: f64, sums: &mut [f64]) {
        sums[0] += w * scale;
    }

    #[inline(always)]
    fn plain(&self, w: &f64) -> Option<f64> {
        Some(*w)
    }

    /// For a perfectly conducting flake and an exact transmission, one loop of the
    /// same operations per ray without calls, which the compiler vectorises; `weigh`
    /// ray by ray otherwise.
    #[inline(always)]
    fn weigh_hits(
        &self,
        opts: &TopoOptions,
        inc: &Inc,
        rays: &HitRays,
        kept: usize,
        hits: &[(u16, u64)],
        out: &mut Vec<f64>,
    ) {
        out.clear();
        let t = opts.transmission;
        if !opts.flake.is_perfect() || t == Transmission::Paper {
            out.extend(
                hits.iter()
                    .map(|&(k, _)| self.weigh(opts, inc, &rays.get(usize::from(k)))),
            );
            return;
        }
        // Every kept ray, in one loop per (transmission, weighting), each without
        // branches; then the hits' weights moved to the front (`hits[j].0 ≥ j`).
        out.resize(kept, 0.0);
        // The perfect conductor's constant amplitudes.
        let flake = opts.flake.amplitudes(1.0, opts.n);
        let physical = opts.weighting == Weighting::Physical;
        let n = opts.n;
        match (t, physical) {
            (Transmission::S, false) => {
                exact_weights(Transmission::S, false, n, inc, flake, rays, out)
            }
            (Transmission::S, true) => {
                exact_weights(Transmission::S, true, n, inc, flake, rays, out)
            }
            (Transmission::P, false) => {
                exact_weights(Transmission::P, false, n, inc, flake, rays, out)
            }
            (Transmission::P, true) => {
                exact_weights(Transmission::P, true, n, inc, flake, rays, out)
            }
            (Transmission::ExactUnpolarized, false) => exact_weights(
                Transmission::ExactUnpolarized,
                false,
                n,
                inc,
                flake,
                rays,
                out,
            ),
            (Transmission::ExactUnpolarized, true) => exact_weights(
                Transmission::ExactUnpolarized,
                true,
                n,
                inc,
                flake,
                rays,
                out,
            ),
            // Taken above: the path factor is not the Mueller row's.
            (Transmission::Paper, _) => {}
        }
        for (j, &(k, _)) in hits.iter().enumerate() {
            out[j] = out[usize::from(k)];
        }
        out.truncate(hits.len());
    }
}

/// [`Scalar::weigh`] of the first `out.len()` rays of `rays` for transmission `t`
/// (not `paper`), weighting physical or not and flake amplitudes `flake` (the same for
/// every ray: a perfect conductor), in one loop over the rays' fields.
#[inline(always)]
fn exact_weights(
    t: Transmission,
    physical: bool,
    n: f64,
    inc: &Inc,
    flake: (jones::C64, jones::C64),
    rays: &HitRays,
    out: &mut [f64],
) {
    let len = out.len();
    let (mx, my, mz, q) = (
        &rays.mx[..len],
        &rays.my[..len],
        &rays.mz[..len],
        &rays.q[..len],
    );
    let gamma = &rays.gamma[..len];
    let (k2x, k2y, k2z) = (&rays.k2x[..len], &rays.k2y[..len], &rays.k2z[..len]);
    let (ox, oy, oz) = (&rays.ox[..len], &rays.oy[..len], &rays.oz[..len]);
    let entry_t = (inc.amplitudes[2], inc.amplitudes[3]);
    for k in 0..len {
        let ray = Ray {
            m: [mx[k], my[k], mz[k], q[k]],
            gamma: gamma[k],
            k2: Vec3::new(k2x[k], k2y[k], k2z[k]),
            k_out: Vec3::new(ox[k], oy[k], oz[k]),
        };
        let f = exact_path_factor(t, n, entry_t, &ray_directions(inc, &ray), flake);
        out[k] = if physical {
            f * ray.gamma * ray.m[3] * (1.0 / inc.cos_t)
        } else {
            f * ray.gamma
        };
    }
}

/// The directions of a ray's Jones path ([`flakescatter_optics::jones`]).
#[inline(always)]
fn ray_directions(inc: &Inc, ray: &Ray) -> RayPath {
    RayPath {
        k_in: inc.k_in,
        k1: Vec3::new(inc.k1x, 0.0, inc.k1z),
        m: Vec3::new(ray.m[0], ray.m[1], ray.m[2]),
        k2: ray.k2,
        k_out: ray.k_out,
    }
}

/// The Jones path of a ray ([`flakescatter_optics::jones`]) with its amplitudes.
#[inline(always)]
pub(crate) fn ray_path(opts: &TopoOptions, inc: &Inc, ray: &Ray) -> (RayPath, PathAmplitudes) {
    let n = opts.n;
    let amps = PathAmplitudes {
        entry: (inc.amplitudes[2], inc.amplitudes[3]),
        flake: opts.flake.amplitudes(ray.gamma, n),
        exit: jones::exit_amplitudes(ray.k_out.z, ray.k2.z, n),
    };
    (ray_directions(inc, ray), amps)
}

/// The path factor `F` of a ray (module docs, step 3).
#[inline(always)]
fn path_factor(opts: &TopoOptions, inc: &Inc, ray: &Ray) -> f64 {
    path_factor_of(
        opts,
        &inc.entry,
        (inc.amplitudes[2], inc.amplitudes[3]),
        &ray_directions(inc, ray),
        ray.gamma,
    )
}

/// The path factor `F` of a ray given by its directions (module docs, step 3), shared
/// by the plain and the isotropic model: for `paper` the product of averaged powers
/// at each crossing; otherwise the exact first row of the ray's Mueller matrix
/// ([`flakescatter_optics::jones`]), `m00` for an unpolarised beam, `m00 ± m01` for s
/// or p. `entry_t` are the entry amplitudes `(ts, tp)`, `gamma = −k1·m`.
#[inline(always)]
pub(crate) fn path_factor_of(
    opts: &TopoOptions,
    entry: &FresnelPower,
    entry_t: (f64, f64),
    path: &RayPath,
    gamma: f64,
) -> f64 {
    let (t, n) = (opts.transmission, opts.n);
    if t == Transmission::Paper {
        let exit = fresnel::power_from_cosines(path.k_out.z, path.k2.z, n);
        let flake = opts.flake.power(gamma, n);
        return t.path_factor(entry, flake, &exit);
    }
    exact_path_factor(t, n, entry_t, path, opts.flake.amplitudes(gamma, n))
}

/// The exact path factor (`t` not `paper`) of a ray with flake amplitudes `flake`
/// ([`path_factor_of`]).
#[inline(always)]
fn exact_path_factor(
    t: Transmission,
    n: f64,
    entry_t: (f64, f64),
    path: &RayPath,
    flake: (jones::C64, jones::C64),
) -> f64 {
    let amps = PathAmplitudes {
        entry: entry_t,
        flake,
        exit: jones::exit_amplitudes(path.k_out.z, path.k2.z, n),
    };
    let row = path.first_row(&amps);
    t.from_first_row(row).unwrap_or(row.0)
}

/// Sums of one tile.
#[derive(Debug)]
struct Partial {
    /// Per (incidence, internal detector, channel), then [`LANES`] slots of padding.
    sums: Vec<f64>,
    /// Rays per (incidence, internal detector), then [`LANES`] slots of padding.
    counts: Vec<u32>,
    usable: u64,
    lost_tir: u64,
    lost_down: u64,
}

/// Everything fixed during a run.
struct Setup<'a> {
    incs: Vec<Inc>,
    index: ConeIndex,
    /// The internal detectors.
    cones: &'a [Cone],
    /// Per internal detector: 1 (physical) or `cos ϑ'/cos ϑ` (paper-printed).
    scale: Vec<f64>,
    /// Whether every ray adds its weight unchanged: every `scale` is 1 and there is no
    /// binder absorption.
    unit: bool,
    ndet: usize,
    options: &'a TopoOptions,
    absorption: Option<PathAbsorption>,
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
    /// A model with `options`.
    ///
    /// # Errors
    /// [`TopoError::Index`] for an index that is not a finite real ≥ 1,
    /// [`TopoError::FlakeIndex`] for an invalid complex flake index,
    /// [`TopoError::Window`] for an even window or one below 3.
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
        })
    }

    /// The same model with the binder absorbing along each ray's path inside the film
    /// (module docs, step 6). The isotropic average refuses a model with absorption.
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
        let (ny, h) = (map.ny(), k / 2);
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
                    usable += tile_slopes::<true>(map, h, rect, scratch, |r, c, a, b| {
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
                    clearcoat_seen: seen_cc,
                });
            }
        }
        Ok(TopoResult {
            points,
            ..acc.totals
        })
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
        let n = self.options.n;

        // Internal detectors: the user's cones, then one specular cone per incidence and
        // distinct aperture (for `relative`).
        let mut apertures: Vec<f64> = Vec::new();
        for c in cones {
            if !apertures.contains(&c.half_angle()) {
                apertures.push(c.half_angle());
            }
        }
        let mut all = cones.to_vec();
        for &t in theta_i {
            for &a in &apertures {
                all.push(Cone::in_plane(-t, a).map_err(TopoError::Detector)?);
            }
        }
        let ndet = all.len();
        let scale: Vec<f64> = all
            .iter()
            .map(|c| match self.options.weighting {
                Weighting::Physical => 1.0,
                Weighting::PaperPrinted => {
                    let cz = c.axis().z;
                    let sin2 = (1.0 - cz * cz).max(0.0);
                    (1.0 - sin2 / (n * n)).sqrt() / cz
                }
            })
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
            stats.tiles
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
        Ok(Accumulated {
            all,
            apertures,
            ndet,
            sum: stats.sum,
            m2: stats.m2,
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
/// standard errors come.
pub(crate) struct TileStats {
    /// Σ over tiles of each slot's tile sum.
    pub sum: Vec<f64>,
    mean: Vec<f64>,
    /// Σ of squared deviations of the tile sums from their mean.
    pub m2: Vec<f64>,
    /// Tiles added so far.
    pub tiles: u64,
}

impl TileStats {
    /// No tiles yet, `slots` slots.
    pub fn new(slots: usize) -> Self {
        Self {
            sum: vec![0.0; slots],
            mean: vec![0.0; slots],
            m2: vec![0.0; slots],
            tiles: 0,
        }
    }

    /// Adds one tile's sums `v`, one per slot.
    #[inline]
    pub fn add(&mut self, v: &[f64]) {
        self.tiles += 1;
        let inv_seen = 1.0 / self.tiles as f64;
        for (((s, m), q), &v) in self
            .sum
            .iter_mut()
            .zip(self.mean.iter_mut())
            .zip(self.m2.iter_mut())
            .zip(v)
        {
            *s += v;
            let delta = v - *m;
            *m += delta * inv_seen;
            *q += delta * (v - *m);
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

/// Reusable buffers of [`trace_tile`]: the normals' window sums, a chunk of slopes and
/// what [`trace_chunk`] keeps per normal of a chunk.
#[derive(Debug, Default)]
struct TraceScratch {
    normals: Scratch,
    /// Slopes `(a, b)` of the chunk's usable pixels.
    slopes: Vec<[f64; 2]>,
    chunk: Chunk,
}

/// Per normal of a chunk: its components `m.x`, `m.y`, `m.z` and `1/m.z`, and the
/// index cell of its ray at the current incidence.
#[derive(Debug, Default)]
struct Chunk {
    mx: Vec<f64>,
    my: Vec<f64>,
    mz: Vec<f64>,
    q: Vec<f64>,
    cells: Vec<u32>,
    /// At one incidence, the kept rays that enter some cone: their position in
    /// `kept` and the mask of their cell's cones that contain them (all ones, whether
    /// any contains them or not, for a cell of more than 64 cones).
    hits: Vec<(u16, u64)>,
    /// Per hit, the position of its cell's first block ([`ConeIndex::block_range`]).
    firsts: Vec<u32>,
    /// At one incidence, the positions in the chunk of the kept rays (whose cell lists
    /// cones), in ray order.
    kept: Vec<u16>,
    /// The kept rays' normals and directions, in the order of `kept`.
    found: HitRays,
}

/// Normals handled together, incidence by incidence: 26 KiB with their slopes, so that
/// they stay in the L1 cache for every incidence.
const RAY_CHUNK: usize = 512;

// Positions in a chunk are stored as `u16`.
const _: () = assert!(RAY_CHUNK <= 1 << 16);

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
    let mut trace = |slopes: &[[f64; 2]], p: &mut Partial| match pulp::Arch::new() {
        #[cfg(target_arch = "x86_64")]
        pulp::Arch::V4(v4) => pulp::Simd::vectorize(
            v4,
            ChunkTrace {
                setup,
                slopes,
                chunk,
                acc,
                p,
                lanes: v4,
            },
        ),
        arch => arch.dispatch(ChunkTrace {
            setup,
            slopes,
            chunk,
            acc,
            p,
            lanes: Portable,
        }),
    };
    let usable = tile_slopes::<false>(
        map,
        setup.options.window / 2,
        rect,
        normals,
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

/// One chunk's rays, handed to [`pulp::Arch::dispatch`] (or to [`pulp::x86::V4`]
/// directly, which then also tests the cone blocks: `lanes`) so that [`trace_chunk`] is
/// compiled for the processor's instruction set (SSE2, AVX2 or AVX-512 encodings of the
/// same operations in the same order, without fused multiply–add: the results do not
/// depend on it).
struct ChunkTrace<'a, 's, A, L> {
    setup: &'a Setup<'s>,
    slopes: &'a [[f64; 2]],
    chunk: &'a mut Chunk,
    acc: &'a A,
    p: &'a mut Partial,
    lanes: L,
}

impl<A: Accumulator, L: Lanes> pulp::WithSimd for ChunkTrace<'_, '_, A, L> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        trace_chunk(
            self.setup,
            self.slopes,
            self.chunk,
            self.acc,
            self.p,
            self.lanes,
        );
    }
}

/// One ray per pixel of `slopes` and incidence, added to `p`.
///
/// The normals first, then per incidence: a pass without branches (which the compiler
/// vectorises) computes every ray's exit and its cell of the cone index, counting the
/// lost rays and giving them, and rays outside the box of the cells that list cones
/// (most for in-plane detectors), the empty cell ([`crate::index::Grid::boxed_cell`]).
/// The other rays whose cell lists cones, the kept ones, are listed in ray order, from
/// a mask of 64 rays at a time; a second pass without branches gives their exit
/// directions field by field ([`HitRays`]); a third tests each against its cell's
/// candidate cones, eight at a time ([`ConeIndex::inside_mask_of`]: one AVX-512 compare
/// per eight where the processor has it, the same bits); the weights of the rays that
/// some cone contains follow ([`Accumulator::weigh_hits`]: for the scalar model with a
/// perfectly conducting flake and an exact transmission, one vectorised loop over all
/// kept rays), and last each such ray is added to its cones in the cell's order (for
/// the scalar model without detector factors, a block of consecutive detectors in one
/// masked eight-lane addition, other blocks cone by cone in a loop of a few
/// instructions).
///
/// Always inlined into [`ChunkTrace`]'s `with_simd`, with everything it calls in the hot
/// loops (the accumulators' `weigh`, `weigh_hits` and the path factor), so that all of
/// it is compiled for the instruction set [`pulp::Arch::dispatch`] chose: code the
/// compiler kept out of line ran as baseline SSE2 (a closure and `Scalar::weigh`, once a
/// quarter of a run's time; `RayPath::first_row`, which kept the weight loop scalar).
#[inline(always)]
fn trace_chunk<A: Accumulator, L: Lanes>(
    setup: &Setup<'_>,
    slopes: &[[f64; 2]],
    chunk: &mut Chunk,
    acc: &A,
    p: &mut Partial,
    lanes: L,
) {
    let opts = setup.options;
    let n = opts.n;
    let ndet = setup.ndet;
    let channels = acc.channels();
    let index = &setup.index;
    let empty = index.empty_cell();
    let len = slopes.len();
    let Chunk {
        mx,
        my,
        mz,
        q,
        cells,
        hits,
        firsts,
        kept,
        found,
    } = chunk;
    for v in [&mut *mx, &mut *my, &mut *mz, &mut *q] {
        v.clear();
        v.resize(len, 0.0);
    }
    cells.clear();
    cells.resize(len, empty);
    // m = (−a, −b, 1)/sqrt(1 + a² + b²) and its 1/m.z.
    for ((((&[a, b], mx), my), mz), q) in slopes
        .iter()
        .zip(mx.iter_mut())
        .zip(my.iter_mut())
        .zip(mz.iter_mut())
        .zip(q.iter_mut())
    {
        *q = (1.0 + a * a + b * b).sqrt();
        let inv = 1.0 / *q;
        *mx = -a * inv;
        *my = -b * inv;
        *mz = inv;
    }
    let (mx, my, mz, q) = (&mx[..], &my[..], &mz[..], &q[..]);
    // The exit of a ray off normal `(mx, my, mz)` (physics.md §5 step 2): γ, k2 and the
    // horizontal components of k_out in air.
    let exit = |inc: &Inc, mx: f64, my: f64, mz: f64| {
        let gamma = -(inc.k1x * mx + inc.k1z * mz);
        let g2 = 2.0 * gamma;
        let k2z = inc.k1z + g2 * mz;
        let (k2x, k2y) = (inc.k1x + g2 * mx, g2 * my);
        (gamma, Vec3::new(k2x, k2y, k2z), n * k2x, n * k2y)
    };
    // Per-incidence records (below), every slot written before it is read.
    hits.resize(len.max(hits.len()), (0, 0));
    firsts.resize(len.max(firsts.len()), 0);
    kept.resize(len.max(kept.len()), 0);
    found.fit(RAY_CHUNK.max(len));
    let mut weights: Vec<A::Weight> = Vec::with_capacity(len);
    for (ii, inc) in setup.incs.iter().enumerate() {
        let base = ii * ndet;
        // This incidence's sums and counts, and what follows them (the next
        // incidence's, and the padding of `LANES` past the last).
        let sums_all = &mut p.sums[base * channels..];
        let counts_all = &mut p.counts[base..];
        let (mut down, mut tir) = (0u32, 0u32);
        // Local copies, which the loop keeps in registers.
        let (grid, listed) = index.listed();
        let last = listed.len() - 1;
        let here = *inc;
        for (((&mx, &my), &mz), cell) in mx.iter().zip(my).zip(mz).zip(cells.iter_mut()) {
            let (gamma, k2, ox, oy) = exit(&here, mx, my, mz);
            // Rays that head down (this includes gamma <= 0), then rays that are totally
            // internally reflected.
            let is_down = (gamma <= 0.0) | (k2.z <= 0.0);
            let is_tir = !is_down & (ox * ox + oy * oy >= 1.0);
            down += u32::from(is_down);
            tir += u32::from(is_tir);
            // The empty cell, or the cell if it lies in the box of the cells that
            // list cones (most rays of in-plane detectors fall outside it).
            *cell = if is_down | is_tir {
                empty
            } else {
                grid.boxed_cell(ox, oy)
            };
        }
        p.lost_down += u64::from(down);
        p.lost_tir += u64::from(tir);
        // The kept rays (whose cell lists a cone), in ray order: their positions in the
        // chunk, then their exit directions in a loop without branches (vectorised),
        // then which of their cell's candidate cones they enter, then the weights of
        // those that enter any and the additions, in ray order (the sums' order, and so
        // their bits, are those of one ray at a time).
        // Sixty-four rays at a time: the mask of those in the box (a vectorised
        // compare), then one step per such ray, kept if its cell lists cones.
        let mut nkept = 0;
        let slots = &mut kept[..len];
        for (g, group) in cells.chunks(64).enumerate() {
            let mut boxed = 0u64;
            for (j, &c) in group.iter().enumerate() {
                boxed |= u64::from(c != empty) << j;
            }
            while boxed != 0 {
                let j = boxed.trailing_zeros() as usize;
                boxed &= boxed - 1;
                // `i < len ≤ RAY_CHUNK`, which fits in 16 bits.
                slots[nkept] = (g * 64 + j) as u16;
                nkept += usize::from(listed[(group[j] as usize).min(last)] != empty);
            }
        }
        let kept = &kept[..nkept];

        let mut slots = found.slots(nkept);
        for (k, &i) in kept.iter().enumerate() {
            // `i < len` already: the `min` lets the compiler drop the bounds checks.
            let i = usize::from(i).min(len - 1);
            let (gamma, k2, ox, oy) = exit(&here, mx[i], my[i], mz[i]);
            let oz = (1.0 - (ox * ox + oy * oy)).sqrt();
            slots.set(
                k,
                &Ray {
                    m: [mx[i], my[i], mz[i], q[i]],
                    gamma,
                    k2,
                    k_out: Vec3::new(ox, oy, oz),
                },
            );
        }
        let mut nhit = 0;
        let (ox, oy, oz) = (&found.ox[..nkept], &found.oy[..nkept], &found.oz[..nkept]);
        let (hits_out, firsts_out) = (&mut hits[..nkept], &mut firsts[..nkept]);
        for (k, &i) in kept.iter().enumerate() {
            let cell = cells[usize::from(i)] as usize;
            let range = index.block_range(cell);
            // `range.start < 2³²`: the index's offsets are u32.
            firsts_out[nhit] = range.start as u32;
            // All ones for a cell of more than 64 candidates, tested in the additions.
            let mask = index.inside_mask_of(lanes, cell, range, ox[k], oy[k], oz[k]);
            hits_out[nhit] = (k as u16, mask);
            nhit += usize::from(mask != 0);
        }
        // The weights of the rays that enter some cone (once each).
        acc.weigh_hits(opts, inc, found, nkept, &hits[..nhit], &mut weights);
        for ((&(k, mut mask), w), &first) in hits[..nhit].iter().zip(&weights).zip(&firsts[..nhit])
        {
            // All ones: a cell whose cones are tested one by one below (of more than 64,
            // or 64 that all contain the ray, which gives the same cones in order).
            if mask != u64::MAX
                && setup.unit
                && channels == 1
                && let Some(w) = acc.plain(w)
            {
                // The scalar model without detector factors: `sums[d] += w` (the
                // generic `w · 1.0`, the same number). A block of consecutive
                // detectors `j, j + 1, …` (in-plane sweeps) adds to eight of them at
                // once, `w` where its lanes contain the ray and −0.0 and 0 rays, which
                // change nothing, elsewhere (`sums` and `counts` reach `LANES` past the
                // last detector, into the next incidence's or the padding); other
                // blocks cone by cone.
                let (runs, detectors) =
                    (index.runs(first as usize), index.detectors(first as usize));
                let (sums, counts) = (
                    &mut sums_all[..ndet + LANES],
                    &mut counts_all[..ndet + LANES],
                );
                let mut b = 0;
                while mask != 0 {
                    let bits = mask as u8;
                    // `NO_RUN` is above every detector.
                    let j = runs[b] as usize;
                    if j < ndet {
                        let s: &mut [f64; LANES] =
                            (&mut sums[j..j + LANES]).try_into().expect("LANES");
                        let c: &mut [u32; LANES] =
                            (&mut counts[j..j + LANES]).try_into().expect("LANES");
                        lanes.add_hits(s, c, bits, w);
                    } else {
                        let mut bits = bits;
                        while bits != 0 {
                            let d = detectors[b * LANES + bits.trailing_zeros() as usize] as usize;
                            sums[d] += w;
                            counts[d] += 1;
                            bits &= bits - 1;
                        }
                    }
                    mask >>= LANES;
                    b += 1;
                }
                continue;
            }
            let k = usize::from(k);
            let ray = &found.get(k);
            let absorbed = setup.absorption.map(|a| a.factor(inc.cos_t, ray.k2.z));
            let mut add = |w: &A::Weight, d: u32| {
                let d = d as usize;
                let scale = match absorbed {
                    Some(a) => setup.scale[d] * a,
                    None => setup.scale[d],
                };
                acc.add(
                    w,
                    ray,
                    &setup.cones[d],
                    scale,
                    &mut sums_all[d * channels..(d + 1) * channels],
                );
                counts_all[d] += 1;
            };
            if mask != u64::MAX {
                let detectors = index.detectors(first as usize);
                while mask != 0 {
                    add(w, detectors[mask.trailing_zeros() as usize]);
                    mask &= mask - 1;
                }
            } else {
                let cell = cells[usize::from(kept[k])] as usize;
                let o = ray.k_out;
                for e in index
                    .cell_entries(cell)
                    .iter()
                    .filter(|e| e.contains(o.x, o.y, o.z))
                {
                    add(w, e.index);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// The scalar model's vectorised `weigh_hits` gives, bit for bit, `weigh` of each
    /// hit (the reference, ray by ray through `path_factor_of`), for every transmission
    /// and weighting, a perfect and a metal flake, and batch lengths that leave vector
    /// remainders (1, 7, 9, 64 and 333 kept rays, all or every third of them hits). The
    /// rays are those of random flake normals at several incidences, with the exit of
    /// `trace_chunk`; ray 0 of each batch leaves along the zenith (`k_out.x = k_out.y =
    /// 0`, the special case of the Jones frames).
    #[test]
    fn batch_weights_equal_the_weights_ray_by_ray() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let n = 1.5;
        let mut checked = 0;
        for theta in [0.0, 0.3, 0.8, 1.3] {
            let inc = Inc::new(theta, n);
            let mut rays = Vec::new();
            // A normal halfway between k1 and the zenith sends the ray straight up.
            let up = Vec3::new(-inc.k1x, 0.0, 1.0 - inc.k1z).normalize();
            let mut tries = 0;
            while rays.len() < 333 {
                tries += 1;
                assert!(tries < 100_000, "too few rays leave at θi = {theta}");
                let m = if rays.is_empty() {
                    up
                } else {
                    let (a, b): (f64, f64) =
                        (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
                    Vec3::new(-a, -b, 1.0) / (1.0 + a * a + b * b).sqrt()
                };
                let gamma = -(inc.k1x * m.x + inc.k1z * m.z);
                let k2 = Vec3::new(inc.k1x, 0.0, inc.k1z) + m * (2.0 * gamma);
                let (ox, oy) = (n * k2.x, n * k2.y);
                let r2 = ox * ox + oy * oy;
                if gamma <= 0.0 || k2.z <= 0.0 || r2 >= 1.0 {
                    continue;
                }
                rays.push(Ray {
                    m: [m.x, m.y, m.z, 1.0 / m.z],
                    gamma,
                    k2,
                    k_out: Vec3::new(ox, oy, (1.0 - r2).sqrt()),
                });
            }
            // Up to rounding: made exact below, as the special case needs.
            assert!(
                rays[0].k_out.x.abs() < 1e-15 && rays[0].k_out.y == 0.0,
                "{:?}",
                rays[0].k_out
            );
            rays[0].k_out = Vec3::new(0.0, 0.0, 1.0);
            let mut soa = HitRays::default();
            soa.fit(rays.len());
            let mut slots = soa.slots(rays.len());
            for (k, r) in rays.iter().enumerate() {
                slots.set(k, r);
            }
            for transmission in Transmission::ALL {
                for weighting in [Weighting::Physical, Weighting::PaperPrinted] {
                    for flake in [
                        FlakeReflectance::PerfectConductor,
                        FlakeReflectance::aluminium_550nm(),
                    ] {
                        let opts = TopoOptions {
                            transmission,
                            weighting,
                            flake,
                            ..TopoOptions::default()
                        };
                        for len in [1, 7, 9, 64, rays.len()] {
                            // All kept rays hit, or every third one and the last.
                            for step in [1, 3] {
                                let hits: Vec<(u16, u64)> = (0..len)
                                    .filter(|k| k % step == 0 || k + 1 == len)
                                    .map(|k| (k as u16, 1))
                                    .collect();
                                let mut out = vec![f64::NAN; 3];
                                Scalar.weigh_hits(&opts, &inc, &soa, len, &hits, &mut out);
                                assert_eq!(out.len(), hits.len());
                                for (w, &(k, _)) in out.iter().zip(&hits) {
                                    let want = Scalar.weigh(&opts, &inc, &rays[usize::from(k)]);
                                    assert!(want.is_finite() && want > 0.0, "{want}");
                                    assert_eq!(
                                        w.to_bits(),
                                        want.to_bits(),
                                        "ray {k} of {len}, {transmission}, {weighting:?}, {flake:?}, θi = {theta}"
                                    );
                                    checked += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }
}
