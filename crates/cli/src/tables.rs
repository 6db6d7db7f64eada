//! The CSV tables and JSON rows the subcommands write (docs/cli.md "Output columns").
//!
//! Files keep full precision: values in the shortest form that reads back to the same
//! number (`{:e}`), angles exactly as they were given ([`crate::parse::deg`]). An
//! undefined value (no specular reference, no standard error) is an empty cell in CSV
//! and `null` in JSON.

use std::io::Write;

use flakescatter::compare::IncidenceComparison;
use flakescatter::stats::segment::SegmentedFlake;
use flakescatter::{CurveRow, Curves, DetectorSet, Instrument};
use serde_json::{Value, json};

use rayon::prelude::*;

use crate::parse::{deg, deg_num};

/// Rows per block of a curve table, formatted on one thread.
const BLOCK: usize = 4096;
/// Most rows formatted before they are written (so that a large table is never held
/// whole): [`wave_rows`] is at most this.
const MAX_WAVE: usize = 16 * BLOCK;

/// Rows formatted at a time, then written: two blocks per thread (one per thread
/// leaves a thread idle whenever its block ends first: the 304,551-row grid took 56 ms
/// with 2 blocks a wave on 2 threads, 35 ms with 4, 38 ms with 8 or 16, which also hold
/// more), at least 4 and at most 16 blocks.
fn wave_rows() -> usize {
    BLOCK * (2 * rayon::current_num_threads()).clamp(4, MAX_WAVE / BLOCK)
}

pub use crate::number::num;
use crate::number::{push_json_num, push_num_bytes};

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

/// The text of a curve table: the CSV ([`CsvText`]) or the JSON array of rows
/// ([`JsonText`]), written by a [`TableWriter`].
pub trait TableText: Sync {
    /// What comes before the first row (the CSV header, the `[` of the array).
    fn head(&self, out: &mut Vec<u8>);
    /// Appends the text of `rows`, the first of which is row `first` of the table.
    fn rows(&self, first: usize, rows: &[CurveRow], out: &mut Vec<u8>);
    /// What follows the last row of a table of `count` rows.
    fn tail(&self, count: usize, out: &mut Vec<u8>);
}

/// A curve table written as its rows come ([`TableWriter::push`], e.g. one incidence at
/// a time from [`flakescatter::distribution_rows`]): they are formatted in blocks on all
/// threads a wave at a time, and the waves written in order, so the bytes are those of
/// one sequential pass for any number of threads and however the rows are handed in,
/// and neither all rows nor all text are ever held. Nothing reaches `out` before the
/// first wave (or [`TableWriter::finish`]), so an error before the first rows leaves it
/// untouched.
pub struct TableWriter<'w, T> {
    out: &'w mut dyn Write,
    text: T,
    /// The head, until it is written with the first wave.
    head: Option<Vec<u8>>,
    /// Rows of a wave.
    wave: usize,
    /// Rows handed in and not yet formatted (less than a wave).
    pending: Vec<CurveRow>,
    /// Rows formatted so far.
    done: usize,
    /// One buffer per block of a wave, kept from wave to wave: each is allocated (and its
    /// pages touched) once, not once per block.
    blocks: Vec<Vec<u8>>,
}

impl<'w, T: TableText> TableWriter<'w, T> {
    /// A table of `text` to be written to `out`.
    pub fn new(out: &'w mut dyn Write, text: T) -> Self {
        let mut head = Vec::new();
        text.head(&mut head);
        let wave = wave_rows();
        Self {
            out,
            text,
            head: Some(head),
            wave,
            pending: Vec::new(),
            done: 0,
            blocks: vec![Vec::new(); wave / BLOCK],
        }
    }

    /// The next rows of the table.
    ///
    /// # Errors
    /// Those of `out`.
    pub fn push(&mut self, mut rows: &[CurveRow]) -> std::io::Result<()> {
        while !rows.is_empty() {
            if self.pending.is_empty() && rows.len() >= self.wave {
                let (wave, rest) = rows.split_at(self.wave);
                self.wave(wave)?;
                rows = rest;
                continue;
            }
            let take = (self.wave - self.pending.len()).min(rows.len());
            if self.pending.capacity() == 0 {
                self.pending.reserve_exact(self.wave);
            }
            self.pending.extend_from_slice(&rows[..take]);
            rows = &rows[take..];
            if self.pending.len() == self.wave {
                let pending = std::mem::take(&mut self.pending);
                self.wave(&pending)?;
                self.pending = pending;
                self.pending.clear();
            }
        }
        Ok(())
    }

    /// Writes the rows still held and the tail, and flushes `out`.
    ///
    /// # Errors
    /// Those of `out`.
    pub fn finish(mut self) -> std::io::Result<()> {
        let pending = std::mem::take(&mut self.pending);
        self.wave(&pending)?;
        let mut tail = Vec::new();
        self.text.tail(self.done, &mut tail);
        self.out.write_all(&tail)?;
        self.out.flush()
    }

    /// Formats `rows` (at most a wave) in blocks on all threads and writes them, after
    /// the head if it is still held.
    fn wave(&mut self, rows: &[CurveRow]) -> std::io::Result<()> {
        let used = rows.len().div_ceil(BLOCK);
        let (text, first) = (&self.text, self.done);
        rows.par_chunks(BLOCK)
            .zip(self.blocks[..used].par_iter_mut())
            .enumerate()
            .for_each(|(b, (rows, buf))| {
                buf.clear();
                text.rows(first + b * BLOCK, rows, buf);
            });
        if let Some(head) = self.head.take() {
            self.out.write_all(&head)?;
        }
        for b in &self.blocks[..used] {
            self.out.write_all(b)?;
        }
        self.done += rows.len();
        Ok(())
    }
}

/// The curve CSV of cli.md (`theta_i_deg, theta_s_deg, phi_s_deg, aperture_deg,
/// brdf_per_sr, reflectance, relative`, plus `rays, std_err` when `topo_columns`), with
/// more columns after the standard ones: `extra_header`, and `extra(k)` for the cells of
/// row `k`.
pub struct CsvText<X> {
    header: Vec<String>,
    /// `theta_s,phi_s,aperture,` of each detector, angles as given.
    detectors: Vec<String>,
    topo_columns: bool,
    extra: X,
}

impl<X: Fn(usize) -> Vec<String> + Sync> CsvText<X> {
    /// The CSV of the curves of `instrument`.
    pub fn new(
        instrument: &Instrument,
        topo_columns: bool,
        extra_header: &[String],
        extra: X,
    ) -> Self {
        let mut header: Vec<String> = [
            "theta_i_deg",
            "theta_s_deg",
            "phi_s_deg",
            "aperture_deg",
            "brdf_per_sr",
            "reflectance",
            "relative",
        ]
        .map(String::from)
        .to_vec();
        if topo_columns {
            header.extend(["rays".into(), "std_err".into()]);
        }
        header.extend_from_slice(extra_header);
        // Angles are written as given (`deg`, which tries precisions until one reads
        // back): computed once per detector (and per incidence), not per row.
        let aperture = deg(instrument.aperture());
        let detectors = (0..instrument.detectors().len())
            .map(|j| {
                let (ts, ps) = detector_rad(instrument, j);
                format!("{},{},{aperture},", deg(ts), deg(ps))
            })
            .collect();
        Self {
            header,
            detectors,
            topo_columns,
            extra,
        }
    }
}

impl<X: Fn(usize) -> Vec<String> + Sync> TableText for CsvText<X> {
    fn head(&self, out: &mut Vec<u8>) {
        for (i, name) in self.header.iter().enumerate() {
            if i > 0 {
                out.push(b',');
            }
            push_field(out, name);
        }
        out.push(b'\n');
    }

    // The numbers never need CSV quoting (digits, `-`, `.`, `e`); the header and the
    // extra cells go through `push_field`, which quotes as the csv crate does elsewhere
    // in the CLI.
    fn rows(&self, first: usize, rows: &[CurveRow], buf: &mut Vec<u8>) {
        let mut incidence = (f64::NAN, String::new());
        for (i, row) in rows.iter().enumerate() {
            if row.theta_i.to_bits() != incidence.0.to_bits() {
                incidence = (row.theta_i, deg(row.theta_i) + ",");
            }
            buf.extend_from_slice(incidence.1.as_bytes());
            buf.extend_from_slice(self.detectors[row.detector].as_bytes());
            push_num_bytes(buf, row.brdf);
            buf.push(b',');
            if let Some(v) = row.reflectance {
                push_num_bytes(buf, v);
            }
            buf.push(b',');
            push_num_bytes(buf, row.relative);
            if self.topo_columns {
                buf.push(b',');
                if let Some(r) = row.rays {
                    let _ = write!(buf, "{r}");
                }
                buf.push(b',');
                if let Some(e) = row.std_err {
                    push_num_bytes(buf, e);
                }
            }
            for text in (self.extra)(first + i) {
                buf.push(b',');
                push_field(buf, &text);
            }
            buf.push(b'\n');
        }
    }

    fn tail(&self, _count: usize, _out: &mut Vec<u8>) {}
}

/// No extra CSV columns.
pub fn no_extra(_: usize) -> Vec<String> {
    Vec::new()
}

/// Writes the curve CSV ([`CsvText`] without extra columns).
pub fn write_curves(
    out: &mut dyn Write,
    curves: &Curves,
    topo_columns: bool,
) -> anyhow::Result<()> {
    write_curves_with(out, curves, topo_columns, &[], no_extra)
}

/// Writes the curve CSV with extra columns ([`CsvText`]).
pub fn write_curves_with(
    out: &mut dyn Write,
    curves: &Curves,
    topo_columns: bool,
    extra_header: &[String],
    extra: impl Fn(usize) -> Vec<String> + Sync,
) -> anyhow::Result<()> {
    let text = CsvText::new(&curves.instrument, topo_columns, extra_header, extra);
    let mut table = TableWriter::new(out, text);
    table.push(&curves.rows)?;
    Ok(table.finish()?)
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
    let aperture = deg_num(curves.instrument.aperture());
    let finite = |x: f64| x.is_finite().then_some(x);
    // Angles as given, once per detector and per incidence (as in `CsvText`).
    let detectors: Vec<(f64, f64)> = (0..curves.instrument.detectors().len())
        .map(|j| {
            let (ts, ps) = detector_rad(&curves.instrument, j);
            (deg_num(ts), deg_num(ps))
        })
        .collect();
    let mut incidence = (f64::NAN, 0.0);
    let rows = curves.rows.iter().map(|row| {
        if row.theta_i.to_bits() != incidence.0.to_bits() {
            incidence = (row.theta_i, deg_num(row.theta_i));
        }
        let (ts, ps) = detectors[row.detector];
        json!({
            "theta_i_deg": incidence.1,
            "theta_s_deg": ts,
            "phi_s_deg": ps,
            "aperture_deg": aperture,
            "brdf_per_sr": finite(row.brdf),
            "reflectance": row.reflectance.and_then(finite),
            "relative": finite(row.relative),
            "rays": row.rays,
            "std_err": row.std_err.and_then(finite),
        })
    });
    Value::Array(rows.collect())
}

/// The rows of [`rows_json`] as the text `serde_json` writes for them (pretty, keys in
/// the sorted order of its maps, numbers by `zmij`'s shortest digits, non-finite values
/// `null`), as the value of an entry of a top-level object: the `--json` output of a
/// large grid is written straight from the rows, never held as a `Value` tree.
pub struct JsonText {
    /// The aperture as given, a JSON number.
    aperture: Vec<u8>,
    /// `θs` and `φs` of each detector as given, JSON numbers.
    detectors: Vec<(Vec<u8>, Vec<u8>)>,
}

impl JsonText {
    /// The JSON rows of the curves of `instrument`.
    pub fn new(instrument: &Instrument) -> Self {
        let num = |x: f64| {
            let mut t = Vec::new();
            push_json_num(&mut t, Some(x));
            t
        };
        // Angles as given, once per detector (and per incidence), as in `CsvText`.
        let detectors = (0..instrument.detectors().len())
            .map(|j| {
                let (ts, ps) = detector_rad(instrument, j);
                (num(deg_num(ts)), num(deg_num(ps)))
            })
            .collect();
        Self {
            aperture: num(deg_num(instrument.aperture())),
            detectors,
        }
    }
}

impl TableText for JsonText {
    fn head(&self, out: &mut Vec<u8>) {
        out.push(b'[');
    }

    fn rows(&self, first: usize, rows: &[CurveRow], buf: &mut Vec<u8>) {
        let mut incidence = (f64::NAN, Vec::new());
        for (i, row) in rows.iter().enumerate() {
            if row.theta_i.to_bits() != incidence.0.to_bits() {
                incidence.0 = row.theta_i;
                incidence.1.clear();
                push_json_num(&mut incidence.1, Some(deg_num(row.theta_i)));
            }
            let (ts, ps) = &self.detectors[row.detector];
            let finite = |x: f64| x.is_finite().then_some(x);
            buf.extend_from_slice(if first + i == 0 { b"\n" } else { b",\n" });
            buf.extend_from_slice(b"    {\n      \"aperture_deg\": ");
            buf.extend_from_slice(&self.aperture);
            buf.extend_from_slice(b",\n      \"brdf_per_sr\": ");
            push_json_num(buf, finite(row.brdf));
            buf.extend_from_slice(b",\n      \"phi_s_deg\": ");
            buf.extend_from_slice(ps);
            buf.extend_from_slice(b",\n      \"rays\": ");
            match row.rays {
                Some(r) => {
                    let _ = write!(buf, "{r}");
                }
                None => buf.extend_from_slice(b"null"),
            }
            buf.extend_from_slice(b",\n      \"reflectance\": ");
            push_json_num(buf, row.reflectance);
            buf.extend_from_slice(b",\n      \"relative\": ");
            push_json_num(buf, Some(row.relative));
            buf.extend_from_slice(b",\n      \"std_err\": ");
            push_json_num(buf, row.std_err);
            buf.extend_from_slice(b",\n      \"theta_i_deg\": ");
            buf.extend_from_slice(&incidence.1);
            buf.extend_from_slice(b",\n      \"theta_s_deg\": ");
            buf.extend_from_slice(ts);
            buf.extend_from_slice(b"\n    }");
        }
    }

    fn tail(&self, count: usize, out: &mut Vec<u8>) {
        out.extend_from_slice(if count == 0 { b"]" } else { b"\n  ]" });
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
    let mut warnings = CurveWarnings::default();
    warnings.check(&curves.rows);
    let mut out = warnings.found;
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

/// The per-incidence warnings of [`curve_warnings`] (`relative` undefined), for rows
/// handed in a block at a time.
#[derive(Debug, Default)]
pub struct CurveWarnings {
    /// Incidences already warned about.
    seen: Vec<f64>,
    found: Vec<String>,
}

impl CurveWarnings {
    /// Checks the next rows; returns the warnings they add.
    pub fn check(&mut self, rows: &[CurveRow]) -> &[String] {
        let start = self.found.len();
        for row in rows.iter().filter(|r| !r.relative.is_finite()) {
            if !self.seen.contains(&row.theta_i) {
                self.seen.push(row.theta_i);
                self.found.push(format!(
                    "theta_i {}°: the detector at the specular direction collects nothing, so `relative` is undefined (empty in the CSV, null in JSON)",
                    deg(row.theta_i)
                ));
            }
        }
        &self.found[start..]
    }

    /// Every warning so far, in order.
    pub fn all(&self) -> &[String] {
        &self.found
    }
}

/// Writes the flake table of several maps, `(map name, its flakes)`: io's one writer
/// (columns `flakescatter::io::flakes::SEGMENTED_COLUMNS`, flakes numbered from 1 on
/// each map).
pub fn write_flakes(
    out: &mut dyn Write,
    maps: &[(String, &[SegmentedFlake])],
) -> anyhow::Result<()> {
    let maps: Vec<(&str, &[SegmentedFlake])> = maps.iter().map(|(n, f)| (n.as_str(), *f)).collect();
    flakescatter::io::flakes::write_segmented_flakes(out, "the flake table", &maps)?;
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
    use flakescatter::{CurveRow, Curves, DetectorSet, Instrument};
    use serde_json::json;

    use super::{
        CsvText, JsonText, MAX_WAVE, TableText, TableWriter, detector_rad, no_extra, num,
        push_field, rows_json, write_curves,
    };
    use crate::parse::deg;

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

    /// Curves of `n_i` incidences × `n_d` detectors whose rows hold every kind of cell:
    /// undefined values (`None`, NaN, infinite), negative zero, rays, numbers of every
    /// magnitude; angles that are not round in radians.
    fn curves(n_i: usize, n_d: usize) -> Curves {
        let theta_i: Vec<f64> = (0..n_i).map(|k| (k as f64 * 0.7).to_radians()).collect();
        let ts = (0..n_d)
            .map(|j| (-80.0 + 160.0 * j as f64 / n_d as f64).to_radians())
            .collect();
        let instrument = Instrument::new(
            theta_i.clone(),
            DetectorSet::InPlane(ts),
            1.5f64.to_radians(),
        )
        .unwrap();
        let mut rows = Vec::new();
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for &ti in &theta_i {
            for j in 0..n_d {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let x = f64::from_bits(s >> 1);
                let k = rows.len();
                rows.push(CurveRow {
                    theta_i: ti,
                    detector: j,
                    brdf: [x, f64::NAN, -0.0, 1e300 * x][k % 4],
                    reflectance: (k % 3 != 0).then_some(x * 1e-5),
                    relative: if k % 7 == 0 { f64::INFINITY } else { x / 3.0 },
                    rays: (k % 5 == 0).then_some(s >> 20),
                    std_err: (k % 2 == 0).then_some(if k % 11 == 0 { f64::NAN } else { x }),
                });
            }
        }
        Curves {
            model: "distribution",
            instrument,
            coating: flakescatter::Coating::default(),
            settings: flakescatter::Settings::default(),
            rows,
            source: String::new(),
        }
    }

    /// Writes `curves` through a `TableWriter` of `text`, the rows handed in pieces of
    /// `piece` (so that waves and blocks start mid-incidence and mid-piece).
    fn table(curves: &Curves, text: impl TableText, piece: usize) -> String {
        let mut out = Vec::new();
        let mut t = TableWriter::new(&mut out, text);
        for rows in curves.rows.chunks(piece) {
            t.push(rows).unwrap();
        }
        t.finish().unwrap();
        String::from_utf8(out).unwrap()
    }

    /// The CSV of several waves, however its rows are handed in, is the one a plain
    /// sequential writer (the csv crate, cells from `deg` and `num`) gives.
    #[test]
    fn the_csv_is_that_of_a_sequential_writer() {
        let c = curves(23, 6001);
        assert!(c.rows.len() > 2 * MAX_WAVE);
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record([
            "theta_i_deg",
            "theta_s_deg",
            "phi_s_deg",
            "aperture_deg",
            "brdf_per_sr",
            "reflectance",
            "relative",
            "rays",
            "std_err",
            "k, \"x\"",
        ])
        .unwrap();
        for (k, r) in c.rows.iter().enumerate() {
            let (ts, ps) = detector_rad(&c.instrument, r.detector);
            w.write_record([
                deg(r.theta_i),
                deg(ts),
                deg(ps),
                deg(c.instrument.aperture()),
                num(r.brdf),
                r.reflectance.map(num).unwrap_or_default(),
                num(r.relative),
                r.rays.map(|n| n.to_string()).unwrap_or_default(),
                r.std_err.map(num).unwrap_or_default(),
                format!("{k},a"),
            ])
            .unwrap();
        }
        let want = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let extra = |k: usize| vec![format!("{k},a")];
        let header = ["k, \"x\"".to_owned()];
        for piece in [1, 1000, 6001, c.rows.len()] {
            let text = CsvText::new(&c.instrument, true, &header, extra);
            assert!(table(&c, text, piece) == want, "pieces of {piece}");
        }
        // Without the topographic and extra columns.
        let text = table(&c, CsvText::new(&c.instrument, false, &[], no_extra), 777);
        let mut written = Vec::new();
        write_curves(&mut written, &c, false).unwrap();
        assert!(text.as_bytes() == written);
        assert_eq!(text.lines().count(), c.rows.len() + 1);
    }

    /// The JSON rows of several waves, however they are handed in, as the value of a
    /// top-level entry, are the text `serde_json`'s own pretty writer gives for the
    /// `Value` rows of `rows_json` (keys sorted, its number formatting, `null`s).
    #[test]
    fn the_json_rows_are_serde_jsons_text_of_the_value_rows() {
        let c = curves(23, 6001);
        assert!(c.rows.len() > 2 * MAX_WAVE);
        // Keys sorted as the JSON text writes them (serde_json keeps insertion order
        // when zarrs turns its `preserve_order` on).
        let mut want = json!({ "rows": rows_json(&c) });
        want.sort_all_objects();
        let want = serde_json::to_string_pretty(&want).unwrap();
        for piece in [1, 1000, 6001, c.rows.len()] {
            let text = table(&c, JsonText::new(&c.instrument), piece);
            assert!(
                format!("{{\n  \"rows\": {text}\n}}") == want,
                "pieces of {piece}"
            );
        }
        let empty = Curves {
            rows: Vec::new(),
            ..c
        };
        let text = table(&empty, JsonText::new(&empty.instrument), 1);
        assert_eq!(text, "[]");
    }
}
