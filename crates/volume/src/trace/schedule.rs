//! The order of work of a run (module docs, "Order of work"): sweeps of rays sorted
//! along a Z-order curve, chunks handed to the threads one at a time, and their sums
//! taken back in chunk order.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

use rayon::prelude::*;

use super::BATCHES;
use super::ray::{Partial, Run};
use super::reduce::Acc;

/// Most rays whose entry points are sorted together (a sweep).
pub(super) const SWEEP_RAYS: u64 = 1 << 20;

/// Rays per chunk of a sorted sweep (the unit of work handed to a thread).
const CHUNK_RAYS: usize = 4096;

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

    /// Traces every incidence `theta_i` (radians) into the run's cones in rounds of
    /// sweeps (module docs, "Order of work"), calling `progress(done, total)` from the
    /// calling thread as chunks finish: per incidence, the ordered reduction of its
    /// batches, and the segments traced in all.
    pub(super) fn trace(
        &self,
        theta_i: &[f64],
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> (Vec<Acc>, u64) {
        let run = self;
        let rays = self.rays;
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
        (acc, segments)
    }
}
