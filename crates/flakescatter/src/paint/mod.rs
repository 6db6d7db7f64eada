//! Real paints (physics.md §12): measured BRDF tables read into the paint model of
//! [`flakescatter_paint`] (re-exported as [`crate::paint_model`]), its joint fit, a
//! fitted paint evaluated at an instrument's geometry, and a fixed paint compared with a
//! table; the parameter file (`P.json`, [`file`]) and the reports shared by the
//! command-line tool and `analyze` ([`report`]).
//!
//! Conventions: radians in every API, BRDFs in sr⁻¹; the detector azimuth `φr = 0` is
//! the specular half-plane (as `--detectors`).

mod curves;
pub mod file;
pub mod report;

use std::path::Path;

pub use curves::{PaintCurves, PaintRow, paint_curves};
use flakescatter_io::brdf::{BrdfTable, looks_like_brdf_table, read_brdf_table};
use flakescatter_io::measured::{MeasuredCurve, read_measured};
use flakescatter_paint::Channel;
pub use flakescatter_paint::fit::{
    Estimate, Evidence, Family, FitOptions, GroupResidual, Measurement, Observation, PaintFit,
    PaintFitWarning, Point, Region, Selection,
};
use flakescatter_paint::{PaintError, PaintModel};

use crate::PipelineError;
use crate::compare::MeasuredKind;

/// Reads a measured table for the paint model: a BRDF table (`theta_r_deg`,
/// `phi_r_deg`, `brdf_<channel>_per_sr` columns; [`flakescatter_io::brdf`]) or an
/// in-plane curve (`theta_s_deg`, `value`; one channel named `value`) whose values are
/// BRDFs or reflectance factors as `kind` says (divided by π).
///
/// # Errors
/// [`PipelineError::Measurement`] naming the file, line and column: unreadable, a
/// malformed or unknown column, angles out of range, values that are not positive, a
/// geometry given twice; relative values (a paint has an absolute BRDF).
pub fn read_measurement(path: &Path, kind: MeasuredKind) -> Result<Measurement, PipelineError> {
    let text = flakescatter_io::files::read_text(path)
        .map_err(|e| PipelineError::Measurement(e.to_string()))?;
    if looks_like_brdf_table(&text) {
        let table = read_brdf_table(path, &|name| {
            Channel::parse(name).map(|_| ()).map_err(|e| e.to_string())
        })
        .map_err(|e| PipelineError::Measurement(e.to_string()))?;
        return from_table(table);
    }
    let curve = read_measured(path).map_err(|e| PipelineError::Measurement(e.to_string()))?;
    from_curve(&curve, kind)
}

/// The paint fit's view of a BRDF table.
///
/// # Errors
/// [`PipelineError::Measurement`] for a channel name the paint model does not know.
pub fn from_table(t: BrdfTable) -> Result<Measurement, PipelineError> {
    let channels = t
        .channels
        .iter()
        .map(|c| {
            Channel::parse(c).map_err(|e| {
                PipelineError::Measurement(format!(
                    "{}, line {}, column brdf_{c}_per_sr: {e}",
                    t.file, t.header_line
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Measurement {
        file: t.file,
        channels,
        rows: t
            .rows
            .into_iter()
            .map(|r| Observation {
                theta_i: r.theta_i,
                theta_r: r.theta_r,
                phi_r: r.phi_r,
                values: r.values,
                uncertainties: r.uncertainties,
                line: r.line,
            })
            .collect(),
    })
}

/// The paint fit's view of an in-plane curve (module docs of [`read_measurement`]).
///
/// # Errors
/// [`PipelineError::Measurement`] for relative values, a value that is not positive, or
/// a geometry given twice (named by line).
pub fn from_curve(c: &MeasuredCurve, kind: MeasuredKind) -> Result<Measurement, PipelineError> {
    let scale = match kind {
        MeasuredKind::Brdf => 1.0,
        MeasuredKind::ReflectanceFactor => 1.0 / std::f64::consts::PI,
        MeasuredKind::Relative => {
            return Err(PipelineError::Measurement(format!(
                "{}: relative values (normalised to specular) cannot be fitted by a paint, whose BRDF is absolute; give BRDFs or reflectance factors (--measured-kind)",
                c.file
            )));
        }
    };
    let mut rows: Vec<Observation> = Vec::with_capacity(c.points.len());
    for p in &c.points {
        if !(p.value > 0.0) {
            return Err(PipelineError::Measurement(format!(
                "{}, line {}, column value: {} is not positive: a paint is fitted in log",
                c.file, p.line, p.value
            )));
        }
        if let Some(first) = rows.iter().find(|o| {
            o.theta_i == p.theta_i && o.line != p.line && {
                let ts = if o.phi_r == 0.0 {
                    -o.theta_r
                } else {
                    o.theta_r
                };
                ts == p.theta_s
            }
        }) {
            return Err(PipelineError::Measurement(format!(
                "{}, line {}, columns theta_i_deg, theta_s_deg: the geometry is already on line {}",
                c.file, p.line, first.line
            )));
        }
        let (theta_r, phi_r) = if p.theta_s <= 0.0 {
            (-p.theta_s, 0.0)
        } else {
            (p.theta_s, std::f64::consts::PI)
        };
        rows.push(Observation {
            theta_i: p.theta_i,
            theta_r,
            phi_r,
            values: vec![p.value * scale],
            uncertainties: vec![p.uncertainty.map(|u| u * scale)],
            line: p.line,
        });
    }
    Ok(Measurement {
        file: c.file.clone(),
        channels: vec![Channel::parse("value").map_err(PipelineError::Paint)?],
        rows,
    })
}

/// The joint fit (module docs of [`flakescatter_paint::fit`]).
///
/// # Errors
/// [`PipelineError::Paint`] as the fit says.
pub fn fit(m: &Measurement, opts: &FitOptions) -> Result<PaintFit, PipelineError> {
    Ok(flakescatter_paint::fit::fit_paint(m, opts)?)
}

/// A fixed paint against a table.
#[derive(Debug, Clone)]
pub struct PaintComparison {
    /// The points compared.
    pub points: Vec<Point>,
    /// The paint at each, sr⁻¹.
    pub model: Vec<f64>,
    /// Residual groups.
    pub groups: Vec<GroupResidual>,
}

/// Compare `model` with the points of `m` within `sel` (no fit).
///
/// # Errors
/// [`PipelineError::Paint`]: a channel of the table that the paint does not have
/// (named, with the paint's channels), no usable point.
pub fn compare(
    model: &PaintModel,
    m: &Measurement,
    sel: &Selection,
) -> Result<PaintComparison, PipelineError> {
    let (points, values) = flakescatter_paint::fit::evaluate(model, m, sel)?;
    let groups = flakescatter_paint::fit::group_residuals(m, &points, &values);
    Ok(PaintComparison {
        points,
        model: values,
        groups,
    })
}

impl From<PaintError> for PipelineError {
    fn from(e: PaintError) -> Self {
        Self::Paint(e)
    }
}
