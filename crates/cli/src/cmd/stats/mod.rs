//! `flakescatter stats`: area-weighted flake orientation histogram and Gaussian width
//! fit, of a flake table or of several maps pooled (a sample), with per-map widths and
//! the pixel-level statistics on request.

mod pixels;
mod report;

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::TopoSettings;
use flakescatter::inputs::{LoadOptions, MapSource};
use flakescatter::io::flakes::{read_flakes, write_histogram, write_histogram_bins};
use flakescatter::sample::{SampleSettings, sample_statistics};
use flakescatter::stats::fit::fit_gaussian_ml;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::histogram::AreaHistogram;
use flakescatter::stats::segment::SegmentParams;
use flakescatter::topo::DEFAULT_BLOCK_UM;
use serde_json::{Value, json};

use crate::flags::SegmentArgs;
use crate::maps::{MapInputArgs, Repeats, load_all};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::tables::write_flakes;
use report::{ci_deg, summary, write_per_map, write_plot};

/// Orientation statistics of a flake table (--flakes) or of the flakes segmented from
/// height maps (--map, as `flakescatter segment`; several maps are pooled as one
/// sample): writes the area-weighted histogram of the flake polar angle θn (CSV
/// `theta_lo_deg, theta_hi_deg, area_fraction, p_per_rad, p_tilde`) and fits a Gaussian
/// p̃ by maximum likelihood. With several maps the width has two 95 % intervals: the
/// flake-level one (flakes as independent draws) and the map-level one (maps as the
/// independent units, Student's t on maps − 1 degrees of freedom), and each map its own
/// width, flagged when inconsistent with the others.
#[derive(Debug, clap::Args)]
#[command(group = clap::ArgGroup::new("pixel").multiple(false).args(["pixel_normals", "pixel_normals_only"]))]
pub struct Args {
    /// Flake table (CSV with header): columns `nx, ny, nz, area_um2`, or
    /// `theta_x_deg, theta_y_deg, area_um2`, or the endpoint columns
    /// `x1_um, z1_um, x2_um, z2_um, y1_um, zy1_um, y2_um, zy2_um` (paper eq. 6).
    #[arg(
        long,
        value_name = "FILE",
        required_unless_present = "map",
        conflicts_with = "map"
    )]
    pub flakes: Option<PathBuf>,
    /// Height maps or z-stacks to segment into flakes first (as `flakescatter segment`),
    /// directories of them or quoted glob patterns; several are pooled. The histogram
    /// uses each flake's fitted normal and true area.
    #[arg(long, value_name = "MAP", num_args = 1..)]
    pub map: Vec<PathBuf>,
    /// Map inputs (with --map): calibration, intensity pairing and cutoff, stacks.
    #[command(flatten)]
    pub input: MapInputArgs,
    /// Segmentation flags (with --map).
    #[command(flatten)]
    pub segment: SegmentArgs,
    /// With --map: also write the flake table (as `segment --out`) here.
    #[arg(long = "flakes-out", value_name = "FILE", requires = "map")]
    pub flakes_out: Option<PathBuf>,
    /// With --map: write the per-map table here (CSV: map, flakes, area_um2,
    /// effective_flakes, hwhm_deg, hwhm_ci95_lo_deg, hwhm_ci95_hi_deg, z, flagged).
    #[arg(long = "per-map", value_name = "FILE", requires = "map")]
    pub per_map: Option<PathBuf>,
    /// With --map: the statistics of the local (--window) normals of all usable pixels,
    /// each weighted by its true area; --out then writes their histogram (readable by
    /// `model --orientation table`) and the JSON gives the flake-level and pixel-level
    /// widths side by side (where the width comes from).
    #[arg(long = "pixel-normals", requires = "map")]
    pub pixel_normals: bool,
    /// With --map: only the pixel-level statistics of --pixel-normals, without
    /// segmenting flakes (the histogram CSV of --out and the JSON's `pixel_level`).
    /// Whenever every map is a Zarr store that `topo` would stream, the maps are read
    /// band by band (memory of about one band of 64 MiB of heights, not the map;
    /// docs/guide.md "Big maps"), else whole; the numbers are the same. Refuses the
    /// flake-level flags (--pixel-normals, --flakes-out, --per-map, --plot,
    /// --z-step-um, --noise-um, --min-pixels).
    #[arg(
        long = "pixel-normals-only",
        requires = "map",
        conflicts_with_all = ["flakes_out", "per_map", "plot", "z_step_um", "noise_um", "min_pixels"]
    )]
    pub pixel_normals_only: bool,
    /// Least-squares window of the pixel normals, pixels (odd, >= 3).
    #[arg(long, value_name = "K", default_value_t = 5, value_parser = crate::parse::odd_window)]
    pub window: usize,
    /// Side of the tiles whose spread gives the pixel-level interval, µm.
    #[arg(long = "tile-um", value_name = "UM", default_value_t = DEFAULT_BLOCK_UM, allow_negative_numbers = true)]
    pub tile_um: f64,
    /// Histogram bin width in degrees, in [0.001, 45].
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub bin: f64,
    /// Write the histogram CSV here (`-` = stdout). Without `--out` and `--json` the
    /// histogram goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Draw the area-weighted histogram of p̃ with the fitted Gaussian and its 95 % band
    /// (.svg or .png).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Print a JSON summary on stdout: fitted `hwhm_deg`, `hwhm_ci95_deg` (flake level),
    /// `map_level` (with several maps), `maps` (per map), `flakes`, `total_area_um2`,
    /// bin width, inputs and version.
    #[arg(long)]
    pub json: bool,
}

/// The files (or stdout) the run writes, registered with the plan before any work.
struct Outputs {
    /// The histogram (--out, or stdout without --json).
    table: Option<Dest>,
    /// --flakes-out.
    flakes: Option<Dest>,
    /// --per-map.
    per_map: Option<Dest>,
    /// --plot.
    plot: Option<Dest>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    if let Some(f) = &args.flakes {
        plan.input("--flakes", f);
    }
    let out = Outputs {
        table: plan.table("--out", args.out.as_deref(), args.json),
        flakes: plan.output("--flakes-out", args.flakes_out.as_deref(), Kind::Table),
        per_map: plan.output("--per-map", args.per_map.as_deref(), Kind::Table),
        plot: plan.output("--plot", args.plot.as_deref(), Kind::Plot),
    };
    if args.json {
        plan.stdout("--json");
    }
    check_numbers(&args)?;
    let params = args.segment.params()?;
    let options = args.input.load_options()?;
    let sources = if args.map.is_empty() {
        Vec::new()
    } else {
        args.input
            .sources("--map", &args.map, &mut plan, Repeats::Refuse)?
    };
    plan.check()?;
    let bin = args.bin.to_radians();

    if let Some(path) = &args.flakes {
        return of_flake_table(&args, plan, &out, path, bin);
    }
    if args.pixel_normals_only {
        return pixels::only(&args, plan, out.table.as_ref(), &sources, bin);
    }
    of_maps(&args, plan, &out, &sources, &options, params, bin)
}

/// The numeric flags clap cannot check alone (bin width; window and tile side with
/// --pixel-normals), in the order a user meets them.
fn check_numbers(args: &Args) -> anyhow::Result<()> {
    // At least 0.001°: 90 000 bins over [0, 90°] at most.
    if !(args.bin.is_finite() && (0.001..=45.0).contains(&args.bin)) {
        bail!(
            "--bin {}: the bin width must be in [0.001, 45] degrees",
            args.bin
        );
    }
    if args.pixel_normals || args.pixel_normals_only {
        flakescatter::checks::window(args.window).map_err(|e| anyhow::anyhow!("--window {e}"))?;
        flakescatter::checks::tile_um(args.tile_um)
            .map_err(|e| anyhow::anyhow!("--tile-um {e}"))?;
    }
    Ok(())
}

/// A flake table: one sample without maps.
fn of_flake_table(
    args: &Args,
    mut plan: Plan,
    out: &Outputs,
    path: &Path,
    bin: f64,
) -> anyhow::Result<()> {
    let t = read_flakes(path).with_context(|| format!("reading --flakes {}", path.display()))?;
    let hist = AreaHistogram::from_flakes(&t.flakes, bin)
        .with_context(|| format!("histogram of {}", path.display()))?;
    let samples: Vec<(f64, f64)> = t.flakes.iter().map(|f| (f.theta_n(), f.area_um2)).collect();
    let needs_fit = args.json || out.plot.is_some();
    let fit = needs_fit
        .then(|| {
            fit_gaussian_ml(&samples)
                .with_context(|| format!("fitting a Gaussian to {}", path.display()))
        })
        .transpose()?;
    write_plot(
        &mut plan,
        out.plot.as_ref(),
        &hist,
        fit.as_ref(),
        None,
        &path.display().to_string(),
    )?;
    if let Some(dest) = &out.table {
        let name = dest.name();
        plan.write(
            dest,
            |w| Ok(write_histogram(w, &name, &hist)?),
            Some(format!("{} bins", hist.bins().len())),
        )?;
    }
    plan.finish()?;
    if let (true, Some(fit)) = (args.json, fit) {
        print_json(&json!({
            "version": env!("CARGO_PKG_VERSION"),
            "input": {
                "flakes_file": path.display().to_string(),
                "map": Value::Null,
                "column_set": t.column_set.name(),
                "bin_deg": args.bin,
            },
            "flakes": t.flakes.len(),
            "total_area_um2": hist.total_area_um2(),
            "fit": "maximum likelihood, Gaussian p_tilde ∝ exp(-θ²/(2 sigma²)) on [0, 90°), area-weighted",
            "hwhm_deg": fit.hwhm().to_degrees(),
            "hwhm_ci95_deg": ci_deg(fit.hwhm_ci95()),
            "hwhm_ci95_method": fit.ci_method.describe(),
            "sigma_deg": fit.sigma.to_degrees(),
            "effective_flakes": fit.effective_n,
            "histogram_bins": hist.bins().len(),
            "histogram_file": args.out.as_ref().map(|p| p.display().to_string()),
        }))?;
    }
    Ok(())
}

/// Height maps: segmented, pooled as one sample.
fn of_maps(
    args: &Args,
    mut plan: Plan,
    out: &Outputs,
    sources: &[MapSource],
    options: &LoadOptions,
    params: SegmentParams,
    bin: f64,
) -> anyhow::Result<()> {
    let inputs = load_all(sources, options)?;
    let maps: Vec<&HeightMap> = inputs.iter().map(|i| &i.loaded.map).collect();
    let names: Vec<String> = sources
        .iter()
        .map(|s| s.height.display().to_string())
        .collect();
    let settings = SampleSettings {
        segment: params,
        bin_width: bin,
        pixel_normals: args.pixel_normals.then_some(TopoSettings {
            window: args.window,
            tile_um: args.tile_um,
        }),
    };
    let stats = sample_statistics(&maps, &settings, &|_, _| {})
        .map_err(|e| anyhow::anyhow!("--map {}: {e}", names.join(", ")))?;
    for (name, seg) in names.iter().zip(&stats.segmentations) {
        if let Some(w) = seg.warning {
            warn(&format!("{name}: {w}"));
        }
    }
    for w in &stats.pooled.warnings {
        warn(&w.to_string());
    }
    if let Some(Err(e)) = stats.pixel.as_ref().map(|px| &px.orientation.histogram_fit) {
        warn(&format!(
            "--pixel-normals: the Gaussian fit to the pixel-level histogram failed (its width is null in the JSON; the histogram is written): {e}"
        ));
    }
    if let Some(dest) = &out.flakes {
        let rows: Vec<(String, &[_])> = names
            .iter()
            .zip(&stats.segmentations)
            .map(|(n, s)| (n.clone(), s.flakes.as_slice()))
            .collect();
        let total: usize = rows.iter().map(|r| r.1.len()).sum();
        plan.write(
            dest,
            |w| write_flakes(w, &rows),
            Some(format!("{total} flakes")),
        )?;
    }
    if let Some(dest) = &out.per_map {
        plan.write(
            dest,
            |w| write_per_map(w, &stats.pooled, &names),
            Some(format!("{} maps", names.len())),
        )?;
    }
    let title = if names.len() == 1 {
        names[0].clone()
    } else {
        format!("{} maps", names.len())
    };
    write_plot(
        &mut plan,
        out.plot.as_ref(),
        &stats.histogram,
        Some(&stats.pooled.flake_level),
        Some(&stats.pooled),
        &title,
    )?;
    if let Some(dest) = &out.table {
        let name = dest.name();
        match &stats.pixel {
            Some(px) => {
                let t = &px.orientation.tilts;
                let fractions = t.area_fractions();
                plan.write(
                    dest,
                    |w| Ok(write_histogram_bins(w, &name, &t.edges, &fractions)?),
                    Some(format!("{} bins of pixel normals", fractions.len())),
                )?;
            }
            None => plan.write(
                dest,
                |w| Ok(write_histogram(w, &name, &stats.histogram)?),
                Some(format!("{} bins", stats.histogram.bins().len())),
            )?,
        }
    }
    plan.finish()?;
    if args.json {
        print_json(&summary(args, &names, sources, &stats))?;
    }
    Ok(())
}
