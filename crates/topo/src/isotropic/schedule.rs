//! The scheduler of the isotropic model and its reduction (module docs of [`super`],
//! "Tabulation and its error", "Uncertainty and determinism"): batches of tiles whose
//! deposits are made in parallel; the table nodes a batch needs that are not computed
//! yet, computed in parallel (a node's value does not depend on when it is computed);
//! what the contraction needs per cell and odd node; the tiles' contraction with the
//! table under the kernel layer's dispatch; and the tile sums reduced in tile order
//! while the next batch's deposits are made.

use std::ops::Range;

use flakescatter_optics::polarization::Weighting;
use rayon::prelude::*;

use super::response::{IsoSetup, RingScratch};
use super::table::{
    CellInfo, DepositRule, NodeResponse, Row, Run, TileDeposit, TileScratch, cell_info,
    deposit_tile, odd_defect,
};
use crate::TopoModel;
use crate::model::TileStats;
use crate::simd::{Kernels, LANES, Lanes, dispatch};
use crate::source::HeightSource;

/// Tiles traced between two progress reports.
const BATCH: usize = 256;

/// Sums of one tile.
#[derive(Debug)]
pub(crate) struct IsoPartial {
    sums: Vec<f64>,
    defect: Vec<f64>,
    counts: Vec<u32>,
    usable: u64,
    lost_tir: f64,
    lost_down: f64,
}

/// What the tiles of a run add up to, per (incidence, internal detector) slot: the
/// ordered reduction of the tile sums.
pub(crate) struct IsoSums {
    /// The tile sums' total and Welford `m2`.
    pub stats: TileStats,
    /// The interpolation error estimate, summed without cancellation.
    pub defect: Vec<f64>,
    /// Pixels whose interpolated response is non-zero.
    pub rays: Vec<u64>,
    /// Σ of the lost fractions over pixels and incidences.
    pub lost_tir: f64,
    /// See `lost_tir`.
    pub lost_down: f64,
    /// Usable pixels over all maps.
    pub usable: u64,
    /// Table nodes evaluated, summed over incidences.
    pub nodes: usize,
}

impl IsoSums {
    /// Nothing yet, in `nslots` slots.
    pub fn new(nslots: usize) -> Self {
        Self {
            stats: TileStats::new(nslots),
            defect: vec![0.0; nslots],
            rays: vec![0u64; nslots],
            lost_tir: 0.0,
            lost_down: 0.0,
            usable: 0,
            nodes: 0,
        }
    }

    /// Statistics tiles reduced.
    pub fn tiles(&self) -> u64 {
        self.stats.count()
    }

    /// The next tile's sums, interpolation-error sums and lost fractions, in tile
    /// order (one slot per sum).
    pub fn add_floats(&mut self, sums: &[f64], defect: &[f64], lost_tir: f64, lost_down: f64) {
        let nslots = self.defect.len();
        self.stats.add(&sums[..nslots]);
        self.lost_tir += lost_tir;
        self.lost_down += lost_down;
        for (d, &v) in self.defect.iter_mut().zip(&defect[..nslots]) {
            *d += v;
        }
    }

    /// The next tile, in tile order.
    pub fn add_partial(&mut self, p: &IsoPartial) {
        self.add_floats(&p.sums, &p.defect, p.lost_tir, p.lost_down);
        self.usable += p.usable;
        for (r, &c) in self.rays.iter_mut().zip(&p.counts) {
            *r += u64::from(c);
        }
    }
}

impl IsoPartial {
    /// The tile's row of a `TileSums` (sums, interpolation-error sums, lost
    /// fractions) appended to `rows`, and its counts added to `counts`.
    pub fn append_to(&self, rows: &mut Vec<f64>, counts: &mut [u64]) {
        let nslots = counts.len();
        rows.extend_from_slice(&self.sums[..nslots]);
        rows.extend_from_slice(&self.defect[..nslots]);
        rows.extend_from_slice(&[self.lost_tir, self.lost_down]);
        for (r, &c) in counts.iter_mut().zip(&self.counts) {
            *r += u64::from(c);
        }
    }

    /// Usable pixels of the tile.
    pub fn usable(&self) -> u64 {
        self.usable
    }
}

/// The table, per incidence, and what the contraction needs per fine cell and odd
/// node, filled as the batches need them.
struct Table {
    rows: Vec<Vec<Row>>,
    computed: Vec<bool>,
    cells: Vec<Vec<CellInfo>>,
    cells_done: Vec<bool>,
    defects: Vec<Vec<Vec<Run>>>,
    defects_done: Vec<bool>,
    nodes: usize,
    missing: Vec<usize>,
}

impl Table {
    fn new(ninc: usize) -> Self {
        Self {
            rows: (0..ninc).map(|_| Vec::new()).collect(),
            computed: Vec::new(),
            cells: (0..ninc).map(|_| Vec::new()).collect(),
            cells_done: Vec::new(),
            defects: (0..ninc).map(|_| Vec::new()).collect(),
            defects_done: Vec::new(),
            nodes: 0,
            missing: Vec::new(),
        }
    }

    /// The table nodes `deposits` need that are not computed yet, computed in parallel
    /// (each node's value does not depend on when it is computed).
    fn compute_nodes(&mut self, deposits: &[TileDeposit], setup: &IsoSetup<'_>, delta: f64) {
        let ninc = self.rows.len();
        let Self {
            missing, computed, ..
        } = self;
        missing.clear();
        let mut need = |k: usize, computed: &mut Vec<bool>| {
            if k >= computed.len() {
                computed.resize(k + 1, false);
            }
            if !computed[k] {
                computed[k] = true;
                missing.push(k);
            }
        };
        for d in deposits {
            for &(k, _, _) in &d.nodes {
                need(k as usize, computed);
            }
            for &(k, _) in &d.odd {
                let k = k as usize;
                need(k - 1, computed);
                need(k, computed);
                need(k + 1, computed);
            }
            for &(c, _) in &d.cells {
                let c = c as usize;
                for k in c.saturating_sub(2)..=c + 3 {
                    need(k, computed);
                }
            }
        }
        if self.missing.is_empty() {
            return;
        }
        let table_jobs: Vec<(usize, usize)> = self
            .missing
            .iter()
            .flat_map(|&k| (0..ninc).map(move |ii| (ii, k)))
            .collect();
        let fresh: Vec<NodeResponse> = table_jobs
            .par_iter()
            .map_init(RingScratch::default, |sc, &(ii, k)| {
                setup.response(ii, k as f64 * delta, sc)
            })
            .collect();
        self.nodes += fresh.len();
        for r in &mut self.rows {
            if r.len() < self.computed.len() {
                r.resize_with(self.computed.len(), NodeResponse::default);
            }
        }
        for (&(ii, k), resp) in table_jobs.iter().zip(fresh) {
            self.rows[ii][k] = resp;
        }
    }

    /// What the contraction needs per cell and odd node, once each: the new cells and
    /// odd nodes of `deposits`, then their information, one incidence per task.
    fn prepare_cells(&mut self, deposits: &[TileDeposit]) {
        let (mut new_cells, mut new_odd) = (Vec::new(), Vec::new());
        let (cells_done, defects_done) = (&mut self.cells_done, &mut self.defects_done);
        for d in deposits {
            for &(c, _) in &d.cells {
                let c = c as usize;
                if c >= cells_done.len() {
                    cells_done.resize(c + 1, false);
                }
                if !cells_done[c] {
                    cells_done[c] = true;
                    new_cells.push(c);
                }
            }
            for &(k, _) in &d.odd {
                let k = k as usize;
                if k >= defects_done.len() {
                    defects_done.resize(k + 1, false);
                }
                if !defects_done[k] {
                    defects_done[k] = true;
                    new_odd.push(k);
                }
            }
        }
        let (ncells, nodd) = (cells_done.len(), defects_done.len());
        (self.cells.par_iter_mut().zip(&mut self.defects))
            .zip(&self.rows)
            .for_each(|((cells, defects), rows)| {
                cells.resize_with(ncells, CellInfo::default);
                defects.resize_with(nodd, Vec::new);
                for &c in &new_cells {
                    cells[c] = cell_info(rows, c);
                }
                for &k in &new_odd {
                    defects[k] = odd_defect(rows, k);
                }
            });
    }

    /// The contraction of each tile of `deposits` with the table, in parallel, each
    /// under the kernel layer's dispatch ([`contract_tile`]).
    fn contract(&self, deposits: &[TileDeposit], ndet: usize, kernels: Kernels) -> Vec<IsoPartial> {
        deposits
            .par_iter()
            .map(|d| {
                dispatch!(kernels, |lanes| contract_tile(
                    d,
                    &self.rows,
                    &self.cells,
                    &self.defects,
                    ndet,
                    lanes
                ))
            })
            .collect()
    }
}

/// Deposits the tiles numbered `range` of `sources` (band by band, module docs of
/// [`crate::model`], "Streaming"), computes the table nodes they need, contracts each
/// tile with the table and hands the tile sums to `take` in tile order (module docs),
/// for `ndet` internal detectors per incidence of `setup` and node spacing `delta`;
/// `progress` as in [`TopoModel::run_isotropic_with`], in tiles of the range. Returns
/// the valid points of each map's tiles of the range and the table nodes evaluated.
///
/// # Errors
/// [`crate::TopoError::Source`] when a source cannot give a band.
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_range(
    model: &TopoModel,
    sources: &[&dyn HeightSource],
    setup: &IsoSetup<'_>,
    ndet: usize,
    delta: f64,
    range: Range<u64>,
    progress: &(dyn Fn(u64, u64) + Sync),
    take: &mut (dyn FnMut(IsoPartial) + Send),
) -> Result<(Vec<u64>, usize), crate::TopoError> {
    let opts = model.options();
    let kernels = model.kernels();
    let ninc = setup.incs.len();
    // Nodes 0..=kmax cover θ up to π/2 with the neighbours the deposits use.
    let kmax = (std::f64::consts::FRAC_PI_2 * setup.inv_delta).ceil() as usize + 4;
    let mut table = Table::new(ninc);
    let total = range.end - range.start;
    let h = opts.window / 2;
    let physical = opts.weighting == Weighting::Physical;
    // The ordered reduction of a batch's tile sums, run while the next batch's
    // deposits are made (`rayon::join`); returns the tiles reduced so far.
    let mut reduced = 0u64;
    let mut reduce = |partials: Vec<IsoPartial>| {
        for p in partials {
            take(p);
            reduced += 1;
        }
        reduced
    };
    let rule = DepositRule {
        h,
        physical,
        inv_delta: setup.inv_delta,
        kmax,
        kernels,
    };
    let mut pending = Vec::new();
    let valid = model.for_each_batch(sources, range, BATCH, |_, map, batch| {
        // 1. Deposits of the batch's tiles (and the previous batch's reduction).
        let done = std::mem::take(&mut pending);
        let (r, deposits): (u64, Vec<TileDeposit>) = rayon::join(
            || reduce(done),
            || {
                batch
                    .par_iter()
                    .map_init(TileScratch::default, |ts, &rect| {
                        deposit_tile(map, rect, &rule, ts)
                    })
                    .collect()
            },
        );
        progress(r, total);
        // 2. The table nodes they need that are not computed yet.
        table.compute_nodes(&deposits, setup, delta);
        // 3. What the contraction needs per cell and odd node.
        table.prepare_cells(&deposits);
        // 4. Contraction with the table (reduced with the next batch's deposits, or
        // after the last batch).
        pending = table.contract(&deposits, ndet, kernels);
    })?;
    progress(reduce(pending), total);
    Ok((valid, table.nodes))
}

/// Contracts one tile's deposits with the table rows (`rows[ii][k]`): per detector the
/// same products and sums, in the same order, as one entry at a time; the rows, odd-node
/// defects and lit detectors go a run of consecutive detectors at a time ([`Run`]),
/// into sums that reach [`LANES`] past the last detector. Always inlined into the body
/// of [`dispatch!`], so that it is compiled for the instruction set it chose.
#[inline(always)]
fn contract_tile<L: Lanes>(
    d: &TileDeposit,
    rows: &[Vec<Row>],
    cells: &[Vec<CellInfo>],
    defects: &[Vec<Vec<Run>>],
    ndet: usize,
    lanes: L,
) -> IsoPartial {
    let ninc = rows.len();
    let mut p = IsoPartial {
        sums: vec![0.0; ninc * ndet + LANES],
        defect: vec![0.0; ninc * ndet + LANES],
        counts: vec![0; ninc * ndet + LANES],
        usable: d.usable,
        lost_tir: 0.0,
        lost_down: 0.0,
    };
    // The edge corrections of one cell's pixels.
    let mut dh: Vec<f64> = Vec::new();
    // The eight sums from detector `j` of a slice that reaches `LANES` past the last.
    fn eight<T>(v: &mut [T], j: u32) -> &mut [T; LANES] {
        let j = j as usize;
        (&mut v[j..j + LANES]).try_into().expect("LANES elements")
    }
    for (ii, table) in rows.iter().enumerate() {
        let base = ii * ndet;
        let sums = &mut p.sums[base..base + ndet + LANES];
        for &(k, g, gn) in &d.nodes {
            let row = &table[k as usize];
            for r in &row.runs {
                lanes.add_scaled(eight(sums, r.start), &r.v, g, r.len as usize);
            }
            p.lost_tir += gn * row.tir;
            p.lost_down += gn * row.down;
        }
        let defect = &mut p.defect[base..base + ndet + LANES];
        for &(k, hat) in &d.odd {
            for r in &defects[ii][k as usize] {
                lanes.add_scaled(eight(defect, r.start), &r.v, hat, r.len as usize);
            }
        }
        // Per fine cell (pixels sorted by cell): pixels whose interpolated response is
        // non-zero, and the edge cells, where the edge-aware interpolation replaces the
        // linear one and the size of that correction is the error estimate.
        let counts = &mut p.counts[base..base + ndet + LANES];
        let mut start = 0;
        for &(c, nc) in &d.cells {
            let info = &cells[ii][c as usize];
            let cell = start..start + nc as usize;
            let (ts, ws) = (&d.pixel_t[cell.clone()], &d.pixel_w[cell]);
            start += nc as usize;
            for &(first, count) in &info.lit {
                lanes.add_count(eight(counts, first), nc, count as usize);
            }
            for e in &info.edges {
                // The corrections in a loop of independent pixels (vectorised), then
                // their sums in raster order, in registers.
                dh.clear();
                dh.extend(ts.iter().zip(ws).map(|(&t, &w)| w * e.correction(t)));
                let det = e.det as usize;
                let (mut s, mut f) = (sums[det], defect[det]);
                for &dh in dh.iter() {
                    if e.apply {
                        s += dh;
                    }
                    f += dh.abs();
                }
                (sums[det], defect[det]) = (s, f);
            }
        }
    }
    p
}
