//! flakescatter: reflectance of metallic flake coatings from flake orientations.
//!
//! This facade re-exports every layer under one name.

pub use flakescatter_io as io;
pub use flakescatter_optics as optics;
pub use flakescatter_stats as stats;
pub use flakescatter_synth as synth;
