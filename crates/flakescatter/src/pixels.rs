//! Pixel-level orientation statistics, and where the orientation width comes from
//! (physics.md §5.2).
//!
//! Conventions: radians and micrometres; widths are the Gaussian `s` of
//! `flakescatter_stats::distribution` (`p̃ ∝ exp(−θ²/(2s²))`), with the hwhm as a helper.
//!
//! * [`pixel_orientation`]: the area-weighted histogram of the local (`k × k`) normals
//!   of all usable pixels, each weighted by its true area `dx · dy / m.z` (the factor
//!   `1/m.z` of the topographic ray weight), as a tabulated [`Orientation`] that the
//!   distribution model takes, with its Gaussian width fitted two ways: least squares
//!   on the histogram's `p̃` (dominated by the core, robust to the few steep windows
//!   that straddle flake edges) and maximum likelihood over all pixels (moment matching
//!   of `θ²`, which those steep windows can dominate). The isotropic
//!   topographic model equals the usable-pixel coverage times the distribution model
//!   driven by this distribution, up to the histogram's bin width (physics.md §5.2).
//! * [`width_sources`]: for a set of maps, the flake-level width (segmented flakes, one
//!   plane per flake, area-weighted) beside the pixel-level width of all usable pixels
//!   and of the pixels whose window lies inside one segmented flake. For small tilts the
//!   tilt vectors add, so the variances do: `s_inside² ≈ s_flake² + s_rough²`, and
//!   `s_rough = sqrt(s_inside² − s_flake²)` is the within-flake roughness (per tilt
//!   component, radians) that the paper's topographic model adds to the distribution.
//!   For that difference the flakes are weighted like the pixels (each flake by the true
//!   area of its inside pixels): with the flakes' own areas, a few per cent of weighting
//!   difference between the two widths would pass for roughness (the square root of a
//!   small difference of squares is sensitive to it); with matched weights smooth
//!   flakes give exactly zero.
//!
//! Uncertainty. Neighbouring pixels share windows and flakes, so pixel counts say
//! nothing about precision. The width's 95 % interval comes from the spread of the
//! per-tile sums of `area` and `area · θ²` (ratio estimator of the mean square tilt
//! `m2`, `se² = T/(T−1) Σ_t (S_t − m2 A_t)² / (Σ_t A_t)²`), mapped through the monotone
//! relation between `m2` and `s`; with a single tile the interval is `(0, ∞)`.

use flakescatter_stats::distribution::{GaussianWidth, HWHM_PER_SIGMA, Orientation};
use flakescatter_stats::fit::{HistogramFit, WidthFit, fit_gaussian_histogram, fit_gaussian_ml};
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::histogram::AreaHistogram;
use flakescatter_stats::segment::{SegmentParams, Segmentation, segment};
use flakescatter_topo::{PixelTilts, TopoModel, TopoOptions};

use crate::PipelineError;
use crate::pipeline::TopoSettings;

/// A Gaussian width fitted to pixel tilts, with an interval from the spread between
/// tiles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelWidth {
    /// Maximum-likelihood `s` (moment matching of the area-weighted `θn²`), radians.
    pub sigma: f64,
    /// 95 % interval of `s` from the tiles, radians (`(0, ∞)` with one tile; the upper
    /// end is `∞` when the interval reaches the uniform limit).
    pub sigma_ci95: (f64, f64),
    /// Area-weighted mean square tilt `m2`, rad².
    pub mean_square_tilt: f64,
    /// Its standard error from the tiles, rad² (NaN with one tile).
    pub mean_square_tilt_std_err: f64,
    /// Usable pixels used.
    pub pixels: u64,
    /// Statistics tiles holding usable pixels.
    pub tiles: usize,
}

impl PixelWidth {
    /// Fitted hwhm `w = s·sqrt(2 ln 2)`, radians.
    #[must_use]
    pub fn hwhm(&self) -> f64 {
        self.sigma * HWHM_PER_SIGMA
    }

    /// 95 % interval of the hwhm, radians.
    #[must_use]
    pub fn hwhm_ci95(&self) -> (f64, f64) {
        (
            self.sigma_ci95.0 * HWHM_PER_SIGMA,
            self.sigma_ci95.1 * HWHM_PER_SIGMA,
        )
    }

    /// The fitted Gaussian distribution.
    ///
    /// # Errors
    /// [`PipelineError::Orientation`] when `s` is not below π/2.
    pub fn orientation(&self) -> Result<Orientation, PipelineError> {
        Orientation::gaussian(GaussianWidth::Sigma(self.sigma))
            .map_err(|e| PipelineError::Orientation(e.to_string()))
    }
}

/// What [`pixel_orientation`] returns.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelOrientation {
    /// The binned true areas, per-tile sums and pixel counts.
    pub tilts: PixelTilts,
    /// The histogram as a tabulated distribution (what `model --orientation table`
    /// reads; write it with `flakescatter_io::write_histogram_bins(…,
    /// &tilts.edges, &tilts.area_fractions())`).
    pub orientation: Orientation,
    /// Least-squares Gaussian fit to the histogram's `p̃` (`stats::fit`), or why it
    /// failed (e.g. the best width at an end of the searched range: a histogram
    /// narrower than its bins); an optional statistic, so its failure is not the
    /// whole statistics' failure.
    pub histogram_fit: Result<HistogramFit, String>,
    /// Maximum-likelihood width over all usable pixels with its tile interval; `None`
    /// when the mean square tilt reaches the uniform limit (windows across flake edges
    /// have tilts near 90° and can dominate `θ²`).
    pub width: Option<PixelWidth>,
}

/// Where the width comes from: flakes against pixels ([`width_sources`]).
#[derive(Debug, Clone, PartialEq)]
pub struct WidthSources {
    /// Flake-level width: one normal per segmented flake, area-weighted (its interval
    /// treats flakes as independent).
    pub flake: WidthFit,
    /// Segmented flakes over all maps.
    pub flakes: usize,
    /// Pixel-level width of all usable pixels (what the topographic model traces,
    /// including windows across flake edges); `None` when those make the mean square
    /// tilt reach the uniform limit.
    pub pixel: Option<PixelWidth>,
    /// Pixel-level width of the pixels whose whole window lies inside one segmented
    /// flake (pixels on a flake's rim masked).
    pub inside: PixelWidth,
    /// Flake-level `s` with each flake weighted by the true area of its inside pixels
    /// (the weights of `inside`), radians.
    pub flake_sigma_pixel_weighted: f64,
    /// `sqrt(s_inside² − s_flake,pixel-weighted²)`, radians: the within-flake roughness
    /// as a tilt spread per component; `None` when the inside width is not above it.
    pub within_flake_sigma: Option<f64>,
}

/// `s` whose truncated Gaussian has `E[θ²] = m2`: the ML fit depends on its samples only
/// through the area-weighted `m2` (`flakescatter_stats::fit`), so one sample at
/// `θ = √m2` gives that `s`.
fn sigma_for(m2: f64) -> Result<f64, PipelineError> {
    fit_gaussian_ml(&[(m2.sqrt(), 1.0)])
        .map(|f| f.sigma)
        .map_err(|e| PipelineError::Fit(format!("pixel-level width: {e}")))
}

/// The width of pixel tilts with its tile interval (module docs).
fn width_of(t: &PixelTilts) -> Result<PixelWidth, PipelineError> {
    let m2 = t.mean_square_tilt();
    let se = t.mean_square_tilt_std_err();
    let sigma = sigma_for(m2)?;
    let ci = if se.is_finite() {
        let lo = m2 - 1.96 * se;
        let hi = m2 + 1.96 * se;
        (
            if lo > 0.0 {
                sigma_for(lo).unwrap_or(0.0)
            } else {
                0.0
            },
            sigma_for(hi).unwrap_or(f64::INFINITY),
        )
    } else {
        (0.0, f64::INFINITY)
    };
    Ok(PixelWidth {
        sigma,
        sigma_ci95: ci,
        mean_square_tilt: m2,
        mean_square_tilt_std_err: se,
        pixels: t.usable_pixels,
        tiles: t.tiles.iter().filter(|x| x.pixels > 0).count(),
    })
}

pub(crate) fn model(topo: &TopoSettings) -> Result<TopoModel, PipelineError> {
    Ok(TopoModel::new(TopoOptions {
        window: topo.window,
        ..TopoOptions::default()
    })?
    .with_block_um(topo.tile_um)?)
}

/// The area-weighted distribution of the usable pixels' normals over `maps` (their
/// masks already holding any intensity cutoff), in bins of `bin_width` radians, with
/// its Gaussian width (module docs).
///
/// # Errors
/// [`PipelineError::Topo`] for invalid settings, bin width or maps (no usable pixel).
/// A histogram no Gaussian fits (all pixels flat) is not an error: its
/// [`PixelOrientation::histogram_fit`] says why.
pub fn pixel_orientation(
    maps: &[&HeightMap],
    topo: &TopoSettings,
    bin_width: f64,
) -> Result<PixelOrientation, PipelineError> {
    let tilts = model(topo)?.pixel_tilts(maps, bin_width)?;
    orientation_of(tilts, bin_width)
}

/// The distribution, its histogram and widths from the pixel tilts.
pub(crate) fn orientation_of(
    tilts: PixelTilts,
    bin_width: f64,
) -> Result<PixelOrientation, PipelineError> {
    let orientation = tilts
        .orientation()
        .map_err(|e| PipelineError::Orientation(e.to_string()))?;
    // The same bins as an `AreaHistogram`: one sample per non-empty bin, at its centre.
    let samples = tilts
        .edges
        .windows(2)
        .zip(&tilts.bin_area_um2)
        .filter(|&(_, &a)| a > 0.0)
        .map(|(e, &a)| (0.5 * (e[0] + e[1]), a));
    let histogram = AreaHistogram::new(samples, bin_width)
        .map_err(|e| PipelineError::Orientation(e.to_string()))?;
    let histogram_fit = fit_gaussian_histogram(&histogram).map_err(|e| e.to_string());
    Ok(PixelOrientation {
        width: width_of(&tilts).ok(),
        tilts,
        orientation,
        histogram_fit,
    })
}

/// The map with every pixel masked that is not inside a segmented flake or that has a
/// 4-neighbour of another label: a `k × k` window of valid points then never spans two
/// flakes (a window holding two labels holds a 4-adjacent pair of them, both masked).
fn inside_flakes(map: &HeightMap, labels: &[u32]) -> Result<HeightMap, PipelineError> {
    let (nx, ny) = (map.nx(), map.ny());
    let valid = map.valid();
    let mask: Vec<bool> = (0..nx * ny)
        .map(|i| {
            let (c, r) = (i % nx, i / nx);
            let l = labels[i];
            let same = |j: usize| labels[j] == l;
            valid[i]
                && l != 0
                && (c == 0 || same(i - 1))
                && (c + 1 == nx || same(i + 1))
                && (r == 0 || same(i - nx))
                && (r + 1 == ny || same(i + nx))
        })
        .collect();
    HeightMap::with_mask(nx, ny, map.dx(), map.dy(), map.heights().to_vec(), mask)
        .map_err(|e| PipelineError::Orientation(e.to_string()))
}

/// The flake-level width (segmented flakes, one plane each, area-weighted ML fit)
/// beside the pixel-level widths of all usable pixels and of the pixels inside single
/// flakes, for `maps` (masks already holding any intensity cutoff), and the
/// within-flake roughness they imply (module docs).
///
/// # Errors
/// [`PipelineError::Orientation`] for invalid segmentation parameters,
/// [`PipelineError::Fit`] when no flake is found or no width fits,
/// [`PipelineError::Topo`] for invalid settings or maps without usable pixels (also
/// inside the flakes).
pub fn width_sources(
    maps: &[&HeightMap],
    params: &SegmentParams,
    topo: &TopoSettings,
) -> Result<WidthSources, PipelineError> {
    let segmentations = maps
        .iter()
        .map(|map| segment(map, params).map_err(|e| PipelineError::Orientation(e.to_string())))
        .collect::<Result<Vec<_>, _>>()?;
    let refs: Vec<&Segmentation> = segmentations.iter().collect();
    width_sources_from(maps, &refs, topo)
}

/// As [`width_sources`] for maps already segmented: `segmentations[k]` is the
/// segmentation of `maps[k]` (e.g. from [`crate::sample::sample_statistics`]), so that
/// no map is segmented twice.
///
/// # Errors
/// As [`width_sources`]; [`PipelineError::Orientation`] when the numbers of maps and
/// segmentations differ.
pub fn width_sources_from(
    maps: &[&HeightMap],
    segmentations: &[&Segmentation],
    topo: &TopoSettings,
) -> Result<WidthSources, PipelineError> {
    if maps.len() != segmentations.len() {
        return Err(PipelineError::Orientation(format!(
            "{} maps but {} segmentations",
            maps.len(),
            segmentations.len()
        )));
    }
    let model = model(topo)?;
    // The bins do not enter the widths; 1° is only needed to build the tilts.
    let bin = 1f64.to_radians();
    let pixel = width_of(&model.pixel_tilts(maps, bin)?).ok();
    let mut samples = Vec::new();
    let mut matched = Vec::new();
    let mut inside_maps = Vec::with_capacity(maps.len());
    for (map, seg) in maps.iter().zip(segmentations) {
        let inside = inside_flakes(map, &seg.labels)?;
        // True area of each flake's usable inside pixels: the flake's weight among the
        // inside pixels.
        let mut weight = vec![0.0; seg.flakes.len()];
        if let Ok(normals) = model.normals(&inside) {
            let pixel_area = map.dx() * map.dy();
            for r in 0..map.ny() {
                for c in 0..map.nx() {
                    if let Some((a, b)) = normals.slope(c, r) {
                        let l = seg.labels[r * map.nx() + c] as usize;
                        weight[l - 1] += pixel_area * (1.0 + a * a + b * b).sqrt();
                    }
                }
            }
        }
        for (f, &w) in seg.flakes.iter().zip(&weight) {
            let flake = f.to_flake();
            samples.push((flake.theta_n(), flake.area_um2));
            if w > 0.0 {
                matched.push((flake.theta_n(), w));
            }
        }
        inside_maps.push(inside);
    }
    if samples.is_empty() {
        return Err(PipelineError::Fit(
            "no flake was segmented in any map: no flake-level width".into(),
        ));
    }
    let flake = fit_gaussian_ml(&samples)
        .map_err(|e| PipelineError::Fit(format!("flake-level width: {e}")))?;
    let refs: Vec<&HeightMap> = inside_maps.iter().collect();
    let inside = width_of(&model.pixel_tilts(&refs, bin)?)?;
    let flake_matched = fit_gaussian_ml(&matched)
        .map_err(|e| PipelineError::Fit(format!("flake-level width (pixel weights): {e}")))?
        .sigma;
    let d = inside.sigma * inside.sigma - flake_matched * flake_matched;
    Ok(WidthSources {
        flake,
        flakes: samples.len(),
        pixel,
        inside,
        flake_sigma_pixel_weighted: flake_matched,
        within_flake_sigma: (d > 0.0).then(|| d.sqrt()),
    })
}
