//! The instrument: incidence angles, detectors and their aperture.
//!
//! Conventions (physics.md §1): radians; in-plane detectors by the signed angle `θs`
//! (`θs = −θi` specular, `θs > 0` on the source side); out-of-plane detectors by
//! `(θr, φr)` with `φr = 0` the specular half-plane. The aperture is the half-angle of
//! every detector's cone; 0 means point detectors.

use flakescatter_optics::detector::Cone;

use crate::PipelineError;

/// Largest accepted aperture half-angle, radians (20°).
pub const MAX_APERTURE: f64 = 20.0 * std::f64::consts::PI / 180.0;

/// Where the detectors are.
#[derive(Debug, Clone, PartialEq)]
pub enum DetectorSet {
    /// In the plane of incidence, at signed angles `θs ∈ (−π/2, π/2)` (radians).
    InPlane(Vec<f64>),
    /// Anywhere above the sample, at `(θr, φr)` (radians), `θr ∈ [0, π/2)`.
    OutOfPlane(Vec<(f64, f64)>),
}

impl DetectorSet {
    /// Number of detectors.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Self::InPlane(v) => v.len(),
            Self::OutOfPlane(v) => v.len(),
        }
    }

    /// Whether there are no detectors.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A goniometric instrument: incidences × detectors with one aperture.
#[derive(Debug, Clone, PartialEq)]
pub struct Instrument {
    theta_i: Vec<f64>,
    detectors: DetectorSet,
    aperture: f64,
    cones: Vec<Cone>,
}

impl Instrument {
    /// Validate and build.
    ///
    /// # Errors
    /// [`PipelineError::Instrument`] for an empty list, `θi` outside `[0, π/2)`, a
    /// detector outside the upper hemisphere, or an aperture outside `[0, 20°]`.
    pub fn new(
        theta_i: Vec<f64>,
        detectors: DetectorSet,
        aperture: f64,
    ) -> Result<Self, PipelineError> {
        let bad = |msg: String| Err(PipelineError::Instrument(msg));
        if theta_i.is_empty() {
            return bad("no incidence angle given".into());
        }
        for &t in &theta_i {
            if !(t.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&t)) {
                return bad(format!(
                    "incidence angle {:.6}° is outside [0, 90)",
                    t.to_degrees()
                ));
            }
        }
        if !(aperture.is_finite() && (0.0..=MAX_APERTURE + 1e-12).contains(&aperture)) {
            return bad(format!(
                "aperture {:.6}° is outside [0, 20]",
                aperture.to_degrees()
            ));
        }
        if detectors.is_empty() {
            return bad("no detector given".into());
        }
        let cones = match &detectors {
            DetectorSet::InPlane(ts) => ts
                .iter()
                .map(|&t| {
                    Cone::in_plane(t, aperture).map_err(|_| {
                        PipelineError::Instrument(format!(
                            "detector angle theta_s = {:.6}° is outside (-90, 90)",
                            t.to_degrees()
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
            DetectorSet::OutOfPlane(d) => d
                .iter()
                .map(|&(tr, pr)| {
                    Cone::out_of_plane(tr, pr, aperture).map_err(|_| {
                        PipelineError::Instrument(format!(
                            "detector (theta_r, phi_r) = ({:.6}°, {:.6}°): theta_r must be in [0, 90)",
                            tr.to_degrees(),
                            pr.to_degrees()
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        Ok(Self {
            theta_i,
            detectors,
            aperture,
            cones,
        })
    }

    /// The defaults of the command-line contract: incidences 0°, 30°, 45°, 60°, 75°;
    /// in-plane detectors from −70° to 70° every 0.5°; aperture 1.5°.
    #[must_use]
    pub fn default_in_plane() -> Self {
        let ti = [0.0, 30.0, 45.0, 60.0, 75.0].map(f64::to_radians).to_vec();
        let ts = (0..=280)
            .map(|k| (-70.0 + 0.5 * f64::from(k)).to_radians())
            .collect();
        Self::new(ti, DetectorSet::InPlane(ts), 1.5f64.to_radians()).expect("valid defaults")
    }

    /// Incidence angles, radians.
    #[must_use]
    pub fn theta_i(&self) -> &[f64] {
        &self.theta_i
    }

    /// The detectors.
    #[must_use]
    pub fn detectors(&self) -> &DetectorSet {
        &self.detectors
    }

    /// Aperture half-angle, radians.
    #[must_use]
    pub fn aperture(&self) -> f64 {
        self.aperture
    }

    /// One cone per detector, in order.
    #[must_use]
    pub fn cones(&self) -> &[Cone] {
        &self.cones
    }
}
