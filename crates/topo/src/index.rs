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

/// The geometry of a [`ConeIndex`]'s grid.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    /// Cells per unit of `x` or `y` (`side/2`).
    inv_cell: f64,
    /// `side − 1`.
    last: f64,
    /// Cells per axis.
    side: f64,
}

impl Grid {
    /// The cell of `(x, y)`: `(v + 1)·side/2` clamped to `[0, side − 1]` in floating
    /// point and truncated, for `v = x` and `y`, combined as `iy·side + ix` (exact
    /// integers far below 2⁵²); an integer-valued `t` in `[0, 2³²)` plus 2⁵² is exact
    /// with `t` in the low bits of its representation: a conversion without the checks
    /// of `as`.
    #[inline(always)]
    pub fn cell(self, x: f64, y: f64) -> u32 {
        const INT: f64 = 4_503_599_627_370_496.0;
        let at = |v: f64| ((v + 1.0) * self.inv_cell).max(0.0).min(self.last).trunc();
        (at(y) * self.side + at(x) + INT).to_bits() as u32
    }
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
}

impl ConeIndex {
    /// Builds the index for `cones` (all with `α > 0`).
    pub fn new(cones: &[Cone]) -> Self {
        Self::with_margin(cones, 0.0)
    }

    /// Builds the index for `cones` widened by `margin` radians: a cell lists every cone
    /// whose axis is within `α + margin` of some direction projecting into the cell
    /// (`α + margin < π`).
    pub fn with_margin(cones: &[Cone], margin: f64) -> Self {
        let chord = |c: &Cone| 2.0 * (0.5 * (c.half_angle() + margin)).sin();
        let min_chord = cones.iter().map(chord).fold(f64::INFINITY, f64::min);
        // Cells about the size of the smallest cone's projection, at most 1024 per axis
        // and at least 8.
        let cell = min_chord.clamp(2.0 / 1024.0, 2.0 / 8.0);
        let side = (2.0 / cell).ceil() as usize;
        let inv_cell = side as f64 / 2.0;
        let to_cell = |v: f64| (((v + 1.0) * inv_cell).floor().max(0.0) as usize).min(side - 1);
        let mut lists: Vec<Vec<Entry>> = vec![Vec::new(); side * side];
        for (j, c) in cones.iter().enumerate() {
            let a = c.axis();
            // A small margin covers rounding at the cap's edge.
            let half = chord(c) * (1.0 + 1e-9) + 1e-12;
            let (x0, x1) = (to_cell(a.x - half), to_cell(a.x + half));
            let (y0, y1) = (to_cell(a.y - half), to_cell(a.y + half));
            let e = Entry {
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
            };
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    lists[iy * side + ix].push(e);
                }
            }
        }
        let mut offsets = Vec::with_capacity(side * side + 2);
        let mut entries = Vec::new();
        offsets.push(0);
        for l in lists {
            entries.extend(l);
            offsets.push(entries.len() as u32);
        }
        // The empty cell past the grid.
        offsets.push(entries.len() as u32);
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
        Self {
            side,
            inv_cell,
            offsets,
            entries,
            listed,
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
        Grid {
            inv_cell: self.inv_cell,
            last: (self.side - 1) as f64,
            side: self.side as f64,
        }
    }

    /// A cell that lists no cone, outside the grid (for rays that leave no exit).
    #[inline]
    pub fn empty_cell(&self) -> u32 {
        (self.side * self.side) as u32
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
    use rand::{RngExt, SeedableRng};

    /// Every (direction, cone) pair that `Cone::contains` accepts is found through the
    /// index: brute force over all cones is the independent reference.
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
        let index = ConeIndex::new(&cones);
        let mut hits = 0;
        for _ in 0..20_000 {
            // Directions concentrated near the cones' rims and everywhere else.
            let c = &cones[rng.random_range(0..cones.len())];
            let (u, v) = flakescatter_optics::detector::orthonormal_frame(c.axis());
            let beta = c.half_angle() * rng.random_range(0.9..1.1);
            let psi = rng.random_range(0.0..std::f64::consts::TAU);
            let k = c.axis().into_inner() * beta.cos()
                + (u.into_inner() * psi.cos() + v.into_inner() * psi.sin()) * beta.sin();
            if k.z <= 0.0 {
                continue;
            }
            let k = flakescatter_optics::UnitVec3::new_normalize(k);
            let mut found: Vec<u32> = index
                .candidates(k.x, k.y)
                .iter()
                .filter(|e| e.ax * k.x + e.ay * k.y + e.az * k.z > e.cos_alpha)
                .map(|e| e.index)
                .collect();
            found.sort_unstable();
            let truth: Vec<u32> = (0..cones.len() as u32)
                .filter(|&j| cones[j as usize].contains(&k))
                .collect();
            hits += truth.len();
            assert_eq!(found, truth);
        }
        assert!(
            hits > 10_000,
            "the test must exercise many containments ({hits})"
        );
    }
    /// `listed` marks exactly the cells that list cones, the empty cell past the grid
    /// lists none and marks itself (so a lost ray sent there is never taken for one in
    /// the grid's last cell, which here lists a cone), and the cell of a direction is
    /// the integer formula `min(⌊(v + 1)·side/2⌋, side − 1)` per axis (0 below and for
    /// NaN).
    #[test]
    fn listed_cells_and_the_cell_formula() {
        let corner = Cone::out_of_plane(1.45, std::f64::consts::FRAC_PI_4, 0.5).unwrap();
        let index = ConeIndex::new(&[corner, Cone::in_plane(0.3, 0.05).unwrap()]);
        let (grid, listed) = index.listed();
        let empty = index.empty_cell();
        assert_eq!(listed.len(), empty as usize + 1);
        assert_eq!(listed[empty as usize], empty);
        assert!(index.cell_entries(empty as usize).is_empty());
        assert!(!index.cell_entries(empty as usize - 1).is_empty());
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
        for pair in values.chunks(2) {
            let (x, y) = (pair[0], pair[pair.len() - 1]);
            let want = formula(y) * side + formula(x);
            assert_eq!(grid.cell(x, y) as usize, want, "({x}, {y})");
            assert_eq!(index.cell(x, y), want);
        }
    }
}
