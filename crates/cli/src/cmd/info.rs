//! `flakescatter info MAP`: what a height-map file holds (size, pitch, valid points,
//! height statistics, format metadata).
//!
//! Units: the library works in micrometres; this command reports metres (`_m` keys) as
//! the command-line contract (cli.md) asks.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::io::{DecimalMark, MapFormat, ReadOptions, ZUnit, read_intensity, read_map};
use flakescatter::stats::heightmap::HeightMap;
use serde_json::{Map, Value, json};

/// Calibration flags shared by every subcommand that reads height maps.
#[derive(Debug, Clone, clap::Args)]
pub struct MapArgs {
    /// Pixel pitch in µm, `DX` or `DX,DY` (x along columns, y along rows). Required for
    /// plain-text matrices without a size header; overrides the file's pitch otherwise.
    #[arg(long = "pixel-um", value_name = "DX[,DY]", allow_hyphen_values = true)]
    pub pixel_um: Option<String>,
    /// Unit of the heights in plain-text matrices without a unit header: `um`, `nm` or
    /// `m`. Overrides the file's unit; refused for X3P and SDF height maps, which are
    /// calibrated (and ignored for intensity maps).
    #[arg(long = "z-unit", value_name = "UNIT")]
    pub z_unit: Option<String>,
    /// Read X3P files whose MD5 checksums do not match; the mismatch is reported in the
    /// metadata (`x3p.md5_mismatch`) instead of failing.
    #[arg(long)]
    pub accept_md5_mismatch: bool,
    /// Plain-text matrices write decimals with a comma (`1,5`, German exports); values
    /// are then separated by whitespace or `;`. Without this flag (or --decimal-point)
    /// the decimal mark is detected, and a file that allows both readings is refused.
    #[arg(long, conflicts_with = "decimal_point")]
    pub decimal_comma: bool,
    /// Plain-text matrices write decimals with a point; commas separate values.
    #[arg(long)]
    pub decimal_point: bool,
}

impl MapArgs {
    /// Parses the flags into reader options; errors name the flag.
    pub fn read_options(&self) -> anyhow::Result<ReadOptions> {
        let pixel_um = match &self.pixel_um {
            None => None,
            Some(s) => {
                let parts: Vec<&str> = s.split(',').map(str::trim).collect();
                let parse = |p: &str| -> anyhow::Result<f64> {
                    let v: f64 = p.parse().with_context(|| {
                        format!(
                            "--pixel-um {s}: {p:?} is not a number (expected DX or DX,DY in µm)"
                        )
                    })?;
                    if !(v.is_finite() && v > 0.0) {
                        bail!("--pixel-um {s}: the pitch must be finite and > 0 µm");
                    }
                    Ok(v)
                };
                match parts.as_slice() {
                    [d] => {
                        let d = parse(d)?;
                        Some((d, d))
                    }
                    [x, y] => Some((parse(x)?, parse(y)?)),
                    _ => bail!("--pixel-um {s}: expected DX or DX,DY in µm"),
                }
            }
        };
        let z_unit = match &self.z_unit {
            None => None,
            Some(s) => Some(
                s.parse::<ZUnit>()
                    .with_context(|| format!("--z-unit {s}"))?,
            ),
        };
        Ok(ReadOptions {
            pixel_um,
            z_unit,
            accept_md5_mismatch: self.accept_md5_mismatch,
            decimal: if self.decimal_comma {
                DecimalMark::Comma
            } else if self.decimal_point {
                DecimalMark::Point
            } else {
                DecimalMark::Auto
            },
            ..ReadOptions::default()
        })
    }
}

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
        allow_hyphen_values = true
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
    let (mut map, format) = read_map(&args.map, &options)
        .with_context(|| format!("flakescatter info {}", args.map.display()))?;
    let valid_before_cutoff = map.valid_count();
    if let (Some(path), Some(cutoff)) = (&args.intensity, args.cutoff) {
        let (intensity, _) = read_intensity(path, &options)
            .with_context(|| format!("--intensity {}", path.display()))?;
        map.apply_intensity_cutoff(&intensity, cutoff)
            .with_context(|| {
                format!(
                    "--intensity {} --cutoff {cutoff} on {}",
                    path.display(),
                    args.map.display()
                )
            })?;
    }
    if args.json {
        let v = summary_json(&args, &options, &map, format, valid_before_cutoff);
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    let n = map.len();
    let valid = map.valid_count();
    println!("file            {}", args.map.display());
    println!("format          {format}");
    println!(
        "size            {} x {} points (nx x ny)",
        map.nx(),
        map.ny()
    );
    println!(
        "pixel pitch     {} µm x {} µm (dx x dy)",
        map.dx(),
        map.dy()
    );
    println!(
        "extent          {} µm x {} µm",
        map.dx() * map.nx() as f64,
        map.dy() * map.ny() as f64
    );
    println!(
        "valid points    {valid} of {n} ({} invalid, {:.2} %)",
        n - valid,
        100.0 * (n - valid) as f64 / n as f64
    );
    if let (Some(path), Some(cutoff)) = (&args.intensity, args.cutoff) {
        println!(
            "intensity mask  {} with cutoff {cutoff}: {valid} of {valid_before_cutoff} valid points kept",
            path.display()
        );
    }
    match map.summary() {
        Some(s) => {
            println!("height min      {} µm", s.min);
            println!("height max      {} µm", s.max);
            println!("height mean     {} µm", s.mean);
            println!("height rms      {} µm (about the mean)", s.rms);
        }
        None => println!("heights         no valid point"),
    }
    if !map.metadata().is_empty() {
        println!("metadata");
        for (k, v) in map.metadata() {
            println!("  {k:<28} {v}");
        }
    }
    Ok(())
}
