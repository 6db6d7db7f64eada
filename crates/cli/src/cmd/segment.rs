//! `flakescatter segment MAP`: find the individual flakes of a confocal height map and
//! write one row per flake (normal, angles, areas, roughness, border flag, quality).
//!
//! Units: the library works in µm and radians; the table has µm columns and degrees in
//! `_deg` columns (cli.md).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::io::{read_intensity, read_map};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::segment::{SegmentParams, Segmentation, SegmentedFlake, segment};
use serde_json::json;

use crate::cmd::info::MapArgs;
use crate::common::Failure;
use crate::instrument::{table_to_stdout, table_writer};

/// Columns of the flake table written by `segment` (the first eight are the flake-table
/// "normals" set with centre and angles, readable by `stats --flakes`).
pub const COLUMNS: [&str; 16] = [
    "x_um",
    "y_um",
    "nx",
    "ny",
    "nz",
    "area_um2",
    "theta_n_deg",
    "phi_n_deg",
    "projected_area_um2",
    "equivalent_diameter_um",
    "rms_um",
    "tilt_se_deg",
    "pixels",
    "inliers",
    "touches_border",
    "quality",
];

/// Map input and segmentation flags, shared with `stats --map`.
#[derive(Debug, Clone, clap::Args)]
pub struct SegmentArgs {
    /// Calibration flags.
    #[command(flatten)]
    pub calibration: MapArgs,
    /// Intensity image of the same size (X3P, SDF or text); pixels whose intensity is
    /// below --cutoff are left out (dark background between flakes).
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
    /// z quantisation step of the instrument, µm (0 = none); sets the height-jump and
    /// plane-residual thresholds.
    #[arg(
        long = "z-step-um",
        value_name = "UM",
        default_value_t = 0.3,
        allow_negative_numbers = true
    )]
    pub z_step_um: f64,
    /// Height noise standard deviation of the instrument, µm.
    #[arg(
        long = "noise-um",
        value_name = "UM",
        default_value_t = 0.03,
        allow_negative_numbers = true
    )]
    pub noise_um: f64,
    /// Smallest flake kept, pixels (>= 3).
    #[arg(long = "min-pixels", value_name = "N", default_value_t = 100)]
    pub min_pixels: usize,
}

impl SegmentArgs {
    /// The segmentation parameters; errors name the flag.
    pub fn params(&self) -> anyhow::Result<SegmentParams> {
        if !(self.z_step_um.is_finite() && self.z_step_um >= 0.0) {
            bail!("--z-step-um {}: must be finite and >= 0 µm", self.z_step_um);
        }
        if !(self.noise_um.is_finite() && self.noise_um >= 0.0) {
            bail!("--noise-um {}: must be finite and >= 0 µm", self.noise_um);
        }
        if self.min_pixels < 3 {
            bail!("--min-pixels {}: must be at least 3", self.min_pixels);
        }
        let mut p = SegmentParams::for_instrument(self.z_step_um, self.noise_um);
        p.min_pixels = self.min_pixels;
        Ok(p)
    }
}

/// Reads `map` (with the intensity cutoff) and segments it. A map without flakes gives
/// an empty result whose warning is printed on stderr.
pub fn segment_file(map: &Path, args: &SegmentArgs) -> anyhow::Result<(HeightMap, Segmentation)> {
    let params = args.params()?;
    let options = args.calibration.read_options()?;
    let (mut height, _) =
        read_map(map, &options).with_context(|| format!("reading MAP {}", map.display()))?;
    if let (Some(ipath), Some(cutoff)) = (&args.intensity, args.cutoff) {
        let (intensity, _) = read_intensity(ipath, &options)
            .with_context(|| format!("reading --intensity {}", ipath.display()))?;
        height
            .apply_intensity_cutoff(&intensity, cutoff)
            .with_context(|| {
                format!(
                    "height map {} with --intensity {} and --cutoff {cutoff}",
                    map.display(),
                    ipath.display()
                )
            })?;
    }
    let seg = segment(&height, &params).with_context(|| format!("segmenting {}", map.display()))?;
    if let Some(w) = seg.warning {
        eprintln!("warning: {}: {w}; the flake table is empty", map.display());
    }
    Ok((height, seg))
}

/// Writes the flake table (header [`COLUMNS`]); `file` names the destination in errors.
pub fn write_table(w: impl Write, file: &str, flakes: &[SegmentedFlake]) -> anyhow::Result<()> {
    let fail =
        |e: &dyn std::fmt::Display| anyhow::Error::new(Failure(format!("writing {file}: {e}")));
    let mut w = csv::Writer::from_writer(w);
    w.write_record(COLUMNS).map_err(|e| fail(&e))?;
    for f in flakes {
        let row = [
            f.centre_um[0].to_string(),
            f.centre_um[1].to_string(),
            f.normal.x.to_string(),
            f.normal.y.to_string(),
            f.normal.z.to_string(),
            f.area_um2.to_string(),
            f.theta_n.to_degrees().to_string(),
            f.phi_n.to_degrees().to_string(),
            f.projected_area_um2.to_string(),
            f.equivalent_diameter_um.to_string(),
            f.rms_um.to_string(),
            f.tilt_se.to_degrees().to_string(),
            f.pixels.to_string(),
            f.inliers.to_string(),
            f.touches_border.to_string(),
            f.quality.to_string(),
        ];
        w.write_record(&row).map_err(|e| fail(&e))?;
    }
    w.flush().map_err(|e| fail(&e))
}

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
    let to_stdout = table_to_stdout(args.out.as_deref(), args.json)?;
    let (map, seg) = segment_file(&args.map, &args.segment)?;
    if let Some((w, name)) = table_writer(args.out.as_deref(), to_stdout)? {
        write_table(w, &name, &seg.flakes)?;
    }
    if args.json {
        let s = &args.segment;
        let summary = json!({
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
        });
        let mut out = std::io::stdout().lock();
        writeln!(out, "{}", serde_json::to_string_pretty(&summary)?)
            .map_err(|e| anyhow::Error::new(Failure(format!("writing stdout: {e}"))))?;
    }
    Ok(())
}
