//! `flakescatter topo MAP [MAP ...]`: the topographic model (physics.md §5) over one or
//! more height maps, accumulated into one result; with `--isotropic`, averaged over the
//! sample's rotation about its normal (§5.1).

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::chart::topographic_chart;
use flakescatter::spectral::{MultiAngleSource, multi_angle_colour, spectral_topographic_curves};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::topo::{DEFAULT_BLOCK_UM, IsotropicResult, TopoResult, TopoWarning};
use flakescatter::{
    Curves, TopoSettings, isotropic_curves, topographic_curves, topographic_mueller,
};
use serde_json::{Value, json};

use crate::flags::{
    ColourArgs, DEFAULT_WAVELENGTHS, GeometryArgs, InstrumentArgs, PolarizationArgs, SpectralArgs,
};
use crate::maps::{MapInputArgs, Repeats, load_all};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::tables::{curve_warnings, rows_json, units_json, write_curves, write_curves_with};
use flakescatter::inputs::MapSource;

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
    #[arg(long, value_name = "K", default_value_t = 5, value_parser = crate::parse::whole, allow_negative_numbers = true)]
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
    args.spectral.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    let coating = args.instrument.optics.coating()?;
    let settings = args.instrument.settings();
    let polarimetry = args.polarization.polarimetry(settings.transmission)?;
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
    let context = || format!("--window {}, --tile-um {}", args.window, args.tile_um);
    let (curves, result, mueller) = match (&polarimetry, args.isotropic) {
        (None, true) => {
            let spacing = args.node_spacing_deg.map(f64::to_radians);
            let (c, r) = isotropic_curves(
                &coating,
                &instrument,
                &settings,
                &topo,
                spacing,
                &refs,
                &progress,
            )
            .with_context(context)?;
            (c, Totals::Isotropic(r), None)
        }
        (None, false) => {
            let (c, r) =
                topographic_curves(&coating, &instrument, &settings, &topo, &refs, &progress)
                    .with_context(context)?;
            (c, Totals::Plain(r), None)
        }
        (Some(p), _) => {
            let (mu, r) =
                topographic_mueller(&coating, &instrument, &settings, &topo, &refs, p, &progress)
                    .with_context(context)?;
            (mu.detected_curves(), Totals::Plain(r), Some(mu))
        }
    };
    let elements = args.polarization.elements();
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut warnings: Vec<String> = result
        .warnings()
        .iter()
        .map(|w| format!("{w} (--tile-um {})", args.tile_um))
        .collect();
    // Rows without a standard error are counted unless the model already said that none
    // can be estimated.
    let all_missing = result
        .warnings()
        .iter()
        .any(|w| matches!(w, TopoWarning::StdErrNotEstimable { .. }));
    warnings.extend(curve_warnings(&curves, !all_missing));
    if let Some(mu) = &mueller {
        warnings.extend(crate::mueller::warnings(mu));
    }
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
        let mut s = summary(&args, &sources, &maps, &result, &curves);
        s["warnings"] = json!(warnings);
        if let Some(p) = &polarimetry {
            s["inputs"]["polarimetry"] = args.polarization.echo(p);
            s["polarimetry"] = json!({
                "convention": crate::mueller::CONVENTION,
                "units": crate::mueller::units(elements),
                "std_err": "1/sr, standard error of the reading brdf_per_sr from the spread between map tiles (the elements' own errors are not written)",
            });
        }
        if table.is_none() {
            let mut rows = rows_json(&curves);
            if let (Totals::Isotropic(r), Some(rows)) = (&result, rows.as_array_mut()) {
                for (row, e) in rows.iter_mut().zip(&r.interpolation_error) {
                    row["interpolation_error"] = json!(e.is_finite().then_some(*e));
                }
            }
            if let Some(mu) = &mueller {
                crate::mueller::add_to_rows(&mut rows, mu, elements);
            }
            s["rows"] = rows;
        } else {
            s["row_count"] = json!(curves.rows.len());
        }
        print_json(&s)?;
    }
    Ok(())
}

/// What the model run gives besides the curves: the plain model's or the isotropic
/// model's totals.
enum Totals {
    Plain(TopoResult),
    Isotropic(IsotropicResult),
}

impl Totals {
    fn warnings(&self) -> &[TopoWarning] {
        match self {
            Self::Plain(r) => &r.warnings,
            Self::Isotropic(r) => &r.warnings,
        }
    }

    /// The `counts` object of the JSON summary.
    fn counts(&self) -> Value {
        match self {
            Self::Plain(r) => json!({
                "maps": r.maps,
                "pixels": r.pixels,
                "usable_pixels": r.usable_pixels,
                "usable_fraction": r.usable_fraction(),
                "rays_traced": r.rays_traced,
                "rays_lost_tir": r.rays_lost_tir,
                "rays_lost_down": r.rays_lost_down,
                "tiles": r.tiles,
            }),
            Self::Isotropic(r) => json!({
                "maps": r.maps,
                "pixels": r.pixels,
                "usable_pixels": r.usable_pixels,
                "usable_fraction": r.usable_fraction(),
                "rings_traced": r.rings_traced,
                "rings_lost_tir": r.rings_lost_tir,
                "rings_lost_down": r.rings_lost_down,
                "tiles": r.tiles,
                "node_spacing_deg": r.node_spacing.to_degrees(),
                "nodes": r.nodes,
            }),
        }
    }
}

/// The largest interpolation error estimate of an isotropic run, absolute (reflectance
/// units) and relative to the row's reflectance (over rows with light).
fn interpolation_summary(r: &IsotropicResult) -> Value {
    let max = r
        .interpolation_error
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .fold(0.0, f64::max);
    let max_relative = r
        .interpolation_error
        .iter()
        .zip(&r.points)
        .filter(|(e, p)| e.is_finite() && p.reflectance > 0.0)
        .map(|(e, p)| e / p.reflectance)
        .fold(0.0, f64::max);
    json!({ "max": max, "max_relative": max_relative })
}

/// A progress bar on stderr when it is a terminal and `work` (pixels × runs) is large.
fn progress_bar(work: f64) -> Option<indicatif::ProgressBar> {
    (std::io::stderr().is_terminal() && work > 2e7).then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template("tracing {bar:40} {pos}/{len} tiles {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    })
}

/// `--wavelengths` without `--multi-angle`: the curves at every wavelength.
fn spectral_curves(
    args: &Args,
    sources: &[MapSource],
    mut plan: Plan,
    table: Option<Dest>,
    plot: bool,
    settings: &flakescatter::Settings,
) -> anyhow::Result<()> {
    let Some(wavelengths) = args.spectral.wavelengths_nm(None)? else {
        bail!(
            "{} describes the coating versus wavelength: give --wavelengths LIST (nm), e.g. 380:780:10, or --multi-angle",
            args.spectral.first_flag().unwrap_or("a spectral flag")
        );
    };
    if plot {
        bail!("--plot draws the curves of one wavelength; it does not apply to --wavelengths");
    }
    args.spectral.validate()?;
    let instrument = args.instrument.instrument()?;
    let rows = instrument.theta_i().len() as f64
        * instrument.detectors().len() as f64
        * wavelengths.len() as f64;
    if rows > crate::flags::MAX_ROWS as f64 {
        bail!(
            "--wavelengths with --theta-i and --theta-s: {rows:e} rows is more than the limit of {}",
            crate::flags::MAX_ROWS
        );
    }
    plan.check()?;
    let (coating, coating_echo) = args.spectral.coating(&args.instrument.optics)?;
    let maps = load_maps(args, sources)?;
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let runs = if coating.is_wavelength_independent() {
        1
    } else {
        wavelengths.len()
    };
    let pixels: usize = maps.iter().map(HeightMap::len).sum();
    let bar = progress_bar(pixels as f64 * instrument.theta_i().len() as f64 * runs as f64);
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let s = spectral_topographic_curves(
        &coating,
        &wavelengths,
        &instrument,
        settings,
        &topo,
        &refs,
        &progress,
    )
    .with_context(|| format!("--window {}, --tile-um {}", args.window, args.tile_um))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut warnings: Vec<String> = s.topo[0]
        .warnings
        .iter()
        .map(|w| format!("{w} (--tile-um {})", args.tile_um))
        .collect();
    let all_missing = s.topo[0]
        .warnings
        .iter()
        .any(|w| matches!(w, TopoWarning::StdErrNotEstimable { .. }));
    for (w, c) in s.wavelengths_nm.iter().zip(&s.curves) {
        for msg in curve_warnings(c, !all_missing) {
            let msg = format!("{w} nm: {msg}");
            if !warnings.contains(&msg) {
                warnings.push(msg);
            }
        }
    }
    for w in &warnings {
        warn(w);
    }
    if let Some(dest) = &table {
        let n: usize = s.curves.iter().map(|c| c.rows.len()).sum();
        plan.write(
            dest,
            |w| crate::spectra::write_spectral_curves(w, &s, true),
            Some(format!("{n} rows")),
        )?;
    }
    plan.finish()?;
    if args.json {
        let mut j = summary(
            args,
            sources,
            &maps,
            &Totals::Plain(s.topo[0].clone()),
            &s.curves[0],
        );
        j["command"] = json!("topo --wavelengths");
        j["inputs"]["spectral"] = coating_echo;
        j["inputs"]["wavelengths_nm"] = json!(args.spectral.wavelengths_text(""));
        j["warnings"] = json!(warnings);
        if table.is_none() {
            j["rows"] = crate::spectra::spectral_rows_json(&s);
        } else {
            j["row_count"] = json!(s.curves.iter().map(|c| c.rows.len()).sum::<usize>());
        }
        print_json(&j)?;
    }
    Ok(())
}

/// `--multi-angle`: CIELAB per geometry of the set, from the spectral topographic model.
fn multi_angle(
    args: &Args,
    sources: &[MapSource],
    mut plan: Plan,
    table: Option<Dest>,
    plot: bool,
    settings: &flakescatter::Settings,
) -> anyhow::Result<()> {
    if plot {
        bail!("--plot draws curves; it does not apply to --multi-angle");
    }
    if args.instrument.theta_s.is_some() || args.instrument.detectors.is_some() {
        bail!(
            "--theta-s/--detectors do not apply to --multi-angle: its detectors are the geometry set's aspecular angles"
        );
    }
    let spectra = plan.output(
        "--spectra-out",
        args.geometry.spectra_out.as_deref(),
        Kind::Table,
    );
    let set = args.geometry.set(args.instrument.theta_i.as_deref())?;
    let aperture = args.instrument.optics.aperture_rad()?;
    let wavelengths = args
        .spectral
        .wavelengths_nm(Some(DEFAULT_WAVELENGTHS))?
        .unwrap_or_default();
    args.spectral.validate()?;
    plan.check()?;
    let (coating, coating_echo) = args.spectral.coating(&args.instrument.optics)?;
    let maps = load_maps(args, sources)?;
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let runs = if coating.is_wavelength_independent() {
        1
    } else {
        wavelengths.len()
    };
    let pixels: usize = maps.iter().map(HeightMap::len).sum();
    let bar = progress_bar(pixels as f64 * set.incidences().len() as f64 * runs as f64);
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    let topo = TopoSettings {
        window: args.window,
        tile_um: args.tile_um,
    };
    let m = multi_angle_colour(
        &coating,
        settings,
        MultiAngleSource::Topographic {
            topo: &topo,
            maps: &refs,
        },
        &set,
        aperture,
        &wavelengths,
        args.colour.illuminant(),
        args.colour.observer(),
        &progress,
    )
    .with_context(|| {
        format!(
            "--multi-angle (--window {}, --tile-um {})",
            args.window, args.tile_um
        )
    })?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let inputs = json!({
        "maps": sources.iter().map(|p| p.height.display().to_string()).collect::<Vec<_>>(),
        "intensity": sources.iter().filter_map(|s| s.intensity.as_ref().map(|p| p.display().to_string())).collect::<Vec<_>>(),
        "cutoff": args.input.cutoff,
        "map_inputs": args.input.echo(sources),
        "window": args.window,
        "tile_um": args.tile_um,
        "instrument": args.instrument.optics.echo(args.instrument.clearcoat),
        "spectral": coating_echo,
        "wavelengths_nm": args.spectral.wavelengths_text(DEFAULT_WAVELENGTHS),
        "colorimetry": args.colour.echo(),
    });
    crate::spectra::multi_angle_outputs(
        plan,
        "topo --multi-angle",
        &m,
        inputs,
        table.as_ref(),
        spectra.as_ref(),
        args.json,
        args.out.as_deref(),
    )
}

/// The `--json` summary (without the rows).
fn summary(
    args: &Args,
    sources: &[MapSource],
    maps: &[HeightMap],
    r: &Totals,
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
    let mut s = json!({
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
            "isotropic": args.isotropic,
            "node_spacing_deg": args.node_spacing_deg,
            "instrument": args.instrument.echo(),
        },
        "counts": r.counts(),
        "warnings": r.warnings().iter().map(ToString::to_string).collect::<Vec<_>>(),
        "units": {
            "columns": units_json(),
            "rays": "number of rays counted in the detector",
            "std_err": "1/sr, standard error of brdf_per_sr from the spread between map tiles; null (empty in the CSV) when not estimable: fewer than 2 tiles, or no ray in the detector",
            "reflectance_normalisation": "fraction of the incident beam over all pixels of all maps (invalid pixels are black substrate)",
        },
        "out": args.out.as_ref().map(|p| p.display().to_string()),
        "plot": args.plot.as_ref().map(|p| p.display().to_string()),
    });
    if let Totals::Isotropic(iso) = r {
        s["interpolation_error"] = interpolation_summary(iso);
        let units = &mut s["units"];
        units["rays"] = json!(
            "number of usable pixels whose ring of exit directions (every azimuth of the sample) meets the detector"
        );
        units["interpolation_error"] = json!(
            "fraction of the incident beam (reflectance units): estimated error of the row's reflectance from tabulating each ring response on tilt nodes (docs/physics.md §5.1); interpolation_error.max is the largest over the rows, max_relative the largest relative to the row's reflectance"
        );
        units["node_spacing_deg"] =
            json!("degree, spacing of the tilt nodes of the ring-response table");
        units["rings"] = json!(
            "rings_traced: usable pixels x incidences; rings_lost_tir / rings_lost_down: summed azimuth fractions of the rings totally internally reflected / heading down (rays' worth)"
        );
    }
    s
}
