//! `flakescatter synth`: a synthetic confocal map of a flake layer with known truth.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::io::{MapFormat, write_intensity, write_map};
use flakescatter::stats::distribution::MIN_GAUSSIAN_WIDTH;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::synth::{
    DiameterDistribution, FlakeAmount, LayerParams, LayerSpec, Param, SynthError, generate,
    truth_csv,
};

use crate::common::Failure;

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
    #[arg(long, value_name = "N[,NY]", default_value = "512")]
    pub size: String,
    /// Pixel pitch in µm: `D` or `DX,DY` (default 0.18, the paper's microscope).
    #[arg(long, value_name = "DX[,DY]", default_value = "0.18")]
    pub pixel_um: String,
    /// Seed of every random draw; the same seed gives the same files, bit for bit.
    #[arg(long, default_value_t = 1)]
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
    #[arg(long, value_name = "N")]
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
    /// z quantisation step, µm (0 = off).
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
    /// Height map output: X3P, or plain text when the name ends in `.txt`.
    #[arg(long, value_name = "MAP")]
    pub out: Option<PathBuf>,
    /// Intensity map output (X3P, or plain text for `.txt`).
    #[arg(long, value_name = "FILE")]
    pub intensity_out: Option<PathBuf>,
    /// Truth table (CSV, `-` = stdout): `id, x_um, y_um, nx, ny, nz, area_um2 (visible true
    /// area), theta_n_deg, phi_n_deg, z_um, depth_um, diameter_um, true_area_um2,
    /// visible_pixels, visible_projected_area_um2`, one row per visible flake.
    #[arg(long, value_name = "FILE")]
    pub truth_out: Option<PathBuf>,
    /// Print a JSON summary (inputs, counts, suggested intensity cutoff) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Parses `A` or `A,B` into a pair (`A,A` for a single value).
fn pair<T: std::str::FromStr + Copy>(s: &str, flag: &str) -> anyhow::Result<(T, T)> {
    let parse = |p: &str| {
        p.trim()
            .parse::<T>()
            .ok()
            .with_context(|| format!("{flag} {s}: `{p}` is not a valid number"))
    };
    match s.split(',').collect::<Vec<_>>().as_slice() {
        [a] => {
            let a = parse(a)?;
            Ok((a, a))
        }
        [a, b] => Ok((parse(a)?, parse(b)?)),
        _ => bail!("{flag} {s}: expected one value or two separated by a comma"),
    }
}

fn write_out(map: &HeightMap, path: &Path, flag: &str, intensity: bool) -> anyhow::Result<()> {
    let is_txt = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("txt"));
    let format = if is_txt {
        MapFormat::Text
    } else {
        MapFormat::X3p
    };
    let written = if intensity {
        write_intensity(map, path, format)
    } else {
        write_map(map, path, format)
    };
    written.map_err(|e| anyhow::Error::new(Failure(format!("{flag}: {e}"))))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let width = match (args.hwhm, args.sigma) {
        (_, Some(s)) => GaussianWidth::Sigma(s.to_radians()),
        (Some(h), None) => GaussianWidth::Hwhm(h.to_radians()),
        (None, None) => GaussianWidth::Hwhm(6f64.to_radians()),
    };
    let flag = if args.sigma.is_some() {
        "--sigma"
    } else {
        "--hwhm"
    };
    let given = args.sigma.or(args.hwhm).unwrap_or(6.0);
    let Ok(orientation) = Orientation::gaussian(width) else {
        bail!(
            "{flag} {given}: the width must be at least {:.1e} and below 90 degrees",
            MIN_GAUSSIAN_WIDTH.to_degrees()
        );
    };
    let (nx, ny) = pair::<usize>(&args.size, "--size")?;
    let (dx, dy) = pair::<f64>(&args.pixel_um, "--pixel-um")?;
    let truth_to_stdout = args
        .truth_out
        .as_ref()
        .is_some_and(|p| p.as_os_str() == "-");
    if truth_to_stdout && args.json {
        bail!("--truth-out - and --json both write to stdout: give --truth-out a file name");
    }

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
    spec.confocal.z_step_um = args.z_step_um;
    spec.confocal.noise_sd_um = args.height_noise_um;
    let params = LayerParams::new(spec).map_err(|e| invalid(&e))?;
    let layer = generate(&params).context("generating the layer")?;

    if let Some(p) = &args.out {
        write_out(&layer.height, p, "--out", false)?;
    }
    if let Some(p) = &args.intensity_out {
        write_out(&layer.intensity, p, "--intensity-out", true)?;
    }
    if let Some(p) = &args.truth_out {
        let text = truth_csv(&layer);
        if truth_to_stdout {
            std::io::stdout()
                .lock()
                .write_all(text.as_bytes())
                .map_err(|e| anyhow::Error::new(Failure(format!("writing stdout: {e}"))))?;
        } else {
            std::fs::write(p, text).map_err(|e| {
                anyhow::Error::new(Failure(format!(
                    "cannot write --truth-out {}: {e}",
                    p.display()
                )))
            })?;
        }
    }

    if args.json {
        let s = params.spec();
        let show = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
        let summary = serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "input": {
                "orientation": "gaussian",
                // Echo the value given exactly; derive the other one.
                "hwhm_deg": args.sigma.map_or(args.hwhm.unwrap_or(6.0), |_| width.hwhm().to_degrees()),
                "sigma_deg": args.sigma.unwrap_or(width.sigma().to_degrees()),
                "nx": s.nx,
                "ny": s.ny,
                "dx_um": s.dx_um,
                "dy_um": s.dy_um,
                "seed": s.seed,
                "film_um": s.film_um,
                "diameter_mean_um": args.diameter_um,
                "diameter_rel_sd": args.diameter_rel_sd,
                "diameter_distribution": "log-normal, clipped to [mean/4, 3 mean]",
                "thickness_um": s.thickness_um,
                "coverage": args.count.is_none().then_some(args.coverage.unwrap_or(1.5)),
                "count": args.count,
                "roughness_rms_um": s.roughness.rms_um,
                "roughness_correlation_um": s.roughness.correlation_um,
                "psf_sd_um": s.confocal.psf_sd_um,
                "z_step_um": s.confocal.z_step_um,
                "height_noise_sd_um": s.confocal.noise_sd_um,
                "intensity_flake": s.intensity.flake,
                "intensity_background": s.intensity.background,
                "intensity_noise_sd": s.intensity.noise_sd,
            },
            "width_um": s.nx as f64 * s.dx_um,
            "height_um": s.ny as f64 * s.dy_um,
            "flakes_placed": layer.truth.len(),
            "flakes_visible": layer.visible_flakes().count(),
            "flakes_redrawn_to_fit_the_film": layer.redrawn_flakes,
            "covered_fraction": layer.covered_fraction(),
            "suggested_cutoff": s.intensity.midpoint(),
            "height_file": show(&args.out),
            "intensity_file": show(&args.intensity_out),
            "truth_file": show(&args.truth_out),
        });
        let mut out = std::io::stdout().lock();
        writeln!(out, "{}", serde_json::to_string_pretty(&summary)?)
            .map_err(|e| anyhow::Error::new(Failure(format!("writing stdout: {e}"))))?;
    }
    Ok(())
}

/// The flag a library parameter comes from, if it has one.
fn flag(param: Param) -> Option<&'static str> {
    Some(match param {
        Param::DxUm | Param::DyUm => "--pixel-um",
        Param::FilmUm => "--film-um",
        Param::ThicknessUm => "--thickness-um",
        Param::DiameterMeanUm => "--diameter-um",
        Param::DiameterRelSd => "--diameter-rel-sd",
        Param::Coverage => "--coverage",
        Param::Count => "--count",
        Param::RoughnessRmsUm => "--roughness-um",
        Param::RoughnessCorrelationUm => "--correlation-um",
        Param::PsfSdUm => "--psf-sd-um",
        Param::ZStepUm => "--z-step-um",
        Param::HeightNoiseSdUm => "--height-noise-um",
        _ => return None,
    })
}

/// A refused specification, in the flags and units the user typed (µm for lengths).
fn invalid(e: &SynthError) -> anyhow::Error {
    match *e {
        SynthError::InvalidParameter {
            param,
            value,
            expected,
        } => match flag(param) {
            Some(f) => anyhow::anyhow!("{f} {value}: expected {expected}"),
            None => anyhow::anyhow!("invalid synth parameters (see --help): {e}"),
        },
        SynthError::FilmThinnerThanFlakes {
            film_um,
            thickness_um,
        } => anyhow::anyhow!(
            "--film-um {film_um}: the film is thinner than the flakes (--thickness-um {thickness_um}); every flake must lie inside the film"
        ),
        SynthError::FlakesDoNotFit {
            film_um,
            diameter_um,
            max_diameter_um,
            thickness_um,
            fraction,
        } => anyhow::anyhow!(
            "--film-um {film_um}: flakes of --diameter-um {diameter_um} (up to {max_diameter_um} um) and --thickness-um {thickness_um} do not fit: {:.2} % of them are tilted too far to lie inside the film (at most {:.1} % may be drawn again); use a thicker --film-um, a smaller --diameter-um or a narrower --hwhm",
            100.0 * fraction,
            100.0 * flakescatter::synth::MAX_REDRAWN_FRACTION
        ),
        _ => anyhow::anyhow!("invalid synth parameters (see --help): {e}"),
    }
}
