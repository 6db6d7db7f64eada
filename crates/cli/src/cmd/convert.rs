//! `flakescatter convert IN OUT`: reads a height map in any format `info` reads (X3P,
//! SDF, text, the instrument formats, Zarr; docs/formats.md) and writes it as X3P, SDF
//! (text, `aISO-1.0`), plain text or a Zarr v3 store (a directory, written whole and
//! swapped in), the output format taken from OUT's extension.
//!
//! Heights, pitch and invalid points are kept exactly (X3P ↔ SDF round trip exact);
//! of the metadata, what both formats hold (the SDF `ManufacID` and dates from `sdf.*`
//! keys) is kept; the rest of the input's metadata is not written. An intensity image
//! (a file that says it holds intensities: `flakescatter_io::quantity`) is read and
//! written as one, its values unchanged and the output marked as intensities.

use std::path::PathBuf;

use flakescatter::inputs::{LoadOptions, MapSource};
use flakescatter::io::{MapFormat, write_map};

use crate::flags::MapArgs;
use crate::maps::load_all;
use crate::output::{Kind, Plan};

/// Convert a height map between formats (the output format from OUT's extension:
/// .x3p, .sdf, .txt or .zarr).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The map to read (any format `info` reads, recognised from its content).
    #[arg(value_name = "IN")]
    pub input: PathBuf,
    /// The file to write: `.x3p` (ISO 25178-72), `.sdf` (ISO 25178-71, text), `.txt`,
    /// or `.zarr` (a Zarr v3 store: a directory, replaced only when empty or an earlier
    /// output of `convert`).
    #[arg(value_name = "OUT")]
    pub output: PathBuf,
    /// Calibration and channel flags of the input.
    #[command(flatten)]
    pub calibration: MapArgs,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = flakescatter::io::ReadOptions {
        as_stored: true,
        ..args.calibration.read_options()?
    };
    let mut plan = Plan::new();
    plan.input("IN", &args.input);
    plan.map_output("OUT", Some(&args.output), Kind::ConvertedMap, "convert");
    plan.check()?;
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let format = match ext.as_deref() {
        Some("sdf") => MapFormat::Sdf,
        Some("txt") => MapFormat::Text,
        Some("zarr") => MapFormat::Zarr,
        _ => MapFormat::X3p,
    };
    let load = LoadOptions {
        read: options,
        ..LoadOptions::default()
    };
    let source = MapSource::new(&args.input, None).with_channels(args.calibration.channel()?, None);
    let mut loaded = load_all(&[source], &load)?;
    let loaded = loaded.remove(0).loaded;
    let map = &loaded.map;
    let values = match map.quantity() {
        flakescatter::stats::heightmap::Quantity::Height => "heights",
        flakescatter::stats::heightmap::Quantity::Intensity => "intensities",
    };
    let detail = format!(
        "{} x {} {values}, {} from {}",
        map.nx(),
        map.ny(),
        format.name(),
        loaded.format
    );
    plan.write_map_output(
        "OUT",
        &args.output,
        "convert",
        |tmp| {
            write_map(map, tmp, format)?;
            Ok(())
        },
        Some(detail),
    )?;
    plan.finish()
}
