//! `flakescatter segment MAP [MAP ...]`: find the individual flakes of confocal height
//! maps (or z-stacks) and write one row per flake (normal, angles, areas, roughness,
//! border flag, quality, map, flake number); `--overlay DIR` draws each map with its
//! flakes coloured by tilt.
//!
//! Units: the library works in µm and radians; the table has µm columns and degrees in
//! `_deg` columns (cli.md).

use std::path::PathBuf;

use flakescatter::inputs::short_names;
use flakescatter::overlay::overlay;
use flakescatter::sample::segment_maps;
use flakescatter::stats::heightmap::HeightMap;
use serde_json::json;

use crate::flags::SegmentArgs;
use crate::maps::{MapInputArgs, Repeats, load_all};
use crate::output::{Plan, print_json, warn};
use crate::picture::overlay_png;
use crate::tables::write_flakes;

/// Finds the individual flakes of confocal height maps: mask from the intensity map,
/// regions split where heights jump or the plane turns, a robust plane fit per flake.
///
/// Writes a flake table (CSV): x_um, y_um (centroid, x along columns, y along rows),
/// nx, ny, nz (unit normal), area_um2 (true area = projected / nz), theta_n_deg,
/// phi_n_deg, projected_area_um2, equivalent_diameter_um, rms_um (plane residual),
/// tilt_se_deg (standard error of the tilt), pixels, inliers, touches_border, quality
/// (0..1), map (the file), flake (its number on that map, 1, 2, ...).
/// `flakescatter stats --flakes` reads it.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Height maps (X3P, SDF or plain text, recognised from the content), z-stacks
    /// (.tif), directories of them or quoted glob patterns.
    #[arg(value_name = "MAP", required = true)]
    pub maps: Vec<PathBuf>,
    /// Map inputs: calibration, intensity pairing and cutoff, stacks.
    #[command(flatten)]
    pub input: MapInputArgs,
    /// Segmentation flags.
    #[command(flatten)]
    pub segment: SegmentArgs,
    /// Write the flake table here (`-` = stdout). Without --out and --json it goes to
    /// stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write one PNG per map into this directory: the height map in grey, each flake
    /// filled with the colour of its tilt and outlined, flake numbers on large flakes,
    /// pixels in no flake hatched, pixels without data dark, a colour bar in degrees.
    /// The directory is created, or replaced whole when empty or an earlier overlay
    /// directory; a directory holding other files is refused.
    #[arg(long, value_name = "DIR")]
    pub overlay: Option<PathBuf>,
    /// Top of the overlays' tilt colour scale, degrees (flakes tilted more take its
    /// colour), in (0, 90].
    #[arg(
        long = "overlay-max-deg",
        value_name = "DEG",
        default_value_t = 20.0,
        allow_negative_numbers = true
    )]
    pub overlay_max_deg: f64,
    /// Print a JSON summary on stdout: counts of flakes and pixels per map, warnings,
    /// inputs, version.
    #[arg(long)]
    pub json: bool,
}

/// The owner recorded in an overlay directory's marker (`output::owned`).
const OVERLAY_OWNER: &str = "segment --overlay";

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    if let Some(dir) = &args.overlay {
        plan.output_dir("--overlay", dir, OVERLAY_OWNER);
    }
    if !(args.overlay_max_deg.is_finite()
        && args.overlay_max_deg > 0.0
        && args.overlay_max_deg <= 90.0)
    {
        anyhow::bail!(
            "--overlay-max-deg {}: expected a tilt in (0, 90] degrees",
            args.overlay_max_deg
        );
    }
    let params = args.segment.params()?;
    let options = args.input.load_options()?;
    let sources = args
        .input
        .sources("MAP", &args.maps, &mut plan, Repeats::Refuse)?;
    plan.check()?;
    let inputs = load_all(&sources, &options)?;
    let maps: Vec<&HeightMap> = inputs.iter().map(|i| &i.loaded.map).collect();
    let segs = segment_maps(&maps, &params, &|_, _| {})?;
    let names: Vec<String> = sources
        .iter()
        .map(|s| s.height.display().to_string())
        .collect();
    for (name, seg) in names.iter().zip(&segs) {
        if let Some(w) = seg.warning {
            warn(&format!("{name}: {w}; it adds no row to the flake table"));
        }
    }
    let total: usize = segs.iter().map(|s| s.flakes.len()).sum();
    if let Some(dest) = &table {
        let rows: Vec<(String, &[_])> = names
            .iter()
            .zip(&segs)
            .map(|(n, s)| (n.clone(), s.flakes.as_slice()))
            .collect();
        plan.write(
            dest,
            |w| write_flakes(w, &rows),
            Some(format!("{total} flakes")),
        )?;
    }
    let short = short_names(&sources);
    if let Some(dir) = &args.overlay {
        let mut files = Vec::with_capacity(maps.len());
        for ((map, seg), (name, file)) in maps.iter().zip(&segs).zip(short.iter().zip(&names)) {
            let o = overlay(map, seg, args.overlay_max_deg.to_radians());
            let png_name = format!("{name}.png");
            let bytes = overlay_png(&o, file, &dir.join(&png_name).display().to_string())?;
            files.push((PathBuf::from(png_name), bytes));
        }
        plan.write_dir(
            "--overlay",
            dir,
            OVERLAY_OWNER,
            &files,
            Some(format!("{} overlays", files.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        let s = &args.segment;
        let per_map: Vec<_> = names
            .iter()
            .zip(&segs)
            .zip(&inputs)
            .zip(&short)
            .map(|(((name, seg), input), short)| {
                let map = &input.loaded.map;
                json!({
                    "map": name,
                    "format": input.loaded.format,
                    "nx": map.nx(),
                    "ny": map.ny(),
                    "dx_um": map.dx(),
                    "dy_um": map.dy(),
                    "flakes": seg.flakes.len(),
                    "flakes_touching_border": seg.flakes.iter().filter(|f| f.touches_border).count(),
                    "valid_pixels": seg.valid_pixels,
                    "dropped_pixels": seg.dropped_pixels,
                    "total_area_um2": seg.flakes.iter().map(|f| f.area_um2).sum::<f64>(),
                    "warning": seg.warning.map(|w| w.to_string()),
                    "overlay": args.overlay.as_ref().map(|d| d.join(format!("{short}.png")).display().to_string()),
                })
            })
            .collect();
        let first = &inputs[0].loaded.map;
        print_json(&json!({
            "version": env!("CARGO_PKG_VERSION"),
            "input": {
                "map": names[0],
                "intensity": sources[0].intensity.as_ref().map(|p| p.display().to_string()),
                "inputs": args.input.echo(&sources),
                "cutoff": args.input.cutoff,
                "z_step_um": s.z_step_um,
                "noise_um": s.noise_um,
                "min_pixels": s.min_pixels,
                "overlay_max_deg": args.overlay_max_deg,
            },
            "maps": per_map,
            "nx": first.nx(),
            "ny": first.ny(),
            "dx_um": first.dx(),
            "dy_um": first.dy(),
            "flakes": total,
            "flakes_touching_border": segs.iter().flat_map(|s| &s.flakes).filter(|f| f.touches_border).count(),
            "valid_pixels": segs.iter().map(|s| s.valid_pixels).sum::<usize>(),
            "dropped_pixels": segs.iter().map(|s| s.dropped_pixels).sum::<usize>(),
            "total_area_um2": segs.iter().flat_map(|s| &s.flakes).map(|f| f.area_um2).sum::<f64>(),
            "warning": segs.iter().find_map(|s| s.warning).map(|w| w.to_string()),
            "flake_table": args.out.as_ref().map(|p| p.display().to_string()),
            "overlay_scale": "maps below 512 points on their larger side are enlarged by floor(512/side), above 2048 reduced by ceil(side/2048); the map is the top-left of the image, the colour bar strip to its right",
        }))?;
    }
    Ok(())
}
