//! `flakescatter segment MAP`: find the individual flakes of a confocal height map and
//! write one row per flake (normal, angles, areas, roughness, border flag, quality).
//!
//! Units: the library works in µm and radians; the table has µm columns and degrees in
//! `_deg` columns (cli.md).

use std::path::PathBuf;

use serde_json::json;

use crate::flags::SegmentArgs;
use crate::maps::segment_file;
use crate::output::{Plan, print_json};
use crate::tables::write_flakes;

/// Finds the individual flakes of a confocal height map: mask from the intensity map,
/// regions split where heights jump or the plane turns, a robust plane fit per flake.
///
/// Writes a flake table (CSV): x_um, y_um (centroid, x along columns, y along rows),
/// nx, ny, nz (unit normal), area_um2 (true area = projected / nz), theta_n_deg,
/// phi_n_deg, projected_area_um2, equivalent_diameter_um, rms_um (plane residual),
/// tilt_se_deg (standard error of the tilt), pixels, inliers, touches_border, quality
/// (0..1). `flakescatter stats --flakes` reads it.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The height-map file (X3P, SDF or plain text, recognised from the content).
    #[arg(value_name = "MAP")]
    pub map: PathBuf,
    /// Map input and segmentation flags.
    #[command(flatten)]
    pub segment: SegmentArgs,
    /// Write the flake table here (`-` = stdout). Without --out and --json it goes to
    /// stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout: counts of flakes, pixels, warning, inputs, version.
    #[arg(long)]
    pub json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    plan.input("MAP", &args.map);
    args.segment.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    args.segment.params()?;
    args.segment.calibration.read_options()?;
    plan.check()?;
    let (map, seg) = segment_file(&args.map, &args.segment)?;
    if let Some(dest) = &table {
        plan.write(
            dest,
            |w| write_flakes(w, &seg.flakes),
            Some(format!("{} flakes", seg.flakes.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        let s = &args.segment;
        print_json(&json!({
            "version": env!("CARGO_PKG_VERSION"),
            "input": {
                "map": args.map.display().to_string(),
                "intensity": s.intensity.as_ref().map(|p| p.display().to_string()),
                "cutoff": s.cutoff,
                "z_step_um": s.z_step_um,
                "noise_um": s.noise_um,
                "min_pixels": s.min_pixels,
            },
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
            "flake_table": args.out.as_ref().map(|p| p.display().to_string()),
        }))?;
    }
    Ok(())
}
