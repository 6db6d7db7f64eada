//! `flakescatter compare`: a measured goniometric curve against a model (physics.md §7).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::compare::{
    IncidenceComparison, MeasuredKind, ModelPoint, compare, distribution_points,
};
use flakescatter::io::curves::read_curve;
use flakescatter::io::measured::{MeasuredCurve, read_measured};
use flakescatter::{Coating, PipelineError, Settings};
use serde_json::{Value, json};

use crate::cmd::model::{OrientationArgs, orientation_from};
use crate::instrument::{InstrumentArgs, open_out, out_is_stdout};
use crate::plot::{Figure, Series, Style, draw};

/// The measured curve and what its values are.
#[derive(Debug, Clone, clap::Args)]
pub struct MeasuredArgs {
    /// Measured curve, CSV with header `theta_i_deg, theta_s_deg, value` and optionally
    /// `uncertainty` (one standard uncertainty, same unit as value).
    #[arg(long, value_name = "FILE")]
    pub measured: PathBuf,
    /// What `value` is: brdf (1/sr), reflectance-factor (π × BRDF) or relative (1 at
    /// specular).
    #[arg(long, value_name = "KIND", default_value = "brdf")]
    pub measured_kind: MeasuredKind,
    /// Leave out the clear coat's own specular reflection (on by default in comparisons,
    /// so that the specular peak is modelled too).
    #[arg(long)]
    pub no_clearcoat: bool,
}

impl MeasuredArgs {
    /// Read the measured file.
    pub fn read(&self) -> anyhow::Result<MeasuredCurve> {
        read_measured(&self.measured)
            .with_context(|| format!("reading --measured {}", self.measured.display()))
    }

    /// Settings with the clear coat on unless `--no-clearcoat`.
    pub fn settings(&self, instrument: &InstrumentArgs) -> Settings {
        Settings {
            clearcoat: !self.no_clearcoat,
            ..instrument.settings()
        }
    }
}

/// Compare a measured curve with the distribution model (or a model result file):
/// fits the model's vertical scale per incidence to the points 5°–40° from specular
/// (excluding the specular peak) and reports residuals of log10 values in the paper's
/// three regions: specular (< 5° from specular), near-specular (5°–40°), far (> 40°).
///
/// The model is evaluated at the measured angles with --aperture; --theta-i/--theta-s
/// are not used. Without --json a table goes to stdout; --out writes one CSV row per
/// measured point.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub measured: MeasuredArgs,
    #[command(flatten)]
    pub instrument: InstrumentArgs,
    #[command(flatten)]
    pub orientation: OrientationArgs,
    /// Compare against a result CSV written by `model` or `topo` (columns theta_i_deg,
    /// theta_s_deg, aperture_deg, brdf_per_sr, relative) instead of computing the model.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["hwhm", "sigma", "rms_tilt", "distribution"])]
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
}

/// Model values from a result CSV, matched to the measured angles (degrees to 1e-6).
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
        if (aperture - aperture_deg).abs() > 1e-6 {
            bail!(
                "--model {name}, line {line}: aperture_deg {aperture} differs from --aperture {aperture_deg}; compare at the aperture the model was computed with"
            );
        }
        out.push((
            row.theta_i.to_degrees(),
            row.theta_s.to_degrees(),
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
    let out_to_stdout = out_is_stdout(args.out.as_deref(), args.json)?;
    let measured = args.measured.read()?;
    let coating = args.instrument.coating()?;
    let settings = args.measured.settings(&args.instrument);
    let aperture = args.instrument.aperture_rad()?;
    let aperture_deg = args.instrument.aperture;
    let kind = args.measured.measured_kind;
    let (results, model_desc) = if let Some(path) = &args.model {
        let table = model_file(path, aperture_deg)?;
        let lookup = |ti: f64, ts: &[f64]| -> Result<Vec<ModelPoint>, PipelineError> {
            ts.iter()
                .map(|&t| {
                    let (a, b) = (ti.to_degrees(), t.to_degrees());
                    table
                        .iter()
                        .find(|(x, y, _)| (x - a).abs() < 1e-6 && (y - b).abs() < 1e-6)
                        .map(|r| r.2)
                        .ok_or_else(|| PipelineError::Measurement(format!(
                            "--model {}: no row for theta_i_deg {a}, theta_s_deg {b} (the model was not computed at this measured angle)",
                            path.display()
                        )))
                })
                .collect()
        };
        (
            compare(&measured, kind, &lookup)?,
            json!({"file": path.display().to_string()}),
        )
    } else {
        let (orientation, echo) = orientation_from(&args.orientation)?;
        let model = |ti: f64, ts: &[f64]| {
            distribution_points(&coating, &settings, aperture, &orientation, ti, ts)
        };
        (compare(&measured, kind, &model)?, echo)
    };

    if let Some(path) = &args.out {
        write_points(&mut open_out(path)?, &results)?;
    }
    if let Some(path) = &args.plot {
        draw(path, &figure(&results, kind, &measured.file))?;
    }
    if args.json {
        let summary = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "compare",
            "inputs": {
                "measured": measured.file,
                "measured_kind": kind.name(),
                "model": model_desc,
                "instrument": args.instrument.echo(),
                "clearcoat": settings.clearcoat,
            },
            "regions_deg": {"specular": "< 5 from specular", "near-specular": "5 to 40", "far": "> 40"},
            "scale_fitted_on": "near-specular points (5 to 40 degrees from specular)",
            "residual": "log10(measured) - log10(scale * model)",
            "incidences": incidences_json(&results),
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else if !out_to_stdout {
        print_table(&results);
    }
    Ok(())
}

fn incidences_json(results: &[IncidenceComparison]) -> Value {
    Value::Array(
        results
            .iter()
            .map(|c| {
                json!({
                    "theta_i_deg": c.theta_i.to_degrees(),
                    "scale": c.scale,
                    "regions": c.regions.iter().map(|r| json!({
                        "region": r.region.name(),
                        "points": r.points,
                        "points_without_model": r.no_model,
                        "rms_log10": r.rms_log10,
                        "mean_log10": r.mean_log10,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect(),
    )
}

fn print_table(results: &[IncidenceComparison]) {
    println!("theta_i_deg  scale        region         points  rms_log10  mean_log10");
    for c in results {
        for r in &c.regions {
            let f = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |v| format!("{v:.4}"));
            println!(
                "{:<12} {:<12.5e} {:<14} {:>6}  {:>9}  {:>10}",
                format!("{:.2}", c.theta_i.to_degrees()),
                c.scale,
                r.region.name(),
                r.points,
                f(r.rms_log10),
                f(r.mean_log10)
            );
        }
    }
}

fn write_points(
    out: &mut dyn std::io::Write,
    results: &[IncidenceComparison],
) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let fail =
        |e: csv::Error| anyhow::Error::new(crate::common::Failure(format!("writing CSV: {e}")));
    w.write_record([
        "theta_i_deg",
        "theta_s_deg",
        "region",
        "measured",
        "model",
        "residual_log10",
    ])
    .map_err(fail)?;
    for c in results {
        for p in &c.points {
            w.write_record([
                format!("{}", round(p.theta_i.to_degrees())),
                format!("{}", round(p.theta_s.to_degrees())),
                p.region.name().to_string(),
                format!("{:.9e}", p.measured),
                format!("{:.9e}", p.model),
                format!("{:.6}", p.residual),
            ])
            .map_err(fail)?;
        }
    }
    w.flush()
        .map_err(|e| anyhow::Error::new(crate::common::Failure(format!("writing CSV: {e}"))))?;
    Ok(())
}

fn round(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

/// Measured points and scaled model lines per incidence, log axis.
pub fn figure(results: &[IncidenceComparison], kind: MeasuredKind, file: &str) -> Figure {
    let mut series = Vec::new();
    for (k, c) in results.iter().enumerate() {
        let ti = c.theta_i.to_degrees();
        series.push(Series {
            label: format!("measured, θi = {ti:.1}°"),
            points: c
                .points
                .iter()
                .map(|p| (p.theta_s.to_degrees(), p.measured))
                .collect(),
            style: Style::Points,
            colour: k,
        });
        series.push(Series {
            label: format!("model × {:.3e}, θi = {ti:.1}°", c.scale),
            points: c
                .points
                .iter()
                .map(|p| (p.theta_s.to_degrees(), p.model))
                .collect(),
            style: Style::Line,
            colour: k,
        });
    }
    let unit = match kind {
        MeasuredKind::Brdf => "BRDF (1/sr)",
        MeasuredKind::ReflectanceFactor => "reflectance factor (π × BRDF)",
        MeasuredKind::Relative => "relative reflectance (1 at specular)",
    };
    Figure {
        title: format!("Measured ({file}) vs model, scale fitted 5°–40° from specular"),
        x_label: "θs (degrees; θs = −θi is specular)".into(),
        y_label: unit.into(),
        log_y: true,
        series,
    }
}

/// The coating and settings echo used by `fit` (kept here so both agree).
pub fn model_inputs(coating: &Coating, settings: &Settings) -> Value {
    json!({
        "n": coating.n,
        "transmission": settings.transmission.name(),
        "weighting": settings.weighting.name(),
        "clearcoat": settings.clearcoat,
    })
}
