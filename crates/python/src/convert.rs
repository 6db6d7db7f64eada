//! Conversion at the boundary: degrees to radians, keyword values to the facade's
//! types, the facade's rows to columns of numpy arrays.
//!
//! Conventions: angles arrive in degrees (as on the command line) and are converted
//! with `f64::to_radians`, the CLI's conversion, so that the same typed angles give the
//! same radians and so the same numbers. Angle columns of a result echo the degrees
//! that were given (`theta_i_deg`, `theta_s_deg`, `phi_s_deg`, `aperture_deg`). Lengths
//! are micrometres throughout. Undefined values are NaN in float columns (the CLI's
//! empty cells).

use std::path::PathBuf;

use flakescatter::io::flakes::read_histogram_from;
use flakescatter::io::measured::{MeasuredCurve, read_measured, read_measured_from};
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::polarization::{Transmission, Weighting};
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{Coating, DetectorSet, Instrument, Settings};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::errors::{Kind, input, to_py};

/// The CLI's default incidences, degrees.
pub const DEFAULT_THETA_I: [f64; 5] = [0.0, 30.0, 45.0, 60.0, 75.0];

/// The CLI's default detectors `-70:70:0.5`, degrees.
pub fn default_theta_s() -> Vec<f64> {
    (0..=280).map(|k| -70.0 + 0.5 * f64::from(k)).collect()
}

/// Largest number of incidence × detector rows (the CLI's limit).
const MAX_ROWS: f64 = 1e7;

/// A 1-D sequence of floats (list, tuple, numpy array of any real dtype) or one number.
pub fn floats(py: Python<'_>, name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    if let Ok(x) = obj.extract::<f64>() {
        return Ok(vec![x]);
    }
    let np = py.import("numpy")?;
    let arr = np.call_method1("asarray", (obj, "float64")).map_err(|_| {
        input(
            py,
            format!("{name}: expected a number or a sequence of numbers"),
        )
    })?;
    let arr: PyReadonlyArray1<'_, f64> = arr
        .extract()
        .map_err(|_| input(py, format!("{name}: expected a 1-D sequence of numbers")))?;
    Ok(arr.as_array().to_vec())
}

/// Checks that every value is finite and within `[lo, hi]` with open ends as asked;
/// the message names the parameter and the range in degrees (as the CLI's does).
pub fn check_range(
    py: Python<'_>,
    name: &str,
    values: &[f64],
    (lo, hi): (f64, f64),
    (lo_open, hi_open): (bool, bool),
) -> PyResult<()> {
    for &v in values {
        let above = if lo_open { v > lo } else { v >= lo };
        let below = if hi_open { v < hi } else { v <= hi };
        if !(v.is_finite() && above && below) {
            return Err(input(
                py,
                format!(
                    "{name}: {v}° is outside {}{lo}, {hi}{} degrees",
                    if lo_open { "(" } else { "[" },
                    if hi_open { ")" } else { "]" }
                ),
            ));
        }
    }
    Ok(())
}

/// The instrument keywords of every model: incidences, detectors, aperture (degrees).
pub struct InstrumentArgs {
    /// Incidences, degrees.
    pub theta_i: Vec<f64>,
    /// In-plane detectors, degrees (when `detectors` is `None`).
    pub theta_s: Vec<f64>,
    /// Out-of-plane detectors `(θr, φr)`, degrees.
    pub detectors: Option<Vec<(f64, f64)>>,
    /// Aperture half-angle, degrees.
    pub aperture: f64,
}

impl InstrumentArgs {
    /// Reads the keywords (`None` = the CLI's default).
    pub fn new(
        py: Python<'_>,
        theta_i: Option<&Bound<'_, PyAny>>,
        theta_s: Option<&Bound<'_, PyAny>>,
        detectors: Option<&Bound<'_, PyAny>>,
        aperture: f64,
    ) -> PyResult<Self> {
        let theta_i = match theta_i {
            Some(o) => floats(py, "theta_i", o)?,
            None => DEFAULT_THETA_I.to_vec(),
        };
        check_range(py, "theta_i", &theta_i, (0.0, 90.0), (false, true))?;
        if !(aperture.is_finite() && (0.0..=20.0).contains(&aperture)) {
            return Err(input(
                py,
                format!("aperture={aperture}: expected a half-angle in [0, 20] degrees"),
            ));
        }
        let (theta_s, detectors) = match (theta_s, detectors) {
            (Some(_), Some(_)) => {
                return Err(input(
                    py,
                    "theta_s and detectors: give one (detectors replaces theta_s)",
                ));
            }
            (_, Some(d)) => (Vec::new(), Some(detector_pairs(py, d)?)),
            (Some(o), None) => (floats(py, "theta_s", o)?, None),
            (None, None) => (default_theta_s(), None),
        };
        if detectors.is_none() {
            check_range(py, "theta_s", &theta_s, (-90.0, 90.0), (true, true))?;
        }
        let args = Self {
            theta_i,
            theta_s,
            detectors,
            aperture,
        };
        let rows = args.theta_i.len() as f64 * args.detector_count() as f64;
        if rows > MAX_ROWS {
            return Err(input(
                py,
                format!(
                    "theta_i and theta_s/detectors: {} incidences × {} detectors = {rows:e} rows is more than the limit of {MAX_ROWS:e}",
                    args.theta_i.len(),
                    args.detector_count()
                ),
            ));
        }
        Ok(args)
    }

    /// Number of detectors.
    pub fn detector_count(&self) -> usize {
        self.detectors.as_ref().map_or(self.theta_s.len(), Vec::len)
    }

    /// The facade's instrument (radians).
    pub fn instrument(&self, py: Python<'_>) -> PyResult<Instrument> {
        let set = match &self.detectors {
            Some(d) => DetectorSet::OutOfPlane(
                d.iter()
                    .map(|&(t, p)| (t.to_radians(), p.to_radians()))
                    .collect(),
            ),
            None => DetectorSet::InPlane(self.theta_s.iter().map(|t| t.to_radians()).collect()),
        };
        Instrument::new(
            self.theta_i.iter().map(|t| t.to_radians()).collect(),
            set,
            self.aperture.to_radians(),
        )
        .map_err(|e| to_py(py, Kind::Input, &e))
    }

    /// The detector coordinates of detector `j` as given: `(θs, 0)` in plane, `(θr, φr)`
    /// out of plane, degrees.
    pub fn detector_deg(&self, j: usize) -> (f64, f64) {
        match &self.detectors {
            Some(d) => d[j],
            None => (self.theta_s[j], 0.0),
        }
    }
}

/// Out-of-plane detectors: an `(m, 2)` array-like of `(theta_r_deg, phi_r_deg)`.
fn detector_pairs(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Vec<(f64, f64)>> {
    let np = py.import("numpy")?;
    let bad = || {
        input(
            py,
            "detectors: expected an (m, 2) array of (theta_r_deg, phi_r_deg) pairs",
        )
    };
    let arr = np
        .call_method1("asarray", (obj, "float64"))
        .map_err(|_| bad())?;
    let flat = arr.call_method1("reshape", (-1,)).map_err(|_| bad())?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 2 || shape[0] == 0 {
        return Err(bad());
    }
    let v: PyReadonlyArray1<'_, f64> = flat.extract().map_err(|_| bad())?;
    let v = v.as_array();
    let mut out = Vec::with_capacity(shape[0]);
    for k in 0..shape[0] {
        let (t, p) = (v[2 * k], v[2 * k + 1]);
        if !(t.is_finite() && (0.0..90.0).contains(&t)) {
            return Err(input(
                py,
                format!("detectors, row {k}: theta_r_deg {t} is outside [0, 90)"),
            ));
        }
        if !(p.is_finite() && (-360.0..=360.0).contains(&p)) {
            return Err(input(
                py,
                format!("detectors, row {k}: phi_r_deg {p} is outside [-360, 360]"),
            ));
        }
        out.push((t, p));
    }
    Ok(out)
}

/// The coating: clear-coat index `n` and the flake index `(N, K)` (perfect conductor
/// when `None`).
pub fn coating(py: Python<'_>, n: f64, flake_index: Option<(f64, f64)>) -> PyResult<Coating> {
    coating_with_stack(py, n, flake_index, None, None, None)
}

/// The coating with, instead of `flake_index`, interference flakes: `flake_stack` (a
/// stack spec, `"TiO2:120/mica:400/TiO2:120"`) at `wavelength_nm`, free in the binder
/// or on `flake_core` (physics.md §13).
pub fn coating_with_stack(
    py: Python<'_>,
    n: f64,
    flake_index: Option<(f64, f64)>,
    flake_stack: Option<&str>,
    flake_core: Option<&str>,
    wavelength_nm: Option<f64>,
) -> PyResult<Coating> {
    match (flake_stack, flake_index, wavelength_nm) {
        (None, _, None) if flake_core.is_none() => {}
        (None, _, _) => {
            return Err(input(
                py,
                "flake_core and wavelength_nm apply to flake_stack only",
            ));
        }
        (Some(_), Some(_), _) => {
            return Err(input(
                py,
                "flake_stack and flake_index: give one of them (a stack flake or a metal flake)",
            ));
        }
        (Some(_), None, None) => {
            return Err(input(
                py,
                "flake_stack needs wavelength_nm (an interference flake has no single-wavelength meaning)",
            ));
        }
        (Some(stack), None, Some(wl)) => {
            let mut c = coating_with_stack(py, n, None, None, None, None)?;
            c.flake = flakescatter::film::stack_flake(stack, flake_core, wl).map_err(|e| {
                use flakescatter::film::StackFlakeError as E;
                input(
                    py,
                    match e {
                        E::Spec(_) | E::AtWavelength(_) => format!("flake_stack: {e}"),
                        E::Core(_) => format!("flake_core: {e}"),
                        E::Wavelength(_) => e.to_string(),
                    },
                )
            })?;
            return Ok(c);
        }
    }
    let flake = match flake_index {
        None => FlakeReflectance::PerfectConductor,
        Some((nf, k)) => FlakeReflectance::complex(nf, k).map_err(|e| {
            input(
                py,
                format!("flake_index=({nf}, {k}): {}", crate::errors::message(&e)),
            )
        })?,
    };
    Coating::new(n, flake).map_err(|e| input(py, format!("n={e}")))
}

/// Model settings from the keyword names (the CLI's values).
pub fn settings(
    py: Python<'_>,
    transmission: &str,
    weighting: &str,
    clearcoat: bool,
) -> PyResult<Settings> {
    let transmission: Transmission = transmission
        .parse()
        .map_err(|e| input(py, format!("transmission={transmission:?}: {e}")))?;
    let weighting: Weighting = weighting
        .parse()
        .map_err(|e| input(py, format!("weighting={weighting:?}: {e}")))?;
    Ok(Settings {
        transmission,
        weighting,
        clearcoat,
        ..Settings::default()
    })
}

/// A width keyword (degrees) as radians: at least the library's smallest Gaussian width
/// and below 90° (the CLI's check).
fn width(py: Python<'_>, name: &str, deg: f64) -> PyResult<f64> {
    let min_deg = flakescatter::stats::distribution::MIN_GAUSSIAN_WIDTH.to_degrees();
    if !(deg.is_finite() && deg >= min_deg && deg < 90.0) {
        return Err(input(
            py,
            format!("{name}={deg}: the width must be at least {min_deg:.1e} and below 90 degrees"),
        ));
    }
    Ok(deg.to_radians())
}

/// The orientation distribution of the keywords `hwhm`, `sigma`, `rms_tilt` (degrees,
/// at most one; hwhm 6° when none) or `distribution` (a histogram: a path to the CSV
/// that `stats` writes, or a dict with `theta_lo_deg`, `theta_hi_deg`, `area_fraction`
/// arrays, read by the same reader).
pub fn orientation(
    py: Python<'_>,
    hwhm: Option<f64>,
    sigma: Option<f64>,
    rms_tilt: Option<f64>,
    distribution: Option<&Bound<'_, PyAny>>,
) -> PyResult<Orientation> {
    let widths = [hwhm, sigma, rms_tilt]
        .iter()
        .filter(|w| w.is_some())
        .count();
    if widths > 1 {
        return Err(input(py, "hwhm, sigma, rms_tilt: give at most one width"));
    }
    if let Some(d) = distribution {
        if widths > 0 {
            return Err(input(
                py,
                "distribution: a tabulated distribution takes no hwhm/sigma/rms_tilt",
            ));
        }
        let (name, table) = if let Ok(dict) = d.cast::<PyDict>() {
            let text = table_csv(
                py,
                "distribution",
                dict,
                &["theta_lo_deg", "theta_hi_deg", "area_fraction"],
                &[],
            )?;
            let name = "distribution (dict)";
            (name.to_string(), read_histogram_from(text.as_bytes(), name))
        } else {
            let path = path_of(py, "distribution", d)?;
            let name = path.display().to_string();
            let table = flakescatter::io::flakes::read_histogram(&path);
            (name, table)
        };
        let table = table.map_err(|e| {
            let kind = if matches!(e, flakescatter::io::flakes::FlakeTableError::Io { .. }) {
                Kind::File
            } else {
                Kind::Content
            };
            to_py(py, kind, &e)
        })?;
        return Orientation::tabulated(table.edges_rad, table.area_fractions).map_err(|e| {
            crate::errors::raise(
                py,
                Kind::Content,
                format!("distribution {name}: {}", crate::errors::message(&e)),
                None,
            )
        });
    }
    let w = match (hwhm, sigma, rms_tilt) {
        (Some(h), _, _) => GaussianWidth::Hwhm(width(py, "hwhm", h)?),
        (_, Some(s), _) => GaussianWidth::Sigma(width(py, "sigma", s)?),
        (_, _, Some(r)) => GaussianWidth::RmsTilt(width(py, "rms_tilt", r)?),
        _ => GaussianWidth::Hwhm(6f64.to_radians()),
    };
    Orientation::gaussian(w).map_err(|e| to_py(py, Kind::Input, &e))
}

/// A filesystem path from `str` or `os.PathLike`.
pub fn path_of(py: Python<'_>, name: &str, obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
        .map_err(|_| input(py, format!("{name}: expected a path (str or os.PathLike)")))
}

/// A dict of equal-length columns as CSV text with the given required and optional
/// columns, each value in the shortest form that reads back to the same number, so
/// that the project's CSV readers check it exactly as they check a file.
pub fn table_csv(
    py: Python<'_>,
    name: &str,
    dict: &Bound<'_, PyDict>,
    required: &[&str],
    optional: &[&str],
) -> PyResult<String> {
    let mut cols: Vec<(&str, Vec<f64>)> = Vec::new();
    for &c in required {
        let v = dict.get_item(c)?.ok_or_else(|| {
            input(
                py,
                format!("{name}: missing key {c:?} (needs {})", required.join(", ")),
            )
        })?;
        cols.push((c, floats(py, &format!("{name}[{c:?}]"), &v)?));
    }
    for &c in optional {
        if let Some(v) = dict.get_item(c)?
            && !v.is_none()
        {
            cols.push((c, floats(py, &format!("{name}[{c:?}]"), &v)?));
        }
    }
    let len = cols[0].1.len();
    if let Some((c, v)) = cols.iter().find(|(_, v)| v.len() != len) {
        return Err(input(
            py,
            format!(
                "{name}: column {c:?} has {} values, {:?} has {len}",
                v.len(),
                cols[0].0
            ),
        ));
    }
    let mut text = cols.iter().map(|(c, _)| *c).collect::<Vec<_>>().join(",");
    text.push('\n');
    for k in 0..len {
        let row: Vec<String> = cols.iter().map(|(_, v)| format!("{:?}", v[k])).collect();
        text.push_str(&row.join(","));
        text.push('\n');
    }
    Ok(text)
}

/// A measured curve: a path to the CSV `compare`/`fit` read, or a dict with
/// `theta_i_deg`, `theta_s_deg`, `value` (and optionally `uncertainty`) arrays, read by
/// the same reader.
pub fn measured(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<MeasuredCurve> {
    let curve = if let Ok(dict) = obj.cast::<PyDict>() {
        let text = table_csv(
            py,
            "measured",
            dict,
            &["theta_i_deg", "theta_s_deg", "value"],
            &["uncertainty"],
        )?;
        read_measured_from(text.as_bytes(), "measured (dict)")
    } else if obj.is_instance_of::<PyString>() || obj.hasattr("__fspath__")? {
        read_measured(&path_of(py, "measured", obj)?)
    } else {
        return Err(input(
            py,
            "measured: expected a path to a measured-curve CSV or a dict with theta_i_deg, theta_s_deg, value arrays",
        ));
    };
    curve.map_err(|e| {
        let kind = if matches!(e, flakescatter::io::flakes::FlakeTableError::Io { .. }) {
            Kind::File
        } else {
            Kind::Content
        };
        to_py(py, kind, &e)
    })
}

/// Columns of a result: name → numpy array, in insertion order.
pub struct Columns<'py> {
    py: Python<'py>,
    dict: Bound<'py, PyDict>,
}

impl<'py> Columns<'py> {
    /// An empty set of columns.
    pub fn new(py: Python<'py>) -> Self {
        Self {
            py,
            dict: PyDict::new(py),
        }
    }

    /// Adds a float64 column.
    pub fn f64(self, name: &str, v: Vec<f64>) -> PyResult<Self> {
        self.dict.set_item(name, PyArray1::from_vec(self.py, v))?;
        Ok(self)
    }

    /// Adds an int64 column.
    pub fn i64(self, name: &str, v: Vec<i64>) -> PyResult<Self> {
        self.dict.set_item(name, PyArray1::from_vec(self.py, v))?;
        Ok(self)
    }

    /// Adds a bool column.
    pub fn bool(self, name: &str, v: Vec<bool>) -> PyResult<Self> {
        self.dict.set_item(name, PyArray1::from_vec(self.py, v))?;
        Ok(self)
    }

    /// Adds any Python value.
    pub fn value(self, name: &str, v: impl IntoPyObject<'py>) -> PyResult<Self> {
        self.dict.set_item(name, v)?;
        Ok(self)
    }

    /// The dict.
    pub fn done(self) -> Bound<'py, PyDict> {
        self.dict
    }
}

/// `Option<f64>` → NaN for `None`.
pub fn nan(x: Option<f64>) -> f64 {
    x.unwrap_or(f64::NAN)
}

/// An angle in radians as the degrees that were typed: the shortest decimal `d` with
/// `d.to_radians() == rad` (so `30f64.to_radians()` gives back 30, not
/// 29.999999999999996). The CLI writes angles read from files this way; other values
/// give their degrees to full precision.
pub fn typed_degrees(rad: f64) -> f64 {
    flakescatter::stats::decimal::typed_degrees(rad)
}
