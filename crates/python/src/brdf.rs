//! Tabulated BRDFs: `read_brdf` (MERL isotropic tables, `docs/formats.md`).

use flakescatter::io::merl::{
    BINS, CHANNELS, MerlError, PHI_D_BINS, SCALES, THETA_D_BINS, THETA_H_BINS, read_merl,
};
use numpy::PyArray1;
use numpy::PyArrayMethods;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::path_of;
use crate::errors::{Kind, released, to_py};

/// A MERL isotropic BRDF table (Matusik et al. 2003; the layout and indexing of MERL's
/// reference reader, `docs/formats.md`). Returns a dict: `brdf`, float64 array of shape
/// `(3, 90, 90, 180)` indexed `[channel R, G, B][θh bin][θd bin][φd bin]`, the BRDF in
/// sr⁻¹ (the stored number times the channel's scale), NaN where the file holds no value
/// (a negative number: below the horizon or not measured); `channels` `["R", "G",
/// "B"]`; `scale` the three scales; `file` the path. Bin `h` of θh spans
/// `(π/2)(h/90)²…(π/2)((h+1)/90)²`, bins of θd are π/180 wide over `[0, π/2)` and bins
/// of φd π/180 wide over `[0, π)` (φd folded by reciprocity). Raises `FileError` for a
/// file that cannot be read and `FileFormatError` (naming the file) for another header,
/// length or a stored number that is not finite.
#[pyfunction]
pub fn read_brdf<'py>(py: Python<'py>, path: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let path = path_of(py, "path", path)?;
    let table = released(py, || read_merl(&path))?.map_err(|e| match e {
        MerlError::Io { .. } => to_py(py, Kind::File, &e),
        _ => to_py(py, Kind::Content, &e),
    })?;
    let values: Vec<f64> = table
        .raw()
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            if s >= 0.0 {
                s * SCALES[k / BINS]
            } else {
                f64::NAN
            }
        })
        .collect();
    let brdf =
        PyArray1::from_vec(py, values).reshape([3, THETA_H_BINS, THETA_D_BINS, PHI_D_BINS])?;
    let d = PyDict::new(py);
    d.set_item("brdf", brdf)?;
    d.set_item("channels", CHANNELS.to_vec())?;
    d.set_item("scale", SCALES.to_vec())?;
    d.set_item("file", path.display().to_string())?;
    Ok(d)
}
