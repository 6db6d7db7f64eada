//! Flakes as thin discs and their z-buffer rendering as seen from above.
//!
//! Conventions: lengths in µm, `z` up (into the air), heights measured from the substrate.
//! A disc has mid-plane centre `c = (cx, cy, cz)`, unit normal `m` with `m.z > 0`,
//! diameter `d` and thickness `t`. Its **top face** is the disc of radius `d/2` centred at
//! `c_top = c + (t/2) m` in the plane through `c_top` with normal `m`; above the point
//! `(cx, cy)` that plane is at `cz + t / (2 m.z)`. A pixel centre `(x, y)` is covered when
//! the point `p = (x, y, z_top(x, y))` of that plane satisfies `|p - c_top| ≤ d/2`; the
//! covered set is an ellipse with semi-axes `d/2` and `m.z d/2`, of area
//! `π d² m.z / 4`. The rim (side wall, height `t`) is not drawn: a heightfield seen from
//! above cannot show the steep wall, and a confocal microscope does not resolve it either.
//!
//! Occlusion: each pixel shows the top-most covering face (a z-buffer); on an exact tie
//! the disc that comes first in the list wins. The label map holds the 1-based index of
//! the visible disc, `0` where none is visible.

use nalgebra::{Unit, Vector3};
use rayon::prelude::*;

use crate::SynthError;

/// One flake: a thin circular disc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// `x` of the mid-plane centre, µm (`x = col * dx` on the map).
    pub centre_x_um: f64,
    /// `y` of the mid-plane centre, µm (`y = row * dy` on the map).
    pub centre_y_um: f64,
    /// Height of the mid-plane centre above the substrate, µm.
    pub centre_z_um: f64,
    /// Diameter, µm (> 0).
    pub diameter_um: f64,
    /// Thickness, µm (≥ 0).
    pub thickness_um: f64,
    /// Unit normal of the faces, pointing up (`z > 0`).
    pub normal: Unit<Vector3<f64>>,
}

impl Disc {
    /// Centre of the top face, `c + (t/2) m`, µm.
    pub fn top_centre(&self) -> Vector3<f64> {
        Vector3::new(self.centre_x_um, self.centre_y_um, self.centre_z_um)
            + 0.5 * self.thickness_um * self.normal.into_inner()
    }

    /// Height of the top face above the map point `(x, y)` (µm), or `None` when that
    /// point of the plane is farther than `d/2` from the face centre.
    pub fn top_height_at(&self, x_um: f64, y_um: f64) -> Option<f64> {
        let g = Geometry::new(self);
        g.height(x_um, y_um)
    }

    /// True area of one face, `π d² / 4`, µm².
    pub fn true_area_um2(&self) -> f64 {
        std::f64::consts::PI * self.diameter_um * self.diameter_um / 4.0
    }

    pub(crate) fn validate(&self, index: usize) -> Result<(), SynthError> {
        let fields = [
            self.centre_x_um,
            self.centre_y_um,
            self.centre_z_um,
            self.diameter_um,
            self.thickness_um,
        ];
        let reason = if fields.iter().any(|v| !v.is_finite()) {
            Some("coordinates, diameter and thickness must be finite")
        } else if self.diameter_um <= 0.0 {
            Some("diameter must be > 0")
        } else if self.thickness_um < 0.0 {
            Some("thickness must be >= 0")
        } else if self.normal.iter().any(|v| !v.is_finite())
            || self.normal.z <= 0.0
            || (self.normal.norm() - 1.0).abs() > 1e-9
        {
            Some("normal must be a unit vector with z > 0")
        } else {
            None
        };
        match reason {
            Some(reason) => Err(SynthError::InvalidDisc { index, reason }),
            None => Ok(()),
        }
    }
}

/// Precomputed quantities of one disc for the inner loop.
#[derive(Debug, Clone, Copy)]
struct Geometry {
    top: Vector3<f64>,
    mx: f64,
    my: f64,
    inv_mz: f64,
    r2: f64,
    r: f64,
}

impl Geometry {
    fn new(d: &Disc) -> Self {
        let r = 0.5 * d.diameter_um;
        Self {
            top: d.top_centre(),
            mx: d.normal.x,
            my: d.normal.y,
            inv_mz: 1.0 / d.normal.z,
            r2: r * r,
            r,
        }
    }

    #[inline]
    fn height(&self, x: f64, y: f64) -> Option<f64> {
        let ex = x - self.top.x;
        let ey = y - self.top.y;
        // Stay in the plane m·(p - c_top) = 0.
        let ez = -(self.mx * ex + self.my * ey) * self.inv_mz;
        (ex * ex + ey * ey + ez * ez <= self.r2).then_some(self.top.z + ez)
    }
}

/// Rows per parallel work unit (fixed, so results never depend on the thread count).
const BAND: usize = 16;

/// Renders `discs` on an `nx × ny` grid of pitch `dx × dy` µm (pixel centres at
/// `x = col dx`, `y = row dy`). Returns the top-most face height per pixel (µm,
/// `-∞` where no disc is visible) and the label map (1-based disc index, `0` = none).
///
/// Discs are assumed valid (see [`Disc`]); `generate` checks them.
pub(crate) fn render(
    nx: usize,
    ny: usize,
    dx: f64,
    dy: f64,
    discs: &[Disc],
) -> (Vec<f64>, Vec<u32>) {
    let geo: Vec<Geometry> = discs.iter().map(Geometry::new).collect();
    let bands = ny.div_ceil(BAND);
    // Bucket discs by band, in ascending disc order.
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (i, g) in geo.iter().enumerate() {
        let lo = ((g.top.y - g.r) / dy).ceil();
        let hi = ((g.top.y + g.r) / dy).floor();
        if hi < 0.0 || lo > (ny - 1) as f64 {
            continue;
        }
        let (lo, hi) = (lo.max(0.0) as usize, (hi as usize).min(ny - 1));
        for bucket in &mut buckets[lo / BAND..=hi / BAND] {
            bucket.push(i as u32);
        }
    }
    let mut z = vec![f64::NEG_INFINITY; nx * ny];
    let mut labels = vec![0u32; nx * ny];
    z.par_chunks_mut(nx * BAND)
        .zip(labels.par_chunks_mut(nx * BAND))
        .enumerate()
        .for_each(|(b, (zb, lb))| {
            let row0 = b * BAND;
            let rows = zb.len() / nx;
            for &i in &buckets[b] {
                let g = &geo[i as usize];
                let r_lo = (((g.top.y - g.r) / dy).ceil().max(row0 as f64)) as usize;
                let r_hi = (((g.top.y + g.r) / dy).floor()).min((row0 + rows - 1) as f64);
                if r_hi < r_lo as f64 {
                    continue;
                }
                let c_lo = ((g.top.x - g.r) / dx).ceil().max(0.0);
                let c_hi = ((g.top.x + g.r) / dx).floor().min((nx - 1) as f64);
                if c_hi < c_lo {
                    continue;
                }
                let (c_lo, c_hi) = (c_lo as usize, c_hi as usize);
                for row in r_lo..=r_hi as usize {
                    let y = row as f64 * dy;
                    let off = (row - row0) * nx;
                    for col in c_lo..=c_hi {
                        if let Some(h) = g.height(col as f64 * dx, y) {
                            let k = off + col;
                            if h > zb[k] {
                                zb[k] = h;
                                lb[k] = i + 1;
                            }
                        }
                    }
                }
            }
        });
    (z, labels)
}
