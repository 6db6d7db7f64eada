//! Pictures to check a segmentation, as data: per map an RGB raster of the height map
//! in grey with each flake filled in the colour of its tilt `θn` and outlined, the
//! pixels the segmentation set aside hatched and those without data tinted, plus where
//! to write flake numbers. The command-line tool adds the colour bar and text and
//! encodes the PNG; the library decides every pixel of the map area.
//!
//! Conventions: image `x` along map columns, `y` along map rows (row 0 at the top, as
//! the map is stored); the map area is the top-left `width × height` pixels of the
//! image. Scale: maps whose larger side is below 512 points are enlarged by the integer
//! factor `⌊512 / side⌋` (each map point a square of image pixels), maps above 2048
//! points are reduced by `⌈side / 2048⌉` (each image pixel shows the map point at the
//! top-left of its block), others are drawn one image pixel per map point.
//!
//! Colours (8-bit sRGB):
//! * height: grey `g` from 60 (the 1st percentile of the valid heights) to 230 (the
//!   99th), clipped;
//! * flake pixels: `round(α c + (1 − α) g)` per channel, `α` = [`FILL_ALPHA`], with
//!   `c` the colour of the flake's `θn` on the viridis colour map (matplotlib's, 17
//!   anchors interpolated linearly, within 2 units of the full table) from 0 to
//!   `max_tilt` (flakes tilted more take the top colour). Because the grey adds the
//!   same to every channel, channel differences carry the tilt alone:
//!   `R − G ≈ α (c_R − c_G)`;
//! * outline: black where a flake pixel has a 4-neighbour outside the flake;
//! * valid pixels in no flake (regions too small or not planar): the grey crossed by
//!   orange diagonal hatching ([`HATCH`], every 8th image diagonal, 2 pixels wide);
//! * pixels without data (invalid in the file or below the intensity cutoff):
//!   [`NO_DATA`].

use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::segment::Segmentation;

/// Opacity of the tilt colour over the grey height.
pub const FILL_ALPHA: f64 = 0.6;
/// Colour of pixels without data.
pub const NO_DATA: [u8; 3] = [40, 40, 52];
/// Colour of the hatching of valid pixels in no flake.
pub const HATCH: [u8; 3] = [235, 120, 20];
/// Colour of flake outlines.
pub const OUTLINE: [u8; 3] = [0, 0, 0];
/// Default top of the tilt colour scale, radians (20°).
pub const DEFAULT_MAX_TILT: f64 = 0.349_065_850_398_865_9;
/// Flakes with at least this many image pixels get their number written.
pub const LABEL_MIN_IMAGE_PIXELS: usize = 1500;

/// The viridis colour map of matplotlib at `16 k / 255`, `k = 0..15`, and at 1.
const VIRIDIS: [[u8; 3]; 17] = [
    [68, 1, 84],
    [72, 24, 106],
    [71, 45, 123],
    [66, 64, 134],
    [59, 82, 139],
    [51, 99, 141],
    [44, 114, 142],
    [38, 130, 142],
    [33, 145, 140],
    [31, 160, 136],
    [40, 174, 128],
    [63, 188, 115],
    [94, 201, 98],
    [132, 212, 75],
    [173, 220, 48],
    [216, 226, 25],
    [253, 231, 37],
];

/// The viridis colour of `t` in `[0, 1]` (clamped), as floating-point channels.
#[must_use]
pub fn viridis(t: f64) -> [f64; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let pos = |k: usize| {
        if k == 16 {
            1.0
        } else {
            16.0 * k as f64 / 255.0
        }
    };
    let mut k = 0;
    while k < 15 && pos(k + 1) < t {
        k += 1;
    }
    let (a, b) = (pos(k), pos(k + 1));
    let f = ((t - a) / (b - a)).clamp(0.0, 1.0);
    let (c0, c1) = (VIRIDIS[k], VIRIDIS[k + 1]);
    [0, 1, 2].map(|i| f64::from(c0[i]) + f * (f64::from(c1[i]) - f64::from(c0[i])))
}

/// The colour of tilt `theta` (radians) on a scale from 0 to `max_tilt`.
#[must_use]
pub fn tilt_colour(theta: f64, max_tilt: f64) -> [u8; 3] {
    viridis(theta / max_tilt).map(|v| v.round().clamp(0.0, 255.0) as u8)
}

/// How a map is scaled into the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Each map point is a `k × k` square of image pixels.
    Up(usize),
    /// Each image pixel shows one map point of a `k × k` block (its top-left).
    Down(usize),
}

impl Scale {
    /// The scale for a map of `nx × ny` points (module docs).
    #[must_use]
    pub fn for_map(nx: usize, ny: usize) -> Self {
        let side = nx.max(ny).max(1);
        if side > 2048 {
            Self::Down(side.div_ceil(2048))
        } else {
            Self::Up((512 / side).max(1))
        }
    }

    /// Image pixels per map point (`1/k` when reduced).
    #[must_use]
    pub fn pixels_per_point(self) -> f64 {
        match self {
            Self::Up(k) => k as f64,
            Self::Down(k) => 1.0 / k as f64,
        }
    }
}

/// A flake number to write on the image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    /// Image column of the label's centre.
    pub x: u32,
    /// Image row of the label's centre.
    pub y: u32,
    /// The text (the flake's number in the flake table).
    pub text: String,
}

/// The overlay of one map (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// Width of the map area, image pixels.
    pub width: u32,
    /// Height of the map area, image pixels.
    pub height: u32,
    /// How map points are scaled.
    pub scale: Scale,
    /// The map area, row-major RGB, `width × height × 3` bytes.
    pub rgb: Vec<u8>,
    /// Flake numbers to write (flakes of at least [`LABEL_MIN_IMAGE_PIXELS`]).
    pub labels: Vec<Label>,
    /// Top of the tilt colour scale, radians.
    pub max_tilt: f64,
}

/// The overlay of `map` (as segmented, masks holding the intensity cutoff) and its
/// segmentation `seg`, tilts coloured from 0 to `max_tilt` radians (module docs).
/// A label map that does not fit the map gives a picture without flakes.
#[must_use]
pub fn overlay(map: &HeightMap, seg: &Segmentation, max_tilt: f64) -> Overlay {
    let (nx, ny) = (map.nx(), map.ny());
    let scale = Scale::for_map(nx, ny);
    let (w, h) = match scale {
        Scale::Up(k) => (nx * k, ny * k),
        Scale::Down(k) => (nx.div_ceil(k), ny.div_ceil(k)),
    };
    let point = |x: usize, y: usize| match scale {
        Scale::Up(k) => (x / k, y / k),
        Scale::Down(k) => (x * k, y * k),
    };
    let labels_ok = seg.labels.len() == nx * ny;
    let label = |c: usize, r: usize| if labels_ok { seg.labels[r * nx + c] } else { 0 };
    // Grey levels from the 1st to the 99th percentile of the valid heights.
    let mut valid: Vec<f64> = map
        .heights()
        .iter()
        .zip(map.valid())
        .filter(|(z, v)| **v && z.is_finite())
        .map(|(z, _)| *z)
        .collect();
    valid.sort_by(f64::total_cmp);
    let q = |f: f64| {
        if valid.is_empty() {
            0.0
        } else {
            valid[((valid.len() - 1) as f64 * f).round() as usize]
        }
    };
    let (z0, z1) = (q(0.01), q(0.99));
    let grey = |z: f64| {
        let t = if z1 > z0 { (z - z0) / (z1 - z0) } else { 0.5 };
        60.0 + 170.0 * t.clamp(0.0, 1.0)
    };
    let colours: Vec<[f64; 3]> = seg
        .flakes
        .iter()
        .map(|f| viridis(f.theta_n / max_tilt))
        .collect();
    let mut rgb = vec![0u8; w * h * 3];
    let mut image_pixels = vec![0usize; seg.flakes.len()];
    for y in 0..h {
        for x in 0..w {
            let (c, r) = point(x, y);
            let i = r * nx + c;
            let px: [u8; 3] = if !map.valid()[i] {
                NO_DATA
            } else {
                let g = grey(map.heights()[i]);
                let l = label(c, r);
                if l == 0 {
                    if (x + y) % 8 < 2 {
                        HATCH
                    } else {
                        [g.round() as u8; 3]
                    }
                } else {
                    image_pixels[l as usize - 1] += 1;
                    let edge = (c > 0 && label(c - 1, r) != l)
                        || (c + 1 < nx && label(c + 1, r) != l)
                        || (r > 0 && label(c, r - 1) != l)
                        || (r + 1 < ny && label(c, r + 1) != l);
                    // Outlines one image pixel wide, on the flake's own side.
                    let on_edge = edge
                        && match scale {
                            Scale::Down(_) => true,
                            Scale::Up(k) => {
                                let (dx, dy) = (x % k, y % k);
                                (c > 0 && label(c - 1, r) != l && dx == 0)
                                    || (c + 1 < nx && label(c + 1, r) != l && dx == k - 1)
                                    || (r > 0 && label(c, r - 1) != l && dy == 0)
                                    || (r + 1 < ny && label(c, r + 1) != l && dy == k - 1)
                            }
                        };
                    if on_edge {
                        OUTLINE
                    } else {
                        let col = colours[l as usize - 1];
                        col.map(|v| (FILL_ALPHA * v + (1.0 - FILL_ALPHA) * g).round() as u8)
                    }
                }
            };
            rgb[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&px);
        }
    }
    // Labels at the flake's pixel nearest its centroid.
    let ppp = scale.pixels_per_point();
    let mut labels = Vec::new();
    if labels_ok {
        // One pass: per flake, its pixel nearest its centroid.
        let centre: Vec<(f64, f64)> = seg
            .flakes
            .iter()
            .map(|f| (f.centre_um[0] / map.dx(), f.centre_um[1] / map.dy()))
            .collect();
        let mut best = vec![(f64::INFINITY, 0usize, 0usize); seg.flakes.len()];
        for r in 0..ny {
            for c in 0..nx {
                let l = seg.labels[r * nx + c] as usize;
                if l == 0 || image_pixels[l - 1] < LABEL_MIN_IMAGE_PIXELS {
                    continue;
                }
                let (cx, cy) = centre[l - 1];
                let d = (c as f64 - cx).powi(2) + (r as f64 - cy).powi(2);
                if d < best[l - 1].0 {
                    best[l - 1] = (d, c, r);
                }
            }
        }
        for (k, b) in best.iter().enumerate() {
            if b.0.is_finite() {
                labels.push(Label {
                    x: ((b.1 as f64 + 0.5) * ppp) as u32,
                    y: ((b.2 as f64 + 0.5) * ppp) as u32,
                    text: (k + 1).to_string(),
                });
            }
        }
    }
    Overlay {
        width: w as u32,
        height: h as u32,
        scale,
        rgb,
        labels,
        max_tilt,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_matches_matplotlib_between_anchors() {
        // matplotlib.colormaps['viridis'](x) × 255 at x = 0.1, 0.4, 0.7 (full 256-entry
        // table, not the anchors used here).
        for (x, want) in [
            (0.1, [72.07, 35.94, 116.67]),
            (0.4, [41.72, 120.14, 142.33]),
            (0.7, [68.07, 190.93, 112.35]),
        ] {
            let got = viridis(x);
            for i in 0..3 {
                assert!((got[i] - want[i]).abs() < 2.0, "x {x}: {got:?} vs {want:?}");
            }
        }
        assert_eq!(tilt_colour(0.0, 1.0), [68, 1, 84]);
        assert_eq!(tilt_colour(2.0, 1.0), [253, 231, 37]);
    }

    #[test]
    fn scales() {
        assert_eq!(Scale::for_map(128, 100), Scale::Up(4));
        assert_eq!(Scale::for_map(512, 512), Scale::Up(1));
        assert_eq!(Scale::for_map(2048, 10), Scale::Up(1));
        assert_eq!(Scale::for_map(4096, 4096), Scale::Down(2));
        assert_eq!(Scale::for_map(5000, 10), Scale::Down(3));
    }
}
