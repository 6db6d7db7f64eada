//! Reading the inputs of a command through `io`: height maps with their intensity
//! masks, and the out-of-plane detector file. Errors name the file and the flag.

use std::path::Path;

use anyhow::{Context, bail};
use flakescatter::io::{MapFormat, ReadOptions, read_intensity, read_map};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::segment::{Segmentation, segment};

use crate::flags::SegmentArgs;
use crate::output::warn;

/// Checks an intensity cutoff: a finite number.
pub fn check_cutoff(cutoff: Option<f64>) -> anyhow::Result<()> {
    match cutoff {
        Some(c) if !c.is_finite() => bail!("--cutoff {c}: expected a finite number"),
        _ => Ok(()),
    }
}

/// A height map as read, with its intensity mask applied.
pub struct Masked {
    /// The map.
    pub map: HeightMap,
    /// Its file format.
    pub format: MapFormat,
    /// Valid points before the intensity cutoff.
    pub valid_before_cutoff: usize,
}

/// Reads the height map `path` (named `what` in messages, e.g. `MAP`) and applies the
/// intensity cutoff when both `intensity` and `cutoff` are given.
pub fn read_masked(
    what: &str,
    path: &Path,
    intensity: Option<&Path>,
    cutoff: Option<f64>,
    options: &ReadOptions,
) -> anyhow::Result<Masked> {
    let (mut map, format) =
        read_map(path, options).with_context(|| format!("reading {what} {}", path.display()))?;
    let valid_before_cutoff = map.valid_count();
    if let (Some(ipath), Some(cutoff)) = (intensity, cutoff) {
        let (mask, _) = read_intensity(ipath, options)
            .with_context(|| format!("reading --intensity {}", ipath.display()))?;
        map.apply_intensity_cutoff(&mask, cutoff).with_context(|| {
            format!(
                "{what} {} with --intensity {} and --cutoff {cutoff}",
                path.display(),
                ipath.display()
            )
        })?;
    }
    Ok(Masked {
        map,
        format,
        valid_before_cutoff,
    })
}

/// Reads `map` (with the intensity cutoff) and segments it. A map without flakes gives
/// an empty result whose warning is printed on stderr.
pub fn segment_file(map: &Path, args: &SegmentArgs) -> anyhow::Result<(HeightMap, Segmentation)> {
    let params = args.params()?;
    let options = args.calibration.read_options()?;
    let height = read_masked("MAP", map, args.intensity.as_deref(), args.cutoff, &options)?.map;
    let seg = segment(&height, &params).with_context(|| format!("segmenting {}", map.display()))?;
    if let Some(w) = seg.warning {
        warn(&format!("{}: {w}; the flake table is empty", map.display()));
    }
    Ok((height, seg))
}

/// Reads out-of-plane detectors (io's detector reader: CSV with header
/// `theta_r_deg, phi_r_deg`, degrees, ranges checked); returns `(θr, φr)` in radians.
pub fn read_detectors(path: &Path) -> anyhow::Result<Vec<(f64, f64)>> {
    Ok(flakescatter::io::detectors::read_detectors(path)
        .with_context(|| format!("--detectors {}", path.display()))?
        .into_iter()
        .map(|d| (d.theta_r, d.phi_r))
        .collect())
}
