//! What a paint fit or comparison reports, shared by the command-line tool and `analyze`:
//! its JSON, its summary lines, the per-point table, and what its plots show.
//!
//! Conventions: angles in degrees (reports are read by people), BRDFs in sr⁻¹, residuals
//! `log10(model/measured)`. A number JSON cannot hold (an uncertainty that was not
//! estimated) is `null`.

use serde_json::{Value, json};

use super::{
    FitExtras, FitOptions, GroupResidual, Measurement, PaintComparison, PaintFit, Point, Region,
};
use crate::PipelineError;
use crate::chart::{Chart, Series, Style};

/// The targets of the real-paints check (issue: rms `log10` residuals), for reports:
/// `(near, far)` at incidences up to 60°, both at 75°, and out of the plane overall.
pub const TARGETS: ((f64, f64), f64, f64) = ((0.06, 0.12), 0.2, 0.1);

/// The numbers of flake layers [`fit_and_report`] tries when it fits the number of
/// layers (`fit --paint --fit-flake-layers`, Python's `fit_paint(fit_flake_layers=True)`):
/// 1 to this.
pub const FLAKE_LAYERS_SCANNED: u32 = 16;

/// The joint fit of `m` and its report ([`fit_json`]), as `fit --paint` gives them.
///
/// With `fit_layers`, the number of flake layers is fitted too (physics.md §12.8): the
/// whole fit at every `N` from 1 to [`FLAKE_LAYERS_SCANNED`]
/// ([`super::fit_flake_layers`]), the lowest `χ²` kept; the report then adds
/// `flake_layers` (the `N` kept) and `flake_layers_scan` (`layers` and `chi2` at each,
/// `null` where the fit failed). The fit returned is the one kept, its paint's flakes
/// piled that deep. `extras` adds parameters to the fit (the binder's tint, §12.9).
///
/// # Errors
/// [`PipelineError::Paint`] as the fit says; with `fit_layers`, also for flakes that are
/// not a free interference stack, or a fit that fails at every `N`.
pub fn fit_and_report(
    m: &Measurement,
    opts: &FitOptions,
    extras: FitExtras,
    fit_layers: bool,
) -> Result<(PaintFit, Value), PipelineError> {
    if !fit_layers {
        let fit = super::fit_with(m, opts, extras)?;
        let report = fit_json(&fit, m, opts);
        return Ok((fit, report));
    }
    let lf = super::fit_flake_layers_with(m, opts, FLAKE_LAYERS_SCANNED, extras)?;
    let kept = FitOptions {
        flake_metal: opts.flake_metal.with_layers(lf.layers)?,
        ..opts.clone()
    };
    let mut report = fit_json(&lf.fit, m, &kept);
    report["flake_layers"] = json!(lf.layers);
    report["flake_layers_scan"] = json!({
        "note": "the whole fit at each number of flake layers, the lowest chi2 kept (every N has the same parameters)",
        "layers": lf.scan.iter().map(|s| s.0).collect::<Vec<_>>(),
        "chi2": lf.scan.iter().map(|s| s.1).collect::<Vec<_>>(),
    });
    Ok((lf.fit, report))
}

/// The weighting a fit used, in words.
#[must_use]
pub fn weighting(uncertainties_given: bool) -> &'static str {
    if uncertainties_given {
        "each point by its stated uncertainty: residual (ln model - ln measured)/(u/measured)"
    } else {
        "relative: every point weighs the same in ln (no uncertainty columns), residual ln model - ln measured"
    }
}

/// The residual groups as JSON.
#[must_use]
pub fn groups_json(groups: &[GroupResidual]) -> Value {
    Value::Array(
        groups
            .iter()
            .map(|g| {
                json!({
                    "plane": if g.theta_i.is_some() { "in" } else { "out" },
                    "theta_i_deg": g.theta_i.map(|t| shortest(t.to_degrees())),
                    "region": g.region.name(),
                    "points": g.points,
                    "rms_log10": g.rms_log10,
                    "mean_log10": g.mean_log10,
                    "target_rms_log10": target_of(g),
                })
            })
            .collect(),
    )
}

/// The fit's report (the `"fit"` section of the parameter file, and `--json`).
#[must_use]
pub fn fit_json(fit: &PaintFit, m: &Measurement, opts: &FitOptions) -> Value {
    let est = |e: &super::Estimate| json!({"name": e.name, "value": e.value, "std": e.std, "lo95": e.lo95, "hi95": e.hi95});
    let mut report = json!({
        "file": m.file,
        "family": fit.family.name(),
        "families": fit.candidates.iter().map(|c| json!({
            "family": c.family.name(),
            "chi2": c.evidence.chi2,
            "parameters": c.evidence.parameters,
            "aic": c.evidence.aic,
            "bic": c.evidence.bic,
        })).collect::<Vec<_>>(),
        "criterion": "lowest BIC among the families fitted",
        "points": fit.points.len(),
        "parameters": fit.evidence.parameters,
        "dof": fit.dof,
        "chi2": fit.evidence.chi2,
        "aic": fit.evidence.aic,
        "bic": fit.evidence.bic,
        "weighting": weighting(fit.uncertainties_given),
        "uncertainty_basis": fit.uncertainty_basis.describe(),
        "uncertainty_scale": fit.uncertainty_scale,
        "iterations": fit.iterations,
        "selection": selection_json(&opts.selection),
        "coat_index_fitted": opts.fit_n,
        "haze_fitted": opts.haze,
        "smoothing": opts.smoothing,
        "coverage": {
            "used": fit.coverage.used,
            "min": fit.coverage.min,
            "max": fit.coverage.max,
            "given": fit.coverage.given,
            "note": "the BRDF fixes coverage*flake_scale and (1-coverage)^2*base_albedo only; min keeps every flake scale <= 1, max every base albedo <= 1",
        },
        "fitted": fit.fitted.iter().map(est).collect::<Vec<_>>(),
        "correlation": {
            "names": fit.fitted.iter().map(|e| e.name.clone()).collect::<Vec<_>>(),
            "matrix": fit.correlation,
        },
        "physical": fit.physical.iter().map(est).collect::<Vec<_>>(),
        "residuals": groups_json(&fit.groups),
        "worst_ratio_to_target": worst_ratio(&fit.groups),
        "warnings": fit.warnings.iter().map(ToString::to_string).collect::<Vec<_>>(),
    });
    // A fitted binder tint (physics.md §12.9), only when fitted (other reports keep
    // their keys); the tints themselves are in `fitted` and `physical`.
    if fit.tint_fitted {
        report["tint_fitted"] = json!(true);
    }
    // Piled flakes (physics.md §12.8), only when piled (other reports keep their keys).
    if opts.flake_metal.layers() > 1 {
        report["flake_layers"] = json!(opts.flake_metal.layers());
    }
    // A fitted stack thickness: the layers, the range and the scan that started the fit
    // (physics.md §12.7), only when there is one (other reports keep their keys).
    if let (Some(t), Some(scan)) = (&opts.thickness, &fit.thickness_scan) {
        report["thickness"] = json!({
            "layers": t.layers,
            "range_nm": [t.range_nm.0, t.range_nm.1],
            "scan": {
                "note": "chi2 at each thickness with the shape and coat of a Trowbridge-Reitz fit at the spec's thickness held and the channel amplitudes refitted; its minimum started the joint fit",
                "thickness_nm": scan.iter().map(|p| p.0).collect::<Vec<_>>(),
                "chi2": scan.iter().map(|p| if p.1.is_finite() { json!(p.1) } else { Value::Null }).collect::<Vec<_>>(),
            },
        });
    }
    report
}

/// The selection as JSON.
#[must_use]
pub fn selection_json(sel: &super::Selection) -> Value {
    json!({
        "aspecular_deg": [shortest(sel.aspecular.0.to_degrees()), shortest(sel.aspecular.1.to_degrees())],
        "max_theta_r_deg": shortest(sel.max_theta_r.to_degrees()),
        "min_value_per_sr": sel.min_value,
    })
}

/// A comparison's report.
#[must_use]
pub fn comparison_json(c: &PaintComparison, m: &Measurement, sel: &super::Selection) -> Value {
    json!({
        "file": m.file,
        "points": c.points.len(),
        "selection": selection_json(sel),
        "residuals": groups_json(&c.groups),
        "worst_ratio_to_target": worst_ratio(&c.groups),
    })
}

/// A group's target rms `log10` ([`TARGETS`]): near and far in the plane (the 75° one
/// above 67.5°), and out of the plane overall; `None` for the groups with no target
/// (specular, out of plane by region).
#[must_use]
pub fn target_of(g: &GroupResidual) -> Option<f64> {
    let ((near, far), at75, oop) = TARGETS;
    match (g.theta_i, g.region) {
        (Some(t), Region::Near) if t.to_degrees() <= 67.5 => Some(near),
        (Some(t), Region::Far) if t.to_degrees() <= 67.5 => Some(far),
        (Some(_), Region::Near | Region::Far) => Some(at75),
        (None, Region::All) => Some(oop),
        _ => None,
    }
}

/// The group table as lines of text (one per group, the target where one applies).
#[must_use]
pub fn groups_text(groups: &[GroupResidual]) -> Vec<String> {
    groups
        .iter()
        .map(|g| {
            let plane = match (g.theta_i, g.region) {
                (Some(t), _) => format!("in plane, theta_i {:>5.1}", t.to_degrees()),
                (None, Region::All) => "out of plane, all      ".into(),
                (None, _) => "out of plane           ".into(),
            };
            format!(
                "{plane} {:<8} {:>5} points  rms log10 {:.3}  mean {:+.3}{}",
                g.region.name(),
                g.points,
                g.rms_log10,
                g.mean_log10,
                target_of(g).map_or(String::new(), |t| format!("  (target {t})"))
            )
        })
        .collect()
}

/// The largest ratio of a group's rms `log10` to its target ([`target_of`]; the measure
/// of the real-paints check, below 1 when every target is met).
#[must_use]
pub fn worst_ratio(groups: &[GroupResidual]) -> f64 {
    groups
        .iter()
        .filter_map(|g| target_of(g).map(|t| g.rms_log10 / t))
        .fold(0.0, f64::max)
}

/// The per-point table: `theta_i_deg, theta_r_deg, phi_r_deg, channel, measured_per_sr,
/// model_per_sr, log10_residual`, as CSV text.
#[must_use]
pub fn points_csv(m: &Measurement, points: &[Point], model: &[f64]) -> String {
    let mut out = String::from(
        "theta_i_deg,theta_r_deg,phi_r_deg,channel,measured_per_sr,model_per_sr,log10_residual\n",
    );
    for (p, v) in points.iter().zip(model) {
        let o = &m.rows[p.row];
        out.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            shortest(o.theta_i.to_degrees()),
            shortest(o.theta_r.to_degrees()),
            shortest(o.phi_r.to_degrees()),
            m.channels[p.channel].name,
            p.value,
            v,
            (v / p.value).log10()
        ));
    }
    out
}

/// Degrees read back from radians, rounded to 12 significant digits (a table's
/// `30` is `29.999999999999996` after the round trip).
fn shortest(deg: f64) -> f64 {
    let r = (deg * 1e9).round() / 1e9;
    if (r - deg).abs() < 1e-9 { r } else { deg }
}

/// The in-plane chart of one incidence: measured points and the model as a line, per
/// channel, log axis, against the signed detector angle `θs`.
#[must_use]
pub fn in_plane_chart(m: &Measurement, points: &[Point], model: &[f64], theta_i: f64) -> Chart {
    let mut series = Vec::new();
    for (k, ch) in m.channels.iter().enumerate() {
        // r, g, b in their own colours (palette: 1 red, 2 green, 0 blue).
        let colour = match ch.name.as_str() {
            "r" => 1,
            "g" => 2,
            "b" => 0,
            _ => k + 3,
        };
        let mut pts: Vec<(f64, f64, f64)> = points
            .iter()
            .zip(model)
            .filter(|(p, _)| p.channel == k)
            .filter_map(|(p, v)| {
                let o = &m.rows[p.row];
                (o.theta_i == theta_i && o.in_plane()).then(|| {
                    let ts = if o.phi_r.cos() > 0.0 {
                        -o.theta_r
                    } else {
                        o.theta_r
                    };
                    (ts.to_degrees(), p.value, *v)
                })
            })
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(Series {
            label: format!("measured {}", ch.name),
            points: pts.iter().map(|p| (p.0, p.1)).collect(),
            style: Style::Points,
            colour,
        });
        series.push(Series {
            label: format!("model {}", ch.name),
            points: pts.iter().map(|p| (p.0, p.2)).collect(),
            style: Style::Line,
            colour,
        });
    }
    Chart {
        title: format!(
            "{}: measured and paint model in the plane, θi = {:.1}°\nmodel: one parameter set for every incidence",
            m.file,
            theta_i.to_degrees()
        ),
        x_label: crate::chart::THETA_S_LABEL.into(),
        y_label: "BRDF (sr⁻¹)".into(),
        log_y: true,
        series,
    }
}

/// One panel of a residual map: the incidence (radians) and its detectors'
/// `(θr, φr, log10(model/measured))` in degrees and decades ([`residual_map`]).
pub type ResidualPanel = (f64, Vec<(f64, f64, f64)>);

/// Out-of-plane residuals of one incidence, for a map: `(θr, φr, log10(model/measured))`
/// in degrees, averaged over the channels.
#[must_use]
pub fn residual_map(
    m: &Measurement,
    points: &[Point],
    model: &[f64],
    theta_i: f64,
) -> Vec<(f64, f64, f64)> {
    let mut cells: Vec<(f64, f64, f64, usize)> = Vec::new();
    for (p, v) in points.iter().zip(model) {
        let o = &m.rows[p.row];
        if o.theta_i != theta_i || o.in_plane() {
            continue;
        }
        let r = (v / p.value).log10();
        let (tr, pr) = (o.theta_r.to_degrees(), o.phi_r.to_degrees());
        match cells.iter_mut().find(|c| c.0 == tr && c.1 == pr) {
            Some(c) => {
                c.2 += r;
                c.3 += 1;
            }
            None => cells.push((tr, pr, r, 1)),
        }
    }
    cells
        .into_iter()
        .map(|(a, b, s, n)| (a, b, s / n as f64))
        .collect()
}

/// The summary lines of a fit for a terminal.
#[must_use]
pub fn fit_text(fit: &PaintFit) -> Vec<String> {
    let mut lines = Vec::new();
    lines.push(format!(
        "paint fit: {} points, {} parameters, family {} (lowest BIC of {})",
        fit.points.len(),
        fit.evidence.parameters,
        fit.family.name(),
        fit.candidates
            .iter()
            .map(|c| format!("{} {:.1}", c.family.name(), c.evidence.bic))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    lines.push(format!(
        "chi2 = {:.4} for {} degrees of freedom; AIC {:.1}, BIC {:.1}; uncertainties: {}",
        fit.evidence.chi2,
        fit.dof,
        fit.evidence.aic,
        fit.evidence.bic,
        fit.uncertainty_basis.describe()
    ));
    for e in &fit.physical {
        lines.push(format!(
            "{:<24} = {:<12.6} ± {:<10.3e} (95 %: {:.6} .. {:.6})",
            e.name, e.value, e.std, e.lo95, e.hi95
        ));
    }
    lines.push(format!(
        "coverage {:.4} ({}; the data allow {:.4} .. {:.4})",
        fit.coverage.used,
        if fit.coverage.given {
            "given"
        } else {
            "middle of the interval"
        },
        fit.coverage.min,
        fit.coverage.max
    ));
    lines.push("rms log10(model/measured) by region:".into());
    lines.extend(
        groups_text(&fit.groups)
            .into_iter()
            .map(|l| format!("  {l}")),
    );
    lines.push(format!(
        "worst group / target = {:.2} (<= 1 meets every target)",
        worst_ratio(&fit.groups)
    ));
    lines
}
