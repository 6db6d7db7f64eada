//! Instrument flags shared by `model`, `topo`, `compare` and `fit` (cli.md), angle-list
//! parsing, and the CSV / JSON writers of curve results.
//!
//! Degrees on the command line and in files; radians from here on.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::io::detectors::read_detectors;
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::polarization::{Transmission, Weighting};
use flakescatter::{Coating, Curves, DetectorSet, Instrument, Settings};
use serde_json::{Value, json};

use crate::common::Failure;

/// Instrument and coating flags (cli.md "Instrument flags").
#[derive(Debug, Clone, clap::Args)]
pub struct InstrumentArgs {
    /// Clear-coat refractive index (real, >= 1).
    #[arg(
        long = "n",
        value_name = "X",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub n: f64,
    /// Incidence angles in degrees, in [0, 90): a list `0,30,60`, an inclusive range
    /// `start:stop:step`, or both comma-separated.
    #[arg(
        long,
        value_name = "LIST",
        default_value = "0,30,45,60,75",
        allow_hyphen_values = true
    )]
    pub theta_i: String,
    /// Signed in-plane detector angles in degrees, in (-90, 90); `theta_s = -theta_i` is
    /// the specular direction, positive angles are on the source side.
    #[arg(
        long,
        value_name = "LIST",
        default_value = "-70:70:0.5",
        allow_hyphen_values = true
    )]
    pub theta_s: String,
    /// Detector cone half-angle in degrees, in [0, 20]; 0 = point detectors.
    #[arg(
        long,
        value_name = "A",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub aperture: f64,
    /// Out-of-plane detectors: CSV with header `theta_r_deg,phi_r_deg` (phi_r = 0 is the
    /// specular half-plane); replaces --theta-s.
    #[arg(long, value_name = "FILE")]
    pub detectors: Option<PathBuf>,
    /// Fresnel bookkeeping: exact-unpolarized, paper (T_av at each crossing, eq. 10), s
    /// or p (polarised beam).
    #[arg(long, value_name = "K", default_value = "exact-unpolarized")]
    pub transmission: Transmission,
    /// Ray weighting: physical, or paper-printed (the printed eqs. 9/13/14; breaks
    /// energy conservation, for reproducing the paper's shapes only).
    #[arg(long, value_name = "K", default_value = "physical")]
    pub weighting: Weighting,
    /// Add the clear coat's own specular reflection (physics.md §6).
    #[arg(long)]
    pub clearcoat: bool,
    /// Complex flake index `N,K` (e.g. `0.96,6.69` for aluminium at 550 nm); default a
    /// perfect conductor, as in the paper.
    #[arg(long, value_name = "N,K")]
    pub flake_index: Option<String>,
}

impl InstrumentArgs {
    /// The coating these flags describe.
    pub fn coating(&self) -> anyhow::Result<Coating> {
        if !(self.n.is_finite() && self.n >= 1.0) {
            bail!(
                "--n {}: the refractive index must be a real number >= 1",
                self.n
            );
        }
        let flake = match &self.flake_index {
            None => FlakeReflectance::PerfectConductor,
            Some(s) => {
                let parts: Vec<&str> = s.split(',').map(str::trim).collect();
                let parsed: Option<Vec<f64>> = parts.iter().map(|p| p.parse().ok()).collect();
                match parsed.as_deref() {
                    Some([n, k]) => FlakeReflectance::complex(*n, *k)
                        .with_context(|| format!("--flake-index {s}"))?,
                    _ => bail!("--flake-index {s}: expected two numbers `N,K`, e.g. 0.96,6.69"),
                }
            }
        };
        Ok(Coating { n: self.n, flake })
    }

    /// The model settings these flags describe.
    pub fn settings(&self) -> Settings {
        Settings {
            transmission: self.transmission,
            weighting: self.weighting,
            clearcoat: self.clearcoat,
            ..Settings::default()
        }
    }

    /// The detector half-angle in radians, checked to be in `[0, 20°]`.
    pub fn aperture_rad(&self) -> anyhow::Result<f64> {
        if !(self.aperture.is_finite() && (0.0..=20.0).contains(&self.aperture)) {
            bail!(
                "--aperture {}: expected a half-angle in [0, 20] degrees",
                self.aperture
            );
        }
        Ok(self.aperture.to_radians())
    }

    /// The instrument these flags describe (angles converted to radians).
    pub fn instrument(&self) -> anyhow::Result<Instrument> {
        let theta_i = parse_angles("--theta-i", &self.theta_i)?;
        for &t in &theta_i {
            if !(0.0..90.0).contains(&t) {
                bail!("--theta-i: {t}° is outside [0, 90)");
            }
        }
        let aperture = self.aperture_rad()?;
        let detectors = match &self.detectors {
            Some(path) => DetectorSet::OutOfPlane(
                read_detectors(path)
                    .with_context(|| format!("--detectors {}", path.display()))?
                    .into_iter()
                    .map(|d| (d.theta_r, d.phi_r))
                    .collect(),
            ),
            None => {
                let ts = parse_angles("--theta-s", &self.theta_s)?;
                for &t in &ts {
                    if !(t > -90.0 && t < 90.0) {
                        bail!("--theta-s: {t}° is outside (-90, 90)");
                    }
                }
                DetectorSet::InPlane(ts.into_iter().map(f64::to_radians).collect())
            }
        };
        Ok(Instrument::new(
            theta_i.into_iter().map(f64::to_radians).collect(),
            detectors,
            aperture,
        )?)
    }

    /// The flags echoed for JSON metadata.
    pub fn echo(&self) -> Value {
        json!({
            "n": self.n,
            "theta_i_deg": self.theta_i,
            "theta_s_deg": if self.detectors.is_some() { Value::Null } else { json!(self.theta_s) },
            "detectors_file": self.detectors.as_ref().map(|p| p.display().to_string()),
            "aperture_deg": self.aperture,
            "transmission": self.transmission.name(),
            "weighting": self.weighting.name(),
            "clearcoat": self.clearcoat,
            "flake_index": self.flake_index.clone().unwrap_or_else(|| "perfect-conductor".into()),
        })
    }
}

/// Largest number of angles a list may expand to.
const MAX_ANGLES: usize = 1_000_000;

/// Parse `0,30,60`, `-70:70:0.5` (inclusive) or a comma-separated mix, in degrees.
pub fn parse_angles(flag: &str, text: &str) -> anyhow::Result<Vec<f64>> {
    let mut out = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        if item.is_empty() {
            bail!(
                "{flag} `{text}`: empty item; expected numbers like `0,30,60` or a range `start:stop:step`"
            );
        }
        let num = |s: &str| -> anyhow::Result<f64> {
            let v: f64 = s
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("{flag} `{text}`: `{s}` is not a number"))?;
            if !v.is_finite() {
                bail!("{flag} `{text}`: `{s}` is not finite");
            }
            Ok(v)
        };
        let parts: Vec<&str> = item.split(':').collect();
        match parts.as_slice() {
            [one] => out.push(num(one)?),
            [a, b, c] => {
                let (start, stop, step) = (num(a)?, num(b)?, num(c)?);
                if step <= 0.0 {
                    bail!("{flag} `{item}`: the step must be > 0");
                }
                if stop < start {
                    bail!("{flag} `{item}`: the range is empty (stop < start)");
                }
                // Inclusive, robust to rounding: count the steps once.
                let count = ((stop - start) / step + 1e-9).floor();
                if count >= MAX_ANGLES as f64 {
                    bail!("{flag} `{item}`: more than {MAX_ANGLES} angles");
                }
                for k in 0..=(count as usize) {
                    out.push(start + step * k as f64);
                }
            }
            _ => bail!("{flag} `{item}`: expected a number or `start:stop:step`"),
        }
        if out.len() > MAX_ANGLES {
            bail!("{flag}: more than {MAX_ANGLES} angles");
        }
    }
    Ok(out)
}

/// Detector coordinates in degrees for output: `(θs, φ=0)` in plane (`φ = 0` or 180
/// is encoded in the sign of θs), `(θr, φr)` out of plane.
pub fn detector_deg(instrument: &Instrument, j: usize) -> (f64, f64) {
    match instrument.detectors() {
        DetectorSet::InPlane(ts) => (ts[j].to_degrees(), 0.0),
        DetectorSet::OutOfPlane(d) => (d[j].0.to_degrees(), d[j].1.to_degrees()),
    }
}

/// Write the curve CSV of cli.md (`theta_i_deg, theta_s_deg, phi_s_deg, aperture_deg,
/// brdf_per_sr, reflectance, relative`, plus `rays, std_err` when `topo_columns`).
pub fn write_curves_csv(
    out: &mut dyn Write,
    curves: &Curves,
    topo_columns: bool,
) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(out);
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
    w.write_record(&header).map_err(fail)?;
    let aperture = curves.instrument.aperture().to_degrees();
    for row in &curves.rows {
        let (ts, ps) = detector_deg(&curves.instrument, row.detector);
        let mut rec = vec![
            fmt(row.theta_i.to_degrees()),
            fmt(ts),
            fmt(ps),
            fmt(aperture),
            format!("{:.9e}", row.brdf),
            row.reflectance
                .map(|r| format!("{r:.9e}"))
                .unwrap_or_default(),
            // Undefined (the specular detector collects nothing): an empty cell.
            if row.relative.is_finite() {
                format!("{:.9e}", row.relative)
            } else {
                String::new()
            },
        ];
        if topo_columns {
            rec.push(row.rays.map(|r| r.to_string()).unwrap_or_default());
            rec.push(row.std_err.map(|e| format!("{e:.3e}")).unwrap_or_default());
        }
        w.write_record(&rec).map_err(fail)?;
    }
    w.flush()
        .map_err(|e| anyhow::Error::new(Failure(format!("writing CSV: {e}"))))?;
    Ok(())
}

/// Warn on stderr for each incidence whose `relative` values are undefined because the
/// same-aperture detector at the specular direction collects nothing.
pub fn warn_undefined_relative(curves: &Curves) {
    let mut seen: Vec<f64> = Vec::new();
    for row in curves.rows.iter().filter(|r| !r.relative.is_finite()) {
        if !seen.contains(&row.theta_i) {
            seen.push(row.theta_i);
            eprintln!(
                "warning: theta_i {}°: the detector at the specular direction collects nothing, so `relative` is undefined (empty in the CSV, null in JSON)",
                round(row.theta_i.to_degrees())
            );
        }
    }
}

/// Rows as JSON objects with unit-suffixed keys.
pub fn rows_json(curves: &Curves) -> Value {
    let aperture = curves.instrument.aperture().to_degrees();
    Value::Array(
        curves
            .rows
            .iter()
            .map(|row| {
                let (ts, ps) = detector_deg(&curves.instrument, row.detector);
                json!({
                    "theta_i_deg": round(row.theta_i.to_degrees()),
                    "theta_s_deg": round(ts),
                    "phi_s_deg": round(ps),
                    "aperture_deg": round(aperture),
                    "brdf_per_sr": row.brdf,
                    "reflectance": row.reflectance,
                    "relative": row.relative,
                    "rays": row.rays,
                    "std_err": row.std_err,
                })
            })
            .collect(),
    )
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

/// Angles print without float noise (`-69.5`, not `-69.50000000000001`).
fn fmt(x: f64) -> String {
    let r = round(x);
    if r == 0.0 { "0".into() } else { format!("{r}") }
}

fn round(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

fn fail(e: csv::Error) -> anyhow::Error {
    anyhow::Error::new(Failure(format!("writing CSV: {e}")))
}

/// Whether a subcommand's table goes to stdout: `--out -`, or no `--out` and no
/// `--json`. Both the table and the JSON summary on stdout is a usage error.
pub fn table_to_stdout(out: Option<&Path>, json: bool) -> anyhow::Result<bool> {
    Ok(out_is_stdout(out, json)? || (out.is_none() && !json))
}

/// Whether `--out` is `-` (stdout); `--out -` together with `--json` is a usage error
/// (both would write to stdout).
pub fn out_is_stdout(out: Option<&Path>, json: bool) -> anyhow::Result<bool> {
    let to_stdout = out.is_some_and(|p| p.as_os_str() == "-");
    if to_stdout && json {
        bail!("--out - and --json both write to stdout: give --out a file name");
    }
    Ok(to_stdout)
}

/// The writer for a subcommand's table and its name for messages: stdout when
/// `to_stdout` (from [`table_to_stdout`]), else the `--out` file, else none.
pub fn table_writer(
    out: Option<&Path>,
    to_stdout: bool,
) -> anyhow::Result<Option<(Box<dyn Write>, String)>> {
    if to_stdout {
        return Ok(Some((Box::new(std::io::stdout().lock()), "stdout".into())));
    }
    match out {
        Some(path) => Ok(Some((open_out(path)?, path.display().to_string()))),
        None => Ok(None),
    }
}

/// Open `--out` (`-` = stdout) for writing; failures are not the user's fault (exit 1).
pub fn open_out(path: &Path) -> anyhow::Result<Box<dyn Write>> {
    if path.as_os_str() == "-" {
        return Ok(Box::new(std::io::stdout().lock()));
    }
    let f = std::fs::File::create(path).map_err(|e| {
        anyhow::Error::new(Failure(format!(
            "cannot write --out {}: {e}",
            path.display()
        )))
    })?;
    Ok(Box::new(std::io::BufWriter::new(f)))
}
