//! `flakescatter topo MAP [MAP ...]`: the topographic model (physics.md §5) over one or
//! more height maps, accumulated into one result; with `--isotropic`, averaged over the
//! sample's rotation about its normal (§5.1).

mod spectral;
mod summary;

use std::path::PathBuf;

use anyhow::bail;
use flakescatter::chart::topographic_chart;
use flakescatter::inputs::MapSource;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::streaming::{isotropic_curves_streamed, topographic_curves_streamed};
use flakescatter::topo::{DEFAULT_BLOCK_UM, TopoWarning};
use flakescatter::{
    Curves, MuellerCurves, TopoSettings, isotropic_curves, topographic_curves, topographic_mueller,
};

use crate::flags::{ColourArgs, GeometryArgs, InstrumentArgs, PolarizationArgs, SpectralArgs};
use crate::maps::stream::{self, Loaded};
use crate::maps::{MapInputArgs, Repeats};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::tables::{curve_warnings, write_curves, write_curves_with};
use spectral::{multi_angle, spectral_curves};
use summary::{Outcome, Totals, report};

/// Reflectance from confocal height maps: one ray per usable pixel, reflected by the
/// local least-squares plane (paper eqs. 14–15 as corrected in docs/physics.md §5).
///
/// Writes one CSV row per incidence × detector: theta_i_deg, theta_s_deg, phi_s_deg,
/// aperture_deg, brdf_per_sr, reflectance (fraction of the beam over all pixels of all
/// maps), relative (to the same detector at the specular direction), rays (rays counted
/// in the detector) and std_err (standard error of brdf_per_sr, from the spread between
/// map tiles of --tile-um; empty when not estimable: fewer than 2 tiles, or no ray).
///
/// With --isotropic every pixel sends a ring of rays, one per azimuth of the sample
/// turned about its normal (exact, docs/physics.md §5.1): the same columns, `rays`
/// counting the pixels whose ring meets the detector; --json adds each row's
/// interpolation error estimate.
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
    #[arg(long, value_name = "K", default_value_t = 5, value_parser = crate::parse::odd_window)]
    pub window: usize,
    /// Side of the square map tiles whose spread gives std_err, µm (a few flake
    /// diameters).
    #[arg(long, value_name = "UM", default_value_t = DEFAULT_BLOCK_UM, allow_negative_numbers = true)]
    pub tile_um: f64,
    /// Average over every rotation of the sample about its normal, exactly (the
    /// goniometer's view of an isotropic sample, docs/physics.md §5.1): each pixel's
    /// ray becomes the ring of its normal at every azimuth. The result does not depend
    /// on how the map lies on its grid.
    #[arg(long)]
    pub isotropic: bool,
    /// With --isotropic: spacing of the tilt nodes on which each detector's ring
    /// response is tabulated, degrees, in (0, 0.572958] (0.01 rad); default the aperture
    /// / 128 (0.0117° for 1.5°). Smaller is slower and more exact (the JSON gives the
    /// interpolation error estimate).
    #[arg(
        long,
        value_name = "DEG",
        requires = "isotropic",
        allow_negative_numbers = true
    )]
    pub node_spacing_deg: Option<f64>,
    #[command(flatten)]
    pub instrument: InstrumentArgs,
    /// Polarisation (--polarization mueller, --incident, --analyzer): what the detectors
    /// read for that polarisation, from each ray's Mueller matrix.
    #[command(flatten)]
    pub polarization: PolarizationArgs,
    #[command(flatten)]
    pub spectral: SpectralArgs,
    /// Albedo of a Lambertian base under the flakes, in [0, 1] (default 0, a black
    /// base): with --flake-stack SPEC without --flake-core, the light the flakes transmit
    /// reaches it and comes back up through them and the coat, driven by the maps'
    /// pixel-level normals and scaled by the usable-pixel coverage (docs/physics.md §13,
    /// "The base under a map's flakes").
    #[arg(long, value_name = "RHO", allow_negative_numbers = true)]
    pub base_albedo: Option<String>,
    /// Multi-angle colour instead of a curve: the --geometry-set (ASTM E2194: 45°
    /// incidence, or the one --theta-i) or --aspecular angles; spectral reflectance
    /// factors over the --aperture cone at --wavelengths, CIELAB per geometry (with the
    /// standard error of L* from the map tiles) and the flop index.
    #[arg(long)]
    pub multi_angle: bool,
    #[command(flatten)]
    pub geometry: GeometryArgs,
    #[command(flatten)]
    pub colour: ColourArgs,
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
    flakescatter::checks::window(args.window).map_err(|e| anyhow::anyhow!("--window {e}"))?;
    flakescatter::checks::tile_um(args.tile_um).map_err(|e| anyhow::anyhow!("--tile-um {e}"))?;
    if let Some(d) = args.node_spacing_deg {
        let max = 0.01f64.to_degrees();
        if !(d.is_finite() && d > 0.0 && d.to_radians() <= 0.01) {
            bail!(
                "--node-spacing-deg {d}: expected a spacing in (0, {max:.6}] degrees (at most 0.01 rad)"
            );
        }
    }
    Ok(())
}

/// Read the maps whole and apply the intensity cutoff; errors name the file.
fn load_maps(args: &Args, sources: &[MapSource]) -> anyhow::Result<Vec<HeightMap>> {
    stream::load_whole(&args.input, sources, args.window)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.instrument.inputs(&mut plan);
    args.spectral.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    let coating = args.instrument.optics.coating()?;
    let mut settings = args.instrument.settings();
    let polarimetry = args.polarization.polarimetry(settings.transmission)?;
    if let Some(rho) = args
        .spectral
        .base_albedo(args.base_albedo.as_deref(), polarimetry.is_some())?
    {
        settings.base_albedo = rho;
    }
    if args.isotropic && polarimetry.is_some() {
        bail!(
            "--isotropic with --polarization/--incident/--analyzer: the rotation average is scalar (unpolarised, or --transmission s|p); the Mueller form is computed for the map as it lies (leave out --isotropic)"
        );
    }
    if (args.multi_angle || args.spectral.any()) && (args.isotropic || polarimetry.is_some()) {
        bail!(
            "--multi-angle and --wavelengths run the plain topographic model for unpolarised light: leave out --isotropic, --polarization, --incident and --analyzer"
        );
    }
    validate(&args)?;
    if args.instrument.optics.aperture_rad()? <= 0.0 {
        bail!(
            "--aperture 0: the topographic model counts rays into detector cones; give a half-angle > 0"
        );
    }
    args.input.load_options()?;
    let sources = args
        .input
        .sources("MAP", &args.maps, &mut plan, Repeats::Warn)?;
    if args.multi_angle {
        return multi_angle(&args, &sources, plan, table, plot.is_some(), &settings);
    }
    if args.geometry.any() || args.colour.any() {
        bail!(
            "--geometry-set/--aspecular/--spectra-out/--illuminant/--observer apply to --multi-angle"
        );
    }
    if args.spectral.any() {
        return spectral_curves(&args, &sources, plan, table, plot.is_some(), &settings);
    }
    let instrument = args.instrument.instrument()?;
    plan.check()?;
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let loaded = Loaded::open(&args.input, &sources, args.window, polarimetry.is_none())?;

    // Progress on stderr when it is a terminal and the run is long.
    let work = loaded.pixels() as f64 * instrument.theta_i().len() as f64;
    let bar = progress_bar(work);
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let run = Run {
        args: &args,
        sources: &sources,
        loaded: &loaded,
        coating: &coating,
        instrument: &instrument,
        settings: &settings,
        topo: &topo,
    };
    let (curves, result, mueller) = run.model(polarimetry.as_ref(), &progress)?;
    let infos = match &loaded {
        Loaded::Memory(maps) => summary::infos(maps),
        Loaded::Stores(_) => summary::source_infos(&loaded.sources(), &result),
    };
    let elements = args.polarization.elements();
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let warnings = run_warnings(&args, &result, &curves, mueller.as_ref());
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
            |w| match &mueller {
                None => write_curves(w, &curves, true),
                Some(mu) => {
                    write_curves_with(w, &curves, true, &crate::mueller::header(elements), |k| {
                        crate::mueller::cells(mu, k, elements)
                    })
                }
            },
            Some(format!("{rows} rows")),
        )?;
    }
    if let Some((p, bytes)) = plot_bytes {
        plan.write(&Dest::File(p), |w| Ok(w.write_all(&bytes)?), None)?;
    }
    plan.finish()?;
    if args.json {
        let outcome = Outcome {
            sources: &sources,
            maps: &infos,
            totals: &result,
            curves: &curves,
            polarimetry: polarimetry.as_ref(),
            mueller: mueller.as_ref(),
            warnings: &warnings,
        };
        print_json(&report(&args, &outcome, table.is_none()))?;
    }
    Ok(())
}

/// What the model run of a single-angle `topo` needs.
struct Run<'a> {
    args: &'a Args,
    sources: &'a [MapSource],
    loaded: &'a Loaded,
    coating: &'a flakescatter::Coating,
    instrument: &'a flakescatter::Instrument,
    settings: &'a flakescatter::Settings,
    topo: &'a TopoSettings,
}

impl Run<'_> {
    /// Runs the plain, isotropic or Mueller model over the maps in memory or streamed.
    fn model(
        &self,
        polarimetry: Option<&flakescatter::Polarimetry>,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> anyhow::Result<(Curves, Totals, Option<MuellerCurves>)> {
        let Self {
            args,
            sources,
            loaded,
            coating,
            instrument,
            settings,
            topo,
        } = *self;
        let refs = loaded.maps();
        let streams = loaded.sources();
        let fail = |e: flakescatter::PipelineError| {
            let flags = format!("--window {}, --tile-um {}", args.window, args.tile_um);
            stream::run_error(e, sources, loaded, args.input.cutoff, flags)
        };
        Ok(match (polarimetry, args.isotropic) {
            (None, true) => {
                let spacing = args.node_spacing_deg.map(f64::to_radians);
                let (c, r) = match loaded {
                    Loaded::Memory(_) => isotropic_curves(
                        coating, instrument, settings, topo, spacing, &refs, progress,
                    ),
                    Loaded::Stores(_) => isotropic_curves_streamed(
                        coating, instrument, settings, topo, spacing, &streams, progress,
                    ),
                }
                .map_err(fail)?;
                (c, Totals::Isotropic(r), None)
            }
            (None, false) => {
                let (c, r) = match loaded {
                    Loaded::Memory(_) => {
                        topographic_curves(coating, instrument, settings, topo, &refs, progress)
                    }
                    Loaded::Stores(_) => topographic_curves_streamed(
                        coating, instrument, settings, topo, &streams, progress,
                    ),
                }
                .map_err(fail)?;
                (c, Totals::Plain(r), None)
            }
            (Some(p), _) => {
                let (mu, r) =
                    topographic_mueller(coating, instrument, settings, topo, &refs, p, progress)
                        .map_err(fail)?;
                (mu.detected_curves(), Totals::Plain(r), Some(mu))
            }
        })
    }
}

/// The warnings of a single-angle run, in the order they are printed: the model's
/// (with the tile side), rows without a standard error, the Mueller elements'.
fn run_warnings(
    args: &Args,
    totals: &Totals,
    curves: &Curves,
    mueller: Option<&MuellerCurves>,
) -> Vec<String> {
    let mut warnings: Vec<String> = totals
        .warnings()
        .iter()
        .map(|w| format!("{w} (--tile-um {})", args.tile_um))
        .collect();
    // Rows without a standard error are counted unless the model already said that none
    // can be estimated.
    let all_missing = totals
        .warnings()
        .iter()
        .any(|w| matches!(w, TopoWarning::StdErrNotEstimable { .. }));
    warnings.extend(curve_warnings(curves, !all_missing));
    if let Some(mu) = mueller {
        warnings.extend(crate::mueller::warnings(mu));
    }
    warnings
}

/// A progress bar on stderr when it is a terminal and `work` (pixels × runs) is large.
fn progress_bar(work: f64) -> Option<indicatif::ProgressBar> {
    crate::output::progress::bar("tracing {bar:40} {pos}/{len} tiles {eta}", work > 2e7)
}
