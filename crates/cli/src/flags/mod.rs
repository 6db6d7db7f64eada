//! Flag groups shared by several subcommands (docs/cli.md "Instrument flags"): the
//! coating and model settings, the instrument's angles, the measured curve, the
//! orientation source, map calibration and segmentation, polarisation, the spectral
//! models and the colorimetry.
//!
//! Degrees on the command line; every method here hands radians to the library.

mod colour;
mod instrument;
mod measured;
pub mod modes;
mod paint;
mod polarization;
mod source;
mod spectral;

pub use colour::{ColourArgs, GeometryArgs};
pub use instrument::{InstrumentArgs, MAX_ROWS, OpticsArgs};
pub use measured::MeasuredArgs;
pub use paint::{PaintFlags, flake_metal, paint_flakes};
pub use polarization::PolarizationArgs;
pub use source::{MapArgs, OrientationArgs, SegmentArgs, selector, width};
pub use spectral::{
    DEFAULT_WAVELENGTHS, SpectralArgs, binder_table, constant_alpha, parse_wavelengths,
};

/// Default incidences of `model` and `topo`, degrees.
pub const DEFAULT_THETA_I: &str = "0,30,45,60,75";
/// Default in-plane detectors of `model` and `topo`, degrees.
pub const DEFAULT_THETA_S: &str = "-70:70:0.5";
