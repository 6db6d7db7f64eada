//! Stage 1 of segmentation: pixel links (module docs of [`segment`](super), steps 1–2).
//!
//! Contract: two 4-neighbouring **valid** pixels are linked when their heights differ by
//! at most `max_step_um`; [`linked_regions`] returns the connected components of the
//! links (union–find in raster order, the smaller index as root) that have at least
//! `min_pixels` pixels, each as ascending global pixel indices, ordered by their first
//! pixel. [`Local`] redoes connected components inside one region (for the split stage)
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
    /// `keep[k]`; returns one list of positions `k` per component, in order of their
    /// first member.
    pub(super) fn components(
        &self,
        grid: &Grid<'_>,
        pixels: &[u32],
        keep: &[bool],
    ) -> Vec<Vec<usize>> {
        let mut seen = vec![false; pixels.len()];
        let mut out = Vec::new();
        let mut stack = Vec::new();
        for start in 0..pixels.len() {
            if seen[start] || !keep[start] {
                continue;
            }
            seen[start] = true;
            stack.push(start);
            let mut comp = Vec::new();
            while let Some(k) = stack.pop() {
                comp.push(k);
                let g = pixels[k] as usize;
                let (r, c) = (g / grid.nx - self.row0, g % grid.nx - self.col0);
                let mut visit = |rr: usize, cc: usize| {
                    let s = self.slot[rr * self.w + cc];
                    if s != 0 {
                        let j = (s - 1) as usize;
                        if !seen[j] && keep[j] && grid.linked(g, pixels[j] as usize) {
                            seen[j] = true;
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
            comp.sort_unstable();
            out.push(comp);
        }
        out
    }
}

/// The linked regions of the map with at least `params.min_pixels` pixels (module
/// docs): ascending global pixel indices per region, regions ordered by first pixel.
pub(super) fn linked_regions(grid: &Grid<'_>, n: usize, params: &SegmentParams) -> Vec<Vec<u32>> {
    let (nx, ny, valid) = (grid.nx, grid.ny, grid.valid);
    // Union-find over linked 4-neighbours, in raster order.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for row in 0..ny {
        for col in 0..nx {
            let i = row * nx + col;
            if !valid[i] {
                continue;
            }
            if col > 0 && valid[i - 1] && grid.linked(i, i - 1) {
                union(&mut parent, i as u32, (i - 1) as u32);
            }
            if row > 0 && valid[i - nx] && grid.linked(i, i - nx) {
                union(&mut parent, i as u32, (i - nx) as u32);
            }
        }
    }
    // Group pixels by root (roots are the first pixel of each region).
    let mut region_of = vec![u32::MAX; n];
    let mut sizes: Vec<u32> = Vec::new();
    for i in 0..n {
        if !valid[i] {
            continue;
        }
        let r = find(&mut parent, i as u32) as usize;
        if r == i {
            region_of[i] = sizes.len() as u32;
            sizes.push(0);
        }
        let k = region_of[r];
        region_of[i] = k;
        sizes[k as usize] += 1;
    }
    drop(parent);
    let mut regions: Vec<Vec<u32>> = sizes
        .iter()
        .map(|&s| {
            if s as usize >= params.min_pixels {
                Vec::with_capacity(s as usize)
            } else {
                Vec::new()
            }
        })
        .collect();
    for (i, &k) in region_of.iter().enumerate() {
        if k != u32::MAX && sizes[k as usize] as usize >= params.min_pixels {
            regions[k as usize].push(i as u32);
        }
    }
    drop(region_of);
    regions.retain(|r| !r.is_empty());
    regions
}
