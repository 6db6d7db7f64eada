//! The CSV tables and JSON rows the subcommands write (docs/cli.md "Output columns").
//!
//! Files keep full precision: values in the shortest form that reads back to the same
//! number (`{:e}`), angles exactly as they were given ([`crate::parse::deg`]). An
//! undefined value (no specular reference, no standard error) is an empty cell in CSV
//! and `null` in JSON.

use std::io::Write;

use flakescatter::compare::IncidenceComparison;
use flakescatter::stats::segment::SegmentedFlake;
use flakescatter::{Curves, DetectorSet, Instrument};
use serde_json::{Value, json};

use rayon::prelude::*;

use crate::parse::{deg, deg_num, shortest};

/// Rows per block of the curve CSV, formatted on one thread.
const CSV_BLOCK: usize = 4096;
/// Rows formatted before they are written (so that a large table is never held whole).
const CSV_WAVE: usize = 16 * CSV_BLOCK;

pub use crate::number::num;
use crate::number::push_num_bytes;

/// Detector coordinates for output: `(θs, φ = 0)` in plane (the side is the sign of
/// θs), `(θr, φr)` out of plane; radians.
pub fn detector_rad(instrument: &Instrument, j: usize) -> (f64, f64) {
    match instrument.detectors() {
        DetectorSet::InPlane(ts) => (ts[j], 0.0),
        DetectorSet::OutOfPlane(d) => d[j],
    }
}

fn csv_error(e: csv::Error) -> anyhow::Error {
    let msg = e.to_string();
    match e.into_kind() {
        csv::ErrorKind::Io(io) => io.into(),
        _ => anyhow::anyhow!("CSV: {msg}"),
    }
}

/// Writes the curve CSV of cli.md (`theta_i_deg, theta_s_deg, phi_s_deg, aperture_deg,
/// brdf_per_sr, reflectance, relative`, plus `rays, std_err` when `topo_columns`).
pub fn write_curves(
    out: &mut dyn Write,
    curves: &Curves,
    topo_columns: bool,
) -> anyhow::Result<()> {
    write_curves_with(out, curves, topo_columns, &[], |_| Vec::new())
}

/// [`write_curves`] with more columns after the standard ones: `extra_header`, and
/// `extra(k)` for the cells of row `k`.
pub fn write_curves_with(
    out: &mut dyn Write,
    curves: &Curves,
    topo_columns: bool,
    extra_header: &[String],
    extra: impl Fn(usize) -> Vec<String> + Sync,
) -> anyhow::Result<()> {
    let mut header = vec![
        "theta_i_deg",
        "theta_s_deg",
        "phi_s_deg",
        "aperture_deg",
        "brdf_per_sr",
        "reflectance",
        "relative",
    ];
    if topo_columns {
        header.extend(["rays", "std_err"]);
    }
    header.extend(extra_header.iter().map(String::as_str));
    // Rows are built in one byte buffer and handed to `out` in blocks: the numbers never
    // need CSV quoting (digits, `-`, `.`, `e`), the header and the extra cells go
    // through `push_field`, which quotes as the csv crate does elsewhere in the CLI.
    let mut buf: Vec<u8> = Vec::with_capacity(1 << 17);
    for (i, name) in header.iter().enumerate() {
        if i > 0 {
            buf.push(b',');
        }
        push_field(&mut buf, name);
    }
    buf.push(b'\n');
    // Angles are written as given (`deg`, which tries precisions until one reads back):
    // computed once per incidence and per detector, not per row.
    let aperture = deg(curves.instrument.aperture());
    let detectors: Vec<String> = (0..curves.instrument.detectors().len())
        .map(|j| {
            let (ts, ps) = detector_rad(&curves.instrument, j);
            format!("{},{},{aperture},", deg(ts), deg(ps))
        })
        .collect();
    // Rows are formatted in blocks on all threads, a few blocks at a time, and written
    // in order: the bytes are those of one sequential pass.
    let format_block = |first: usize, rows: &[flakescatter::CurveRow], buf: &mut Vec<u8>| {
        buf.clear();
        let mut incidence = (f64::NAN, String::new());
        for (i, row) in rows.iter().enumerate() {
            if row.theta_i.to_bits() != incidence.0.to_bits() {
                incidence = (row.theta_i, deg(row.theta_i) + ",");
            }
            buf.extend_from_slice(incidence.1.as_bytes());
            buf.extend_from_slice(detectors[row.detector].as_bytes());
            push_num_bytes(buf, row.brdf);
            buf.push(b',');
            if let Some(v) = row.reflectance {
                push_num_bytes(buf, v);
            }
            buf.push(b',');
            push_num_bytes(buf, row.relative);
            if topo_columns {
                buf.push(b',');
                if let Some(r) = row.rays {
                    let _ = write!(buf, "{r}");
                }
                buf.push(b',');
                if let Some(e) = row.std_err {
                    push_num_bytes(buf, e);
                }
            }
            for text in extra(first + i) {
                buf.push(b',');
                push_field(buf, &text);
            }
            buf.push(b'\n');
        }
    };
    out.write_all(&buf)?;
    // One buffer per block of a wave, kept from wave to wave: each is allocated (and its
    // pages touched) once, not once per block.
    let mut blocks: Vec<Vec<u8>> = vec![Vec::new(); CSV_WAVE / CSV_BLOCK];
    for (w, wave) in curves.rows.chunks(CSV_WAVE).enumerate() {
        let used = wave.len().div_ceil(CSV_BLOCK);
        wave.par_chunks(CSV_BLOCK)
            .zip(blocks[..used].par_iter_mut())
            .enumerate()
            .for_each(|(b, (rows, buf))| format_block(w * CSV_WAVE + b * CSV_BLOCK, rows, buf));
        for b in &blocks[..used] {
            out.write_all(b)?;
        }
    }
    out.flush()?;
    Ok(())
}

/// Appends one CSV field, quoted (RFC 4180, inner quotes doubled) when it holds a
/// comma, a quote or a line break.
fn push_field(buf: &mut Vec<u8>, text: &str) {
    if text
        .bytes()
        .any(|c| matches!(c, b',' | b'"' | b'\n' | b'\r'))
    {
        buf.push(b'"');
        for c in text.bytes() {
            if c == b'"' {
                buf.push(b'"');
            }
            buf.push(c);
        }
        buf.push(b'"');
    } else {
        buf.extend_from_slice(text.as_bytes());
    }
}

/// Rows as JSON objects with unit-suffixed keys (undefined values are `null`).
pub fn rows_json(curves: &Curves) -> Value {
    // Serialising plain numbers and `null`s into a `Value` cannot fail.
    serde_json::to_value(RowsJson(curves)).unwrap_or(Value::Null)
}

/// The rows of [`rows_json`] as a serde sequence, written straight to a serializer
/// (the `--json` output of a large grid) without building a `Value` per row. Keys come
/// in the sorted order that a `serde_json` map has, so both give the same text.
pub struct RowsJson<'a>(pub &'a Curves);

impl serde::Serialize for RowsJson<'_> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let curves = self.0;
        let aperture = deg_num(curves.instrument.aperture());
        let finite = |x: f64| x.is_finite().then_some(x);
        // Angles as given, once per detector and per incidence (as in `write_curves_with`).
        let detectors: Vec<(f64, f64)> = (0..curves.instrument.detectors().len())
            .map(|j| {
                let (ts, ps) = detector_rad(&curves.instrument, j);
                (deg_num(ts), deg_num(ps))
            })
            .collect();
        let mut incidence = (f64::NAN, 0.0);
        let mut seq = serializer.serialize_seq(Some(curves.rows.len()))?;
        for row in &curves.rows {
            if row.theta_i.to_bits() != incidence.0.to_bits() {
                incidence = (row.theta_i, deg_num(row.theta_i));
            }
            let (ts, ps) = detectors[row.detector];
            seq.serialize_element(&RowJson {
                aperture,
                brdf: finite(row.brdf),
                phi_s: ps,
                rays: row.rays,
                reflectance: row.reflectance.and_then(finite),
                relative: finite(row.relative),
                std_err: row.std_err.and_then(finite),
                theta_i: incidence.1,
                theta_s: ts,
            })?;
        }
        seq.end()
    }
}

/// One row of [`RowsJson`].
struct RowJson {
    aperture: f64,
    brdf: Option<f64>,
    phi_s: f64,
    rays: Option<u64>,
    reflectance: Option<f64>,
    relative: Option<f64>,
    std_err: Option<f64>,
    theta_i: f64,
    theta_s: f64,
}

impl serde::Serialize for RowJson {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = serializer.serialize_map(Some(9))?;
        m.serialize_entry("aperture_deg", &self.aperture)?;
        m.serialize_entry("brdf_per_sr", &self.brdf)?;
        m.serialize_entry("phi_s_deg", &self.phi_s)?;
        m.serialize_entry("rays", &self.rays)?;
        m.serialize_entry("reflectance", &self.reflectance)?;
        m.serialize_entry("relative", &self.relative)?;
        m.serialize_entry("std_err", &self.std_err)?;
        m.serialize_entry("theta_i_deg", &self.theta_i)?;
        m.serialize_entry("theta_s_deg", &self.theta_s)?;
        m.end()
    }
}

/// Units of the curve columns, for JSON metadata.
pub fn units_json() -> Value {
    json!({
        "theta_i_deg": "degree, incidence angle from the coating normal",
        "theta_s_deg": "degree, signed in-plane detector angle (theta_s = -theta_i is specular); theta_r for out-of-plane detectors",
        "phi_s_deg": "degree, detector azimuth (0 = specular half-plane); 0 for in-plane detectors",
        "aperture_deg": "degree, detector cone half-angle",
        "brdf_per_sr": "1/sr, BRDF averaged over the detector cone (point BRDF for aperture 0)",
        "reflectance": "fraction of the incident beam power collected by the detector",
        "relative": "collected power relative to the same detector at the specular direction",
    })
}

/// Warnings for undefined values in curves: per incidence whose `relative` is undefined
/// (the specular detector collects nothing), and once for rows without a standard
/// error. Returns the warnings (printed by the caller, also put in JSON).
pub fn curve_warnings(curves: &Curves, std_err_expected: bool) -> Vec<String> {
    let mut out = Vec::new();
    let mut seen: Vec<f64> = Vec::new();
    for row in curves.rows.iter().filter(|r| !r.relative.is_finite()) {
        if !seen.contains(&row.theta_i) {
            seen.push(row.theta_i);
            out.push(format!(
                "theta_i {}°: the detector at the specular direction collects nothing, so `relative` is undefined (empty in the CSV, null in JSON)",
                deg(row.theta_i)
            ));
        }
    }
    if std_err_expected {
        let missing = curves
            .rows
            .iter()
            .filter(|r| !r.std_err.is_some_and(f64::is_finite))
            .count();
        if missing > 0 {
            out.push(format!(
                "{missing} of {} rows have no standard error (no ray reached the detector, or too few map tiles to estimate one); their std_err cells are empty",
                curves.rows.len()
            ));
        }
    }
    out
}

/// Columns of the flake table written by `segment` (the first eight are the flake-table
/// "normals" set with centre and angles, readable by `stats --flakes`; the last two say
/// which map a flake is on and its number there, the label of the overlays).
pub const FLAKE_COLUMNS: [&str; 18] = [
    "x_um",
    "y_um",
    "nx",
    "ny",
    "nz",
    "area_um2",
    "theta_n_deg",
    "phi_n_deg",
    "projected_area_um2",
    "equivalent_diameter_um",
    "rms_um",
    "tilt_se_deg",
    "pixels",
    "inliers",
    "touches_border",
    "quality",
    "map",
    "flake",
];

/// Writes the flake table (header [`FLAKE_COLUMNS`]) of several maps: `(map name, its
/// flakes)`, flakes numbered from 1 on each map.
pub fn write_flakes(
    out: &mut dyn Write,
    maps: &[(String, &[SegmentedFlake])],
) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(FLAKE_COLUMNS).map_err(csv_error)?;
    for (name, flakes) in maps {
        for (k, f) in flakes.iter().enumerate() {
            write_flake_row(&mut w, f, name, k + 1)?;
        }
    }
    w.flush()?;
    Ok(())
}

fn write_flake_row<W: Write>(
    w: &mut csv::Writer<W>,
    f: &SegmentedFlake,
    map: &str,
    id: usize,
) -> anyhow::Result<()> {
    {
        let row = [
            shortest(f.centre_um[0]),
            shortest(f.centre_um[1]),
            shortest(f.normal.x),
            shortest(f.normal.y),
            shortest(f.normal.z),
            shortest(f.area_um2),
            shortest(f.theta_n.to_degrees()),
            shortest(f.phi_n.to_degrees()),
            shortest(f.projected_area_um2),
            shortest(f.equivalent_diameter_um),
            shortest(f.rms_um),
            shortest(f.tilt_se.to_degrees()),
            f.pixels.to_string(),
            f.inliers.to_string(),
            f.touches_border.to_string(),
            shortest(f.quality),
            map.to_owned(),
            id.to_string(),
        ];
        w.write_record(&row).map_err(csv_error)?;
    }
    Ok(())
}

/// Writes `compare --out`: one row per measured point.
pub fn write_compared(out: &mut dyn Write, results: &[IncidenceComparison]) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record([
        "theta_i_deg",
        "theta_s_deg",
        "region",
        "measured",
        "model",
        "residual_log10",
    ])
    .map_err(csv_error)?;
    for c in results {
        for p in &c.points {
            w.write_record([
                deg(p.theta_i),
                deg(p.theta_s),
                p.region.name().to_string(),
                num(p.measured),
                num(p.model),
                num(p.residual),
            ])
            .map_err(csv_error)?;
        }
    }
    w.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{RowJson, push_field};

    /// `push_field` against the csv crate (an independent writer) on fields that need
    /// quoting and fields that do not.
    #[test]
    fn fields_are_quoted_as_the_csv_crate_quotes_them() {
        let fields = [
            "m11",
            "",
            "a,b",
            "say \"hi\"",
            "two\nlines",
            "cr\rhere",
            "1.5e-3",
        ];
        let mut ours = Vec::new();
        for (i, f) in fields.iter().enumerate() {
            if i > 0 {
                ours.push(b',');
            }
            push_field(&mut ours, f);
        }
        ours.push(b'\n');
        let mut theirs = csv::Writer::from_writer(Vec::new());
        theirs.write_record(fields).unwrap();
        assert_eq!(
            String::from_utf8(ours).unwrap(),
            String::from_utf8(theirs.into_inner().unwrap()).unwrap()
        );
    }

    /// A streamed row writes its keys in the order of a `serde_json` map (sorted), so
    /// that the streamed `--json` output is the text a `Value` tree gives: the row, read
    /// back into a `Value` (which sorts its keys) and written again, is the same text.
    #[test]
    fn streamed_rows_have_the_key_order_of_a_json_map() {
        let row = RowJson {
            aperture: 1.5,
            brdf: Some(2.5e-3),
            phi_s: 0.0,
            rays: Some(12),
            reflectance: None,
            relative: Some(1.0),
            std_err: None,
            theta_i: 45.0,
            theta_s: -44.9,
        };
        let text = serde_json::to_string_pretty(&row).unwrap();
        let value: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(serde_json::to_string_pretty(&value).unwrap(), text);
        assert_eq!(value.as_object().unwrap().len(), 9);
    }
}
