//! `summary.json`: every number of the report with its uncertainty, the inputs with
//! their SHA-256, the settings, the work counter, the warnings and the file list.

use serde_json::{Value, json};

use super::Analysis;
use crate::analyze::format::{ci_deg, deg};
use crate::analyze::settings::in_plane_angles;
use crate::analyze::{FailedStatistic, OutFile, Work};
use crate::pooled_json;

/// `summary.json` as a value; `files` are the report's other files so far.
pub(super) fn summary(
    a: &Analysis,
    work: Work,
    warnings: &[String],
    map_info: Vec<Value>,
    paint_summary: Value,
    files: &[OutFile],
) -> Value {
    let (input, instrument, coating, models, measured_hashes, failed, build) = (
        a.input,
        a.instrument,
        a.coating,
        a.models,
        a.measured_hashes,
        a.failed,
        a.build,
    );
    let m = &input.manifest;
    let ts_list = in_plane_angles(instrument);
    let statistics = statistics(a);
    let comparison_json = comparison_json(a);
    let fit_json = fit_json(a);
    let multi_json = multi_json(a);
    let file_list: Vec<String> = ["index.md", "index.html", "summary.json"]
        .iter()
        .map(|s| (*s).to_owned())
        .chain(files.iter().map(|f| f.path.clone()))
        .collect();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "build": build,
        "sample": input.name,
        "manifest": input.file.display().to_string(),
        "description": m.description,
        "inputs": {
            "maps": map_info,
            "measured": input.measured.iter().zip(measured_hashes).map(|(f, h)| json!({"file": f.display().to_string(), "sha256": h})).collect::<Vec<_>>(),
            "settings": m,
        },
        "instrument": {
            "theta_i_deg": instrument.theta_i().iter().map(|t| deg(*t)).collect::<Vec<_>>(),
            "detectors": ts_list.len(),
            "aperture_deg": deg(instrument.aperture()),
            "n": coating.n,
            "clearcoat": m.models.clearcoat,
        },
        "statistics": statistics,
        "models": models.curves.iter().map(|c| json!({"model": c.label, "source": c.source, "rows": c.rows.len()})).collect::<Vec<_>>(),
        "model_failures": models.failures.iter().map(|(a, b)| json!({"model": a, "error": b})).collect::<Vec<_>>(),
        "comparison": comparison_json,
        "fit": fit_json,
        "multi_angle": multi_json,
        "paint": paint_summary,
        "work": {
            "maps": work.maps,
            "maps_segmented": work.maps_segmented,
            "maps_reused": work.maps_reused,
            "distribution_runs": work.distribution_runs,
            "topographic_runs": work.topographic_runs,
            "fits": work.fits,
            "multi_angle_runs": work.multi_angle_runs,
            "models_reused": work.models_reused,
            "paint_fits": work.paint_fits,
            "model_work": work.model_work(),
        },
        "failed_statistics": failed.iter().map(FailedStatistic::to_json).collect::<Vec<_>>(),
        "warnings": warnings,
        "files": file_list,
        "units": {
            "hwhm_deg": "degree, half-width at half-maximum of the Gaussian p~ (the paper's w)",
            "hwhm_ci95_deg": "degree, 95 % interval; null for an infinite end",
            "area_um2": "µm², true (visible) flake area",
            "scale": "fitted vertical scale of the model (measured ≈ scale × model 5°–40° from specular)",
            "rms_log10": "root mean square of log10(measured) − log10(scaled model) in the region (0.1 = a factor 1.26)",
            "brdf_per_sr": "1/sr",
            "lightness": "CIE L* of the reflectance factor at one wavelength",
        },
    })
}

/// `statistics`: the pooled width with both intervals, the maps, the pixel level.
fn statistics(a: &Analysis) -> Value {
    let stats = a.stats;
    let p = &stats.pooled;
    let names = &a.input.map_names;
    let flake = &p.flake_level;
    let pixel_failure = a
        .failed
        .iter()
        .find(|f| f.statistic == "statistics.pixel_level");
    json!({
        "flakes": stats.histogram.flakes(),
        "total_area_um2": stats.histogram.total_area_um2(),
        "hwhm_deg": flake.hwhm().to_degrees(),
        "sigma_deg": flake.sigma.to_degrees(),
        "flake_level": {
            "hwhm_ci95_deg": ci_deg(flake.hwhm_ci95()),
            "method": flake.ci_method.describe(),
            "effective_flakes": flake.effective_n,
        },
        "map_level": pooled_json::map_level(p),
        "quoted_interval": pooled_json::quoted_interval(p),
        "heterogeneity": pooled_json::heterogeneity(p),
        "z_bound": p.z_bound,
        "histogram_fit_hwhm_deg": stats.histogram_fit.as_ref().ok().map(|h| h.hwhm().to_degrees()),
        "histogram_fit_error": stats.histogram_fit.as_ref().err(),
        "maps": pooled_json::maps(p, names),
        "pixel_level": stats.pixel.as_ref().map_or_else(|| pixel_failure.map(|f| json!({"error": f.error})), |px| Some(json!({
            "usable_pixels": px.orientation.tilts.usable_pixels,
            "hwhm_deg": px.orientation.width.map(|w| w.hwhm().to_degrees()),
            "hwhm_ci95_deg": px.orientation.width.map(|w| ci_deg(w.hwhm_ci95())),
            "histogram_fit_hwhm_deg": px.orientation.histogram_fit.as_ref().ok().map(|h| h.hwhm().to_degrees()),
            "histogram_fit_error": px.orientation.histogram_fit.as_ref().err(),
            "inside_flakes_hwhm_deg": px.sources.as_ref().ok().map(|w| w.inside.hwhm().to_degrees()),
            "within_flake_sigma_deg": px.sources.as_ref().ok().and_then(|w| w.within_flake_sigma).map(f64::to_degrees),
            "error": px.sources.as_ref().err(),
        }))),
    })
}

/// `comparison`: per model and incidence the scale and the residuals by region.
fn comparison_json(a: &Analysis) -> Vec<Value> {
    a.comparisons
        .iter()
        .flat_map(|(label, cs)| {
            cs.iter().map(move |c| {
                json!({
                    "model": label,
                    "theta_i_deg": deg(c.theta_i),
                    "scale": c.scale,
                    "regions": c.regions_json(),
                })
            })
        })
        .collect()
}

/// `fit`: the width fitted to the measured curve, or why it failed.
fn fit_json(a: &Analysis) -> Option<Value> {
    let models = a.models;
    models.fit.as_ref().map(|f| match f {
        Ok(f) => json!({
            "hwhm_deg": f.hwhm.to_degrees(),
            "hwhm_std_deg": f.hwhm_std.to_degrees(),
            "scales": f.scales.iter().map(|(t, s)| json!({"theta_i_deg": if t.is_finite() { Some(deg(*t)) } else { None }, "scale": s})).collect::<Vec<_>>(),
            "chi2": f.chi2,
            "dof": f.dof,
            "points": f.points,
            "iterations": f.iterations,
            "uncertainty_basis": f.uncertainty_basis,
            "uncertainty_scale": f.uncertainty_scale,
            "warnings": f.warnings,
        }),
        Err(e) => json!({"error": e}),
    })
}

/// `multi_angle`: the multi-angle readout, or why it failed.
fn multi_json(a: &Analysis) -> Option<Value> {
    let models = a.models;
    models.multi_angle.as_ref().map(|r| match r {
        Ok(r) => json!({
            "theta_i_deg": deg(r.theta_i),
            "readouts": r.readouts.iter().map(|(a, rf, l)| json!({
                "aspecular_deg": deg(*a), "reflectance_factor": rf, "lightness": l,
            })).collect::<Vec<_>>(),
            "flop_index": r.flop_index,
            "note": "distribution model with the pooled width; single-wavelength lightness (multiangle module docs)",
        }),
        Err(e) => json!({"error": e}),
    })
}
