//! `flakescatter volume`: the three-dimensional flake layer with multiple scattering
//! (physics.md §10, issue 20), composed by [`flakescatter::volume_curves`]; this command
//! parses and checks the flags, shows progress, and writes the curves, the energy
//! balance and what the layer realised; at several wavelengths through
//! [`flakescatter::spectral_volume_curves`] (module `spectrum`).

mod rows;
mod settings;
mod spectrum;
mod summary;
mod waves;

use std::path::PathBuf;

use anyhow::bail;
use flakescatter::chart::volume_chart;
use flakescatter::{Coating, Instrument, OrientationSource, VolumeSettings, volume_curves};
use serde_json::json;

use crate::flags::{InstrumentArgs, OrientationArgs, constant_alpha};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use rows::{rows_json, volume_warnings, write_volume};
use settings::explain;
use summary::summary;
use waves::{Binder, Waves};

/// What a flake's rim does to a ray (physics.md §10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Rims {
    /// Absorbs (broken edges are not mirrors; the share is reported).
    Absorb,
    /// Transparent: the ray passes through the flake.
    Ignore,
    /// Reflects diffusely (cosine law) with the flake's normal-incidence reflectance.
    Diffuse,
}

/// How a substrate of `--substrate-reflectance R > 0` reflects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SubstrateKind {
    /// Cosine law (a diffuse primer); depolarises.
    Lambertian,
    /// A mirror (a polished panel).
    Mirror,
}

/// Multiple scattering in a three-dimensional flake layer: thin circular flakes placed
/// without overlap in a film under a smooth top interface, every ray followed until it
/// escapes or is absorbed (docs/physics.md §10).
///
/// Writes one CSV row per incidence × detector: theta_i_deg, theta_s_deg, phi_s_deg,
/// aperture_deg, brdf_per_sr, reflectance, relative (as `model`), rays (escapes counted
/// in the detector), std_err_per_sr, and the split coat_brdf_per_sr (first surface),
/// single_bounce_brdf_per_sr (one flake reflection) and multiple_bounce_brdf_per_sr
/// (everything else), with standard errors; then ray_std_err_per_sr,
/// layer_std_err_per_sr (the two parts of std_err_per_sr) and ci95_per_sr (half-width of
/// the 95 % interval). With --wavelengths (or a stack without --wavelength) a first
/// column wavelength_nm, the rows of every wavelength, traced through the same layers with
/// the same rays. The values are means over --layers independent layers. The
/// defaults are the paper's coating: 38 µm film, 16 µm flakes (relative sd 0.25), 1 µm
/// thick, 5 % aluminium by mass.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Film thickness, µm (the flakes lie wholly inside it).
    #[arg(
        long = "film-um",
        value_name = "UM",
        default_value_t = 38.0,
        allow_negative_numbers = true
    )]
    pub film_um: f64,
    /// Film (binder) refractive index (real, >= 1).
    #[arg(
        long = "n",
        value_name = "X",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub n: f64,
    /// Complex flake index `N,K` (e.g. `0.96,6.69` for aluminium at 550 nm); default a
    /// perfect conductor.
    #[arg(long, value_name = "N,K", allow_hyphen_values = true)]
    pub flake_index: Option<String>,
    /// Interference flakes: each flake a thin-film stack, layers from the side light
    /// arrives on, `material:thickness_nm` separated by `/` (e.g.
    /// `TiO2:120/mica:400/TiO2:120`; materials as in `film`), in the binder (--n) on both
    /// sides; the light it transmits goes on through the flake (physics.md §10, §13).
    /// Runs at --wavelength, or at --wavelengths [default 380:780:10].
    #[arg(
        long,
        value_name = "SPEC",
        allow_hyphen_values = true,
        conflicts_with = "flake_index"
    )]
    pub flake_stack: Option<String>,
    /// With --flake-stack: an opaque core under the layers (e.g. aluminium), a material
    /// name or `n+ki`; it absorbs what the layers transmit. Default: a free flake.
    #[arg(
        long,
        value_name = "MATERIAL",
        allow_hyphen_values = true,
        requires = "flake_stack"
    )]
    pub flake_core: Option<String>,
    /// With --flake-stack or a --binder-absorption table: the one vacuum wavelength of
    /// the run, nm (the CSV and JSON as without it).
    #[arg(
        long,
        value_name = "NM",
        allow_negative_numbers = true,
        conflicts_with = "wavelengths"
    )]
    pub wavelength: Option<f64>,
    /// With --flake-stack or --binder-absorption: the run's wavelengths in nm, a list or
    /// an inclusive range `start:stop:step` (e.g. `400:700:20`); the same layers and rays
    /// at each (one seed), a `wavelength_nm` column first [default with --flake-stack
    /// and no --wavelength: 380:780:10].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub wavelengths: Option<String>,
    /// A tinted binder: its absorption coefficient in 1/µm (Napierian, for intensity,
    /// e.g. 0.05), or a CSV `wavelength_nm,alpha_per_um` (needs --wavelength or
    /// --wavelengths); applied along every path inside the film, its share reported as
    /// absorbed_binder (physics.md §10).
    #[arg(long, value_name = "ALPHA|FILE", allow_negative_numbers = true)]
    pub binder_absorption: Option<PathBuf>,
    /// Mean flake diameter, µm.
    #[arg(
        long = "diameter-um",
        value_name = "UM",
        default_value_t = 16.0,
        allow_negative_numbers = true
    )]
    pub diameter_um: f64,
    /// Relative standard deviation of the log-normal diameters, in [0, 1] (0 = all
    /// equal; truncated to [mean/4, 3 mean]).
    #[arg(
        long = "diameter-rel-sd",
        value_name = "X",
        default_value_t = 0.25,
        allow_negative_numbers = true
    )]
    pub diameter_rel_sd: f64,
    /// Flake thickness, µm.
    #[arg(
        long = "thickness-um",
        value_name = "UM",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub thickness_um: f64,
    /// Flake volume per film volume, in [0, 1) [default: --mass-loading 0.05].
    #[arg(
        long,
        value_name = "X",
        conflicts_with = "mass_loading",
        allow_negative_numbers = true
    )]
    pub volume_fraction: Option<f64>,
    /// Mass fraction of aluminium (2.70 g/cm³) in the dry film, in [0, 1) [default:
    /// 0.05, the paper's loading].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub mass_loading: Option<f64>,
    /// Density of the dry binder, g/cm³, for --mass-loading [default: 1.2].
    #[arg(long, value_name = "G_CM3", allow_negative_numbers = true)]
    pub binder_density: Option<f64>,
    /// Flake centres uniform between depths A and B (µm below the top interface,
    /// 0 <= A <= B <= --film-um), each restricted so that the flake lies in the film
    /// [default: the whole film].
    #[arg(long = "depth-um", value_name = "A:B", allow_hyphen_values = true)]
    pub depth_um: Option<String>,
    #[command(flatten)]
    pub source: OrientationArgs,
    /// Incidence angles in degrees, in [0, 90): a list `0,30,60`, an inclusive range
    /// `start:stop:step`, or both [default: 0,30,45,60,75].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_i: Option<String>,
    /// Signed in-plane detector angles in degrees, in (-90, 90); `theta_s = -theta_i`
    /// is specular [default: -70:70:0.5].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_s: Option<String>,
    /// Out-of-plane detectors: CSV with header `theta_r_deg,phi_r_deg`; replaces
    /// --theta-s.
    #[arg(long, value_name = "FILE", conflicts_with = "theta_s")]
    pub detectors: Option<PathBuf>,
    /// Detector cone half-angle in degrees, in (0, 20] (rays are counted into cones).
    #[arg(
        long,
        value_name = "A",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub aperture: f64,
    /// Rays per incidence in all, 1 to 2^40 = 1099511627776, shared among the --layers
    /// (each layer gets rays/layers, rounded up to a multiple of 64, the batches of its
    /// ray errors).
    #[arg(long, value_name = "N", default_value_t = 1_000_000, value_parser = crate::parse::whole_in::<1, { settings::MAX_RAYS }>)]
    pub rays: u64,
    /// Independent layers drawn from the seed, 1 to 10000: the curves are their mean,
    /// std_err its standard error over layers (rays and layers; with 1 layer the rays
    /// only), split into ray_std_err and layer_std_err, with a Student's t 95 %
    /// interval.
    #[arg(long, value_name = "K", default_value_t = flakescatter::volume::DEFAULT_LAYERS, value_parser = layers_arg, allow_negative_numbers = true)]
    pub layers: u32,
    /// Seed of the layer and of the rays (separate streams); a run is reproducible
    /// from it alone, for any number of threads.
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = crate::parse::whole_u64, allow_negative_numbers = true)]
    pub seed: u64,
    /// Side of the periodic square tile, µm (larger than the largest flake).
    #[arg(
        long = "tile-um",
        value_name = "UM",
        default_value_t = 1000.0,
        allow_negative_numbers = true
    )]
    pub tile_um: f64,
    /// Reflectance of the substrate under the film, in [0, 1] (0 = black, the default).
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub substrate_reflectance: f64,
    /// How a reflecting substrate reflects (with --substrate-reflectance > 0).
    #[arg(long, value_enum, value_name = "K", default_value = "lambertian")]
    pub substrate: SubstrateKind,
    /// What flake rims do to a ray.
    #[arg(long, value_enum, value_name = "RULE", default_value = "absorb")]
    pub rims: Rims,
    /// Write the CSV here (`-` = stdout). Without --out and --json the CSV goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (inputs, energy balance, realised layer, units,
    /// version; the rows unless --out writes them).
    #[arg(long)]
    pub json: bool,
    /// Draw the relative curves and their multiple-scattering part (log axis) to this
    /// .svg or .png file.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

/// Everything a run needs once the flags are checked.
pub(super) struct Ready {
    pub(super) instrument_args: InstrumentArgs,
    /// Where the CSV goes (`None`: into the JSON).
    pub(super) table: Option<Dest>,
    pub(super) coating: Coating,
    pub(super) settings: VolumeSettings,
    pub(super) instrument: Instrument,
    pub(super) source: OrientationSource,
    pub(super) orientation_echo: serde_json::Value,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    let instrument_args = args.instrument_args();
    instrument_args.inputs(&mut plan);
    args.source.inputs(&mut plan);
    if let Some(p) = &args.binder_absorption
        && constant_alpha(p).is_none()
    {
        plan.input("--binder-absorption", p);
    }
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    args.source.validate()?;
    let binder = args.binder()?;
    let waves = args.waves(binder.as_ref())?;
    let mut coating = instrument_args.optics.coating()?;
    if let Waves::Many { .. } = waves {
        if plot.is_some() {
            bail!("--plot draws the curves of one wavelength; it does not apply to --wavelengths");
        }
    } else if let Some(flake) = args.stack_flake()? {
        coating.flake = flake;
    }
    if instrument_args.optics.aperture_rad()? <= 0.0 {
        bail!(
            "--aperture 0: the volume model counts rays into detector cones; give a half-angle > 0"
        );
    }
    let mut settings = args.settings()?;
    if let (Some(b), Waves::One(_) | Waves::None) = (&binder, &waves) {
        settings.binder_alpha_per_um = args.alpha_at(b, waves.one())?;
    }
    let instrument = instrument_args.instrument()?;
    if let Waves::Many { nm, .. } = &waves {
        spectrum::check_rows(&instrument, nm.len())?;
    }
    plan.check()?;
    let (orientation, orientation_echo) = args.source.orientation()?;
    let ready = Ready {
        instrument_args,
        table,
        coating,
        settings,
        instrument,
        source: OrientationSource::Distribution(orientation),
        orientation_echo,
    };
    match &waves {
        Waves::Many { nm, text } => {
            spectrum::run_many(&args, ready, plan, binder.as_ref(), nm, text)
        }
        _ => run_one(&args, ready, plan, plot, binder.as_ref()),
    }
}

/// A run at one wavelength (or none): the curves, the plot, the JSON.
fn run_one(
    args: &Args,
    ready: Ready,
    mut plan: Plan,
    plot: Option<Dest>,
    binder: Option<&Binder>,
) -> anyhow::Result<()> {
    let Ready {
        instrument_args,
        table,
        coating,
        settings,
        instrument,
        source,
        orientation_echo,
    } = ready;
    // Progress on stderr when it is a terminal and the run is long.
    let rays_total = settings.rays as f64 * instrument.theta_i().len() as f64;
    let bar = crate::output::progress::bar(
        "tracing {bar:40} {pos}/{len} chunks of rays {eta}",
        rays_total > 2e6,
    );
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let curves = volume_curves(&coating, &instrument, &settings, &source, &progress)
        .map_err(|e| explain(e, args))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let warnings = volume_warnings(&curves);
    for w in &warnings {
        warn(w);
    }
    let plot_bytes = match &plot {
        Some(Dest::File(p)) => Some((p.clone(), crate::plot::encode(p, &volume_chart(&curves))?)),
        _ => None,
    };
    if let Some(dest) = &table {
        let rows = curves.rows.len();
        plan.write(
            dest,
            |w| write_volume(w, &curves),
            Some(format!("{rows} rows")),
        )?;
    }
    if let Some((p, bytes)) = plot_bytes {
        plan.write(&Dest::File(p), |w| Ok(w.write_all(&bytes)?), None)?;
    }
    plan.finish()?;
    if args.json {
        let mut s = summary(args, &instrument_args, &curves, orientation_echo);
        s["warnings"] = json!(warnings);
        if let Some(stack) = &args.flake_stack {
            s["inputs"]["flake_index"] = serde_json::Value::Null;
            s["inputs"]["flake_stack"] = json!(stack);
            s["inputs"]["flake_core"] = json!(args.flake_core);
            s["inputs"]["wavelength_nm"] = json!(args.wavelength);
        }
        if let Some(b) = binder {
            s["inputs"]["wavelength_nm"] = json!(args.wavelength);
            s["inputs"]["binder_absorption"] = b.echo.clone();
            s["binder_alpha_per_um"] = json!(settings.binder_alpha_per_um);
        }
        if table.is_none() {
            s["rows"] = rows_json(&curves);
        } else {
            s["row_count"] = json!(curves.rows.len());
        }
        print_json(&s)?;
    }
    Ok(())
}

/// `--layers K`: a whole number from 1 to [`flakescatter::volume::MAX_LAYERS`], with one
/// message for every value outside (0, −1, 2.5, 1e20).
fn layers_arg(s: &str) -> Result<u32, String> {
    let max = flakescatter::volume::MAX_LAYERS;
    s.trim()
        .parse::<u32>()
        .ok()
        .filter(|k| (1..=max).contains(k))
        .ok_or_else(|| format!("expected a whole number of layers from 1 to {max}"))
}
