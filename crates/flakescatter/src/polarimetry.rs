//! Polarimetry (physics.md §11): both models' Mueller matrices per detector, the BRDF a
//! detector reads for a given incident polarisation and analyser, and the degree of
//! polarisation of the scattered light for unpolarised incidence.
//!
//! Conventions: radians in, radians out; SCATMECH's Stokes/Mueller convention
//! ([`flakescatter_optics::mueller`]): incident Stokes vectors in the `(s, p)` basis of
//! the incident direction (`s = y`, `p = (cos θi, 0, sin θi)`), everything a detector
//! collects in the basis of its axis `(θr, φr)` (`s = (−sin φr, cos φr, 0)`, `p = r × s`;
//! at `θr = 0` too, the limit `θr → 0` at the detector's `φr`). Mueller BRDFs in sr⁻¹,
//! row-major `m00 … m33`; `m00` is the unpolarised BRDF of the scalar curves, exact in
//! every direction. The detected BRDF for an incident Stokes vector `s` (normalised to
//! `S0 = 1`) behind an analyser with row `a` ([`Analyzer::row`]) is `a · M · s`. The
//! polarisation is given here, not by [`Settings::transmission`], which must be left at
//! its default (`exact-unpolarized`): `s`/`p` incidence is the Stokes vector
//! `(1, ±1, 0, 0)`, and `paper`'s product of averages has no Mueller form.

use flakescatter_gaussian::{ConeMethod, curve_mueller};
use flakescatter_optics::mueller::{Analyzer, Mueller, Stokes};
use flakescatter_optics::polarization::Transmission;
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_topo::{TopoModel, TopoOptions, TopoResult};

use crate::PipelineError;
use crate::instrument::Instrument;
use crate::pipeline::{
    Coating, CurveRow, Curves, OrientationSource, Settings, TopoSettings, distribution_model,
};

/// The polarisation of the incident beam and what stands in front of the detectors.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Polarimetry {
    /// Incident Stokes vector (default unpolarised); normalised to unit power.
    pub incident: Stokes,
    /// Analyser in front of every detector (default none).
    pub analyzer: Analyzer,
}

impl Polarimetry {
    /// The 16 weights `w_ij = a_i s_j` of the detected value `Σ w_ij m_ij` (row-major).
    #[must_use]
    pub fn readout(&self) -> [f64; 16] {
        let a = self.analyzer.row();
        let s = self.incident.normalized().parameters();
        let mut w = [0.0; 16];
        for (e, v) in w.iter_mut().enumerate() {
            *v = a[e / 4] * s[e % 4];
        }
        w
    }

    /// The detected value `a · M · s` of a Mueller matrix.
    #[must_use]
    pub fn detect(&self, m: &Mueller) -> f64 {
        m.detected(&self.incident, &self.analyzer)
    }
}

/// One row of a Mueller curve: one incidence × one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MuellerRow {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// Index of the detector in the instrument's list.
    pub detector: usize,
    /// Cone-averaged Mueller BRDF, sr⁻¹, row-major (the point Mueller BRDF for aperture
    /// 0), in the detector's basis.
    pub brdf: [f64; 16],
    /// Collected fraction of the incident beam as a Mueller matrix (no unit),
    /// row-major; `None` for point detectors.
    pub reflectance: Option<[f64; 16]>,
    /// Standard error of each element of `brdf`, sr⁻¹: from the map tiles
    /// (topographic model) or the quadrature's error estimate, the largest over the
    /// elements (distribution model, exact cone integral; `None` for the
    /// constant-integrand approximation).
    pub brdf_std_err: Option<[f64; 16]>,
    /// The BRDF the detector reads for the incident polarisation and analyser,
    /// `a · M · s`, sr⁻¹.
    pub detected_brdf: f64,
    /// Standard error of `detected_brdf` (as `brdf_std_err`), sr⁻¹.
    pub detected_std_err: Option<f64>,
    /// The fraction of the incident beam the detector reads for the incident
    /// polarisation and analyser, `a · R · s` of `reflectance`; `None` for point
    /// detectors.
    pub detected_reflectance: Option<f64>,
    /// The detected power relative to that of the same detector at the specular
    /// direction (the `relative` of the scalar curves for this polarisation).
    pub relative: f64,
    /// Degree of polarisation of the collected light for unpolarised incidence,
    /// `sqrt(m10² + m20² + m30²)/m00`; NaN where nothing is collected.
    pub dop_unpolarized: f64,
    /// Rays counted (topographic model only).
    pub rays: Option<u64>,
}

/// Mueller curves with what they were computed from.
#[derive(Debug, Clone)]
pub struct MuellerCurves {
    /// Which model produced them (`distribution` or `topographic`).
    pub model: &'static str,
    /// The instrument.
    pub instrument: Instrument,
    /// The coating.
    pub coating: Coating,
    /// The settings.
    pub settings: Settings,
    /// The polarisation of the beam and the analyser.
    pub polarimetry: Polarimetry,
    /// Rows, ordered by incidence then detector.
    pub rows: Vec<MuellerRow>,
    /// Free-form description of the source, for metadata.
    pub source: String,
}

impl MuellerCurves {
    /// What the detectors read for [`MuellerCurves::polarimetry`], as scalar curves:
    /// per row `detected_brdf`, `detected_reflectance`, `relative`, `rays` and
    /// `detected_std_err` in the fields of [`CurveRow`] (for unpolarised light and no
    /// analyser these are the scalar curves of the same model, `m00`).
    #[must_use]
    pub fn detected_curves(&self) -> Curves {
        Curves {
            model: self.model,
            instrument: self.instrument.clone(),
            coating: self.coating.clone(),
            settings: self.settings,
            rows: self
                .rows
                .iter()
                .map(|r| CurveRow {
                    theta_i: r.theta_i,
                    detector: r.detector,
                    brdf: r.detected_brdf,
                    reflectance: r.detected_reflectance,
                    relative: r.relative,
                    rays: r.rays,
                    std_err: r.detected_std_err,
                })
                .collect(),
            source: self.source.clone(),
        }
    }
}

/// Refuses settings whose polarisation bookkeeping has no Mueller form (module docs).
fn check_settings(settings: &Settings) -> Result<(), PipelineError> {
    if settings.base_albedo != 0.0 {
        return Err(PipelineError::Polarization(
            "a base under the flakes (base albedo) is modelled for unpolarised light: it does not apply to Mueller matrices".into(),
        ));
    }
    if settings.transmission != Transmission::ExactUnpolarized {
        return Err(PipelineError::Polarization(format!(
            "transmission `{}` does not apply to Mueller matrices: they are exact for every polarisation; give the incident polarisation as a Stokes vector (s = (1, 1, 0, 0), p = (1, -1, 0, 0)) and leave the transmission at `exact-unpolarized`",
            settings.transmission
        )));
    }
    Ok(())
}

fn row_major(m: &Mueller) -> [f64; 16] {
    m.to_row_major()
}

/// The distribution model's Mueller matrices (physics.md §4, §11) for `source` seen by
/// `instrument`, with the detected BRDF for `polarimetry`.
///
/// # Errors
/// [`PipelineError::Polarization`] for a non-default [`Settings::transmission`],
/// [`PipelineError::Model`] for an invalid coating or a constant-integrand request the
/// model refuses, [`PipelineError::Orientation`] for a source that gives no distribution.
pub fn distribution_mueller(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    source: &OrientationSource,
    polarimetry: &Polarimetry,
) -> Result<MuellerCurves, PipelineError> {
    check_settings(settings)?;
    let orientation = source.orientation()?;
    let description = crate::pipeline::describe(&orientation);
    let model = distribution_model(coating, settings, orientation)?;
    let method = settings.cone_method;
    let points = curve_mueller(&model, instrument.theta_i(), instrument.cones(), method)?;
    // The specular detector of each incidence, for `relative` (one aperture per
    // instrument).
    let alpha = instrument.aperture();
    let mut spec = Vec::with_capacity(instrument.theta_i().len());
    for &ti in instrument.theta_i() {
        let cone = flakescatter_optics::detector::Cone::in_plane(-ti, alpha)
            .map_err(|e| PipelineError::Instrument(e.to_string()))?;
        let inc = model.incidence(ti)?;
        spec.push(polarimetry.detect(&model.collect_mueller(&inc, &cone, method).power_per_sr));
    }
    let nd = instrument.cones().len();
    let weights = polarimetry.readout();
    let rows = points
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let c = &p.collected;
            // The quadrature's error bound (largest element error of ρ) in BRDF units.
            let proj = p.cone.projected_solid_angle();
            let err = match c.reflectance {
                Some(_) if proj > 0.0 => c.error / proj,
                Some(_) => 0.0,
                None => c.error,
            };
            let exact = method == ConeMethod::Exact;
            let detected = polarimetry.detect(&c.brdf);
            let s = spec[k / nd];
            MuellerRow {
                theta_i: p.theta_i,
                detector: k % nd,
                brdf: row_major(&c.brdf),
                reflectance: c.reflectance.as_ref().map(row_major),
                brdf_std_err: exact.then_some([err; 16]),
                detected_brdf: detected,
                detected_std_err: exact.then(|| err * weights.iter().map(|w| w.abs()).sum::<f64>()),
                detected_reflectance: c.reflectance.as_ref().map(|r| polarimetry.detect(r)),
                relative: if s > 0.0 {
                    polarimetry.detect(&c.power_per_sr) / s
                } else {
                    f64::NAN
                },
                dop_unpolarized: c.brdf.dop_unpolarized(),
                rays: None,
            }
        })
        .collect();
    Ok(MuellerCurves {
        model: "distribution",
        instrument: instrument.clone(),
        coating: coating.clone(),
        settings: *settings,
        polarimetry: *polarimetry,
        rows,
        source: description,
    })
}

/// The topographic model's Mueller matrices (physics.md §5, §11) over `maps` (their
/// masks already holding any intensity cutoff), accumulated into one result, with the
/// detected BRDF for `polarimetry` and its tile standard error. `progress(done, total)`
/// is called from the calling thread as tiles finish. Returns the curves and the run's
/// totals (pixels, usable pixels, rays traced and lost; `points` empty).
///
/// # Errors
/// [`PipelineError::Polarization`] for a non-default [`Settings::transmission`],
/// [`PipelineError::Topo`] for invalid options or maps, [`PipelineError::Instrument`]
/// for point detectors (aperture 0).
pub fn topographic_mueller(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    maps: &[&HeightMap],
    polarimetry: &Polarimetry,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(MuellerCurves, TopoResult), PipelineError> {
    check_settings(settings)?;
    if instrument.aperture() <= 0.0 {
        return Err(PipelineError::Instrument(
            "the topographic model counts rays into detector cones: the aperture must be > 0"
                .into(),
        ));
    }
    let model = TopoModel::new(TopoOptions {
        n: coating.n,
        transmission: settings.transmission,
        weighting: settings.weighting,
        flake: coating.flake.clone(),
        clearcoat: settings.clearcoat,
        window: topo.window,
    })?
    .with_block_um(topo.tile_um)?;
    let result = model.run_mueller(
        maps,
        instrument.theta_i(),
        instrument.cones(),
        &polarimetry.readout(),
        progress,
    )?;
    let nd = instrument.cones().len();
    let rows = result
        .points
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let inv_proj = 1.0 / p.cone.projected_solid_angle();
            MuellerRow {
                theta_i: p.theta_i,
                detector: k % nd,
                brdf: row_major(&p.brdf),
                reflectance: Some(row_major(&p.reflectance)),
                brdf_std_err: p.brdf_std_err.as_ref().map(row_major),
                detected_brdf: p.readout * inv_proj,
                detected_std_err: p.readout_std_err.map(|e| e * inv_proj),
                detected_reflectance: Some(polarimetry.detect(&p.reflectance)),
                relative: p.relative,
                dop_unpolarized: p.brdf.dop_unpolarized(),
                rays: Some(p.rays),
            }
        })
        .collect();
    let totals = result.totals;
    let curves = MuellerCurves {
        model: "topographic",
        instrument: instrument.clone(),
        coating: coating.clone(),
        settings: *settings,
        polarimetry: *polarimetry,
        rows,
        source: format!(
            "{} height map(s), {} usable of {} pixels",
            maps.len(),
            totals.usable_pixels,
            totals.pixels
        ),
    };
    Ok((curves, totals))
}
