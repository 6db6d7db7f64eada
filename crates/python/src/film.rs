//! Thin-film (interference) flakes: `film`.
//!
//! Conventions (physics.md §13): time dependence `exp(−iωt)`, `n + ik` with `k ≥ 0`, p
//! amplitudes with `r_p = −r_s` at normal incidence (the `tmm` package's); angles in the
//! ambient, degrees; vacuum wavelengths, nm; layers from the incidence side.

use flakescatter::film::{FilmSetup, film_table};
use flakescatter::optics::catalogue::Catalogue;
use numpy::Complex64;
use numpy::PyArray2;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::floats;
use crate::errors::input;

/// Amplitude and power reflection and transmission of a layer stack (a free flake in
/// its binder, or on an opaque `substrate`) at every wavelength × angle. `stack`:
/// `"TiO2:120/mica:400/TiO2:120"` (layers from the incidence side,
/// `material:thickness_nm`, a material a built-in name — TiO2, anatase, Fe2O3, SiO2,
/// Al2O3, mica, aluminium, Cr, Ag — or `"2.6+0.01i"`); `ambient`: the binder's real
/// index; `theta_deg`: incidence angles in the ambient, 0–90; `wavelengths_nm`: vacuum
/// wavelengths. Returns a dict of arrays of shape `(wavelengths, angles)`: complex
/// `rs`, `rp`, `ts`, `tp` and float `R_s`, `R_p`, `T_s`, `T_p` (with a substrate, `T`
/// is the power it absorbs), and `stack` (canonical names), `theta_deg`,
/// `wavelengths_nm`. Raises `InputError` naming the bad layer or argument.
#[pyfunction]
#[pyo3(signature = (stack, *, theta_deg, wavelengths_nm, ambient = 1.5, substrate = None))]
pub fn film<'py>(
    py: Python<'py>,
    stack: &str,
    theta_deg: &Bound<'py, PyAny>,
    wavelengths_nm: &Bound<'py, PyAny>,
    ambient: f64,
    substrate: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let thetas = floats(py, "theta_deg", theta_deg)?;
    let wls = floats(py, "wavelengths_nm", wavelengths_nm)?;
    if thetas.is_empty() || wls.is_empty() {
        return Err(input(
            py,
            "theta_deg and wavelengths_nm: expected at least one value each",
        ));
    }
    if let Some(t) = thetas.iter().find(|t| !(0.0..=90.0).contains(*t)) {
        return Err(input(
            py,
            format!("theta_deg: {t} is outside [0, 90] degrees"),
        ));
    }
    let setup = FilmSetup::parse(stack, ambient, substrate, &Catalogue::builtin())
        .map_err(|e| input(py, e.to_string()))?;
    let rad: Vec<f64> = thetas.iter().map(|d| d.to_radians()).collect();
    let rows = film_table(&setup, &rad, &wls).map_err(|e| input(py, e.to_string()))?;
    let shape = (wls.len(), thetas.len());
    let complex =
        |f: &dyn Fn(usize) -> Complex64| Array2::from_shape_fn(shape, |(i, j)| f(i * shape.1 + j));
    let real = |f: &dyn Fn(usize) -> f64| Array2::from_shape_fn(shape, |(i, j)| f(i * shape.1 + j));
    let d = PyDict::new(py);
    let c = |v: flakescatter::optics::nalgebra::Complex<f64>| Complex64::new(v.re, v.im);
    d.set_item(
        "rs",
        PyArray2::from_owned_array(py, complex(&|k| c(rows[k].response.rs))),
    )?;
    d.set_item(
        "rp",
        PyArray2::from_owned_array(py, complex(&|k| c(rows[k].response.rp))),
    )?;
    d.set_item(
        "ts",
        PyArray2::from_owned_array(py, complex(&|k| c(rows[k].response.ts))),
    )?;
    d.set_item(
        "tp",
        PyArray2::from_owned_array(py, complex(&|k| c(rows[k].response.tp))),
    )?;
    d.set_item(
        "R_s",
        PyArray2::from_owned_array(py, real(&|k| rows[k].response.r_s())),
    )?;
    d.set_item(
        "R_p",
        PyArray2::from_owned_array(py, real(&|k| rows[k].response.r_p())),
    )?;
    d.set_item(
        "T_s",
        PyArray2::from_owned_array(py, real(&|k| rows[k].response.t_s())),
    )?;
    d.set_item(
        "T_p",
        PyArray2::from_owned_array(py, real(&|k| rows[k].response.t_p())),
    )?;
    d.set_item("stack", setup.stack.label())?;
    d.set_item("theta_deg", thetas)?;
    d.set_item("wavelengths_nm", wls)?;
    Ok(d)
}
