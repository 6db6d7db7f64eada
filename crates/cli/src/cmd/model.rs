//! `flakescatter model`: the distribution model (physics.md §4) over an instrument.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::gaussian::ConeMethod;
use flakescatter::io::flakes::read_histogram;
use flakescatter::multiangle::multi_angle;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{OrientationSource, distribution_curves, p_tilde_about_specular};
use serde_json::json;

use crate::instrument::{
    InstrumentArgs, open_out, rows_json, table_to_stdout, table_writer, units_json,
    warn_undefined_relative, write_curves_csv,
};
use crate::plot::{Figure, Series, Style, draw, relative_figure};

/// Where the flake orientation distribution comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OrientationKind {
    /// A Gaussian p~(θn) ∝ exp(-θn²/(2s²)) with one of --hwhm, --sigma, --rms-tilt.
    Gaussian,
    /// A measured histogram (`--distribution FILE`, the CSV written by `stats`).
    Table,
}

/// How detector cones are integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ConeKind {
    /// Exact integral over the cone (quadrature about the detector axis).
    Exact,
    /// The paper's constant-integrand approximation f(r) cos θ ΔΩ.
    Constant,
}

/// Where the orientation distribution comes from (shared by model, compare, fit).
#[derive(Debug, Clone, clap::Args)]
#[command(group = clap::ArgGroup::new("width").multiple(false).args(["hwhm", "sigma", "rms_tilt"]))]
pub struct OrientationArgs {
    /// Orientation source.
    #[arg(long, value_enum, default_value = "gaussian")]
    pub orientation: OrientationKind,
    /// Gaussian half-width at half-maximum of p~, degrees, in (0, 90) (the paper's w).
    /// Default 6 when no width is given.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub hwhm: Option<f64>,
    /// Gaussian standard deviation s of each tilt component, degrees, in (0, 90).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub sigma: Option<f64>,
    /// Gaussian rms tilt σt = s·√2 (p~ ∝ exp(-θ²/σt²)), degrees, in (0, 90).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub rms_tilt: Option<f64>,
    /// Histogram CSV (`theta_lo_deg, theta_hi_deg, area_fraction`, as written by
    /// `flakescatter stats` or `fit --nonparametric`) for `--orientation table`.
    #[arg(long, value_name = "FILE")]
    pub distribution: Option<PathBuf>,
}

/// Reflectance of flat mirror flakes under a clear coat, from their orientation
/// distribution (paper eqs. 9–13 as corrected in docs/physics.md §4).
///
/// Writes one CSV row per incidence × detector: theta_i_deg, theta_s_deg, phi_s_deg,
/// aperture_deg, brdf_per_sr, reflectance (fraction of the beam), relative (to the same
/// detector at the specular direction). With no flags: the defaults below and a hwhm 6°
/// Gaussian.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub instrument: InstrumentArgs,
    #[command(flatten)]
    pub source: OrientationArgs,
    /// Cone integration.
    #[arg(long, value_enum, default_value = "exact")]
    pub cone: ConeKind,
    /// Multi-angle readout instead of a curve: 45° incidence, aspecular −15°, 15°, 25°,
    /// 45°, 75°, 110°, reflectance factors (π × BRDF over the --aperture cone) and the
    /// flop index (single-wavelength approximation; see docs/physics.md).
    #[arg(long)]
    pub multi_angle: bool,
    /// Write the CSV here (`-` = stdout). Without --out and --json the CSV goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (inputs, units, version, rows).
    #[arg(long)]
    pub json: bool,
    /// Draw the relative curves (log axis) to this .svg or .png file, with the Gaussian
    /// p~ drawn about the specular direction as in the paper's Fig. 4.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

/// Validate a width flag (degrees) and convert it.
fn width(flag: &str, deg: f64) -> anyhow::Result<f64> {
    if !(deg.is_finite() && deg > 0.0 && deg < 90.0) {
        bail!("{flag} {deg}: the width must be > 0 and < 90 degrees");
    }
    Ok(deg.to_radians())
}

/// The orientation distribution the flags ask for, with its JSON echo.
pub fn orientation_from(
    args: &OrientationArgs,
) -> anyhow::Result<(Orientation, serde_json::Value)> {
    match args.orientation {
        OrientationKind::Gaussian => {
            if args.distribution.is_some() {
                bail!("--distribution needs --orientation table");
            }
            let (w, echo) = match (args.hwhm, args.sigma, args.rms_tilt) {
                (Some(h), _, _) => (
                    GaussianWidth::Hwhm(width("--hwhm", h)?),
                    json!({"hwhm_deg": h}),
                ),
                (_, Some(s), _) => (
                    GaussianWidth::Sigma(width("--sigma", s)?),
                    json!({"sigma_deg": s}),
                ),
                (_, _, Some(r)) => (
                    GaussianWidth::RmsTilt(width("--rms-tilt", r)?),
                    json!({"rms_tilt_deg": r}),
                ),
                _ => (
                    GaussianWidth::Hwhm(6f64.to_radians()),
                    json!({"hwhm_deg": 6.0}),
                ),
            };
            let o = Orientation::gaussian(w).context("Gaussian width")?;
            Ok((o, json!({"kind": "gaussian", "width": echo})))
        }
        OrientationKind::Table => {
            if args.hwhm.is_some() || args.sigma.is_some() || args.rms_tilt.is_some() {
                bail!("--hwhm/--sigma/--rms-tilt need --orientation gaussian");
            }
            let Some(path) = &args.distribution else {
                bail!("--orientation table needs --distribution FILE");
            };
            let t = read_histogram(path)
                .with_context(|| format!("reading --distribution {}", path.display()))?;
            let o = Orientation::tabulated(t.edges_rad, t.area_fractions)
                .with_context(|| format!("--distribution {}", path.display()))?;
            Ok((
                o,
                json!({"kind": "table", "file": path.display().to_string()}),
            ))
        }
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let to_stdout = table_to_stdout(args.out.as_deref(), args.json)?;
    let coating = args.instrument.coating()?;
    let instrument = args.instrument.instrument()?;
    let mut settings = args.instrument.settings();
    settings.cone_method = match args.cone {
        ConeKind::Exact => ConeMethod::Exact,
        ConeKind::Constant => ConeMethod::ConstantIntegrand,
    };
    let (orientation, orientation_echo) = orientation_from(&args.source)?;
    let source = OrientationSource::Distribution(orientation.clone());
    if args.multi_angle {
        return multi_angle_run(&args, &coating, &settings, &source, orientation_echo);
    }
    let curves = distribution_curves(&coating, &instrument, &settings, &source)?;

    warn_undefined_relative(&curves);
    if let Some((mut w, _)) = table_writer(args.out.as_deref(), to_stdout)? {
        write_curves_csv(&mut w, &curves, false)?;
    }
    if let Some(path) = &args.plot {
        draw(path, &figure(&curves, &orientation))?;
    }
    if args.json {
        let summary = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "model",
            "model": curves.model,
            "inputs": {
                "instrument": args.instrument.echo(),
                "orientation": orientation_echo,
                "cone": match args.cone { ConeKind::Exact => "exact", ConeKind::Constant => "constant-integrand" },
            },
            "units": units_json(),
            "rows": rows_json(&curves),
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    }
    Ok(())
}

/// Relative curves per incidence on a log axis, plus p~ about specular (Fig. 4 style).
fn figure(curves: &flakescatter::Curves, orientation: &Orientation) -> Figure {
    let mut fig = relative_figure(
        curves,
        format!(
            "Distribution model, n = {}, aperture {:.2}°",
            curves.coating.n,
            curves.instrument.aperture().to_degrees()
        ),
    );
    let in_plane = matches!(
        curves.instrument.detectors(),
        flakescatter::DetectorSet::InPlane(_)
    );
    if in_plane && orientation.gaussian_width().is_some() {
        for (k, &ti) in curves.instrument.theta_i().iter().enumerate() {
            // p~(θn)/p~(0) drawn about the specular direction θs = −θi (paper Fig. 4).
            let points = (-900..=900)
                .map(|j| -ti.to_degrees() + f64::from(j) * 0.1)
                .filter(|&x| x > -90.0 && x < 90.0)
                .map(|x| (x, p_tilde_about_specular(orientation, ti, x.to_radians())))
                .collect();
            fig.series.push(Series {
                label: format!("p~ about specular, θi = {:.1}°", ti.to_degrees()),
                points,
                style: Style::Dashed,
                colour: k,
            });
        }
    }
    fig
}

/// `--multi-angle`: the six-angle readout and the flop index.
fn multi_angle_run(
    args: &Args,
    coating: &flakescatter::Coating,
    settings: &flakescatter::Settings,
    source: &OrientationSource,
    orientation_echo: serde_json::Value,
) -> anyhow::Result<()> {
    if args.plot.is_some() {
        bail!("--plot draws curves; it does not apply to --multi-angle");
    }
    let m = multi_angle(
        coating,
        settings,
        source,
        args.instrument.aperture.to_radians(),
    )
    .context("--multi-angle (needs --aperture > 0)")?;
    let to_stdout = match &args.out {
        Some(p) => p.as_os_str() == "-",
        None => !args.json,
    };
    if to_stdout || args.out.is_some() {
        let mut out: Box<dyn std::io::Write> = match &args.out {
            Some(p) if p.as_os_str() != "-" => open_out(p)?,
            _ => Box::new(std::io::stdout().lock()),
        };
        let mut text = String::from(
            "theta_i_deg,aspecular_deg,theta_s_deg,aperture_deg,reflectance_factor,lightness_l_star\n",
        );
        for r in &m.readouts {
            text.push_str(&format!(
                "45,{},{},{},{:.9e},{:.4}\n",
                r.aspecular.to_degrees().round(),
                r.theta_s.to_degrees().round(),
                args.instrument.aperture,
                r.reflectance_factor,
                r.lightness
            ));
        }
        out.write_all(text.as_bytes()).map_err(|e| {
            anyhow::Error::new(crate::common::Failure(format!("writing the readout: {e}")))
        })?;
    }
    if args.json {
        let summary = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "model --multi-angle",
            "inputs": {"instrument": args.instrument.echo(), "orientation": orientation_echo},
            "theta_i_deg": 45.0,
            "aperture_deg": args.instrument.aperture,
            "readouts": m.readouts.iter().map(|r| json!({
                "aspecular_deg": r.aspecular.to_degrees().round(),
                "theta_s_deg": r.theta_s.to_degrees().round(),
                "reflectance_factor": r.reflectance_factor,
                "lightness_l_star": r.lightness,
            })).collect::<Vec<_>>(),
            "flop_index": m.flop_index,
            "flop_index_formula": "2.69 (L*15 - L*110)^1.11 / (L*45)^0.86, L* = CIE 1976 lightness of the reflectance factor",
            "approximation": "single wavelength: the monochromatic reflectance factor stands in for the luminance factor Y",
            "units": {"reflectance_factor": "pi x BRDF averaged over the detector cone (1 for a perfect diffuser)"},
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    }
    Ok(())
}
