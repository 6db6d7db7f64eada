//! flakescatter: the angular reflectance of metallic (aluminium-flake) coatings from
//! flake orientations, after NIST's ray models (Sung et al., J. Coatings Technology 74,
//! 2002), corrected and verified as `docs/physics.md` records.
//!
//! This facade is the one dependency downstream code needs. It re-exports each layer —
//! [`optics`] (Snell, Fresnel, detectors), [`stats`] (orientation distributions, flake
//! statistics, height maps), [`gaussian`] (the distribution model), [`io`] (file
//! formats), [`synth`] (synthetic flake layers), [`colour`] (colorimetry) — and adds the composition they cannot
//! own: a [`Coating`], an [`Instrument`] and an [`OrientationSource`] (a distribution
//! or a flake table) turned into [`Curves`] by [`distribution_curves`], or height maps
//! turned into curves by [`topographic_curves`] or, averaged over the sample's rotation,
//! [`isotropic_curves`] ([`topo`] is the topographic layer); the pixel-level
//! distribution of normals and the flake- against pixel-level width in [`pixels`];
//! measurement against model in [`compare`], fitting of the orientation distribution in
//! [`fit`], multi-angle readouts in [`multiangle`] (single wavelength) and
//! [`spectral`] (per-wavelength models, CIELAB per geometry, ΔE against measured
//! multi-angle colour, the width fitted to `L*`), Mueller matrices, polariser/analyser
//! readings and the degree of polarisation in [`polarimetry`], the three-dimensional
//! layer with multiple scattering in [`volume`] ([`volume_curves`]; [`volume_layer`] is
//! its crate), real paints (coat, flakes and base; measured BRDF tables, their joint fit,
//! the parameter file) in [`paint`] ([`paint_model`] is its crate), what a plot shows in
//! [`chart`], and the paper's figures in kind in [`figures`].
//!
//! Conventions: radians and micrometres in every API; reflectances are fractions of the
//! incident beam power, BRDFs per steradian; in-plane detector angles are signed with
//! `θs = −θi` the specular direction.
//!
//! # Workflow
//! From a confocal height map (a shipped synthetic fixture) to flake statistics to both
//! models' curves:
//! ```
//! use flakescatter::io::{ReadOptions, read_intensity, read_map};
//! use flakescatter::stats::fit::fit_gaussian_ml;
//! use flakescatter::stats::segment::{SegmentParams, segment};
//! use flakescatter::{
//!     Coating, DetectorSet, Instrument, OrientationSource, Settings, TopoSettings,
//!     distribution_curves, topographic_curves,
//! };
//!
//! let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
//! let opts = ReadOptions::default();
//! // 1. The height map, masked by its intensity map (cutoff 0.49).
//! let (mut map, _) = read_map(format!("{dir}/synth-hwhm6-rough.height.x3p"), &opts)?;
//! let (intensity, _) = read_intensity(format!("{dir}/synth-hwhm6-rough.intensity.x3p"), &opts)?;
//! map.apply_intensity_cutoff(&intensity, 0.49)?;
//!
//! // 2. Flakes, and the area-weighted Gaussian width of their tilts.
//! let flakes: Vec<_> = segment(&map, &SegmentParams::default())?
//!     .flakes
//!     .iter()
//!     .map(|f| f.to_flake())
//!     .collect();
//! let tilts: Vec<(f64, f64)> = flakes.iter().map(|f| (f.theta_n(), f.area_um2)).collect();
//! let width = fit_gaussian_ml(&tilts)?;
//! assert!(flakes.len() > 30 && width.hwhm() > 0.0);
//!
//! // 3. Both models at 60° incidence, in-plane detectors of 1.5° half-angle.
//! let ts: Vec<f64> = (-70..=70).map(|d| f64::from(d).to_radians()).collect();
//! let instrument = Instrument::new(vec![60f64.to_radians()], DetectorSet::InPlane(ts), 1.5f64.to_radians())?;
//! let (coating, settings) = (Coating::default(), Settings::default());
//! let gaussian = distribution_curves(
//!     &coating,
//!     &instrument,
//!     &settings,
//!     &OrientationSource::Distribution(width.orientation()?),
//! )?;
//! let (topo, totals) =
//!     topographic_curves(&coating, &instrument, &settings, &TopoSettings::default(), &[&map], &|_, _| {})?;
//! // The row of the specular detector (θs = −60°) is the reference of `relative`.
//! assert!((gaussian.rows[10].relative - 1.0).abs() < 1e-12);
//! assert!(totals.rays_traced > 0 && topo.rows[10].rays.unwrap() > 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A longer version of the same workflow is the example `map_to_curves`
//! (`cargo run --release -p flakescatter --example map_to_curves`).

pub mod analyze;
pub mod chart;
pub mod checks;
pub mod compare;
pub mod export;
pub mod figures;
pub mod film;
pub mod fit;
pub mod inputs;
pub use inputs::distinct;
pub mod instrument;
pub mod multiangle;
pub mod overlay;
pub mod paint;
pub mod pipeline;
pub mod pixels;
pub mod polarimetry;
pub mod pooled_json;
pub mod reproduce;
pub mod sample;
pub mod spectral;
pub mod stack;
pub mod streaming;
pub mod topo_base;
pub mod volume;

pub use flakescatter_colour as colour;
pub use flakescatter_confocal as confocal;
pub use flakescatter_gaussian as gaussian;
pub use flakescatter_io as io;
pub use flakescatter_optics as optics;
pub use flakescatter_paint as paint_model;
pub use flakescatter_stats as stats;
pub use flakescatter_synth as synth;
pub use flakescatter_topo as topo;
pub use flakescatter_volume as volume_layer;

pub use instrument::{DetectorSet, Instrument};
pub use pipeline::{
    Coating, CurveRow, Curves, OrientationSource, Settings, TopoSettings, distribution_curves,
    distribution_rows, isotropic_curves, p_tilde_about_specular, topographic_curves,
};
pub use pixels::{
    PixelOrientation, PixelWidth, WidthSources, pixel_orientation, width_sources,
    width_sources_from,
};
pub use polarimetry::{
    MuellerCurves, MuellerRow, Polarimetry, distribution_mueller, topographic_mueller,
};
pub use volume::{
    SpectralVolumeCurves, VolumeCurves, VolumeRow, VolumeSettings, spectral_volume_curves,
    volume_curves,
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
    /// The volume model rejected its input.
    #[error("volume model: {0}")]
    Volume(#[from] flakescatter_volume::VolumeError),
    /// A polarisation setting that cannot be honoured.
    #[error("polarisation: {0}")]
    Polarization(String),
    /// A spectral setting (wavelengths, dispersion, absorption, colorimetry) that cannot
    /// be honoured.
    #[error("{0}")]
    Spectral(String),
    /// The paint model or its fit rejected its input (the message names the file, line
    /// and column, or the parameter).
    #[error("{0}")]
    Paint(flakescatter_paint::PaintError),
}
