//! Result curves (CSV) as `flakescatter model` and `topo` write them (cli.md), read back
//! to compare a measurement with a model computed earlier.
//!
//! Columns (header required, any order, other columns ignored): `theta_i_deg`,
//! `theta_s_deg` (signed in-plane detector angle, or `θr` for out-of-plane detectors),
//! `aperture_deg`, `brdf_per_sr`, `relative`, and optionally `phi_s_deg` and
//! `reflectance`. `relative` and `reflectance` may be empty cells (undefined where the
//! specular detector collects nothing); they are then `NaN` / `None`. Angles are
//! returned in radians.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::table::{Table, TableError, io_err};

/// One row of a result curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveRow {
    /// Incidence angle, radians, in `[0, π/2)`.
    pub theta_i: f64,
    /// Signed in-plane detector angle (or `θr` out of plane), radians, in `(−π/2, π/2)`.
    pub theta_s: f64,
    /// Detector azimuth, radians, if the file has the column (0 = in plane).
    pub phi_s: Option<f64>,
    /// Detector cone half-angle, radians, in `[0, π/2)`.
    pub aperture: f64,
    /// BRDF averaged over the detector cone, sr⁻¹ (finite, ≥ 0).
    pub brdf: f64,
    /// Relative value; `NaN` where the file leaves it empty.
    pub relative: f64,
    /// Collected fraction of the incident power, if given.
    pub reflectance: Option<f64>,
    /// 1-based line in the file.
    pub line: u64,
}

/// Reads a result curve from a file.
///
/// # Errors
/// [`TableError`] naming the file, line and column: missing or duplicate columns,
/// malformed rows, non-numeric or non-finite values, angles out of range, a negative
/// BRDF, no rows.
pub fn read_curve(path: &Path) -> Result<Vec<CurveRow>, TableError> {
    let name = path.display().to_string();
    let f = File::open(path).map_err(io_err(&name))?;
    read_curve_from(f, &name)
}

/// As [`read_curve`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_curve`].
pub fn read_curve_from(reader: impl Read, file: &str) -> Result<Vec<CurveRow>, TableError> {
    let t = Table::read(reader, file)?;
    let need = [
        "theta_i_deg",
        "theta_s_deg",
        "aperture_deg",
        "brdf_per_sr",
        "relative",
    ];
    let [ci, cs, ca, cb, cr] = t.require(
        need,
        "a result CSV of `model` or `topo` has theta_i_deg, theta_s_deg, aperture_deg, brdf_per_sr, relative",
    )?;
    let (cphi, crefl) = (t.col("phi_s_deg"), t.col("reflectance"));
    // A number, or `None` for an empty cell where that is allowed.
    let optional = |line: u64, rec: &csv::StringRecord, c: usize, name: &str| {
        if rec.get(c).unwrap_or("").is_empty() {
            Ok(None)
        } else {
            t.num(line, rec, c, name).map(Some)
        }
    };
    let mut out = Vec::with_capacity(t.rows.len());
    for (line, rec) in &t.rows {
        let line = *line;
        let ti = t.num(line, rec, ci, need[0])?;
        if !(0.0..90.0).contains(&ti) {
            return Err(t.bad(line, need[0], format!("{ti} is outside [0, 90)")));
        }
        let ts = t.num(line, rec, cs, need[1])?;
        if !(ts > -90.0 && ts < 90.0) {
            return Err(t.bad(line, need[1], format!("{ts} is outside (-90, 90)")));
        }
        let aperture = t.num(line, rec, ca, need[2])?;
        if !(0.0..90.0).contains(&aperture) {
            return Err(t.bad(line, need[2], format!("{aperture} is outside [0, 90)")));
        }
        let brdf = t.num(line, rec, cb, need[3])?;
        if brdf < 0.0 {
            return Err(t.bad(line, need[3], format!("{brdf} is negative")));
        }
        let relative = optional(line, rec, cr, need[4])?.unwrap_or(f64::NAN);
        let phi_s = match cphi {
            Some(c) => {
                let phi = t.num(line, rec, c, "phi_s_deg")?;
                if !(-360.0..=360.0).contains(&phi) {
                    return Err(t.bad(line, "phi_s_deg", format!("{phi} is outside [-360, 360]")));
                }
                Some(phi.to_radians())
            }
            None => None,
        };
        let reflectance = match crefl {
            Some(c) => optional(line, rec, c, "reflectance")?,
            None => None,
        };
        out.push(CurveRow {
            theta_i: ti.to_radians(),
            theta_s: ts.to_radians(),
            phi_s,
            aperture: aperture.to_radians(),
            brdf,
            relative,
            reflectance,
            line,
        });
    }
    if out.is_empty() {
        return Err(TableError::Empty {
            file: file.to_string(),
        });
    }
    Ok(out)
}
