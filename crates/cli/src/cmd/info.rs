//! `flakescatter info MAP`: what a height-map file holds (size, pitch, valid points,
//! height statistics, format metadata).
//!
//! Units: the library works in micrometres; this command reports metres (`_m` keys) as
//! the command-line contract (cli.md) asks.

use std::path::PathBuf;

use std::fmt::Write as _;

use flakescatter::inputs::{LoadOptions, LoadedMap, MapSource};
use flakescatter::io::{ReadOptions, ZUnit};
use flakescatter::stats::heightmap::Quantity;
use serde_json::{Map, Value, json};

use crate::flags::MapArgs;
use crate::maps::{StackInputArgs, check_cutoff, load_all};
use crate::output::{print, print_json};

/// Describe a height-map file (X3P, SDF, plain text or an instrument format, recognised
/// from its content; see docs/formats.md):
/// size, pixel pitch, valid and invalid points, height statistics, channels, metadata.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The height-map file, or a z-stack (.tif, .tiff).
    #[arg(value_name = "MAP")]
    pub map: PathBuf,
    /// Print a JSON summary on stdout: `nx`, `ny`, `dx_m`, `dy_m`, `valid_points`,
    /// `invalid_points`, `quantity` (`height` or `intensity`), `min_m`, `max_m`, `mean_m`,
    /// `rms_m` (heights: about the mean, valid points only; null for intensities),
    /// `intensity_values` (intensities: min, max, mean, rms, unit-less), `format`, `metadata`, `channels` (name, unit, nx, ny, dx_m, dy_m of each
    /// channel of the file), `channel` (the index read) and `intensity_channel` (the
    /// index of the intensity channel used, or null), `file`, `version`.
    #[arg(long)]
    pub json: bool,
    /// Intensity image of the same size (X3P, SDF or text, values as stored); points
    /// whose intensity is below `--cutoff` are counted as invalid.
    #[arg(long, value_name = "FILE", requires = "cutoff")]
    pub intensity: Option<PathBuf>,
    /// Use this channel of MAP itself (index or name, as listed under `channels`) as the
    /// intensity image, instead of a second file.
    #[arg(
        long = "intensity-channel",
        value_name = "NAME|INDEX",
        requires = "cutoff",
        conflicts_with = "intensity"
    )]
    pub intensity_channel: Option<String>,
    /// Intensity cutoff, in the intensity image's own stored values (unit-less).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cutoff: Option<f64>,
    /// Calibration flags.
    #[command(flatten)]
    pub calibration: MapArgs,
    /// Localisation of a z-stack given as MAP (its height map is described, and the
    /// stack's size, voxel sizes and page order with where each came from).
    #[command(flatten)]
    pub stack: StackInputArgs,
}

/// µm → m for reporting.
fn m(um: f64) -> f64 {
    um * 1e-6
}

fn summary_json(args: &Args, options: &ReadOptions, loaded: &LoadedMap) -> Value {
    let (map, format, valid_before_cutoff, stack) = (
        &loaded.map,
        loaded.format.as_str(),
        loaded.valid_before_cutoff,
        loaded.stack.as_ref(),
    );
    let s = map.summary();
    let heights = map.quantity() == Quantity::Height;
    let stat = |f: fn(&flakescatter::stats::heightmap::HeightSummary) -> f64| {
        s.as_ref()
            .filter(|_| heights)
            .map_or(Value::Null, |s| json!(m(f(s))))
    };
    let metadata: Map<String, Value> = map
        .metadata()
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "file": args.map.display().to_string(),
        "format": format,
        "stack": stack.map(|st| json!({
            "nx": st.info.nx,
            "ny": st.info.ny,
            "slices": st.info.nz,
            "sample": st.info.sample.name(),
            "pixel_um": st.info.pixel_um.as_ref().map(|p| vec![p.value.0, p.value.1]),
            "pixel_source": st.info.pixel_um.as_ref().map(|p| p.source.to_string()),
            "z_step_um": st.info.z_step_um.as_ref().map(|z| z.value),
            "z_step_source": st.info.z_step_um.as_ref().map(|z| z.source.to_string()),
            "first_page": st.info.first_page.value.name(),
            "first_page_source": st.info.first_page.source.to_string(),
            "peak": st.peak.method.name(),
            "background": crate::cmd::stack::threshold_json(&st.threshold),
            "valid_pixels": st.report.valid,
            "below_signal": st.report.below_signal,
            "peak_on_first_slice": st.report.first_slice,
            "peak_on_last_slice": st.report.last_slice,
            "not_fittable": st.report.not_fittable,
            "saturated": st.report.saturated,
        })),
        "inputs": {
            "pixel_um": options.pixel_um.map(|(x, y)| vec![x, y]),
            "z_unit": options.z_unit.map(ZUnit::name),
            "accept_md5_mismatch": options.accept_md5_mismatch,
            "decimal": options.decimal.name(),
            "intensity_file": args.intensity.as_ref().map(|p| p.display().to_string()),
            "channel": args.calibration.channel,
            "intensity_channel": args.intensity_channel,
            "cutoff": args.cutoff,
        },
        "valid_points_before_cutoff": valid_before_cutoff,
        "nx": map.nx(),
        "ny": map.ny(),
        "dx_m": m(map.dx()),
        "dy_m": m(map.dy()),
        "valid_points": map.valid_count(),
        "invalid_points": map.len() - map.valid_count(),
        "quantity": map.quantity().name(),
        "intensity_values": s.as_ref().filter(|_| !heights).map(|s| json!({
            "min": s.min, "max": s.max, "mean": s.mean, "rms": s.rms,
        })),
        "min_m": stat(|s| s.min),
        "max_m": stat(|s| s.max),
        "mean_m": stat(|s| s.mean),
        "rms_m": stat(|s| s.rms),
        "metadata": metadata,
        "channel": loaded.channel,
        "intensity_channel": loaded.intensity_channel,
        "channels": loaded.channels.iter().map(|c| json!({
            "name": c.name,
            "unit": c.unit,
            "nx": c.nx,
            "ny": c.ny,
            "dx_m": c.pitch_um.map(|p| m(p.0)),
            "dy_m": c.pitch_um.map(|p| m(p.1)),
        })).collect::<Vec<_>>(),
    })
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    // A map is described as what its file says it holds (heights or intensities).
    let options = ReadOptions {
        as_stored: true,
        ..args.calibration.read_options()?
    };
    check_cutoff(args.cutoff)?;
    let (stack_options, peak) = args.stack.options(&options)?;
    if args.cutoff.is_some() && args.intensity.is_none() && args.intensity_channel.is_none() {
        anyhow::bail!("--cutoff needs --intensity FILE or --intensity-channel NAME|INDEX");
    }
    let source = MapSource::new(&args.map, args.intensity.clone()).with_channels(
        args.calibration.channel()?,
        crate::flags::selector("--intensity-channel", args.intensity_channel.as_deref())?,
    );
    args.stack
        .refuse_without_stacks(std::slice::from_ref(&source))?;
    let load = LoadOptions {
        read: options,
        cutoff: args.cutoff,
        stack: stack_options,
        peak,
    };
    let mut input = load_all(&[source], &load)?;
    let loaded = input.remove(0).loaded;
    let (map, format, valid_before_cutoff) = (
        &loaded.map,
        loaded.format.as_str(),
        loaded.valid_before_cutoff,
    );
    if args.json {
        return print_json(&summary_json(&args, &options, &loaded));
    }
    let n = map.len();
    let valid = map.valid_count();
    let mut s = String::new();
    let _ = writeln!(s, "file            {}", args.map.display());
    let _ = writeln!(s, "format          {format}");
    let _ = writeln!(
        s,
        "quantity        {}",
        match map.quantity() {
            Quantity::Height => "heights (µm)",
            Quantity::Intensity => "intensities (unit-less, as stored; the file says so)",
        }
    );
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
    let mask = match (&args.intensity, loaded.intensity_channel) {
        (Some(path), _) => Some(path.display().to_string()),
        (None, Some(i)) => Some(format!(
            "channel {i} ({})",
            loaded.channels.get(i).map_or("?", |c| c.name.as_str())
        )),
        (None, None) => None,
    };
    if let (Some(mask), Some(cutoff)) = (mask, args.cutoff) {
        let _ = writeln!(
            s,
            "intensity mask  {mask} with cutoff {cutoff}: {valid} of {valid_before_cutoff} valid points kept"
        );
    }
    match (map.summary(), map.quantity()) {
        (Some(h), Quantity::Height) => {
            let _ = writeln!(s, "height min      {} µm", h.min);
            let _ = writeln!(s, "height max      {} µm", h.max);
            let _ = writeln!(s, "height mean     {} µm", h.mean);
            let _ = writeln!(s, "height rms      {} µm (about the mean)", h.rms);
        }
        (Some(h), Quantity::Intensity) => {
            let _ = writeln!(s, "intensity min   {} (unit-less, as stored)", h.min);
            let _ = writeln!(s, "intensity max   {}", h.max);
            let _ = writeln!(s, "intensity mean  {}", h.mean);
            let _ = writeln!(s, "intensity rms   {} (about the mean)", h.rms);
        }
        (None, Quantity::Height) => s.push_str("heights         no valid point\n"),
        (None, Quantity::Intensity) => s.push_str("intensities     no valid point\n"),
    }
    if !loaded.channels.is_empty() {
        s.push_str("channels        (* values read, i intensity used)\n");
        for (i, c) in loaded.channels.iter().enumerate() {
            let _ = writeln!(
                s,
                "  {} {i}  {:<20} {:<6} {} x {}",
                if Some(i) == loaded.channel {
                    "*"
                } else if Some(i) == loaded.intensity_channel {
                    "i"
                } else {
                    " "
                },
                c.name,
                c.unit.as_deref().unwrap_or("-"),
                c.nx,
                c.ny
            );
        }
    }
    if !map.metadata().is_empty() {
        s.push_str("metadata\n");
        for (k, v) in map.metadata() {
            let _ = writeln!(s, "  {k:<28} {v}");
        }
    }
    print(&s)
}
