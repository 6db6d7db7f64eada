//! Measured BRDF tables with geometry and colour channels (CSV; `docs/formats.md`).
//!
//! Columns (header required, any order): `theta_i_deg` (incidence, `[0, 90)`),
//! `theta_r_deg` (detector polar angle from the sample normal, `[0, 90)`), `phi_r_deg`
//! (detector azimuth, `[−360, 360]`, `φr = 0` the specular half-plane and `180` the
//! source's side, as `--detectors`), and one or more channel columns
//! `brdf_<name>_per_sr` (BRDF, sr⁻¹, positive), each with an optional
//! `brdf_<name>_per_sr_uncertainty` (one standard uncertainty, sr⁻¹, positive). Other
//! columns are ignored, except one that starts with `brdf_` and is not one of these
//! forms, which is an error (a misspelt channel would otherwise be dropped silently).
//! Which channel names are known is the caller's rule (`channel_ok`). Two rows with one
//! geometry are an error (at `θr = 0` every azimuth is the same direction; azimuths
//! are taken modulo 360°). Angles are returned in radians.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::table::{Table, TableError, io_err};

/// One row of a BRDF table.
#[derive(Debug, Clone, PartialEq)]
pub struct BrdfRow {
    /// Incidence angle, radians, in `[0, π/2)`.
    pub theta_i: f64,
    /// Detector polar angle, radians, in `[0, π/2)`.
    pub theta_r: f64,
    /// Detector azimuth, radians, in `[−2π, 2π]` (0 the specular half-plane).
    pub phi_r: f64,
    /// One value per channel, sr⁻¹, positive.
    pub values: Vec<f64>,
    /// One standard uncertainty per channel, sr⁻¹, where the column is present.
    pub uncertainties: Vec<Option<f64>>,
    /// 1-based line in the file.
    pub line: u64,
}

/// A BRDF table as read.
#[derive(Debug, Clone, PartialEq)]
pub struct BrdfTable {
    /// The file (for messages).
    pub file: String,
    /// 1-based line of the header.
    pub header_line: u64,
    /// The channel names, `<name>` of `brdf_<name>_per_sr`, in column order.
    pub channels: Vec<String>,
    /// The rows, in file order.
    pub rows: Vec<BrdfRow>,
}

/// `true` when the header of the CSV text `head` (its first non-comment line) names the
/// columns of a BRDF table (`theta_r_deg`), rather than an in-plane curve
/// ([`crate::measured`]).
#[must_use]
pub fn looks_like_brdf_table(head: &str) -> bool {
    head.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|h| {
            h.split(',')
                .any(|c| c.trim().eq_ignore_ascii_case("theta_r_deg"))
        })
}

/// Reads a BRDF table from a file; `channel_ok(name)` says why a channel name is not
/// known (`Err(reason)`), if it is not.
///
/// # Errors
/// [`TableError`] naming the file, line and column (module docs).
pub fn read_brdf_table(
    path: &Path,
    channel_ok: &dyn Fn(&str) -> Result<(), String>,
) -> Result<BrdfTable, TableError> {
    let name = path.display().to_string();
    let f = File::open(path).map_err(io_err(&name))?;
    read_brdf_table_from(f, &name, channel_ok)
}

/// As [`read_brdf_table`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_brdf_table`].
pub fn read_brdf_table_from(
    reader: impl Read,
    file: &str,
    channel_ok: &dyn Fn(&str) -> Result<(), String>,
) -> Result<BrdfTable, TableError> {
    let t = Table::read(reader, file)?;
    let [ci, cr, cp] = t.require(
        ["theta_i_deg", "theta_r_deg", "phi_r_deg"],
        "a BRDF table needs theta_i_deg, theta_r_deg, phi_r_deg and brdf_<channel>_per_sr columns",
    )?;
    // Channel columns, their uncertainty columns, and misspelt brdf_ columns.
    let mut channels: Vec<(String, usize, Option<usize>)> = Vec::new();
    for (j, h) in t.header.iter().enumerate() {
        if let Some(name) = h
            .strip_prefix("brdf_")
            .and_then(|r| r.strip_suffix("_per_sr"))
        {
            if name.is_empty() {
                return Err(t.bad(
                    t.header_line,
                    h,
                    "a channel column needs a name: brdf_<name>_per_sr".into(),
                ));
            }
            channel_ok(name).map_err(|why| t.bad(t.header_line, h, why))?;
            let u = t.col(&format!("{h}_uncertainty"));
            channels.push((name.to_string(), j, u));
        } else if h.starts_with("brdf_") {
            let valid_uncertainty = h
                .strip_suffix("_uncertainty")
                .is_some_and(|v| v.ends_with("_per_sr") && t.col(v).is_some());
            if !valid_uncertainty {
                return Err(t.bad(
                    t.header_line,
                    h,
                    "not a channel column: expected brdf_<name>_per_sr or brdf_<name>_per_sr_uncertainty (with its value column)".into(),
                ));
            }
        }
    }
    if channels.is_empty() {
        return Err(t.bad(
            t.header_line,
            "brdf_<channel>_per_sr",
            format!(
                "no channel column in the header (found: {}); name each channel's BRDF column brdf_<name>_per_sr, e.g. brdf_g_per_sr or brdf_550nm_per_sr",
                t.header.join(", ")
            ),
        ));
    }
    let mut rows: Vec<BrdfRow> = Vec::with_capacity(t.rows.len());
    // (θi, θr, φr mod 360 or 0 at the normal) in degrees → line, for duplicates.
    let mut seen: std::collections::HashMap<(u64, u64, u64), u64> =
        std::collections::HashMap::new();
    for (line, rec) in &t.rows {
        let line = *line;
        let ti = t.num(line, rec, ci, "theta_i_deg")?;
        if !(0.0..90.0).contains(&ti) {
            return Err(t.bad(
                line,
                "theta_i_deg",
                format!("{ti} is outside [0, 90) degrees"),
            ));
        }
        let tr = t.num(line, rec, cr, "theta_r_deg")?;
        if !(0.0..90.0).contains(&tr) {
            return Err(t.bad(
                line,
                "theta_r_deg",
                format!("{tr} is outside [0, 90) degrees"),
            ));
        }
        let pr = t.num(line, rec, cp, "phi_r_deg")?;
        if !(-360.0..=360.0).contains(&pr) {
            return Err(t.bad(
                line,
                "phi_r_deg",
                format!("{pr} is outside [-360, 360] degrees"),
            ));
        }
        let mut values = Vec::with_capacity(channels.len());
        let mut uncertainties = Vec::with_capacity(channels.len());
        for (name, j, u) in &channels {
            let column = format!("brdf_{name}_per_sr");
            let v = t.num(line, rec, *j, &column)?;
            if !(v > 0.0) {
                return Err(t.bad(
                    line,
                    &column,
                    format!("{v} is not positive: a BRDF table is compared and fitted in log; leave out a geometry you could not measure"),
                ));
            }
            values.push(v);
            uncertainties.push(match u {
                Some(k) => {
                    let col = format!("{column}_uncertainty");
                    let s = t.num(line, rec, *k, &col)?;
                    if !(s > 0.0) {
                        return Err(t.bad(
                            line,
                            &col,
                            format!("{s} is not positive (a standard uncertainty)"),
                        ));
                    }
                    Some(s)
                }
                None => None,
            });
        }
        let phi_key = if tr == 0.0 { 0.0 } else { pr.rem_euclid(360.0) };
        let key = (ti.to_bits(), tr.to_bits(), (phi_key + 0.0).to_bits());
        if let Some(first) = seen.insert(key, line) {
            return Err(t.bad(
                line,
                "theta_i_deg, theta_r_deg, phi_r_deg",
                format!("the geometry ({ti}, {tr}, {pr}) degrees is already on line {first}; give each geometry once (average repeated measurements, with their uncertainty)"),
            ));
        }
        rows.push(BrdfRow {
            theta_i: ti.to_radians(),
            theta_r: tr.to_radians(),
            phi_r: pr.to_radians(),
            values,
            uncertainties,
            line,
        });
    }
    if rows.is_empty() {
        return Err(TableError::Empty {
            file: file.to_string(),
        });
    }
    Ok(BrdfTable {
        file: file.to_string(),
        header_line: t.header_line,
        channels: channels.into_iter().map(|c| c.0).collect(),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn any(_: &str) -> Result<(), String> {
        Ok(())
    }

    fn rgb(name: &str) -> Result<(), String> {
        if ["r", "g", "b"].contains(&name) {
            Ok(())
        } else {
            Err(format!("unknown channel `{name}`"))
        }
    }

    #[test]
    fn reads_channels_and_uncertainties() {
        let text = "theta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr,brdf_g_per_sr,brdf_g_per_sr_uncertainty,note\n\
                    30,30,0,1.5,2.5,0.1,x\n30,10,180,0.5,0.25,0.02,y\n";
        let t = read_brdf_table_from(text.as_bytes(), "t.csv", &rgb).unwrap();
        assert_eq!(t.channels, vec!["r", "g"]);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[1].values, vec![0.5, 0.25]);
        assert_eq!(t.rows[1].uncertainties, vec![None, Some(0.02)]);
        assert!((t.rows[1].phi_r - std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(t.rows[1].line, 3);
        assert!(looks_like_brdf_table(
            "# c\ntheta_i_deg, theta_r_deg ,phi_r_deg\n"
        ));
        assert!(!looks_like_brdf_table("theta_i_deg,theta_s_deg,value\n"));
    }

    #[test]
    fn bad_tables_name_line_and_column() {
        let head = "theta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr\n";
        let cases = [
            (
                "theta_i_deg,theta_r_deg,brdf_r_per_sr\n30,1,2\n",
                "phi_r_deg",
            ),
            (
                "theta_i_deg,theta_r_deg,phi_r_deg\n30,1,2\n",
                "no channel column",
            ),
            (
                "theta_i_deg,theta_r_deg,phi_r_deg,brdf_x_per_sr\n30,1,2,1\n",
                "line 1, column brdf_x_per_sr: unknown channel",
            ),
            (
                "theta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr,brdf_red\n30,1,2,1,1\n",
                "column brdf_red",
            ),
            (
                "theta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr,brdf_g_per_sr_uncertainty\n30,1,2,1,1\n",
                "column brdf_g_per_sr_uncertainty",
            ),
            (&format!("{head}95,1,2,1\n"), "line 2, column theta_i_deg"),
            (&format!("{head}30,90,2,1\n"), "line 2, column theta_r_deg"),
            (&format!("{head}30,10,400,1\n"), "line 2, column phi_r_deg"),
            (
                &format!("{head}30,10,0,0\n"),
                "line 2, column brdf_r_per_sr: 0 is not positive",
            ),
            (&format!("{head}30,10,0,-1e-3\n"), "not positive"),
            (
                &format!("{head}30,10,0,abc\n"),
                "line 2, column brdf_r_per_sr",
            ),
            (
                &format!("{head}30,10,0,1\n30,10,360,2\n"),
                "line 3, column theta_i_deg, theta_r_deg, phi_r_deg: the geometry",
            ),
            (&format!("{head}30,0,0,1\n30,0,90,2\n"), "already on line 2"),
            (head, "no data rows"),
        ];
        for (text, needle) in cases {
            let e = read_brdf_table_from(text.as_bytes(), "t.csv", &rgb)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("t.csv") && e.contains(needle),
                "`{e}` lacks `{needle}`"
            );
        }
        // A negative uncertainty.
        let e = read_brdf_table_from(
            "theta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr,brdf_r_per_sr_uncertainty\n30,1,2,1,-1\n".as_bytes(),
            "t.csv",
            &any,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("line 2, column brdf_r_per_sr_uncertainty"),
            "{e}"
        );
    }
}
