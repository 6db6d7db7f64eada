//! Synthetic aluminium-flake layers with exactly known ground truth.
//!
//! Flakes are thin discs (diameter distribution, thickness) dropped at random into a film,
//! oriented by any [`Orientation`] of the stats crate, and seen from above as a confocal
//! microscope sees them: the top-most surface wins, flake surfaces may be rough, and the
//! instrument blurs, quantises and adds noise. Each layer comes with a height map, an
//! intensity map (bright on flakes, dark and noisy between them), a label map and the
//! exact table of every flake ([`TruthFlake`]).
//!
//! Conventions (`physics.md` §1): lengths in µm, angles in radians, `z` the coating
//! normal pointing into the air, heights measured upward from the substrate. Map axes as
//! in [`HeightMap`]: row-major, `x = col * dx`, `y = row * dy`. Results are identical for
//! equal seeds, whatever the number of threads.
//!
//! ```
//! use flakescatter_stats::distribution::{GaussianWidth, Orientation};
//! use flakescatter_synth::{LayerParams, LayerSpec, generate};
//!
//! let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
//! let mut spec = LayerSpec::new(128, 96, orientation, 42);
//! spec.confocal.z_step_um = 0.0; // exact heights
//! let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
//! assert_eq!(layer.height.nx(), 128);
//! assert_eq!(layer.labels.len(), 128 * 96);
//! // Every visible pixel belongs to exactly one flake of the truth table.
//! let visible: usize = layer.truth.iter().map(|f| f.visible_pixels).sum();
//! assert_eq!(visible, layer.labels.iter().filter(|&&l| l != 0).count());
//! ```
//!
//! [`HeightMap`]: flakescatter_stats::heightmap::HeightMap

mod disc;
mod error;
mod field;
mod generate;
mod params;
pub mod stack;

pub use disc::Disc;
pub use error::SynthError;
pub use flakescatter_stats::distribution::Orientation;
pub use generate::{
    SyntheticLayer, TRUTH_COLUMNS, TruthFlake, generate, generate_from_discs, place_flakes,
    truth_csv,
};
pub use params::{
    Confocal, DiameterDistribution, FlakeAmount, IntensityLevels, LayerParams, LayerSpec,
    MAX_FLAKES, MAX_PIXELS, MAX_REDRAWN_FRACTION, Param, Roughness,
};
pub use stack::{AxialResponse, BitDepth, StackSpec, SyntheticStack};
