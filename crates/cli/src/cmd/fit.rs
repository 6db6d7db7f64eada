//! `flakescatter fit`: the flake orientation distribution from a measured curve.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::compare::{FAR_REGION, SPECULAR_REGION};
use flakescatter::fit::{FitSetup, fit_gaussian, fit_nonparametric};
use flakescatter::io::flakes::write_histogram_bins;
use serde_json::json;

use crate::cmd::compare::{MeasuredArgs, model_inputs};
use crate::instrument::{InstrumentArgs, open_out, out_is_stdout, parse_angles};

/// Fit the flake orientation distribution to a measured curve.
///
/// Default: a Gaussian p~ — its hwhm (with a standard uncertainty), the vertical scale
/// (per incidence, or --common-scale) and, with --fit-n, the clear-coat index — by
/// least squares on log values of the points 5°–40° from specular (the specular peak is
/// excluded). With --nonparametric: a tabulated p~ on --bins by regularised
/// non-negative least squares (the paper's "estimate the distribution that can give rise
/// to a measured reflectance curve"); --out then writes it as a histogram CSV that
/// `model --orientation table --distribution` reads.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub measured: MeasuredArgs,
    #[command(flatten)]
    pub instrument: InstrumentArgs,
    /// Start value of the Gaussian hwhm, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 4.0)]
    pub hwhm_start: f64,
    /// Fit the clear-coat index too (start: --n).
    #[arg(long)]
    pub fit_n: bool,
    /// One vertical scale for all incidences (absolute data of one sample) instead of one
    /// per incidence.
    #[arg(long)]
    pub common_scale: bool,
    /// Aspecular range of the points used, degrees, `LO:HI`.
    #[arg(long, value_name = "LO:HI", default_value = "5:40")]
    pub region: String,
    /// Estimate a tabulated p~ instead of a Gaussian.
    #[arg(long)]
    pub nonparametric: bool,
    /// Bin edges of the tabulated p~, degrees (list or range), for --nonparametric.
    #[arg(long, value_name = "LIST", default_value = "0:30:2")]
    pub bins: String,
    /// Smoothness weight of the non-parametric estimate (second differences of p~,
    /// relative to the data), >= 0.
    #[arg(long, value_name = "X", default_value_t = 0.05)]
    pub lambda: f64,
    /// --nonparametric: write the estimated histogram CSV (theta_lo_deg, theta_hi_deg,
    /// area_fraction, p_per_rad, p_tilde) here.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    out_is_stdout(args.out.as_deref(), args.json)?;
    let measured = args.measured.read()?;
    let coating = args.instrument.coating()?;
    let settings = args.measured.settings(&args.instrument);
    let aperture_rad = args.instrument.aperture_rad()?;
    let aperture = args.instrument.aperture;
    let region = match args
        .region
        .split_once(':')
        .map(|(a, b)| (a.trim().parse::<f64>(), b.trim().parse::<f64>()))
    {
        Some((Ok(lo), Ok(hi))) if lo >= 0.0 && hi > lo && hi < 180.0 => {
            (lo.to_radians(), hi.to_radians())
        }
        _ => bail!(
            "--region `{}`: expected LO:HI in degrees with 0 <= LO < HI (default 5:40)",
            args.region
        ),
    };
    let mut setup = FitSetup::new(coating, settings, aperture_rad, args.measured.measured_kind);
    setup.region = region;
    setup.common_scale = args.common_scale;
    let inputs = json!({
        "measured": measured.file,
        "measured_kind": args.measured.measured_kind.name(),
        "model": model_inputs(&coating, &settings),
        "aperture_deg": aperture,
        "region_deg": [region.0.to_degrees(), region.1.to_degrees()],
        "common_scale": args.common_scale,
    });
    if args.nonparametric {
        if args.fit_n {
            bail!("--fit-n applies to the Gaussian fit, not --nonparametric");
        }
        let edges_deg = parse_angles("--bins", &args.bins)?;
        if edges_deg.len() < 2
            || edges_deg.windows(2).any(|w| w[1] <= w[0])
            || edges_deg[0] < 0.0
            || edges_deg[edges_deg.len() - 1] > 90.0
        {
            bail!(
                "--bins `{}`: expected at least two increasing edges within [0, 90] degrees",
                args.bins
            );
        }
        if !(args.lambda.is_finite() && args.lambda >= 0.0) {
            bail!("--lambda {}: expected a finite number >= 0", args.lambda);
        }
        let edges: Vec<f64> = edges_deg.iter().map(|d| d.to_radians()).collect();
        let est = fit_nonparametric(&measured, &setup, &edges, args.lambda)
            .with_context(|| format!("non-parametric fit of {}", measured.file))?;
        if let Some(path) = &args.out {
            // The histogram CSV of `stats`, which `model --orientation table` reads.
            write_histogram_bins(
                open_out(path)?,
                &path.display().to_string(),
                &est.edges,
                &est.area_fractions,
            )
            .map_err(|e| anyhow::Error::new(crate::common::Failure(e.to_string())))?;
        }
        if args.json {
            let summary = json!({
                "version": env!("CARGO_PKG_VERSION"),
                "command": "fit --nonparametric",
                "inputs": inputs,
                "lambda": est.lambda,
                "points": est.points,
                "chi2_relative": est.chi2,
                "bins": est.edges.windows(2).zip(&est.area_fractions).zip(&est.p_tilde).map(|((e, f), p)| json!({
                    "theta_lo_deg": round_deg(e[0]),
                    "theta_hi_deg": round_deg(e[1]),
                    "area_fraction": f,
                    "p_tilde": p,
                })).collect::<Vec<_>>(),
                "units": {"p_tilde": "per steradian x 2 pi, normalised so that the integral of p~ sin(theta) dtheta is 1"},
            });
            println!("{}", serde_json::to_string_pretty(&summary)?);
        } else if args.out.is_none() {
            println!("theta_lo_deg,theta_hi_deg,area_fraction,p_tilde");
            for (e, (f, p)) in est
                .edges
                .windows(2)
                .zip(est.area_fractions.iter().zip(&est.p_tilde))
            {
                println!("{},{},{f:.6},{p:.6}", round_deg(e[0]), round_deg(e[1]));
            }
        }
        return Ok(());
    }
    if args.out.is_some() {
        bail!("--out writes the --nonparametric histogram; the Gaussian fit reports with --json");
    }
    if !(args.hwhm_start.is_finite() && args.hwhm_start > 0.0 && args.hwhm_start < 60.0) {
        bail!(
            "--hwhm-start {}: expected a width in (0, 60) degrees",
            args.hwhm_start
        );
    }
    let fit = fit_gaussian(&measured, &setup, args.hwhm_start.to_radians(), args.fit_n)
        .with_context(|| format!("Gaussian fit of {}", measured.file))?;
    for w in &fit.warnings {
        eprintln!("warning: {}: {w}", measured.file);
    }
    let scales: Vec<_> = fit
        .scales
        .iter()
        .map(|(t, s)| json!({"theta_i_deg": if t.is_nan() { None } else { Some(t.to_degrees()) }, "scale": s}))
        .collect();
    if args.json {
        let summary = json!({
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
            "default_region_deg": [SPECULAR_REGION.to_degrees(), FAR_REGION.to_degrees()],
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "hwhm_deg = {:.4} ± {:.4}",
            fit.hwhm.to_degrees(),
            fit.hwhm_std.to_degrees()
        );
        if let Some(s) = fit.n_std {
            println!("n = {:.4} ± {s:.4}", fit.n);
        }
        for (t, s) in &fit.scales {
            if t.is_nan() {
                println!("scale (all incidences) = {s:.5e}");
            } else {
                println!("scale at theta_i_deg {:.2} = {s:.5e}", t.to_degrees());
            }
        }
        println!(
            "chi2 = {:.3} for {} degrees of freedom ({} points)",
            fit.chi2, fit.dof, fit.points
        );
    }
    Ok(())
}

/// Degrees without float noise (`6`, not `6.000000000000001`).
fn round_deg(rad: f64) -> f64 {
    (rad.to_degrees() * 1e9).round() / 1e9
}
