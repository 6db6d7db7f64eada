//! Multi-angle measurement geometries and the flop index.
//!
//! Conventions (`docs/physics.md` §1): angles in **radians**; the source is on the `−x`
//! side at incidence `θi ∈ [0, π/2)`; the **aspecular** angle is measured from the
//! specular direction, positive toward the normal (ASTM E2194 style); the detector's
//! signed in-plane angle is `θs = −θi + aspecular` (`θs = −θi` is specular, `θs > 0` on the
//! source side), and must lie strictly between `−π/2` and `π/2`.
//!
//! Built-in set: ASTM E2194's 45° incidence with aspecular −15°, 15°, 25°, 45°, 75°,
//! 110° (the six angles of the common portable multi-angle spectrophotometers). Sets with
//! a second incidence (instruments that also illuminate at 15°) are not built in: their
//! angles are instrument documentation this project has not been able to cite; give
//! them as data with [`GeometrySet::new`].
//!
//! **Flop index** (DuPont, as published by X-Rite for its multi-angle instruments):
//! `FI = 2.69 (L*15 − L*110)^1.11 / (L*45)^0.86`, the lightnesses at 15°, 45° and 110°
//! aspecular under 45° incidence.

use crate::error::ColourError;

/// One measurement geometry: incidence and aspecular angle, both radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    theta_i: f64,
    aspecular: f64,
}

impl Geometry {
    /// The geometry `θi`, aspecular (radians).
    ///
    /// # Errors
    /// [`ColourError::InvalidValue`] if `θi ∉ [0, π/2)`, an angle is not finite, or the
    /// detector `θs = −θi + aspecular` is not strictly above the surface (`|θs| < π/2`).
    pub fn new(theta_i: f64, aspecular: f64) -> Result<Self, ColourError> {
        if !(0.0..std::f64::consts::FRAC_PI_2).contains(&theta_i) {
            return Err(ColourError::InvalidValue {
                name: "incidence angle (rad)",
                value: theta_i,
                expected: "0 <= theta_i < pi/2",
            });
        }
        let theta_s = aspecular - theta_i;
        if !(theta_s.abs() < std::f64::consts::FRAC_PI_2) {
            return Err(ColourError::InvalidValue {
                name: "aspecular angle (rad)",
                value: aspecular,
                expected: "a detector above the surface: |aspecular - theta_i| < pi/2",
            });
        }
        Ok(Self { theta_i, aspecular })
    }

    /// Incidence angle `θi`, radians.
    #[must_use]
    pub fn theta_i(&self) -> f64 {
        self.theta_i
    }

    /// Aspecular angle, radians (positive toward the normal).
    #[must_use]
    pub fn aspecular(&self) -> f64 {
        self.aspecular
    }

    /// The detector's signed in-plane angle `θs = −θi + aspecular`, radians.
    #[must_use]
    pub fn theta_s(&self) -> f64 {
        aspecular_to_theta_s(self.theta_i, self.aspecular)
    }
}

/// Signed in-plane detector angle `θs = −θi + aspecular` (radians; physics.md §1).
#[must_use]
pub fn aspecular_to_theta_s(theta_i: f64, aspecular: f64) -> f64 {
    aspecular - theta_i
}

/// Aspecular angle of the in-plane detector `θs` under incidence `θi`:
/// `aspecular = θs + θi` (radians).
#[must_use]
pub fn theta_s_to_aspecular(theta_i: f64, theta_s: f64) -> f64 {
    theta_s + theta_i
}

/// A named list of geometries, in the order an instrument reports them.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometrySet {
    name: String,
    geometries: Vec<Geometry>,
}

/// Aspecular angles of ASTM E2194's 45° set, degrees (as the standard and instruments
/// write them).
pub const ASTM_E2194_ASPECULAR_DEG: [f64; 6] = [-15.0, 15.0, 25.0, 45.0, 75.0, 110.0];

impl GeometrySet {
    /// A set from its geometries.
    ///
    /// # Errors
    /// [`ColourError::InvalidValue`] for an empty list or a repeated geometry.
    pub fn new(name: impl Into<String>, geometries: Vec<Geometry>) -> Result<Self, ColourError> {
        if geometries.is_empty() {
            return Err(ColourError::InvalidValue {
                name: "number of geometries",
                value: 0.0,
                expected: "at least one geometry",
            });
        }
        for (i, g) in geometries.iter().enumerate() {
            if geometries[..i].contains(g) {
                return Err(ColourError::InvalidValue {
                    name: "repeated geometry, aspecular (rad)",
                    value: g.aspecular,
                    expected: "each (incidence, aspecular) pair once",
                });
            }
        }
        Ok(Self {
            name: name.into(),
            geometries,
        })
    }

    /// ASTM E2194's 45° set: `θi = 45°`, aspecular −15°, 15°, 25°, 45°, 75°, 110°.
    #[must_use]
    pub fn astm_e2194() -> Self {
        let theta_i = 45f64.to_radians();
        Self {
            name: "astm-e2194".into(),
            geometries: ASTM_E2194_ASPECULAR_DEG
                .iter()
                .map(|a| Geometry {
                    theta_i,
                    aspecular: a.to_radians(),
                })
                .collect(),
        }
    }

    /// One incidence `θi` with a list of aspecular angles (radians).
    ///
    /// # Errors
    /// As [`Geometry::new`] and [`GeometrySet::new`].
    pub fn custom(theta_i: f64, aspecular: &[f64]) -> Result<Self, ColourError> {
        let geometries = aspecular
            .iter()
            .map(|&a| Geometry::new(theta_i, a))
            .collect::<Result<Vec<_>, _>>()?;
        Self::new("custom", geometries)
    }

    /// The set's name (`"astm-e2194"`, `"custom"` or as given).
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The geometries in report order.
    #[must_use]
    pub fn geometries(&self) -> &[Geometry] {
        &self.geometries
    }

    /// The distinct incidence angles, in first-appearance order (radians).
    #[must_use]
    pub fn incidences(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for g in &self.geometries {
            if !out.contains(&g.theta_i) {
                out.push(g.theta_i);
            }
        }
        out
    }

    /// Index of the geometry with incidence `theta_i` and aspecular `aspecular` (radians),
    /// matched to within `1e-9` rad.
    #[must_use]
    pub fn position(&self, theta_i: f64, aspecular: f64) -> Option<usize> {
        self.geometries.iter().position(|g| {
            (g.theta_i - theta_i).abs() < 1e-9 && (g.aspecular - aspecular).abs() < 1e-9
        })
    }

    /// Flop index from per-geometry lightnesses `lightness` (same order as
    /// [`GeometrySet::geometries`]): needs 45° incidence with 15°, 45° and 110°
    /// aspecular in the set; `None` when they are missing or the index is undefined
    /// (see [`flop_index`]).
    #[must_use]
    pub fn flop_index(&self, lightness: &[f64]) -> Option<f64> {
        if lightness.len() != self.geometries.len() {
            return None;
        }
        let at = |deg: f64| {
            self.position(45f64.to_radians(), deg.to_radians())
                .map(|i| lightness[i])
        };
        flop_index(at(15.0)?, at(45.0)?, at(110.0)?)
    }
}

/// Flop index `FI = 2.69 (L*15 − L*110)^1.11 / (L*45)^0.86` from the lightnesses at
/// 15°, 45° and 110° aspecular (45° incidence). `None` when `L*15 ≤ L*110` or
/// `L*45 ≤ 0` (the power of a non-positive number is not defined) or an input is not
/// finite.
#[must_use]
pub fn flop_index(l15: f64, l45: f64, l110: f64) -> Option<f64> {
    let finite = l15.is_finite() && l45.is_finite() && l110.is_finite();
    (finite && l15 > l110 && l45 > 0.0).then(|| 2.69 * (l15 - l110).powf(1.11) / l45.powf(0.86))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e2194_detectors_in_the_signed_convention() {
        // θs = −45° + aspecular: −60, −30, −20, 0, 30, 65 degrees.
        let set = GeometrySet::astm_e2194();
        let ts: Vec<f64> = set
            .geometries()
            .iter()
            .map(|g| g.theta_s().to_degrees())
            .collect();
        for (got, want) in ts.iter().zip([-60.0, -30.0, -20.0, 0.0, 30.0, 65.0]) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        assert_eq!(set.incidences().len(), 1);
        assert_eq!(
            set.position(45f64.to_radians(), 110f64.to_radians()),
            Some(5)
        );
        let back = theta_s_to_aspecular(45f64.to_radians(), set.geometries()[0].theta_s());
        assert!((back - (-15f64).to_radians()).abs() < 1e-15);
    }

    #[test]
    fn flop_index_closed_form_and_refusals() {
        // L15 = 110, L45 = 40, L110 = 20: 2.69 · 90^1.11 / 40^0.86 written with exp/ln.
        let by_hand = 2.69 * (1.11 * 90f64.ln()).exp() / (0.86 * 40f64.ln()).exp();
        assert!((flop_index(110.0, 40.0, 20.0).unwrap() - by_hand).abs() < 1e-12);
        assert!(flop_index(20.0, 40.0, 30.0).is_none());
        assert!(flop_index(110.0, 0.0, 20.0).is_none());
        assert!(flop_index(f64::NAN, 40.0, 20.0).is_none());
        let set = GeometrySet::astm_e2194();
        let l = [120.0, 110.0, 90.0, 40.0, 25.0, 20.0];
        assert!((set.flop_index(&l).unwrap() - by_hand).abs() < 1e-12);
        let custom = GeometrySet::custom(15f64.to_radians(), &[15f64.to_radians()]).unwrap();
        assert!(custom.flop_index(&[50.0]).is_none());
    }

    #[test]
    fn bad_geometries_are_refused() {
        assert!(Geometry::new(-0.1, 0.0).is_err());
        assert!(Geometry::new(f64::NAN, 0.0).is_err());
        assert!(Geometry::new(std::f64::consts::FRAC_PI_2, 0.0).is_err());
        // 45° incidence, 140° aspecular: θs = 95°, below the horizon.
        assert!(Geometry::new(45f64.to_radians(), 140f64.to_radians()).is_err());
        assert!(GeometrySet::custom(0.5, &[]).is_err());
        assert!(GeometrySet::custom(0.5, &[0.1, 0.1]).is_err());
    }
}
