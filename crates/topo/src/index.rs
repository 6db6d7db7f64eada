//! A grid index from exit directions to the detector cones that may contain them.
//!
//! Conventions: exit directions `k_out` are unit vectors in air with `k_out.z > 0`; a
//! cone of half-angle `α` about the axis `r` contains `k` when `k·r > cos α` (paper
//! eq. 15, [`Cone::contains`]). Every direction in that cone is within the chord
//! `|k − r| < 2 sin(α/2)` of the axis, so its `(x, y)` projection lies in the square of
//! half-side `2 sin(α/2)` about `(r.x, r.y)`. The index is a uniform grid over
//! `(k.x, k.y) ∈ [−1, 1]²`; each cell lists the cones whose square overlaps it, so a ray
//! tests only the cones of its own cell (for in-plane detectors, a ray out of the plane
//! lands in an empty cell and is rejected with one lookup).

use flakescatter_optics::detector::Cone;

use crate::simd::{Block, LANES, Lanes};

/// One cone as the inner loop needs it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Entry {
    pub ax: f64,
    pub ay: f64,
    pub az: f64,
    pub cos_alpha: f64,
    /// `cos(α + margin)`: directions with `k·r` above it are within `margin` of the
    /// cone (equal to `cos_alpha` for an index built without margin).
    pub cos_reach: f64,
    pub index: u32,
}

impl Entry {
    /// Whether the cone contains the direction `(x, y, z)`: `ax·x + ay·y + az·z >
    /// cos α` ([`Cone::contains`] on the models' exit directions).
    #[inline(always)]
    pub fn contains(&self, x: f64, y: f64, z: f64) -> bool {
        self.ax * x + self.ay * y + self.az * z > self.cos_alpha
    }
}

/// [`ConeIndex::runs`] of a block whose detectors are not consecutive.
pub(crate) const NO_RUN: u32 = u32::MAX;

/// The geometry of a [`ConeIndex`]'s grid, and the box of its cells that list cones.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    /// Cells per unit of `x` or `y` (`side/2`).
    inv_cell: f64,
    /// `side − 1`.
    last: f64,
    /// Cells per axis.
    side: f64,
    /// The cells that list cones have columns `ix` in `[x_lo, x_hi)` and rows `iy` in
    /// `[y_lo, y_hi)` (integers; an empty range when no cell lists a cone).
    x_lo: f64,
    x_hi: f64,
    y_lo: f64,
    y_hi: f64,
    /// [`ConeIndex::empty_cell`].
    empty: u32,
}

impl Grid {
    /// The cell of `(x, y)`: `(v + 1)·side/2` clamped to `[0, side − 1]` in floating
    /// point and truncated, for `v = x` and `y`, combined as `iy·side + ix` (exact
    /// integers far below 2⁵²); an integer-valued `t` in `[0, 2³²)` plus 2⁵² is exact
    /// with `t` in the low bits of its representation: a conversion without the checks
    /// of `as`.
    #[inline(always)]
    pub fn cell(self, x: f64, y: f64) -> u32 {
        self.combine(self.at(x).trunc(), self.at(y).trunc())
    }

    /// The cell of `(x, y)` ([`Grid::cell`]) if it lies in the box of the cells that list
    /// cones, else the empty cell: a cheap first filter, without a table lookup (a cell
    /// inside the box may still list nothing). `⌊t⌋` is in `[lo, hi)` exactly when `t`
    /// is, for integers `lo`, `hi` and `t ≥ 0`, so the test is made on the clamped `t`.
    #[inline(always)]
    pub fn boxed_cell(self, x: f64, y: f64) -> u32 {
        let (tx, ty) = (self.at(x), self.at(y));
        let inside = (tx >= self.x_lo) & (tx < self.x_hi) & (ty >= self.y_lo) & (ty < self.y_hi);
        if inside {
            self.combine(tx.trunc(), ty.trunc())
        } else {
            self.empty
        }
    }

    /// `(v + 1)·side/2` clamped to `[0, side − 1]` (NaN to 0).
    #[inline(always)]
    fn at(self, v: f64) -> f64 {
        ((v + 1.0) * self.inv_cell).max(0.0).min(self.last)
    }

    /// `iy·side + ix` for integer-valued `ix`, `iy` in `[0, side)`.
    #[inline(always)]
    fn combine(self, ix: f64, iy: f64) -> u32 {
        const INT: f64 = 4_503_599_627_370_496.0;
        (iy * self.side + ix + INT).to_bits() as u32
    }
}

/// Cells per chord of the narrowest cone for [`ConeIndex::new`]: with the default 281
/// in-plane cones of 1.5° and the benchmark's surface, the rays that land in a cell that
/// lists cones test 5.3 candidates each instead of 12.3 with cells of the chord's size,
/// and 15 % of the rays land in one instead of 19 %. Finer cells gain little more, and
/// cost more to build.
pub(crate) const FINE: f64 = 4.0;

/// Cells per chord of the narrowest cone for the isotropic model's indexes: it queries
/// an index a few times per table node, and five fine ones (one per incidence) cost it
/// more to build than they save.
pub(crate) const COARSE: f64 = 1.0;

/// The most cone entries (about 48 bytes each) the cell lists may hold in all before
/// [`ConeIndex::with_margin`] makes its cells coarser; an index with blocks counts
/// each entry's share of them at its worst, a block of its own (292 bytes with its
/// detectors and run, six entries' worth).
const MAX_ENTRIES: f64 = 1_048_576.0;

/// Whether some unit direction `k` (with `k.z ≥ 0`) projecting into the cell
/// `[x0, x1] × [y0, y1]` may lie within the chord `reach` of the unit axis `a`.
///
/// A necessary condition, so that a cone is never left out of a cell it reaches:
/// `|k − a|² = (k.x − a.x)² + (k.y − a.y)² + (k.z − a.z)²` is at least the sum of each
/// term's least value over the cell, where `k.z = √(1 − k.x² − k.y²)` spans
/// `[√(1 − r²max), √(1 − r²min)]` with `r²` the cell's least and greatest squared
/// distance from the origin (widened by 10⁻¹² under the root, which covers the
/// rounding of `1 − r²` near the horizon). A cell wholly outside the unit disc holds
/// no direction at all.
fn may_reach((x0, x1): (f64, f64), (y0, y1): (f64, f64), a: [f64; 3], reach: f64) -> bool {
    // Distance from `v` to `[lo, hi]`, and the least and greatest `|v|` over it.
    let gap = |v: f64, lo: f64, hi: f64| (lo - v).max(v - hi).max(0.0);
    let least = |lo: f64, hi: f64| gap(0.0, lo, hi);
    let most = |lo: f64, hi: f64| lo.abs().max(hi.abs());
    let r2_min = least(x0, x1).powi(2) + least(y0, y1).powi(2);
    if r2_min > 1.0 + 1e-12 {
        return false;
    }
    let r2_max = most(x0, x1).powi(2) + most(y0, y1).powi(2);
    let z_hi = (1.0 - r2_min + 1e-12).clamp(0.0, 1.0).sqrt();
    let z_lo = (1.0 - r2_max - 1e-12).max(0.0).sqrt();
    let (dx, dy, dz) = (gap(a[0], x0, x1), gap(a[1], y0, y1), gap(a[2], z_lo, z_hi));
    dx * dx + dy * dy + dz * dz < reach * reach
}

/// Cells of side `cell` over `[−1, 1]²`, CSR layout.
#[derive(Debug, Clone)]
pub(crate) struct ConeIndex {
    side: usize,
    inv_cell: f64,
    offsets: Vec<u32>,
    entries: Vec<Entry>,
    /// Per cell, the empty one past the grid included, the cell itself if it lists
    /// cones, else the empty cell.
    listed: Vec<u32>,
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
    /// The box of the cells that list cones, `[x_lo, x_hi, y_lo, y_hi]` ([`Grid`]).
    listed_box: [f64; 4],
}

impl ConeIndex {
    /// Builds the index for `cones` (all with `α > 0`).
    pub fn new(cones: &[Cone]) -> Self {
        Self::with_margin(cones, 0.0, FINE)
    }

    /// Builds the index for `cones` widened by `margin` radians: a cell lists every cone
    /// whose axis is within `α + margin` of some direction projecting into the cell
    /// (`α + margin < π`), and, of those, only cones that pass the test of
    /// [`may_reach`]: a cone whose bounding square only grazes the cell (its corner, or
    /// the side where the cone's projection is compressed towards the horizon) is not
    /// listed. The cells are `cells_per_chord` to the chord `2 sin((α + margin)/2)` of
    /// the narrowest cone along each axis (within the limits below).
    pub fn with_margin(cones: &[Cone], margin: f64, cells_per_chord: f64) -> Self {
        let chord = |c: &Cone| 2.0 * (0.5 * (c.half_angle() + margin)).sin();
        // A small margin covers rounding at the cap's edge.
        let reach = |c: &Cone| chord(c) * (1.0 + 1e-9) + 1e-12;
        let min_chord = cones.iter().map(chord).fold(f64::INFINITY, f64::min);
        // At most 1024 cells per axis and at least 8, made coarser while the lists would
        // hold more than `MAX_ENTRIES` in all (wide cones beside a narrow one).
        let with_blocks = margin == 0.0;
        let per_entry = if with_blocks {
            // A block, its lanes' detectors and its run.
            let block = std::mem::size_of::<Block>() + (LANES + 1) * std::mem::size_of::<u32>();
            1.0 + (block as f64 / std::mem::size_of::<Entry>() as f64)
        } else {
            1.0
        };
        let cells_of = |cell: f64| {
            per_entry
                * cones
                    .iter()
                    .map(|c| (2.0 * reach(c) / cell + 2.0).powi(2))
                    .sum::<f64>()
        };
        let mut cell = (min_chord / cells_per_chord).clamp(2.0 / 1024.0, 2.0 / 8.0);
        while cell < 2.0 / 8.0 && cells_of(cell) > MAX_ENTRIES {
            cell = (2.0 * cell).min(2.0 / 8.0);
        }
        let side = (2.0 / cell).ceil() as usize;
        let inv_cell = side as f64 / 2.0;
        let to_cell = |v: f64| (((v + 1.0) * inv_cell).floor().max(0.0) as usize).min(side - 1);
        // Cell `i` along an axis holds the values `v` with `(v + 1)·side/2` in `[i, i + 1)`,
        // widened by far more than the rounding of that product.
        let bounds = |i: usize| {
            (
                i as f64 / inv_cell - 1.0 - 1e-12,
                (i + 1) as f64 / inv_cell - 1.0 + 1e-12,
            )
        };
        // (cell, cone) pairs, sorted into the CSR layout: each cell lists its cones in
        // their order.
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let mut by_cone = Vec::with_capacity(cones.len());
        for (j, c) in cones.iter().enumerate() {
            let a = c.axis();
            let half = reach(c);
            let (x0, x1) = (to_cell(a.x - half), to_cell(a.x + half));
            let (y0, y1) = (to_cell(a.y - half), to_cell(a.y + half));
            by_cone.push(Entry {
                ax: a.x,
                ay: a.y,
                az: a.z,
                cos_alpha: c.cos_half_angle(),
                cos_reach: if margin > 0.0 {
                    (c.half_angle() + margin).cos()
                } else {
                    c.cos_half_angle()
                },
                index: j as u32,
            });
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    if may_reach(bounds(ix), bounds(iy), [a.x, a.y, a.z], half) {
                        pairs.push(((iy * side + ix) as u32, j as u32));
                    }
                }
            }
        }
        pairs.sort_unstable();
        let entries: Vec<Entry> = pairs.iter().map(|&(_, j)| by_cone[j as usize]).collect();
        // offsets[c + 1] counts the pairs of cell c, then (prefix sums) ends its list.
        let mut offsets = vec![0u32; side * side + 2];
        for &(cell, _) in &pairs {
            offsets[cell as usize + 1] += 1;
        }
        for c in 0..side * side {
            offsets[c + 1] += offsets[c];
        }
        // The empty cell past the grid lists nothing.
        offsets[side * side + 1] = offsets[side * side];
        let empty = (side * side) as u32;
        // The empty cell lists itself.
        let listed = (0..=side * side)
            .map(|c| {
                if offsets[c] < offsets[c + 1] {
                    c as u32
                } else {
                    empty
                }
            })
            .collect();
        // The box of the cells that list cones (an empty one when none does).
        let mut listed_box = [side as f64, 0.0, side as f64, 0.0];
        for &(cell, _) in &pairs {
            let (ix, iy) = ((cell as usize % side) as f64, (cell as usize / side) as f64);
            listed_box[0] = listed_box[0].min(ix);
            listed_box[1] = listed_box[1].max(ix + 1.0);
            listed_box[2] = listed_box[2].min(iy);
            listed_box[3] = listed_box[3].max(iy + 1.0);
        }
        let mut blocks = Vec::new();
        let mut block_detectors = Vec::new();
        let mut block_runs = Vec::new();
        let mut block_offsets = Vec::with_capacity(offsets.len());
        block_offsets.push(0u32);
        for c in 0..=side * side {
            let list = &entries[offsets[c] as usize..offsets[c + 1] as usize];
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
            side,
            inv_cell,
            offsets,
            entries,
            listed,
            blocks,
            block_offsets,
            block_detectors,
            block_runs,
            listed_box,
        }
    }

    /// The candidate cones for a direction with horizontal components `(x, y)`.
    #[inline]
    pub fn candidates(&self, x: f64, y: f64) -> &[Entry] {
        self.cell_entries(self.cell(x, y))
    }

    /// The cell of a direction with horizontal components `(x, y)`: any values, NaN
    /// included, give a cell of the grid (out-of-range ones are clamped to its edge,
    /// NaN to the first column or row).
    #[inline(always)]
    pub fn cell(&self, x: f64, y: f64) -> usize {
        self.grid().cell(x, y) as usize
    }

    /// The grid's geometry and, per cell (the empty cell past the grid included), the
    /// cell itself if it lists cones, else [`ConeIndex::empty_cell`]: what a ray needs
    /// to know to skip the cones, as plain values that a loop keeps in registers (the
    /// cell of `(x, y)` is `grid.cell(x, y)`, and it lists cones when
    /// `listed[cell] != empty_cell()`).
    #[inline]
    pub fn listed(&self) -> (Grid, &[u32]) {
        (self.grid(), &self.listed)
    }

    /// The grid's geometry.
    #[inline]
    fn grid(&self) -> Grid {
        let [x_lo, x_hi, y_lo, y_hi] = self.listed_box;
        Grid {
            inv_cell: self.inv_cell,
            last: (self.side - 1) as f64,
            side: self.side as f64,
            x_lo,
            x_hi,
            y_lo,
            y_hi,
            empty: self.empty_cell(),
        }
    }

    /// A cell that lists no cone, outside the grid (for rays that leave no exit).
    #[inline]
    pub fn empty_cell(&self) -> u32 {
        (self.side * self.side) as u32
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
        if range.is_empty() && self.offsets[cell] < self.offsets[cell + 1] {
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
        &self.entries[self.offsets[cell] as usize..self.offsets[cell + 1] as usize]
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
    /// [`may_reach`] cuts most); the directions are concentrated near the cones' rims,
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
            index.entries.len() as f64 <= MAX_ENTRIES,
            "{}",
            index.entries.len()
        );
        assert!(index.side < 1024, "side {}", index.side);
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
        assert!(index.side >= 8);
        for (c, &l) in listed[..empty as usize].iter().enumerate() {
            assert_eq!(l != empty, !index.cell_entries(c).is_empty(), "cell {c}");
            assert!(l == empty || l as usize == c);
        }
        let side = index.side;
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
