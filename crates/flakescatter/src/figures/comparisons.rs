//! Figs. 9 and 10: the distribution model and the topographic model of the fixture maps
//! against the synthetic measured curve, with per-region residuals.

use std::fmt::Write as _;

use flakescatter_io::measured::MeasuredCurve;
use flakescatter_stats::heightmap::HeightMap;
use serde_json::{Value, json};

use super::paper::rows_at;
use super::{
    APERTURE_DEG, CUTOFF, Ctx, FIXTURES, FiguresError, INCIDENCES, Index, SYNTHETIC_NOTE, deg,
    gaussian, micro, sig,
};
use crate::PipelineError;
use crate::chart::{Chart, Series, Style, THETA_S_LABEL};
use crate::compare::{
    IncidenceComparison, MeasuredKind, ModelPoint, Region, compare, distribution_points,
};
use crate::pipeline::{Coating, TopoSettings, topographic_curves};

/// The measured curve in the `compare --measured` format.
pub(super) fn measured_csv(curve: &MeasuredCurve) -> String {
    let mut s = String::from("theta_i_deg,theta_s_deg,value,uncertainty\n");
    for p in &curve.points {
        let _ = writeln!(
            s,
            "{},{},{:.9e},{:.3e}",
            deg(p.theta_i),
            deg(p.theta_s),
            p.value,
            p.uncertainty.unwrap_or(0.0)
        );
    }
    s
}

/// JSON of one comparison row (scale to `JSON_DIGITS` significant digits, log10
/// residuals to 1e-6).
fn comparison_json(model: &str, c: &IncidenceComparison, dropped: usize) -> Value {
    json!({
        "model": model,
        "theta_i_deg": deg(c.theta_i),
        "scale": sig(c.scale),
        "points": c.points.len(),
        "points_without_model_rays": dropped,
        "regions": c.regions.iter().map(|r| json!({
            "region": r.region.name(),
            "points": r.points,
            "rms_log10": r.rms_log10.map(micro),
            "mean_log10": r.mean_log10.map(micro),
        })).collect::<Vec<_>>(),
    })
}

/// Measured points of one incidence as `(θs°, value)`.
fn measured_series(curve: &MeasuredCurve, ti_deg: f64) -> Series {
    Series {
        label: "\"measured\" (synthetic)".into(),
        points: curve
            .points
            .iter()
            .filter(|p| (p.theta_i.to_degrees() - ti_deg).abs() < 1e-9)
            .map(|p| (deg(p.theta_s), p.value))
            .collect(),
        style: Style::Points,
        colour: 7,
    }
}

/// Fig. 9: distribution model, hwhm 3° and 6°, clear coat on, scaled to the measured curve.
pub(super) fn fig9(
    ctx: &Ctx,
    measured: &MeasuredCurve,
    report: &mut super::Report,
    index: &mut Index,
) -> Result<Value, FiguresError> {
    let coating = Coating::default();
    let settings = ctx.settings(true);
    let aperture = APERTURE_DEG.to_radians();
    let widths = [3.0, 6.0];
    let mut results = Vec::new();
    for &w in &widths {
        let o = gaussian(w)?;
        let model = |ti: f64, ts: &[f64]| -> Result<Vec<ModelPoint>, PipelineError> {
            distribution_points(&coating, &settings, aperture, &o, ti, ts)
        };
        results.push(compare(measured, MeasuredKind::Brdf, &model)?);
    }
    let mut csv = String::from(
        "theta_i_deg,theta_s_deg,region,measured_brdf_per_sr,model_hwhm3_scaled_brdf_per_sr,model_hwhm6_scaled_brdf_per_sr\n",
    );
    let mut json_rows = Vec::new();
    let mut files = vec!["fig9.csv".to_string()];
    for (a, b) in results[0].iter().zip(&results[1]) {
        let ti = a.theta_i.to_degrees().round();
        for (p, q) in a.points.iter().zip(&b.points) {
            let _ = writeln!(
                csv,
                "{ti},{},{},{:.9e},{:.9e},{:.9e}",
                deg(p.theta_s),
                p.region.name(),
                p.measured,
                p.model,
                q.model
            );
        }
        let mut series = Vec::new();
        for (c, (r, w)) in [(a, 3.0), (b, 6.0)].into_iter().enumerate() {
            json_rows.push(comparison_json(&format!("distribution, hwhm {w}°"), r, 0));
            let near = r
                .regions
                .iter()
                .find(|x| x.region.name() == "near-specular");
            series.push(Series {
                label: format!(
                    "model hwhm {w}° (× {:.3}; rms near {:.2})",
                    r.scale,
                    near.and_then(|x| x.rms_log10).unwrap_or(f64::NAN)
                ),
                points: r.points.iter().map(|p| (deg(p.theta_s), p.model)).collect(),
                style: if c == 0 { Style::Line } else { Style::Dashed },
                colour: c,
            });
        }
        series.push(measured_series(measured, ti));
        let stem = format!("fig9_theta{ti}");
        report.chart(
            &stem,
            Chart {
                title: format!(
                    "Fig. 9 analogue: distribution model (clear coat on) vs \"measured\", θi = {ti}°\n{SYNTHETIC_NOTE}"
                ),
                x_label: THETA_S_LABEL.into(),
                y_label: "BRDF (1/sr), models scaled 5°–40° from specular".into(),
                log_y: true,
                series,
            },
        );
        files.push(format!("{stem}.svg"));
        files.push(format!("{stem}.png"));
    }
    report.text("fig9.csv", csv);
    index.add(
        "Fig. 9 — distribution model with hwhm 3° and 6° against the \"measured\" curve",
        &files,
        "The distribution model (clear coat on: its specular reflection adds the narrow \
         peak, physics.md §6) for Gaussian p̃ of hwhm 3° (solid; the width of the flake \
         histograms, as in the paper) and 6° (dashed), each multiplied by a scale fitted \
         to the measured curve 5°–40° from specular (`flakescatter compare`'s rule), on a \
         log axis, at θi = 30° and 60°. The dots are the SYNTHETIC measured curve \
         (`measured.csv`, see above): its flakes have hwhm 3° but rough surfaces, so — as \
         in the paper — the 3° model is too narrow and the 6° model follows the \
         near-specular fall-off better. `fig9.csv`: `theta_i_deg, theta_s_deg, region` \
         (specular / near-specular / far), `measured_brdf_per_sr` and both scaled models \
         (sr⁻¹). Scales and per-region residuals: table below and `comparison.json`."
            .into(),
    );
    Ok(Value::Array(json_rows))
}

/// Fig. 10: topographic model of each fixture map (`masked`, clear coat on) against the
/// measured curve.
pub(super) fn fig10(
    ctx: &Ctx,
    masked: &[HeightMap],
    measured: &MeasuredCurve,
    report: &mut super::Report,
    index: &mut Index,
    progress: &dyn Fn(&str),
) -> Result<Value, FiguresError> {
    let instrument = ctx.instrument()?;
    let settings = ctx.settings(true);
    let mut json_rows = Vec::new();
    let mut per_incidence: Vec<Vec<Series>> = vec![Vec::new(); INCIDENCES.len()];
    let mut csv = String::from(
        "map,theta_i_deg,theta_s_deg,region,measured_brdf_per_sr,model_scaled_brdf_per_sr,model_scaled_std_err_per_sr,rays,scale\n",
    );
    let mut notes = Vec::new();
    for (c, ((stem, _, label), map)) in FIXTURES.iter().zip(masked).enumerate() {
        progress(&format!("  topographic model of {stem}"));
        let (curves, topo) = topographic_curves(
            &Coating::default(),
            &instrument,
            &settings,
            &TopoSettings::default(),
            &[map],
            &|_, _| {},
        )?;
        notes.push(format!(
            "`{stem}`: {} usable pixels of {}",
            topo.usable_pixels, topo.pixels
        ));
        // The model at the measured points; detectors where no ray arrived are left out of
        // the comparison (a zero cannot be compared on a log scale) and counted.
        let lookup = |ti: f64, ts: f64| {
            curves.rows.iter().find(|r| {
                (r.theta_i - ti).abs() < 1e-9
                    && (ctx.theta_s_deg[r.detector].to_radians() - ts).abs() < 1e-9
            })
        };
        let mut kept = MeasuredCurve {
            file: measured.file.clone(),
            points: measured
                .points
                .iter()
                .filter(|p| lookup(p.theta_i, p.theta_s).is_some_and(|r| r.brdf > 0.0))
                .copied()
                .collect(),
        };
        // With ~70 flakes a map may send no ray at all 5°–40° from specular at some
        // incidence (the smooth fixture's terraces send light to specular or far from
        // it): there is no scale to fit, so that incidence is not shown for this map.
        for ti in kept.incidences() {
            let fittable = kept
                .points
                .iter()
                .any(|p| p.theta_i == ti && Region::of(ti, p.theta_s) == Region::NearSpecular);
            if !fittable {
                kept.points.retain(|p| p.theta_i != ti);
                notes.push(format!(
                    "`{stem}` at θi = {}°: no ray 5°–40° from specular, so no scale to fit; not shown",
                    deg(ti)
                ));
            }
        }
        if kept.points.is_empty() {
            continue;
        }
        let model = |ti: f64, ts: &[f64]| -> Result<Vec<ModelPoint>, PipelineError> {
            ts.iter()
                .map(|&t| {
                    lookup(ti, t)
                        .map(|r| {
                            ModelPoint::from_row(
                                r.brdf,
                                r.relative,
                                r.reflectance,
                                APERTURE_DEG.to_radians(),
                            )
                        })
                        .ok_or_else(|| {
                            PipelineError::Measurement(format!(
                                "no model detector at θs = {:.3}°",
                                t.to_degrees()
                            ))
                        })
                })
                .collect()
        };
        let result = compare(&kept, MeasuredKind::Brdf, &model)?;
        for r in &result {
            let ti = r.theta_i.to_degrees().round();
            let k = INCIDENCES
                .iter()
                .position(|&d| d == ti)
                .ok_or(FiguresError::Figure {
                    figure: "Fig. 10",
                    message: "compare returned an incidence the figure was not asked for".into(),
                })?;
            let total = measured
                .points
                .iter()
                .filter(|p| (p.theta_i - r.theta_i).abs() < 1e-12)
                .count();
            let dropped = total - r.points.len();
            json_rows.push(comparison_json(&format!("topographic, {stem}"), r, dropped));
            for p in &r.points {
                let row = lookup(p.theta_i, p.theta_s).copied();
                // Empty when the map's tiles cannot give a standard error.
                let se = row
                    .and_then(|x| x.std_err)
                    .map_or_else(String::new, |e| format!("{:.3e}", e * r.scale));
                let _ = writeln!(
                    csv,
                    "{stem},{ti},{},{},{:.9e},{:.9e},{se},{},{:.6e}",
                    deg(p.theta_s),
                    p.region.name(),
                    p.measured,
                    p.model,
                    row.and_then(|x| x.rays).unwrap_or(0),
                    r.scale
                );
            }
            // Every detector, zeros included: the line breaks where no ray arrived.
            let line = rows_at(&curves, ti)
                .iter()
                .map(|row| (ctx.theta_s_deg[row.detector], r.scale * row.brdf))
                .collect();
            let near = r
                .regions
                .iter()
                .find(|x| x.region.name() == "near-specular");
            per_incidence[k].push(Series {
                label: format!(
                    "{label} (× {:.3}; rms near {:.2})",
                    r.scale,
                    near.and_then(|x| x.rms_log10).unwrap_or(f64::NAN)
                ),
                points: line,
                style: Style::Line,
                colour: c,
            });
            if dropped > 0 {
                notes.push(format!(
                    "`{stem}` at θi = {ti}°: {dropped} of {total} detectors received no ray"
                ));
            }
        }
    }
    let mut files = vec!["fig10.csv".to_string()];
    for (k, mut series) in per_incidence.into_iter().enumerate() {
        let ti = INCIDENCES[k];
        series.push(measured_series(measured, ti));
        let stem = format!("fig10_theta{ti}");
        report.chart(
            &stem,
            Chart {
                title: format!(
                    "Fig. 10 analogue: topographic model of the fixture maps vs \"measured\", θi = {ti}°\n{SYNTHETIC_NOTE}. Model: ~70 flakes per map, noisy"
                ),
                x_label: THETA_S_LABEL.into(),
                y_label: "BRDF (1/sr), models scaled 5°–40° from specular".into(),
                log_y: true,
                series,
            },
        );
        files.push(format!("{stem}.svg"));
        files.push(format!("{stem}.png"));
    }
    report.text("fig10.csv", csv);
    index.add(
        "Fig. 10 — topographic model of the fixture maps against the \"measured\" curve",
        &files,
        format!(
            "The topographic model (physics.md §5: 5 × 5 least-squares normals, one ray \
             per usable pixel, clear coat on) of each shipped fixture map alone (intensity \
             cutoff {CUTOFF}), scaled to the SYNTHETIC measured curve 5°–40° from specular. \
             Each map holds only ~70 flakes, so its curve is noisy (physics.md §5: ~10⁴ \
             flakes give ~10 % rms in a small cone) and falls to zero where no flake \
             sends a ray (gaps in the lines); the standard error of each point, from the \
             spread over 32 µm tiles, is in `fig10.csv`. Detectors that received no ray \
             are left out of the comparison. The smooth fixture's 0.3 µm z steps make \
             flat terraces whose normals are exactly vertical: the huge specular peak of its \
             curve is this artefact (the paper saw the same from its microscope's \
             interpolation), on top of the clear coat's reflection. The smooth fixture \
             (hwhm 3°, flat flakes) gives a curve narrower than the rough \"measured\" \
             sample; the rough fixture is closer. {}. `fig10.csv`: `map, theta_i_deg, \
             theta_s_deg, region, measured_brdf_per_sr, model_scaled_brdf_per_sr, \
             model_scaled_std_err_per_sr` (sr⁻¹), `rays` (rays counted by the detector), \
             `scale`.",
            notes.join("; ")
        ),
    );
    Ok(Value::Array(json_rows))
}
