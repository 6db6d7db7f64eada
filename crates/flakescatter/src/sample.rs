//! A sample is many maps: segmentation of each map, the pooled orientation statistics
//! of all their flakes with an interval in which the maps are the independent units
//! ([`flakescatter_stats::pool`]), each map's own width and whether it agrees with the
//! others, the pooled area-weighted histogram, and optionally the pixel-level
//! statistics (where the width comes from, [`crate::pixels`]).
//!
//! Conventions: radians and micrometres; widths are the Gaussian `s` of
//! `flakescatter_stats::distribution` (`p̃ ∝ exp(−θ²/(2s²))`) with hwhm helpers; maps
//! are given with their masks already holding any intensity cutoff.
//!
//! **Visible flakes and the generator's flakes.** On synthetic layers the pooled
//! statistics estimate the width of the flakes one can see (the top-most surface, each
//! flake weighted by the area that shows), which could differ from the generator's
//! distribution if occlusion favoured some tilts. Measured on 160 maps of 512² pixels
//! at 0.18 µm (hwhm 6°, the generator's defaults; `tests/sample.rs`): the visible
//! flakes' hwhm is 5.988° with the profile-likelihood interval [5.913°, 6.064°], so no
//! systematic difference is seen at the 1.3 % level. On 20 samples of 8 such maps the
//! pooled width of the segmented flakes was within 0.7 % of the visible truth's, and
//! the map-level interval covered it in all 20; on 60 samples of 8 maps of one family
//! the consistency test flagged some map in 3 (5 %, the family-wise rate it is built
//! for).

use flakescatter_stats::fit::{HistogramFit, fit_gaussian_histogram};
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::histogram::AreaHistogram;
use flakescatter_stats::pool::{PoolError, PooledWidth, pool_maps};
use flakescatter_stats::segment::{SegmentParams, Segmentation, segment};

use crate::PipelineError;
use crate::pipeline::TopoSettings;
use crate::pixels::{PixelOrientation, WidthSources, pixel_orientation, width_sources_from};

/// What [`sample_statistics`] computes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleSettings {
    /// Segmentation parameters (the same for every map).
    pub segment: SegmentParams,
    /// Histogram bin width, radians.
    pub bin_width: f64,
    /// Also the pixel-level statistics with these topographic settings (window, tile).
    pub pixel_normals: Option<TopoSettings>,
}

/// The pixel-level statistics of a sample ([`crate::pixels`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PixelLevel {
    /// The area-weighted distribution of the usable pixels' normals, binned like the
    /// flake histogram, with its fitted widths.
    pub orientation: PixelOrientation,
    /// Flake-level against pixel-level width and the within-flake roughness they imply;
    /// `None` (with the reason) when they cannot be compared, e.g. no usable pixel
    /// inside any flake.
    pub sources: Result<WidthSources, String>,
}

/// The statistics of a sample of several maps.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleStatistics {
    /// Per map, in the order given, its segmentation.
    pub segmentations: Vec<Segmentation>,
    /// The pooled width with both intervals, per-map widths and consistency flags.
    pub pooled: PooledWidth,
    /// The area-weighted histogram of all flakes of all maps.
    pub histogram: AreaHistogram,
    /// Least-squares Gaussian fit to that histogram's `p̃` (what `stats --plot` draws
    /// beside the maximum-likelihood width), or why it failed (e.g. bins that cannot
    /// resolve it).
    pub histogram_fit: Result<HistogramFit, String>,
    /// The pixel-level statistics when asked for.
    pub pixel: Option<PixelLevel>,
}

/// The flakes of a segmentation as `(θn, true area)` samples (radians, µm²).
#[must_use]
pub fn tilt_samples(seg: &Segmentation) -> Vec<(f64, f64)> {
    seg.flakes
        .iter()
        .map(|f| (f.to_flake().theta_n(), f.area_um2))
        .collect()
}

/// Pools already segmented maps: the pooled width and per-map widths, and the pooled
/// histogram in bins of `bin_width` radians.
///
/// # Errors
/// [`PipelineError::Fit`] when no map holds a flake or no width fits;
/// [`PipelineError::Orientation`] for an invalid bin width.
pub fn pool_segmentations(
    segmentations: &[&Segmentation],
    bin_width: f64,
) -> Result<(PooledWidth, AreaHistogram), PipelineError> {
    let samples: Vec<Vec<(f64, f64)>> = segmentations.iter().map(|s| tilt_samples(s)).collect();
    let refs: Vec<&[(f64, f64)]> = samples.iter().map(Vec::as_slice).collect();
    let pooled = pool_maps(&refs).map_err(|e| match e {
        PoolError::NoFlakes { maps } => PipelineError::Fit(format!(
            "no flake found in {}: nothing to histogram or fit",
            if maps == 1 {
                "the map".to_owned()
            } else {
                format!("any of the {maps} maps")
            }
        )),
        e => PipelineError::Fit(e.to_string()),
    })?;
    let flakes: Vec<_> = segmentations
        .iter()
        .flat_map(|s| s.flakes.iter().map(|f| f.to_flake()))
        .collect();
    let histogram = AreaHistogram::from_flakes(&flakes, bin_width)
        .map_err(|e| PipelineError::Orientation(e.to_string()))?;
    Ok((pooled, histogram))
}

/// Segments every map (in the order given; `progress(done, total)` after each) and
/// pools their flakes (module docs); with [`SampleSettings::pixel_normals`] also the
/// pixel-level statistics.
///
/// # Errors
/// [`PipelineError::Orientation`] for invalid segmentation parameters or bin width
/// (naming the map), [`PipelineError::Fit`] when no map holds a flake,
/// [`PipelineError::Topo`] for pixel-level settings the topographic layer refuses.
pub fn sample_statistics(
    maps: &[&HeightMap],
    settings: &SampleSettings,
    progress: &dyn Fn(usize, usize),
) -> Result<SampleStatistics, PipelineError> {
    let segmentations = segment_maps(maps, &settings.segment, progress)?;
    statistics_of(maps, segmentations, settings)
}

/// Segments every map in the order given, `progress(done, total)` after each.
///
/// # Errors
/// [`PipelineError::Orientation`] for invalid segmentation parameters (naming the map).
pub fn segment_maps(
    maps: &[&HeightMap],
    params: &SegmentParams,
    progress: &dyn Fn(usize, usize),
) -> Result<Vec<Segmentation>, PipelineError> {
    let mut segmentations = Vec::with_capacity(maps.len());
    for (k, map) in maps.iter().enumerate() {
        let seg = segment(map, params)
            .map_err(|e| PipelineError::Orientation(format!("map {}: {e}", k + 1)))?;
        segmentations.push(seg);
        progress(k + 1, maps.len());
    }
    Ok(segmentations)
}

/// As [`sample_statistics`] for maps whose segmentations are known (e.g. kept from an
/// earlier run): `segmentations[k]` must be the segmentation of `maps[k]` with
/// `settings.segment`.
///
/// # Errors
/// As [`sample_statistics`]; [`PipelineError::Orientation`] when the numbers of maps and
/// segmentations differ or a label map does not fit its map.
pub fn statistics_of(
    maps: &[&HeightMap],
    segmentations: Vec<Segmentation>,
    settings: &SampleSettings,
) -> Result<SampleStatistics, PipelineError> {
    if maps.len() != segmentations.len() {
        return Err(PipelineError::Orientation(format!(
            "{} maps but {} segmentations",
            maps.len(),
            segmentations.len()
        )));
    }
    for (k, (m, s)) in maps.iter().zip(&segmentations).enumerate() {
        if s.labels.len() != m.len() {
            return Err(PipelineError::Orientation(format!(
                "map {}: its label map has {} pixels, the map {}",
                k + 1,
                s.labels.len(),
                m.len()
            )));
        }
    }
    let refs: Vec<&Segmentation> = segmentations.iter().collect();
    let (pooled, histogram) = pool_segmentations(&refs, settings.bin_width)?;
    let histogram_fit = fit_gaussian_histogram(&histogram).map_err(|e| e.to_string());
    let pixel = match settings.pixel_normals {
        None => None,
        Some(topo) => Some(pixel_level(maps, &refs, &topo, settings.bin_width)?),
    };
    Ok(SampleStatistics {
        segmentations,
        pooled,
        histogram,
        histogram_fit,
        pixel,
    })
}

/// The pixel-level statistics of segmented maps (`segmentations[k]` of `maps[k]`) with
/// the topographic settings `topo`, in bins of `bin_width` radians.
///
/// # Errors
/// [`PipelineError::Topo`] for settings the topographic layer refuses or a map it
/// cannot use (smaller than the window, no valid pixel), naming the map by its index.
pub fn pixel_level(
    maps: &[&HeightMap],
    segmentations: &[&Segmentation],
    topo: &TopoSettings,
    bin_width: f64,
) -> Result<PixelLevel, PipelineError> {
    Ok(PixelLevel {
        orientation: pixel_orientation(maps, topo, bin_width)?,
        sources: width_sources_from(maps, segmentations, topo).map_err(|e| e.to_string()),
    })
}
