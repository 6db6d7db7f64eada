//! Automated segmentation of confocal height maps into individual flakes (issue 8).
//!
//! Conventions (`physics.md` §1, §5): heights and pitches in **micrometres**, angles in
//! **radians**, map axes `x = col · dx`, `y = row · dy` (row-major), `z` the coating
//! normal pointing into the air. Flake normals have `z > 0`; `θn` is their polar angle,
//! `φn ∈ [0, 2π)` their azimuth from `+x` toward `+y` (see [`crate::flake`]).
//!
//! The paper measured flakes by hand and notes that an automated analysis "requires a
//! robust edge-finding algorithm". The algorithm here:
//!
//! 1. **Mask.** Only valid pixels of the [`HeightMap`] take part (apply the intensity
//!    cutoff first with [`HeightMap::apply_intensity_cutoff`]).
//! 2. **Height-jump edges.** Two 4-neighbouring valid pixels are linked when their
//!    heights differ by at most [`SegmentParams::max_step_um`]. Inside a flake
//!    neighbours differ by at most one z step plus noise (a flake tilted by θ rises
//!    `dx · tan θ` per pixel, 0.016 µm for 5° at 0.18 µm); where one flake lies over
//!    another the height jumps. Connected components of the links (union–find, 4-
//!    connectivity) are the candidate regions.
//! 3. **Plane splitting (normal turns).** Two flakes that cross each other meet without a
//!    height jump along their intersection line; their regions are joined in step 2. Each
//!    region is therefore fitted with a robust plane: candidate planes are least-squares
//!    fits on a 4 × 4 grid of sub-blocks of the region (plus the whole region), the
//!    candidate with the most points within the inlier band wins, and it is refined by
//!    iterated least squares on the inliers with the band
//!    `max(inlier_band_um, reject_sigmas · 1.4826 · median|r|)` (MAD rejection). The
//!    largest connected set of inliers is one flake; the rest of the region is split
//!    into linked components again and each is treated the same way. Small leftover
//!    pieces (below [`SegmentParams::min_pixels`]) that touch a flake are kept with it as
//!    rejected points (they count for its area, not for its plane); others are dropped.
//! 4. **Merging.** A flake partly covered by another shows as separate pieces. Pieces
//!    whose bounding boxes lie within [`SegmentParams::merge_gap_um`] of each other,
//!    whose normals agree within [`SegmentParams::merge_angle`], and whose joint
//!    least-squares plane fits both no worse than `merge_ms_ratio` times their pooled
//!    mean square residual (plus `inlier_band_um²/16`) are merged, most similar pairs
//!    first.
//! 5. **Per flake**: the least-squares plane through its inlier points (paper eq. 5), the
//!    normal, `θn`, `φn`, projected area `N · dx · dy`, true area `projected / nz`,
//!    equivalent diameter `sqrt(4 · true area / π)`, residual rms (roughness plus
//!    instrument noise and quantisation), whether it touches the map border, and a
//!    quality score.
//!
//! Every step is deterministic: the union–find runs in raster order, regions are
//! processed in parallel but collected in order, and merging is sequential; results do
//! not depend on the number of threads.
//!
//! Memory: one `u32` per pixel is alive throughout, the label map. It starts as the
//! union–find parent array, is relabelled in place to region numbers (with one bit per
//! pixel while it is), the split stage writes piece numbers over each region's pixels
//! and the last pass turns them into the flake labels of [`Segmentation::labels`].
//! Pixel lists exist only for the regions being split in one batch (at most
//! `SPLIT_BATCH_PIXELS` pixels, or one larger region) and their pieces; everything else
//! is per region, piece or flake.
//!
//! Code map: `params` (parameters and errors), `links` (steps 1–2), `split` (step 3),
//! `merge` (step 4), `plane` (least-squares sums shared by both), and this file (the
//! entry point and step 5).

mod links;
mod merge;
mod params;
mod plane;
mod split;

use std::f64::consts::PI;

use rayon::prelude::*;

use crate::flake::{Flake, UnitVec3, polar_from_normal};
use crate::heightmap::HeightMap;

use links::{Grid, NONE, REGION, Region, linked_regions, region_pixels};
use merge::merge_pieces;
pub use params::{SegmentError, SegmentParams};

/// Most pixels of the regions split in one parallel batch (a single larger region is a
/// batch of its own): bounds the pixel lists alive at once (the batch's regions and
/// pieces, 4 bytes per pixel each) while leaving the threads enough regions to share.
const SPLIT_BATCH_PIXELS: usize = 1 << 20;
use plane::{Plane, Sums, normal_of};
use split::{Piece, split_region};

/// Why a segmentation found nothing (the result is then empty, not an error).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SegmentWarning {
    /// The map has no valid pixel (all masked or NaN).
    NoValidPixels,
    /// Valid pixels exist but no region reached `min_pixels` with a usable plane.
    NoFlakes,
}

impl std::fmt::Display for SegmentWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::NoValidPixels => "the map has no valid pixel: no flake can be found",
            Self::NoFlakes => {
                "no flake found: no connected region of valid pixels is large enough and planar"
            }
        })
    }
}

/// One flake found by [`segment`].
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentedFlake {
    /// Unit normal of the fitted plane, `z > 0`.
    pub normal: UnitVec3,
    /// Polar angle of the normal, radians.
    pub theta_n: f64,
    /// Azimuth of the normal, radians in `[0, 2π)` from `+x` toward `+y`.
    pub phi_n: f64,
    /// Centroid of the flake's pixels `(x, y)`, µm in map coordinates.
    pub centre_um: [f64; 2],
    /// Number of pixels assigned to the flake (inliers plus rejected points).
    pub pixels: usize,
    /// Number of pixels used for the plane (inliers).
    pub inliers: usize,
    /// Projected area on the `xy` plane, `pixels · dx · dy`, µm².
    pub projected_area_um2: f64,
    /// True (visible) area on the flake, `projected / nz`, µm².
    pub area_um2: f64,
    /// Diameter of a disc of the same true area, `sqrt(4 · area / π)`, µm.
    pub equivalent_diameter_um: f64,
    /// Root mean square of the inliers' height residuals about the plane, µm (roughness
    /// plus noise and quantisation).
    pub rms_um: f64,
    /// Standard error of the tilt, radians: `rms · sqrt((Sxx + Syy)/det)` from the
    /// least-squares normal equations (optimistic when residuals are correlated, e.g.
    /// by quantisation).
    pub tilt_se: f64,
    /// Whether a pixel of the flake lies on the first or last row or column.
    pub touches_border: bool,
    /// Quality in `(0, 1]`: `inliers / pixels · exp(−tilt_se / 0.1°)`.
    pub quality: f64,
}

impl SegmentedFlake {
    /// The flake as a [`Flake`] (normal, true area, centre) for histograms and fits.
    pub fn to_flake(&self) -> Flake {
        Flake {
            normal: self.normal,
            area_um2: self.area_um2,
            centre_um: Some(self.centre_um),
        }
    }
}

/// Result of [`segment`].
#[derive(Debug, Clone, PartialEq)]
pub struct Segmentation {
    /// Flakes found, ordered by their first pixel in raster order.
    pub flakes: Vec<SegmentedFlake>,
    /// Row-major label map: `k + 1` where flake `k` lies, `0` elsewhere.
    pub labels: Vec<u32>,
    /// Valid pixels of the map.
    pub valid_pixels: usize,
    /// Valid pixels assigned to no flake (regions too small or not planar).
    pub dropped_pixels: usize,
    /// Set when no flake was found, saying why.
    pub warning: Option<SegmentWarning>,
}

/// Step 3 of [`segment`]: the planar pieces of the linked `regions`, in parallel within
/// batches of regions, numbered in region order; each batch's pieces are written into
/// the label map as piece numbers, so only one batch's pixel lists are alive at a time.
fn planar_pieces(
    grid: &Grid<'_>,
    labels: &mut [u32],
    regions: &[Region],
    params: &SegmentParams,
) -> Vec<Piece> {
    let nx = grid.nx;
    let mut pieces: Vec<Piece> = Vec::new();
    let mut start = 0;
    while start < regions.len() {
        let mut end = start + 1;
        let mut batch = regions[start].size;
        while end < regions.len() && batch + regions[end].size <= SPLIT_BATCH_PIXELS {
            batch += regions[end].size;
            end += 1;
        }
        let split: Vec<(Vec<u32>, Piece)> = region_pixels(nx, labels, &regions[start..end], start)
            .into_par_iter()
            .flat_map_iter(|pixels| split_region(grid, pixels, params))
            .collect();
        for (pixels, piece) in split {
            let q = pieces.len() as u32;
            for p in pixels {
                labels[p as usize] = q;
            }
            pieces.push(piece);
        }
        start = end;
    }
    pieces
}

/// Finds the individual flakes of a height map (module docs).
///
/// ```
/// use flakescatter_stats::heightmap::HeightMap;
/// use flakescatter_stats::segment::{SegmentParams, segment};
///
/// // 40 x 20 pixels of 0.2 µm: a flake z = 0.05 x (left) next to one 4 µm higher.
/// let z: Vec<f64> = (0..20 * 40)
///     .map(|i| {
///         let x = (i % 40) as f64 * 0.2;
///         if i % 40 < 20 { 0.05 * x } else { 4.0 }
///     })
///     .collect();
/// let map = HeightMap::new(40, 20, 0.2, 0.2, z)?;
/// let seg = segment(&map, &SegmentParams::default())?;
/// assert_eq!(seg.flakes.len(), 2);
/// // tan θn = 0.05 for the left flake; its area is 400 pixels × 0.04 µm² / nz.
/// assert!((seg.flakes[0].theta_n - 0.05f64.atan()).abs() < 1e-9);
/// assert_eq!(seg.flakes[0].pixels, 400);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// Invalid pixels are ignored; a map without valid pixels, or without any region large
/// and planar enough, gives an empty result with [`Segmentation::warning`] set.
///
/// # Errors
/// [`SegmentError::BadParameter`] for a parameter out of range.
pub fn segment(map: &HeightMap, params: &SegmentParams) -> Result<Segmentation, SegmentError> {
    params.validate()?;
    let (nx, ny) = (map.nx(), map.ny());
    let n = nx * ny;
    let z = map.heights();
    let valid = map.valid();
    let valid_pixels = map.valid_count();
    let empty = |warning| Segmentation {
        flakes: Vec::new(),
        labels: vec![0; n],
        valid_pixels,
        dropped_pixels: valid_pixels,
        warning: Some(warning),
    };
    if valid_pixels == 0 {
        return Ok(empty(SegmentWarning::NoValidPixels));
    }
    if n > u32::MAX as usize - 1 {
        return Err(SegmentError::BadParameter {
            name: "map size",
            value: n as f64,
            expected: "fewer than 2^32 - 1 pixels",
        });
    }
    let z_ref = map.summary().map_or(0.0, |s| s.mean);
    let grid = Grid {
        nx,
        ny,
        dx: map.dx(),
        dy: map.dy(),
        z,
        valid,
        z_ref,
        max_step: params.max_step_um,
    };

    // Step 2: the label map, `REGION | k` on linked region k (of at least `min_pixels`).
    let (mut labels, regions) = linked_regions(&grid, params);

    // Step 3: planar pieces (`planar_pieces`).
    let pieces = planar_pieces(&grid, &mut labels, &regions, params);
    drop(regions);

    // Step 4: merge pieces of one flake.
    let groups = merge_pieces(&grid, &pieces, params);

    // Step 5: per flake outputs. The plane of each group, then one raster pass over the
    // label map: a group's pixels are visited in ascending order (as the sums below
    // require), flakes are numbered in order of their first pixel and the label map
    // becomes the output's (`k + 1` on flake k, 0 elsewhere).
    let (dx, dy) = (map.dx(), map.dy());
    // Groups with a plane: (inlier sums, inlier count, plane); `fit_of[piece]` indexes
    // them, NONE for pieces of a group without one.
    let mut fits: Vec<(Sums, usize, Plane)> = Vec::with_capacity(groups.len());
    let mut fit_of = vec![NONE; pieces.len()];
    let planes: Vec<Option<(Sums, usize, Plane)>> = groups
        .par_iter()
        .map(|g| {
            let sums = g
                .iter()
                .fold(Sums::default(), |s, &i| s.plus(&pieces[i].sums));
            let inliers: usize = g.iter().map(|&i| pieces[i].inliers).sum();
            sums.plane().map(|plane| (sums, inliers, plane))
        })
        .collect();
    for (g, fit) in groups.iter().zip(planes) {
        if let Some(fit) = fit {
            for &i in g {
                fit_of[i] = fits.len() as u32;
            }
            fits.push(fit);
        }
    }
    // Per flake in output order: its fit, pixel count, sums of x and y, border flag.
    struct Tally {
        fit: usize,
        count: usize,
        cx: f64,
        cy: f64,
        touches_border: bool,
    }
    let mut flake_of = vec![NONE; fits.len()];
    let mut tallies: Vec<Tally> = Vec::new();
    for row in 0..ny {
        for col in 0..nx {
            let i = row * nx + col;
            let l = labels[i];
            let g = if l < REGION { fit_of[l as usize] } else { NONE };
            if g == NONE {
                labels[i] = 0;
                continue;
            }
            let f = &mut flake_of[g as usize];
            if *f == NONE {
                *f = tallies.len() as u32;
                tallies.push(Tally {
                    fit: g as usize,
                    count: 0,
                    cx: 0.0,
                    cy: 0.0,
                    touches_border: false,
                });
            }
            let t = &mut tallies[*f as usize];
            t.count += 1;
            t.cx += col as f64 * dx;
            t.cy += row as f64 * dy;
            t.touches_border |= row == 0 || col == 0 || row + 1 == ny || col + 1 == nx;
            labels[i] = *f + 1;
        }
    }
    let assigned: usize = tallies.iter().map(|t| t.count).sum();
    let flakes: Vec<SegmentedFlake> = tallies
        .iter()
        .map(|t| {
            let (sums, inliers, plane) = fits[t.fit];
            let normal = normal_of(&plane);
            let (theta_n, phi_n) = polar_from_normal(&normal);
            let count = t.count;
            let projected = count as f64 * dx * dy;
            let area = projected / normal.z;
            let rms = (plane.sse / sums.n).sqrt();
            let tilt_se = rms * plane.se_factor.sqrt();
            let quality = inliers as f64 / count as f64 * (-tilt_se / 0.1f64.to_radians()).exp();
            SegmentedFlake {
                normal,
                theta_n,
                phi_n,
                centre_um: [t.cx / count as f64, t.cy / count as f64],
                pixels: count,
                inliers,
                projected_area_um2: projected,
                area_um2: area,
                equivalent_diameter_um: (4.0 * area / PI).sqrt(),
                rms_um: rms,
                tilt_se,
                touches_border: t.touches_border,
                quality,
            }
        })
        .collect();
    let warning = flakes.is_empty().then_some(SegmentWarning::NoFlakes);
    Ok(Segmentation {
        flakes,
        labels,
        valid_pixels,
        dropped_pixels: valid_pixels - assigned,
        warning,
    })
}
