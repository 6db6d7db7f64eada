//! `flakescatter synth`: a synthetic confocal map of a flake layer with known truth, and
//! with `--stack-out` the confocal z-stack a microscope would record of it.

mod errors;
mod stack;
mod summary;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::Context;
use flakescatter::io::stack::PageOrder;
use flakescatter::io::{MapFormat, write_intensity, write_map};
use flakescatter::stack::write_synthetic_stack_with;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::synth::{
    DiameterDistribution, FlakeAmount, LayerParams, LayerSpec, SyntheticStack, generate, truth_csv,
};

use crate::output::{Kind, Plan, print_json};
use crate::parse::{pair, whole, whole_u64};
use errors::invalid;
pub use stack::{AxialKind, FirstPage, StackOutArgs};
use summary::summary;

/// Generate a synthetic layer of aluminium flakes (thin discs in a clear film) as a
/// confocal microscope would see it: a height map, an intensity map and the exact table
/// of the flakes. Heights are in µm above the substrate; intensity is 0..1 (8-bit steps).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Gaussian orientation width as the half-width at half-maximum of p̃, degrees
    /// (default 6 when neither --hwhm nor --sigma is given).
    #[arg(
        long,
        value_name = "DEG",
        conflicts_with = "sigma",
        allow_negative_numbers = true
    )]
    pub hwhm: Option<f64>,
    /// Gaussian orientation width as the sd `s` of each tilt component, degrees
    /// (`hwhm = s·sqrt(2 ln 2)`).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub sigma: Option<f64>,
    /// Map size in pixels: `N` (square) or `NX,NY`.
    #[arg(
        long,
        value_name = "N[,NY]",
        default_value = "512",
        allow_hyphen_values = true
    )]
    pub size: String,
    /// Pixel pitch in µm: `D` or `DX,DY` (default 0.18, the paper's microscope).
    #[arg(
        long,
        value_name = "DX[,DY]",
        default_value = "0.18",
        allow_hyphen_values = true
    )]
    pub pixel_um: String,
    /// Seed of every random draw; the same seed gives the same files, bit for bit.
    #[arg(long, default_value_t = 1, value_parser = whole_u64, allow_negative_numbers = true)]
    pub seed: u64,
    /// Film thickness, µm.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 38.0,
        allow_negative_numbers = true
    )]
    pub film_um: f64,
    /// Mean flake diameter, µm (log-normal, see --diameter-rel-sd).
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 16.0,
        allow_negative_numbers = true
    )]
    pub diameter_um: f64,
    /// Relative standard deviation of the diameter (sd / mean); 0 = all equal.
    #[arg(
        long,
        value_name = "X",
        default_value_t = 0.25,
        allow_negative_numbers = true
    )]
    pub diameter_rel_sd: f64,
    /// Flake thickness, µm.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub thickness_um: f64,
    /// Coverage: summed flake area per unit area of the placement region (default 1.5,
    /// about 78 % of the map shows a flake).
    #[arg(
        long,
        value_name = "X",
        conflicts_with = "count",
        allow_negative_numbers = true
    )]
    pub coverage: Option<f64>,
    /// Place exactly this many flakes instead of a coverage.
    #[arg(long, value_name = "N", value_parser = crate::parse::count_in::<1, { flakescatter::synth::MAX_FLAKES }>)]
    pub count: Option<usize>,
    /// Flake roughness rms, µm (0 = smooth).
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub roughness_um: f64,
    /// Roughness correlation length (1/e lag of a Gaussian correlation), µm.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub correlation_um: f64,
    /// Lateral resolution: sd of a Gaussian PSF blurring the heights, µm (0 = off).
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub psf_sd_um: f64,
    /// z quantisation step of the height map, µm (0 = off). With --stack-out: the distance
    /// between the stack's slices, and the map of --out is the exact surface.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.3,
        allow_negative_numbers = true
    )]
    pub z_step_um: f64,
    /// sd of Gaussian height noise added after quantisation, µm.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub height_noise_um: f64,
    /// Height map output: `.x3p` (ISO 25178-72), `.txt` (plain text) or `.zarr` (a Zarr
    /// v3 store, a directory).
    #[arg(long, value_name = "MAP")]
    pub out: Option<PathBuf>,
    /// Intensity map output: `.x3p`, `.txt` or `.zarr` (a second store, holding the
    /// `intensity` array alone).
    #[arg(long, value_name = "FILE")]
    pub intensity_out: Option<PathBuf>,
    /// Truth table (CSV, `-` = stdout): `id, x_um, y_um, nx, ny, nz, area_um2 (visible true
    /// area), theta_n_deg, phi_n_deg, z_um, depth_um, diameter_um, true_area_um2,
    /// visible_pixels, visible_projected_area_um2`, one row per visible flake.
    #[arg(long, value_name = "FILE")]
    pub truth_out: Option<PathBuf>,
    #[command(flatten)]
    pub stack: StackOutArgs,
    /// Print a JSON summary (inputs, counts, suggested intensity cutoff) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Writes a map output through the output layer (X3P, text for `.txt`, a Zarr v3
/// store for `.zarr`).
fn write_out(
    plan: &mut Plan,
    flag: &str,
    map: &HeightMap,
    path: &Path,
    intensity: bool,
) -> anyhow::Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let format = match ext.as_deref() {
        Some("txt") => MapFormat::Text,
        Some("zarr") => MapFormat::Zarr,
        _ => MapFormat::X3p,
    };
    let detail = format!("{} x {}", map.nx(), map.ny());
    plan.write_map_output(
        flag,
        path,
        "synth",
        |tmp| {
            if intensity {
                write_intensity(map, tmp, format)?;
            } else {
                write_map(map, tmp, format)?;
            }
            Ok(())
        },
        Some(detail),
    )
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    plan.map_output("--out", args.out.as_deref(), Kind::Map, "synth");
    plan.map_output(
        "--intensity-out",
        args.intensity_out.as_deref(),
        Kind::Map,
        "synth",
    );
    let truth_out = plan.output("--truth-out", args.truth_out.as_deref(), Kind::Table);
    plan.output("--stack-out", args.stack.stack_out.as_deref(), Kind::Stack);
    if args.json {
        plan.stdout("--json");
    }
    let (width, flag) = match (args.hwhm, args.sigma) {
        (_, Some(s)) => (
            GaussianWidth::Sigma(crate::flags::width("--sigma", s)?),
            "--sigma",
        ),
        (Some(h), None) => (
            GaussianWidth::Hwhm(crate::flags::width("--hwhm", h)?),
            "--hwhm",
        ),
        (None, None) => (GaussianWidth::Hwhm(6f64.to_radians()), "--hwhm"),
    };
    let orientation = Orientation::gaussian(width).context(flag)?;
    let (nx, ny) = pair("--size", &args.size, "a whole number of pixels", |p| {
        whole(p).ok()
    })?;
    let (dx, dy) = pair("--pixel-um", &args.pixel_um, "a number (µm)", |p| {
        p.parse::<f64>().ok()
    })?;

    let mut spec = LayerSpec::new(nx, ny, orientation, args.seed);
    spec.dx_um = dx;
    spec.dy_um = dy;
    spec.film_um = args.film_um;
    spec.diameter = DiameterDistribution::LogNormal {
        mean_um: args.diameter_um,
        rel_sd: args.diameter_rel_sd,
    };
    spec.thickness_um = args.thickness_um;
    spec.amount = match (args.count, args.coverage) {
        (Some(n), _) => FlakeAmount::Count(n),
        (None, Some(c)) => FlakeAmount::Coverage(c),
        (None, None) => FlakeAmount::Coverage(1.5),
    };
    spec.roughness.rms_um = args.roughness_um;
    spec.roughness.correlation_um = args.correlation_um;
    spec.confocal.psf_sd_um = args.psf_sd_um;
    args.stack.validate(args.z_step_um, args.height_noise_um)?;
    let with_stack = args.stack.stack_out.is_some();
    // A stack samples z itself: its layer keeps exact heights.
    spec.confocal.z_step_um = if with_stack { 0.0 } else { args.z_step_um };
    spec.confocal.noise_sd_um = args.height_noise_um;
    let params = LayerParams::new(spec).map_err(|e| invalid(&e))?;
    plan.check()?;
    let layer = generate(&params).context("generating the layer")?;
    let stack = match &args.stack.stack_out {
        Some(_) => Some(
            args.stack
                .stack(args.z_step_um, args.seed, &params, &layer)?,
        ),
        None => None,
    };

    if let Some(p) = &args.out {
        write_out(&mut plan, "--out", &layer.height, p, false)?;
    }
    if let Some(p) = &args.intensity_out {
        write_out(&mut plan, "--intensity-out", &layer.intensity, p, true)?;
    }
    if let (Some(path), Some(stack)) = (&args.stack.stack_out, &stack) {
        let order = args.stack.stack_first_page.order();
        write_stack(&mut plan, path, stack, order)?;
    }
    if let Some(dest) = &truth_out {
        let text = truth_csv(&layer);
        let rows = text.lines().count().saturating_sub(1);
        plan.write(
            dest,
            |w| Ok(w.write_all(text.as_bytes())?),
            Some(format!("{rows} flakes")),
        )?;
    }
    plan.finish()?;

    if args.json {
        print_json(&summary(&args, width, &params, &layer, stack.as_ref()))?;
    }
    Ok(())
}

/// Write the synthetic z-stack to `path` through `plan` (page 0 at the end `order`
/// names), with a progress bar on a terminal for large stacks.
fn write_stack(
    plan: &mut Plan,
    path: &Path,
    stack: &SyntheticStack,
    order: PageOrder,
) -> anyhow::Result<()> {
    let (nx, ny, nz) = stack.size();
    let bar = (std::io::stderr().is_terminal() && (nx * ny * nz) as f64 > 2e7).then(|| {
        let b = indicatif::ProgressBar::new(nz as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("rendering {bar:40} {pos}/{len} slices {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let progress = |done: u64, _: u64| {
        if let Some(b) = &bar {
            b.set_position(done);
        }
    };
    plan.write_via_path(
        path,
        |tmp| Ok(write_synthetic_stack_with(tmp, stack, order, &progress)?),
        Some(format!("{nx} x {ny} x {nz} slices")),
    )?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    Ok(())
}
