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

/// Reads out-of-plane detectors: CSV with header `theta_r_deg, phi_r_deg`, degrees.
pub fn read_detectors(path: &Path) -> anyhow::Result<Vec<(f64, f64)>> {
    let name = path.display();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .with_context(|| format!("reading --detectors {name}"))?;
    let headers = rdr
        .headers()
        .with_context(|| format!("--detectors {name}: no header"))?
        .clone();
    let col = |want: &str| headers.iter().position(|h| h == want);
    let (Some(ct), Some(cp)) = (col("theta_r_deg"), col("phi_r_deg")) else {
        bail!(
            "--detectors {name}: the header must have columns theta_r_deg and phi_r_deg (found: {})",
            headers.iter().collect::<Vec<_>>().join(", ")
        );
    };
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| anyhow::anyhow!("--detectors {name}: {}", csv_message(&e)))?;
        let line = rec.position().map_or(0, csv::Position::line);
        let get = |c: usize, what: &str| -> anyhow::Result<f64> {
            let s = rec.get(c).unwrap_or("");
            let v: f64 = s.parse().map_err(|_| {
                anyhow::anyhow!(
                    "--detectors {name}, line {line}, column {what}: `{s}` is not a number"
                )
            })?;
            if !v.is_finite() {
                bail!("--detectors {name}, line {line}, column {what}: `{s}` is not finite");
            }
            Ok(v)
        };
        let (t, p) = (get(ct, "theta_r_deg")?, get(cp, "phi_r_deg")?);
        if !(0.0..90.0).contains(&t) {
            bail!("--detectors {name}, line {line}: theta_r_deg {t} is outside [0, 90)");
        }
        if !(-360.0..=360.0).contains(&p) {
            bail!("--detectors {name}, line {line}: phi_r_deg {p} is outside [-360, 360]");
        }
        out.push((t, p));
    }
    if out.is_empty() {
        bail!("--detectors {name}: no detector rows");
    }
    Ok(out)
}

/// A CSV reading error in words (no Rust debug text).
pub fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => format!(
            "line {}: {len} fields where the header has {expected_len}",
            pos.as_ref().map_or(0, csv::Position::line)
        ),
        csv::ErrorKind::Utf8 { pos, .. } => format!(
            "line {}: not valid UTF-8 text",
            pos.as_ref().map_or(0, csv::Position::line)
        ),
        _ => e.to_string(),
    }
}
