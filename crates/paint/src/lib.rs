//! A measured metallic paint as physics (physics.md §12): a clear coat whose surface may
//! be rough, flakes of the distribution model (physics.md §4) with Gaussian, heavy-tailed
//! (Pearson VII, Trowbridge–Reitz) or tabulated orientations and the optics of a metal,
//! and a Lambertian base coat under both; one BRDF per colour channel, reciprocal and
//! energy-conserving for every parameter set.
//!
//! * [`channel`]: colour channels (`r`, `g`, `b`, `y`, wavelengths) and their wavelengths;
//! * [`coat`]: the coat surface's reflection and its directional albedo;
//! * [`layer`]: the flake layer's shadowing of its own flakes (Smith's `Λ`);
//! * [`base`]: the base under the coat, internal reflections summed;
//! * [`metal`]: what the flakes are made of (a metal or an interference stack);
//! * [`model`]: the three together, [`PaintModel`].
//!
//! Conventions: radians; the frame of `flakescatter_optics` (`z` the coating normal into
//! the air, source on the `−x` side, exit directions `r` with `r.z > 0`, azimuth `φr = 0`
//! the specular half-plane); BRDFs in sr⁻¹.
//!
//! # Example
//! A silver paint: Trowbridge–Reitz flakes of slope scale 0.1 covering 60 % of the
//! coat, a grey base, a flat coat of index 1.5; its BRDF 20° from specular at 45°:
//! ```
//! use flakescatter_optics::Vec3;
//! use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
//! use flakescatter_stats::Orientation;
//!
//! let params = PaintParams {
//!     coat: CoatParams::flat(1.5),
//!     orientation: Orientation::trowbridge_reitz(0.1)?,
//!     coverage: 0.6,
//!     flake_metal: FlakeMetal::Aluminium,
//!     channels: vec![ChannelParams {
//!         channel: Channel::parse("g")?,
//!         flake_scale: 0.9,
//!         base_albedo: 0.3,
//!         tint: 0.0,
//!     }],
//! };
//! let model = PaintModel::new(params)?;
//! let inc = model.incidence(45f64.to_radians())?;
//! let t = 25f64.to_radians(); // 20° from specular toward the normal, in the plane
//! let r = Vec3::new(t.sin(), 0.0, t.cos());
//! let terms = model.terms(&inc, &r, 0);
//! assert!(terms.flakes > terms.base && terms.base > 0.0 && terms.coat == 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod base;
pub mod channel;
pub mod coat;
pub mod cone;
pub mod fit;
pub mod layer;
pub mod metal;
pub mod model;

pub use channel::Channel;
pub use coat::{CoatParams, CoatSurface};
pub use metal::StackFlakes;
pub use model::{ChannelParams, FlakeMetal, PaintIncidence, PaintModel, PaintParams, Terms};

/// Errors of the paint model and its fit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PaintError {
    /// A parameter out of range (the message names it and the range).
    #[error("{0}")]
    Parameter(String),
    /// An unknown or malformed channel.
    #[error("{0}")]
    Channel(String),
    /// A geometry out of range.
    #[error("{0}")]
    Geometry(String),
    /// Measured data a fit cannot use (the message names the file, line and column).
    #[error("{0}")]
    Data(String),
    /// A fit that failed (no convergence, an undetermined parameter).
    #[error("{0}")]
    Fit(String),
}
