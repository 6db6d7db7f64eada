//! The `[paint]` part of a sample's report: the paint fitted to the sample's measured
//! BRDF table (`fit --paint`, physics.md §12), its parameters with 95 % intervals, the
//! residuals by region, plots, and the parameter file. The fit is cached under
//! `cache/paint.json`, keyed by the table's SHA-256 and the options, so that a rerun
//! recomputes only the (cheap) residuals of the cached paint.

use std::path::Path;

use serde_json::{Value, json};

use super::document::Block;
use super::manifest::PaintSection;
use super::{AnalyzeError, Content, OutFile};
use crate::compare::MeasuredKind;
use crate::paint::file::ParamsFile;
use crate::paint::report::{
    ResidualPanel, fit_json, groups_text, in_plane_chart, points_csv, residual_map, worst_ratio,
};
use crate::paint::{Family, FitOptions, Measurement, PaintComparison, Selection};

/// What the paint part adds to a report.
pub struct PaintOutcome {
    /// Files of the report (under `paint/`) and the cache file.
    pub files: Vec<OutFile>,
    /// The report's section.
    pub blocks: Vec<Block>,
    /// `summary.json`'s `"paint"`.
    pub summary: Value,
    /// Warnings of the fit.
    pub warnings: Vec<String>,
    /// Whether the fit ran (false: taken from the cache).
    pub fitted: bool,
    /// The fitted paint (what the report's preview shows).
    pub params: crate::paint_model::PaintParams,
}

/// The fit's options of a `[paint]` section.
fn options(s: &PaintSection, n: f64) -> FitOptions {
    let mut o = FitOptions::new();
    // The manifest's check has refused any other name.
    o.families = Family::choice(&s.family).unwrap_or_else(|_| Family::all());
    o.n = n;
    o.coverage = s.coverage;
    let mut sel = Selection::default();
    if let Some([lo, hi]) = s.region_deg {
        sel.aspecular = (lo.to_radians(), hi.to_radians());
    }
    if let Some(t) = s.max_theta_r_deg {
        sel.max_theta_r = t.to_radians();
    }
    if let Some(v) = s.min_value {
        sel.min_value = v;
    }
    o.selection = sel;
    o
}

/// The paint part of a sample (module docs). `file` is the resolved table, `cached`
/// the content of `cache/paint.json` if any, `n` the coating's index, `build` the
/// program build's identity (part of the key, as in [`super::analyze_sample`]).
///
/// # Errors
/// [`AnalyzeError::Input`] for a table that cannot be read (named), a fit that fails.
pub fn paint_part(
    s: &PaintSection,
    file: &Path,
    n: f64,
    cached: Option<&Value>,
    build: &str,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<PaintOutcome, AnalyzeError> {
    let sha = flakescatter_io::files::sha256_file(file)
        .map_err(|e| AnalyzeError::Input(e.to_string()))?;
    let opts = options(s, n);
    let key = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "build": build,
        "table_sha256": sha,
        "section": s,
        "n": n,
    });
    let m = crate::paint::read_measurement(file, MeasuredKind::Brdf)
        .map_err(|e| AnalyzeError::Input(e.to_string()))?;
    let reuse = cached
        .filter(|c| c["key"] == key)
        .and_then(|c| serde_json::from_value::<ParamsFile>(c["params"].clone()).ok());
    let (params_file, fitted) = match reuse {
        Some(p) => (p, false),
        None => {
            progress("paint fit to the measured table", 0, 1);
            let fit = crate::paint::fit(&m, &opts).map_err(|e| {
                AnalyzeError::Input(format!("paint fit of {}: {e}", file.display()))
            })?;
            progress("paint fit to the measured table", 1, 1);
            let report = fit_json(&fit, &m, &opts);
            (ParamsFile::new(&fit.params, Some(report)), true)
        }
    };
    let name = file.display().to_string();
    let params = params_file
        .to_params(&name)
        .map_err(|e| AnalyzeError::Input(e.to_string()))?;
    let model = crate::paint_model::PaintModel::new(params.clone())
        .map_err(|e| AnalyzeError::Input(format!("{name}: {e}")))?;
    let cmp = crate::paint::compare(&model, &m, &opts.selection)
        .map_err(|e| AnalyzeError::Input(e.to_string()))?;
    let report = params_file.fit.clone().unwrap_or(Value::Null);
    let text = params_file
        .to_json()
        .map_err(|e| AnalyzeError::Input(e.to_string()))?;

    let mut files = vec![
        OutFile {
            path: "paint/params.json".into(),
            content: Content::Text(text),
        },
        OutFile {
            path: "paint/points.csv".into(),
            content: Content::Text(points_csv(&m, &cmp.points, &cmp.model)),
        },
    ];
    let images = pictures(&m, &cmp, &name, &mut files);
    files.push(OutFile {
        path: "cache/paint.json".into(),
        content: Content::Text(
            serde_json::to_string(&json!({"key": key, "params": params_file})).unwrap_or_default(),
        ),
    });
    let mut blocks = section(&name, &report, params_file.flakes.coverage, &cmp);
    for (path, caption) in images {
        blocks.push(Block::Image(path, caption));
    }
    let warnings: Vec<String> = report["warnings"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|w| w.as_str().map(|w| format!("paint fit of {name}: {w}")))
                .collect()
        })
        .unwrap_or_default();
    Ok(PaintOutcome {
        files,
        blocks,
        summary: json!({
            "file": name,
            "sha256": sha,
            "params": "paint/params.json",
            "fit": report,
            "worst_ratio_to_target": worst_ratio(&cmp.groups),
            "reused": !fitted,
        }),
        warnings,
        fitted,
        params,
    })
}

/// The in-plane charts (one per incidence with points) and the out-of-plane residual
/// maps, added to `files`; their paths and captions for the report.
fn pictures(
    m: &Measurement,
    cmp: &PaintComparison,
    name: &str,
    files: &mut Vec<OutFile>,
) -> Vec<(String, String)> {
    let mut incidences: Vec<f64> = Vec::new();
    for p in &cmp.points {
        let t = m.rows[p.row].theta_i;
        if !incidences.contains(&t) {
            incidences.push(t);
        }
    }
    incidences.sort_by(f64::total_cmp);
    let mut images = Vec::new();
    for &t in &incidences {
        let chart = in_plane_chart(m, &cmp.points, &cmp.model, t);
        if chart.series.iter().all(|s| s.points.is_empty()) {
            continue;
        }
        let path = format!(
            "paint/in_plane_theta_i_{}.png",
            (t.to_degrees() * 1e6).round() / 1e6
        );
        images.push((
            path.clone(),
            format!(
                "Measured and fitted paint in the plane at θi = {:.1}°.",
                t.to_degrees()
            ),
        ));
        files.push(OutFile {
            path,
            content: Content::Chart(chart),
        });
    }
    let maps: Vec<ResidualPanel> = incidences
        .iter()
        .map(|&t| (t, residual_map(m, &cmp.points, &cmp.model, t)))
        .filter(|(_, c)| !c.is_empty())
        .collect();
    if !maps.is_empty() {
        let path = "paint/out_of_plane_residuals.png".to_string();
        images.push((
            path.clone(),
            "Out-of-plane residuals log10(model/measured) per incidence.".into(),
        ));
        files.push(OutFile {
            path,
            content: Content::ResidualMaps(maps, name.to_string()),
        });
    }
    images
}

/// The report's section: what was fitted, the physical parameters with their intervals
/// (from the fit's JSON `report`), and the residuals by region of the comparison.
fn section(name: &str, report: &Value, coverage: f64, cmp: &PaintComparison) -> Vec<Block> {
    let mut blocks = vec![
        Block::Heading(2, "Paint fitted to the measured BRDF table".into()),
        Block::Para(format!(
            "`{name}`: one paint (clear coat, flakes, base; physics.md §12) for every incidence, row and channel; family `{}` (the lowest BIC of those fitted), {} points, chi2/dof {}; {}. Coverage {:.3} ({}; the table allows {:.3} to {:.3}: it fixes only coverage × flake scale and (1 − coverage)² × base albedo).",
            report["family"].as_str().unwrap_or("?"),
            cmp.points.len(),
            fmt(report["chi2"]
                .as_f64()
                .zip(report["dof"].as_f64())
                .map(|(c, d)| c / d)),
            report["weighting"].as_str().unwrap_or(""),
            coverage,
            if report["coverage"]["given"].as_bool() == Some(true) {
                "given"
            } else {
                "the middle of the interval"
            },
            report["coverage"]["min"].as_f64().unwrap_or(f64::NAN),
            report["coverage"]["max"].as_f64().unwrap_or(f64::NAN),
        )),
    ];
    let rows: Vec<Vec<String>> = report["physical"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|e| {
                    vec![
                        e["name"].as_str().unwrap_or("").to_string(),
                        fmt(e["value"].as_f64()),
                        format!("{} .. {}", fmt(e["lo95"].as_f64()), fmt(e["hi95"].as_f64())),
                    ]
                })
                .collect()
        })
        .unwrap_or_default();
    blocks.push(Block::Table(
        vec!["parameter".into(), "value".into(), "95 % interval".into()],
        rows,
    ));
    blocks.push(Block::Para(format!(
        "Residuals rms log10(model/measured) by region (targets: near 0.06 and far 0.12 at θi ≤ 60°, 0.2 at 75°, 0.1 out of plane); worst group / target {:.2}:",
        worst_ratio(&cmp.groups)
    )));
    blocks.push(Block::List(groups_text(&cmp.groups)));
    blocks
}

/// A number for a report table (6 significant digits; `—` for none).
fn fmt(v: Option<f64>) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.6}"),
        _ => "—".into(),
    }
}
