//! The physics of one path through the film (the crate docs' ray rules): entry,
//! flake faces and rims, the substrate, the top interface from inside, and the tally
//! of each escape into the detector cones and the energy balance; the ray's generator.
//! A free stack flake's faces split the ray into reflection and transmission (module
//! `stack`); a tinted binder takes its share along each segment (module `binder`).

use flakescatter_numerics::cone_grid::{ConeGrid, ConeSpec};
use flakescatter_numerics::simd::{Kernels, dispatch};
use flakescatter_optics::detector::{self, Cone, orthonormal_frame};
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::{UnitVec3, Vec3, refraction};
use rand::{Rng, RngExt, SeedableRng};
use rand_xoshiro::{SplitMix64, Xoshiro256PlusPlus};

use super::binder;
use super::stack::StackFaces;
use super::{BATCHES, RimRule, Substrate, TraceOptions};
use crate::grid::{FlakeGrid, Next, Surface};
use crate::layer::Flake;

// Energy slots of a batch.
pub(super) const E_SINGLE: usize = 0;
pub(super) const E_MULTI: usize = 1;
pub(super) const E_VIA_SUB: usize = 2;
pub(super) const E_SUB: usize = 3;
pub(super) const E_FLAKES: usize = 4;
pub(super) const E_RIMS: usize = 5;
pub(super) const E_CUT: usize = 6;
pub(super) const E_BINDER: usize = 7;
pub(super) const E_SLOTS: usize = 8;

/// Sums of one batch (or of a batch's rays within one chunk).
pub(super) struct Partial {
    /// `[single, multiple]` per internal detector.
    pub(super) cones: Vec<[f64; 2]>,
    pub(super) counts: Vec<u64>,
    pub(super) energy: [f64; E_SLOTS],
    pub(super) segments: u64,
}

impl Partial {
    pub(super) fn new(ndet: usize) -> Self {
        Self {
            cones: vec![[0.0; 2]; ndet],
            counts: vec![0; ndet],
            energy: [0.0; E_SLOTS],
            segments: 0,
        }
    }

    /// Adds `other`'s sums to these.
    pub(super) fn merge(&mut self, other: &Partial) {
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

/// A cone as [`ConeGrid`] takes it.
pub(super) fn spec(c: &Cone) -> ConeSpec {
    let a = c.axis();
    ConeSpec {
        axis: [a.x, a.y, a.z],
        half_angle: c.half_angle(),
        cos_half_angle: c.cos_half_angle(),
    }
}

/// Everything fixed during a run.
pub(super) struct Run<'r> {
    pub(super) flakes: &'r [Flake],
    pub(super) grid: &'r FlakeGrid,
    pub(super) options: &'r TraceOptions,
    pub(super) cones: ConeGrid,
    pub(super) ndet: usize,
    pub(super) film: f64,
    pub(super) tile: f64,
    pub(super) rays: u64,
    pub(super) batch_rays: u64,
    pub(super) max_cells: u64,
    /// The rays' key, from the seed (see [`ray_rng`]).
    pub(super) key: [u64; 2],
    /// The kernels the rays run with.
    pub(super) kernels: Kernels,
    /// The faces of a free stack flake (module `stack`); `None` for every other flake.
    pub(super) stack: Option<StackFaces>,
}

/// One chunk's rays, handed to [`dispatch`] (a closure would be kept out of
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

/// The two words every ray's generator starts from: SplitMix64 of the seed, the second
/// word XORed with SplitMix64's finaliser of the realisation `k` (a bijection with
/// `0 ↦ 0`, so realisation 0 is a single layer's key and distinct `k` give distinct
/// keys).
pub(super) fn ray_key(seed: u64, k: u64) -> [u64; 2] {
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
    /// Ray `q` of incidence number `ii`: its generator (stream `ii·N + q`) after its
    /// first two numbers, and the entry point `(x, y)` they give (µm, uniform on
    /// `[0, L)²`).
    #[inline(always)]
    pub(super) fn ray_start(&self, ii: u64, q: u64) -> (Xoshiro256PlusPlus, f64, f64) {
        let l = self.tile;
        let mut rng = ray_rng(self.key, ii * self.rays + q);
        let x = l * rng.random::<f64>();
        let y = l * rng.random::<f64>();
        (rng, x, y)
    }

    /// Traces the rays `first + o` for the offsets `o` of `order` (from [`Run::sorted`])
    /// of incidence number `ii` at angle `theta_i`, in that order; each ray adds to the
    /// sums of its batch (`q / batch_rays`).
    pub(super) fn chunk(&self, theta_i: f64, ii: u64, first: u64, order: &[u32]) -> Vec<Partial> {
        let n = self.options.n;
        let k_in = detector::incident_direction(theta_i);
        let k1 = refraction::into_coating(&k_in, n).into_inner();
        let entry = fresnel::air_to_coating(theta_i, n);
        let mut parts: Vec<Partial> = (0..BATCHES).map(|_| Partial::new(self.ndet)).collect();
        dispatch(
            self.kernels,
            ChunkRays {
                run: self,
                ii,
                first,
                order,
                k1: &k1,
                entry: &entry,
                parts: &mut parts,
            },
        );
        parts
    }

    /// The loop of [`Run::chunk`], inlined into the instruction-set build that
    /// [`dispatch`] chose (with what is inlined into it: the ray loop and
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
        let alpha = opts.binder_alpha_per_um;
        // Flake (not binder) at the start of the next segment, µm (module `binder`).
        let mut in_flake = 0.0f64;
        loop {
            let mut w = ws + wp;
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
            if alpha > 0.0 {
                let (len, skip) = (binder::length(&next, tau_max), in_flake);
                p.energy[E_BINDER] += binder::attenuate(alpha, len - skip, &mut ws, &mut wp);
                (w, in_flake) = (ws + wp, 0.0);
            }
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
                            let top = h.surface == Surface::Top;
                            if self.face(top, cos_iota, &mut ws, &mut wp, rng, p) {
                                k += 2.0 * cos_iota * h.normal;
                                // Keep the direction a unit vector against rounding drift.
                                k /= k.norm();
                                flake_hits += 1;
                            } else {
                                // On through the flake along the same line (`stack`),
                                // flake and not binder over its chord (`binder`).
                                other_events += 1;
                                in_flake = binder::chord(
                                    alpha,
                                    &self.flakes[h.flake as usize],
                                    &pos,
                                    &k,
                                    l,
                                );
                            }
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

    /// A hit on the top (`top`) or bottom face of a flake at local incidence cosine
    /// `cos_iota`: the channel weights `(ws, wp)` become what the ray carries on, the rest
    /// is tallied as `absorbed_flakes`; returns whether the ray is reflected (`false`: it
    /// goes on through a free stack flake, module `stack`).
    #[inline(always)]
    fn face(
        &self,
        top: bool,
        cos_iota: f64,
        ws: &mut f64,
        wp: &mut f64,
        rng: &mut Xoshiro256PlusPlus,
        p: &mut Partial,
    ) -> bool {
        let n = self.options.n;
        if let Some(faces) = &self.stack {
            let s = faces.split(top, cos_iota, n, *ws, *wp, rng.random());
            p.energy[E_FLAKES] += s.absorbed;
            (*ws, *wp) = (s.ws, s.wp);
            !s.transmitted
        } else {
            let (rs, rp) = self.options.flake.power(cos_iota, n);
            p.energy[E_FLAKES] += *ws * (1.0 - rs) + *wp * (1.0 - rp);
            *ws *= rs;
            *wp *= rp;
            true
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
            if e.contains(out.x, out.y, out.z) {
                let d = e.index as usize;
                p.cones[d][cat] += w;
                p.counts[d] += 1;
            }
        }
    }
}
