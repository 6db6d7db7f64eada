//! `flakescatter info MAP`: what a height-map file holds (size, pitch, valid points,
//! height statistics, format metadata).
//!
//! Units: the library works in micrometres; this command reports metres (`_m` keys) as
//! the command-line contract (cli.md) asks.

use std::path::PathBuf;

use std::fmt::Write as _;

use flakescatter::io::{MapFormat, ReadOptions, ZUnit};
use flakescatter::stats::heightmap::HeightMap;
use serde_json::{Map, Value, json};

use crate::flags::MapArgs;
use crate::maps::{check_cutoff, read_masked};
use crate::output::{print, print_json};

/// Describe a height-map file (X3P, SDF or plain text, recognised from its content):
/// size, pixel pitch, valid and invalid points, height statistics, metadata.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The height-map file.
    #[arg(value_name = "MAP")]
    pub map: PathBuf,
    /// Print a JSON summary on stdout: `nx`, `ny`, `dx_m`, `dy_m`, `valid_points`,
    /// `invalid_points`, `min_m`, `max_m`, `mean_m`, `rms_m` (about the mean, valid points
    /// only), `format`, `metadata`, `file`, `version`.
    #[arg(long)]
    pub json: bool,
    /// Intensity image of the same size (X3P, SDF or text, values as stored); points
    /// whose intensity is below `--cutoff` are counted as invalid.
    #[arg(long, value_name = "FILE", requires = "cutoff")]
    pub intensity: Option<PathBuf>,
    /// Intensity cutoff, in the intensity file's own stored values (unit-less).
    #[arg(
        long,
        value_name = "X",
        requires = "intensity",
        allow_negative_numbers = true
    )]
    pub cutoff: Option<f64>,
    /// Calibration flags.
    #[command(flatten)]
    pub calibration: MapArgs,
}

/// µm → m for reporting.
fn m(um: f64) -> f64 {
    um * 1e-6
}

fn summary_json(
    args: &Args,
    options: &ReadOptions,
    map: &HeightMap,
    format: MapFormat,
    valid_before_cutoff: usize,
) -> Value {
    let s = map.summary();
    let stat = |f: fn(&flakescatter::stats::heightmap::HeightSummary) -> f64| {
        s.as_ref().map_or(Value::Null, |s| json!(m(f(s))))
    };
    let metadata: Map<String, Value> = map
        .metadata()
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "file": args.map.display().to_string(),
        "format": format.name(),
        "inputs": {
            "pixel_um": options.pixel_um.map(|(x, y)| vec![x, y]),
            "z_unit": options.z_unit.map(ZUnit::name),
            "accept_md5_mismatch": options.accept_md5_mismatch,
            "decimal": options.decimal.name(),
            "intensity_file": args.intensity.as_ref().map(|p| p.display().to_string()),
            "cutoff": args.cutoff,
        },
        "valid_points_before_cutoff": valid_before_cutoff,
        "nx": map.nx(),
        "ny": map.ny(),
        "dx_m": m(map.dx()),
        "dy_m": m(map.dy()),
        "valid_points": map.valid_count(),
        "invalid_points": map.len() - map.valid_count(),
        "min_m": stat(|s| s.min),
        "max_m": stat(|s| s.max),
        "mean_m": stat(|s| s.mean),
        "rms_m": stat(|s| s.rms),
        "metadata": metadata,
    })
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = args.calibration.read_options()?;
    check_cutoff(args.cutoff)?;
    let masked = read_masked(
        "MAP",
        &args.map,
        args.intensity.as_deref(),
        args.cutoff,
        &options,
    )?;
    let (map, format, valid_before_cutoff) =
        (masked.map, masked.format, masked.valid_before_cutoff);
    if args.json {
        return print_json(&summary_json(
            &args,
            &options,
            &map,
            format,
            valid_before_cutoff,
        ));
    }
    let n = map.len();
    let valid = map.valid_count();
    let mut s = String::new();
    let _ = writeln!(s, "file            {}", args.map.display());
    let _ = writeln!(s, "format          {format}");
    let _ = writeln!(
        s,
        "size            {} x {} points (nx x ny)",
        map.nx(),
        map.ny()
    );
    let _ = writeln!(
        s,
        "pixel pitch     {} µm x {} µm (dx x dy)",
        map.dx(),
        map.dy()
    );
    let _ = writeln!(
        s,
        "extent          {} µm x {} µm",
        map.dx() * map.nx() as f64,
        map.dy() * map.ny() as f64
    );
    let _ = writeln!(
        s,
        "valid points    {valid} of {n} ({} invalid, {:.2} %)",
        n - valid,
        100.0 * (n - valid) as f64 / n as f64
    );
    if let (Some(path), Some(cutoff)) = (&args.intensity, args.cutoff) {
        let _ = writeln!(
            s,
            "intensity mask  {} with cutoff {cutoff}: {valid} of {valid_before_cutoff} valid points kept",
            path.display()
        );
    }
    match map.summary() {
        Some(h) => {
            let _ = writeln!(s, "height min      {} µm", h.min);
            let _ = writeln!(s, "height max      {} µm", h.max);
            let _ = writeln!(s, "height mean     {} µm", h.mean);
            let _ = writeln!(s, "height rms      {} µm (about the mean)", h.rms);
        }
        None => s.push_str("heights         no valid point\n"),
    }
    if !map.metadata().is_empty() {
        s.push_str("metadata\n");
        for (k, v) in map.metadata() {
            let _ = writeln!(s, "  {k:<28} {v}");
        }
    }
    print(&s)
}
