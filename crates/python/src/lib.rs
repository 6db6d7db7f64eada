//! Python bindings of flakescatter: the module `flakescatter._flakescatter`, re-exported
//! by the Python package `flakescatter` (`python/flakescatter/__init__.py`), with type
//! stubs in `_flakescatter.pyi`.
//!
//! The bindings are conversion and error mapping only: every function converts its
//! keywords (degrees and micrometres, as the CLI's flags) to the facade's types, calls
//! one facade function with the GIL released, and converts the result to numpy arrays
//! with the CLI's column names. Errors map to `flakescatter.Error` and its subclasses
//! (`errors`); panics are caught at the boundary; long calls (the ray models, the
//! volume model, stacks) stop with `KeyboardInterrupt` on Ctrl-C.

mod analysis;
mod batch;
mod brdf;
mod convert;
mod errors;
mod extras;
mod film;
mod map;
mod models;
mod paint;
mod stream;

use pyo3::prelude::*;

/// Raises `InternalError` through the boundary's panic handling: a panic inside Rust
/// code, as a bug would cause. For the test suite.
#[pyfunction]
fn _panic_for_test(py: Python<'_>) -> PyResult<()> {
    errors::released(py, || -> () {
        panic!("a deliberate panic for the test suite")
    })
}

/// The native module.
#[pymodule]
fn _flakescatter(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<map::Map>()?;
    m.add_class::<stream::StoreRun>()?;
    m.add_function(wrap_pyfunction!(map::read_map, m)?)?;
    m.add_function(wrap_pyfunction!(map::write_map, m)?)?;
    m.add_function(wrap_pyfunction!(brdf::read_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::segment, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::orientation_stats, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::compare, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::fit, m)?)?;
    m.add_function(wrap_pyfunction!(models::distribution_model, m)?)?;
    m.add_function(wrap_pyfunction!(models::topographic_model, m)?)?;
    m.add_function(wrap_pyfunction!(models::isotropic_model, m)?)?;
    m.add_function(wrap_pyfunction!(models::distribution_mueller, m)?)?;
    m.add_function(wrap_pyfunction!(models::topographic_mueller, m)?)?;
    m.add_function(wrap_pyfunction!(models::volume_model, m)?)?;
    m.add_function(wrap_pyfunction!(paint::fit_paint, m)?)?;
    m.add_function(wrap_pyfunction!(paint::paint_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(extras::spectrum_to_lab, m)?)?;
    m.add_function(wrap_pyfunction!(film::film, m)?)?;
    m.add_function(wrap_pyfunction!(extras::delta_e, m)?)?;
    m.add_function(wrap_pyfunction!(extras::localise_stack, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_sample_name, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_comparison_table, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_check_sample_names, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    Ok(())
}
