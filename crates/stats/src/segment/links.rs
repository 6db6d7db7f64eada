//! Stage 1 of segmentation: pixel links (module docs of [`segment`](super), steps 1–2).
//!
//! Contract: two 4-neighbouring **valid** pixels are linked when their heights differ by
//! at most `max_step_um`; [`linked_regions`] labels the connected components of the
//! links (union–find in raster order, the smaller index as root) that have at least
//! `min_pixels` pixels in one per-pixel label map, numbered in order of their first
//! pixel, and [`region_pixels`] lists the pixels of consecutive regions (ascending global
//! indices). [`Local`] redoes connected components inside one region (for the split stage)
//! with the same link rule. Deterministic and sequential.

use super::params::SegmentParams;

/// Union–find with path halving; the smaller index becomes the root (deterministic).
pub(super) fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = parent[i as usize];
    }
    i
}

pub(super) fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// Read-only view of the map used by the per-region work.
pub(super) struct Grid<'a> {
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) dx: f64,
    pub(super) dy: f64,
    pub(super) z: &'a [f64],
    pub(super) valid: &'a [bool],
    pub(super) z_ref: f64,
    pub(super) max_step: f64,
}

impl Grid<'_> {
    pub(super) fn point(&self, i: u32) -> [f64; 3] {
        let i = i as usize;
        let (row, col) = (i / self.nx, i % self.nx);
        [
            col as f64 * self.dx,
            row as f64 * self.dy,
            self.z[i] - self.z_ref,
        ]
    }

    pub(super) fn linked(&self, i: usize, j: usize) -> bool {
        (self.z[i] - self.z[j]).abs() <= self.max_step
    }
}

/// A region's pixels on a local bounding-box grid, for connected components.
pub(super) struct Local {
    pub(super) col0: usize,
    pub(super) row0: usize,
    pub(super) w: usize,
    pub(super) h: usize,
    /// `slot[local] = position in the pixel list + 1`, `0` if the pixel is not in it.
    pub(super) slot: Vec<u32>,
}

impl Local {
    pub(super) fn new(grid: &Grid<'_>, pixels: &[u32]) -> Self {
        let (mut c0, mut r0, mut c1, mut r1) = (usize::MAX, usize::MAX, 0, 0);
        for &p in pixels {
            let (r, c) = (p as usize / grid.nx, p as usize % grid.nx);
            c0 = c0.min(c);
            c1 = c1.max(c);
            r0 = r0.min(r);
            r1 = r1.max(r);
        }
        let (w, h) = (c1 + 1 - c0, r1 + 1 - r0);
        let mut slot = vec![0u32; w * h];
        for (k, &p) in pixels.iter().enumerate() {
            let (r, c) = (p as usize / grid.nx, p as usize % grid.nx);
            slot[(r - r0) * w + (c - c0)] = k as u32 + 1;
        }
        Self {
            col0: c0,
            row0: r0,
            w,
            h,
            slot,
        }
    }

    /// Connected components (4-neighbours, linked heights) among the pixels with
    /// `keep[k]`; returns one list of positions `k` per component (ascending), in order
    /// of their first member.
    pub(super) fn components(
        &self,
        grid: &Grid<'_>,
        pixels: &[u32],
        keep: &[bool],
    ) -> Vec<Vec<usize>> {
        // Component number of each position (NOT_SEEN outside), found by depth-first
        // search from each unseen kept position in ascending order; the lists are then
        // filled in one ascending pass, so each comes out sorted without a sort.
        const NOT_SEEN: u32 = u32::MAX;
        let mut comp_of = vec![NOT_SEEN; pixels.len()];
        let mut sizes: Vec<usize> = Vec::new();
        let mut stack = Vec::new();
        for start in 0..pixels.len() {
            if comp_of[start] != NOT_SEEN || !keep[start] {
                continue;
            }
            let id = sizes.len() as u32;
            comp_of[start] = id;
            stack.push(start);
            let mut size = 0;
            while let Some(k) = stack.pop() {
                size += 1;
                let g = pixels[k] as usize;
                let (r, c) = (g / grid.nx - self.row0, g % grid.nx - self.col0);
                let mut visit = |rr: usize, cc: usize| {
                    let s = self.slot[rr * self.w + cc];
                    if s != 0 {
                        let j = (s - 1) as usize;
                        if comp_of[j] == NOT_SEEN && keep[j] && grid.linked(g, pixels[j] as usize) {
                            comp_of[j] = id;
                            stack.push(j);
                        }
                    }
                };
                if c > 0 {
                    visit(r, c - 1);
                }
                if c + 1 < self.w {
                    visit(r, c + 1);
                }
                if r > 0 {
                    visit(r - 1, c);
                }
                if r + 1 < self.h {
                    visit(r + 1, c);
                }
            }
            sizes.push(size);
        }
        let mut out: Vec<Vec<usize>> = sizes.iter().map(|&s| Vec::with_capacity(s)).collect();
        for (k, &id) in comp_of.iter().enumerate() {
            if id != NOT_SEEN {
                out[id as usize].push(k);
            }
        }
        out
    }
}

/// Label of a pixel in no region: invalid, or in a linked region below `min_pixels`.
pub(super) const NONE: u32 = u32::MAX;

/// Tag of a region label `REGION | k` in the label map until region `k` is split; the
/// split stage overwrites its pixels with piece numbers, which stay below the tag (a
/// map has fewer than 2³² pixels and every region and piece at least 3, so both counts
/// are below 2³¹).
pub(super) const REGION: u32 = 1 << 31;

/// A linked region of the label map: its size and bounding box (rows and columns,
/// inclusive).
#[derive(Debug, Clone, Copy)]
pub(super) struct Region {
    pub(super) size: usize,
    row0: usize,
    row1: usize,
    col0: usize,
    col1: usize,
}

/// The pixels of the regions `first, first + 1, …` of [`linked_regions`] given in
/// `regions` (consecutive, not split yet): one list per region, ascending global
/// indices, read in one raster scan of the rows and columns their boxes span (regions
/// are numbered by their first pixel, so consecutive ones lie in a band of rows).
pub(super) fn region_pixels(
    nx: usize,
    labels: &[u32],
    regions: &[Region],
    first: usize,
) -> Vec<Vec<u32>> {
    let mut out: Vec<Vec<u32>> = regions.iter().map(|r| Vec::with_capacity(r.size)).collect();
    let (Some(row0), Some(row1), Some(col0), Some(col1)) = (
        regions.iter().map(|r| r.row0).min(),
        regions.iter().map(|r| r.row1).max(),
        regions.iter().map(|r| r.col0).min(),
        regions.iter().map(|r| r.col1).max(),
    ) else {
        return out;
    };
    // Labels of these regions: REGION | first ..= REGION | (first + len - 1); every
    // other label (NONE, other regions, piece numbers) lies outside.
    let lo = REGION | first as u32;
    let count = regions.len() as u32;
    for row in row0..=row1 {
        let (a, b) = (row * nx + col0, row * nx + col1 + 1);
        for (i, &l) in (a..b).zip(&labels[a..b]) {
            let k = l.wrapping_sub(lo);
            if k < count {
                out[k as usize].push(i as u32);
            }
        }
    }
    out
}

/// The linked regions of the map with at least `params.min_pixels` pixels (module
/// docs), as one label map and the regions' sizes and boxes: `labels[i] = REGION | k`
/// for the pixels of region `k`, [`NONE`] for the others; regions are numbered in
/// order of their first pixel (raster order).
///
/// Memory: the label map (one `u32` per pixel) is the union–find parent array relabelled
/// in place, plus one bit per pixel while it is relabelled and one [`Region`] per
/// region kept.
pub(super) fn linked_regions(grid: &Grid<'_>, params: &SegmentParams) -> (Vec<u32>, Vec<Region>) {
    let (nx, ny, valid) = (grid.nx, grid.ny, grid.valid);
    let n = nx * ny;
    // Union-find over linked 4-neighbours, in raster order. Afterwards every pixel that
    // is not a root points to a smaller index (the smaller root wins a union and path
    // halving only moves a pixel to its grandparent).
    let mut lab: Vec<u32> = (0..n as u32).collect();
    for row in 0..ny {
        for col in 0..nx {
            let i = row * nx + col;
            if !valid[i] {
                continue;
            }
            if col > 0 && valid[i - 1] && grid.linked(i, i - 1) {
                union(&mut lab, i as u32, (i - 1) as u32);
            }
            if row > 0 && valid[i - nx] && grid.linked(i, i - nx) {
                union(&mut lab, i as u32, (i - nx) as u32);
            }
        }
    }
    // In raster order (all smaller indices are done): a root's entry becomes its
    // component's size, any other valid pixel's entry its root (its parent if that is
    // a root, else the parent's entry, already its root). `root` marks the roots.
    let mut root = vec![0u64; n.div_ceil(64)];
    let is_root = |root: &[u64], i: usize| (root[i / 64] >> (i % 64)) & 1 == 1;
    for i in 0..n {
        if !valid[i] {
            continue;
        }
        let p = lab[i] as usize;
        if p == i {
            root[i / 64] |= 1 << (i % 64);
            lab[i] = 1;
        } else {
            let r = if is_root(&root, p) {
                p
            } else {
                lab[p] as usize
            };
            lab[i] = r as u32;
            lab[r] += 1;
        }
    }
    // Again in raster order: a root's entry becomes its region's label (regions below
    // `min_pixels` get NONE), any other valid pixel takes its root's.
    let mut regions: Vec<Region> = Vec::new();
    for row in 0..ny {
        for col in 0..nx {
            let i = row * nx + col;
            if !valid[i] {
                lab[i] = NONE;
                continue;
            }
            let l = if is_root(&root, i) {
                let size = lab[i] as usize;
                if size >= params.min_pixels {
                    regions.push(Region {
                        size,
                        row0: row,
                        row1: row,
                        col0: col,
                        col1: col,
                    });
                    REGION | (regions.len() - 1) as u32
                } else {
                    NONE
                }
            } else {
                lab[lab[i] as usize]
            };
            lab[i] = l;
            if l != NONE {
                let r = &mut regions[(l & !REGION) as usize];
                r.row1 = row;
                r.col0 = r.col0.min(col);
                r.col1 = r.col1.max(col);
            }
        }
    }
    (lab, regions)
}
