//! Plots of curves (SVG), log axis for reflectance, labelled axes with units.

use std::path::Path;

use anyhow::{Context, bail};
use plotters::prelude::*;

use crate::common::Failure;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Solid line.
    Line,
    /// Dashed line.
    Dashed,
}

/// One series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points; non-finite or (on a log axis) non-positive values are skipped.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
    /// Colour index into the palette.
    pub colour: usize,
}

/// A figure.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Title (first line) and an optional note (second line).
    pub title: String,
    /// x-axis label with unit.
    pub x_label: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The series.
    pub series: Vec<Series>,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Draw `fig` to `path`; the extension must be `.svg`.
pub fn draw(path: &Path, fig: &Figure) -> anyhow::Result<()> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => {}
        _ => bail!("--plot {}: only .svg plots are supported", path.display()),
    }
    let usable = |x: f64, y: f64| x.is_finite() && y.is_finite() && (!fig.log_y || y > 0.0);
    let pts = || {
        fig.series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&(x, y)| usable(x, y))
    };
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in pts() {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && y0.is_finite()) {
        bail!(
            "--plot {}: nothing to draw (no finite, positive values)",
            path.display()
        );
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if fig.log_y {
        // At most 8 decades below the maximum, so that a few tiny values do not squash the plot.
        y0 = y0.max(y1 * 1e-8);
        y0 /= 1.5;
        y1 *= 1.5;
    } else {
        let pad = 0.05 * (y1 - y0).max(1e-300);
        y0 -= pad;
        y1 += pad;
    }
    let backend = SVGBackend::new(path, (900, 620));
    let root = backend.into_drawing_area();
    let err = |e: String| anyhow::Error::new(Failure(format!("drawing {}: {e}", path.display())));
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(&fig.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80);
    macro_rules! finish {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(fig.x_label.as_str())
                .y_desc(fig.y_label.as_str())
                .y_label_formatter(&|v: &f64| tick(*v))
                .x_label_formatter(&|v: &f64| tick(*v))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            for s in &fig.series {
                let colour = PALETTE[s.colour % PALETTE.len()];
                let data: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .copied()
                    .filter(|&(x, y)| usable(x, y) && (!fig.log_y || y >= y0))
                    .collect();
                match s.style {
                    Style::Line => {
                        chart
                            .draw_series(LineSeries::new(data, colour.stroke_width(2)))
                            .map_err(|e| err(e.to_string()))?
                            .label(s.label.as_str())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                            });
                    }
                    Style::Dashed => {
                        chart
                            .draw_series(DashedLineSeries::new(data, 6, 4, colour.stroke_width(1)))
                            .map_err(|e| err(e.to_string()))?
                            .label(s.label.as_str())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(1))
                            });
                    }
                }
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(|e| err(e.to_string()))?;
        }};
    }
    if fig.log_y {
        finish!(
            builder
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(|e| err(e.to_string()))?
        );
    } else {
        finish!(
            builder
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| err(e.to_string()))?
        );
    }
    root.present()
        .map_err(|e| err(e.to_string()))
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Tick labels with at most three significant digits (`1e-5`, `0.25`, `-40`).
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        format!("{m}e{e}")
    }
}
