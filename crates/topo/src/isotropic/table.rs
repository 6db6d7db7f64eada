//! The table of the isotropic model (module docs of [`super`], "Tabulation and its
//! error"): the responses of the nodes `θ_k = k δ` in runs of consecutive detectors, what
//! each tile deposits on the nodes ([`deposit_tile`]), and per fine cell the edges where
//! the square-root law replaces linear interpolation and the error estimate's terms.

use flakescatter_stats::HeightMap;

use crate::normals::{DirectRow, Rect, Scratch, tile_usable};
use crate::simd::{Kernels, LANES};

/// The response of one node at one incidence: `(detector, h_j)` sorted by detector with
/// `h_j > 0`, and the lost fractions of the ring.
#[derive(Debug, Clone, Default)]
pub(crate) struct NodeResponse {
    pub(crate) entries: Vec<(u32, f64)>,
    /// `entries` in runs of consecutive detectors, for the contraction.
    pub(crate) runs: Vec<Run>,
    pub(crate) tir: f64,
    pub(crate) down: f64,
}

/// Up to [`LANES`] consecutive detectors `start, start + 1, …` and their values
/// (zero past `len`): what the contraction adds to eight consecutive sums at once.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Run {
    pub(crate) start: u32,
    pub(crate) len: u32,
    pub(crate) v: [f64; LANES],
}

/// `entries` (sorted by detector) cut into runs of consecutive detectors, at most
/// [`LANES`] long.
pub(crate) fn runs_of(entries: &[(u32, f64)]) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for &(det, v) in entries {
        match runs.last_mut() {
            Some(r) if r.start + r.len == det && (r.len as usize) < LANES => {
                r.v[r.len as usize] = v;
                r.len += 1;
            }
            _ => {
                let mut vs = [0.0; LANES];
                vs[0] = v;
                runs.push(Run {
                    start: det,
                    len: 1,
                    v: vs,
                });
            }
        }
    }
    runs
}

/// One table row: the response of one node at one incidence (empty until computed).
pub(crate) type Row = NodeResponse;

/// One tile's deposits (module docs): area factors and pixel counts on fine nodes,
/// area factors times the hat of the coarse cell on odd nodes, pixels per fine cell;
/// each list in ascending order of its node or cell.
#[derive(Debug, Default)]
pub(crate) struct TileDeposit {
    pub(crate) usable: u64,
    pub(crate) nodes: Vec<(u32, f64, f64)>,
    pub(crate) odd: Vec<(u32, f64)>,
    pub(crate) cells: Vec<(u32, u32)>,
    /// Every pixel's `t` and area factor `w`, grouped by fine cell in the order of
    /// `cells` (raster order within a cell), for the edge cells.
    pub(crate) pixel_t: Vec<f64>,
    pub(crate) pixel_w: Vec<f64>,
}

/// A detector whose response switches on or off inside a fine cell: `h` is zero at one
/// node and not at the other. Near such an edge `h ∝ sqrt(θ − θc)` times a smooth
/// factor, so `h²` is smooth: it is interpolated linearly, from the two nodes on the
/// lit side, as `q(t) = q0 + qs t` (`t ∈ [0, 1]` across the cell, root clamped into
/// the cell), and `h ≈ sqrt(max(q, 0))` replaces the linear `lin0 (1 − t) + lin1 t`.
///
/// The square-root law is applied only where `h²` is nearly straight over the lit
/// side's nodes ([`square_root_edge`]); elsewhere (a ring's arc ending at the horizon,
/// a response narrower than a few cells, or an edge next to another change of shape)
/// the cell stays linear. In both cases the difference between the two interpolations
/// enters the error estimate.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Edge {
    pub(crate) det: u32,
    pub(crate) lin0: f64,
    pub(crate) lin1: f64,
    pub(crate) q0: f64,
    pub(crate) qs: f64,
    pub(crate) apply: bool,
}

impl Edge {
    /// Edge-aware minus linear interpolation at `t`.
    #[inline]
    pub(crate) fn correction(&self, t: f64) -> f64 {
        (self.q0 + self.qs * t).max(0.0).sqrt() - (self.lin0 * (1.0 - t) + self.lin1 * t)
    }
}

/// Whether `h²` at three consecutive lit nodes (nearest the edge first) is straight
/// enough for the square-root law: second difference below a tenth of the first.
/// Edges of another kind (a ring's arc ending at the horizon, where the exit Fresnel
/// factor vanishes) stay linear.
pub(crate) fn square_root_edge(q1: f64, q2: f64, q3: f64) -> bool {
    (q3 - 2.0 * q2 + q1).abs() <= 0.1 * (q2 - q1)
}

/// What the contraction needs per fine cell and incidence, computed once from the rows:
/// the detectors lit at either node (for `rays`) and the edges.
#[derive(Debug, Clone, Default)]
pub(crate) struct CellInfo {
    /// The lit detectors in runs `(first, count)` of at most [`LANES`] consecutive ones.
    pub(crate) lit: Vec<(u32, u32)>,
    pub(crate) edges: Vec<Edge>,
}

/// The cell information of fine cell `c`.
pub(crate) fn cell_info(rows: &[Row], c: usize) -> CellInfo {
    let (r0, r1) = (&rows[c].entries, &rows[c + 1].entries);
    let mut dets: Vec<u32> = r0.iter().chain(r1).map(|e| e.0).collect();
    dets.sort_unstable();
    dets.dedup();
    let mut lit: Vec<(u32, u32)> = Vec::new();
    for det in dets {
        match lit.last_mut() {
            Some((first, count)) if *first + *count == det && (*count as usize) < LANES => {
                *count += 1;
            }
            _ => lit.push((det, 1)),
        }
    }
    CellInfo {
        lit,
        edges: cell_edges(rows, c),
    }
}

/// `|h_k − (h_{k−1} + h_{k+1})/2|` for every detector lit at all three nodes around the
/// odd node `k` (coarse cells holding an edge are covered by the edge terms).
pub(crate) fn odd_defect(rows: &[Row], k: usize) -> Vec<Run> {
    let (a, b, c) = (&rows[k - 1].entries, &rows[k].entries, &rows[k + 1].entries);
    let entries: Vec<(u32, f64)> = b
        .iter()
        .filter_map(|&(det, v)| {
            let (va, vc) = (value_in(a, det), value_in(c, det));
            (va > 0.0 && vc > 0.0).then(|| (det, (v - 0.5 * (va + vc)).abs()))
        })
        .collect();
    runs_of(&entries)
}

/// Value of detector `det` in a sorted row (0 when absent).
pub(crate) fn value_in(row: &[(u32, f64)], det: u32) -> f64 {
    row.binary_search_by_key(&det, |e| e.0)
        .map_or(0.0, |i| row[i].1)
}

/// The edges of fine cell `c` (nodes `c − 2 … c + 3` computed): every detector lit at
/// only one node of the cell, with its square-root model (module docs, [`Edge`]).
pub(crate) fn cell_edges(rows: &[Row], c: usize) -> Vec<Edge> {
    let (r0, r1) = (&rows[c].entries, &rows[c + 1].entries);
    let mut out = Vec::new();
    let (mut i0, mut i1) = (0, 0);
    while i0 < r0.len() || i1 < r1.len() {
        let d0 = r0.get(i0).map_or(u32::MAX, |e| e.0);
        let d1 = r1.get(i1).map_or(u32::MAX, |e| e.0);
        let det = d0.min(d1);
        let v0 = if d0 == det { r0[i0].1 } else { 0.0 };
        let v1 = if d1 == det { r1[i1].1 } else { 0.0 };
        if d0 == det {
            i0 += 1;
        }
        if d1 == det {
            i1 += 1;
        }
        if v0 == 0.0 && v1 > 0.0 {
            let h2 = value_in(&rows[c + 2].entries, det);
            let h3 = value_in(&rows[c + 3].entries, det);
            let slope = h2 * h2 - v1 * v1;
            // h² through nodes c+1, c+2, its root clamped into the cell (to node c
            // when h² does not grow away from the edge).
            let (mut q0, mut qs) = (v1 * v1 - slope, slope);
            if slope <= 0.0 || q0 > 0.0 {
                (q0, qs) = (0.0, v1 * v1);
            }
            let apply = slope > 0.0 && square_root_edge(v1 * v1, h2 * h2, h3 * h3);
            out.push(Edge {
                det,
                lin0: 0.0,
                lin1: v1,
                q0,
                qs,
                apply,
            });
        } else if v0 > 0.0 && v1 == 0.0 {
            let hm = if c > 0 {
                value_in(&rows[c - 1].entries, det)
            } else {
                0.0
            };
            let hmm = if c > 1 {
                value_in(&rows[c - 2].entries, det)
            } else {
                0.0
            };
            let drop = hm * hm - v0 * v0;
            let (q0, mut qs) = (v0 * v0, -drop);
            if drop <= 0.0 || q0 + qs > 0.0 {
                qs = -v0 * v0;
            }
            let apply = drop > 0.0 && c > 1 && square_root_edge(v0 * v0, hm * hm, hmm * hmm);
            out.push(Edge {
                det,
                lin0: v0,
                lin1: 0.0,
                q0,
                qs,
                apply,
            });
        }
    }
    out
}

/// Scratch arrays of the deposits: per node (`g`, `gn`, `hat`) and per fine cell
/// (`cells`), all zero between tiles; per usable pixel of the tile (`slopes`,
/// `coords`), overwritten by each tile.
#[derive(Debug, Default)]
pub(crate) struct TileScratch {
    pub(crate) normals: Scratch,
    pub(crate) direct: DirectRow,
    pub(crate) g: Vec<f64>,
    pub(crate) gn: Vec<f64>,
    pub(crate) hat: Vec<f64>,
    pub(crate) cells: Vec<u32>,
    /// The usable pixels' direct slopes `(a, b)`, raster order.
    pub(crate) slopes: Vec<(f64, f64)>,
    /// Their node coordinates `x` and area factors `w`.
    pub(crate) coords: Vec<(f64, f64)>,
}

/// How every tile of a run deposits its pixels ([`deposit_tile`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DepositRule {
    /// Half the window side.
    pub h: usize,
    /// Whether the weighting is physical (area factor `1/m.z`) or not (1).
    pub physical: bool,
    /// `1/δ`.
    pub inv_delta: f64,
    /// The last node.
    pub kmax: usize,
    /// The kernels of the slopes' sums.
    pub kernels: Kernels,
}

/// The node coordinate `x = θn/δ` of slopes `(a, b)`.
pub(crate) fn node_coordinate(a: f64, b: f64, inv_delta: f64) -> f64 {
    (a * a + b * b).sqrt().atan() * inv_delta
}

/// The deposits of one tile's usable pixels (raster order): for a pixel at node
/// coordinate `x = θn/δ` in fine cell `c = ⌊x⌋` with `t = x − c` and area factor `w`:
/// `w(1 − t)`, `w t` on nodes `c`, `c + 1` (and the same without `w` for the lost
/// fractions); `w · (1 − |1 − 2t'|)` on the odd node `2C + 1` of its coarse cell
/// `C = ⌊x/2⌋`, `t' = x/2 − C` (the shape of the difference between the fine and the
/// coarse interpolation); one pixel in cell `c`.
///
/// The pixels only add (no test of whether a node was touched before: a branch per
/// node that the processor could not predict); the touched nodes and cells are then
/// read off the pixel counts per cell, between the least and greatest cell of the
/// tile: node `k` is touched when cell `k` or `k − 1` holds a pixel, odd node `k`
/// when cell `k` or `k − 1` does (`⌊x/2⌋ = ⌊c/2⌋`, so a pixel's odd node is `c | 1`).
pub(crate) fn deposit_tile(
    map: &HeightMap,
    rect: Rect,
    rule: &DepositRule,
    ts: &mut TileScratch,
) -> TileDeposit {
    let DepositRule {
        h,
        physical,
        inv_delta,
        kmax,
        kernels,
    } = *rule;
    if ts.g.len() < kmax + 1 {
        ts.g.resize(kmax + 1, 0.0);
        ts.gn.resize(kmax + 1, 0.0);
        ts.hat.resize(kmax + 1, 0.0);
        ts.cells.resize(kmax + 1, 0);
    }
    let TileScratch {
        normals,
        direct,
        g,
        gn,
        hat,
        cells,
        slopes,
        coords,
    } = ts;
    let mut pixels = Vec::with_capacity((rect.r1 - rect.r0) * (rect.c1 - rect.c0));
    let mut direct = direct.tile(map, h, rect, kernels);
    // The usable pixels' slopes first, then their node coordinates and area factors
    // in a loop of independent pixels (so that the processor overlaps their `atan`s),
    // then the deposits in raster order.
    slopes.clear();
    tile_usable(map, h, rect, normals, |row, col| {
        slopes.push(direct.slopes(row, col));
    });
    coords.clear();
    coords.extend(slopes.iter().map(|&(a, b)| {
        let w = if physical {
            (1.0 + a * a + b * b).sqrt()
        } else {
            1.0
        };
        (node_coordinate(a, b, inv_delta), w)
    }));
    // The least and greatest cell of the tile's pixels.
    let (mut lo, mut hi) = (usize::MAX, 0);
    for &(x, w) in coords.iter() {
        let c = x as usize;
        let t = x - c as f64;
        for (k, f) in [(c, 1.0 - t), (c + 1, t)] {
            g[k] += w * f;
            gn[k] += f;
        }
        cells[c] += 1;
        pixels.push((c as u32, t, w));
        let x2 = 0.5 * x;
        let cc = x2 as usize;
        let t2 = x2 - cc as f64;
        hat[2 * cc + 1] += w * (1.0 - (1.0 - 2.0 * t2).abs());
        (lo, hi) = (lo.min(c), hi.max(c));
    }
    let usable = coords.len() as u64;
    let mut d = TileDeposit {
        usable,
        nodes: Vec::new(),
        odd: Vec::new(),
        cells: Vec::new(),
        pixel_t: Vec::new(),
        pixel_w: Vec::new(),
    };
    if usable == 0 {
        return d;
    }
    let held = |c: usize, cells: &[u32]| c >= lo && c <= hi && cells[c] > 0;
    for k in lo..=hi + 1 {
        if held(k, cells) || (k > 0 && held(k - 1, cells)) {
            d.nodes.push((k as u32, g[k], gn[k]));
        }
        (g[k], gn[k]) = (0.0, 0.0);
    }
    for k in (lo | 1..=hi | 1).step_by(2) {
        if held(k, cells) || held(k - 1, cells) {
            d.odd.push((k as u32, hat[k]));
        }
        hat[k] = 0.0;
    }
    // Pixels grouped by cell (stable: raster order within a cell), cells ascending: a
    // counting sort, each cell's count turned into its first slot, the pixels placed
    // in the order they came.
    let mut first = 0u32;
    for (c, slot) in (lo..).zip(&mut cells[lo..=hi]) {
        let count = *slot;
        if count > 0 {
            d.cells.push((c as u32, count));
            *slot = first;
            first += count;
        }
    }
    let (mut pixel_t, mut pixel_w) = (vec![0.0; pixels.len()], vec![0.0; pixels.len()]);
    for &(c, t, w) in &pixels {
        let slot = &mut cells[c as usize];
        (pixel_t[*slot as usize], pixel_w[*slot as usize]) = (t, w);
        *slot += 1;
    }
    (d.pixel_t, d.pixel_w) = (pixel_t, pixel_w);
    cells[lo..=hi].fill(0);
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs hold consecutive detectors only, at most `LANES` of them, every entry once
    /// and in order, with zeros past their length.
    #[test]
    fn runs_cut_rows_at_gaps_and_at_eight() {
        let dets = [3, 4, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 40];
        let entries: Vec<(u32, f64)> = dets.iter().map(|&d| (d, f64::from(d) + 0.5)).collect();
        let runs = runs_of(&entries);
        let shape: Vec<(u32, u32)> = runs.iter().map(|r| (r.start, r.len)).collect();
        assert_eq!(shape, [(3, 2), (6, 8), (14, 3), (40, 1)]);
        let back: Vec<(u32, f64)> = runs
            .iter()
            .flat_map(|r| (0..r.len).map(move |l| (r.start + l, r.v[l as usize])))
            .collect();
        assert_eq!(back, entries);
        assert!(
            runs.iter()
                .all(|r| r.v[r.len as usize..].iter().all(|&v| v == 0.0))
        );
    }
}
