//! `flakescatter topo MAP [MAP ...]`: the topographic model (physics.md §5) over one or
//! more height maps, accumulated into one result.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::chart::topographic_chart;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::topo::{DEFAULT_BLOCK_UM, TopoResult, TopoWarning};
use flakescatter::{Curves, TopoSettings, topographic_curves};
use serde_json::{Value, json};

use crate::flags::InstrumentArgs;
use crate::maps::{MapInputArgs, Repeats, load_all};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::tables::{curve_warnings, rows_json, units_json, write_curves};
use flakescatter::inputs::MapSource;

/// Reflectance from confocal height maps: one ray per usable pixel, reflected by the
/// local least-squares plane (paper eqs. 14–15 as corrected in docs/physics.md §5).
///
/// Writes one CSV row per incidence × detector: theta_i_deg, theta_s_deg, phi_s_deg,
/// aperture_deg, brdf_per_sr, reflectance (fraction of the beam over all pixels of all
/// maps), relative (to the same detector at the specular direction), rays (rays counted
/// in the detector) and std_err (standard error of brdf_per_sr, from the spread between
/// map tiles of --tile-um; empty when not estimable: fewer than 2 tiles, or no ray).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Height maps (X3P, SDF or plain text, recognised from the content), z-stacks
    /// (.tif), directories of them or quoted glob patterns; all are traced and
    /// accumulated into one result.
    #[arg(required = true, value_name = "MAP")]
    pub maps: Vec<PathBuf>,
    /// Map inputs: calibration, intensity pairing (--intensity once per map, or
    /// --intensity-suffix) and cutoff, stacks.
    #[command(flatten)]
    pub input: MapInputArgs,
    /// Side of the least-squares window for local normals, pixels (odd, >= 3).
    #[arg(long, value_name = "K", default_value_t = 5, value_parser = crate::parse::whole, allow_negative_numbers = true)]
    pub window: usize,
    /// Side of the square map tiles whose spread gives std_err, µm (a few flake
    /// diameters).
    #[arg(long, value_name = "UM", default_value_t = DEFAULT_BLOCK_UM, allow_negative_numbers = true)]
    pub tile_um: f64,
    #[command(flatten)]
    pub instrument: InstrumentArgs,
    /// Write the CSV here (`-` = stdout). Without --out and --json the CSV goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (inputs, counts of pixels and rays, units,
    /// version; the rows unless --out writes them).
    #[arg(long)]
    pub json: bool,
    /// Draw the relative curves (log axis) to this .svg or .png file.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

/// Checks the flags that need no file.
fn validate(args: &Args) -> anyhow::Result<()> {
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
    Ok(())
}

/// Read the maps and apply the intensity cutoff; errors name the file.
fn load_maps(args: &Args, sources: &[MapSource]) -> anyhow::Result<Vec<HeightMap>> {
    let options = args.input.load_options()?;
    let mut maps = Vec::with_capacity(sources.len());
    for input in load_all(sources, &options)? {
        let (path, map) = (&input.source.height, input.loaded.map);
        if map.valid_count() == 0 {
            bail!(
                "height map {}: no valid pixel (all {} are NaN or masked)",
                path.display(),
                map.len()
            );
        }
        if args.window > map.nx().min(map.ny()) {
            bail!(
                "--window {}: larger than height map {} ({} x {} pixels)",
                args.window,
                path.display(),
                map.nx(),
                map.ny()
            );
        }
        maps.push(map);
    }
    Ok(maps)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.instrument.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    let coating = args.instrument.optics.coating()?;
    let settings = args.instrument.settings();
    validate(&args)?;
    if args.instrument.optics.aperture_rad()? <= 0.0 {
        bail!(
            "--aperture 0: the topographic model counts rays into detector cones; give a half-angle > 0"
        );
    }
    let instrument = args.instrument.instrument()?;
    args.input.load_options()?;
    let sources = args
        .input
        .sources("MAP", &args.maps, &mut plan, Repeats::Warn)?;
    plan.check()?;
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let maps = load_maps(&args, &sources)?;
    let refs: Vec<&HeightMap> = maps.iter().collect();

    // Progress on stderr when it is a terminal and the run is long.
    let pixels: usize = maps.iter().map(HeightMap::len).sum();
    let work = pixels as f64 * instrument.theta_i().len() as f64;
    let bar = (std::io::stderr().is_terminal() && work > 2e7).then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template("tracing {bar:40} {pos}/{len} tiles {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    let (curves, result) =
        topographic_curves(&coating, &instrument, &settings, &topo, &refs, &progress)
            .with_context(|| format!("--window {}, --tile-um {}", args.window, args.tile_um))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut warnings: Vec<String> = result
        .warnings
        .iter()
        .map(|w| format!("{w} (--tile-um {})", args.tile_um))
        .collect();
    // Rows without a standard error are counted unless the model already said that none
    // can be estimated.
    let all_missing = result
        .warnings
        .iter()
        .any(|w| matches!(w, TopoWarning::StdErrNotEstimable { .. }));
    warnings.extend(curve_warnings(&curves, !all_missing));
    for w in &warnings {
        warn(w);
    }
    let plot_bytes = match &plot {
        Some(Dest::File(p)) => Some((
            p.clone(),
            crate::plot::encode(p, &topographic_chart(&curves))?,
        )),
        _ => None,
    };
    if let Some(dest) = &table {
        let rows = curves.rows.len();
        plan.write(
            dest,
            |w| write_curves(w, &curves, true),
            Some(format!("{rows} rows")),
        )?;
    }
    if let Some((p, bytes)) = plot_bytes {
        plan.write(&Dest::File(p), |w| Ok(w.write_all(&bytes)?), None)?;
    }
    plan.finish()?;
    if args.json {
        let mut s = summary(&args, &sources, &maps, &result, &curves);
        s["warnings"] = json!(warnings);
        if table.is_none() {
            s["rows"] = rows_json(&curves);
        } else {
            s["row_count"] = json!(curves.rows.len());
        }
        print_json(&s)?;
    }
    Ok(())
}

/// The `--json` summary (without the rows).
fn summary(
    args: &Args,
    sources: &[MapSource],
    maps: &[HeightMap],
    r: &TopoResult,
    curves: &Curves,
) -> Value {
    let per_map: Vec<Value> = sources
        .iter()
        .zip(maps)
        .map(|(p, m)| {
            json!({
                "file": p.height.display().to_string(),
                "nx": m.nx(),
                "ny": m.ny(),
                "dx_um": m.dx(),
                "dy_um": m.dy(),
                "valid_pixels": m.valid_count(),
            })
        })
        .collect();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "topo",
        "model": curves.model,
        "inputs": {
            "maps": per_map,
            "intensity": sources.iter().filter_map(|s| s.intensity.as_ref().map(|p| p.display().to_string())).collect::<Vec<_>>(),
            "cutoff": args.input.cutoff,
            "pixel_um": args.input.calibration.pixel_um,
            "z_unit": args.input.calibration.z_unit,
            "map_inputs": args.input.echo(sources),
            "window": args.window,
            "tile_um": args.tile_um,
            "instrument": args.instrument.echo(),
        },
        "counts": {
            "maps": r.maps,
            "pixels": r.pixels,
            "usable_pixels": r.usable_pixels,
            "usable_fraction": r.usable_fraction(),
            "rays_traced": r.rays_traced,
            "rays_lost_tir": r.rays_lost_tir,
            "rays_lost_down": r.rays_lost_down,
            "tiles": r.tiles,
        },
        "warnings": r.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "units": {
            "columns": units_json(),
            "rays": "number of rays counted in the detector",
            "std_err": "1/sr, standard error of brdf_per_sr from the spread between map tiles; null (empty in the CSV) when not estimable: fewer than 2 tiles, or no ray in the detector",
            "reflectance_normalisation": "fraction of the incident beam over all pixels of all maps (invalid pixels are black substrate)",
        },
        "out": args.out.as_ref().map(|p| p.display().to_string()),
        "plot": args.plot.as_ref().map(|p| p.display().to_string()),
    })
}
