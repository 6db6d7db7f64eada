//! `flakescatter fit`: the flake orientation distribution from a measured curve.

mod multi_angle;
pub mod paint;
mod report;

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::fit::{FitSetup, fit_gaussian, fit_nonparametric};
use flakescatter::io::flakes::write_histogram_bins;
use serde_json::json;

use crate::flags::{ColourArgs, MeasuredArgs, SpectralArgs};
use crate::output::{Kind, Plan, print, print_json, warn};
use crate::parse::{angles, deg, deg_num, shortest};
use multi_angle::multi_angle;
use report::{gaussian_json, gaussian_text, nonparametric_json};

/// Fit the flake orientation distribution to a measured curve.
///
/// Default: a Gaussian p~ — its hwhm (with a standard uncertainty), the vertical scale
/// (per incidence, or --common-scale) and, with --fit-n, the clear-coat index — by
/// least squares on log values of the points 5°–40° from specular (the specular peak is
/// excluded). With --nonparametric: a tabulated p~ on --bins by regularised
/// non-negative least squares (the paper's "estimate the distribution that can give rise
/// to a measured reflectance curve"); --out then writes it as a histogram CSV that
/// `model --orientation table --distribution` reads. --theta-i/--theta-s select the
/// measured points used. With --paint: a paint (clear coat, flakes, base) fitted to a
/// BRDF table with geometry and channels, every incidence and row at once.
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
    /// Aspecular range of the points used, degrees, `LO:HI` (default 5:40; 2:180 with
    /// --paint).
    #[arg(long, value_name = "LO:HI", allow_hyphen_values = true)]
    pub region: Option<String>,
    /// Estimate a tabulated p~ instead of a Gaussian.
    #[arg(long)]
    pub nonparametric: bool,
    /// --nonparametric: bin edges of the tabulated p~, degrees (list or range).
    #[arg(
        long,
        value_name = "LIST",
        default_value = "0:30:2",
        allow_hyphen_values = true
    )]
    pub bins: String,
    /// --nonparametric: smoothness weight of the estimate (second differences of p~,
    /// relative to the data), a finite number >= 0.
    #[arg(
        long,
        value_name = "X",
        default_value_t = 0.05,
        value_parser = non_negative,
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
    #[command(flatten)]
    pub paint: paint::PaintArgs,
}

/// A finite number >= 0, for clap (`--lambda -1` is refused whatever the mode).
fn non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err("expected a finite number >= 0".into()),
    }
}

/// `--region LO:HI` in radians (default 5:40).
fn region(text: Option<&str>) -> anyhow::Result<(f64, f64)> {
    let text = text.unwrap_or("5:40");
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
    if let Some(flag) = args.paint.stray() {
        bail!("{flag} applies to --paint");
    }
    if args.paint.paint {
        if args.measured.measured_multiangle.is_some() {
            bail!("--paint fits a BRDF table given with --measured, not --measured-multiangle");
        }
        if args.spectral.any_besides_stack() || args.colour.any() {
            bail!(
                "the spectral and colour flags do not apply to --paint (but --flake-stack and --flake-core do)"
            );
        }
        if args.json {
            plan.stdout("--json");
        } else {
            plan.stdout("the fit's summary");
        }
        return paint::run(&args, plan);
    }
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
    let region = region(args.region.as_deref())?;
    let edges = if args.nonparametric {
        if args.fit_n {
            bail!("--fit-n applies to the Gaussian fit, not --nonparametric");
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
        "aperture_deg": args.measured.optics.aperture_deg(),
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
