//! The ray pass of the plain model over one chunk of pixels ([`trace_chunk`]), run
//! under the kernel layer's dispatch ([`crate::simd::dispatch!`]) so that it is compiled
//! for the processor's instruction set: the rays' exits and index cells, the kept rays
//! field by field ([`HitRays`]), their cone masks, their weights (the scalar model's
//! vectorised loop, [`exact_weigh_hits`]) and the additions. The equations it applies
//! are those of [`super::physics`]; every (incidence, detector) sum takes its rays in
//! pixel order, so the result is that of one ray at a time, bit for bit.

use flakescatter_optics::Vec3;
use flakescatter_optics::jones;
use flakescatter_optics::polarization::{Transmission, Weighting};

use super::TopoOptions;
use super::physics::{Accumulator, Inc, Ray, Scalar, exact_path_factor, exit, ray_directions};
use super::tiles::{Partial, Setup};
use crate::simd::{LANES, Lanes};

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
    pub fn fit(&mut self, len: usize) {
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
    pub fn get(&self, k: usize) -> Ray {
        Ray {
            m: [self.mx[k], self.my[k], self.mz[k], self.q[k]],
            gamma: self.gamma[k],
            k2: Vec3::new(self.k2x[k], self.k2y[k], self.k2z[k]),
            k_out: Vec3::new(self.ox[k], self.oy[k], self.oz[k]),
        }
    }

    /// Slots `0..n` of every field, to be set ray by ray.
    #[inline(always)]
    pub fn slots(&mut self, n: usize) -> HitSlots<'_> {
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
pub(crate) struct HitSlots<'a> {
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
    pub fn set(&mut self, k: usize, ray: &Ray) {
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

/// [`Accumulator::weigh_hits`] of the scalar model ([`Scalar`]): for a perfectly
/// conducting flake and an exact transmission, one loop of the same operations per ray
/// without calls, which the compiler vectorises ([`exact_weights`]); [`Scalar::weigh`]
/// ray by ray otherwise. The same bits either way (a unit test).
#[inline(always)]
pub(crate) fn exact_weigh_hits(
    scalar: &Scalar,
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
                .map(|&(k, _)| scalar.weigh(opts, inc, &rays.get(usize::from(k)))),
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
        (Transmission::S, false) => exact_weights(Transmission::S, false, n, inc, flake, rays, out),
        (Transmission::S, true) => exact_weights(Transmission::S, true, n, inc, flake, rays, out),
        (Transmission::P, false) => exact_weights(Transmission::P, false, n, inc, flake, rays, out),
        (Transmission::P, true) => exact_weights(Transmission::P, true, n, inc, flake, rays, out),
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

/// [`Scalar`]'s `weigh` of the first `out.len()` rays of `rays` for transmission `t`
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

/// Per normal of a chunk: its components `m.x`, `m.y`, `m.z` and `1/m.z`, and the
/// index cell of its ray at the current incidence.
#[derive(Debug, Default)]
pub(crate) struct Chunk {
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
pub(crate) const RAY_CHUNK: usize = 512;

// Positions in a chunk are stored as `u16`.
const _: () = assert!(RAY_CHUNK <= 1 << 16);

/// One ray per pixel of `slopes` and incidence, added to `p`.
///
/// The normals first, then per incidence: a pass without branches (which the compiler
/// vectorises) computes every ray's exit and its cell of the cone index, counting the
/// lost rays and giving them, and rays outside the box of the cells that list cones
/// (most for in-plane detectors), the empty cell ([`crate::index::Grid::boxed_cell`]).
/// The other rays whose cell lists cones, the kept ones, are listed in ray order, from
/// a mask of 64 rays at a time; a second pass without branches gives their exit
/// directions field by field ([`HitRays`]); a third tests each against its cell's
/// candidate cones, eight at a time ([`crate::index::ConeIndex::inside_mask_of`]: one AVX-512 compare
/// per eight where the processor has it, the same bits) ([`find_hits`]); the weights
/// of the rays that some cone contains follow ([`Accumulator::weigh_hits`]: for the
/// scalar model with a perfectly conducting flake and an exact transmission, one
/// vectorised loop over all kept rays), and last each such ray is added to its cones in
/// the cell's order (for the scalar model without detector factors, a block of
/// consecutive detectors in one masked eight-lane addition, other blocks cone by cone
/// in a loop of a few instructions) ([`add_hits`]).
///
/// Always inlined into the body of [`crate::simd::dispatch!`], with everything it calls
/// in the hot loops (the accumulators' `weigh`, `weigh_hits` and the path factor), so
/// that all of it is compiled for the instruction set the dispatch chose: code the
/// compiler kept out of line ran as baseline SSE2 (a closure and `Scalar::weigh`, once a
/// quarter of a run's time; `RayPath::first_row`, which kept the weight loop scalar).
#[inline(always)]
pub(crate) fn trace_chunk<A: Accumulator, L: Lanes>(
    setup: &Setup<'_>,
    slopes: &[[f64; 2]],
    chunk: &mut Chunk,
    acc: &A,
    p: &mut Partial,
    lanes: L,
) {
    let len = slopes.len();
    let empty = setup.index.empty_cell();
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
    let normals = [&mx[..], &my[..], &mz[..], &q[..]];
    // Per-incidence records (below), every slot written before it is read.
    hits.resize(len.max(hits.len()), (0, 0));
    firsts.resize(len.max(firsts.len()), 0);
    kept.resize(len.max(kept.len()), 0);
    found.fit(RAY_CHUNK.max(len));
    let mut weights: Vec<A::Weight> = Vec::with_capacity(len);
    for (ii, inc) in setup.incs.iter().enumerate() {
        let (nkept, nhit) = find_hits(
            setup, inc, normals, cells, kept, found, hits, firsts, p, lanes,
        );
        // The weights of the rays that enter some cone (once each).
        acc.weigh_hits(
            setup.options,
            inc,
            found,
            nkept,
            &hits[..nhit],
            &mut weights,
        );
        let hits = Hits {
            kept: &kept[..nkept],
            cells,
            hits: &hits[..nhit],
            firsts: &firsts[..nhit],
            weights: &weights,
            rays: found,
        };
        add_hits(setup, ii, &hits, acc, p, lanes);
    }
}

/// At incidence `inc`, the rays of the chunk's normals (`[m.x, m.y, m.z, 1/m.z]`) that
/// enter some cone ([`trace_chunk`]): the lost rays counted into `p`, each ray's cell
/// (the empty one for a ray lost or outside the box of listed cells) in `cells`, the
/// kept rays' positions in `kept` and their rays in `found`, and per ray that some
/// cone contains, in ray order, its position in `kept` with its cone mask (`hits`) and
/// its cell's first block (`firsts`). Returns the numbers of kept rays and of hits.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn find_hits<L: Lanes>(
    setup: &Setup<'_>,
    inc: &Inc,
    [mx, my, mz, q]: [&[f64]; 4],
    cells: &mut [u32],
    kept: &mut [u16],
    found: &mut HitRays,
    hits: &mut [(u16, u64)],
    firsts: &mut [u32],
    p: &mut Partial,
    lanes: L,
) -> (usize, usize) {
    let n = setup.options.n;
    let index = &setup.index;
    let empty = index.empty_cell();
    let len = mx.len();
    let (mut down, mut tir) = (0u32, 0u32);
    // Local copies, which the loop keeps in registers.
    let (grid, listed) = index.listed();
    let last = listed.len() - 1;
    let here = *inc;
    for (((&mx, &my), &mz), cell) in mx.iter().zip(my).zip(mz).zip(cells.iter_mut()) {
        let (gamma, k2, ox, oy) = exit(&here, n, mx, my, mz);
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
        let (gamma, k2, ox, oy) = exit(&here, n, mx[i], my[i], mz[i]);
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
    (nkept, nhit)
}

/// What [`find_hits`] and the weights give at one incidence, for [`add_hits`].
struct Hits<'a, W> {
    /// The kept rays' positions in the chunk.
    kept: &'a [u16],
    /// Each ray's cell.
    cells: &'a [u32],
    /// Per ray that some cone contains: its position in `kept` and its cone mask.
    hits: &'a [(u16, u64)],
    /// Per hit, its cell's first block.
    firsts: &'a [u32],
    /// Per hit, its weight.
    weights: &'a [W],
    /// The kept rays.
    rays: &'a HitRays,
}

/// Adds each hit of incidence `ii` to the cones that contain it, in the cell's order
/// ([`trace_chunk`]).
#[inline(always)]
fn add_hits<A: Accumulator, L: Lanes>(
    setup: &Setup<'_>,
    ii: usize,
    h: &Hits<'_, A::Weight>,
    acc: &A,
    p: &mut Partial,
    lanes: L,
) {
    let (ndet, channels) = (setup.ndet, acc.channels());
    let (index, inc) = (&setup.index, &setup.incs[ii]);
    let base = ii * ndet;
    // This incidence's sums and counts, and what follows them (the next
    // incidence's, and the padding of `LANES` past the last).
    let sums_all = &mut p.sums[base * channels..];
    let counts_all = &mut p.counts[base..];
    for ((&(k, mut mask), w), &first) in h.hits.iter().zip(h.weights).zip(h.firsts) {
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
            let (runs, detectors) = (index.runs(first as usize), index.detectors(first as usize));
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
                    let s: &mut [f64; LANES] = (&mut sums[j..j + LANES]).try_into().expect("LANES");
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
        let ray = &h.rays.get(k);
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
            let cell = h.cells[usize::from(h.kept[k])] as usize;
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

#[cfg(test)]
mod tests {
    use super::*;
    use flakescatter_optics::flake::FlakeReflectance;
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
                            flake: flake.clone(),
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
