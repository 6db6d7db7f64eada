//! Colorimetry for flakescatter: what an appearance engineer reads off a multi-angle
//! spectrophotometer, computed from spectral reflectance factors.
//!
//! * [`tables`]: the CIE 1931 2° and CIE 1964 10° observers and illuminants D65, D50
//!   and A at 1 nm, 360–830 nm (the CIE's published data files, embedded);
//! * [`tristimulus`]: spectral reflectance factor → CIE XYZ with ASTM E308's practice
//!   (summation at the spectrum's own 1–5 nm spacing, Lagrange weights for coarser or
//!   irregular sampling; never linear interpolation of the spectrum);
//! * [`lab`]: XYZ → CIELAB → L*C*h;
//! * [`difference`]: ΔE*ab, ΔE*94 and CIEDE2000;
//! * [`geometry`]: multi-angle geometries (ASTM E2194's 45° set, custom sets), the
//!   aspecular → signed `θs` conversion and the flop index.
//!
//! Conventions: wavelengths in **nanometres** (`_nm` in every name: the unit of the CIE
//! tables and of every spectral file), angles in radians; reflectance factors are
//! dimensionless (1 = perfect reflecting diffuser; metallic coatings exceed 1 near
//! specular); XYZ on the scale `Y = 100` for the perfect diffuser; CIELAB white point from
//! the same illuminant and observer. No I/O and no printing: the CIE files are compiled
//! in.
//!
//! # Example
//! A mid-grey sample and a slightly reddish one, 10 nm from 400 to 700 nm, D65 / 10°:
//! ```
//! use flakescatter_colour::{
//!     delta_e_2000, delta_e_ab, Illuminant, Observer, TristimulusWeights,
//! };
//!
//! let wavelengths: Vec<f64> = (0..=30).map(|i| 400.0 + 10.0 * f64::from(i)).collect();
//! let weights = TristimulusWeights::new(&wavelengths, Illuminant::D65, Observer::Cie1964TenDegree)?;
//!
//! // A constant reflectance factor is neutral: a* = b* = 0, L* = 116·0.2^(1/3) − 16.
//! let grey = weights.lab(&vec![0.2; wavelengths.len()])?;
//! assert!(grey.a.abs() < 1e-9 && grey.b.abs() < 1e-9);
//! assert!((grey.l - (116.0 * 0.2f64.cbrt() - 16.0)).abs() < 1e-9);
//!
//! // More reflectance in the red: positive a*, and a colour difference from the grey.
//! let reddish: Vec<f64> = wavelengths.iter().map(|&w| if w > 600.0 { 0.22 } else { 0.2 }).collect();
//! let sample = weights.lab(&reddish)?;
//! assert!(sample.a > 0.0);
//! assert!(delta_e_2000(&grey, &sample) > 0.0 && delta_e_ab(&grey, &sample) > 0.0);
//!
//! // The D65 / 10° white point through these weights.
//! let white = weights.white_point();
//! assert!((white.y - 100.0).abs() < 1e-12 && (white.x - 94.81).abs() < 0.01);
//! # Ok::<(), flakescatter_colour::ColourError>(())
//! ```

pub mod difference;
mod error;
pub mod geometry;
pub mod lab;
pub mod tables;
pub mod tristimulus;

pub use difference::{Cie94, Ciede2000, delta_e_94, delta_e_2000, delta_e_2000_with, delta_e_ab};
pub use error::ColourError;
pub use geometry::{Geometry, GeometrySet, aspecular_to_theta_s, flop_index, theta_s_to_aspecular};
pub use lab::{Lab, Lch, Xyz, lightness};
pub use tables::{Illuminant, Observer};
pub use tristimulus::{Ends, Integration, TristimulusWeights, spectrum_to_lab, spectrum_to_xyz};
