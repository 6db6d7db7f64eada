//! A grid index from exit directions to the detector cones that may contain them: the
//! cells of [`flakescatter_numerics::cone_grid`] (conventions there: `k·r > cos α`,
//! the `(x, y)` projection of a cone's cap inside the square of half-side
//! `2 sin(α/2)` about its axis), and, for the plain model's kernels, each cell's cones
//! in blocks of [`LANES`] so that a direction is tested against eight at once.

use flakescatter_numerics::cone_grid::{ConeGrid, ConeSpec};
use flakescatter_optics::detector::Cone;

use crate::simd::{Block, LANES, Lanes};

pub(crate) use flakescatter_numerics::cone_grid::{COARSE, Entry, FINE, Grid};

/// [`ConeIndex::runs`] of a block whose detectors are not consecutive.
pub(crate) const NO_RUN: u32 = u32::MAX;

/// A cone as [`ConeGrid`] takes it.
pub(crate) fn spec(c: &Cone) -> ConeSpec {
    let a = c.axis();
    ConeSpec {
        axis: [a.x, a.y, a.z],
        half_angle: c.half_angle(),
        cos_half_angle: c.cos_half_angle(),
    }
}

/// The cells of a [`ConeGrid`] and their blocks.
#[derive(Debug, Clone)]
pub(crate) struct ConeIndex {
    grid: ConeGrid,
    /// Per cell of at most 64 entries, its entries in blocks of [`LANES`] (entry `k`
    /// of the cell is lane `k % LANES` of block `k / LANES`), CSR layout with
    /// `block_offsets`; none for an index with a margin, which the blocks' test
    /// (`cos_alpha`) would not honour.
    blocks: Vec<Block>,
    block_offsets: Vec<u32>,
    /// The detector of each block's lanes: lane `l` of block `b` at `LANES·b + l`
    /// ([`Entry::index`]; 0 in unused lanes).
    block_detectors: Vec<u32>,
    /// Per block, its first lane's detector `j` when its used lanes hold the
    /// consecutive detectors `j, j + 1, …` (in-plane sweeps), else [`NO_RUN`].
    block_runs: Vec<u32>,
}

impl ConeIndex {
    /// Builds the index for `cones` (all with `α > 0`).
    pub fn new(cones: &[Cone]) -> Self {
        Self::with_margin(cones, 0.0, FINE)
    }

    /// Builds the index for `cones` widened by `margin` radians, with cells
    /// `cells_per_chord` to the narrowest cone's chord ([`ConeGrid::new`]). An index
    /// without margin counts each entry's share of the cells' memory at its worst, a
    /// block of its own (292 bytes with its detectors and run, six entries' worth).
    pub fn with_margin(cones: &[Cone], margin: f64, cells_per_chord: f64) -> Self {
        let with_blocks = margin == 0.0;
        let per_entry = if with_blocks {
            // A block, its lanes' detectors and its run.
            let block = std::mem::size_of::<Block>() + (LANES + 1) * std::mem::size_of::<u32>();
            1.0 + (block as f64 / std::mem::size_of::<Entry>() as f64)
        } else {
            1.0
        };
        let specs: Vec<ConeSpec> = cones.iter().map(spec).collect();
        let grid = ConeGrid::new(&specs, margin, cells_per_chord, per_entry);
        let cells = grid.side() * grid.side();
        let mut blocks = Vec::new();
        let mut block_detectors = Vec::new();
        let mut block_runs = Vec::new();
        let mut block_offsets = Vec::with_capacity(cells + 2);
        block_offsets.push(0u32);
        for c in 0..=cells {
            let list = grid.cell_entries(c);
            let blocked = if with_blocks && list.len() <= 64 {
                list
            } else {
                &[]
            };
            for part in blocked.chunks(LANES) {
                let mut b = Block::empty();
                let mut detectors = [0; LANES];
                for (l, e) in part.iter().enumerate() {
                    (b.ax[l], b.ay[l], b.az[l], b.cos_alpha[l]) = (e.ax, e.ay, e.az, e.cos_alpha);
                    detectors[l] = e.index;
                }
                blocks.push(b);
                block_detectors.extend(detectors);
                let run = part.iter().zip(part[0].index..).all(|(e, j)| e.index == j);
                block_runs.push(if run { part[0].index } else { NO_RUN });
            }
            block_offsets.push(blocks.len() as u32);
        }
        Self {
            grid,
            blocks,
            block_offsets,
            block_detectors,
            block_runs,
        }
    }

    /// The candidate cones for a direction with horizontal components `(x, y)`.
    #[inline]
    pub fn candidates(&self, x: f64, y: f64) -> &[Entry] {
        self.grid.candidates(x, y)
    }

    /// The cell of a direction with horizontal components `(x, y)` ([`ConeGrid::cell`]).
    #[cfg(test)]
    pub fn cell(&self, x: f64, y: f64) -> usize {
        self.grid.cell(x, y)
    }

    /// The grid's geometry and which cells list cones ([`ConeGrid::listed`]).
    #[inline]
    pub fn listed(&self) -> (Grid, &[u32]) {
        self.grid.listed()
    }

    /// A cell that lists no cone, outside the grid (for rays that leave no exit).
    #[inline]
    pub fn empty_cell(&self) -> u32 {
        self.grid.empty_cell()
    }

    /// The entries of `cell` in blocks of [`LANES`] ([`Block`]).
    #[cfg(test)]
    pub fn cell_blocks(&self, cell: usize) -> &[Block] {
        &self.blocks[self.block_range(cell)]
    }

    /// The positions of `cell`'s blocks among all blocks (empty for a cell without).
    #[inline(always)]
    pub fn block_range(&self, cell: usize) -> std::ops::Range<usize> {
        self.block_offsets[cell] as usize..self.block_offsets[cell + 1] as usize
    }

    /// Per block from position `first` on: the detector of its first lane when its
    /// used lanes hold consecutive detectors, else [`NO_RUN`].
    #[inline(always)]
    pub fn runs(&self, first: usize) -> &[u32] {
        &self.block_runs[first..]
    }

    /// The detectors of the entries of the blocks from position `first` on: entry `e`
    /// of a cell whose blocks start at `first` ([`ConeIndex::block_range`]) is detector
    /// `detectors(first)[e]`, bit `e` of its [`ConeIndex::inside_mask_of`].
    #[inline(always)]
    pub fn detectors(&self, first: usize) -> &[u32] {
        &self.block_detectors[first * LANES..]
    }

    /// [`ConeIndex::inside_mask_of`] with the cell's own block range.
    #[cfg(test)]
    pub fn inside_mask<L: Lanes>(&self, lanes: L, cell: usize, x: f64, y: f64, z: f64) -> u64 {
        self.inside_mask_of(lanes, cell, self.block_range(cell), x, y, z)
    }

    /// The mask of the cones of `cell` (bit `k` for its entry `k`), whose
    /// [`ConeIndex::block_range`] is `range`, that contain the direction `(x, y, z)`
    /// (`cos_alpha`, without the margin), for a cell of at most 64 entries in an index
    /// without margin; otherwise all ones, and the caller tests the entries one by one
    /// (which gives the same cones, in the same order, for a mask that is all ones
    /// because all 64 contain the direction).
    #[inline(always)]
    pub fn inside_mask_of<L: Lanes>(
        &self,
        lanes: L,
        cell: usize,
        range: std::ops::Range<usize>,
        x: f64,
        y: f64,
        z: f64,
    ) -> u64 {
        if range.is_empty() && !self.grid.cell_entries(cell).is_empty() {
            return u64::MAX;
        }
        let mut mask = 0u64;
        for (b, block) in self.blocks[range].iter().enumerate() {
            mask |= lanes.inside(block, x, y, z) << (b * LANES);
        }
        mask
    }

    /// The cones listed in `cell` (from [`ConeIndex::cell`]).
    #[inline]
    pub fn cell_entries(&self, cell: usize) -> &[Entry] {
        self.grid.cell_entries(cell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::Portable;
    use rand::{RngExt, SeedableRng};

    /// Every (direction, cone) pair that `Cone::contains` accepts is found through the
    /// index, and with a margin every pair within `α + margin`: brute force over all
    /// cones is the independent reference. The cones include axes near the horizon
    /// (where a cone's projection is most compressed, so the cells' `z` test of
    /// `may_reach` of `flakescatter_numerics::cone_grid` cuts most); the directions are concentrated near the cones' rims,
    /// and their `z` is formed from `(x, y)` as the models form it.
    #[test]
    fn index_finds_every_containing_cone() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut cones = Vec::new();
        for d in -140..=140 {
            cones.push(
                Cone::in_plane(f64::from(d) * 0.5f64.to_radians(), 1.5f64.to_radians()).unwrap(),
            );
        }
        for _ in 0..200 {
            let t = rng.random_range(0.0..1.5);
            let p = rng.random_range(-3.2..3.2);
            let a = rng.random_range(0.001..0.3);
            cones.push(Cone::out_of_plane(t, p, a).unwrap());
        }
        for _ in 0..40 {
            let t = rng.random_range(1.45..std::f64::consts::FRAC_PI_2 - 1e-4);
            let p = rng.random_range(-3.2..3.2);
            let a = rng.random_range(0.002..0.05);
            cones.push(Cone::out_of_plane(t, p, a).unwrap());
        }
        #[cfg(target_arch = "x86_64")]
        let v4 = crate::simd::testing::avx512_or_note("index_finds_every_containing_cone");
        for (margin, per_chord) in [(0.0, FINE), (0.0, COARSE), (0.01, COARSE), (0.01, FINE)] {
            let index = ConeIndex::with_margin(&cones, margin, per_chord);
            let (mut hits, mut blocked, mut multi) = (0, 0, 0);
            let (mut wide_checked, mut in_runs) = (0, 0);
            for _ in 0..40_000 {
                let c = &cones[rng.random_range(0..cones.len())];
                let (u, v) = flakescatter_optics::detector::orthonormal_frame(c.axis());
                let beta = (c.half_angle() + margin) * rng.random_range(0.9..1.1);
                let psi = rng.random_range(0.0..std::f64::consts::TAU);
                let k = c.axis().into_inner() * beta.cos()
                    + (u.into_inner() * psi.cos() + v.into_inner() * psi.sin()) * beta.sin();
                let k = flakescatter_optics::UnitVec3::new_normalize(k);
                let r2 = k.x * k.x + k.y * k.y;
                if k.z <= 0.0 || r2 >= 1.0 {
                    continue;
                }
                let kz = (1.0 - r2).sqrt();
                let mut found: Vec<u32> = index
                    .candidates(k.x, k.y)
                    .iter()
                    .filter(|e| e.ax * k.x + e.ay * k.y + e.az * kz > e.cos_reach)
                    .map(|e| e.index)
                    .collect();
                found.sort_unstable();
                let kk = flakescatter_optics::Vec3::new(k.x, k.y, kz);
                let truth: Vec<u32> = (0..cones.len() as u32)
                    .filter(|&j| {
                        let c = &cones[j as usize];
                        if margin == 0.0 {
                            c.contains(&flakescatter_optics::UnitVec3::new_unchecked(kk))
                        } else {
                            c.axis().dot(&kk) > (c.half_angle() + margin).cos()
                        }
                    })
                    .collect();
                hits += truth.len();
                assert_eq!(
                    found, truth,
                    "margin {margin}, {per_chord} cells per chord, k = {kk:?}"
                );
                // The blocked lists give the same cones without a margin: bit `e` of the
                // mask for entry `e` of the cell, its detector from the block.
                let cell = index.cell(k.x, k.y);
                let mask = index.inside_mask(Portable, cell, k.x, k.y, kz);
                // The box filter keeps every direction that some cone contains.
                let (grid, _) = index.listed();
                if !truth.is_empty() {
                    assert_eq!(grid.boxed_cell(k.x, k.y) as usize, cell, "k = {kk:?}");
                }
                // The AVX-512 test of the blocks gives the portable one's bits.
                #[cfg(target_arch = "x86_64")]
                if let Some(v4) = v4 {
                    let wide =
                        pulp::Simd::vectorize(v4, || index.inside_mask(v4, cell, k.x, k.y, kz));
                    assert_eq!(wide, mask, "AVX-512 blocks, k = {kk:?}");
                    wide_checked += 1;
                }
                if margin == 0.0 && mask != u64::MAX {
                    let blocks = index.cell_blocks(cell);
                    assert_eq!(blocks.len(), index.cell_entries(cell).len().div_ceil(LANES));
                    let detectors = index.detectors(index.block_range(cell).start);
                    let mut by_mask: Vec<u32> = (0..64)
                        .filter(|e| mask >> e & 1 == 1)
                        .map(|e| detectors[e])
                        .collect();
                    // In the cell's order, which the sums' bits depend on.
                    let in_order: Vec<u32> = index
                        .cell_entries(cell)
                        .iter()
                        .filter(|e| e.contains(k.x, k.y, kz))
                        .map(|e| e.index)
                        .collect();
                    assert_eq!(by_mask, in_order, "order of the blocks, k = {kk:?}");
                    // A block with a run holds the consecutive detectors from it.
                    let runs = index.runs(index.block_range(cell).start);
                    for e in (0..64).filter(|e| mask >> e & 1 == 1) {
                        if runs[e / LANES] != NO_RUN {
                            assert_eq!(detectors[e], runs[e / LANES] + (e % LANES) as u32);
                            in_runs += 1;
                        }
                    }
                    multi += usize::from(blocks.len() > 1);
                    by_mask.sort_unstable();
                    assert_eq!(
                        by_mask, truth,
                        "blocks, {per_chord} cells per chord, k = {kk:?}"
                    );
                    blocked += 1;
                }
            }
            assert!(
                hits > 20_000,
                "the test must exercise many containments ({hits})"
            );
            assert!(
                margin > 0.0 || (blocked > 20_000 && multi > 1000 && in_runs > 20_000),
                "blocked lists tested {blocked} times, {multi} of more than one block, \
                 {in_runs} cones found in runs"
            );
            #[cfg(target_arch = "x86_64")]
            if v4.is_some() {
                assert!(
                    wide_checked > 20_000,
                    "AVX-512 masks tested {wide_checked} times"
                );
            }
            let _ = wide_checked;
        }
    }

    /// A narrow cone beside many wide ones would give lists of millions of entries at
    /// the narrow cone's cell size (200 cones of α = 0.5 over cells of 2/1024: about
    /// 200 × (2 · 2 sin 0.25 / (2/1024))² ≈ 6 · 10⁷); the cells are made coarser until
    /// the lists fit in `MAX_ENTRIES`, and the narrow cone is still found.
    #[test]
    fn wide_cones_beside_a_narrow_one_keep_the_index_small() {
        let narrow = Cone::in_plane(0.2, 0.001).unwrap();
        let mut cones = vec![narrow];
        for k in 0..200 {
            let t = 0.1 + 1.2 * f64::from(k) / 200.0;
            cones.push(Cone::out_of_plane(t, f64::from(k), 0.5).unwrap());
        }
        let index = ConeIndex::new(&cones);
        assert!(
            index.grid.entries().len() as f64 <= flakescatter_numerics::cone_grid::MAX_ENTRIES,
            "{}",
            index.grid.entries().len()
        );
        assert!(index.grid.side() < 1024, "side {}", index.grid.side());
        let k = narrow.axis();
        assert!(index.candidates(k.x, k.y).iter().any(|e| e.index == 0));
    }

    /// `listed` marks exactly the cells that list cones, the empty cell past the grid
    /// lists none and marks itself (so a lost ray sent there is never taken for one in
    /// the grid), the grid's last cell, a corner outside the unit disc that no direction
    /// projects into, lists nothing although the corner cone's bounding square covers
    /// it, and the cell of a direction is the integer formula
    /// `min(⌊(v + 1)·side/2⌋, side − 1)` per axis (0 below and for NaN).
    #[test]
    fn listed_cells_and_the_cell_formula() {
        let corner = Cone::out_of_plane(1.45, std::f64::consts::FRAC_PI_4, 0.5).unwrap();
        let index = ConeIndex::new(&[corner, Cone::in_plane(0.3, 0.05).unwrap()]);
        let (grid, listed) = index.listed();
        let empty = index.empty_cell();
        assert_eq!(listed.len(), empty as usize + 1);
        assert_eq!(listed[empty as usize], empty);
        assert!(index.cell_entries(empty as usize).is_empty());
        // The corner cone (axis at 1.45 rad from the zenith towards x = y, α = 0.5)
        // has the bounding square (|a.x − x|, |a.y − y| < 2 sin(α/2) ≈ 0.49) of
        // a.x = a.y ≈ 0.70, so it reaches the corner x = y = 1, whose cell (of side
        // 0.25 or less) is wholly outside the unit disc.
        let a = corner.axis();
        assert!(1.0 - a.x < 0.49 && 1.0 - a.y < 0.49, "{a:?}");
        assert!(index.cell_entries(empty as usize - 1).is_empty());
        assert!(index.grid.side() >= 8);
        for (c, &l) in listed[..empty as usize].iter().enumerate() {
            assert_eq!(l != empty, !index.cell_entries(c).is_empty(), "cell {c}");
            assert!(l == empty || l as usize == c);
        }
        let side = index.grid.side();
        let formula = |v: f64| {
            let t = ((v + 1.0) * side as f64 / 2.0).floor();
            if t.is_nan() || t < 0.0 {
                0
            } else {
                (t as usize).min(side - 1)
            }
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut values: Vec<f64> = (0..20_000).map(|_| rng.random_range(-1.2..1.2)).collect();
        values.extend([f64::NAN, -1.0, 1.0, 0.0, -0.0, 1e300, -1e300, f64::INFINITY]);
        values.extend((0..=side).map(|k| 2.0 * k as f64 / side as f64 - 1.0));
        // Directions near the two cones' axes, for the box filter.
        let (a, b) = (*corner.axis(), *Cone::in_plane(0.3, 0.05).unwrap().axis());
        for _ in 0..20_000 {
            let (x, y) = if rng.random_range(0..2) == 0 {
                (a.x, a.y)
            } else {
                (b.x, b.y)
            };
            values.push(x + rng.random_range(-0.6..0.6));
            values.push(y + rng.random_range(-0.6..0.6));
        }
        let (mut boxed, mut outside) = (0, 0);
        for pair in values.chunks(2) {
            let (x, y) = (pair[0], pair[pair.len() - 1]);
            let want = formula(y) * side + formula(x);
            assert_eq!(grid.cell(x, y) as usize, want, "({x}, {y})");
            assert_eq!(index.cell(x, y), want);
            // The box filter gives the cell, or the empty cell for a cell that lists
            // nothing.
            let in_box = grid.boxed_cell(x, y);
            if in_box == empty {
                assert_eq!(listed[want], empty, "({x}, {y}) left out of the box");
                outside += 1;
            } else {
                assert_eq!(in_box as usize, want, "({x}, {y})");
                boxed += 1;
            }
        }
        assert!(
            boxed > 1000 && outside > 1000,
            "{boxed} in the box, {outside} outside"
        );
    }
}
