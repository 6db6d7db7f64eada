//! `volume`'s rows: the CSV columns, the rows as CSV and JSON, the warnings about them
//! and the energy balance as JSON.

use std::io::Write;

use flakescatter::VolumeCurves;
use flakescatter::volume::EnergyBalance;
use serde_json::{Value, json};

use crate::parse::{deg, deg_num};
use crate::tables::{detector_rad, num};

/// Rows whose flake light rests on fewer escapes than this are named in a warning.
const FEW_RAYS: u64 = 100;

/// The CSV columns (docs/cli.md "volume").
pub const COLUMNS: [&str; 17] = [
    "theta_i_deg",
    "theta_s_deg",
    "phi_s_deg",
    "aperture_deg",
    "brdf_per_sr",
    "reflectance",
    "relative",
    "rays",
    "std_err_per_sr",
    "coat_brdf_per_sr",
    "single_bounce_brdf_per_sr",
    "single_bounce_std_err_per_sr",
    "multiple_bounce_brdf_per_sr",
    "multiple_bounce_std_err_per_sr",
    "ray_std_err_per_sr",
    "layer_std_err_per_sr",
    "ci95_per_sr",
];

/// A standard error, empty where no ray reached the detector (not estimable).
fn se(rays: u64, x: f64) -> String {
    if rays == 0 { String::new() } else { num(x) }
}

/// A between-layer part or interval: empty with one layer, or where no ray arrived.
fn se_opt(rays: u64, x: Option<f64>) -> String {
    x.map_or_else(String::new, |v| se(rays, v))
}

/// Writes the curve CSV.
pub(super) fn write_volume(out: &mut dyn Write, c: &VolumeCurves) -> anyhow::Result<()> {
    let mut text = COLUMNS.join(",");
    text.push('\n');
    push_rows(&mut text, c, None);
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// Appends the CSV lines of `c`'s rows to `text`, each after `prefix` and a comma when
/// given (the wavelength of a spectral run).
pub(super) fn push_rows(text: &mut String, c: &VolumeCurves, prefix: Option<&str>) {
    let aperture = deg(c.instrument.aperture());
    for r in &c.rows {
        let (ts, ps) = detector_rad(&c.instrument, r.detector);
        let cells = [
            deg(r.theta_i),
            deg(ts),
            deg(ps),
            aperture.clone(),
            num(r.brdf),
            num(r.reflectance),
            num(r.relative),
            r.rays.to_string(),
            se(r.rays, r.std_err),
            num(r.coat_brdf),
            num(r.single_bounce_brdf),
            se(r.rays, r.single_bounce_std_err),
            num(r.multiple_bounce_brdf),
            se(r.rays, r.multiple_bounce_std_err),
            se(r.rays, r.ray_std_err),
            se_opt(r.rays, r.layer_std_err),
            se_opt(r.rays, r.ci95),
        ];
        if let Some(p) = prefix {
            text.push_str(p);
            text.push(',');
        }
        text.push_str(&cells.join(","));
        text.push('\n');
    }
}

/// Rows as JSON objects (undefined values `null`).
pub(super) fn rows_json(c: &VolumeCurves) -> Value {
    let finite = |x: f64| x.is_finite().then_some(x);
    let aperture = deg_num(c.instrument.aperture());
    Value::Array(
        c.rows
            .iter()
            .map(|r| {
                let (ts, ps) = detector_rad(&c.instrument, r.detector);
                let se = |x: f64| (r.rays > 0).then_some(x).and_then(finite);
                json!({
                    "theta_i_deg": deg_num(r.theta_i),
                    "theta_s_deg": deg_num(ts),
                    "phi_s_deg": deg_num(ps),
                    "aperture_deg": aperture,
                    "brdf_per_sr": finite(r.brdf),
                    "reflectance": finite(r.reflectance),
                    "relative": finite(r.relative),
                    "rays": r.rays,
                    "std_err_per_sr": se(r.std_err),
                    "coat_brdf_per_sr": finite(r.coat_brdf),
                    "single_bounce_brdf_per_sr": finite(r.single_bounce_brdf),
                    "single_bounce_std_err_per_sr": se(r.single_bounce_std_err),
                    "multiple_bounce_brdf_per_sr": finite(r.multiple_bounce_brdf),
                    "multiple_bounce_std_err_per_sr": se(r.multiple_bounce_std_err),
                    "ray_std_err_per_sr": se(r.ray_std_err),
                    "layer_std_err_per_sr": r.layer_std_err.and_then(se),
                    "ci95_per_sr": r.ci95.and_then(se),
                })
            })
            .collect(),
    )
}

/// Warnings: flakes the film could not hold as drawn, undefined `relative`, detectors no
/// ray reached, rows resting on few rays.
pub(super) fn volume_warnings(c: &VolumeCurves) -> Vec<String> {
    let mut out = Vec::new();
    let l = &c.layer;
    if c.settings.layers == 1 {
        out.push(
            "--layers 1: the standard errors count the rays only; the scatter between layers of other seeds, often several times larger, is not in them (layer_std_err and ci95 are empty); use --layers 2 or more".to_owned(),
        );
    }
    if l.resized > 0 {
        out.push(format!(
            "{} of {} flakes (all layers) were taller than the {} µm film at their tilt and got a diameter that fits (normals kept; {:.2} % of the flake area lost, physics.md §10); a thicker --film-um keeps them whole",
            l.resized,
            l.flakes,
            c.settings.film_um,
            100.0 * l.resized_area_fraction
        ));
    }
    if l.moved > 0 {
        out.push(format!(
            "{} of {} flakes (all layers) could not lie inside the film at a depth --depth-um allows and were put at the nearest depth that does (physics.md §10)",
            l.moved, l.flakes
        ));
    }
    let mut seen: Vec<f64> = Vec::new();
    for r in c.rows.iter().filter(|r| !r.relative.is_finite()) {
        if !seen.contains(&r.theta_i) {
            seen.push(r.theta_i);
            out.push(format!(
                "theta_i {}°: the detector at the specular direction collects nothing, so `relative` is undefined (empty in the CSV, null in JSON)",
                deg(r.theta_i)
            ));
        }
    }
    let n = c.rows.len();
    let dark = c.rows.iter().filter(|r| r.rays == 0).count();
    if dark > 0 {
        out.push(format!(
            "{dark} of {n} rows: no ray reached the detector, so their flake light is 0 with no standard error (empty std_err cells); more --rays, a wider --aperture or a larger --tile-um"
        ));
    }
    let few = c
        .rows
        .iter()
        .filter(|r| r.rays > 0 && r.rays < FEW_RAYS)
        .count();
    if few > 0 {
        out.push(format!(
            "{few} of {n} rows rest on fewer than {FEW_RAYS} rays (relative standard errors above about 10 %); more --rays would steady them"
        ));
    }
    out
}

/// The energy balance of one incidence as JSON (fractions of the incident beam), with
/// `absorbed_binder` when the binder absorbs (`binder`).
pub(super) fn energy_json(e: &EnergyBalance, binder: bool) -> Value {
    let mut v = json!({
        "coat_reflected": e.coat_reflected,
        "escaped_single": e.escaped_single,
        "escaped_multiple": e.escaped_multiple,
        "absorbed_substrate": e.absorbed_substrate,
        "absorbed_flakes": e.absorbed_flakes,
        "absorbed_other": e.absorbed_other,
        "absorbed_rims": e.absorbed_rims,
        "cut_off": e.cut_off,
        "escaped_via_substrate": e.escaped_via_substrate,
    });
    if binder {
        v["absorbed_binder"] = json!(e.absorbed_binder);
    }
    v
}
