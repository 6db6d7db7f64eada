//! The physics of one ray of the topographic model: paper eqs. 14 and 15 with the
//! corrections of physics.md §5 (and §6, §8.1, §11 for the clear coat, the binder's
//! absorption and the polarisation). This file holds the equations; where the rays
//! come from (the pixels' normals, [`crate::normals`]), how they are scheduled and
//! summed ([`super::tiles`]) and the vectorised pass that runs them ([`super::chunk`])
//! are elsewhere.
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
//! 6. With binder absorption ([`crate::TopoModel::with_absorption`], physics.md §8.1)
//!    each ray's contribution (scalar or Mueller) is multiplied by
//!    [`PathAbsorption::factor`](flakescatter_optics::absorption::PathAbsorption::factor)
//!    `(cos θt, k2.z)`; the flakes' depth is the absorption's depth model, not read
//!    from the map. Without it nothing is multiplied.
//!
//! On a map of flat flakes whose normals follow a distribution, the pixel normals are
//! projected-area weighted (density `D(m) m.z` per usable pixel), so the expected
//! reflectance is `coverage · ∫ D F γ / cos θt dΩm` over the cone: the distribution
//! model (physics.md §4) times the usable-pixel coverage.

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::jones::{self, PathAmplitudes, RayPath};
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_optics::{Vec3, refraction};

use super::TopoOptions;
use super::chunk::{HitRays, exact_weigh_hits};

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
    pub fn new(theta_i: f64, n: f64) -> Self {
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

/// The exit of the ray of incidence `inc` off the unit normal `(mx, my, mz)` (steps 1
/// and 2, in a coating of index `n`): `γ = −k1·m`, `k2 = k1 + 2γ m`, and the horizontal
/// components `n k2.x`, `n k2.y` of `k_out` in air (`k_out.z` follows from them for the
/// rays that leave).
#[inline(always)]
pub(crate) fn exit(inc: &Inc, n: f64, mx: f64, my: f64, mz: f64) -> (f64, Vec3, f64, f64) {
    let gamma = -(inc.k1x * mx + inc.k1z * mz);
    let g2 = 2.0 * gamma;
    let k2z = inc.k1z + g2 * mz;
    let (k2x, k2y) = (inc.k1x + g2 * mx, g2 * my);
    (gamma, Vec3::new(k2x, k2y, k2z), n * k2x, n * k2y)
}

/// The detector factor of step 3 for a cone in a coating of index `n`: 1 for the
/// physical weight, `cos ϑ'/cos ϑ` of the cone's axis for `paper-printed` (shared by the
/// plain and the isotropic model).
pub(crate) fn printed_scale(weighting: Weighting, cone: &Cone, n: f64) -> f64 {
    match weighting {
        Weighting::Physical => 1.0,
        Weighting::PaperPrinted => {
            let cz = cone.axis().z;
            let sin2 = (1.0 - cz * cz).max(0.0);
            (1.0 - sin2 / (n * n)).sqrt() / cz
        }
    }
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

/// The scalar model: one sum per detector, `w = F γ/(m.z cos θt)` (module docs).
pub(crate) struct Scalar;

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
    /// same operations per ray without calls, which the compiler vectorises
    /// ([`exact_weigh_hits`]); `weigh` ray by ray otherwise.
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
        exact_weigh_hits(self, opts, inc, rays, kept, hits, out);
    }
}

/// The directions of a ray's Jones path ([`flakescatter_optics::jones`]).
#[inline(always)]
pub(crate) fn ray_directions(inc: &Inc, ray: &Ray) -> RayPath {
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
pub(crate) fn exact_path_factor(
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
