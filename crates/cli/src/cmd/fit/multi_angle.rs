//! `fit --measured-multiangle`: the Gaussian width fitted to measured L* by the
//! spectral distribution model, and its result as JSON and for the terminal.

use std::fmt::Write as _;

use anyhow::{Context, bail};
use serde_json::{Value, json};

use super::Args;
use crate::flags::DEFAULT_WAVELENGTHS;
use crate::output::{Plan, print, print_json, warn};
use crate::parse::{deg, deg_num, fixed};

/// `--measured-multiangle`: the Gaussian width (with a common scale, and `n` with
/// --fit-n) fitted to the measured L* by the spectral distribution model.
pub(super) fn multi_angle(args: &Args, plan: Plan) -> anyhow::Result<()> {
    let Some(path) = &args.measured.measured_multiangle else {
        bail!("--measured-multiangle FILE is needed here");
    };
    if args.nonparametric {
        bail!("--nonparametric fits a curve; the L* fit of --measured-multiangle is Gaussian");
    }
    if args.out.is_some() {
        bail!("--out writes the --nonparametric histogram; the L* fit reports on stdout (--json)");
    }
    if let Some(region) = &args.region {
        bail!(
            "--region {}: the L* fit uses every measured geometry (leave out the ones you do not want in the file)",
            region
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
            "aperture_deg": args.measured.optics.aperture_deg(),
            "spectral": coating_echo,
            "wavelengths_nm": args.spectral.wavelengths_text(DEFAULT_WAVELENGTHS),
            "colorimetry": args.colour.echo(),
        });
        print_json(&lightness_json(&fit, inputs))
    } else {
        print(&lightness_text(&fit))
    }
}

/// The L* fit as JSON (`--json`), with the inputs echoed.
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
