//! Stage 2 of segmentation: robust plane split (module docs of [`segment`](super), step 3).
//!
//! Contract: [`split_region`] takes one linked region and returns its planar pieces.
//! Each piece is the largest connected set of inliers of a robust plane (best of the
//! whole-region and 4 × 4 sub-block least-squares candidates by inlier count, refined
//! by iterated least squares with MAD rejection); leftovers of at least `min_pixels`
//! are split again, smaller leftovers touching the piece join it as rejected points,
//! the rest are dropped. A piece comes with its pixels (ascending) and carries its inlier
//! count, the sums of its inliers and its bounding box. Pure function of the region: regions can be split in parallel.

use super::links::{Grid, Local};
use super::params::SegmentParams;
use super::plane::{Plane, Sums, fit_sums};

/// Bounding box of a set of pixels, µm in map coordinates (`x = col · dx`, `y = row · dy`).
#[derive(Debug, Clone, Copy)]
pub(super) struct BBox {
    pub(super) x0: f64,
    pub(super) x1: f64,
    pub(super) y0: f64,
    pub(super) y1: f64,
}

impl BBox {
    fn of(grid: &Grid<'_>, pixels: &[u32]) -> Self {
        let mut b = Self {
            x0: f64::MAX,
            x1: f64::MIN,
            y0: f64::MAX,
            y1: f64::MIN,
        };
        for &p in pixels {
            let q = grid.point(p);
            b.x0 = b.x0.min(q[0]);
            b.x1 = b.x1.max(q[0]);
            b.y0 = b.y0.min(q[1]);
            b.y1 = b.y1.max(q[1]);
        }
        b
    }

    /// Distance between the two boxes (0 when they overlap or touch), µm.
    pub(super) fn gap(&self, o: &Self) -> f64 {
        let gx = (o.x0 - self.x1).max(self.x0 - o.x1).max(0.0);
        let gy = (o.y0 - self.y1).max(self.y0 - o.y1).max(0.0);
        gx.hypot(gy)
    }
}

/// A planar piece: how many of its pixels are inliers, the inlier sums and the
/// bounding box of all its pixels. [`split_region`] returns the pixels beside it.
#[derive(Debug, Clone)]
pub(super) struct Piece {
    pub(super) inliers: usize,
    pub(super) sums: Sums,
    pub(super) bbox: BBox,
}

fn residual(p: &Plane, q: &[f64; 3]) -> f64 {
    q[2] - (p.a * q[0] + p.b * q[1] + p.c)
}

/// Robust plane of `pts` (module docs, step 3): returns the inlier flags, or `None` when
/// no plane can be fitted.
fn robust_plane(pts: &[[f64; 3]], params: &SegmentParams) -> Option<Vec<bool>> {
    let band0 = params.inlier_band_um;
    // Candidates: the whole set and a 4 x 4 grid of sub-blocks.
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in pts {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    const G: usize = 4;
    let mut cells = vec![Sums::default(); G * G];
    let mut all = Sums::default();
    let cw = ((x1 - x0) / G as f64).max(f64::MIN_POSITIVE);
    let ch = ((y1 - y0) / G as f64).max(f64::MIN_POSITIVE);
    for p in pts {
        let cx = (((p[0] - x0) / cw) as usize).min(G - 1);
        let cy = (((p[1] - y0) / ch) as usize).min(G - 1);
        cells[cy * G + cx].add(*p);
        all.add(*p);
    }
    let min_cell = (params.min_pixels as f64 / 4.0).max(12.0);
    let mut best: Option<(usize, Plane)> = None;
    for s in std::iter::once(&all).chain(cells.iter().filter(|s| s.n >= min_cell)) {
        let Some(pl) = s.plane() else { continue };
        let count = pts
            .iter()
            .filter(|q| residual(&pl, q).abs() <= band0)
            .count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            best = Some((count, pl));
        }
    }
    let (_, mut plane) = best?;
    let mut inl: Vec<bool> = pts
        .iter()
        .map(|q| residual(&plane, q).abs() <= band0)
        .collect();
    let mut abs_r = Vec::with_capacity(pts.len());
    for _ in 0..12 {
        plane = fit_sums(pts, |k| inl[k]).plane()?;
        abs_r.clear();
        abs_r.extend(
            pts.iter()
                .zip(&inl)
                .filter(|(_, i)| **i)
                .map(|(q, _)| residual(&plane, q).abs()),
        );
        let mid = abs_r.len() / 2;
        let mad = *abs_r.select_nth_unstable_by(mid, f64::total_cmp).1;
        let band = (params.reject_sigmas * 1.4826 * mad).clamp(band0, 2.0 * band0);
        let next: Vec<bool> = pts
            .iter()
            .map(|q| residual(&plane, q).abs() <= band)
            .collect();
        if next == inl {
            break;
        }
        inl = next;
    }
    (inl.iter().filter(|&&b| b).count() >= 3).then_some(inl)
}

/// Splits one linked region (its pixels, ascending global indices) into planar pieces
/// (module docs, step 3): each piece with its pixels (global indices, ascending).
pub(super) fn split_region(
    grid: &Grid<'_>,
    region: Vec<u32>,
    params: &SegmentParams,
) -> Vec<(Vec<u32>, Piece)> {
    let mut out = Vec::new();
    let mut queue = vec![region];
    while let Some(pixels) = queue.pop() {
        if pixels.len() < params.min_pixels {
            continue;
        }
        let pts: Vec<[f64; 3]> = pixels.iter().map(|&p| grid.point(p)).collect();
        let Some(inl) = robust_plane(&pts, params) else {
            continue;
        };
        let local = Local::new(grid, &pixels);
        let comps = local.components(grid, &pixels, &inl);
        let Some(main) = comps
            .iter()
            .enumerate()
            .max_by_key(|(i, c)| (c.len(), std::cmp::Reverse(*i)))
            .map(|(_, c)| c)
        else {
            continue;
        };
        if main.len() < params.min_pixels {
            continue;
        }
        let mut member = vec![false; pixels.len()];
        for &k in main {
            member[k] = true;
        }
        let rest: Vec<bool> = member.iter().map(|m| !m).collect();
        // The piece: the main component and the small leftovers touching it.
        let mut in_piece = member.clone();
        let inliers = main.len();
        let sums = fit_sums(&pts, |k| member[k]);
        // Leftovers: big ones are new regions, small ones touching the piece join it
        // as rejected points.
        let leftovers = local.components(grid, &pixels, &rest);
        for comp in leftovers {
            if comp.len() >= params.min_pixels {
                queue.push(comp.iter().map(|&k| pixels[k]).collect());
                continue;
            }
            let touches = comp.iter().any(|&k| {
                let g = pixels[k] as usize;
                let (r, c) = (g / grid.nx - local.row0, g % grid.nx - local.col0);
                let mut hit = false;
                let mut check = |rr: usize, cc: usize| {
                    let s = local.slot[rr * local.w + cc];
                    hit |= s != 0 && member[(s - 1) as usize];
                };
                if c > 0 {
                    check(r, c - 1);
                }
                if c + 1 < local.w {
                    check(r, c + 1);
                }
                if r > 0 {
                    check(r - 1, c);
                }
                if r + 1 < local.h {
                    check(r + 1, c);
                }
                hit
            });
            if touches {
                for &k in &comp {
                    in_piece[k] = true;
                }
            }
        }
        let piece_pixels: Vec<u32> = pixels
            .iter()
            .zip(&in_piece)
            .filter(|(_, t)| **t)
            .map(|(&p, _)| p)
            .collect();
        let bbox = BBox::of(grid, &piece_pixels);
        out.push((
            piece_pixels,
            Piece {
                inliers,
                sums,
                bbox,
            },
        ));
    }
    out
}
