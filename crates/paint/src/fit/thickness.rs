//! The thickness of an interference flake's layers as a fit parameter (physics.md
//! §12.7).
//!
//! An interference stack's reflectance is periodic in each layer's optical thickness
//! (a fringe every `λ/(2 n cos θ)`), so `χ²` has a minimum in every period and a local
//! minimiser stays in the one it starts in. The fit therefore starts from a **scan**:
//! a Trowbridge–Reitz fit with the thickness held at the spec's value gives the shape
//! and the coat; then, with those held, `χ²` is evaluated on a grid of thicknesses
//! ([`scan_grid`]: 5 nm steps, at most [`MAX_SCAN`] points, over the range given), each
//! with the channel amplitudes refitted by non-negative least squares; the grid's
//! minimum starts the joint fit, in which the thickness is free with everything else.
//! The profile is reported, and other local minima of it that the data barely tell from
//! the best one earn a warning ([`ambiguous_minima`]).

use super::FitOptions;
use super::data::{Measurement, Point};
use super::engine::Engine;
use super::layout::{Amplitudes, Family, Layout};
use super::solve::{solve, start_amplitudes};
use crate::PaintError;
use crate::model::FlakeMetal;

/// A fitted thickness: the stack's layers it sets (numbered from 1, from the side light
/// arrives on; several layers move together, e.g. `[1, 3]` for the two TiO2 coats of a
/// TiO2/mica/TiO2 pigment) and the range searched, nm.
#[derive(Debug, Clone, PartialEq)]
pub struct ThicknessFit {
    /// The layers, numbered from 1.
    pub layers: Vec<usize>,
    /// The range searched and the fit's bounds, nm (`0 < lo < hi`).
    pub range_nm: (f64, f64),
}

/// Most grid points of a scan.
pub const MAX_SCAN: usize = 400;

/// The scan's thicknesses: `lo`, `lo + 5`, … up to `hi` (inclusive), nm; a coarser even
/// step when that would be more than [`MAX_SCAN`] points.
#[must_use]
pub fn scan_grid(range_nm: (f64, f64)) -> Vec<f64> {
    let (lo, hi) = range_nm;
    let step = ((hi - lo) / (MAX_SCAN - 1) as f64).max(5.0);
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    (0..n).map(|j| (lo + j as f64 * step).min(hi)).collect()
}

impl ThicknessFit {
    /// Checks the range (`0 < lo < hi`, finite), that there is a layer, and that
    /// `metal` is a stack having every layer named.
    ///
    /// # Errors
    /// [`PaintError::Parameter`] naming what is wrong.
    pub fn check(&self, metal: &FlakeMetal) -> Result<(), PaintError> {
        let (lo, hi) = self.range_nm;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo < hi) {
            return Err(PaintError::Parameter(format!(
                "thickness range {lo}:{hi} nm: expected 0 < low < high, finite"
            )));
        }
        if self.layers.is_empty() {
            return Err(PaintError::Parameter(
                "a thickness fit needs at least one layer of the flake stack".into(),
            ));
        }
        metal.with_thickness(&self.layers, lo).map(|_| ())
    }
}

/// The thickness a fit starts from: the spec's thickness of the first fitted layer,
/// held inside the range.
pub(super) fn start(t: &ThicknessFit, metal: &FlakeMetal) -> f64 {
    metal
        .thickness(t.layers[0])
        .unwrap_or(t.range_nm.0)
        .clamp(t.range_nm.0, t.range_nm.1)
}

/// The scan (module docs): the profile `(thickness nm, χ²)` over [`scan_grid`], and its
/// minimum.
///
/// # Errors
/// As [`solve`] when even the start cannot be evaluated.
pub(super) fn scan(
    m: &Measurement,
    points: &[Point],
    have_u: bool,
    opts: &FitOptions,
    names: &[String],
    amplitudes: Amplitudes,
    t: &ThicknessFit,
) -> Result<(Vec<(f64, f64)>, f64), PaintError> {
    // Shape and coat from a Trowbridge–Reitz fit at the spec's thickness; when that
    // does not converge, the defaults a fit starts from.
    let tr = |thickness: Option<(f64, f64)>| {
        Layout::new(
            Family::TrowbridgeReitz,
            opts.haze,
            opts.fit_n,
            opts.n,
            names,
            amplitudes,
            thickness,
        )
    };
    let prefit = solve(m, points, have_u, tr(None), opts, None).ok();
    let layout = tr(Some(t.range_nm));
    let ti = layout.thickness_index().expect("a thickness entry");
    let engine = Engine::new(
        m,
        points,
        &layout,
        opts.flake_metal.clone(),
        &t.layers,
        opts.smoothing,
    );
    let mut q = super::solve::start_values(&layout, opts, prefit.as_ref())?;
    let mut profile = Vec::new();
    for d in scan_grid(t.range_nm) {
        q[ti] = d;
        start_amplitudes(&engine, &layout, points, &mut q, None)?;
        let chi2 = engine.residuals(&q)?.map_or(f64::INFINITY, |r| {
            r[..points.len()].iter().map(|v| v * v).sum()
        });
        profile.push((d, chi2));
    }
    let best = profile
        .iter()
        .copied()
        .filter(|p| p.1.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or_else(|| start(t, &opts.flake_metal), |p| p.0);
    Ok((profile, best))
}

/// Local minima of the scan `profile` at least 20 nm from the fitted `fitted_nm` whose
/// `χ²` exceeds the scan's lowest by less than `4 χ²/dof` (`chi2_per_dof` the fit's:
/// about two standard deviations of a one-parameter change, with the noise scaled to
/// the fit): other orders the data barely tell from the one fitted. Both sides of the
/// comparison are scan values (the shape and coat held alike), and each returned pair
/// is `(thickness nm, (χ² − lowest)/(χ²/dof))`.
#[must_use]
pub fn ambiguous_minima(
    profile: &[(f64, f64)],
    fitted_nm: f64,
    chi2_per_dof: f64,
) -> Vec<(f64, f64)> {
    let lowest = profile
        .iter()
        .map(|p| p.1)
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    let unit = chi2_per_dof.max(f64::MIN_POSITIVE);
    (0..profile.len())
        .filter(|&j| {
            let v = profile[j].1;
            let left = j == 0 || profile[j - 1].1 > v;
            let right = j + 1 == profile.len() || profile[j + 1].1 >= v;
            left && right && v.is_finite()
        })
        .map(|j| (profile[j].0, (profile[j].1 - lowest) / unit))
        .filter(|&(d, delta)| (d - fitted_nm).abs() >= 20.0 && delta < 4.0)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid: 5 nm steps including both ends when they fall on the grid, coarser
    /// steps over a wide range (never more than `MAX_SCAN` points).
    #[test]
    fn grid() {
        let g = scan_grid((40.0, 300.0));
        assert_eq!(g.len(), 53);
        assert_eq!((g[0], g[1], g[52]), (40.0, 45.0, 300.0));
        let wide = scan_grid((10.0, 5000.0));
        assert!(
            wide.len() <= MAX_SCAN && wide.len() >= MAX_SCAN - 1,
            "{}",
            wide.len()
        );
        assert!((wide[1] - wide[0] - 4990.0 / 399.0).abs() < 1e-9);
    }

    /// Local minima: another one is flagged only when its χ² is within 4 χ²/dof of the
    /// scan's lowest and it is at least 20 nm from the fitted thickness; the profile's
    /// ends count as minima.
    #[test]
    fn ambiguous() {
        // χ²/dof = 10: the limit is the lowest + 40.
        let profile = [
            (50.0, 1100.0),
            (55.0, 1200.0),
            (60.0, 1030.0), // a minimum within the limit
            (65.0, 1300.0),
            (70.0, 1000.0), // the lowest
            (75.0, 1050.0),
            (80.0, 1045.0), // a minimum, but above the limit
            (85.0, 1100.0),
            (90.0, 1039.0), // within the limit and a minimum (the end)
        ];
        let got = ambiguous_minima(&profile, 69.7, 10.0);
        assert_eq!(got.len(), 1, "60 nm is within 20 nm of 69.7: {got:?}");
        assert_eq!(got[0].0, 90.0);
        assert!((got[0].1 - 3.9).abs() < 1e-12);
        // Fitted near 90 (the joint fit may move off the scan's best).
        let got = ambiguous_minima(&profile, 90.0, 10.0);
        let at: Vec<f64> = got.iter().map(|p| p.0).collect();
        assert_eq!(at, vec![60.0, 70.0]);
        assert_eq!(got[1].1, 0.0);
        // The first point is a minimum when the profile rises from it.
        let got = ambiguous_minima(
            &[(10.0, 1001.0), (15.0, 2000.0), (200.0, 1000.0)],
            200.0,
            1.0,
        );
        assert_eq!(got, vec![(10.0, 1.0)]);
    }
}
