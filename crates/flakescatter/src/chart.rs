//! What a plot shows, as plain data: series of `(x, y)` points with a style, axis labels
//! with units, a title. The command-line tool draws a [`Chart`] (SVG or PNG); the
//! library only decides what goes into it.
//!
//! Conventions: x values are degrees (θs, θr or θn, as the axis label says) because
//! charts are read by people; y values in the unit of the label. Points that cannot be
//! drawn (not finite, or ≤ 0 on a log axis) are gaps. An uncertainty band
//! ([`Style::Band`], made by [`Series::band`]) holds its lower and upper bounds as
//! pairs of points.

use crate::compare::{IncidenceComparison, MeasuredKind};
use crate::instrument::DetectorSet;
use crate::pipeline::{Curves, p_tilde_about_specular};
use crate::volume::VolumeCurves;
use flakescatter_stats::Orientation;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Solid line.
    Line,
    /// Dashed line.
    Dashed,
    /// Markers only (measured points).
    Points,
    /// A filled band between a lower and an upper bound (an uncertainty band): the
    /// points come in pairs `(x, lower), (x, upper)`, in order of `x` (see
    /// [`Series::band`]). A pair whose upper bound cannot be drawn is a gap; a lower
    /// bound that cannot be drawn on a log axis (≤ 0) is drawn at the bottom of the axis.
    Band,
    /// Vertical error bars: the points come in pairs `(x, low), (x, high)`, one bar
    /// per pair (±1 standard error of a curve, drawn in the curve's colour).
    ErrorBars,
}

/// One series of `(x, y)` points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text (empty: no legend entry).
    pub label: String,
    /// Points; non-finite or (on a log axis) non-positive values are gaps.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
    /// Colour index into the drawing palette.
    pub colour: usize,
}

impl Series {
    /// A [`Style::Band`] series from `(x, lower, upper)` triples.
    #[must_use]
    pub fn band(
        label: String,
        colour: usize,
        bounds: impl IntoIterator<Item = (f64, f64, f64)>,
    ) -> Self {
        Self {
            label,
            points: bounds
                .into_iter()
                .flat_map(|(x, lo, hi)| [(x, lo), (x, hi)])
                .collect(),
            style: Style::Band,
            colour,
        }
    }

    /// The `(x, lower, upper)` triples of a [`Style::Band`] series (the points taken in
    /// pairs; a last unpaired point is ignored).
    #[must_use]
    pub fn band_bounds(&self) -> Vec<(f64, f64, f64)> {
        self.points
            .chunks_exact(2)
            .map(|p| (p[0].0, p[0].1, p[1].1))
            .collect()
    }
}

/// A chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Title (first line) and an optional note (after `\n`).
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

/// x-axis label of in-plane curves.
pub const THETA_S_LABEL: &str = "θs (degrees; θs = −θi is specular)";

/// The relative curves of a model result, one line per incidence, on a log axis (the
/// paper's "normalised to 1 in the specular direction"). Out-of-plane detectors are
/// placed by their polar angle `θr`.
#[must_use]
pub fn relative_chart(curves: &Curves, title: String) -> Chart {
    let detectors = curves.instrument.detectors();
    let x = |j: usize| match detectors {
        DetectorSet::InPlane(ts) => ts[j].to_degrees(),
        DetectorSet::OutOfPlane(d) => d[j].0.to_degrees(),
    };
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
                .map(|r| (x(r.detector), r.relative))
                .collect(),
            style: Style::Line,
            colour: k,
        })
        .collect();
    Chart {
        title,
        x_label: match detectors {
            DetectorSet::InPlane(_) => THETA_S_LABEL.into(),
            DetectorSet::OutOfPlane(_) => "θr, detector polar angle (degrees)".into(),
        },
        y_label: "relative reflectance (1 at specular)".into(),
        log_y: true,
        series,
    }
}

/// The distribution model's chart (`model --plot`): relative curves per incidence and,
/// for a Gaussian `orientation` and in-plane detectors, `p̃` drawn about the specular
/// direction (dashed, as in the paper's Fig. 4).
#[must_use]
pub fn distribution_chart(curves: &Curves, orientation: &Orientation) -> Chart {
    let mut chart = relative_chart(
        curves,
        format!(
            "Distribution model, n = {}, aperture {:.2}°",
            curves.coating.n,
            curves.instrument.aperture().to_degrees()
        ),
    );
    let in_plane = matches!(curves.instrument.detectors(), DetectorSet::InPlane(_));
    if in_plane && orientation.gaussian_width().is_some() {
        for (k, &ti) in curves.instrument.theta_i().iter().enumerate() {
            let points = (-900..=900)
                .map(|j| -ti.to_degrees() + f64::from(j) * 0.1)
                .filter(|&x| x > -90.0 && x < 90.0)
                .map(|x| (x, p_tilde_about_specular(orientation, ti, x.to_radians())))
                .collect();
            chart.series.push(Series {
                label: format!("p~ about specular, θi = {:.1}°", ti.to_degrees()),
                points,
                style: Style::Dashed,
                colour: k,
            });
        }
    }
    chart
}

/// The topographic model's chart (`topo --plot`, also averaged over the sample's
/// rotation): relative curves per incidence, each with a band of ± one standard error
/// where the rows have one (`relative · (1 ± std_err / brdf)`: the error of the
/// detector's own value; the specular reference's error is not included).
#[must_use]
pub fn topographic_chart(curves: &Curves) -> Chart {
    let what = if curves.model == "topographic-isotropic" {
        "Topographic model averaged over the sample's rotation"
    } else {
        "Topographic model"
    };
    let mut chart = relative_chart(
        curves,
        format!(
            "{what}, n = {}, aperture {:.2}°",
            curves.coating.n,
            curves.instrument.aperture().to_degrees()
        ),
    );
    let detectors = curves.instrument.detectors();
    let x = |j: usize| match detectors {
        DetectorSet::InPlane(ts) => ts[j].to_degrees(),
        DetectorSet::OutOfPlane(d) => d[j].0.to_degrees(),
    };
    for (k, &ti) in curves.instrument.theta_i().iter().enumerate() {
        let bounds: Vec<(f64, f64, f64)> = curves
            .rows
            .iter()
            .filter(|r| r.theta_i == ti)
            .map(|r| {
                let rel = match r.std_err {
                    Some(se) if r.brdf > 0.0 => se / r.brdf,
                    _ => f64::NAN,
                };
                (
                    x(r.detector),
                    r.relative * (1.0 - rel),
                    r.relative * (1.0 + rel),
                )
            })
            .collect();
        if bounds.iter().any(|b| b.2.is_finite()) {
            let label = if k == 0 {
                "± 1 standard error (map tiles)".to_owned()
            } else {
                String::new()
            };
            chart.series.push(Series::band(label, k, bounds));
        }
    }
    chart
}

/// The volume model's chart (`volume --plot`): per incidence the collected power
/// relative to the specular detector (solid, coat reflection included) and the part of
/// it that multiple scattering brings, on the same scale (dashed: `relative` times the
/// multiple-bounce share of the cone's BRDF), log axis.
#[must_use]
pub fn volume_chart(curves: &VolumeCurves) -> Chart {
    let detectors = curves.instrument.detectors();
    let x = |j: usize| match detectors {
        DetectorSet::InPlane(ts) => ts[j].to_degrees(),
        DetectorSet::OutOfPlane(d) => d[j].0.to_degrees(),
    };
    let mut series = Vec::new();
    for (k, &ti) in curves.instrument.theta_i().iter().enumerate() {
        let rows = || curves.rows.iter().filter(move |r| r.theta_i == ti);
        series.push(Series {
            label: format!("total, θi = {:.1}°", ti.to_degrees()),
            points: rows().map(|r| (x(r.detector), r.relative)).collect(),
            style: Style::Line,
            colour: k,
        });
        series.push(Series {
            label: format!("multiple scattering, θi = {:.1}°", ti.to_degrees()),
            points: rows()
                .map(|r| (x(r.detector), r.relative * r.multiple_bounce_brdf / r.brdf))
                .collect(),
            style: Style::Dashed,
            colour: k,
        });
    }
    Chart {
        title: format!(
            "Volume model, n = {}, film {} µm, {} flakes, aperture {:.2}°",
            curves.coating.n,
            curves.settings.film_um,
            curves.layer.flakes,
            curves.instrument.aperture().to_degrees()
        ),
        x_label: match detectors {
            DetectorSet::InPlane(_) => THETA_S_LABEL.into(),
            DetectorSet::OutOfPlane(_) => "θr, detector polar angle (degrees)".into(),
        },
        y_label: "relative reflectance (1 at specular)".into(),
        log_y: true,
        series,
    }
}

/// Adds to `chart` one [`Style::ErrorBars`] series per incidence of `curves` whose rows
/// have standard errors: `relative × scale ± relative × scale × std_err / brdf` (the
/// relative error of the BRDF carried to the plotted value; `scale` is the factor the
/// chart's curve was multiplied by). Rows without a standard error or a positive BRDF
/// get no bar; the bars take the colour of the incidence's curve (its index).
pub fn with_error_bars(chart: &mut Chart, curves: &Curves, scale: f64) {
    let detectors = curves.instrument.detectors();
    let x = |j: usize| match detectors {
        DetectorSet::InPlane(ts) => ts[j].to_degrees(),
        DetectorSet::OutOfPlane(d) => d[j].0.to_degrees(),
    };
    for (k, &ti) in curves.instrument.theta_i().iter().enumerate() {
        let mut points = Vec::new();
        for r in curves.rows.iter().filter(|r| r.theta_i == ti) {
            if let Some(se) = r.std_err
                && se.is_finite()
                && r.brdf > 0.0
                && r.relative.is_finite()
            {
                let y = r.relative * scale;
                let d = y * se / r.brdf;
                points.push((x(r.detector), y - d));
                points.push((x(r.detector), y + d));
            }
        }
        if !points.is_empty() {
            chart.series.push(Series {
                label: String::new(),
                points,
                style: Style::ErrorBars,
                colour: k,
            });
        }
    }
}

/// The area-weighted histogram of `p̃` (`stats --plot`) as steps over its bins, the
/// maximum-likelihood Gaussian of width `sigma` (radians) and, dashed, the Gaussians at
/// the ends of its 95 % interval `sigma_ci95` (the band; an infinite end is left out),
/// `interval` saying which interval it is. x: θn in degrees; y: `p̃` (`2π p2`,
/// physics.md §3), linear.
#[must_use]
pub fn histogram_chart(
    hist: &flakescatter_stats::histogram::AreaHistogram,
    sigma: f64,
    sigma_ci95: (f64, f64),
    interval: &str,
    title: &str,
) -> Chart {
    let bins = hist.bins();
    let mut steps = Vec::with_capacity(2 * bins.len());
    let mut top = 0f64;
    for b in &bins {
        steps.push((b.theta_lo.to_degrees(), b.p_tilde));
        steps.push((b.theta_hi.to_degrees(), b.p_tilde));
        if b.p_tilde > 0.0 {
            top = top.max(b.theta_hi);
        }
    }
    // Draw to the last non-empty bin or 4 widths, whichever is further, within 90°.
    let x_max = top
        .max(4.0 * sigma * flakescatter_stats::distribution::HWHM_PER_SIGMA)
        .min(std::f64::consts::FRAC_PI_2);
    steps.retain(|p| p.0 <= x_max.to_degrees() + 1e-9);
    let curve = |s: f64| -> Vec<(f64, f64)> {
        let Ok(o) = Orientation::gaussian(flakescatter_stats::GaussianWidth::Sigma(s)) else {
            return Vec::new();
        };
        (0..=400)
            .map(|k| f64::from(k) / 400.0 * x_max)
            .map(|t| (t.to_degrees(), o.p_tilde(t)))
            .collect()
    };
    let hwhm = |s: f64| (s * flakescatter_stats::distribution::HWHM_PER_SIGMA).to_degrees();
    let mut series = vec![
        Series {
            label: format!("histogram ({} flakes)", hist.flakes()),
            points: steps,
            style: Style::Line,
            colour: 7,
        },
        Series {
            label: format!("Gaussian, hwhm {:.2}°", hwhm(sigma)),
            points: curve(sigma),
            style: Style::Line,
            colour: 1,
        },
    ];
    for (k, s) in [sigma_ci95.0, sigma_ci95.1].into_iter().enumerate() {
        if s.is_finite() && s > 0.0 {
            series.push(Series {
                label: if k == 0 {
                    format!(
                        "95 % interval ({interval}): hwhm {:.2}°–{}",
                        hwhm(sigma_ci95.0),
                        if sigma_ci95.1.is_finite() {
                            format!("{:.2}°", hwhm(sigma_ci95.1))
                        } else {
                            "∞".into()
                        }
                    )
                } else {
                    String::new()
                },
                points: curve(s),
                style: Style::Dashed,
                colour: 1,
            });
        }
    }
    Chart {
        title: title.to_owned(),
        x_label: "θn, flake tilt (degrees)".into(),
        y_label: "p̃ (2π × area fraction per sr)".into(),
        log_y: false,
        series,
    }
}

/// Measured points and scaled model lines per incidence, log axis (`compare --plot`);
/// `file` names the measurement in the title.
#[must_use]
pub fn comparison_chart(results: &[IncidenceComparison], kind: MeasuredKind, file: &str) -> Chart {
    let mut series = Vec::new();
    for (k, c) in results.iter().enumerate() {
        let ti = c.theta_i.to_degrees();
        series.push(Series {
            label: format!("measured, θi = {ti:.1}°"),
            points: c
                .points
                .iter()
                .map(|p| (p.theta_s.to_degrees(), p.measured))
                .collect(),
            style: Style::Points,
            colour: k,
        });
        series.push(Series {
            label: format!("model × {:.3e}, θi = {ti:.1}°", c.scale),
            points: c
                .points
                .iter()
                .map(|p| (p.theta_s.to_degrees(), p.model))
                .collect(),
            style: Style::Line,
            colour: k,
        });
    }
    let unit = match kind {
        MeasuredKind::Brdf => "BRDF (1/sr)",
        MeasuredKind::ReflectanceFactor => "reflectance factor (π × BRDF)",
        MeasuredKind::Relative => "relative reflectance (1 at specular)",
    };
    Chart {
        title: format!("Measured ({file}) vs model, scale fitted 5°–40° from specular"),
        x_label: THETA_S_LABEL.into(),
        y_label: unit.into(),
        log_y: true,
        series,
    }
}
