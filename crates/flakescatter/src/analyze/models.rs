//! The models of an analysis (module docs of [`super`]): the distribution model from
//! the pooled width and from the pooled histogram, the topographic model, the width
//! fitted to the measured curve and the multi-angle readout, each as the manifest asks;
//! a model that fails is recorded and the others still run.

use flakescatter_io::measured::MeasuredCurve;
use flakescatter_stats::Orientation;
use flakescatter_stats::heightmap::HeightMap;

use super::cache::{FitRec, ModelCache, MultiRec, curve_rec};
use super::settings::measured_kind;
use super::{AnalyzeError, Manifest, TopoKind, Work, stage};
use crate::PipelineError;
use crate::fit::{FitSetup, fit_gaussian};
use crate::instrument::Instrument;
use crate::multiangle::multi_angle;
use crate::pipeline::{
    Coating, OrientationSource, Settings, TopoSettings, distribution_curves, isotropic_curves,
    topographic_curves,
};
use crate::sample::SampleStatistics;

/// Runs every model the manifest asks for (module docs).
#[allow(clippy::too_many_arguments)]
pub(super) fn run_models(
    m: &Manifest,
    key: String,
    instrument: &Instrument,
    coating: &Coating,
    stats: &SampleStatistics,
    maps: &[&HeightMap],
    measured: Option<&MeasuredCurve>,
    work: &mut Work,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<ModelCache, AnalyzeError> {
    let settings = Settings {
        clearcoat: m.models.clearcoat,
        ..Settings::default()
    };
    let mut curves = Vec::new();
    let mut failures = Vec::new();
    let width = stats
        .pooled
        .flake_level
        .orientation()
        .map_err(|e| stage("pooled width")(PipelineError::Orientation(e.to_string())))?;
    if m.models.distribution_fitted {
        progress("distribution model, pooled width", 0, 1);
        work.distribution_runs += 1;
        match distribution_curves(
            coating,
            instrument,
            &settings,
            &OrientationSource::Distribution(width.clone()),
        ) {
            Ok(c) => curves.push(curve_rec("distribution (pooled width)", &c)),
            Err(e) => failures.push(("distribution (pooled width)".into(), e.to_string())),
        }
    }
    if m.models.distribution_histogram {
        progress("distribution model, pooled histogram", 0, 1);
        work.distribution_runs += 1;
        match stats
            .histogram
            .to_orientation()
            .map_err(|e| PipelineError::Orientation(e.to_string()))
            .and_then(|o| {
                distribution_curves(
                    coating,
                    instrument,
                    &settings,
                    &OrientationSource::Distribution(o),
                )
            }) {
            Ok(c) => curves.push(curve_rec("distribution (pooled histogram)", &c)),
            Err(e) => failures.push(("distribution (pooled histogram)".into(), e.to_string())),
        }
    }
    let topo = TopoSettings {
        window: m.models.window,
        tile_um: m.models.tile_um,
    };
    let mut topo_warnings = Vec::new();
    let tick = |done: u64, total: u64| progress("topographic model", done as usize, total as usize);
    match m.models.topographic {
        TopoKind::None => {}
        TopoKind::Plain => {
            work.topographic_runs += 1;
            match topographic_curves(coating, instrument, &settings, &topo, maps, &tick) {
                Ok((c, r)) => {
                    topo_warnings.extend(r.warnings.iter().map(ToString::to_string));
                    curves.push(curve_rec("topographic", &c));
                }
                Err(e) => failures.push(("topographic".into(), e.to_string())),
            }
        }
        TopoKind::Isotropic => {
            work.topographic_runs += 1;
            match isotropic_curves(coating, instrument, &settings, &topo, None, maps, &tick) {
                Ok((c, r)) => {
                    topo_warnings.extend(r.warnings.iter().map(ToString::to_string));
                    curves.push(curve_rec("topographic (isotropic)", &c));
                }
                Err(e) => failures.push(("topographic (isotropic)".into(), e.to_string())),
            }
        }
    }
    let fit = fit_part(
        m, instrument, coating, &settings, stats, measured, work, progress,
    );
    let multi = multi_part(m, instrument, coating, &settings, width, work, progress);
    Ok(ModelCache {
        key,
        curves,
        failures,
        fit,
        multi_angle: multi,
        topo_warnings,
    })
}

/// The width fitted to the measured curve, when the manifest asks for it and there is a
/// measured curve.
#[allow(clippy::too_many_arguments)]
fn fit_part(
    m: &Manifest,
    instrument: &Instrument,
    coating: &Coating,
    settings: &Settings,
    stats: &SampleStatistics,
    measured: Option<&MeasuredCurve>,
    work: &mut Work,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Option<Result<FitRec, String>> {
    match (m.models.fit, measured) {
        (true, Some(curve)) => {
            progress("width fit to the measured curve", 0, 1);
            work.fits += 1;
            let kind = measured_kind(m);
            let setup = FitSetup::new(coating.clone(), *settings, instrument.aperture(), kind);
            Some(
                fit_gaussian(curve, &setup, stats.pooled.hwhm(), false)
                    .map(|f| FitRec {
                        hwhm: f.hwhm,
                        hwhm_std: f.hwhm_std,
                        scales: f.scales.clone(),
                        chi2: f.chi2,
                        dof: f.dof,
                        points: f.points,
                        iterations: f.iterations,
                        uncertainty_basis: f.uncertainty_basis.describe().to_owned(),
                        uncertainty_scale: f.uncertainty_scale,
                        warnings: f.warnings.iter().map(ToString::to_string).collect(),
                    })
                    .map_err(|e| e.to_string()),
            )
        }
        _ => None,
    }
}

/// The multi-angle readout with the pooled width `width`, when the manifest asks for it.
fn multi_part(
    m: &Manifest,
    instrument: &Instrument,
    coating: &Coating,
    settings: &Settings,
    width: Orientation,
    work: &mut Work,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Option<Result<MultiRec, String>> {
    m.models.multi_angle.then(|| {
        progress("multi-angle readout", 0, 1);
        work.multi_angle_runs += 1;
        multi_angle(
            coating,
            settings,
            &OrientationSource::Distribution(width),
            instrument.aperture(),
        )
        .map(|r| MultiRec {
            theta_i: r.theta_i,
            readouts: r
                .readouts
                .iter()
                .map(|x| (x.aspecular, x.reflectance_factor, x.lightness))
                .collect(),
            flop_index: r.flop_index,
        })
        .map_err(|e| e.to_string())
    })
}
