//! Tables and JSON of the spectral results (docs/cli.md "Spectral models", "Colour"):
//! curves per wavelength, CIELAB per multi-angle geometry, spectra, colour differences.
//!
//! Angles are written as they were given ([`crate::parse::deg`]), values in the
//! shortest round-trip form ([`crate::tables::num`]); hue angles in degrees.

use std::fmt::Write as _;
use std::io::Write;

use flakescatter::colour::{Lab, Xyz};
use flakescatter::spectral::{
    GeometryDifference, MultiAngleColour, MultiAngleComparison, SpectralCurves,
};
use serde_json::{Value, json};

use crate::output::{Dest, Plan, print, print_json, warn};
use crate::parse::{deg, deg_num, fixed, shortest};
use crate::tables::{detector_rad, num};

fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Hue angle in degrees, `[0, 360)`.
pub fn hue_deg(lab: &Lab) -> f64 {
    lab.hue().to_degrees()
}

/// Adds each wavelength's curve warnings ([`crate::tables::curve_warnings`]) to
/// `warnings`, prefixed by the wavelength, each message once.
pub fn push_curve_warnings(warnings: &mut Vec<String>, s: &SpectralCurves, std_err_rows: bool) {
    for (w, c) in s.wavelengths_nm.iter().zip(&s.curves) {
        for msg in crate::tables::curve_warnings(c, std_err_rows) {
            let msg = format!("{w} nm: {msg}");
            if !warnings.contains(&msg) {
                warnings.push(msg);
            }
        }
    }
}

/// Writes the curves of every wavelength: `wavelength_nm` and the curve columns of
/// cli.md (`rays, std_err` too when `topo_columns`).
pub fn write_spectral_curves(
    out: &mut dyn Write,
    s: &SpectralCurves,
    topo_columns: bool,
) -> anyhow::Result<()> {
    let mut text = String::from(
        "wavelength_nm,theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative",
    );
    if topo_columns {
        text.push_str(",rays,std_err");
    }
    text.push('\n');
    for (w, curves) in s.wavelengths_nm.iter().zip(&s.curves) {
        let aperture = deg(curves.instrument.aperture());
        for row in &curves.rows {
            let (ts, ps) = detector_rad(&curves.instrument, row.detector);
            let _ = write!(
                text,
                "{},{},{},{},{aperture},{},{},{}",
                shortest(*w),
                deg(row.theta_i),
                deg(ts),
                deg(ps),
                num(row.brdf),
                opt(row.reflectance),
                num(row.relative)
            );
            if topo_columns {
                let _ = write!(
                    text,
                    ",{},{}",
                    row.rays.map(|r| r.to_string()).unwrap_or_default(),
                    opt(row.std_err)
                );
            }
            text.push('\n');
        }
    }
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// The rows of every wavelength as JSON objects (`wavelength_nm` added to each).
pub fn spectral_rows_json(s: &SpectralCurves) -> Value {
    let mut rows = Vec::new();
    for (w, curves) in s.wavelengths_nm.iter().zip(&s.curves) {
        if let Value::Array(r) = crate::tables::rows_json(curves) {
            for mut v in r {
                v["wavelength_nm"] = json!(w);
                rows.push(v);
            }
        }
    }
    Value::Array(rows)
}

/// The colour keys `X, Y, Z, L, a, b, C, h` (h in degrees).
pub fn colour_json(xyz: &Xyz, lab: &Lab) -> Value {
    json!({
        "X": xyz.x, "Y": xyz.y, "Z": xyz.z,
        "L": lab.l, "a": lab.a, "b": lab.b,
        "C": lab.chroma(), "h": hue_deg(lab),
    })
}

/// Units of the colour keys.
pub fn colour_units() -> Value {
    json!({
        "X, Y, Z": "CIE tristimulus values, Y = 100 for the perfect reflecting diffuser",
        "L, a, b": "CIELAB (CIE 1976), white point = the perfect reflector under the same illuminant and observer",
        "C": "chroma C*ab",
        "h": "degree, hue angle h_ab in [0, 360)",
        "reflectance_factor": "pi x BRDF averaged over the detector cone (1 for a perfect diffuser)",
    })
}

/// The per-geometry CSV of a multi-angle colour.
pub fn write_multi_angle(out: &mut dyn Write, m: &MultiAngleColour) -> anyhow::Result<()> {
    let mut text = String::from(
        "theta_i_deg,aspecular_deg,theta_s_deg,aperture_deg,reflectance_factor,lightness_l_star,X,Y,Z,L,a,b,C,h_deg,lightness_std_err\n",
    );
    let aperture = deg(m.aperture);
    for g in &m.geometries {
        let ti = g.geometry.theta_i();
        let asp = g.geometry.aspecular();
        let _ = writeln!(
            text,
            "{},{},{},{aperture},{},{},{},{},{},{},{},{},{},{},{}",
            deg(ti),
            deg(asp),
            shortest(deg_num(asp) - deg_num(ti)),
            num(g.luminance_factor),
            num(g.lab.l),
            num(g.xyz.x),
            num(g.xyz.y),
            num(g.xyz.z),
            num(g.lab.l),
            num(g.lab.a),
            num(g.lab.b),
            num(g.lab.chroma()),
            num(hue_deg(&g.lab)),
            opt(g.lightness_std_err)
        );
    }
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// The long spectra CSV of a multi-angle colour (`colour --reflectance` reads it).
pub fn write_spectra(out: &mut dyn Write, m: &MultiAngleColour) -> anyhow::Result<()> {
    let mut text =
        String::from("theta_i_deg,aspecular_deg,wavelength_nm,reflectance_factor,std_err\n");
    for g in &m.geometries {
        let (ti, asp) = (deg(g.geometry.theta_i()), deg(g.geometry.aspecular()));
        for ((w, r), e) in m
            .wavelengths_nm
            .iter()
            .zip(&g.reflectance)
            .zip(&g.reflectance_std_err)
        {
            let _ = writeln!(text, "{ti},{asp},{},{},{}", shortest(*w), num(*r), opt(*e));
        }
    }
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// The readouts of a multi-angle colour as JSON (keys of cli.md).
pub fn readouts_json(m: &MultiAngleColour) -> Value {
    Value::Array(
        m.geometries
            .iter()
            .map(|g| {
                let ti = g.geometry.theta_i();
                let asp = g.geometry.aspecular();
                let mut v = colour_json(&g.xyz, &g.lab);
                v["theta_i_deg"] = json!(deg_num(ti));
                v["aspecular_deg"] = json!(deg_num(asp));
                v["theta_s_deg"] = json!(deg_num(asp) - deg_num(ti));
                v["reflectance_factor"] = json!(finite(g.luminance_factor));
                v["lightness_l_star"] = json!(finite(g.lab.l));
                v["lightness_std_err"] = json!(g.lightness_std_err);
                v["rays"] = json!(g.rays);
                v
            })
            .collect(),
    )
}

/// The JSON summary of a multi-angle colour (without the command's inputs).
pub fn multi_angle_json(m: &MultiAngleColour) -> Value {
    json!({
        "model": m.model,
        "geometry_set": m.set.name(),
        "theta_i_deg": m.set.incidences().first().map(|t| deg_num(*t)),
        "aperture_deg": deg_num(m.aperture),
        "wavelengths_nm": m.wavelengths_nm,
        "illuminant": m.illuminant.label(),
        "observer_deg": match m.observer { flakescatter::colour::Observer::Cie1931TwoDegree => 2, _ => 10 },
        "white_point": {"X": m.white.x, "Y": m.white.y, "Z": m.white.z},
        "dispersive": m.dispersive,
        "readouts": readouts_json(m),
        "flop_index": m.flop_index,
        "flop_index_formula": "2.69 (L*15 - L*110)^1.11 / (L*45)^0.86 (DuPont, as published by X-Rite), at 45° incidence; null when the set lacks 45° incidence with 15°, 45° and 110° aspecular, or L*15 <= L*110",
        "warnings": m.warnings,
        "units": {
            "colour": colour_units(),
            "reflectance_factor": "luminance factor Y/Yn: the Y-weighted mean of the spectral reflectance factor (pi x BRDF over the detector cone); the reflectance factor itself for a flat spectrum",
            "lightness_std_err": "standard uncertainty of L* from the model's standard errors, taken as fully correlated between wavelengths (an upper bound otherwise); null where not estimable",
        },
    })
}

/// One colour difference as JSON, with both colours.
pub fn difference_json(d: &GeometryDifference) -> Value {
    json!({
        "theta_i_deg": deg_num(d.geometry.theta_i()),
        "aspecular_deg": deg_num(d.geometry.aspecular()),
        "measured": {"L": d.measured.l, "a": d.measured.a, "b": d.measured.b},
        "model": {"L": d.model.l, "a": d.model.a, "b": d.model.b},
        "delta_l": d.delta_l,
        "delta_a": d.delta_a,
        "delta_b": d.delta_b,
        "delta_e_ab": d.delta_e_ab,
        "delta_e_94": d.delta_e_94,
        "delta_e_2000": d.delta_e_2000,
    })
}

/// The per-geometry CSV of a comparison.
fn comparison_csv(c: &MultiAngleComparison) -> String {
    let mut s = String::from(
        "theta_i_deg,aspecular_deg,measured_L,measured_a,measured_b,model_L,model_a,model_b,delta_l,delta_a,delta_b,delta_e_ab,delta_e_94,delta_e_2000\n",
    );
    for d in &c.rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            deg(d.geometry.theta_i()),
            deg(d.geometry.aspecular()),
            num(d.measured.l),
            num(d.measured.a),
            num(d.measured.b),
            num(d.model.l),
            num(d.model.a),
            num(d.model.b),
            num(d.delta_l),
            num(d.delta_a),
            num(d.delta_b),
            num(d.delta_e_ab),
            num(d.delta_e_94),
            num(d.delta_e_2000)
        );
    }
    s
}

/// The comparison for the terminal (display rounding).
fn comparison_text(c: &MultiAngleComparison) -> String {
    let mut s = String::from(
        "theta_i  aspecular  measured L*     a*     b*   model L*     a*     b*      dL*  dE2000\n",
    );
    for d in &c.rows {
        let _ = writeln!(
            s,
            "{:<8} {:<9} {:>11} {:>6} {:>6} {:>10} {:>6} {:>6} {:>8} {:>7}",
            deg(d.geometry.theta_i()),
            deg(d.geometry.aspecular()),
            fixed(d.measured.l, 2),
            fixed(d.measured.a, 2),
            fixed(d.measured.b, 2),
            fixed(d.model.l, 2),
            fixed(d.model.a, 2),
            fixed(d.model.b, 2),
            fixed(d.delta_l, 2),
            fixed(d.delta_e_2000, 2)
        );
    }
    let f = |x: Option<f64>| x.map_or_else(|| "not defined".to_string(), |v| fixed(v, 2));
    let _ = writeln!(
        s,
        "mean dE2000 {}, largest {} at aspecular {}°; flop index measured {}, model {}",
        fixed(c.mean_delta_e_2000, 2),
        fixed(c.max_delta_e_2000.0, 2),
        deg(c.rows[c.max_delta_e_2000.1].geometry.aspecular()),
        f(c.measured_flop_index),
        f(c.model.flop_index)
    );
    s
}

/// Writes a comparison: CSV to `out`, a table on stdout unless `--json` or `--out -`,
/// the JSON summary when `json`.
pub fn comparison_outputs(
    mut plan: Plan,
    c: &MultiAngleComparison,
    inputs: Value,
    out: Option<&Dest>,
    json: bool,
) -> anyhow::Result<()> {
    for w in &c.model.warnings {
        warn(w);
    }
    if let Some(dest) = out {
        plan.write(
            dest,
            |w| Ok(w.write_all(comparison_csv(c).as_bytes())?),
            Some(format!("{} rows", c.rows.len())),
        )?;
    }
    plan.finish()?;
    if json {
        let mut v = json!({
            "version": env!("CARGO_PKG_VERSION"),
            "command": "compare --measured-multiangle",
            "inputs": inputs,
            "geometries": c.rows.iter().map(difference_json).collect::<Vec<_>>(),
            "mean_delta_e_2000": c.mean_delta_e_2000,
            "max_delta_e_2000": c.max_delta_e_2000.0,
            "measured_flop_index": c.measured_flop_index,
            "model_flop_index": c.model.flop_index,
            "differences": "model (sample) - measured (standard); delta_e_94 weights from the measured chroma",
        });
        v["model"] = multi_angle_json(&c.model);
        print_json(&v)
    } else if out != Some(&Dest::Stdout) {
        print(&comparison_text(c))
    } else {
        Ok(())
    }
}

/// Writes what a multi-angle command computed: the per-geometry table to `table`, the
/// spectra to `spectra`, the JSON summary when `json`; warnings on stderr.
#[allow(clippy::too_many_arguments)]
pub fn multi_angle_outputs(
    mut plan: Plan,
    command: &str,
    m: &MultiAngleColour,
    inputs: Value,
    table: Option<&Dest>,
    spectra: Option<&Dest>,
    json: bool,
    out: Option<&std::path::Path>,
) -> anyhow::Result<()> {
    for w in &m.warnings {
        warn(w);
    }
    if let Some(dest) = table {
        plan.write(
            dest,
            |w| write_multi_angle(w, m),
            Some(format!("{} rows", m.geometries.len())),
        )?;
    }
    if let Some(dest) = spectra {
        plan.write(
            dest,
            |w| write_spectra(w, m),
            Some(format!(
                "{} rows",
                m.geometries.len() * m.wavelengths_nm.len()
            )),
        )?;
    }
    plan.finish()?;
    if json {
        let mut v = multi_angle_json(m);
        v["version"] = json!(env!("CARGO_PKG_VERSION"));
        v["command"] = json!(command);
        v["inputs"] = inputs;
        v["out"] = json!(out.map(|p| p.display().to_string()));
        print_json(&v)?;
    }
    Ok(())
}
