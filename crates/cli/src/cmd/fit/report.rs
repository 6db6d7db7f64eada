//! `fit`'s results as JSON (`--json`) and for the terminal: the Gaussian fit and the
//! non-parametric estimate.

use std::fmt::Write as _;

use flakescatter::compare::{FAR_REGION, SPECULAR_REGION};
use flakescatter::fit::{GaussianFit, NonParametricFit};
use serde_json::{Value, json};

use crate::parse::{deg, deg_num, fixed};

/// The non-parametric estimate as JSON (`--json`), with the inputs echoed.
pub(super) fn nonparametric_json(est: &NonParametricFit, inputs: Value) -> Value {
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

/// The Gaussian fit as JSON (`--json`), with the inputs echoed.
pub(super) fn gaussian_json(fit: &GaussianFit, inputs: Value) -> Value {
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
pub(super) fn gaussian_text(fit: &GaussianFit) -> String {
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
