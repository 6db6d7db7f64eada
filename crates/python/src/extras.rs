//! Colorimetry and confocal stacks: `spectrum_to_lab`, `delta_e`, `localise_stack`.
//!
//! Conventions: wavelengths in nanometres (the CIE tables' unit); reflectance factors
//! dimensionless (1 = the perfect reflecting diffuser); CIELAB from XYZ on the scale
//! `Y = 100` with the white point of the same illuminant and observer. Stack maps in µm.

use flakescatter::colour::{
    Cie94, Illuminant, Lab, Observer, TristimulusWeights, delta_e_94, delta_e_2000, delta_e_ab,
};
use flakescatter::confocal::{MinSignal, PeakMethod, PeakOptions};
use flakescatter::io::stack::{PageOrder, ReadStackError, StackOptions};
use flakescatter::stack::{StackPipelineError, localise_stack as facade_localise_stack};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{floats, path_of};
use crate::errors::{Kind, input, interruptible, to_py};
use crate::map::Map;

fn illuminant(py: Python<'_>, name: &str) -> PyResult<Illuminant> {
    match name {
        "D65" => Ok(Illuminant::D65),
        "D50" => Ok(Illuminant::D50),
        "A" => Ok(Illuminant::A),
        _ => Err(input(
            py,
            format!("illuminant={name:?}: expected \"D65\", \"D50\" or \"A\""),
        )),
    }
}

fn observer(py: Python<'_>, name: &str) -> PyResult<Observer> {
    match name {
        "2" => Ok(Observer::Cie1931TwoDegree),
        "10" => Ok(Observer::Cie1964TenDegree),
        _ => Err(input(
            py,
            format!("observer={name:?}: expected \"2\" (CIE 1931) or \"10\" (CIE 1964)"),
        )),
    }
}

/// CIE XYZ and CIELAB of spectral reflectance factors (ASTM E308 practice at the
/// spectrum's own sampling, colour crate). `wavelengths_nm`: 1-D, nm, increasing;
/// `reflectance`: 1-D (one spectrum) or 2-D of shape `(spectra, wavelengths)`.
/// `illuminant` is `"D65"`, `"D50"` or `"A"`; `observer` `"10"` (CIE 1964) or `"2"`
/// (CIE 1931). Returns a dict of float64 arrays `X`, `Y`, `Z` (Y = 100 for the perfect
/// diffuser), `L`, `a`, `b`, shape `(spectra,)` (or scalars for one spectrum), and the
/// `white_point` (X, Y, Z).
#[pyfunction]
#[pyo3(signature = (wavelengths_nm, reflectance, *, illuminant = "D65", observer = "10"))]
pub fn spectrum_to_lab<'py>(
    py: Python<'py>,
    wavelengths_nm: &Bound<'py, PyAny>,
    reflectance: &Bound<'py, PyAny>,
    illuminant: &str,
    observer: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let w = floats(py, "wavelengths_nm", wavelengths_nm)?;
    let ill = self::illuminant(py, illuminant)?;
    let obs = self::observer(py, observer)?;
    let np = py.import("numpy")?;
    let r = np
        .call_method1("asarray", (reflectance, "float64"))
        .map_err(|_| input(py, "reflectance: expected an array of numbers"))?;
    let ndim: usize = r.getattr("ndim")?.extract()?;
    let single = ndim == 1;
    let r = if single {
        r.call_method1("reshape", (1, -1))?
    } else {
        r
    };
    let r = r.cast_into::<PyArray2<f64>>().map_err(|_| {
        input(
            py,
            "reflectance: expected a 1-D spectrum or a 2-D array (spectra, wavelengths)",
        )
    })?;
    if r.shape()[1] != w.len() {
        return Err(input(
            py,
            format!(
                "reflectance: {} values per spectrum for {} wavelengths",
                r.shape()[1],
                w.len()
            ),
        ));
    }
    let rows: Vec<Vec<f64>> = r
        .readonly()
        .as_array()
        .rows()
        .into_iter()
        .map(|x| x.to_vec())
        .collect();
    let weights = TristimulusWeights::new(&w, ill, obs).map_err(|e| to_py(py, Kind::Input, &e))?;
    let mut cols: [Vec<f64>; 6] = Default::default();
    for (k, spectrum) in rows.iter().enumerate() {
        let xyz = weights.xyz(spectrum).map_err(|e| {
            input(
                py,
                format!("reflectance, spectrum {k}: {}", crate::errors::message(&e)),
            )
        })?;
        let lab = xyz.to_lab(&weights.white_point());
        for (c, v) in cols
            .iter_mut()
            .zip([xyz.x, xyz.y, xyz.z, lab.l, lab.a, lab.b])
        {
            c.push(v);
        }
    }
    let d = PyDict::new(py);
    for (name, c) in ["X", "Y", "Z", "L", "a", "b"].iter().zip(cols) {
        if single {
            d.set_item(name, c[0])?;
        } else {
            d.set_item(name, PyArray1::from_vec(py, c))?;
        }
    }
    let wp = weights.white_point();
    d.set_item("white_point", (wp.x, wp.y, wp.z))?;
    Ok(d)
}

/// Colour differences between CIELAB colours `reference` and `sample`: arrays of shape
/// `(..., 3)` holding (L*, a*, b*) (or one triple each). `formula` is `"2000"`
/// (CIEDE2000, k_L = k_C = k_H = 1), `"ab"` (ΔE*ab, CIE 1976) or `"94"` (ΔE*94, graphic
/// arts weights). Returns a float or an array of the broadcast shape without the last
/// axis.
#[pyfunction]
#[pyo3(signature = (reference, sample, *, formula = "2000"))]
pub fn delta_e<'py>(
    py: Python<'py>,
    reference: &Bound<'py, PyAny>,
    sample: &Bound<'py, PyAny>,
    formula: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let f: fn(&Lab, &Lab) -> f64 = match formula {
        "2000" => delta_e_2000,
        "ab" => delta_e_ab,
        "94" => |a, b| delta_e_94(a, b, Cie94::default()),
        _ => {
            return Err(input(
                py,
                format!("formula={formula:?}: expected \"2000\", \"ab\" or \"94\""),
            ));
        }
    };
    let np = py.import("numpy")?;
    let bad = |name: &str| {
        input(
            py,
            format!("{name}: expected (L*, a*, b*) values, an array of shape (..., 3)"),
        )
    };
    let a = np
        .call_method1("asarray", (reference, "float64"))
        .map_err(|_| bad("reference"))?;
    let b = np
        .call_method1("asarray", (sample, "float64"))
        .map_err(|_| bad("sample"))?;
    let pair = np
        .call_method1("broadcast_arrays", (a, b))
        .map_err(|_| input(py, "reference and sample: shapes do not broadcast"))?;
    let (a, b): (Bound<'py, PyAny>, Bound<'py, PyAny>) = pair.extract()?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    if shape.last() != Some(&3) {
        return Err(bad("reference"));
    }
    let flat = |x: &Bound<'py, PyAny>| -> PyResult<Vec<f64>> {
        let x = np
            .call_method1("ascontiguousarray", (x,))?
            .call_method1("reshape", (-1, 3))?;
        let x = x
            .cast_into::<PyArray2<f64>>()
            .map_err(|_| bad("reference"))?;
        Ok(x.readonly().as_array().iter().copied().collect())
    };
    let (va, vb) = (flat(&a)?, flat(&b)?);
    let lab = |v: &[f64], name: &str| {
        Lab::new(v[0], v[1], v[2])
            .map_err(|e| input(py, format!("{name}: {}", crate::errors::message(&e))))
    };
    let mut out = Vec::with_capacity(va.len() / 3);
    for (x, y) in va.chunks(3).zip(vb.chunks(3)) {
        out.push(f(&lab(x, "reference")?, &lab(y, "sample")?));
    }
    if shape.len() == 1 {
        return Ok(out[0].into_pyobject(py)?.into_any());
    }
    let arr = PyArray1::from_vec(py, out);
    arr.call_method1("reshape", (shape[..shape.len() - 1].to_vec(),))
}

/// From a confocal z-stack (TIFF: ImageJ, OME-TIFF or Zeiss LSM) to maps, as the facade's
/// `stack::localise_stack`: each pixel's axial intensity peak gives its height (µm above
/// the lowest slice), its brightest sample the intensity (full scale 1 for integer
/// stacks) and its FWHM the width map (µm). `method` is `"gaussian"` (default),
/// `"parabolic"`, `"centroid"` or `"argmax"`; `fraction` (0, 1] the share of the maximum
/// above which slices count as the peak; `min_signal` the brightest sample below which a
/// pixel is invalid (default `None`: estimated from the stack's own noise, dark level +
/// k × noise sd so that one background pixel in a thousand passes; the dict's
/// `min_signal` and `min_signal_source` say what was used); `half_window` the samples kept on each side of the maximum;
/// `saturation` the level counted as saturated. `pixel_um`, `z_step_um` and
/// `first_page` (`"bottom"`/`"top"`) override the file's calibration. Returns a dict:
/// `height`, `intensity`, `width` (`Map`s), `report` (pixel counts) and `info` (stack
/// size, voxel sizes and their sources). Interruptible with Ctrl-C.
#[pyfunction]
#[pyo3(signature = (path, *, method = "gaussian", fraction = 0.5, min_signal = None, half_window = 3, saturation = None, pixel_um = None, z_step_um = None, first_page = None))]
#[allow(clippy::too_many_arguments)]
pub fn localise_stack<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    method: &str,
    fraction: f64,
    min_signal: Option<f64>,
    half_window: usize,
    saturation: Option<f64>,
    pixel_um: Option<(f64, f64)>,
    z_step_um: Option<f64>,
    first_page: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let path = path_of(py, "path", path)?;
    let method = PeakMethod::from_name(method).ok_or_else(|| {
        input(
            py,
            format!("method={method:?}: expected \"gaussian\", \"parabolic\", \"centroid\" or \"argmax\""),
        )
    })?;
    let first_page = match first_page {
        None => None,
        Some("bottom") => Some(PageOrder::BottomFirst),
        Some("top") => Some(PageOrder::TopFirst),
        Some(o) => {
            return Err(input(
                py,
                format!("first_page={o:?}: expected \"bottom\" or \"top\""),
            ));
        }
    };
    let read = StackOptions {
        pixel_um,
        z_step_um,
        first_page,
    };
    let peak = PeakOptions {
        method,
        fraction,
        min_signal: min_signal.map_or(MinSignal::Estimated, MinSignal::Level),
        half_window,
        saturation,
    };
    let maps = interruptible(py, |progress| {
        facade_localise_stack(&path, &read, &peak, &|d, t| progress(d, t))
    })?
    .map_err(|e| {
        let kind = match &e {
            StackPipelineError::Read(ReadStackError::Io { .. }) => Kind::File,
            StackPipelineError::Read(_) | StackPipelineError::Stack(_) => Kind::Content,
            _ => Kind::Input,
        };
        to_py(py, kind, &e)
    })?;
    let d = PyDict::new(py);
    d.set_item(
        "height",
        Map {
            map: maps.height,
            format: None,
        },
    )?;
    d.set_item(
        "intensity",
        Map {
            map: maps.intensity,
            format: None,
        },
    )?;
    d.set_item(
        "width",
        Map {
            map: maps.width,
            format: None,
        },
    )?;
    let r = &maps.report;
    let report = PyDict::new(py);
    for (k, v) in [
        ("valid", r.valid),
        ("below_signal", r.below_signal),
        ("first_slice", r.first_slice),
        ("last_slice", r.last_slice),
        ("not_fittable", r.not_fittable),
        ("window_limited", r.window_limited),
        ("saturated", r.saturated),
    ] {
        report.set_item(k, v)?;
    }
    d.set_item("report", report)?;
    d.set_item("min_signal", maps.threshold.level)?;
    d.set_item("min_signal_source", maps.threshold.to_string())?;
    let i = &maps.info;
    let info = PyDict::new(py);
    info.set_item("format", i.format.name())?;
    info.set_item("nx", i.nx)?;
    info.set_item("ny", i.ny)?;
    info.set_item("nz", i.nz)?;
    info.set_item("sample", i.sample.name())?;
    info.set_item("pixel_um", i.pixel_um.as_ref().map(|s| s.value))?;
    info.set_item(
        "pixel_um_source",
        i.pixel_um.as_ref().map(|s| s.source.to_string()),
    )?;
    info.set_item("z_step_um", i.z_step_um.as_ref().map(|s| s.value))?;
    info.set_item(
        "z_step_um_source",
        i.z_step_um.as_ref().map(|s| s.source.to_string()),
    )?;
    info.set_item("first_page", i.first_page.value.name())?;
    info.set_item("pages", i.pages)?;
    let meta = PyDict::new(py);
    for (k, v) in &i.metadata {
        meta.set_item(k, v)?;
    }
    info.set_item("metadata", meta)?;
    d.set_item("info", info)?;
    Ok(d)
}
