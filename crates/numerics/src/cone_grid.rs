//! A grid index from exit directions to the detector cones that may contain them.
//!
//! Conventions: exit directions `k` are unit vectors with `k.z ≥ 0` (in air, above the
//! sample); a cone of half-angle `α` about the unit axis `r` contains `k` when
//! `k·r > cos α` (the detector test of the ray models, [`Entry::contains`]). Every
//! direction in that cone is within the chord `|k − r| < 2 sin(α/2)` of the axis, so
//! its `(x, y)` projection lies in the square of half-side `2 sin(α/2)` about
//! `(r.x, r.y)`. The index is a uniform grid over `(k.x, k.y) ∈ [−1, 1]²`; each cell
//! lists the cones that may reach it, in the cones' order, so a ray tests only the
//! cones of its own cell (for in-plane detectors, a ray out of the plane lands in an
//! empty cell and is rejected with one lookup). Used by the topographic and the volume
//! model; no units but radians.

/// A detector cone as the index needs it: its unit axis, its half-angle `α` (radians,
/// in `(0, π)`) and `cos α` (as the caller computes it: the containment test compares
/// with this value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeSpec {
    /// The unit axis `(x, y, z)`.
    pub axis: [f64; 3],
    /// The half-angle `α`, radians.
    pub half_angle: f64,
    /// `cos α`.
    pub cos_half_angle: f64,
}

/// One cone as the inner loop needs it.
#[derive(Debug, Clone, Copy)]
pub struct Entry {
    /// The axis' `x`.
    pub ax: f64,
    /// The axis' `y`.
    pub ay: f64,
    /// The axis' `z`.
    pub az: f64,
    /// `cos α`.
    pub cos_alpha: f64,
    /// `cos(α + margin)`: directions with `k·r` above it are within `margin` of the
    /// cone (equal to `cos_alpha` for an index built without margin).
    pub cos_reach: f64,
    /// The cone's position in the list the index was built from.
    pub index: u32,
}

impl Entry {
    /// Whether the cone contains the direction `(x, y, z)`: `ax·x + ay·y + az·z >
    /// cos α`, each product and sum rounded in that order (the cones' own containment
    /// test on the models' exit directions).
    #[inline(always)]
    pub fn contains(&self, x: f64, y: f64, z: f64) -> bool {
        self.ax * x + self.ay * y + self.az * z > self.cos_alpha
    }
}

/// The geometry of a [`ConeGrid`]'s grid, and the box of its cells that list cones.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
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
    /// [`ConeGrid::empty_cell`].
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

/// Cells per chord of the narrowest cone for an index of exit directions traced once
/// each (the topographic model's, the volume model's): with the default 281
/// in-plane cones of 1.5° and the benchmark's surface, the rays that land in a cell that
/// lists cones test 5.3 candidates each instead of 12.3 with cells of the chord's size,
/// and 15 % of the rays land in one instead of 19 %. Finer cells gain little more, and
/// cost more to build.
pub const FINE: f64 = 4.0;

/// Cells per chord of the narrowest cone for the isotropic topographic model's indexes: it queries
/// an index a few times per table node, and five fine ones (one per incidence) cost it
/// more to build than they save.
pub const COARSE: f64 = 1.0;

/// The most cone entries (about 48 bytes each) the cell lists may hold in all before
/// [`ConeGrid::new`] makes its cells coarser, each entry counted `entry_weight` times
/// (a caller that keeps more per entry, as the topographic model's blocks, says so).
pub const MAX_ENTRIES: f64 = 1_048_576.0;

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

/// Cells of equal side over `[−1, 1]²`, each listing the cones that may contain a
/// direction projecting into it (CSR layout; module docs).
#[derive(Debug, Clone)]
pub struct ConeGrid {
    side: usize,
    inv_cell: f64,
    offsets: Vec<u32>,
    entries: Vec<Entry>,
    /// Per cell, the empty one past the grid included, the cell itself if it lists
    /// cones, else the empty cell.
    listed: Vec<u32>,
    /// The box of the cells that list cones, `[x_lo, x_hi, y_lo, y_hi]` ([`Grid`]).
    listed_box: [f64; 4],
}

impl ConeGrid {
    /// Builds the index for `cones` (all with `α > 0`) widened by `margin` radians: a
    /// cell lists every cone whose axis is within `α + margin` of some direction
    /// projecting into the cell (`α + margin < π`), and, of those, only cones that pass
    /// the test of `may_reach`: a cone whose bounding square only grazes the cell (its
    /// corner, or the side where the cone's projection is compressed towards the
    /// horizon) is not listed. The cells are `cells_per_chord` to the chord
    /// `2 sin((α + margin)/2)` of the narrowest cone along each axis ([`FINE`],
    /// [`COARSE`]), at most 1024 and at least 8 per axis, and made coarser while the
    /// lists would hold more than about 10⁶ entries in all, each counted
    /// `entry_weight` times (1 when the caller keeps nothing more per entry).
    #[must_use]
    pub fn new(cones: &[ConeSpec], margin: f64, cells_per_chord: f64, entry_weight: f64) -> Self {
        let chord = |c: &ConeSpec| 2.0 * (0.5 * (c.half_angle + margin)).sin();
        // A small margin covers rounding at the cap's edge.
        let reach = |c: &ConeSpec| chord(c) * (1.0 + 1e-9) + 1e-12;
        let min_chord = cones.iter().map(chord).fold(f64::INFINITY, f64::min);
        let cells_of = |cell: f64| {
            entry_weight
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
            let a = c.axis;
            let half = reach(c);
            let (x0, x1) = (to_cell(a[0] - half), to_cell(a[0] + half));
            let (y0, y1) = (to_cell(a[1] - half), to_cell(a[1] + half));
            by_cone.push(Entry {
                ax: a[0],
                ay: a[1],
                az: a[2],
                cos_alpha: c.cos_half_angle,
                cos_reach: if margin > 0.0 {
                    (c.half_angle + margin).cos()
                } else {
                    c.cos_half_angle
                },
                index: j as u32,
            });
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    if may_reach(bounds(ix), bounds(iy), a, half) {
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
        Self {
            side,
            inv_cell,
            offsets,
            entries,
            listed,
            listed_box,
        }
    }

    /// The candidate cones for a direction with horizontal components `(x, y)`.
    #[inline]
    #[must_use]
    pub fn candidates(&self, x: f64, y: f64) -> &[Entry] {
        self.cell_entries(self.cell(x, y))
    }

    /// The cell of a direction with horizontal components `(x, y)`: any values, NaN
    /// included, give a cell of the grid (out-of-range ones are clamped to its edge,
    /// NaN to the first column or row).
    #[inline(always)]
    #[must_use]
    pub fn cell(&self, x: f64, y: f64) -> usize {
        self.grid().cell(x, y) as usize
    }

    /// The grid's geometry and, per cell (the empty cell past the grid included), the
    /// cell itself if it lists cones, else [`ConeGrid::empty_cell`]: what a ray needs
    /// to know to skip the cones, as plain values that a loop keeps in registers (the
    /// cell of `(x, y)` is `grid.cell(x, y)`, and it lists cones when
    /// `listed[cell] != empty_cell()`).
    #[inline]
    #[must_use]
    pub fn listed(&self) -> (Grid, &[u32]) {
        (self.grid(), &self.listed)
    }

    /// The grid's geometry.
    #[inline]
    #[must_use]
    pub fn grid(&self) -> Grid {
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

    /// Cells per axis.
    #[must_use]
    pub fn side(&self) -> usize {
        self.side
    }

    /// A cell that lists no cone, outside the grid (for rays that leave no exit).
    #[inline]
    #[must_use]
    pub fn empty_cell(&self) -> u32 {
        (self.side * self.side) as u32
    }

    /// The cones listed in `cell` (from [`ConeGrid::cell`]; the empty cell lists none).
    #[inline]
    #[must_use]
    pub fn cell_entries(&self, cell: usize) -> &[Entry] {
        &self.entries[self.offsets[cell] as usize..self.offsets[cell + 1] as usize]
    }

    /// The cells' lists one after another (cell by cell, each in the cones' order).
    #[must_use]
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// The cone of half-angle `alpha` about the direction at `theta` from the zenith
    /// and azimuth `phi` (spherical coordinates), with `cos α` from `f64::cos`.
    fn cone(theta: f64, phi: f64, alpha: f64) -> ConeSpec {
        ConeSpec {
            axis: [
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ],
            half_angle: alpha,
            cos_half_angle: alpha.cos(),
        }
    }

    /// A unit direction at angle `beta` from the unit axis `a`, at azimuth `psi` about
    /// it (Rodrigues: `a cos β + (u cos ψ + v sin ψ) sin β` with `u`, `v` completing
    /// `a` to an orthonormal frame).
    fn around(a: [f64; 3], beta: f64, psi: f64) -> [f64; 3] {
        let t = if a[2].abs() < 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let cross = |p: [f64; 3], q: [f64; 3]| {
            [
                p[1] * q[2] - p[2] * q[1],
                p[2] * q[0] - p[0] * q[2],
                p[0] * q[1] - p[1] * q[0],
            ]
        };
        let u = cross(a, t);
        let nu = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        let u = u.map(|c| c / nu);
        let v = cross(a, u);
        std::array::from_fn(|i| {
            a[i] * beta.cos() + (u[i] * psi.cos() + v[i] * psi.sin()) * beta.sin()
        })
    }

    /// Every (direction, cone) pair with `k·r > cos(α + margin)` is found through the
    /// index, for fine and coarse cells, with and without a margin: brute force over
    /// all cones is the independent reference. The cones include in-plane sweeps,
    /// random ones and axes near the horizon (where a cone's projection is most
    /// compressed and the cells' `z` test cuts most); the directions lie near the
    /// cones' rims, their `z` formed from `(x, y)` as the models form it.
    #[test]
    fn the_index_finds_every_containing_cone() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut cones = Vec::new();
        for d in -140..=140 {
            let t = f64::from(d) * 0.5f64.to_radians();
            cones.push(cone(
                t.abs(),
                if t < 0.0 { std::f64::consts::PI } else { 0.0 },
                1.5f64.to_radians(),
            ));
        }
        for _ in 0..200 {
            let (t, p, a) = (
                rng.random_range(0.0..1.5),
                rng.random_range(-3.2..3.2),
                rng.random_range(0.001..0.3),
            );
            cones.push(cone(t, p, a));
        }
        for _ in 0..40 {
            let t = rng.random_range(1.45..std::f64::consts::FRAC_PI_2 - 1e-4);
            let (p, a) = (rng.random_range(-3.2..3.2), rng.random_range(0.002..0.05));
            cones.push(cone(t, p, a));
        }
        for (margin, per_chord) in [(0.0, FINE), (0.0, COARSE), (0.01, COARSE), (0.01, FINE)] {
            let grid = ConeGrid::new(&cones, margin, per_chord, 1.0);
            let mut hits = 0;
            for _ in 0..40_000 {
                let c = &cones[rng.random_range(0..cones.len())];
                let beta = (c.half_angle + margin) * rng.random_range(0.9..1.1);
                let k = around(c.axis, beta, rng.random_range(0.0..std::f64::consts::TAU));
                let r2 = k[0] * k[0] + k[1] * k[1];
                if k[2] <= 0.0 || r2 >= 1.0 {
                    continue;
                }
                let kz = (1.0 - r2).sqrt();
                let mut found: Vec<u32> = grid
                    .candidates(k[0], k[1])
                    .iter()
                    .filter(|e| e.ax * k[0] + e.ay * k[1] + e.az * kz > e.cos_reach)
                    .map(|e| e.index)
                    .collect();
                found.sort_unstable();
                let truth: Vec<u32> = (0..cones.len() as u32)
                    .filter(|&j| {
                        let c = &cones[j as usize];
                        let dot = c.axis[0] * k[0] + c.axis[1] * k[1] + c.axis[2] * kz;
                        let bound = if margin == 0.0 {
                            c.cos_half_angle
                        } else {
                            (c.half_angle + margin).cos()
                        };
                        dot > bound
                    })
                    .collect();
                hits += truth.len();
                assert_eq!(
                    found, truth,
                    "margin {margin}, {per_chord} cells per chord, k = {k:?}"
                );
                // The box filter keeps every direction that some cone contains.
                if !truth.is_empty() {
                    assert_eq!(
                        grid.grid().boxed_cell(k[0], k[1]) as usize,
                        grid.cell(k[0], k[1])
                    );
                }
            }
            assert!(
                hits > 20_000,
                "the test must exercise many containments ({hits})"
            );
        }
    }

    /// A narrow cone beside many wide ones would give lists of millions of entries at
    /// the narrow cone's cell size (200 cones of α = 0.5 over cells of 2/1024: about
    /// 200 × (2 · 2 sin 0.25 / (2/1024))² ≈ 6 · 10⁷); the cells are made coarser until
    /// the lists fit in 2²⁰ entries (weighted), and the narrow cone is still found.
    #[test]
    fn wide_cones_beside_a_narrow_one_keep_the_index_small() {
        let narrow = cone(0.2, 0.0, 0.001);
        let mut cones = vec![narrow];
        for k in 0..200 {
            cones.push(cone(0.1 + 1.2 * f64::from(k) / 200.0, f64::from(k), 0.5));
        }
        for weight in [1.0, 6.0] {
            let grid = ConeGrid::new(&cones, 0.0, FINE, weight);
            assert!(
                grid.entries().len() as f64 * weight <= MAX_ENTRIES,
                "{}",
                grid.entries().len()
            );
            assert!(grid.side() < 1024, "side {}", grid.side());
            let k = narrow.axis;
            assert!(grid.candidates(k[0], k[1]).iter().any(|e| e.index == 0));
        }
        // Alone, the narrow cone gets the finest cells: 4 to its chord 2 sin(0.0005),
        // 2/(0.001/4) = 8000 per axis, clamped to 1024.
        assert_eq!(ConeGrid::new(&[narrow], 0.0, FINE, 1.0).side(), 1024);
    }

    /// `listed` marks exactly the cells that list cones, the empty cell past the grid
    /// lists none and marks itself, the grid's last cell, a corner outside the unit
    /// disc, lists nothing although the corner cone's bounding square covers it, and
    /// the cell of a direction is the integer formula `min(⌊(v + 1)·side/2⌋, side − 1)`
    /// per axis (0 below and for NaN).
    #[test]
    fn listed_cells_and_the_cell_formula() {
        let corner = cone(1.45, std::f64::consts::FRAC_PI_4, 0.5);
        let grid = ConeGrid::new(&[corner, cone(0.3, 0.0, 0.05)], 0.0, FINE, 1.0);
        let (geometry, listed) = grid.listed();
        let empty = grid.empty_cell();
        assert_eq!(listed.len(), empty as usize + 1);
        assert_eq!(listed[empty as usize], empty);
        assert!(grid.cell_entries(empty as usize).is_empty());
        // The corner cone's bounding square (half-side 2 sin(α/2) ≈ 0.49 about
        // a.x = a.y ≈ 0.70) reaches the corner x = y = 1, outside the unit disc.
        assert!(1.0 - corner.axis[0] < 0.49);
        assert!(grid.cell_entries(empty as usize - 1).is_empty());
        assert!(grid.side() >= 8);
        for (c, &l) in listed[..empty as usize].iter().enumerate() {
            assert_eq!(l != empty, !grid.cell_entries(c).is_empty(), "cell {c}");
            assert!(l == empty || l as usize == c);
        }
        let side = grid.side();
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
        let (mut boxed, mut outside) = (0, 0);
        for pair in values.chunks(2) {
            let (x, y) = (pair[0], pair[pair.len() - 1]);
            let want = formula(y) * side + formula(x);
            assert_eq!(geometry.cell(x, y) as usize, want, "({x}, {y})");
            assert_eq!(grid.cell(x, y), want);
            let in_box = geometry.boxed_cell(x, y);
            if in_box == empty {
                assert_eq!(listed[want], empty, "({x}, {y}) left out of the box");
                outside += 1;
            } else {
                assert_eq!(in_box as usize, want, "({x}, {y})");
                boxed += 1;
            }
        }
        assert!(
            boxed > 100 && outside > 1000,
            "{boxed} in the box, {outside} outside"
        );
    }
}
