//! Measured BRDF tables as the fit sees them: rows of a geometry and one value per
//! channel, and the choice of the points a fit uses.
//!
//! Conventions: radians; `θr`, `φr` as `--detectors` (`φr = 0` the specular
//! half-plane); values are BRDFs in sr⁻¹ with optional standard uncertainties. The
//! *aspecular angle* of a row is the angle between its detector direction and the
//! specular direction `(sin θi, 0, cos θi)`, in and out of the plane.

use flakescatter_optics::Vec3;

use crate::{Channel, PaintError};

/// One measured geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Incidence angle, radians, in `[0, π/2)`.
    pub theta_i: f64,
    /// Detector polar angle, radians, in `[0, π/2)`.
    pub theta_r: f64,
    /// Detector azimuth, radians (`0` the specular half-plane, `π` the source's side).
    pub phi_r: f64,
    /// The value in each channel (BRDF, sr⁻¹), in the measurement's channel order.
    pub values: Vec<f64>,
    /// Standard uncertainty of each value, sr⁻¹, where given.
    pub uncertainties: Vec<Option<f64>>,
    /// 1-based line in the file (for messages).
    pub line: u64,
}

impl Observation {
    /// The detector direction, a unit vector with `z ≥ 0`.
    #[must_use]
    pub fn direction(&self) -> Vec3 {
        let (st, ct) = self.theta_r.sin_cos();
        let (sp, cp) = self.phi_r.sin_cos();
        Vec3::new(st * cp, st * sp, ct)
    }

    /// The aspecular angle, radians (module docs).
    #[must_use]
    pub fn aspecular(&self) -> f64 {
        let (si, ci) = self.theta_i.sin_cos();
        let r = self.direction();
        // atan2 of |r × p| and r·p keeps the digits near specular.
        let cross = Vec3::new(r.y * ci, r.z * si - r.x * ci, -r.y * si).norm();
        cross.atan2(r.x * si + r.z * ci)
    }

    /// `true` in the plane of incidence (`φr` a multiple of π to 1e-9).
    #[must_use]
    pub fn in_plane(&self) -> bool {
        self.phi_r.sin().abs() < 1e-9
    }
}

/// A measured table.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// The file it came from (for messages).
    pub file: String,
    /// Its channels, in column order.
    pub channels: Vec<Channel>,
    /// Its rows, in file order.
    pub rows: Vec<Observation>,
}

/// Which points of a table a fit or a comparison uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Selection {
    /// Aspecular range `[lo, hi]`, radians. Default `[2°, 180°]`: within 2° of specular
    /// a measured peak is the instrument's resolution acting on the coat's mirror
    /// reflection, which a point model does not represent.
    pub aspecular: (f64, f64),
    /// Largest detector polar angle used, radians (default π/2: all).
    pub max_theta_r: f64,
    /// Smallest value used, sr⁻¹ (default 0: all).
    pub min_value: f64,
}

impl Default for Selection {
    fn default() -> Self {
        Self {
            aspecular: (2f64.to_radians(), std::f64::consts::PI),
            max_theta_r: std::f64::consts::FRAC_PI_2,
            min_value: 0.0,
        }
    }
}

/// One value a fit uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Row of the measurement.
    pub row: usize,
    /// Channel index.
    pub channel: usize,
    /// The measured value, sr⁻¹.
    pub value: f64,
    /// Standard uncertainty of `ln value` (`u/value`), or 1 without uncertainties.
    pub sigma_ln: f64,
}

/// The points of `m` within `sel`, and whether every one has a stated uncertainty.
///
/// # Errors
/// [`PaintError::Data`] naming the file when no point is left, or naming the line and
/// column of a value that is not positive (a log fit needs positive values) or an
/// uncertainty that is not positive.
pub fn select(m: &Measurement, sel: &Selection) -> Result<(Vec<Point>, bool), PaintError> {
    let mut points = Vec::new();
    let mut all_u = true;
    for (row, o) in m.rows.iter().enumerate() {
        let a = o.aspecular();
        if a < sel.aspecular.0 - 1e-12 || a > sel.aspecular.1 + 1e-12 {
            continue;
        }
        if o.theta_r > sel.max_theta_r + 1e-12 {
            continue;
        }
        for (channel, &value) in o.values.iter().enumerate() {
            if value < sel.min_value {
                continue;
            }
            let column = || format!("brdf_{}_per_sr", m.channels[channel].name);
            if !(value > 0.0 && value.is_finite()) {
                return Err(PaintError::Data(format!(
                    "{}, line {}, column {}: value {value} is not positive; a log fit needs positive values",
                    m.file,
                    o.line,
                    column()
                )));
            }
            let sigma_ln = match o.uncertainties.get(channel).copied().flatten() {
                Some(u) if u > 0.0 => u / value,
                Some(u) => {
                    return Err(PaintError::Data(format!(
                        "{}, line {}, column {}_uncertainty: {u} is not positive",
                        m.file,
                        o.line,
                        column()
                    )));
                }
                None => {
                    all_u = false;
                    1.0
                }
            };
            points.push(Point {
                row,
                channel,
                value,
                sigma_ln,
            });
        }
    }
    if points.is_empty() {
        return Err(PaintError::Data(format!(
            "{}: no usable point: none lies between {:.1}° and {:.1}° from specular with theta_r <= {:.1}° and a value >= {}",
            m.file,
            sel.aspecular.0.to_degrees(),
            sel.aspecular.1.to_degrees(),
            sel.max_theta_r.to_degrees(),
            sel.min_value
        )));
    }
    // A mixture of stated and missing uncertainties weighs nothing consistently.
    if !all_u {
        for p in &mut points {
            p.sigma_ln = 1.0;
        }
    }
    Ok((points, all_u))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aspecular_angles() {
        let o = |ti: f64, tr: f64, pr: f64| Observation {
            theta_i: ti.to_radians(),
            theta_r: tr.to_radians(),
            phi_r: pr.to_radians(),
            values: vec![1.0],
            uncertainties: vec![None],
            line: 2,
        };
        assert!(o(30.0, 30.0, 0.0).aspecular() < 1e-15);
        assert!((o(30.0, 10.0, 0.0).aspecular().to_degrees() - 20.0).abs() < 1e-12);
        assert!((o(30.0, 10.0, 180.0).aspecular().to_degrees() - 40.0).abs() < 1e-12);
        // Out of the plane: cos a = r·p.
        let x = o(45.0, 40.0, 90.0);
        let want = (40f64.to_radians().sin() * 0.0
            + 40f64.to_radians().cos() * 45f64.to_radians().cos())
        .acos();
        assert!((x.aspecular() - want).abs() < 1e-12);
        assert!(!x.in_plane() && o(45.0, 40.0, 180.0).in_plane());
    }
}
