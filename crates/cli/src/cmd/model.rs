//! `flakescatter model`: the distribution model (physics.md §4) over an instrument.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::chart::distribution_chart;
use flakescatter::gaussian::ConeMethod;
use flakescatter::spectral::{MultiAngleSource, multi_angle_colour, spectral_distribution_curves};
use flakescatter::{
    Coating, Instrument, OrientationSource, Settings, distribution_curves, distribution_mueller,
    distribution_rows,
};
use serde_json::{Value, json};

use crate::flags::{
    ColourArgs, DEFAULT_WAVELENGTHS, GeometryArgs, InstrumentArgs, OrientationArgs, PaintFlags,
    PolarizationArgs, SpectralArgs,
};
use crate::output::{Dest, Kind, Plan, print_json, print_json_with, warn};
use crate::tables::{
    CsvText, CurveWarnings, JsonText, TableText, TableWriter, no_extra, rows_json, units_json,
    write_curves, write_curves_with,
};

/// How detector cones are integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ConeKind {
    /// Exact integral over the cone (quadrature about the detector axis).
    Exact,
    /// The paper's constant-integrand approximation f(r) cos θ ΔΩ.
    Constant,
}

/// Reflectance of flat mirror flakes under a clear coat, from their orientation
/// distribution (paper eqs. 9–13 as corrected in docs/physics.md §4).
///
/// Writes one CSV row per incidence × detector: theta_i_deg, theta_s_deg, phi_s_deg,
/// aperture_deg, brdf_per_sr, reflectance (fraction of the beam), relative (to the same
/// detector at the specular direction). With no flags: the defaults below and a hwhm 6°
/// Gaussian. With --polarization mueller, --incident or --analyzer: what the detectors
/// read for that polarisation (exact Jones/Mueller path, SCATMECH's bases), and the
/// Mueller columns.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub instrument: InstrumentArgs,
    #[command(flatten)]
    pub source: OrientationArgs,
    #[command(flatten)]
    pub polarization: PolarizationArgs,
    /// Cone integration.
    #[arg(long, value_enum, default_value = "exact")]
    pub cone: ConeKind,
    #[command(flatten)]
    pub spectral: SpectralArgs,
    /// Multi-angle colour instead of a curve: the --geometry-set (ASTM E2194: 45°
    /// incidence, or the one --theta-i, aspecular −15°, 15°, 25°, 45°, 75°, 110°) or
    /// --aspecular angles; spectral reflectance factors (π × BRDF over the --aperture
    /// cone) at --wavelengths, CIELAB per geometry and the flop index.
    #[arg(long)]
    pub multi_angle: bool,
    #[command(flatten)]
    pub geometry: GeometryArgs,
    #[command(flatten)]
    pub colour: ColourArgs,
    /// Write the CSV here (`-` = stdout). Without --out and --json the CSV goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (inputs, units, version; the rows unless --out
    /// writes them).
    #[arg(long)]
    pub json: bool,
    /// Draw the relative curves (log axis) to this .svg or .png file, with the Gaussian
    /// p~ drawn about the specular direction as in the paper's Fig. 4.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// A fitted paint (`fit --paint --params-out P.json`): its BRDF per channel
    /// (clear coat, flakes and base; physics.md §12) at --theta-i × --theta-s or
    /// --detectors, averaged over the --aperture cone; columns theta_i_deg, theta_s_deg
    /// (in-plane), theta_r_deg, phi_r_deg, aperture_deg, `brdf_<channel>_per_sr`.
    #[arg(long, value_name = "P.json", conflicts_with_all = [
        "hwhm", "sigma", "rms_tilt", "distribution", "orientation", "n", "clearcoat",
        "transmission", "weighting", "flake_index", "multi_angle", "polarization",
        "incident", "analyzer", "cone",
    ])]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub paint: PaintFlags,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.instrument.inputs(&mut plan);
    args.source.inputs(&mut plan);
    args.spectral.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
    }
    if args.params.is_some() || args.paint.paint {
        if args.params.is_some() && args.paint.base_albedo.is_some() {
            bail!(
                "--base-albedo with --params: the paint's base is in its parameter file (physics.md §12.3)"
            );
        }
        if args.params.is_some() && args.paint.paint {
            bail!("--params and --paint: give the paint either as a parameter file or by flags");
        }
        return crate::cmd::paint::model(&args, plan, table);
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    args.source.validate()?;
    let coating = args.instrument.optics.coating()?;
    let mut settings = args.instrument.settings();
    settings.cone_method = match args.cone {
        ConeKind::Exact => ConeMethod::Exact,
        ConeKind::Constant => ConeMethod::ConstantIntegrand,
    };
    let polarimetry = args.polarization.polarimetry(settings.transmission)?;
    if let Some(rho) = args
        .spectral
        .base_albedo(args.paint.base_albedo.as_deref(), polarimetry.is_some())?
    {
        settings.base_albedo = rho;
    }
    if args.multi_angle {
        if polarimetry.is_some() {
            bail!(
                "--polarization/--incident/--analyzer do not apply to --multi-angle: its readout is for unpolarised light (--transmission s|p give a polarised beam)"
            );
        }
        return multi_angle(&args, plan, table, plot.is_some(), &settings);
    }
    if args.geometry.any() || args.colour.any() {
        bail!(
            "--geometry-set/--aspecular/--spectra-out/--illuminant/--observer apply to --multi-angle"
        );
    }
    if args.spectral.any() {
        if polarimetry.is_some() {
            bail!(
                "--polarization/--incident/--analyzer do not apply to --wavelengths: the spectral curves are for unpolarised light (or --transmission s|p)"
            );
        }
        return spectral_curves(&args, plan, table, plot.is_some(), &settings);
    }
    let instrument = args.instrument.instrument()?;
    plan.check()?;
    let (orientation, orientation_echo) = args.source.orientation()?;
    let source = OrientationSource::Distribution(orientation.clone());
    if polarimetry.is_none() && plot.is_none() {
        let run = Run {
            coating: &coating,
            instrument: &instrument,
            settings: &settings,
            source: &source,
        };
        return streamed(&args, plan, table.as_ref(), &run, &orientation_echo);
    }
    let (curves, mueller) = match &polarimetry {
        None => (
            distribution_curves(&coating, &instrument, &settings, &source)?,
            None,
        ),
        Some(p) => {
            let mu = distribution_mueller(&coating, &instrument, &settings, &source, p)?;
            (mu.detected_curves(), Some(mu))
        }
    };
    let elements = args.polarization.elements();
    let mut warnings = crate::tables::curve_warnings(&curves, false);
    if let Some(mu) = &mueller {
        warnings.extend(crate::mueller::warnings(mu));
    }
    for w in &warnings {
        warn(w);
    }
    let plot_bytes = match &plot {
        Some(Dest::File(p)) => Some((
            p.clone(),
            crate::plot::encode(p, &distribution_chart(&curves, &orientation))?,
        )),
        _ => None,
    };
    if let Some(dest) = &table {
        let rows = curves.rows.len();
        plan.write(
            dest,
            |w| match &mueller {
                None => write_curves(w, &curves, false),
                Some(mu) => {
                    write_curves_with(w, &curves, false, &crate::mueller::header(elements), |k| {
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
    if args.json {
        let mut summary = summary(&args, &orientation_echo, curves.model, &warnings);
        if let Some(p) = &polarimetry {
            summary["inputs"]["polarimetry"] = args.polarization.echo(p);
            summary["polarimetry"] = json!({
                "convention": crate::mueller::CONVENTION,
                "units": crate::mueller::units(elements),
            });
        }
        if table.is_none() {
            if let Some(mu) = &mueller {
                let mut rows = rows_json(&curves);
                crate::mueller::add_to_rows(&mut rows, mu, elements);
                summary["rows"] = rows;
            } else {
                // Streamed in its place among the keys (a large grid's rows).
                summary["rows"] = serde_json::Value::Null;
                plan.finish()?;
                return print_json_with(summary, "rows", |out, _| {
                    let mut t = TableWriter::new(out, JsonText::new(&curves.instrument));
                    t.push(&curves.rows)?;
                    Ok(t.finish()?)
                });
            }
        } else {
            summary["row_count"] = json!(curves.rows.len());
        }
        plan.finish()?;
        return print_json(&summary);
    }
    plan.finish()
}

/// The JSON summary of the curves (inputs, units, warnings, version; no rows).
fn summary(args: &Args, orientation_echo: &Value, model: &str, warnings: &[String]) -> Value {
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "model",
        "model": model,
        "inputs": {
            "instrument": args.instrument.echo(),
            "orientation": orientation_echo,
            "cone": match args.cone { ConeKind::Exact => "exact", ConeKind::Constant => "constant-integrand" },
        },
        "units": units_json(),
        "warnings": warnings,
        "out": args.out.as_ref().map(|p| p.display().to_string()),
        "plot": args.plot.as_ref().map(|p| p.display().to_string()),
    })
}

/// What the distribution model is run on.
struct Run<'a> {
    coating: &'a Coating,
    instrument: &'a Instrument,
    settings: &'a Settings,
    source: &'a OrientationSource,
}

impl Run<'_> {
    /// Writes the table of `text` to `out` as the rows are computed, one incidence at a
    /// time; their warnings are printed as they are found and kept in `warnings`.
    fn write(
        &self,
        out: &mut dyn Write,
        text: impl TableText,
        warnings: &mut CurveWarnings,
    ) -> anyhow::Result<()> {
        let mut table = TableWriter::new(out, text);
        distribution_rows(
            self.coating,
            self.instrument,
            self.settings,
            self.source,
            |rows| {
                for w in warnings.check(rows) {
                    warn(w);
                }
                Ok::<(), anyhow::Error>(table.push(rows)?)
            },
        )?;
        Ok(table.finish()?)
    }
}

/// The curves without a plot or Mueller columns (which need them whole): the CSV, or
/// the `--json` rows, written as they are computed, so that a large grid is never held
/// whole, as rows or as text. Same bytes as the path above.
fn streamed(
    args: &Args,
    mut plan: Plan,
    table: Option<&Dest>,
    run: &Run<'_>,
    orientation_echo: &Value,
) -> anyhow::Result<()> {
    let count = run.instrument.theta_i().len() * run.instrument.cones().len();
    let mut warnings = CurveWarnings::default();
    // `distribution_curves` names its model so.
    let model = "distribution";
    if let Some(dest) = table {
        plan.write(
            dest,
            |w| {
                let text = CsvText::new(run.instrument, false, &[], no_extra);
                run.write(w, text, &mut warnings)
            },
            Some(format!("{count} rows")),
        )?;
    }
    if !args.json {
        return plan.finish();
    }
    let mut summary = summary(args, orientation_echo, model, warnings.all());
    if table.is_some() {
        summary["row_count"] = json!(count);
        plan.finish()?;
        return print_json(&summary);
    }
    // Streamed in its place among the keys; the warnings, found on the way, come after.
    summary["rows"] = Value::Null;
    plan.finish()?;
    print_json_with(summary, "rows", |out, summary| {
        run.write(out, JsonText::new(run.instrument), &mut warnings)?;
        summary["warnings"] = json!(warnings.all());
        Ok(())
    })
}

/// `--wavelengths` without `--multi-angle`: the curves at every wavelength.
fn spectral_curves(
    args: &Args,
    mut plan: Plan,
    table: Option<Dest>,
    plot: bool,
    settings: &flakescatter::Settings,
) -> anyhow::Result<()> {
    let (wavelengths, instrument) = args.spectral.curve_run(&args.instrument, plot)?;
    plan.check()?;
    let (coating, coating_echo) = args.spectral.coating(&args.instrument.optics)?;
    let (orientation, orientation_echo) = args.source.orientation()?;
    let s = spectral_distribution_curves(
        &coating,
        &wavelengths,
        &instrument,
        settings,
        &OrientationSource::Distribution(orientation),
    )?;
    let mut warnings = Vec::new();
    crate::spectra::push_curve_warnings(&mut warnings, &s, false);
    for w in &warnings {
        warn(w);
    }
    if let Some(dest) = &table {
        let n: usize = s.curves.iter().map(|c| c.rows.len()).sum();
        plan.write(
            dest,
            |w| crate::spectra::write_spectral_curves(w, &s, false),
            Some(format!("{n} rows")),
        )?;
    }
    plan.finish()?;
    if args.json {
        let mut summary = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "model --wavelengths",
            "model": "distribution",
            "inputs": {
                "instrument": args.instrument.echo(),
                "orientation": orientation_echo,
                "spectral": coating_echo,
                "wavelengths_nm": args.spectral.wavelengths_text(""),
            },
            "units": units_json(),
            "warnings": warnings,
            "out": args.out.as_ref().map(|p| p.display().to_string()),
        });
        if args.paint.base_albedo.is_some() {
            summary["inputs"]["base_albedo"] = json!(settings.base_albedo);
        }
        if table.is_none() {
            summary["rows"] = crate::spectra::spectral_rows_json(&s);
        } else {
            summary["row_count"] = json!(s.curves.iter().map(|c| c.rows.len()).sum::<usize>());
        }
        print_json(&summary)?;
    }
    Ok(())
}

/// `--multi-angle`: CIELAB per geometry of the set, from the spectral model.
fn multi_angle(
    args: &Args,
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
    if aperture <= 0.0 {
        bail!(
            "--aperture 0: --multi-angle gives reflectance factors over the detector cone; give a half-angle > 0"
        );
    }
    let wavelengths = args
        .spectral
        .wavelengths_nm(Some(DEFAULT_WAVELENGTHS))?
        .unwrap_or_default();
    args.spectral.validate()?;
    plan.check()?;
    let (coating, coating_echo) = args.spectral.coating(&args.instrument.optics)?;
    let (orientation, orientation_echo) = args.source.orientation()?;
    let source = OrientationSource::Distribution(orientation);
    let m = multi_angle_colour(
        &coating,
        settings,
        MultiAngleSource::Distribution(&source),
        &set,
        aperture,
        &wavelengths,
        args.colour.illuminant(),
        args.colour.observer(),
        &|_, _| {},
    )
    .context("--multi-angle")?;
    let mut inputs = json!({
        "instrument": args.instrument.optics.echo(args.instrument.clearcoat),
        "orientation": orientation_echo,
        "spectral": coating_echo,
        "wavelengths_nm": args.spectral.wavelengths_text(DEFAULT_WAVELENGTHS),
        "colorimetry": args.colour.echo(),
    });
    if args.paint.base_albedo.is_some() {
        inputs["base_albedo"] = json!(settings.base_albedo);
    }
    crate::spectra::multi_angle_outputs(
        plan,
        "model --multi-angle",
        &m,
        inputs,
        table.as_ref(),
        spectra.as_ref(),
        args.json,
        args.out.as_deref(),
    )
}
