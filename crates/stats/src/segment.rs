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

use std::f64::consts::PI;

use nalgebra::{Unit, Vector3};
use rayon::prelude::*;
use thiserror::Error;

use crate::flake::{Flake, UnitVec3, polar_from_normal};
use crate::heightmap::HeightMap;

/// Errors from [`segment`]: only bad parameters (bad maps give an empty result with a
/// [`SegmentWarning`]).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SegmentError {
    /// A parameter is not finite or out of its range.
    #[error("segmentation parameter {name} = {value} is invalid: expected {expected}")]
    BadParameter {
        /// The field of [`SegmentParams`].
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
}

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

/// Tuning of [`segment`]. Build with [`SegmentParams::for_instrument`] (or `default()`,
/// the paper's microscope) and adjust fields if needed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentParams {
    /// Largest height difference between 4-neighbouring pixels of one flake, µm.
    pub max_step_um: f64,
    /// Smallest half-width of the band of accepted plane residuals, µm.
    pub inlier_band_um: f64,
    /// Residuals beyond this many robust standard deviations (1.4826 · MAD) are rejected.
    pub reject_sigmas: f64,
    /// Smallest flake, in pixels (≥ 3).
    pub min_pixels: usize,
    /// Largest angle between the normals of two pieces that may be merged, radians.
    pub merge_angle: f64,
    /// Largest gap between the bounding boxes of two pieces that may be merged, µm.
    pub merge_gap_um: f64,
    /// Two pieces merge only if their joint plane's mean square residual is at most this
    /// factor times their pooled mean square residual (plus `inlier_band_um² / 16`).
    pub merge_ms_ratio: f64,
}

impl SegmentParams {
    /// Thresholds derived from the instrument: z quantisation step `z_step_um` (µm, `0`
    /// for none) and height noise standard deviation `noise_sd_um` (µm).
    ///
    /// `max_step_um = z_step + max(0.2, 6 · noise)` and
    /// `inlier_band_um = z_step / 2 + 4 · noise + 0.02`: a quantised plane deviates from
    /// the true plane by at most half a step, noise by a few sd. Other fields: 2.5 sigmas,
    /// 100 pixels, 10°, 25 µm, ratio 1.5.
    pub fn for_instrument(z_step_um: f64, noise_sd_um: f64) -> Self {
        Self {
            max_step_um: z_step_um + (6.0 * noise_sd_um).max(0.2),
            inlier_band_um: 0.5 * z_step_um + 4.0 * noise_sd_um + 0.02,
            reject_sigmas: 2.5,
            min_pixels: 100,
            merge_angle: 10f64.to_radians(),
            merge_gap_um: 25.0,
            merge_ms_ratio: 1.5,
        }
    }

    fn validate(&self) -> Result<(), SegmentError> {
        let check = |name: &'static str, value: f64, ok: bool, expected: &'static str| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(SegmentError::BadParameter {
                    name,
                    value,
                    expected,
                })
            }
        };
        check(
            "max_step_um",
            self.max_step_um,
            self.max_step_um > 0.0,
            "finite and > 0 µm",
        )?;
        check(
            "inlier_band_um",
            self.inlier_band_um,
            self.inlier_band_um > 0.0,
            "finite and > 0 µm",
        )?;
        check(
            "reject_sigmas",
            self.reject_sigmas,
            self.reject_sigmas > 0.0,
            "finite and > 0",
        )?;
        check(
            "min_pixels",
            self.min_pixels as f64,
            self.min_pixels >= 3,
            "at least 3",
        )?;
        check(
            "merge_angle",
            self.merge_angle,
            (0.0..PI / 2.0).contains(&self.merge_angle),
            "in [0, π/2) rad",
        )?;
        check(
            "merge_gap_um",
            self.merge_gap_um,
            self.merge_gap_um >= 0.0,
            "finite and >= 0 µm",
        )?;
        check(
            "merge_ms_ratio",
            self.merge_ms_ratio,
            self.merge_ms_ratio >= 1.0,
            "finite and >= 1",
        )
    }
}

impl Default for SegmentParams {
    /// [`SegmentParams::for_instrument`]`(0.3, 0.03)`: the paper's 0.3 µm z step and a
    /// 30 nm height noise.
    fn default() -> Self {
        Self::for_instrument(0.3, 0.03)
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

/// Sums over points `(x, y, z)` for an exact least-squares plane (coordinates relative
/// to a fixed origin).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Sums {
    n: f64,
    x: f64,
    y: f64,
    z: f64,
    xx: f64,
    xy: f64,
    yy: f64,
    xz: f64,
    yz: f64,
    zz: f64,
}

#[derive(Debug, Clone, Copy)]
struct Plane {
    a: f64,
    b: f64,
    c: f64,
    /// Residual sum of squares.
    sse: f64,
    /// `(Sxx + Syy) / det` of the centred normal equations, 1/µm².
    se_factor: f64,
}

impl Sums {
    fn add(&mut self, p: [f64; 3]) {
        let [x, y, z] = p;
        self.n += 1.0;
        self.x += x;
        self.y += y;
        self.z += z;
        self.xx += x * x;
        self.xy += x * y;
        self.yy += y * y;
        self.xz += x * z;
        self.yz += y * z;
        self.zz += z * z;
    }

    fn plus(&self, o: &Self) -> Self {
        Self {
            n: self.n + o.n,
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
            xx: self.xx + o.xx,
            xy: self.xy + o.xy,
            yy: self.yy + o.yy,
            xz: self.xz + o.xz,
            yz: self.yz + o.yz,
            zz: self.zz + o.zz,
        }
    }

    /// Sum of squared residuals of these points about the plane `p`.
    fn sse_about(&self, p: &Plane) -> f64 {
        let (a, b, c) = (p.a, p.b, p.c);
        (self.zz - 2.0 * (a * self.xz + b * self.yz + c * self.z)
            + a * a * self.xx
            + 2.0 * a * b * self.xy
            + b * b * self.yy
            + 2.0 * c * (a * self.x + b * self.y)
            + c * c * self.n)
            .max(0.0)
    }

    /// Least-squares plane `z = a x + b y + c`; `None` if fewer than 3 points or the
    /// points are collinear.
    fn plane(&self) -> Option<Plane> {
        let n = self.n;
        if n < 3.0 {
            return None;
        }
        let (mx, my, mz) = (self.x / n, self.y / n, self.z / n);
        let sxx = self.xx - n * mx * mx;
        let syy = self.yy - n * my * my;
        let sxy = self.xy - n * mx * my;
        let sxz = self.xz - n * mx * mz;
        let syz = self.yz - n * my * mz;
        let szz = self.zz - n * mz * mz;
        let det = sxx * syy - sxy * sxy;
        if det.is_nan() || det <= 1e-9 * (sxx * syy).max(f64::MIN_POSITIVE) {
            return None;
        }
        let a = (sxz * syy - syz * sxy) / det;
        let b = (syz * sxx - sxz * sxy) / det;
        let c = mz - a * mx - b * my;
        let sse = (szz - a * sxz - b * syz).max(0.0);
        Some(Plane {
            a,
            b,
            c,
            sse,
            se_factor: (sxx + syy) / det,
        })
    }
}

/// Union–find with path halving; the smaller index becomes the root (deterministic).
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = parent[i as usize];
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// Read-only view of the map used by the per-region work.
struct Grid<'a> {
    nx: usize,
    ny: usize,
    dx: f64,
    dy: f64,
    z: &'a [f64],
    valid: &'a [bool],
    z_ref: f64,
    max_step: f64,
}

impl Grid<'_> {
    fn point(&self, i: u32) -> [f64; 3] {
        let i = i as usize;
        let (row, col) = (i / self.nx, i % self.nx);
        [
            col as f64 * self.dx,
            row as f64 * self.dy,
            self.z[i] - self.z_ref,
        ]
    }

    fn linked(&self, i: usize, j: usize) -> bool {
        (self.z[i] - self.z[j]).abs() <= self.max_step
    }
}

/// A region's pixels on a local bounding-box grid, for connected components.
struct Local {
    col0: usize,
    row0: usize,
    w: usize,
    h: usize,
    /// `slot[local] = position in the pixel list + 1`, `0` if the pixel is not in it.
    slot: Vec<u32>,
}

impl Local {
    fn new(grid: &Grid<'_>, pixels: &[u32]) -> Self {
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
    fn components(&self, grid: &Grid<'_>, pixels: &[u32], keep: &[bool]) -> Vec<Vec<usize>> {
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

/// A planar piece: its pixels (global indices, ascending), which of them are inliers,
/// and the inlier sums.
#[derive(Debug, Clone)]
struct Piece {
    pixels: Vec<u32>,
    inliers: usize,
    sums: Sums,
}

fn fit_sums(pts: &[[f64; 3]], keep: impl Fn(usize) -> bool) -> Sums {
    let mut s = Sums::default();
    for (k, p) in pts.iter().enumerate() {
        if keep(k) {
            s.add(*p);
        }
    }
    s
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

/// Splits one linked region into planar pieces (module docs, step 3).
fn split_region(grid: &Grid<'_>, region: Vec<u32>, params: &SegmentParams) -> Vec<Piece> {
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
        let mut piece_pos = main.clone();
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
                piece_pos.extend_from_slice(&comp);
            }
        }
        piece_pos.sort_unstable();
        out.push(Piece {
            pixels: piece_pos.iter().map(|&k| pixels[k]).collect(),
            inliers,
            sums,
        });
    }
    out
}

#[derive(Debug, Clone, Copy)]
struct BBox {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
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

    fn gap(&self, o: &Self) -> f64 {
        let gx = (o.x0 - self.x1).max(self.x0 - o.x1).max(0.0);
        let gy = (o.y0 - self.y1).max(self.y0 - o.y1).max(0.0);
        gx.hypot(gy)
    }
}

fn normal_of(p: &Plane) -> UnitVec3 {
    Unit::new_normalize(Vector3::new(-p.a, -p.b, 1.0))
}

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
fn merge_pieces(grid: &Grid<'_>, pieces: &[Piece], params: &SegmentParams) -> Vec<Vec<usize>> {
    let boxes: Vec<BBox> = pieces.iter().map(|p| BBox::of(grid, &p.pixels)).collect();
    let n = pieces.len();
    let mut cands: Vec<(f64, usize, usize)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let boxes = &boxes;
            (i + 1..n).filter_map(move |j| {
                if boxes[i].gap(&boxes[j]) > params.merge_gap_um {
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

    // Step 2: union-find over linked 4-neighbours, in raster order.
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

    // Step 3: planar pieces, in parallel, collected in region order.
    let pieces: Vec<Piece> = regions
        .into_par_iter()
        .flat_map_iter(|r| split_region(&grid, r, params))
        .collect();

    // Step 4: merge pieces of one flake.
    let groups = merge_pieces(&grid, &pieces, params);

    // Step 5: per flake outputs.
    let (dx, dy) = (map.dx(), map.dy());
    let mut found: Vec<(Vec<u32>, SegmentedFlake)> = groups
        .par_iter()
        .filter_map(|g| {
            let mut pixels: Vec<u32> = g
                .iter()
                .flat_map(|&i| pieces[i].pixels.iter().copied())
                .collect();
            pixels.sort_unstable();
            let sums = g
                .iter()
                .fold(Sums::default(), |s, &i| s.plus(&pieces[i].sums));
            let inliers: usize = g.iter().map(|&i| pieces[i].inliers).sum();
            let plane = sums.plane()?;
            let normal = normal_of(&plane);
            let (theta_n, phi_n) = polar_from_normal(&normal);
            let count = pixels.len();
            let (mut cx, mut cy) = (0.0, 0.0);
            let mut touches_border = false;
            for &p in &pixels {
                let (r, c) = (p as usize / nx, p as usize % nx);
                cx += c as f64 * dx;
                cy += r as f64 * dy;
                touches_border |= r == 0 || c == 0 || r + 1 == ny || c + 1 == nx;
            }
            let projected = count as f64 * dx * dy;
            let area = projected / normal.z;
            let rms = (plane.sse / sums.n).sqrt();
            let tilt_se = rms * plane.se_factor.sqrt();
            let quality = inliers as f64 / count as f64 * (-tilt_se / 0.1f64.to_radians()).exp();
            let flake = SegmentedFlake {
                normal,
                theta_n,
                phi_n,
                centre_um: [cx / count as f64, cy / count as f64],
                pixels: count,
                inliers,
                projected_area_um2: projected,
                area_um2: area,
                equivalent_diameter_um: (4.0 * area / PI).sqrt(),
                rms_um: rms,
                tilt_se,
                touches_border,
                quality,
            };
            Some((pixels, flake))
        })
        .collect();
    found.sort_by_key(|(p, _)| p[0]);
    let mut labels = vec![0u32; n];
    let mut assigned = 0usize;
    for (k, (pixels, _)) in found.iter().enumerate() {
        assigned += pixels.len();
        for &p in pixels {
            labels[p as usize] = k as u32 + 1;
        }
    }
    let flakes: Vec<SegmentedFlake> = found.into_iter().map(|(_, f)| f).collect();
    let warning = flakes.is_empty().then_some(SegmentWarning::NoFlakes);
    Ok(Segmentation {
        flakes,
        labels,
        valid_pixels,
        dropped_pixels: valid_pixels - assigned,
        warning,
    })
}
