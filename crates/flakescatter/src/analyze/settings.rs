//! The settings of an analysis, read off its manifest: the loader options, the
//! segmentation parameters, the coating, the instrument of the models and the kind of
//! the measured quantity.

use flakescatter_io::measured::MeasuredCurve;
use flakescatter_io::stack::{PageOrder, StackOptions};
use flakescatter_io::{ReadOptions, ZUnit};
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_stats::segment::SegmentParams;

use super::{AnalyzeError, Manifest, stage};
use crate::compare::MeasuredKind;
use crate::inputs::LoadOptions;
use crate::instrument::{DetectorSet, Instrument};
use crate::pipeline::Coating;

/// The loader options of a manifest.
///
/// # Errors
/// A message naming the key for values [`Manifest::validate`] lets through but the
/// readers refuse (e.g. an unknown z unit).
pub fn load_options(m: &Manifest) -> Result<LoadOptions, String> {
    let z_unit = match &m.maps.z_unit {
        Some(z) => Some(
            z.parse::<ZUnit>()
                .map_err(|e| format!("key `maps.z_unit`: {e}"))?,
        ),
        None => None,
    };
    let read = ReadOptions {
        pixel_um: m.maps.pixel_um.map(|[x, y]| (x, y)),
        z_unit,
        ..ReadOptions::default()
    };
    let peak = flakescatter_confocal::PeakOptions {
        method: flakescatter_confocal::PeakMethod::from_name(&m.stack.peak)
            .ok_or_else(|| format!("key `stack.peak`: `{}` is not a method", m.stack.peak))?,
        min_signal: m
            .stack
            .min_signal
            .map_or(flakescatter_confocal::MinSignal::Estimated, |v| {
                flakescatter_confocal::MinSignal::Level(v)
            }),
        ..flakescatter_confocal::PeakOptions::default()
    };
    Ok(LoadOptions {
        read,
        cutoff: m.maps.cutoff,
        stack: StackOptions {
            pixel_um: read.pixel_um,
            z_step_um: m.stack.z_step_um,
            first_page: match m.stack.first_page.as_deref() {
                Some("top") => Some(PageOrder::TopFirst),
                Some(_) => Some(PageOrder::BottomFirst),
                None => None,
            },
        },
        peak,
    })
}

pub(super) fn segment_params(m: &Manifest) -> SegmentParams {
    let mut p = SegmentParams::for_instrument(m.instrument.z_step_um, m.instrument.noise_um);
    p.min_pixels = m.instrument.min_pixels;
    p
}

pub(super) fn coating_of(m: &Manifest) -> Result<Coating, String> {
    let c = &m.coating;
    let flake = match (c.flake_index, &c.flake_stack, c.wavelength_nm) {
        (Some([n, k]), _, _) => FlakeReflectance::complex(n, k)
            .map_err(|e| format!("key `coating.flake_index`: {e}"))?,
        (None, Some(stack), Some(wl)) => {
            crate::film::stack_flake(stack, c.flake_core.as_deref(), wl)
                .map_err(|e| format!("key `coating.flake_stack`: {e}"))?
        }
        _ => FlakeReflectance::PerfectConductor,
    };
    Coating::new(m.coating.n, flake).map_err(|e| format!("key `coating.n`: {e}"))
}

/// The instrument of the models: the manifest's incidences (default the measured
/// ones, else 30° and 60°) and detectors.
pub(super) fn instrument_of(
    m: &Manifest,
    measured: Option<&MeasuredCurve>,
) -> Result<Instrument, AnalyzeError> {
    let ti: Vec<f64> = match (&m.models.theta_i_deg, measured) {
        (Some(t), _) => t.iter().map(|d| d.to_radians()).collect(),
        (None, Some(c)) => c.incidences(),
        (None, None) => vec![30f64.to_radians(), 60f64.to_radians()],
    };
    let ts: Vec<f64> = match &m.models.theta_s_deg {
        Some(a) => a
            .degrees("models.theta_s_deg")
            .map_err(AnalyzeError::Input)?
            .iter()
            .map(|d| d.to_radians())
            .collect(),
        None => (-140..=140)
            .map(|k| (f64::from(k) * 0.5).to_radians())
            .collect(),
    };
    Instrument::new(
        ti,
        DetectorSet::InPlane(ts),
        m.models.aperture_deg.to_radians(),
    )
    .map_err(stage("instrument"))
}

pub(super) fn kind_name(m: &Manifest) -> String {
    m.measured
        .as_ref()
        .map_or_else(|| "brdf".into(), |s| s.kind.clone())
}

/// The measured quantity named by `measured.kind` (the default when there is none).
pub(super) fn measured_kind(m: &Manifest) -> MeasuredKind {
    m.measured
        .as_ref()
        .and_then(|s| s.kind.parse().ok())
        .unwrap_or_default()
}

/// The in-plane detector angles of `instrument`, radians (none for out-of-plane ones).
pub(super) fn in_plane_angles(instrument: &Instrument) -> Vec<f64> {
    match instrument.detectors() {
        DetectorSet::InPlane(ts) => ts.clone(),
        DetectorSet::OutOfPlane(_) => Vec::new(),
    }
}
