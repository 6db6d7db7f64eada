//! Real paints (physics.md §12): measured BRDF tables read into the paint model of
//! [`flakescatter_paint`] (re-exported as [`crate::paint_model`]), its joint fit, a
//! fitted paint evaluated at an instrument's geometry, and a fixed paint compared with a
//! table; the parameter file (`P.json`, [`file`](mod@file)) and the reports shared by the
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
    Estimate, Evidence, Family, FitExtras, FitOptions, GroupResidual, MAX_TINT, Measurement,
    Observation, PaintFit, PaintFitWarning, Point, Region, Selection, ThicknessFit,
};
use flakescatter_paint::{PaintError, PaintModel};

use crate::PipelineError;
use crate::compare::MeasuredKind;
use crate::film::StackFlakeError;

/// Interference flakes for a paint from text, as `--flake-stack` and `--flake-core` give
/// them (against the built-in catalogue): the stack is taken at each channel's
/// wavelength when the paint is built (physics.md §12.7).
///
/// # Errors
/// [`StackFlakeError::Spec`] for a stack that does not parse (naming the layer),
/// [`StackFlakeError::Core`] for an unknown core.
pub fn stack_flakes(
    stack: &str,
    core: Option<&str>,
) -> Result<flakescatter_paint::FlakeMetal, StackFlakeError> {
    let catalogue = flakescatter_optics::catalogue::Catalogue::builtin();
    let stack = flakescatter_optics::stack_spec::StackSpec::parse(stack, &catalogue)
        .map_err(StackFlakeError::Spec)?;
    let core = core
        .map(|c| catalogue.parse(c))
        .transpose()
        .map_err(StackFlakeError::Core)?;
    Ok(flakescatter_paint::FlakeMetal::stack(stack, core))
}

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
    if flakescatter_io::merl::is_merl_file(path) {
        let table = flakescatter_io::merl::read_merl(path)
            .map_err(|e| PipelineError::Measurement(e.to_string()))?;
        return Ok(from_merl(&table, &path.display().to_string()));
    }
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

/// Incidences of the rows [`from_merl`] takes from a MERL table, degrees.
pub const MERL_THETA_I_DEG: [f64; 5] = [15.0, 30.0, 45.0, 60.0, 75.0];
/// Azimuths of its out-of-plane detectors, degrees (`φr = 0` the specular half-plane).
pub const MERL_PHI_R_DEG: [f64; 8] = [10.0, 20.0, 30.0, 45.0, 60.0, 90.0, 120.0, 150.0];

/// The paint fit's view of a MERL table (channels `r`, `g`, `b`): the table looked up
/// as MERL's reference reader does ([`flakescatter_io::merl::MerlTable::lookup`]) on
/// the grid of the shipped paint tables (`fixtures/real/paints/README.md`): incidences
/// [`MERL_THETA_I_DEG`]; in-plane detectors `θr = 0…85°` in 1° steps on both sides
/// (`φr = 0` and 180°); out-of-plane detectors `θr = 5…80°` in 5° steps at
/// [`MERL_PHI_R_DEG`]; point detectors. A geometry whose bin has no value, or a value
/// that is not positive in some channel, is left out (a paint is fitted in log). Rows
/// carry no uncertainty; `line` is 0 (a binary file has none).
#[must_use]
pub fn from_merl(table: &flakescatter_io::merl::MerlTable, file: &str) -> Measurement {
    let mut detectors: Vec<(f64, f64)> = Vec::new();
    for t in 0..=85 {
        detectors.push((f64::from(t), 0.0));
        if t > 0 {
            detectors.push((f64::from(t), 180.0));
        }
    }
    for &p in &MERL_PHI_R_DEG {
        for t in (5..=80).step_by(5) {
            detectors.push((f64::from(t), p));
        }
    }
    let mut rows = Vec::new();
    for &ti in &MERL_THETA_I_DEG {
        let ti = ti.to_radians();
        let wi = [-ti.sin(), 0.0, ti.cos()];
        for &(tr, pr) in &detectors {
            let (tr, pr) = (tr.to_radians(), pr.to_radians());
            let wo = [tr.sin() * pr.cos(), tr.sin() * pr.sin(), tr.cos()];
            if let Some(v) = table.lookup(wi, wo)
                && v.iter().all(|x| *x > 0.0)
            {
                rows.push(Observation {
                    theta_i: ti,
                    theta_r: tr,
                    phi_r: pr,
                    values: v.to_vec(),
                    uncertainties: vec![None; 3],
                    line: 0,
                });
            }
        }
    }
    Measurement {
        file: file.to_owned(),
        channels: ["r", "g", "b"]
            .iter()
            .map(|c| Channel::parse(c).expect("r, g and b are channels"))
            .collect(),
        rows,
    }
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

/// The joint fit with the parameters `extras` adds (`extras.tint`: the binder's tint
/// over the flakes per channel, physics.md §12.9).
///
/// # Errors
/// [`PipelineError::Paint`] as the fit says.
pub fn fit_with(
    m: &Measurement,
    opts: &FitOptions,
    extras: FitExtras,
) -> Result<PaintFit, PipelineError> {
    Ok(flakescatter_paint::fit::fit_paint_with(m, opts, extras)?)
}

/// Fit `m` with the flakes of `opts` piled `N` deep for every `N` in `1..=max`, the
/// lowest `χ²` kept (physics.md §12.8).
///
/// # Errors
/// [`PipelineError::Paint`] for flakes that are not a free stack, `max` outside
/// 1–1000, or a fit that fails at every `N`.
pub fn fit_flake_layers(
    m: &Measurement,
    opts: &FitOptions,
    max: u32,
) -> Result<flakescatter_paint::fit::LayersFit, PipelineError> {
    Ok(flakescatter_paint::fit::fit_flake_layers(m, opts, max)?)
}

/// [`fit_flake_layers`] with the parameters `extras` adds to every fit.
///
/// # Errors
/// As [`fit_flake_layers`].
pub fn fit_flake_layers_with(
    m: &Measurement,
    opts: &FitOptions,
    max: u32,
    extras: FitExtras,
) -> Result<flakescatter_paint::fit::LayersFit, PipelineError> {
    Ok(flakescatter_paint::fit::fit_flake_layers_with(
        m, opts, max, extras,
    )?)
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
