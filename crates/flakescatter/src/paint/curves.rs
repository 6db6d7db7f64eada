//! A paint at an instrument's geometry: one row per incidence × detector with the BRDF
//! of every channel (averaged over the detector cone; the point BRDF for point
//! detectors) and what the cone collects.

use flakescatter_optics::Vec3;
use flakescatter_optics::detector::Cone;
use flakescatter_paint::PaintModel;
use flakescatter_paint::cone::collect;
use rayon::prelude::*;

use crate::PipelineError;
use crate::instrument::Instrument;

/// One incidence × one detector.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintRow {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// The detector.
    pub cone: Cone,
    /// Per channel (the model's order), the cone-averaged BRDF, sr⁻¹.
    pub brdf: Vec<f64>,
    /// Per channel, the fraction of the beam the cone collects.
    pub power: Vec<f64>,
}

/// A paint's curves.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintCurves {
    /// Channel names, in order.
    pub channels: Vec<String>,
    /// Rows, incidence-major in the instrument's order.
    pub rows: Vec<PaintRow>,
}

/// The paint `model` at `instrument` (rows computed in parallel; the same numbers for
/// any thread count).
///
/// # Errors
/// [`PipelineError::Paint`] for an incidence the model refuses.
pub fn paint_curves(
    model: &PaintModel,
    instrument: &Instrument,
) -> Result<PaintCurves, PipelineError> {
    let channels: Vec<String> = model
        .params()
        .channels
        .iter()
        .map(|c| c.channel.name.clone())
        .collect();
    let incidences = instrument
        .theta_i()
        .iter()
        .map(|&t| model.incidence(t))
        .collect::<Result<Vec<_>, _>>()?;
    let cones = instrument.cones();
    let alpha = instrument.aperture();
    let rows = (0..incidences.len() * cones.len())
        .into_par_iter()
        .map(|k| {
            let inc = &incidences[k / cones.len()];
            let cone = cones[k % cones.len()];
            let axis: Vec3 = cone.axis().into_inner();
            let (brdf, power) = (0..channels.len())
                .map(|ch| {
                    let c = collect(model, inc, &axis, alpha, ch);
                    (c.brdf, c.power)
                })
                .unzip();
            PaintRow {
                theta_i: inc.theta_i,
                cone,
                brdf,
                power,
            }
        })
        .collect();
    Ok(PaintCurves { channels, rows })
}
