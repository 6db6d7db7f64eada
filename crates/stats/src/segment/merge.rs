//! Stage 3 of segmentation: occlusion-aware merging (module docs of
//! [`segment`](super), step 4).
//!
//! Contract: [`merge_pieces`] groups the pieces of one flake that an occluding flake cut
//! apart. A pair is a candidate when the gap between their bounding boxes is at most
//! `merge_gap_um`, their normals agree within `merge_angle`, their joint least-squares
//! plane fits each no worse than `merge_ms_ratio` times its own mean square residual
//! (plus `inlier_band_um²/16`), and the line between their centroids is supported (the
//! flake or something above it is seen along it). Candidates are merged most similar
//! first, re-checking the criteria on the growing groups. Returns groups of piece
//! indices, each sorted, ordered by their smallest piece; sequential after a parallel
//! candidate search, so deterministic.

use rayon::prelude::*;

use super::links::{Grid, find, union};
use super::params::SegmentParams;
use super::plane::{Sums, normal_of};
use super::split::Piece;

/// Whether two groups with inlier sums `s1`, `s2` fit one plane: the joint
/// least-squares plane must fit **each** group with a mean square residual at most
/// `merge_ms_ratio` times the group's own (plus `inlier_band_um² / 16`). Returns the
/// larger of the two ratios when they do.
fn merge_score(s1: &Sums, s2: &Sums, params: &SegmentParams) -> Option<f64> {
    let (p1, p2) = (s1.plane()?, s2.plane()?);
    if normal_of(&p1).angle(&normal_of(&p2)) > params.merge_angle {
        return None;
    }
    let pj = s1.plus(s2).plane()?;
    let tol = params.inlier_band_um * params.inlier_band_um / 16.0;
    let mut worst: f64 = 0.0;
    for (s, p) in [(s1, &p1), (s2, &p2)] {
        let own = p.sse / s.n + tol;
        let joint = s.sse_about(&pj) / s.n + tol;
        let ratio = joint / own;
        if ratio > params.merge_ms_ratio {
            return None;
        }
        worst = worst.max(ratio);
    }
    Some(worst)
}

/// A flake is convex, so on the straight line between the centroids of two of its
/// pieces the flake itself or something above it (an occluding flake) must be seen:
/// every pixel sampled along the line must be valid and not lie below the joint plane
/// by more than the inlier band (up to 2 % of the samples may fail, for noise).
fn line_supported(grid: &Grid<'_>, s1: &Sums, s2: &Sums, params: &SegmentParams) -> bool {
    let Some(p) = s1.plus(s2).plane() else {
        return false;
    };
    let (x1, y1) = (s1.x / s1.n, s1.y / s1.n);
    let (x2, y2) = (s2.x / s2.n, s2.y / s2.n);
    let steps = ((x2 - x1).abs() / grid.dx)
        .max((y2 - y1).abs() / grid.dy)
        .ceil()
        .max(1.0) as usize;
    let mut bad = 0usize;
    for k in 0..=steps {
        let t = k as f64 / steps as f64;
        let (x, y) = (x1 + t * (x2 - x1), y1 + t * (y2 - y1));
        let col = (x / grid.dx).round();
        let row = (y / grid.dy).round();
        if col < 0.0 || row < 0.0 || col >= grid.nx as f64 || row >= grid.ny as f64 {
            bad += 1;
            continue;
        }
        let i = row as usize * grid.nx + col as usize;
        let below = grid.z[i] - grid.z_ref < p.a * x + p.b * y + p.c - params.inlier_band_um;
        if !grid.valid[i] || below {
            bad += 1;
        }
    }
    bad as f64 <= 0.02 * (steps + 1) as f64
}

/// Merges pieces of one flake separated by occluding flakes (module docs, step 4).
/// Returns groups of piece indices, each sorted, ordered by their smallest piece.
pub(super) fn merge_pieces(
    grid: &Grid<'_>,
    pieces: &[Piece],
    params: &SegmentParams,
) -> Vec<Vec<usize>> {
    let n = pieces.len();
    let mut cands: Vec<(f64, usize, usize)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            (i + 1..n).filter_map(move |j| {
                if pieces[i].bbox.gap(&pieces[j].bbox) > params.merge_gap_um {
                    return None;
                }
                let score = merge_score(&pieces[i].sums, &pieces[j].sums, params)?;
                line_supported(grid, &pieces[i].sums, &pieces[j].sums, params)
                    .then_some((score, i, j))
            })
        })
        .collect();
    cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut sums: Vec<Sums> = pieces.iter().map(|p| p.sums).collect();
    for (_, i, j) in cands {
        let (ri, rj) = (find(&mut parent, i as u32), find(&mut parent, j as u32));
        if ri == rj {
            continue;
        }
        let (si, sj) = (&sums[ri as usize], &sums[rj as usize]);
        if merge_score(si, sj, params).is_some() && line_supported(grid, si, sj, params) {
            let joint = sums[ri as usize].plus(&sums[rj as usize]);
            union(&mut parent, ri, rj);
            let r = find(&mut parent, ri) as usize;
            sums[r] = joint;
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut slot = vec![usize::MAX; n];
    for i in 0..n {
        let r = find(&mut parent, i as u32) as usize;
        if slot[r] == usize::MAX {
            slot[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[slot[r]].push(i);
    }
    groups
}
