//! What the Mueller path of `model` and `topo` adds to their output (docs/cli.md
//! "Polarisation"): the CSV columns `m00 … m33` (with `--polarization mueller`) and
//! `dop_unpolarized`, the same in the JSON rows, the convention and the units.
//!
//! The standard columns hold what the detectors read for `--incident` behind
//! `--analyzer` ([`flakescatter::MuellerCurves::detected_curves`]); this module only
//! formats what the facade computed.

use flakescatter::MuellerCurves;
use serde_json::{Value, json};

use crate::tables::num;

/// The basis convention, in words, for JSON metadata (physics.md §11).
pub const CONVENTION: &str = "SCATMECH's: Stokes vectors and Mueller matrices in the (s, p) basis of each direction k, s = (z x k)/|z x k| (horizontal), p = k x s; the incident beam in the basis of the incident direction (s = y), everything a detector collects in the basis of its cone's axis (theta_r, phi_r), s = (-sin phi_r, cos phi_r, 0); S1 > 0 is s-polarised, S2 > 0 linear along s + p, S3 > 0 left circular (time dependence exp(-i omega t)); S_out = M S_in (physics.md §11)";

/// Names of the 16 element columns, row-major.
fn element_names() -> impl Iterator<Item = String> {
    (0..16).map(|e| format!("m{}{}", e / 4, e % 4))
}

/// The extra CSV header: `m00 … m33` when `elements`, then `dop_unpolarized`.
pub fn header(elements: bool) -> Vec<String> {
    let mut h: Vec<String> = if elements {
        element_names().collect()
    } else {
        Vec::new()
    };
    h.push("dop_unpolarized".to_owned());
    h
}

/// The extra cells of row `k` (same order as [`header`]); undefined values are empty.
pub fn cells(curves: &MuellerCurves, k: usize, elements: bool) -> Vec<String> {
    let row = &curves.rows[k];
    let mut c: Vec<String> = if elements {
        row.brdf.iter().map(|&m| num(m)).collect()
    } else {
        Vec::new()
    };
    c.push(num(row.dop_unpolarized));
    c
}

/// Adds `mueller_brdf_per_sr` (with `elements`) and `dop_unpolarized` to each JSON row
/// of [`crate::tables::rows_json`].
pub fn add_to_rows(rows: &mut Value, curves: &MuellerCurves, elements: bool) {
    let finite = |x: f64| x.is_finite().then_some(x);
    if let Value::Array(rows) = rows {
        for (row, m) in rows.iter_mut().zip(&curves.rows) {
            if elements {
                row["mueller_brdf_per_sr"] = json!(m.brdf.map(finite));
            }
            row["dop_unpolarized"] = json!(finite(m.dop_unpolarized));
        }
    }
}

/// One warning for rows whose degree of polarisation is undefined (nothing collected).
pub fn warnings(curves: &MuellerCurves) -> Vec<String> {
    let undefined = curves
        .rows
        .iter()
        .filter(|r| !r.dop_unpolarized.is_finite())
        .count();
    if undefined == 0 {
        return Vec::new();
    }
    vec![format!(
        "{undefined} of {} rows collect nothing (m00 = 0), so their dop_unpolarized is undefined (empty in the CSV, null in JSON)",
        curves.rows.len()
    )]
}

/// Units of what the Mueller path adds, for JSON metadata.
pub fn units(elements: bool) -> Value {
    let mut u = json!({
        "brdf_per_sr": "1/sr, the BRDF a detector reads for --incident behind --analyzer: a . M . s, s the incident Stokes vector normalised to S0 = 1, a = (1, 0, 0, 0) without an analyser and (1, S1/|S|, S2/|S|, S3/|S|)/2 for an ideal polariser passing S (|S| = sqrt(S1^2 + S2^2 + S3^2))",
        "reflectance": "fraction of the incident beam power the detector reads for --incident behind --analyzer (the same a . R . s of the cone's reflectance Mueller matrix)",
        "relative": "the reading relative to that of the same detector at the specular direction, for the same --incident and --analyzer",
        "dop_unpolarized": "degree of polarisation of the collected light for unpolarised incidence, sqrt(m10^2 + m20^2 + m30^2)/m00 (no unit, 0 to 1); null where nothing is collected",
    });
    if elements {
        u["m00 ... m33"] = json!(
            "1/sr, the cone-averaged Mueller BRDF, row-major (m_ij: row i, column j), in the basis of the convention; m00 is the unpolarised BRDF"
        );
    }
    u
}
