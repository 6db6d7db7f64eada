//! Measurement against model (physics.md §7): regions, the fitted vertical scale and
//! residuals of `log10` values.
//!
//! Conventions: radians. The aspecular distance of an in-plane detector is
//! `|θs + θi|`. Regions: **specular** within [`SPECULAR_REGION`] (5°) of specular —
//! the clear coat's peak; **near-specular** from 5° to [`FAR_REGION`] (40°); **far**
//! beyond 40° (the paper's three regions). The model's vertical scale is fitted, per
//! incidence, to the near-specular points only (excluding the specular peak), as the
//! paper does; residuals are `log10(measured) − log10(scale × model)`.

use std::fmt;
use std::str::FromStr;

use flakescatter_gaussian::ConeMethod;
use flakescatter_io::measured::MeasuredCurve;
use flakescatter_optics::detector::Cone;
use flakescatter_stats::Orientation;

use crate::PipelineError;
use crate::pipeline::{Coating, Settings, distribution_model};

/// Half-width of the specular region, radians (5°).
pub const SPECULAR_REGION: f64 = flakescatter_paint::fit::report::NEAR_FROM;
/// Start of the far region, radians (40° from specular).
pub const FAR_REGION: f64 = flakescatter_paint::fit::report::FAR_FROM;

/// What the measured `value` column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MeasuredKind {
    /// BRDF, sr⁻¹ (default).
    #[default]
    Brdf,
    /// Reflectance factor, `π × BRDF` (dimensionless).
    ReflectanceFactor,
    /// Collected power normalised to 1 at the specular direction (the paper's figures).
    Relative,
}

impl MeasuredKind {
    /// The command-line name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Brdf => "brdf",
            Self::ReflectanceFactor => "reflectance-factor",
            Self::Relative => "relative",
        }
    }
}

impl fmt::Display for MeasuredKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MeasuredKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "brdf" => Ok(Self::Brdf),
            "reflectance-factor" => Ok(Self::ReflectanceFactor),
            "relative" => Ok(Self::Relative),
            _ => Err(format!(
                "unknown measured kind `{s}`: expected brdf, reflectance-factor or relative"
            )),
        }
    }
}

/// The paper's three regions of a goniometric curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Region {
    /// Within 5° of specular.
    Specular,
    /// 5° to 40° from specular.
    NearSpecular,
    /// More than 40° from specular.
    Far,
}

impl Region {
    /// All regions in order.
    pub const ALL: [Self; 3] = [Self::Specular, Self::NearSpecular, Self::Far];

    /// The region of detector `theta_s` at incidence `theta_i` (radians).
    #[must_use]
    pub fn of(theta_i: f64, theta_s: f64) -> Self {
        // One classification for curves and tables (the paint crate's, physics.md §7):
        // points exactly on a boundary (5°, 40°) belong to the near-specular region.
        match flakescatter_paint::fit::Region::of((theta_s + theta_i).abs()) {
            flakescatter_paint::fit::Region::Specular => Self::Specular,
            flakescatter_paint::fit::Region::Far => Self::Far,
            _ => Self::NearSpecular,
        }
    }

    /// A short name (`specular`, `near-specular`, `far`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Specular => "specular",
            Self::NearSpecular => "near-specular",
            Self::Far => "far",
        }
    }
}

/// What a model predicts for one detector, in both of the units a measurement may use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelPoint {
    /// Cone-averaged BRDF, sr⁻¹.
    pub brdf: f64,
    /// Collected power relative to the same detector at the specular direction (NaN
    /// when that detector collects nothing).
    pub relative: f64,
    /// Collected power per steradian of aperture, not normalised (`ρ / ΔΩ`; for a point
    /// detector `f cos θ`): what `relative` divides by its specular value.
    pub power: f64,
}

impl ModelPoint {
    /// The model point of a curve row computed with detectors of half-angle `aperture`
    /// (radians): `power = reflectance / ΔΩ`, `ΔΩ = 2π(1 − cos α)`; NaN for a point
    /// detector, whose row has no reflectance.
    #[must_use]
    pub fn from_row(brdf: f64, relative: f64, reflectance: Option<f64>, aperture: f64) -> Self {
        let solid = 4.0 * std::f64::consts::PI * (0.5 * aperture).sin().powi(2);
        Self {
            brdf,
            relative,
            power: reflectance.map_or(f64::NAN, |r| r / solid),
        }
    }

    /// The model value in the unit of a measurement of kind `kind` (a reflectance factor
    /// is `π × BRDF`).
    #[must_use]
    pub fn in_kind(&self, kind: MeasuredKind) -> f64 {
        match kind {
            MeasuredKind::Brdf => self.brdf,
            MeasuredKind::ReflectanceFactor => std::f64::consts::PI * self.brdf,
            MeasuredKind::Relative => self.relative,
        }
    }
}

/// The distribution model at incidence `theta_i` for in-plane detectors at `theta_s`
/// (radians), detectors of half-angle `aperture`.
///
/// # Errors
/// [`PipelineError::Model`] or [`PipelineError::Instrument`] for invalid input.
pub fn distribution_points(
    coating: &Coating,
    settings: &Settings,
    aperture: f64,
    orientation: &Orientation,
    theta_i: f64,
    theta_s: &[f64],
) -> Result<Vec<ModelPoint>, PipelineError> {
    let model = distribution_model(coating, settings, orientation.clone())?;
    let inc = model.incidence(theta_i)?;
    let cone = |ts: f64| {
        Cone::in_plane(ts, aperture).map_err(|e| PipelineError::Instrument(e.to_string()))
    };
    let method = if aperture == 0.0 {
        ConeMethod::Exact
    } else {
        settings.cone_method
    };
    model.check_method(&inc, aperture, method)?;
    let spec = model.collect(&inc, &cone(-theta_i)?, method).power_per_sr;
    theta_s
        .iter()
        .map(|&ts| {
            let c = model.collect(&inc, &cone(ts)?, method);
            Ok(ModelPoint {
                brdf: c.brdf,
                relative: if spec > 0.0 {
                    c.power_per_sr / spec
                } else {
                    f64::NAN
                },
                power: c.power_per_sr,
            })
        })
        .collect()
}

/// A model given as a table of rows `(θi, θs, point)` (radians), e.g. a saved result
/// of `model` or `topo`, evaluated at `theta_s` for incidence `theta_i`: each detector
/// must have a row within 1e-6° of it; `source` names the table in errors.
///
/// # Errors
/// [`PipelineError::Measurement`] naming the first detector without a row.
pub fn tabulated_points(
    rows: &[(f64, f64, ModelPoint)],
    source: &str,
    theta_i: f64,
    theta_s: &[f64],
) -> Result<Vec<ModelPoint>, PipelineError> {
    let tol = 1e-6f64.to_radians();
    theta_s
        .iter()
        .map(|&t| {
            rows.iter()
                .find(|(a, b, _)| (a - theta_i).abs() < tol && (b - t).abs() < tol)
                .map(|r| r.2)
                .ok_or_else(|| {
                    PipelineError::Measurement(format!(
                        "{source}: no row for theta_i_deg {}, theta_s_deg {} (the model was not computed at this measured angle)",
                        short_deg(theta_i),
                        short_deg(t)
                    ))
                })
        })
        .collect()
}

/// Degrees for messages, to 1e-6 without trailing zeros.
fn short_deg(rad: f64) -> String {
    let s = format!("{:.6}", rad.to_degrees());
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// A model as a function `(θi, &[θs]) -> model points` (radians).
pub type ModelFn<'a> = dyn Fn(f64, &[f64]) -> Result<Vec<ModelPoint>, PipelineError> + 'a;

/// One measured point next to the scaled model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComparedPoint {
    /// Incidence, radians.
    pub theta_i: f64,
    /// Detector, radians.
    pub theta_s: f64,
    /// Line in the measured file.
    pub line: u64,
    /// Measured value (as in the file).
    pub measured: f64,
    /// Model value in the same unit, times the fitted scale.
    pub model: f64,
    /// `log10(measured) − log10(model)`; NaN where the model is zero (such points are
    /// counted in [`RegionSummary::no_model`] and left out of the statistics).
    pub residual: f64,
    /// Region of the point.
    pub region: Region,
}

/// Residual statistics of one region at one incidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionSummary {
    /// The region.
    pub region: Region,
    /// Number of points in the statistics.
    pub points: usize,
    /// Points left out because the model is zero (or undefined) there.
    pub no_model: usize,
    /// Root mean square of the log10 residuals (`None` without points).
    pub rms_log10: Option<f64>,
    /// Mean of the log10 residuals (`None` without points).
    pub mean_log10: Option<f64>,
}

/// The comparison at one incidence.
#[derive(Debug, Clone, PartialEq)]
pub struct IncidenceComparison {
    /// Incidence, radians.
    pub theta_i: f64,
    /// Fitted vertical scale of the model (measured ≈ scale × model near specular).
    pub scale: f64,
    /// Per-region summaries, in [`Region::ALL`] order.
    pub regions: Vec<RegionSummary>,
    /// The points.
    pub points: Vec<ComparedPoint>,
}

impl IncidenceComparison {
    /// Its regions as JSON, one writer for `compare --json` and `analyze`'s
    /// `summary.json`: per region its name, points, points without a model value, and
    /// the rms and mean of `log10(model/measured)`.
    #[must_use]
    pub fn regions_json(&self) -> serde_json::Value {
        self.regions
            .iter()
            .map(|r| {
                serde_json::json!({
                    "region": r.region.name(),
                    "points": r.points,
                    "points_without_model": r.no_model,
                    "rms_log10": r.rms_log10,
                    "mean_log10": r.mean_log10,
                })
            })
            .collect()
    }
}

/// Two angles (radians) that stand for the same typed degrees: within 1e-9 rad.
fn same_angle(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// The points of `measured` at the incidences `theta_i` and detector angles `theta_s`
/// (radians; `None` keeps all). Every listed incidence must be in the file; the
/// detector list may be wider than the file (a range), but must match some point.
///
/// # Errors
/// [`PipelineError::Measurement`] naming the incidence that is not measured (with the
/// ones that are), or saying that the selection leaves no point.
pub fn select(
    measured: &MeasuredCurve,
    theta_i: Option<&[f64]>,
    theta_s: Option<&[f64]>,
) -> Result<MeasuredCurve, PipelineError> {
    let have = measured.incidences();
    let list = |v: &[f64]| {
        v.iter()
            .map(|&t| short_deg(t))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(missing) = theta_i.and_then(|ti| {
        ti.iter()
            .find(|&&t| !have.iter().any(|&h| same_angle(h, t)))
    }) {
        return Err(PipelineError::Measurement(format!(
            "{}: no measured point at θi = {}° (the file has θi = {}°)",
            measured.file,
            list(&[*missing]),
            list(&have)
        )));
    }
    let points: Vec<_> = measured
        .points
        .iter()
        .filter(|p| theta_i.is_none_or(|v| v.iter().any(|&t| same_angle(t, p.theta_i))))
        .filter(|p| theta_s.is_none_or(|v| v.iter().any(|&t| same_angle(t, p.theta_s))))
        .copied()
        .collect();
    if points.is_empty() {
        return Err(PipelineError::Measurement(format!(
            "{}: the selected angles match no measured point",
            measured.file
        )));
    }
    Ok(MeasuredCurve {
        file: measured.file.clone(),
        points,
    })
}

/// Points of `measured` at incidence `theta_i` as `(θs, value, line)`, checked for the
/// log scale.
///
/// # Errors
/// [`PipelineError::Measurement`] for a value ≤ 0.
pub fn points_at(
    measured: &MeasuredCurve,
    theta_i: f64,
) -> Result<Vec<(f64, f64, u64)>, PipelineError> {
    measured
        .points
        .iter()
        .filter(|p| p.theta_i == theta_i)
        .map(|p| {
            if p.value > 0.0 {
                Ok((p.theta_s, p.value, p.line))
            } else {
                Err(PipelineError::Measurement(format!(
                    "{}, line {}: value {} is not positive and cannot be compared on a log scale (remove the point, or give values above the noise floor)",
                    measured.file, p.line, p.value
                )))
            }
        })
        .collect()
}

/// Compare a measured curve with a model given as a function
/// `(θi, &[θs]) -> model points`, per incidence.
///
/// # Errors
/// [`PipelineError::Measurement`] for values ≤ 0 or an incidence without points in the
/// near-specular region (where the scale is fitted); model errors as they come.
pub fn compare(
    measured: &MeasuredCurve,
    kind: MeasuredKind,
    model: &ModelFn<'_>,
) -> Result<Vec<IncidenceComparison>, PipelineError> {
    let mut out = Vec::new();
    for ti in measured.incidences() {
        let pts = points_at(measured, ti)?;
        let ts: Vec<f64> = pts.iter().map(|p| p.0).collect();
        let values = model(ti, &ts)?;
        // Scale: mean log ratio over the near-specular points with a positive model.
        let logs: Vec<f64> = pts
            .iter()
            .zip(&values)
            .filter(|((ts, _, _), m)| {
                Region::of(ti, *ts) == Region::NearSpecular && m.in_kind(kind) > 0.0
            })
            .map(|((_, y, _), m)| y.ln() - m.in_kind(kind).ln())
            .collect();
        if logs.is_empty() {
            return Err(PipelineError::Measurement(format!(
                "{}: no measured point 5°–40° from specular with a non-zero model value at θi = {:.3}°; the vertical scale is fitted there",
                measured.file,
                ti.to_degrees()
            )));
        }
        let scale = (logs.iter().sum::<f64>() / logs.len() as f64).exp();
        let points: Vec<ComparedPoint> = pts
            .iter()
            .zip(&values)
            .map(|(&(ts, y, line), m)| {
                let mv = scale * m.in_kind(kind);
                ComparedPoint {
                    theta_i: ti,
                    theta_s: ts,
                    line,
                    measured: y,
                    model: mv,
                    residual: if mv > 0.0 {
                        y.log10() - mv.log10()
                    } else {
                        f64::NAN
                    },
                    region: Region::of(ti, ts),
                }
            })
            .collect();
        let regions = Region::ALL
            .iter()
            .map(|&region| {
                let all: Vec<f64> = points
                    .iter()
                    .filter(|p| p.region == region)
                    .map(|p| p.residual)
                    .collect();
                let r: Vec<f64> = all.iter().copied().filter(|x| x.is_finite()).collect();
                let n = r.len();
                RegionSummary {
                    region,
                    points: n,
                    no_model: all.len() - n,
                    rms_log10: (n > 0)
                        .then(|| (r.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt()),
                    mean_log10: (n > 0).then(|| r.iter().sum::<f64>() / n as f64),
                }
            })
            .collect();
        out.push(IncidenceComparison {
            theta_i: ti,
            scale,
            regions,
            points,
        });
    }
    Ok(out)
}
