//! Plots of curves (SVG or PNG), log axis for reflectance, labelled axes with units.
//!
//! PNG text is drawn with DejaVu Sans, embedded from the `dejavu` crate (crate MIT /
//! Apache-2.0; the fonts are under the permissive Bitstream Vera / DejaVu licence), so
//! plots need no system font. The PNG file itself is written here (8-bit RGB, zlib via
//! `flate2`, chunk CRCs via `crc32fast`).

use std::io::Write;
use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, bail};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::common::Failure;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Solid line.
    Line,
    /// Dashed line.
    Dashed,
    /// Markers only (measured points).
    Points,
}

/// One series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text (empty: no legend entry, e.g. for the second edge of a band).
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

/// Plot size in pixels (SVG user units and PNG pixels alike).
const SIZE: (u32, u32) = (900, 620);

/// Register the embedded font under the family name the figures use (once per process).
fn register_fonts() -> anyhow::Result<()> {
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

/// The relative curves of a model result, one line per incidence, on a log axis (the
/// paper's "normalised to 1 in the specular direction"). Out-of-plane detectors are
/// placed by their polar angle `θr`.
pub fn relative_figure(curves: &flakescatter::Curves, title: String) -> Figure {
    let in_plane = matches!(
        curves.instrument.detectors(),
        flakescatter::DetectorSet::InPlane(_)
    );
    let series = curves
        .instrument
        .theta_i()
        .iter()
        .enumerate()
        .map(|(k, &ti)| Series {
            label: format!("θi = {:.1}°", ti.to_degrees()),
            points: curves
                .rows
                .iter()
                .filter(|r| r.theta_i == ti)
                .map(|r| {
                    let (ts, _) = crate::instrument::detector_deg(&curves.instrument, r.detector);
                    (ts, r.relative)
                })
                .collect(),
            style: Style::Line,
            colour: k,
        })
        .collect();
    Figure {
        title,
        x_label: if in_plane {
            "θs (degrees; θs = −θi is specular)".into()
        } else {
            "θr, detector polar angle (degrees)".into()
        },
        y_label: "relative reflectance (1 at specular)".into(),
        log_y: true,
        series,
    }
}

/// Draw `fig` to `path`; the extension must be `.svg` or `.png`. The title's first line
/// is the caption, a second line (after `\n`) a smaller note under it.
pub fn draw(path: &Path, fig: &Figure) -> anyhow::Result<()> {
    let png = match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => false,
        Some("png") => true,
        _ => bail!(
            "--plot {}: the plot file must end in .svg or .png",
            path.display()
        ),
    };
    register_fonts()?;
    let err = |e: String| anyhow::Error::new(Failure(format!("drawing {}: {e}", path.display())));
    if png {
        let (w, h) = SIZE;
        let mut buf = vec![255u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
            render(&root, fig, path)?;
            root.present().map_err(|e| err(e.to_string()))?;
        }
        write_png(path, w, h, &buf)
            .map_err(|e| Failure(format!("writing {}: {e}", path.display())))?;
    } else {
        let root = SVGBackend::new(path, SIZE).into_drawing_area();
        render(&root, fig, path)?;
        root.present()
            .map_err(|e| err(e.to_string()))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

/// Write an 8-bit RGB image (`rgb` row-major, 3 bytes a pixel) as a PNG file.
fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> std::io::Result<()> {
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        let len = u32::try_from(data.len()).unwrap_or(u32::MAX);
        out.extend_from_slice(&len.to_be_bytes());
        let mut crc = crc32fast::Hasher::new();
        crc.update(kind);
        crc.update(data);
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        out.extend_from_slice(&crc.finalize().to_be_bytes());
    }
    let row = w as usize * 3;
    // Filter type 0 (none) before every row, then one zlib stream.
    let mut raw = Vec::with_capacity((row + 1) * h as usize);
    for line in rgb.chunks_exact(row) {
        raw.push(0);
        raw.extend_from_slice(line);
    }
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(&raw)?;
    let idat = z.finish()?;
    let mut ihdr = Vec::with_capacity(13);
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    // Bit depth 8, colour type 2 (RGB), deflate, adaptive filtering, no interlace.
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut out = Vec::with_capacity(idat.len() + 64);
    out.extend_from_slice(b"\x89PNG\r\n\x1a\n");
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IDAT", &idat);
    chunk(&mut out, b"IEND", &[]);
    std::fs::write(path, out)
}

/// Draw `fig` on `root` (any backend); `path` only names the file in errors.
fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure,
    path: &Path,
) -> anyhow::Result<()> {
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
    let err = |e: String| anyhow::Error::new(Failure(format!("drawing {}: {e}", path.display())));
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
            for s in &fig.series {
                let colour = PALETTE[s.colour % PALETTE.len()];
                let keep = |&(x, y): &(f64, f64)| usable(x, y) && (!fig.log_y || y >= y0);
                // Lines break where a point cannot be drawn (NaN, or ≤ 0 on a log axis):
                // a gap in the data stays a gap in the plot.
                let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
                for p in &s.points {
                    if keep(p) {
                        runs.last_mut().map(|r| r.push(*p));
                    } else if runs.last().is_some_and(|r| !r.is_empty()) {
                        runs.push(Vec::new());
                    }
                }
                let first = std::mem::take(&mut runs[0]);
                let rest = runs.into_iter().skip(1).filter(|r| !r.is_empty());
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
