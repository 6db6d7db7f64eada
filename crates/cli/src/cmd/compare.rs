//! `flakescatter compare`: a measured goniometric curve against a model (physics.md §7).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::chart::comparison_chart;
use flakescatter::compare::{
    IncidenceComparison, ModelPoint, compare, distribution_points, tabulated_points,
};
use flakescatter::io::curves::read_curve;
use serde_json::{Value, json};

use crate::flags::{ColourArgs, DEFAULT_WAVELENGTHS, MeasuredArgs, OrientationArgs, SpectralArgs};
use crate::output::{Dest, Kind, Plan, print, print_json, warn};
use crate::parse::{deg, deg_num, fixed};
use crate::tables::write_compared;

/// Compare a measured curve with the distribution model (or a model result file):
/// fits the model's vertical scale per incidence to the points 5°–40° from specular
/// (excluding the specular peak) and reports residuals of log10 values in the paper's
/// three regions: specular (< 5° from specular), near-specular (5°–40°), far (> 40°).
///
/// The model is evaluated at the measured angles with --aperture (--theta-i/--theta-s
/// select measured points). Without --json a table goes to stdout; --out writes one
/// CSV row per measured point.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub measured: MeasuredArgs,
    #[command(flatten)]
    pub orientation: OrientationArgs,
    #[command(flatten)]
    pub spectral: SpectralArgs,
    #[command(flatten)]
    pub colour: ColourArgs,
    /// Compare against a result CSV written by `model` or `topo` (columns theta_i_deg,
    /// theta_s_deg, aperture_deg, brdf_per_sr, relative) instead of computing the model;
    /// the model flags do not apply then and are refused.
    #[arg(long, value_name = "FILE", conflicts_with_all = [
        "hwhm", "sigma", "rms_tilt", "distribution", "orientation", "n", "clearcoat",
        "no_clearcoat", "transmission", "weighting", "flake_index", "measured_multiangle",
    ])]
    pub model: Option<PathBuf>,
    /// Write one CSV row per measured point: theta_i_deg, theta_s_deg, region, measured,
    /// model (scaled), residual_log10.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (scales, per-region residuals, inputs, version).
    #[arg(long)]
    pub json: bool,
    /// Plot measured points and model lines (log axis) to an .svg or .png file.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// A fitted paint (`fit --paint --params-out P.json`) against the BRDF table of
    /// --measured, without a fit: rms log10 residuals per incidence and region, in and
    /// out of the plane.
    #[arg(long, value_name = "P.json", conflicts_with_all = [
        "hwhm", "sigma", "rms_tilt", "distribution", "orientation", "n", "clearcoat",
        "no_clearcoat", "transmission", "weighting", "flake_index", "measured_multiangle",
        "model",
    ])]
    pub params: Option<PathBuf>,
    /// --params/--paint: aspecular range of the points compared, degrees `LO:HI`
    /// (default 2:180).
    #[arg(long, value_name = "LO:HI", allow_hyphen_values = true)]
    pub region: Option<String>,
    /// --params/--paint: leave out detectors beyond this polar angle, degrees.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub max_theta_r: Option<f64>,
    /// --params/--paint: leave out values below this BRDF, 1/sr.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub min_value: Option<f64>,
    #[command(flatten)]
    pub paint: crate::flags::PaintFlags,
}

/// Model values from a result CSV, by `(θi, θs)` in radians.
fn model_file(path: &Path, aperture_deg: f64) -> anyhow::Result<Vec<(f64, f64, ModelPoint)>> {
    let name = path.display();
    let rows = read_curve(path).with_context(|| format!("--model {name}"))?;
    let mut out = Vec::with_capacity(rows.len());
    for row in rows {
        let line = row.line;
        if let Some(phi) = row.phi_s
            && phi != 0.0
        {
            bail!(
                "--model {name}, line {line}: phi_s_deg {}: out-of-plane detectors cannot be matched to in-plane measured angles",
                phi.to_degrees()
            );
        }
        let aperture = row.aperture.to_degrees();
        if !((aperture - aperture_deg).abs() <= 1e-6) {
            bail!(
                "--model {name}, line {line}: aperture_deg {aperture} differs from --aperture {aperture_deg}; compare at the aperture the model was computed with"
            );
        }
        out.push((
            row.theta_i,
            row.theta_s,
            ModelPoint::from_row(
                row.brdf,
                row.relative,
                row.reflectance,
                aperture_deg.to_radians(),
            ),
        ));
    }
    Ok(out)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.measured.inputs(&mut plan);
    args.orientation.inputs(&mut plan);
    if let Some(m) = &args.model {
        plan.input("--model", m);
    }
    let out = plan.output("--out", args.out.as_deref(), Kind::Table);
    if args.json {
        plan.stdout("--json");
    } else if out != Some(Dest::Stdout) {
        plan.stdout("the table");
    }
    args.paint.refuse_base_without_paint("compare")?;
    if args.params.is_some() || args.paint.paint {
        if args.params.is_some() && args.paint.paint {
            bail!("--params and --paint: give the paint either as a parameter file or by flags");
        }
        if args.spectral.any() || args.colour.any() {
            bail!("--params/--paint: the spectral and colour flags do not apply to a paint");
        }
        return crate::cmd::paint::compare(&args, plan, out);
    }
    if let Some(flag) = [
        (args.region.is_some(), "--region"),
        (args.max_theta_r.is_some(), "--max-theta-r"),
        (args.min_value.is_some(), "--min-value"),
    ]
    .into_iter()
    .find_map(|(set, f)| set.then_some(f))
    {
        bail!("{flag} applies to a paint (--params or --paint)");
    }
    let plot = plan.output("--plot", args.plot.as_deref(), Kind::Plot);
    args.spectral.inputs(&mut plan);
    if args.measured.measured_multiangle.is_some() {
        return multi_angle(&args, plan, out, plot.is_some());
    }
    if args.spectral.any() || args.colour.any() {
        bail!(
            "{}: the spectral and colour flags apply to --measured-multiangle",
            args.spectral
                .first_flag()
                .unwrap_or("--illuminant/--observer")
        );
    }
    args.measured.validate()?;
    let coating = args.measured.optics.coating()?;
    let settings = args.measured.settings();
    let aperture = args.measured.optics.aperture_rad()?;
    let aperture_deg = args.measured.optics.aperture_deg();
    let kind = args.measured.measured_kind;
    if args.model.is_none() {
        args.orientation.validate()?;
    }
    plan.check()?;
    let (measured, selection) = args.measured.read()?;
    let (results, model_desc) = if let Some(path) = &args.model {
        let table = model_file(path, aperture_deg)?;
        let name = format!("--model {}", path.display());
        let lookup = |ti: f64, ts: &[f64]| tabulated_points(&table, &name, ti, ts);
        (
            compare(&measured, kind, &lookup)?,
            json!({"file": path.display().to_string()}),
        )
    } else {
        let (orientation, echo) = args.orientation.orientation()?;
        let model = |ti: f64, ts: &[f64]| {
            distribution_points(&coating, &settings, aperture, &orientation, ti, ts)
        };
        (compare(&measured, kind, &model)?, echo)
    };
    let without = without_model(&results);
    if !without.is_empty() {
        warn(&format!(
            "{} measured point(s) have a model value of zero (no light reaches the detector in the model) and are left out of the residuals: {}",
            without.len(),
            without
                .iter()
                .map(|(i, s)| format!("θi {} θs {}", deg(*i), deg(*s)))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let plot_bytes = match &plot {
        Some(Dest::File(p)) => Some((
            p.clone(),
            crate::plot::encode(p, &comparison_chart(&results, kind, &measured.file))?,
        )),
        _ => None,
    };
    if let Some(dest) = &out {
        let n: usize = results.iter().map(|c| c.points.len()).sum();
        plan.write(
            dest,
            |w| write_compared(w, &results),
            Some(format!("{n} rows")),
        )?;
    }
    if let Some((p, bytes)) = plot_bytes {
        plan.write(&Dest::File(p), |w| Ok(w.write_all(&bytes)?), None)?;
    }
    plan.finish()?;
    if args.json {
        let inputs = json!({
            "measured": measured.file,
            "measured_kind": kind.name(),
            "selection": selection,
            "model": model_desc,
            "coating": if args.model.is_some() { Value::Null } else { args.measured.optics.echo(settings.clearcoat) },
            "aperture_deg": aperture_deg,
            "clearcoat": args.model.is_none().then_some(settings.clearcoat),
        });
        print_json(&json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "compare",
            "inputs": inputs,
            "regions_deg": {"specular": "< 5 from specular", "near-specular": "5 to 40", "far": "> 40"},
            "scale_fitted_on": "near-specular points (5 to 40 degrees from specular)",
            "residual": "log10(measured) - log10(scale * model)",
            "incidences": incidences_json(&results),
            "points_without_model": without.iter().map(|(i, s)| json!({"theta_i_deg": deg_num(*i), "theta_s_deg": deg_num(*s)})).collect::<Vec<_>>(),
        }))?;
    } else if out != Some(Dest::Stdout) {
        print(&table_text(&results))?;
    }
    Ok(())
}

/// `--measured-multiangle`: the spectral distribution model's CIELAB at the measured
/// geometries against the measured colour, ΔE per geometry.
fn multi_angle(args: &Args, plan: Plan, out: Option<Dest>, plot: bool) -> anyhow::Result<()> {
    let Some(path) = &args.measured.measured_multiangle else {
        bail!("--measured-multiangle FILE is needed here");
    };
    if plot {
        bail!("--plot draws curves; it does not apply to --measured-multiangle");
    }
    args.orientation.validate()?;
    args.spectral.validate()?;
    let aperture = args.measured.optics.aperture_rad()?;
    if aperture <= 0.0 {
        bail!(
            "--aperture 0: multi-angle colour is a reflectance factor over the detector cone; give the instrument's half-angle (> 0)"
        );
    }
    let wavelengths = args
        .spectral
        .wavelengths_nm(Some(DEFAULT_WAVELENGTHS))?
        .unwrap_or_default();
    plan.check()?;
    let file = flakescatter::io::spectral::read_multiangle(path)
        .with_context(|| format!("reading --measured-multiangle {}", path.display()))?;
    let (coating, coating_echo) = args.spectral.coating(&args.measured.optics)?;
    let (orientation, orientation_echo) = args.orientation.orientation()?;
    let source = flakescatter::OrientationSource::Distribution(orientation);
    let settings = args.measured.settings();
    let c = flakescatter::spectral::compare_multi_angle(
        &file,
        &coating,
        &settings,
        flakescatter::spectral::MultiAngleSource::Distribution(&source),
        aperture,
        &wavelengths,
        args.colour.illuminant(),
        args.colour.observer(),
        &|_, _| {},
    )
    .with_context(|| format!("--measured-multiangle {}", path.display()))?;
    let inputs = json!({
        "measured_multiangle": path.display().to_string(),
        "measured_kind": match file.data { flakescatter::io::spectral::MultiAngleData::Lab(_) => "cielab", _ => "spectra" },
        "orientation": orientation_echo,
        "coating": args.measured.optics.echo(settings.clearcoat),
        "spectral": coating_echo,
        "wavelengths_nm": args.spectral.wavelengths_text(DEFAULT_WAVELENGTHS),
        "colorimetry": args.colour.echo(),
    });
    crate::spectra::comparison_outputs(plan, &c, inputs, out.as_ref(), args.json)
}

/// The measured points whose model value is zero or undefined, `(θi, θs)` radians.
fn without_model(results: &[IncidenceComparison]) -> Vec<(f64, f64)> {
    results
        .iter()
        .flat_map(|c| c.points.iter())
        .filter(|p| !p.residual.is_finite())
        .map(|p| (p.theta_i, p.theta_s))
        .collect()
}

fn incidences_json(results: &[IncidenceComparison]) -> Value {
    Value::Array(
        results
            .iter()
            .map(|c| {
                json!({
                    "theta_i_deg": deg_num(c.theta_i),
                    "scale": c.scale,
                    "regions": c.regions_json(),
                })
            })
            .collect(),
    )
}

/// The table printed on stdout (display rounding: 4 decimals of log10, 5 digits of scale).
fn table_text(results: &[IncidenceComparison]) -> String {
    let mut s =
        String::from("theta_i_deg  scale        region         points  rms_log10  mean_log10\n");
    for c in results {
        for r in &c.regions {
            let f = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |v| fixed(v, 4));
            let _ = writeln!(
                s,
                "{:<12} {:<12.5e} {:<14} {:>6}  {:>9}  {:>10}",
                deg(c.theta_i),
                c.scale,
                r.region.name(),
                r.points,
                f(r.rms_log10),
                f(r.mean_log10)
            );
        }
    }
    s
}
