//! `flakescatter model`: the distribution model (physics.md §4) over an instrument.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::chart::distribution_chart;
use flakescatter::gaussian::ConeMethod;
use flakescatter::multiangle::{MultiAngle, multi_angle_at};
use flakescatter::{OrientationSource, distribution_curves, distribution_mueller};
use serde_json::json;

use crate::flags::{InstrumentArgs, OrientationArgs, PolarizationArgs};
use crate::output::{Dest, Kind, Plan, print_json, warn};
use crate::parse::{angles, check_range, deg, deg_num, shortest};
use crate::tables::{num, rows_json, units_json, write_curves, write_curves_with};

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
    /// Multi-angle readout instead of a curve: 45° incidence (or the one --theta-i),
    /// aspecular −15°, 15°, 25°, 45°, 75°, 110°, reflectance factors (π × BRDF over the
    /// --aperture cone) and the flop index (single-wavelength approximation; see
    /// docs/physics.md).
    #[arg(long)]
    pub multi_angle: bool,
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
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.instrument.inputs(&mut plan);
    args.source.inputs(&mut plan);
    let table = plan.table("--out", args.out.as_deref(), args.json);
    if args.json {
        plan.stdout("--json");
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
    if args.multi_angle {
        if polarimetry.is_some() {
            bail!(
                "--polarization/--incident/--analyzer do not apply to --multi-angle: its readout is for unpolarised light (--transmission s|p give a polarised beam)"
            );
        }
        if plot.is_some() {
            bail!("--plot draws curves; it does not apply to --multi-angle");
        }
        if args.instrument.theta_s.is_some() || args.instrument.detectors.is_some() {
            bail!(
                "--theta-s/--detectors do not apply to --multi-angle: its detectors are the six aspecular angles"
            );
        }
        let text = args.instrument.theta_i.as_deref().unwrap_or("45");
        let ti = angles("--theta-i", text)?;
        check_range("--theta-i", &ti, 0.0, 90.0, false, true)?;
        let [theta_i] = ti.as_slice() else {
            bail!("--theta-i {text}: --multi-angle gives one readout; give one incidence");
        };
        let aperture = args.instrument.optics.aperture_rad()?;
        plan.check()?;
        let (orientation, echo) = args.source.orientation()?;
        let m = multi_angle_at(
            &coating,
            &settings,
            &OrientationSource::Distribution(orientation),
            theta_i.to_radians(),
            aperture,
        )
        .context("--multi-angle (needs --aperture > 0)")?;
        return multi_angle_out(&args, plan, table, &m, echo);
    }
    let instrument = args.instrument.instrument()?;
    plan.check()?;
    let (orientation, orientation_echo) = args.source.orientation()?;
    let source = OrientationSource::Distribution(orientation.clone());
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
        let mut summary = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "model",
            "model": curves.model,
            "inputs": {
                "instrument": args.instrument.echo(),
                "orientation": orientation_echo,
                "cone": match args.cone { ConeKind::Exact => "exact", ConeKind::Constant => "constant-integrand" },
            },
            "units": units_json(),
            "warnings": warnings,
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "plot": args.plot.as_ref().map(|p| p.display().to_string()),
        });
        if let Some(p) = &polarimetry {
            summary["inputs"]["polarimetry"] = args.polarization.echo(p);
            summary["polarimetry"] = json!({
                "convention": crate::mueller::CONVENTION,
                "units": crate::mueller::units(elements),
            });
        }
        if table.is_none() {
            let mut rows = rows_json(&curves);
            if let Some(mu) = &mueller {
                crate::mueller::add_to_rows(&mut rows, mu, elements);
            }
            summary["rows"] = rows;
        } else {
            summary["row_count"] = json!(curves.rows.len());
        }
        plan.finish()?;
        return print_json(&summary);
    }
    plan.finish()
}

/// Writes `--multi-angle`: the six-angle readout and the flop index.
fn multi_angle_out(
    args: &Args,
    mut plan: Plan,
    table: Option<Dest>,
    m: &MultiAngle,
    orientation_echo: serde_json::Value,
) -> anyhow::Result<()> {
    let ti = deg(m.theta_i);
    let aperture = deg(m.aperture);
    if let Some(dest) = &table {
        let mut text = String::from(
            "theta_i_deg,aspecular_deg,theta_s_deg,aperture_deg,reflectance_factor,lightness_l_star\n",
        );
        for r in &m.readouts {
            text.push_str(&format!(
                "{ti},{},{},{aperture},{},{}\n",
                deg(r.aspecular),
                shortest(deg_num(r.aspecular) - deg_num(m.theta_i)),
                num(r.reflectance_factor),
                num(r.lightness)
            ));
        }
        plan.write(
            dest,
            |w| Ok(w.write_all(text.as_bytes())?),
            Some(format!("{} rows", m.readouts.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        let summary = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "model --multi-angle",
            "inputs": {"instrument": args.instrument.optics.echo(args.instrument.clearcoat), "orientation": orientation_echo},
            "theta_i_deg": deg_num(m.theta_i),
            "aperture_deg": deg_num(m.aperture),
            "readouts": m.readouts.iter().map(|r| json!({
                "aspecular_deg": deg_num(r.aspecular),
                "theta_s_deg": deg_num(r.aspecular) - deg_num(m.theta_i),
                "reflectance_factor": r.reflectance_factor,
                "lightness_l_star": r.lightness,
            })).collect::<Vec<_>>(),
            "flop_index": m.flop_index,
            "flop_index_formula": "2.69 (L*15 - L*110)^1.11 / (L*45)^0.86, L* = CIE 1976 lightness of the reflectance factor (standardised for 45° incidence)",
            "approximation": "single wavelength: the monochromatic reflectance factor stands in for the luminance factor Y",
            "units": {"reflectance_factor": "pi x BRDF averaged over the detector cone (1 for a perfect diffuser)"},
            "out": args.out.as_ref().map(|p| p.display().to_string()),
        });
        print_json(&summary)?;
    }
    Ok(())
}
