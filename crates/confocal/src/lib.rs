//! From a confocal z-stack to a height map: per-pixel localisation of the axial peak.
//!
//! A laser scanning confocal microscope records a stack of optical slices; a reflecting
//! surface shows, in each pixel, an axial response that peaks where the surface is in
//! focus. Microscope software reports the brightest slice (**argmax**), which quantises
//! heights to the z step (0.3 µm in the seed paper: an rms error of `0.3/√12 = 0.087`
//! µm) and turns gently tilted flakes into terraces whose normals are exactly vertical —
//! the paper's Fig. 10 specular spike. Fitting the response around its maximum
//! localises the surface to a small fraction of the step ([`PeakMethod`]).
//!
//! The [`Localiser`] consumes slices one at a time and keeps per pixel only what the
//! estimator needs (module [`localise`]); it does no file I/O (the `io` crate streams
//! TIFF pages into it). Conventions: lengths in µm; heights above the lowest slice, `z`
//! up; map axes as in [`HeightMap`](flakescatter_stats::heightmap::HeightMap)
//! (row-major, `x = col · dx`, `y = row · dy`); intensities unit-less.
//!
//! ```
//! use flakescatter_confocal::{Localiser, PeakOptions, SliceOrder, StackGeometry};
//!
//! // A 2 x 1 stack of 9 slices 0.3 µm apart whose pixels see Gaussian axial responses
//! // (FWHM 0.6 µm) centred at 1.0 µm and 1.27 µm above the first slice.
//! let geometry = StackGeometry {
//!     nx: 2, ny: 1, nz: 9, dx_um: 0.18, dy_um: 0.18, dz_um: 0.3,
//!     order: SliceOrder::BottomFirst,
//! };
//! let mut loc = Localiser::new(geometry, PeakOptions::default())?;
//! let response = |z: f64, z0: f64| (-4.0 * 2f64.ln() * ((z - z0) / 0.6).powi(2)).exp();
//! for k in 0..9 {
//!     let z = 0.3 * k as f64;
//!     loc.push_slice(&[response(z, 1.0) as f32, response(z, 1.27) as f32])?;
//! }
//! let maps = loc.finish()?;
//! // The default (Gaussian) estimator is exact for a Gaussian response, up to the
//! // f32 samples.
//! assert!((maps.height.get(0, 0).unwrap() - 1.0).abs() < 1e-5);
//! assert!((maps.height.get(1, 0).unwrap() - 1.27).abs() < 1e-5);
//! assert!((maps.width.get(0, 0).unwrap() - 0.6).abs() < 1e-4);
//! assert_eq!(maps.report.valid, 2);
//! # Ok::<(), flakescatter_confocal::ConfocalError>(())
//! ```

mod error;
pub mod localise;
pub mod noise;
pub mod peak;

pub use error::ConfocalError;
pub use localise::{
    Localiser, MAX_HALF_WINDOW, MAX_SLICE_PIXELS, MinSignal, PeakMaps, PeakOptions, PeakReport,
    SliceOrder, StackGeometry,
};
pub use noise::{NoiseEstimate, SignalThreshold};
pub use peak::{Invalid, Peak, PeakMethod, locate_peak};
