//! `stats --pixel-normals-only`: the pixel-level statistics of `--pixel-normals`
//! without segmenting flakes, so that no map needs to be in memory whole: when every
//! map is a Zarr store the band reader can read (the rules of `topo`,
//! [`crate::maps::stream`]), the maps are read band by band; otherwise whole. The
//! numbers are the same either way, bit for bit (the tiles, their order and the order
//! of every sum are the same; docs/physics.md §5 "Tiles and their reduction").

use flakescatter::inputs::MapSource;
use flakescatter::io::flakes::write_histogram_bins;
use flakescatter::streaming::pixel_orientation_streamed;
use flakescatter::{TopoSettings, pixel_orientation};
use serde_json::{Value, json};

use super::Args;
use super::report::pixel_level;
use crate::maps::stream::{self, Loaded};
use crate::output::{Dest, Plan, print_json, warn};

/// Streamed runs of more pixels than this get a progress bar (on a terminal).
const BAR_PIXELS: f64 = 2e7;

/// Runs `stats --map ... --pixel-normals-only`: the histogram of the usable pixels'
/// normals to `table` (`bin` radians wide) and the `--json` summary.
pub(super) fn only(
    args: &Args,
    mut plan: Plan,
    table: Option<&Dest>,
    sources: &[MapSource],
    bin: f64,
) -> anyhow::Result<()> {
    let loaded = Loaded::open(&args.input, sources, args.window, true)?;
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let streamed = matches!(loaded, Loaded::Stores(_));
    let bar = crate::output::progress::bar(
        "pixel normals {bar:40} {pos}/{len} tiles {eta}",
        streamed && loaded.pixels() as f64 > BAR_PIXELS,
    );
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let result = if streamed {
        pixel_orientation_streamed(&loaded.sources(), &topo, bin, &progress)
    } else {
        pixel_orientation(&loaded.maps(), &topo, bin)
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let o = result.map_err(|e| {
        let flags = format!("--window {}, --tile-um {}", args.window, args.tile_um);
        stream::run_error(e, sources, &loaded, args.input.cutoff, flags)
    })?;
    drop(loaded);
    if let Err(e) = &o.histogram_fit {
        warn(&format!(
            "--pixel-normals-only: the Gaussian fit to the pixel-level histogram failed (its width is null in the JSON; the histogram is written): {e}"
        ));
    }
    let fractions = o.tilts.area_fractions();
    if let Some(dest) = table {
        let name = dest.name();
        plan.write(
            dest,
            |w| Ok(write_histogram_bins(w, &name, &o.tilts.edges, &fractions)?),
            Some(format!("{} bins of pixel normals", fractions.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        let mut s = summary(args, sources, fractions.len());
        s["total_area_um2"] = json!(o.tilts.total_area_um2());
        s["pixel_level"] = pixel_level(args, &o);
        print_json(&s)?;
    }
    Ok(())
}

/// The `--json` summary but for the statistics: the inputs and the histogram.
fn summary(args: &Args, sources: &[MapSource], bins: usize) -> Value {
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "input": {
            "flakes_file": Value::Null,
            "map": sources[0].height.display().to_string(),
            "intensity": sources[0].intensity.as_ref().map(|p| p.display().to_string()),
            "cutoff": args.input.cutoff,
            "inputs": args.input.echo(sources),
            "column_set": "pixel normals",
            "bin_deg": args.bin,
        },
        "histogram_of": "pixel normals",
        "histogram_bins": bins,
        "histogram_file": args.out.as_ref().map(|p| p.display().to_string()),
    })
}
