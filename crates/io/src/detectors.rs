//! Out-of-plane detector lists (CSV), cli.md `--detectors`.
//!
//! Columns (header required, any order, other columns ignored): `theta_r_deg`, the polar
//! angle of the detector axis from the coating normal in `[0, 90)` degrees, and
//! `phi_r_deg`, its azimuth in `[-360, 360]` degrees with `φr = 0` the specular
//! half-plane (physics.md §3). Angles are returned in radians.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::table::{Table, TableError, io_err};

/// One out-of-plane detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detector {
    /// Polar angle of the detector axis, radians, in `[0, π/2)`.
    pub theta_r: f64,
    /// Azimuth of the detector axis, radians, in `[−2π, 2π]` (0 = specular half-plane).
    pub phi_r: f64,
    /// 1-based line in the file.
    pub line: u64,
}

/// Reads a detector list from a file.
///
/// # Errors
/// [`TableError`] naming the file, line and column: missing or duplicate columns,
/// malformed rows, non-numeric or non-finite values, angles out of range, no rows.
pub fn read_detectors(path: &Path) -> Result<Vec<Detector>, TableError> {
    let name = path.display().to_string();
    let f = File::open(path).map_err(io_err(&name))?;
    read_detectors_from(f, &name)
}

/// As [`read_detectors`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_detectors`].
pub fn read_detectors_from(reader: impl Read, file: &str) -> Result<Vec<Detector>, TableError> {
    let t = Table::read(reader, file)?;
    let [ct, cp] = t.require(
        ["theta_r_deg", "phi_r_deg"],
        "a detector list needs theta_r_deg and phi_r_deg",
    )?;
    let mut out = Vec::with_capacity(t.rows.len());
    for (line, rec) in &t.rows {
        let line = *line;
        let theta = t.num(line, rec, ct, "theta_r_deg")?;
        if !(0.0..90.0).contains(&theta) {
            return Err(t.bad(
                line,
                "theta_r_deg",
                format!("{theta} is outside [0, 90) degrees"),
            ));
        }
        let phi = t.num(line, rec, cp, "phi_r_deg")?;
        if !(-360.0..=360.0).contains(&phi) {
            return Err(t.bad(
                line,
                "phi_r_deg",
                format!("{phi} is outside [-360, 360] degrees"),
            ));
        }
        out.push(Detector {
            theta_r: theta.to_radians(),
            phi_r: phi.to_radians(),
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
