//! The report's pictures: the histogram with the fitted Gaussian, the curves of every
//! model (with the measured points) per incidence, and each map's segmentation overlay.

use super::Analysis;
use crate::analyze::cache::{CurveRec, RowRec};
use crate::analyze::format::deg;
use crate::analyze::settings::{in_plane_angles, measured_kind};
use crate::analyze::{Content, OutFile};
use crate::chart::{Chart, Series, Style, THETA_S_LABEL, histogram_chart};
use crate::compare::{IncidenceComparison, MeasuredKind, ModelPoint};
use crate::instrument::Instrument;
use crate::overlay::overlay;

/// `histogram.png`: the pooled histogram with the fitted Gaussian and the quoted
/// interval `qci` (radians) named `qname`.
pub(super) fn histogram(a: &Analysis, qci: (f64, f64), qname: &str) -> OutFile {
    let (input, stats) = (a.input, a.stats);
    let p = &stats.pooled;
    let names = &input.map_names;
    OutFile {
        path: "histogram.png".into(),
        content: Content::Chart(histogram_chart(
            &stats.histogram,
            p.flake_level.sigma,
            qci,
            qname,
            &format!(
                "{}: area-weighted flake tilts, {} maps",
                input.name,
                names.len()
            ),
        )),
    }
}

/// One chart per incidence, `curves-theta{θi°}.png`; with each its path, θi in
/// degrees and the incidence's index.
pub(super) fn curves(a: &Analysis) -> (Vec<OutFile>, Vec<(String, f64, usize)>) {
    let (input, instrument, models, measured) = (a.input, a.instrument, a.models, a.measured);
    let ts_list = in_plane_angles(instrument);
    let kind = measured_kind(&input.manifest);
    let mut files = Vec::new();
    let mut curve_images = Vec::new();
    for (k, &ti) in instrument.theta_i().iter().enumerate() {
        let mut series = Vec::new();
        let ti_deg = deg(ti);
        if let Some(curve) = measured {
            series.push(Series {
                label: "measured".into(),
                points: curve
                    .points
                    .iter()
                    .filter(|p| (p.theta_i - ti).abs() < 1e-9)
                    .map(|p| (p.theta_s.to_degrees(), p.value))
                    .collect(),
                style: Style::Points,
                colour: 7,
            });
        }
        for (j, c) in models.curves.iter().enumerate() {
            series.extend(model_series(
                c,
                j,
                ti,
                a.comparisons,
                instrument,
                kind,
                &ts_list,
            ));
        }
        let path = format!("curves-theta{}.png", ti_deg);
        files.push(OutFile {
            path: path.clone(),
            content: Content::Chart(Chart {
                title: format!(
                    "{}: θi = {ti_deg}°, aperture {:.2}°{}\n{}",
                    input.name,
                    instrument.aperture().to_degrees(),
                    if measured.is_some() {
                        ", models scaled 5°–40° from specular"
                    } else {
                        ""
                    },
                    "topographic curve with ±1 standard error bars from map tiles"
                ),
                x_label: THETA_S_LABEL.into(),
                y_label: if measured.is_some() {
                    format!("{} ({})", "measured quantity", kind.name())
                } else {
                    "relative reflectance (1 at specular)".into()
                },
                log_y: true,
                series,
            }),
        });
        curve_images.push((path, ti_deg, k));
    }
    (files, curve_images)
}

/// The series of model curve `c` (the `j`th) at incidence `ti`: the curve, scaled to the
/// measurement where there is one (the comparison's scale), and its error bars.
fn model_series(
    c: &CurveRec,
    j: usize,
    ti: f64,
    comparisons: &[(String, Vec<IncidenceComparison>)],
    instrument: &Instrument,
    kind: MeasuredKind,
    ts_list: &[f64],
) -> Vec<Series> {
    let mut series = Vec::new();
    let scale = comparisons
        .iter()
        .find(|(l, _)| *l == c.label)
        .and_then(|(_, cs)| cs.iter().find(|x| (x.theta_i - ti).abs() < 1e-9))
        .map(|x| x.scale);
    let value = |r: &RowRec| -> f64 {
        match scale {
            Some(s) => {
                s * ModelPoint::from_row(r.brdf, r.relative, r.reflectance, instrument.aperture())
                    .in_kind(kind)
            }
            None => r.relative,
        }
    };
    let rows: Vec<&RowRec> = c.rows.iter().filter(|r| r.theta_i == ti).collect();
    series.push(Series {
        label: match scale {
            Some(s) => format!("{} × {s:.3e}", c.label),
            None => c.label.clone(),
        },
        points: rows
            .iter()
            .map(|r| (ts_list[r.detector].to_degrees(), value(r)))
            .collect(),
        style: if c.label.contains("histogram") {
            Style::Dashed
        } else {
            Style::Line
        },
        colour: j,
    });
    let bars: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            let se = r.std_err?;
            (se.is_finite() && r.brdf > 0.0 && c.model.starts_with("topographic")).then(|| {
                let y = value(r);
                let d = y * se / r.brdf;
                [
                    (ts_list[r.detector].to_degrees(), y - d),
                    (ts_list[r.detector].to_degrees(), y + d),
                ]
            })
        })
        .flatten()
        .collect();
    if !bars.is_empty() {
        series.push(Series {
            label: String::new(),
            points: bars,
            style: Style::ErrorBars,
            colour: j,
        });
    }
    series
}

/// `overlays/{map}.png`: each map's segmentation.
pub(super) fn overlays(a: &Analysis) -> Vec<OutFile> {
    let (m, stats, maps) = (&a.input.manifest, a.stats, a.maps);
    let names = &a.input.map_names;
    let mut files = Vec::new();
    for (k, map) in maps.iter().enumerate() {
        files.push(OutFile {
            path: format!("overlays/{}.png", names[k]),
            content: Content::Overlay(
                Box::new(overlay(
                    map,
                    &stats.segmentations[k],
                    m.stats.overlay_max_deg.to_radians(),
                )),
                names[k].clone(),
            ),
        });
    }
    files
}
