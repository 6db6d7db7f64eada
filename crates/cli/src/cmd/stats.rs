//! `flakescatter stats`: area-weighted flake orientation histogram and Gaussian width
//! fit, of a flake table or of several maps pooled (a sample), with per-map widths and
//! the pixel-level statistics on request.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::TopoSettings;
use flakescatter::chart::histogram_chart;
use flakescatter::io::flakes::{read_flakes, write_histogram, write_histogram_bins};
use flakescatter::sample::{SampleSettings, SampleStatistics, sample_statistics};
use flakescatter::stats::fit::{WidthFit, fit_gaussian_ml};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::histogram::AreaHistogram;
use flakescatter::stats::pool::PooledWidth;
use flakescatter::topo::DEFAULT_BLOCK_UM;
use serde_json::{Value, json};

use crate::flags::SegmentArgs;
use crate::maps::{MapInputArgs, Repeats, load_all};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::tables::{num, write_flakes};

/// Orientation statistics of a flake table (--flakes) or of the flakes segmented from
/// height maps (--map, as `flakescatter segment`; several maps are pooled as one
/// sample): writes the area-weighted histogram of the flake polar angle θn (CSV
/// `theta_lo_deg, theta_hi_deg, area_fraction, p_per_rad, p_tilde`) and fits a Gaussian
/// p̃ by maximum likelihood. With several maps the width has two 95 % intervals: the
/// flake-level one (flakes as independent draws) and the map-level one (maps as the
/// independent units, Student's t on maps − 1 degrees of freedom), and each map its own
/// width, flagged when inconsistent with the others.
#[derive(Debug, clap::Args)]
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
    /// Least-squares window of the pixel normals, pixels (odd, >= 3).
    #[arg(long, value_name = "K", default_value_t = 5, value_parser = crate::parse::whole, allow_negative_numbers = true, requires = "pixel_normals")]
    pub window: usize,
    /// Side of the tiles whose spread gives the pixel-level interval, µm.
    #[arg(long = "tile-um", value_name = "UM", default_value_t = DEFAULT_BLOCK_UM, allow_negative_numbers = true, requires = "pixel_normals")]
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

/// `[lo, hi]` in degrees of the hwhm, `null` for an infinite end.
fn ci_deg(ci: (f64, f64)) -> Value {
    let f = |x: f64| x.is_finite().then(|| x.to_degrees());
    json!([f(ci.0), f(ci.1)])
}

/// The JSON of a pooled sample.
fn pooled_json(p: &PooledWidth, names: &[String]) -> Value {
    let flake = &p.flake_level;
    json!({
        "hwhm_deg": flake.hwhm().to_degrees(),
        "sigma_deg": flake.sigma.to_degrees(),
        "hwhm_ci95_deg": ci_deg(flake.hwhm_ci95()),
        "hwhm_ci95_method": format!("flake level: {}", flake.ci_method.describe()),
        "effective_flakes": flake.effective_n,
        "map_level": p.map_level.map(|m| json!({
            "hwhm_ci95_deg": ci_deg(m.hwhm_ci95()),
            "method": m.describe(),
            "maps": m.maps,
            "dof": m.dof,
            "t_quantile": m.t_quantile,
            "mean_square_tilt_std_err_rad2": m.mean_square_tilt_std_err,
        })),
        "quoted_interval": if p.map_level.is_some() { "map_level" } else { "flake_level" },
        "heterogeneity": p.heterogeneity.map(|h| json!({
            "cochran_q": h.q, "dof": h.dof, "p": h.p, "i2": h.i2,
        })),
        "z_bound": p.z_bound,
        "maps": p.maps.iter().zip(names).map(|(m, name)| json!({
            "map": name,
            "flakes": m.flakes,
            "area_um2": m.area_um2,
            "effective_flakes": m.effective_n,
            "hwhm_deg": m.fit.map(|f| f.hwhm().to_degrees()),
            "hwhm_ci95_deg": m.fit.map(|f| ci_deg(f.hwhm_ci95())),
            "z": m.z,
            "flagged": m.flagged,
        })).collect::<Vec<_>>(),
        "warnings": p.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
    })
}

/// Writes the per-map table.
fn write_per_map(
    w: &mut dyn std::io::Write,
    p: &PooledWidth,
    names: &[String],
) -> anyhow::Result<()> {
    let mut out = csv::Writer::from_writer(w);
    out.write_record([
        "map",
        "flakes",
        "area_um2",
        "effective_flakes",
        "hwhm_deg",
        "hwhm_ci95_lo_deg",
        "hwhm_ci95_hi_deg",
        "z",
        "flagged",
    ])?;
    for (m, name) in p.maps.iter().zip(names) {
        let (h, lo, hi) = m.fit.map_or((f64::NAN, f64::NAN, f64::NAN), |f| {
            let ci = f.hwhm_ci95();
            (f.hwhm().to_degrees(), ci.0.to_degrees(), ci.1.to_degrees())
        });
        out.write_record([
            name.clone(),
            m.flakes.to_string(),
            num(m.area_um2),
            num(m.effective_n),
            num(h),
            num(lo),
            num(hi),
            m.z.map(num).unwrap_or_default(),
            m.flagged.to_string(),
        ])?;
    }
    out.flush()?;
    Ok(())
}

/// Runs the subcommand.
#[allow(clippy::too_many_lines)]
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    if let Some(f) = &args.flakes {
        plan.input("--flakes", f);
    }
    let table = plan.table("--out", args.out.as_deref(), args.json);
    let flakes_out = plan.output("--flakes-out", args.flakes_out.as_deref(), Kind::Table);
    let per_map_out = plan.output("--per-map", args.per_map.as_deref(), Kind::Table);
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    if args.json {
        plan.stdout("--json");
    }
    // At least 0.001°: 90 000 bins over [0, 90°] at most.
    if !(args.bin.is_finite() && (0.001..=45.0).contains(&args.bin)) {
        bail!(
            "--bin {}: the bin width must be in [0.001, 45] degrees",
            args.bin
        );
    }
    if args.pixel_normals {
        if args.window < 3 || args.window.is_multiple_of(2) {
            bail!(
                "--window {}: the least-squares window must be an odd number of pixels >= 3",
                args.window
            );
        }
        if !(args.tile_um.is_finite() && args.tile_um > 0.0) {
            bail!(
                "--tile-um {}: the tile side must be a finite length > 0 µm",
                args.tile_um
            );
        }
    }
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

    // A flake table: one sample without maps.
    if let Some(path) = &args.flakes {
        let t =
            read_flakes(path).with_context(|| format!("reading --flakes {}", path.display()))?;
        let hist = AreaHistogram::from_flakes(&t.flakes, bin)
            .with_context(|| format!("histogram of {}", path.display()))?;
        let samples: Vec<(f64, f64)> = t.flakes.iter().map(|f| (f.theta_n(), f.area_um2)).collect();
        let needs_fit = args.json || plot.is_some();
        let fit = needs_fit
            .then(|| {
                fit_gaussian_ml(&samples)
                    .with_context(|| format!("fitting a Gaussian to {}", path.display()))
            })
            .transpose()?;
        write_plot(
            &mut plan,
            plot.as_ref(),
            &hist,
            fit.as_ref(),
            None,
            &path.display().to_string(),
        )?;
        if let Some(dest) = &table {
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
        return Ok(());
    }

    // Maps: one sample.
    let inputs = load_all(&sources, &options)?;
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
    if let Some(dest) = &flakes_out {
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
    if let Some(dest) = &per_map_out {
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
        plot.as_ref(),
        &stats.histogram,
        Some(&stats.pooled.flake_level),
        Some(&stats.pooled),
        &title,
    )?;
    if let Some(dest) = &table {
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
        print_json(&summary(&args, &names, &sources, &stats))?;
    }
    Ok(())
}

/// The histogram plot, when asked for: the flake histogram with the ML Gaussian and the
/// quoted interval's band.
fn write_plot(
    plan: &mut Plan,
    plot: Option<&Dest>,
    hist: &AreaHistogram,
    fit: Option<&WidthFit>,
    pooled: Option<&PooledWidth>,
    what: &str,
) -> anyhow::Result<()> {
    let (Some(Dest::File(path)), Some(fit)) = (plot, fit) else {
        return Ok(());
    };
    let (ci, which) = match pooled.and_then(|p| p.map_level) {
        Some(m) => (m.sigma_ci95, "map level"),
        None => (fit.sigma_ci95, "flake level"),
    };
    let chart = histogram_chart(
        hist,
        fit.sigma,
        ci,
        which,
        &format!("Area-weighted flake tilts, {what}"),
    );
    let bytes = crate::plot::encode(path, &chart)?;
    plan.write(
        &Dest::File(path.clone()),
        |w| Ok(w.write_all(&bytes)?),
        None,
    )
}

/// The `--json` summary of a sample.
fn summary(
    args: &Args,
    names: &[String],
    sources: &[flakescatter::inputs::MapSource],
    stats: &SampleStatistics,
) -> Value {
    let p = &stats.pooled;
    let mut s = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "input": {
            "flakes_file": Value::Null,
            "map": names[0],
            "intensity": sources[0].intensity.as_ref().map(|p| p.display().to_string()),
            "cutoff": args.input.cutoff,
            "inputs": args.input.echo(sources),
            "column_set": "segmented map",
            "bin_deg": args.bin,
            "z_step_um": args.segment.z_step_um,
            "noise_um": args.segment.noise_um,
            "min_pixels": args.segment.min_pixels,
        },
        "flakes": stats.histogram.flakes(),
        "total_area_um2": stats.histogram.total_area_um2(),
        "fit": "maximum likelihood, Gaussian p_tilde ∝ exp(-θ²/(2 sigma²)) on [0, 90°), area-weighted, all flakes of all maps pooled",
        "histogram_fit_hwhm_deg": stats.histogram_fit.map(|h| h.hwhm().to_degrees()),
        "histogram_bins": stats.histogram.bins().len(),
        "histogram_file": args.out.as_ref().map(|p| p.display().to_string()),
        "histogram_of": if stats.pixel.is_some() { "pixel normals" } else { "flakes" },
    });
    if let (Value::Object(o), Value::Object(extra)) = (&mut s, pooled_json(p, names)) {
        o.extend(extra);
    }
    if let Some(px) = &stats.pixel {
        let o = &px.orientation;
        s["pixel_level"] = json!({
            "usable_pixels": o.tilts.usable_pixels,
            "pixels": o.tilts.pixels,
            "histogram_fit_hwhm_deg": o.histogram_fit.hwhm().to_degrees(),
            "histogram_fit_method": "least squares on the histogram's p_tilde (dominated by the core)",
            "hwhm_deg": o.width.map(|w| w.hwhm().to_degrees()),
            "hwhm_ci95_deg": o.width.map(|w| ci_deg(w.hwhm_ci95())),
            "hwhm_method": "maximum likelihood over all usable pixels (moment matching of θ²), interval from the spread between tiles of --tile-um",
            "window": args.window,
            "tile_um": args.tile_um,
        });
        s["width_sources"] = match &px.sources {
            Ok(w) => json!({
                "flake_level_hwhm_deg": w.flake.hwhm().to_degrees(),
                "flake_level_hwhm_ci95_deg": ci_deg(w.flake.hwhm_ci95()),
                "flakes": w.flakes,
                "pixel_level_hwhm_deg": w.pixel.map(|p| p.hwhm().to_degrees()),
                "inside_flakes_hwhm_deg": w.inside.hwhm().to_degrees(),
                "inside_flakes_hwhm_ci95_deg": ci_deg(w.inside.hwhm_ci95()),
                "inside_pixels": w.inside.pixels,
                "flake_level_pixel_weighted_sigma_deg": w.flake_sigma_pixel_weighted.to_degrees(),
                "within_flake_sigma_deg": w.within_flake_sigma.map(f64::to_degrees),
                "meaning": "flake level: one plane per segmented flake; pixel level: the local normals of all usable pixels (what the topographic model traces); inside flakes: pixels whose window lies inside one flake; within_flake_sigma = sqrt(s_inside² − s_flake²) with flakes weighted like their pixels: the flakes' own roughness as a tilt spread per component",
            }),
            Err(e) => json!({"error": e}),
        };
    }
    s
}
