//! The number of flake layers of a pile as a fit parameter (physics.md §12.8): the
//! whole joint fit ([`super::fit_paint`]) at each whole number of layers in a range, the
//! lowest `χ²` kept.
//!
//! `N` is a count, so it is scanned, not minimised: `χ²(N)` at every `N` is reported
//! with the fit kept. Every `N` has the same parameters, so `χ²` alone ranks them.

use crate::PaintError;
use crate::model::FlakeMetal;

use super::{FitExtras, FitOptions, Measurement, PaintFit, fit_paint_with};

/// The most layers a scan may reach.
pub const MAX_SCAN: u32 = 1000;

/// A fit of the number of flake layers.
#[derive(Debug, Clone)]
pub struct LayersFit {
    /// The fit at the number of layers kept (its paint's flakes piled that deep).
    pub fit: PaintFit,
    /// The number of layers kept (lowest `χ²`).
    pub layers: u32,
    /// Every number of layers tried with its fit's `χ²` (`None` where the fit failed).
    pub scan: Vec<(u32, Option<f64>)>,
}

/// Fit `m` with the flakes of `opts` piled `N` deep for every `N` in `1..=max`, and
/// keep the fit of lowest `χ²`.
///
/// # Errors
/// [`PaintError::Parameter`] unless `opts.flake_metal` is a free interference stack
/// (only those transmit; [`FlakeMetal::with_layers`]) and `max` is in `1..=MAX_SCAN`;
/// the fit's own error when it fails at every `N`.
pub fn fit_flake_layers(
    m: &Measurement,
    opts: &FitOptions,
    max: u32,
) -> Result<LayersFit, PaintError> {
    fit_flake_layers_with(m, opts, max, FitExtras::default())
}

/// [`fit_flake_layers`] with the parameters `extras` adds to every fit.
///
/// # Errors
/// As [`fit_flake_layers`].
pub fn fit_flake_layers_with(
    m: &Measurement,
    opts: &FitOptions,
    max: u32,
    extras: FitExtras,
) -> Result<LayersFit, PaintError> {
    if !(1..=MAX_SCAN).contains(&max) {
        return Err(PaintError::Parameter(format!(
            "flake layers scanned up to {max}: expected 1 to {MAX_SCAN}"
        )));
    }
    if !matches!(&opts.flake_metal, FlakeMetal::Stack(s) if s.core.is_none()) {
        return Err(PaintError::Parameter(
            "a fitted number of flake layers needs free interference flakes (a flake stack without a core): flakes that transmit nothing pile to the top flake".into(),
        ));
    }
    let mut best: Option<(u32, PaintFit)> = None;
    let mut first_error = None;
    let mut scan = Vec::with_capacity(max as usize);
    for n in 1..=max {
        let o = FitOptions {
            flake_metal: opts.flake_metal.with_layers(n)?,
            ..opts.clone()
        };
        match fit_paint_with(m, &o, extras) {
            Ok(fit) => {
                let chi2 = fit.evidence.chi2;
                scan.push((n, Some(chi2)));
                if best.as_ref().is_none_or(|(_, b)| chi2 < b.evidence.chi2) {
                    best = Some((n, fit));
                }
            }
            Err(e) => {
                scan.push((n, None));
                first_error.get_or_insert(e);
            }
        }
    }
    match best {
        Some((layers, fit)) => Ok(LayersFit { fit, layers, scan }),
        None => Err(first_error.unwrap_or_else(|| PaintError::Fit("no fit".into()))),
    }
}
