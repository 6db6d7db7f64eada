//! `flakescatter topo MAP [MAP ...]`: the topographic model (physics.md §5) over one or
//! more height maps, accumulated into one result.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::io::{read_intensity, read_map};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::topo::{DEFAULT_BLOCK_UM, TopoResult};
use flakescatter::{Curves, TopoSettings, topographic_curves};
use serde_json::{Value, json};

use crate::cmd::info::MapArgs;
use crate::instrument::{
    InstrumentArgs, rows_json, table_to_stdout, table_writer, units_json, warn_undefined_relative,
    write_curves_csv,
};
use crate::plot::{Figure, draw, relative_figure};

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
    /// Height maps (X3P, SDF or plain text, recognised from the content); all are traced
    /// and accumulated into one result.
    #[arg(required = true, value_name = "MAP")]
    pub maps: Vec<PathBuf>,
    #[command(flatten)]
    pub calibration: MapArgs,
    /// Intensity map for each height map, same order (repeat the flag: one per map);
    /// pixels with intensity below --cutoff are left out.
    #[arg(long, value_name = "FILE")]
    pub intensity: Vec<PathBuf>,
    /// Intensity cutoff (same unit as the intensity maps); needs --intensity.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cutoff: Option<f64>,
    /// Side of the least-squares window for local normals, pixels (odd, >= 3).
    #[arg(long, value_name = "K", default_value_t = 5)]
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
    /// version, rows).
    #[arg(long)]
    pub json: bool,
    /// Draw the relative curves (log axis) to this SVG file.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

/// Read the maps and apply the intensity cutoff; errors name the file.
fn load_maps(args: &Args) -> anyhow::Result<Vec<HeightMap>> {
    let options = args.calibration.read_options()?;
    match (args.intensity.is_empty(), args.cutoff) {
        (true, Some(c)) => bail!("--cutoff {c} needs --intensity FILE (one per map)"),
        (false, None) => bail!("--intensity needs --cutoff X"),
        (false, Some(_)) if args.intensity.len() != args.maps.len() => bail!(
            "--intensity given {} times for {} height maps: give one intensity map per height map, in the same order",
            args.intensity.len(),
            args.maps.len()
        ),
        _ => {}
    }
    let mut maps = Vec::with_capacity(args.maps.len());
    for (k, path) in args.maps.iter().enumerate() {
        let (mut map, _) = read_map(path, &options)
            .with_context(|| format!("reading height map {}", path.display()))?;
        if let (Some(ipath), Some(cutoff)) = (args.intensity.get(k), args.cutoff) {
            let (intensity, _) = read_intensity(ipath, &options)
                .with_context(|| format!("reading --intensity {}", ipath.display()))?;
            map.apply_intensity_cutoff(&intensity, cutoff)
                .with_context(|| {
                    format!(
                        "height map {} with --intensity {} and --cutoff {cutoff}",
                        path.display(),
                        ipath.display()
                    )
                })?;
        }
        if map.valid_count() == 0 {
            bail!(
                "height map {}: no valid pixel (all {} are NaN or masked)",
                path.display(),
                map.len()
            );
        }
        if args.window <= map.nx().min(map.ny()) {
            maps.push(map);
        } else {
            bail!(
                "--window {}: larger than height map {} ({} x {} pixels)",
                args.window,
                path.display(),
                map.nx(),
                map.ny()
            );
        }
    }
    Ok(maps)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let to_stdout = table_to_stdout(args.out.as_deref(), args.json)?;
    let coating = args.instrument.coating()?;
    let instrument = args.instrument.instrument()?;
    let settings = args.instrument.settings();
    if instrument.aperture() <= 0.0 {
        bail!(
            "--aperture 0: the topographic model counts rays into detector cones; give a half-angle > 0"
        );
    }
    if args.window < 3 || args.window.is_multiple_of(2) {
        bail!(
            "--window {}: the least-squares window must be an odd number of pixels >= 3",
            args.window
        );
    }
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let maps = load_maps(&args)?;
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
    warn_undefined_relative(&curves);
    for w in &result.warnings {
        eprintln!("warning: {w} (--tile-um {})", args.tile_um);
    }
    if let Some((mut w, _)) = table_writer(args.out.as_deref(), to_stdout)? {
        write_curves_csv(&mut w, &curves, true)?;
    }
    if let Some(path) = &args.plot {
        draw(path, &figure(&curves))?;
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&summary(&args, &maps, &result, &curves))?
        );
    }
    Ok(())
}

/// The `--json` summary.
fn summary(args: &Args, maps: &[HeightMap], r: &TopoResult, curves: &Curves) -> Value {
    let per_map: Vec<Value> = args
        .maps
        .iter()
        .zip(maps)
        .map(|(p, m)| {
            json!({
                "file": p.display().to_string(),
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
            "intensity": args.intensity.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "cutoff": args.cutoff,
            "pixel_um": args.calibration.pixel_um,
            "z_unit": args.calibration.z_unit,
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
        "rows": rows_json(curves),
    })
}

/// Relative curves per incidence on a log axis.
fn figure(curves: &Curves) -> Figure {
    relative_figure(
        curves,
        format!(
            "Topographic model, n = {}, aperture {:.2}°",
            curves.coating.n,
            curves.instrument.aperture().to_degrees()
        ),
    )
}
