//! Parameters and errors of [`segment`](super::segment).
//!
//! Contract: a [`SegmentParams`] is plain data; [`SegmentParams::validate`] is called once
//! by the entry point and rejects every non-finite or out-of-range field with a
//! [`SegmentError`] naming it. Lengths in µm, angles in radians.

use std::f64::consts::PI;

use thiserror::Error;

/// Errors from [`segment`](super::segment): only bad parameters (bad maps give an empty
/// result with a [`SegmentWarning`](super::SegmentWarning)).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SegmentError {
    /// A parameter is not finite or out of its range.
    #[error("segmentation parameter {name} = {value} is invalid: expected {expected}")]
    BadParameter {
        /// The field of [`SegmentParams`].
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
}

/// Tuning of [`segment`](super::segment). Build with [`SegmentParams::for_instrument`]
/// (or `default()`, the paper's microscope) and adjust fields if needed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentParams {
    /// Largest height difference between 4-neighbouring pixels of one flake, µm.
    pub max_step_um: f64,
    /// Smallest half-width of the band of accepted plane residuals, µm.
    pub inlier_band_um: f64,
    /// Residuals beyond this many robust standard deviations (1.4826 · MAD) are rejected.
    pub reject_sigmas: f64,
    /// Smallest flake, in pixels (≥ 3).
    pub min_pixels: usize,
    /// Largest angle between the normals of two pieces that may be merged, radians.
    pub merge_angle: f64,
    /// Largest gap between the bounding boxes of two pieces that may be merged, µm.
    pub merge_gap_um: f64,
    /// Two pieces merge only if their joint plane's mean square residual is at most this
    /// factor times their pooled mean square residual (plus `inlier_band_um² / 16`).
    pub merge_ms_ratio: f64,
}

impl SegmentParams {
    /// Thresholds derived from the instrument: z quantisation step `z_step_um` (µm, `0`
    /// for none) and height noise standard deviation `noise_sd_um` (µm).
    ///
    /// `max_step_um = z_step + max(0.2, 6 · noise)` and
    /// `inlier_band_um = z_step / 2 + 4 · noise + 0.02`: a quantised plane deviates from
    /// the true plane by at most half a step, noise by a few sd. Other fields: 2.5 sigmas,
    /// 100 pixels, 10°, 25 µm, ratio 1.5.
    pub fn for_instrument(z_step_um: f64, noise_sd_um: f64) -> Self {
        Self {
            max_step_um: z_step_um + (6.0 * noise_sd_um).max(0.2),
            inlier_band_um: 0.5 * z_step_um + 4.0 * noise_sd_um + 0.02,
            reject_sigmas: 2.5,
            min_pixels: 100,
            merge_angle: 10f64.to_radians(),
            merge_gap_um: 25.0,
            merge_ms_ratio: 1.5,
        }
    }

    pub(super) fn validate(&self) -> Result<(), SegmentError> {
        let check = |name: &'static str, value: f64, ok: bool, expected: &'static str| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(SegmentError::BadParameter {
                    name,
                    value,
                    expected,
                })
            }
        };
        check(
            "max_step_um",
            self.max_step_um,
            self.max_step_um > 0.0,
            "finite and > 0 µm",
        )?;
        check(
            "inlier_band_um",
            self.inlier_band_um,
            self.inlier_band_um > 0.0,
            "finite and > 0 µm",
        )?;
        check(
            "reject_sigmas",
            self.reject_sigmas,
            self.reject_sigmas > 0.0,
            "finite and > 0",
        )?;
        check(
            "min_pixels",
            self.min_pixels as f64,
            self.min_pixels >= 3,
            "at least 3",
        )?;
        check(
            "merge_angle",
            self.merge_angle,
            (0.0..PI / 2.0).contains(&self.merge_angle),
            "in [0, π/2) rad",
        )?;
        check(
            "merge_gap_um",
            self.merge_gap_um,
            self.merge_gap_um >= 0.0,
            "finite and >= 0 µm",
        )?;
        check(
            "merge_ms_ratio",
            self.merge_ms_ratio,
            self.merge_ms_ratio >= 1.0,
            "finite and >= 1",
        )
    }
}

impl Default for SegmentParams {
    /// [`SegmentParams::for_instrument`]`(0.3, 0.03)`: the paper's 0.3 µm z step and a
    /// 30 nm height noise.
    fn default() -> Self {
        Self::for_instrument(0.3, 0.03)
    }
}
