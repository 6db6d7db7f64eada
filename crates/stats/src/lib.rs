//! Flake orientation statistics (paper eqs. 3–8) and height maps.
//!
//! Conventions follow `physics.md` §1 and §3: angles in radians, lengths in
//! micrometres, `z` is the macroscopic coating normal pointing into the air.

pub mod heightmap;
pub use heightmap::{HeightMap, HeightMapError};
