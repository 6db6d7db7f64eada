//! Drawing of [`Chart`]s (SVG or PNG): log axis for reflectance, labelled axes with
//! units. What a chart shows is decided by the facade ([`flakescatter::chart`]).
//!
//! PNG text is drawn with DejaVu Sans, embedded from the `dejavu` crate (crate MIT /
//! Apache-2.0; the fonts are under the permissive Bitstream Vera / DejaVu licence), so
//! plots need no system font. PNG files are encoded by the `png` crate (8-bit RGB).

use std::path::Path;
use std::sync::OnceLock;

use anyhow::bail;
use flakescatter::chart::{Chart, Style};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::output::Failure;

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

/// Plot size in pixels (SVG user units and PNG pixels alike).
const SIZE: (u32, u32) = (900, 620);

/// Register the embedded font under the family name the figures use (once per process).
pub(crate) fn register_fonts() -> anyhow::Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .is_ok()
    });
    if !ok {
        bail!("the embedded DejaVu Sans font could not be loaded");
    }
    Ok(())
}

/// The chart as an SVG document; `name` names the plot in errors.
pub fn svg(chart: &Chart, name: &str) -> anyhow::Result<String> {
    register_fonts()?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, SIZE).into_drawing_area();
        render(&root, chart, name)?;
        root.present()
            .map_err(|e| Failure(format!("drawing {name}: {e}")))?;
    }
    Ok(text)
}

/// The chart as a PNG file (8-bit RGB, encoded by the `png` crate).
pub fn png(chart: &Chart, name: &str) -> anyhow::Result<Vec<u8>> {
    register_fonts()?;
    let (w, h) = SIZE;
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        render(&root, chart, name)?;
        root.present()
            .map_err(|e| Failure(format!("drawing {name}: {e}")))?;
    }
    encode_rgb(w, h, &rgb, name)
}

/// An 8-bit RGB raster (`w × h × 3` bytes, row-major) as PNG bytes.
pub(crate) fn encode_rgb(w: u32, h: u32, rgb: &[u8], name: &str) -> anyhow::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let fail = |e: png::EncodingError| Failure(format!("encoding {name}: {e}"));
    let mut enc = png::Encoder::new(&mut bytes, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::High);
    let mut writer = enc.write_header().map_err(fail)?;
    writer.write_image_data(rgb).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(bytes)
}

/// The chart in the format of `path`'s extension (`.svg` or `.png`).
pub fn encode(path: &Path, chart: &Chart) -> anyhow::Result<Vec<u8>> {
    let name = path.display().to_string();
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => png(chart, &name),
        Some("svg") => svg(chart, &name).map(String::into_bytes),
        _ => bail!("{name}: a plot file must end in .svg or .png"),
    }
}

/// Whether `(x, y)` can be drawn on the chart's axes (finite, and positive on a log axis).
fn usable(fig: &Chart, x: f64, y: f64) -> bool {
    x.is_finite() && y.is_finite() && (!fig.log_y || y > 0.0)
}

/// The axis ranges `(x0, x1, y0, y1)` of `fig`, padded; an error when nothing can be drawn.
fn axis_ranges(fig: &Chart, name: &str) -> anyhow::Result<(f64, f64, f64, f64)> {
    // The axes hold every point of the lines and markers and the bounds of the bands;
    // on a log axis only their upper bounds (a lower bound near zero would stretch it
    // for nothing).
    let pts = fig
        .series
        .iter()
        .filter(|s| s.style != Style::ErrorBars)
        .flat_map(|s| match s.style {
            Style::Band if fig.log_y => s
                .band_bounds()
                .into_iter()
                .map(|(x, _, hi)| (x, hi))
                .collect::<Vec<_>>(),
            _ => s.points.clone(),
        })
        .filter(|&(x, y)| usable(fig, x, y));
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && y0.is_finite()) {
        bail!("plot {name}: nothing to draw (no finite, positive values)");
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
    Ok((x0, x1, y0, y1))
}

/// `root` filled white, with the title's first line as caption and its further lines
/// as a grey note underneath: the area the chart is drawn in.
fn titled_area<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &Chart,
    err: impl Fn(String) -> anyhow::Error,
) -> anyhow::Result<DrawingArea<DB, Shift>> {
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let mut lines = fig.title.lines();
    let caption = lines.next().unwrap_or("");
    let note: Vec<&str> = lines.collect();
    let mut area = root
        .titled(caption, ("sans-serif", 20))
        .map_err(|e| err(e.to_string()))?;
    if !note.is_empty() {
        area = area
            .titled(
                &note.join(" "),
                ("sans-serif", 14).into_font().color(&RGBColor(90, 90, 90)),
            )
            .map_err(|e| err(e.to_string()))?;
    }
    Ok(area)
}

/// A run of points drawn as one piece.
type Run = Vec<(f64, f64)>;

/// The runs of a line or marker series that can be drawn: `points` split where `keep`
/// fails (a gap in the data stays a gap in the plot); the first run (possibly empty)
/// and the further non-empty ones.
fn point_runs(points: &[(f64, f64)], keep: impl Fn(&(f64, f64)) -> bool) -> (Run, Vec<Run>) {
    let mut runs: Vec<Run> = vec![Vec::new()];
    for p in points {
        if keep(p) {
            if let Some(r) = runs.last_mut() {
                r.push(*p);
            }
        } else if runs.last().is_some_and(|r| !r.is_empty()) {
            runs.push(Vec::new());
        }
    }
    let first = std::mem::take(&mut runs[0]);
    let rest = runs.into_iter().skip(1).filter(|r| !r.is_empty()).collect();
    (first, rest)
}

/// The bars of an error-bar series: pairs (x, low), (x, high); a low end off a log axis
/// is drawn from the bottom of the plot (`y0`), a high end is clipped at the top (`y1`).
fn error_bars(
    points: &[(f64, f64)],
    log_y: bool,
    (y0, y1): (f64, f64),
    colour: RGBColor,
) -> Vec<PathElement<(f64, f64)>> {
    points
        .chunks_exact(2)
        .filter(|p| p[0].0.is_finite() && p[1].1.is_finite() && p[1].1 > 0.0)
        .map(|p| {
            let lo = if p[0].1.is_finite() && (!log_y || p[0].1 > y0) {
                p[0].1
            } else {
                y0
            };
            PathElement::new(
                vec![(p[0].0, lo), (p[1].0, p[1].1.min(y1))],
                colour.stroke_width(1),
            )
        })
        .collect()
}

/// Draw `fig` on `root` (any backend); `name` only names the file in errors.
fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &Chart,
    name: &str,
) -> anyhow::Result<()> {
    let (x0, x1, y0, y1) = axis_ranges(fig, name)?;
    let err = |e: String| anyhow::Error::new(Failure(format!("drawing {name}: {e}")));
    let area = titled_area(root, fig, err)?;
    let mut builder = ChartBuilder::on(&area);
    builder
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
            // Bands first, so that the lines and markers are drawn over them.
            for s in fig.series.iter().filter(|s| s.style == Style::Band) {
                let colour = PALETTE[s.colour % PALETTE.len()];
                let fill = colour.mix(0.22).filled();
                let mut drawn = false;
                for run in band_runs(&s.band_bounds(), fig.log_y, y0) {
                    let outline: Vec<(f64, f64)> = run
                        .iter()
                        .map(|&(x, lo, _)| (x, lo))
                        .chain(run.iter().rev().map(|&(x, _, hi)| (x, hi)))
                        .collect();
                    let anno = chart
                        .draw_series(std::iter::once(Polygon::new(outline, fill)))
                        .map_err(|e| err(e.to_string()))?;
                    if !drawn && !s.label.is_empty() {
                        anno.label(s.label.as_str()).legend(move |(x, y)| {
                            Rectangle::new([(x, y - 5), (x + 20, y + 5)], colour.mix(0.22).filled())
                        });
                    }
                    drawn = true;
                }
            }
            for s in fig.series.iter().filter(|s| s.style != Style::Band) {
                let colour = PALETTE[s.colour % PALETTE.len()];
                let keep = |&(x, y): &(f64, f64)| usable(fig, x, y) && (!fig.log_y || y >= y0);
                // Lines break where a point cannot be drawn (NaN, or ≤ 0 on a log axis).
                let (first, rest) = point_runs(&s.points, keep);
                let labelled = !s.label.is_empty();
                match s.style {
                    Style::Line => {
                        let line = |d: Vec<(f64, f64)>| LineSeries::new(d, colour.stroke_width(2));
                        for run in rest {
                            chart
                                .draw_series(line(run))
                                .map_err(|e| err(e.to_string()))?;
                        }
                        let anno = chart
                            .draw_series(line(first))
                            .map_err(|e| err(e.to_string()))?;
                        if labelled {
                            anno.label(s.label.as_str()).legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                            });
                        }
                    }
                    Style::Dashed => {
                        let line = |d: Vec<(f64, f64)>| {
                            DashedLineSeries::new(d, 6, 4, colour.stroke_width(1))
                        };
                        for run in rest {
                            chart
                                .draw_series(line(run))
                                .map_err(|e| err(e.to_string()))?;
                        }
                        let anno = chart
                            .draw_series(line(first))
                            .map_err(|e| err(e.to_string()))?;
                        if labelled {
                            anno.label(s.label.as_str()).legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(1))
                            });
                        }
                    }
                    Style::Band => {}
                    Style::ErrorBars => {
                        let bars = error_bars(&s.points, fig.log_y, (y0, y1), colour);
                        chart.draw_series(bars).map_err(|e| err(e.to_string()))?;
                        let _ = (first, rest);
                    }
                    Style::Points => {
                        let data = std::iter::once(first).chain(rest).flatten();
                        let anno = chart
                            .draw_series(data.map(|p| Circle::new(p, 2, colour.filled())))
                            .map_err(|e| err(e.to_string()))?;
                        if labelled {
                            anno.label(s.label.as_str())
                                .legend(move |(x, y)| Circle::new((x + 10, y), 3, colour.filled()));
                        }
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
    Ok(())
}

/// The runs of a band that can be drawn: consecutive `(x, lower, upper)` with finite
/// values and an upper bound above the axis floor `y0` on a log axis; a lower bound
/// below the floor (or ≤ 0) is drawn at the floor. A run of one point is widened to
/// nothing visible and dropped.
fn band_runs(bounds: &[(f64, f64, f64)], log_y: bool, y0: f64) -> Vec<Vec<(f64, f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new()];
    for &(x, lo, hi) in bounds {
        let ok = x.is_finite() && lo.is_finite() && hi.is_finite() && (!log_y || hi > y0);
        if ok {
            let lo = if log_y { lo.max(y0) } else { lo };
            if let Some(r) = runs.last_mut() {
                r.push((x, lo, hi));
            }
        } else if runs.last().is_some_and(|r| !r.is_empty()) {
            runs.push(Vec::new());
        }
    }
    runs.retain(|r| r.len() >= 2);
    runs
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

pub use flakescatter::paint::report::ResidualPanel;

/// Residuals beyond this many decades get the end colours of [`residual_maps_png`].
const RESIDUAL_SPAN: f64 = 0.3;

/// A diverging colour for a residual `r` (decades): blue for a model too low, white for
/// 0, red for too high, saturated at ±[`RESIDUAL_SPAN`].
fn residual_colour(r: f64) -> RGBColor {
    let t = (r / RESIDUAL_SPAN).clamp(-1.0, 1.0);
    let mix =
        |a: u8, b: u8, f: f64| (f64::from(a) + (f64::from(b) - f64::from(a)) * f).round() as u8;
    if t >= 0.0 {
        RGBColor(mix(255, 178, t), mix(255, 24, t), mix(255, 43, t))
    } else {
        RGBColor(mix(255, 33, -t), mix(255, 102, -t), mix(255, 172, -t))
    }
}

/// Maps of out-of-plane residuals, one panel per incidence: each detector at
/// `(φr, θr)` (degrees) a square coloured by `log10(model/measured)` (blue: model too
/// low, red: too high; saturated at ±0.3 decades), with the panel's rms in its title.
/// `maps` holds `(θi in radians, cells (θr, φr, residual))`.
pub fn residual_maps_png(
    maps: &[ResidualPanel],
    file: &str,
    name: &str,
) -> anyhow::Result<Vec<u8>> {
    register_fonts()?;
    let panels = maps.len().max(1) as u32;
    let (w, h) = (330 * panels, 420);
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    {
        let err = |e: String| anyhow::Error::new(Failure(format!("drawing {name}: {e}")));
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        let root = root
            .titled(
                &format!("{file}: out-of-plane residuals log10(model/measured); blue: model low, red: high, ±{RESIDUAL_SPAN} saturates"),
                ("sans-serif", 16),
            )
            .map_err(|e| err(e.to_string()))?;
        let areas = root.split_evenly((1, panels as usize));
        for ((ti, cells), area) in maps.iter().zip(areas) {
            let rms =
                (cells.iter().map(|c| c.2 * c.2).sum::<f64>() / cells.len().max(1) as f64).sqrt();
            let mut chart = ChartBuilder::on(&area)
                .caption(
                    format!("θi = {:.1}°, rms {rms:.3}", ti.to_degrees()),
                    ("sans-serif", 15),
                )
                .margin(8)
                .x_label_area_size(35)
                .y_label_area_size(40)
                .build_cartesian_2d(-5f64..185f64, 0f64..90f64)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_labels(7)
                .y_labels(10)
                .x_label_formatter(&|v: &f64| format!("{v:.0}"))
                .y_label_formatter(&|v: &f64| format!("{v:.0}"))
                .x_desc("φr (degrees; 0 specular side)")
                .y_desc("θr (degrees)")
                .draw()
                .map_err(|e| err(e.to_string()))?;
            chart
                .draw_series(cells.iter().map(|&(tr, pr, r)| {
                    let pr = pr.rem_euclid(360.0);
                    let pr = if pr > 180.0 { 360.0 - pr } else { pr };
                    Rectangle::new(
                        [(pr - 4.0, tr - 2.4), (pr + 4.0, tr + 2.4)],
                        residual_colour(r).filled(),
                    )
                }))
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    encode_rgb(w, h, &rgb, name)
}

#[cfg(test)]
mod tests {
    use super::band_runs;

    #[test]
    fn band_runs_break_at_gaps_and_floor_the_lower_bound() {
        let nan = f64::NAN;
        let b = [
            (0.0, 0.5, 2.0),
            (1.0, -1.0, 3.0),
            (2.0, nan, nan),
            (3.0, 1.0, 2.0),
            (4.0, 1.0, 2.0),
            (5.0, 0.5, 1e-9),
            (6.0, 1.0, 2.0),
        ];
        // Log axis with floor 0.1: the negative lower bound goes to the floor, the NaN
        // pair and the upper bound below the floor break the band, a lone pair is dropped.
        assert_eq!(
            band_runs(&b, true, 0.1),
            vec![
                vec![(0.0, 0.5, 2.0), (1.0, 0.1, 3.0)],
                vec![(3.0, 1.0, 2.0), (4.0, 1.0, 2.0)]
            ]
        );
        // Linear axis: negative bounds are drawn as they are.
        assert_eq!(band_runs(&b[..2], false, 0.1), vec![b[..2].to_vec()]);
    }
}
