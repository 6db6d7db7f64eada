//! Measured goniometric curves (CSV), physics.md §7 and cli.md.
//!
//! Columns (header required, any order, other columns ignored): `theta_i_deg`,
//! `theta_s_deg` (signed in-plane detector angle, `θs = −θi` specular), `value`, and
//! optionally `uncertainty` (same unit as `value`, one standard uncertainty, > 0 on
//! every row: a zero is refused, naming its line, not read as "no uncertainty"). What
//! `value` is — a BRDF (sr⁻¹), a reflectance factor (π × BRDF) or a relative value —
//! is not in the file; the caller says it. Angles are returned in radians.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::table::{Table, TableError as FlakeTableError};

/// One measured point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredPoint {
    /// Incidence angle, radians, in `[0, π/2)`.
    pub theta_i: f64,
    /// Signed in-plane detector angle, radians, in `(−π/2, π/2)`.
    pub theta_s: f64,
    /// The measured value, as in the file.
    pub value: f64,
    /// Its standard uncertainty, if the file has the column.
    pub uncertainty: Option<f64>,
    /// 1-based line in the file.
    pub line: u64,
}

/// A measured curve as read.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredCurve {
    /// The file it came from (for messages).
    pub file: String,
    /// The points, in file order.
    pub points: Vec<MeasuredPoint>,
}

impl MeasuredCurve {
    /// The distinct incidence angles, in order of first appearance (radians).
    #[must_use]
    pub fn incidences(&self) -> Vec<f64> {
        let mut v: Vec<f64> = Vec::new();
        for p in &self.points {
            if !v.contains(&p.theta_i) {
                v.push(p.theta_i);
            }
        }
        v
    }
}

/// Reads a measured curve from a file.
///
/// # Errors
/// [`FlakeTableError`] naming the file, line and column: missing columns, non-numeric
/// or non-finite values, angles out of range, an uncertainty that is not > 0, no rows.
pub fn read_measured(path: &Path) -> Result<MeasuredCurve, FlakeTableError> {
    let name = path.display().to_string();
    let f = File::open(path).map_err(|source| FlakeTableError::Io {
        file: name.clone(),
        source,
    })?;
    read_measured_from(f, &name)
}

/// As [`read_measured`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_measured`].
pub fn read_measured_from(reader: impl Read, file: &str) -> Result<MeasuredCurve, FlakeTableError> {
    let t = Table::read(reader, file)?;
    let [ci, cs, cv] = t.require(
        ["theta_i_deg", "theta_s_deg", "value"],
        "missing column(s); a measured curve needs theta_i_deg, theta_s_deg, value (and optionally uncertainty)",
    )?;
    let cu = t.col("uncertainty");
    let mut points = Vec::with_capacity(t.rows.len());
    for (line, rec) in &t.rows {
        let line = *line;
        let ti = t.num(line, rec, ci, "theta_i_deg")?;
        if !(0.0..90.0).contains(&ti) {
            return Err(t.bad(line, "theta_i_deg", format!("{ti} is outside [0, 90)")));
        }
        let ts = t.num(line, rec, cs, "theta_s_deg")?;
        if !(ts > -90.0 && ts < 90.0) {
            return Err(t.bad(line, "theta_s_deg", format!("{ts} is outside (-90, 90)")));
        }
        let value = t.num(line, rec, cv, "value")?;
        let uncertainty = match cu {
            Some(c) => {
                let u = t.num(line, rec, c, "uncertainty")?;
                // A fit weighs each point by 1/u²: u = 0 would be an infinite weight (and
                // the fit used to drop the whole column for it), so only u > 0 is read.
                if !(u > 0.0) {
                    return Err(t.bad(
                        line,
                        "uncertainty",
                        format!(
                            "{u} is not positive: a standard uncertainty must be > 0 (leave out the uncertainty column to fit without uncertainties)"
                        ),
                    ));
                }
                Some(u)
            }
            None => None,
        };
        points.push(MeasuredPoint {
            theta_i: ti.to_radians(),
            theta_s: ts.to_radians(),
            value,
            uncertainty,
            line,
        });
    }
    if points.is_empty() {
        return Err(FlakeTableError::Empty {
            file: file.to_string(),
        });
    }
    Ok(MeasuredCurve {
        file: file.to_string(),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_points_in_radians() {
        let text = "theta_i_deg,theta_s_deg,value,uncertainty\n30,-30,1.5,0.01\n30,-20,0.5,0.004\n60,-60,2,0.02\n";
        let c = read_measured_from(text.as_bytes(), "m.csv").unwrap();
        assert_eq!(c.points.len(), 3);
        assert!((c.points[0].theta_i - std::f64::consts::PI / 6.0).abs() < 1e-15);
        assert_eq!(c.points[1].value, 0.5);
        assert_eq!(c.points[1].uncertainty, Some(0.004));
        assert_eq!(c.points[2].line, 4);
        assert_eq!(c.incidences().len(), 2);
    }

    #[test]
    fn bad_files_name_line_and_column() {
        let cases = [
            ("theta_i_deg,value\n30,1\n", "theta_s_deg"),
            (
                "theta_i_deg,theta_s_deg,value\n30,-30,abc\n",
                "line 2, column value",
            ),
            (
                "theta_i_deg,theta_s_deg,value\n95,-30,1\n",
                "line 2, column theta_i_deg",
            ),
            (
                "theta_i_deg,theta_s_deg,value\n30,-90,1\n",
                "line 2, column theta_s_deg",
            ),
            (
                "theta_i_deg,theta_s_deg,value\n30,-30,NaN\n",
                "column value",
            ),
            (
                "theta_i_deg,theta_s_deg,value,uncertainty\n30,-30,1,-1\n",
                "column uncertainty",
            ),
            // One zero among positive uncertainties (it used to make a fit drop the whole
            // column, and its JSON say there was none).
            (
                "theta_i_deg,theta_s_deg,value,uncertainty\n30,-30,1,0.1\n30,-20,1,0\n30,-10,1,0.1\n",
                "line 3, column uncertainty: 0 is not positive",
            ),
            ("theta_i_deg,theta_s_deg,value\n", "no data rows"),
            ("theta_i_deg,theta_s_deg,value\n30,-30\n", "line 2"),
        ];
        for (text, needle) in cases {
            let e = read_measured_from(text.as_bytes(), "m.csv")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("m.csv") && e.contains(needle),
                "`{e}` lacks `{needle}`"
            );
        }
    }
}
