//! `flakescatter fit`: the flake orientation distribution from a measured curve.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::compare::{FAR_REGION, SPECULAR_REGION};
use flakescatter::fit::{FitSetup, GaussianFit, NonParametricFit, fit_gaussian, fit_nonparametric};
use flakescatter::io::flakes::write_histogram_bins;
use serde_json::{Value, json};

use crate::flags::{ColourArgs, DEFAULT_WAVELENGTHS, MeasuredArgs, SpectralArgs};
use crate::output::{Kind, Plan, print, print_json, warn};
use crate::parse::{angles, deg, deg_num, fixed, shortest};

/// Fit the flake orientation distribution to a measured curve.
///
/// Default: a Gaussian p~ — its hwhm (with a standard uncertainty), the vertical scale
/// (per incidence, or --common-scale) and, with --fit-n, the clear-coat index — by
/// least squares on log values of the points 5°–40° from specular (the specular peak is
/// excluded). With --nonparametric: a tabulated p~ on --bins by regularised
/// non-negative least squares (the paper's "estimate the distribution that can give rise
/// to a measured reflectance curve"); --out then writes it as a histogram CSV that
/// `model --orientation table --distribution` reads. --theta-i/--theta-s select the
/// measured points used.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub measured: MeasuredArgs,
    #[command(flatten)]
    pub spectral: SpectralArgs,
    #[command(flatten)]
    pub colour: ColourArgs,
    /// Start value of the Gaussian hwhm, degrees, in (0, 60).
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 4.0,
        allow_negative_numbers = true
    )]
    pub hwhm_start: f64,
    /// Fit the clear-coat index too (start: --n).
    #[arg(long)]
    pub fit_n: bool,
    /// One vertical scale for all incidences (absolute data of one sample) instead of one
    /// per incidence.
    #[arg(long)]
    pub common_scale: bool,
    /// Aspecular range of the points used, degrees, `LO:HI`.
    #[arg(
        long,
        value_name = "LO:HI",
        default_value = "5:40",
        allow_hyphen_values = true
    )]
    pub region: String,
    /// Estimate a tabulated p~ instead of a Gaussian.
    #[arg(long)]
    pub nonparametric: bool,
    /// Bin edges of the tabulated p~, degrees (list or range), for --nonparametric.
    #[arg(
        long,
        value_name = "LIST",
        default_value = "0:30:2",
        allow_hyphen_values = true
    )]
    pub bins: String,
    /// Smoothness weight of the non-parametric estimate (second differences of p~,
    /// relative to the data), >= 0.
    #[arg(
        long,
        value_name = "X",
        default_value_t = 0.05,
        allow_negative_numbers = true
    )]
    pub lambda: f64,
    /// --nonparametric: write the estimated histogram CSV (theta_lo_deg, theta_hi_deg,
    /// area_fraction, p_per_rad, p_tilde) here.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `--region LO:HI` in radians.
fn region(text: &str) -> anyhow::Result<(f64, f64)> {
    match text
        .split_once(':')
        .map(|(a, b)| (a.trim().parse::<f64>(), b.trim().parse::<f64>()))
    {
        Some((Ok(lo), Ok(hi))) if lo >= 0.0 && hi > lo && hi < 180.0 => {
            Ok((lo.to_radians(), hi.to_radians()))
        }
        _ => bail!(
            "--region `{text}`: expected LO:HI in degrees with 0 <= LO < HI < 180 (default 5:40)"
        ),
    }
}

/// Largest number of bins of the non-parametric estimate.
const MAX_BINS: usize = 1000;

/// `--bins` in radians.
fn bins(text: &str) -> anyhow::Result<Vec<f64>> {
    let edges = angles("--bins", text)?;
    if edges.len() > MAX_BINS + 1 {
        bail!(
            "--bins `{text}`: {} bins is more than the limit of {MAX_BINS} (the estimate solves a bins × bins system)",
            edges.len() - 1
        );
    }
    if edges.len() < 2
        || edges.windows(2).any(|w| w[1] <= w[0])
        || edges[0] < 0.0
        || edges[edges.len() - 1] > 90.0
    {
        bail!("--bins `{text}`: expected at least two increasing edges within [0, 90] degrees");
    }
    Ok(edges.iter().map(|d| d.to_radians()).collect())
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    args.measured.inputs(&mut plan);
    let out = plan.output("--out", args.out.as_deref(), Kind::Table);
    if args.json {
        plan.stdout("--json");
    } else if out.is_none() {
        plan.stdout("the result");
    }
    args.spectral.inputs(&mut plan);
    if args.measured.measured_multiangle.is_some() {
        return multi_angle(&args, plan);
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
    let region = region(&args.region)?;
    let edges = if args.nonparametric {
        if args.fit_n {
            bail!("--fit-n applies to the Gaussian fit, not --nonparametric");
        }
        if !(args.lambda.is_finite() && args.lambda >= 0.0) {
            bail!("--lambda {}: expected a finite number >= 0", args.lambda);
        }
        Some(bins(&args.bins)?)
    } else {
        if out.is_some() {
            bail!(
                "--out writes the --nonparametric histogram; the Gaussian fit reports with --json"
            );
        }
        if !(args.hwhm_start.is_finite() && args.hwhm_start > 0.0 && args.hwhm_start < 60.0) {
            bail!(
                "--hwhm-start {}: expected a width in (0, 60) degrees",
                args.hwhm_start
            );
        }
        None
    };
    plan.check()?;
    let (measured, selection) = args.measured.read()?;
    let mut setup = FitSetup::new(coating, settings, aperture, args.measured.measured_kind);
    setup.region = region;
    setup.common_scale = args.common_scale;
    let inputs = json!({
        "measured": measured.file,
        "measured_kind": args.measured.measured_kind.name(),
        "selection": selection,
        "model": args.measured.optics.echo(settings.clearcoat),
        "aperture_deg": args.measured.optics.aperture,
        "region_deg": [deg_num(region.0), deg_num(region.1)],
        "common_scale": args.common_scale,
    });
    if let Some(edges) = edges {
        let est = fit_nonparametric(&measured, &setup, &edges, args.lambda)
            .with_context(|| format!("non-parametric fit of {}", measured.file))?;
        if let Some(dest) = &out {
            let name = dest.name();
            plan.write(
                dest,
                |w| {
                    Ok(write_histogram_bins(
                        w,
                        &name,
                        &est.edges,
                        &est.area_fractions,
                    )?)
                },
                Some(format!("{} bins", est.area_fractions.len())),
            )?;
        }
        plan.finish()?;
        return if args.json {
            print_json(&nonparametric_json(&est, inputs))
        } else if out.is_none() {
            let mut s = String::from("theta_lo_deg,theta_hi_deg,area_fraction,p_tilde\n");
            for (e, (f, p)) in est
                .edges
                .windows(2)
                .zip(est.area_fractions.iter().zip(&est.p_tilde))
            {
                let _ = writeln!(
                    s,
                    "{},{},{},{}",
                    deg(e[0]),
                    deg(e[1]),
                    shortest(*f),
                    shortest(*p)
                );
            }
            print(&s)
        } else {
            Ok(())
        };
    }
    let fit = fit_gaussian(&measured, &setup, args.hwhm_start.to_radians(), args.fit_n)
        .with_context(|| format!("Gaussian fit of {}", measured.file))?;
    for w in &fit.warnings {
        warn(&format!("{}: {w}", measured.file));
    }
    plan.finish()?;
    if args.json {
        print_json(&gaussian_json(&fit, inputs))
    } else {
        print(&gaussian_text(&fit))
    }
}

/// `--measured-multiangle`: the Gaussian width (with a common scale, and `n` with
/// --fit-n) fitted to the measured L* by the spectral distribution model.
fn multi_angle(args: &Args, plan: Plan) -> anyhow::Result<()> {
    let Some(path) = &args.measured.measured_multiangle else {
        bail!("--measured-multiangle FILE is needed here");
    };
    if args.nonparametric {
        bail!("--nonparametric fits a curve; the L* fit of --measured-multiangle is Gaussian");
    }
    if args.out.is_some() {
        bail!("--out writes the --nonparametric histogram; the L* fit reports on stdout (--json)");
    }
    if args.region != "5:40" {
        bail!(
            "--region {}: the L* fit uses every measured geometry (leave out the ones you do not want in the file)",
            args.region
        );
    }
    if !(args.hwhm_start.is_finite() && args.hwhm_start > 0.0 && args.hwhm_start < 60.0) {
        bail!(
            "--hwhm-start {}: expected a width in (0, 60) degrees",
            args.hwhm_start
        );
    }
    args.spectral.validate()?;
    let aperture = args.measured.optics.aperture_rad()?;
    if aperture <= 0.0 {
        bail!("--aperture 0: multi-angle colour needs the instrument's cone half-angle (> 0)");
    }
    let wavelengths = args
        .spectral
        .wavelengths_nm(Some(DEFAULT_WAVELENGTHS))?
        .unwrap_or_default();
    plan.check()?;
    let file = flakescatter::io::spectral::read_multiangle(path)
        .with_context(|| format!("reading --measured-multiangle {}", path.display()))?;
    let (coating, coating_echo) = args.spectral.coating(&args.measured.optics)?;
    let setup = flakescatter::spectral::LightnessFitSetup {
        coating: &coating,
        settings: args.measured.settings(),
        aperture,
        wavelengths_nm: &wavelengths,
        illuminant: args.colour.illuminant(),
        observer: args.colour.observer(),
        fit_n: args.fit_n,
    };
    let fit = flakescatter::spectral::fit_lightness(&file, &setup, args.hwhm_start.to_radians())
        .with_context(|| format!("L* fit of {}", path.display()))?;
    for w in &fit.warnings {
        warn(&format!("{}: {w}", path.display()));
    }
    plan.finish()?;
    if args.json {
        let inputs = json!({
            "measured_multiangle": path.display().to_string(),
            "model": args.measured.optics.echo(args.measured.clearcoat()),
            "aperture_deg": args.measured.optics.aperture,
            "spectral": coating_echo,
            "wavelengths_nm": args.spectral.wavelengths_text(DEFAULT_WAVELENGTHS),
            "colorimetry": args.colour.echo(),
        });
        print_json(&lightness_json(&fit, inputs))
    } else {
        print(&lightness_text(&fit))
    }
}

fn lightness_json(fit: &flakescatter::spectral::LightnessFit, inputs: Value) -> Value {
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "fit --measured-multiangle",
        "inputs": inputs,
        "hwhm_deg": fit.hwhm.to_degrees(),
        "hwhm_std_deg": fit.hwhm_std.to_degrees(),
        "scale": fit.scale,
        "scale_std": fit.scale_std,
        "n": fit.n,
        "n_std": fit.n_std,
        "chi2": fit.chi2,
        "dof": fit.dof,
        "points": fit.points,
        "iterations": fit.iterations,
        "uncertainty_basis": fit.uncertainty_basis.describe(),
        "uncertainty_scale": fit.uncertainty_scale,
        "warnings": fit.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "geometries": fit.residuals.iter().map(|(g, m, l)| json!({
            "theta_i_deg": deg_num(g.theta_i()),
            "aspecular_deg": deg_num(g.aspecular()),
            "measured_L": m.l,
            "model_L": l.l,
            "model_a": l.a,
            "model_b": l.b,
        })).collect::<Vec<_>>(),
        "residual": "L*_model - L*_measured (divided by L_uncertainty when every geometry has one)",
        "scale_meaning": "the model's reflectance factors are multiplied by scale (the flake coverage a fully covering layer does not know)",
    })
}

/// The L* fit for the terminal (display rounding).
fn lightness_text(fit: &flakescatter::spectral::LightnessFit) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "hwhm_deg = {} ± {}",
        fixed(fit.hwhm.to_degrees(), 4),
        fixed(fit.hwhm_std.to_degrees(), 4)
    );
    let _ = writeln!(
        s,
        "scale = {} ± {}",
        fixed(fit.scale, 4),
        fixed(fit.scale_std, 4)
    );
    if let (Some(n), Some(e)) = (fit.n, fit.n_std) {
        let _ = writeln!(s, "n = {} ± {}", fixed(n, 4), fixed(e, 4));
    }
    let _ = writeln!(
        s,
        "chi2 = {} for {} degrees of freedom ({} geometries)",
        fixed(fit.chi2, 3),
        fit.dof,
        fit.points
    );
    s.push_str("theta_i  aspecular  measured L*  model L*\n");
    for (g, m, l) in &fit.residuals {
        let _ = writeln!(
            s,
            "{:<8} {:<9} {:>12} {:>9}",
            deg(g.theta_i()),
            deg(g.aspecular()),
            fixed(m.l, 2),
            fixed(l.l, 2)
        );
    }
    s
}

fn nonparametric_json(est: &NonParametricFit, inputs: Value) -> Value {
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "fit --nonparametric",
        "inputs": inputs,
        "lambda": est.lambda,
        "points": est.points,
        "chi2_relative": est.chi2,
        "bins": est.edges.windows(2).zip(&est.area_fractions).zip(&est.p_tilde).map(|((e, f), p)| json!({
            "theta_lo_deg": deg_num(e[0]),
            "theta_hi_deg": deg_num(e[1]),
            "area_fraction": f,
            "p_tilde": p,
        })).collect::<Vec<_>>(),
        "units": {"p_tilde": "per steradian x 2 pi, normalised so that the integral of p~ sin(theta) dtheta is 1"},
    })
}

fn gaussian_json(fit: &GaussianFit, inputs: Value) -> Value {
    let scales: Vec<_> = fit
        .scales
        .iter()
        .map(|(t, s)| json!({"theta_i_deg": if t.is_nan() { None } else { Some(deg_num(*t)) }, "scale": s}))
        .collect();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "fit",
        "inputs": inputs,
        "hwhm_deg": fit.hwhm.to_degrees(),
        "hwhm_std_deg": fit.hwhm_std.to_degrees(),
        "n": fit.n,
        "n_std": fit.n_std,
        "scales": scales,
        "chi2": fit.chi2,
        "dof": fit.dof,
        "points": fit.points,
        "iterations": fit.iterations,
        "uncertainty_basis": fit.uncertainty_basis.describe(),
        "uncertainty_scale": fit.uncertainty_scale,
        "warnings": fit.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "default_region_deg": [deg_num(SPECULAR_REGION), deg_num(FAR_REGION)],
    })
}

/// The result for the terminal (display rounding).
fn gaussian_text(fit: &GaussianFit) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "hwhm_deg = {} ± {}",
        fixed(fit.hwhm.to_degrees(), 4),
        fixed(fit.hwhm_std.to_degrees(), 4)
    );
    if let Some(e) = fit.n_std {
        let _ = writeln!(s, "n = {} ± {}", fixed(fit.n, 4), fixed(e, 4));
    }
    for (t, sc) in &fit.scales {
        if t.is_nan() {
            let _ = writeln!(s, "scale (all incidences) = {sc:.5e}");
        } else {
            let _ = writeln!(s, "scale at theta_i_deg {} = {sc:.5e}", deg(*t));
        }
    }
    let _ = writeln!(
        s,
        "chi2 = {} for {} degrees of freedom ({} points)",
        fixed(fit.chi2, 3),
        fit.dof,
        fit.points
    );
    s
}
