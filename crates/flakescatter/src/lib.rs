//! flakescatter: the angular reflectance of metallic (aluminium-flake) coatings from
//! flake orientations, after NIST's ray models (Sung et al., J. Coatings Technology 74,
//! 2002), corrected and verified as `docs/physics.md` records.
//!
//! This facade is the one dependency downstream code needs. It re-exports each layer —
//! [`optics`] (Snell, Fresnel, detectors), [`stats`] (orientation distributions, flake
//! statistics, height maps), [`gaussian`] (the distribution model), [`io`] (file
//! formats), [`synth`] (synthetic flake layers) — and adds the composition they cannot
//! own: a [`Coating`], an [`Instrument`] and an [`OrientationSource`] turned into
//! [`Curves`] by [`distribution_curves`].
//!
//! Conventions: radians and micrometres in every API; reflectances are fractions of the
//! incident beam power, BRDFs per steradian; in-plane detector angles are signed with
//! `θs = −θi` the specular direction.
//!
//! # Example
//! From flake normals to the distribution model's curve at 45° incidence:
//! ```
//! use flakescatter::{Coating, DetectorSet, Instrument, OrientationSource, Settings, distribution_curves};
//! use flakescatter::stats::{GaussianWidth, Orientation};
//!
//! let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians()))?;
//! let detectors = DetectorSet::InPlane((-60..=60).map(|d| f64::from(d).to_radians()).collect());
//! let instrument = Instrument::new(vec![45f64.to_radians()], detectors, 1.5f64.to_radians())?;
//! let curves = distribution_curves(
//!     &Coating::default(),
//!     &instrument,
//!     &Settings::default(),
//!     &OrientationSource::Distribution(orientation),
//! )?;
//! // The row at the specular detector (θs = −45°) is the reference of `relative`.
//! let spec = &curves.rows[60 - 45];
//! assert!((spec.relative - 1.0).abs() < 1e-12);
//! assert!(spec.reflectance.unwrap() > 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod compare;
pub mod fit;
pub mod instrument;
pub mod multiangle;
mod nnls;
pub mod pipeline;

pub use flakescatter_gaussian as gaussian;
pub use flakescatter_io as io;
pub use flakescatter_optics as optics;
pub use flakescatter_stats as stats;
pub use flakescatter_synth as synth;
pub use flakescatter_topo as topo;

pub use instrument::{DetectorSet, Instrument};
pub use pipeline::{
    Coating, CurveRow, Curves, OrientationSource, Settings, TopoSettings, distribution_curves,
    topographic_curves,
};

/// Errors of the pipeline.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The instrument is not valid.
    #[error("instrument: {0}")]
    Instrument(String),
    /// The distribution model rejected its input.
    #[error("distribution model: {0}")]
    Model(#[from] flakescatter_gaussian::ModelError),
    /// The orientation source gives no distribution.
    #[error("orientation: {0}")]
    Orientation(String),
    /// A measured curve cannot be used as asked.
    #[error("{0}")]
    Measurement(String),
    /// A fit failed.
    #[error("fit: {0}")]
    Fit(String),
    /// The topographic model rejected its input.
    #[error("topographic model: {0}")]
    Topo(#[from] flakescatter_topo::TopoError),
}
