//! The exception hierarchy and the mapping of the facade's errors onto it.
//!
//! `flakescatter.Error` is the base of everything the module raises on purpose:
//! * `InputError(Error, ValueError)`: a parameter out of range or inconsistent;
//! * `FileFormatError(Error, ValueError)`: a file that was read but whose content is not
//!   usable (the message names the file, line or field, as the CLI's does);
//! * `FileError(Error, OSError)`: a file that cannot be opened, read or written
//!   (`errno` set where known; the message names the file);
//! * `InternalError(Error)`: a panic inside the Rust code (a bug), caught at the boundary
//!   so that it never crosses into Python as a crash.
//!
//! Library warnings go through Python's `warnings` module with the category
//! `flakescatter.FlakescatterWarning(UserWarning)`.
//!
//! Messages are the facade's own error texts, the ones the CLI prints after `error:`
//! (its causes appended when the top message does not already contain them).

use std::error::Error as StdError;
use std::ffi::CString;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Mutex;

use pyo3::exceptions::{PyException, PyOSError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

/// Which exception class an error maps to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A bad parameter: `InputError` (a `ValueError`).
    Input,
    /// A file whose content is not usable: `FileFormatError` (a `ValueError`).
    Content,
    /// A file that cannot be opened, read or written: `FileError` (an `OSError`).
    File,
    /// A bug: `InternalError`.
    Internal,
}

static ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static INPUT: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static CONTENT: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static FILE: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static INTERNAL: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static WARNING: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// A class `name(bases...)` in module `flakescatter`, made with `type()` so that it can
/// have two bases (PyO3's `create_exception!` takes one).
fn new_class<'py>(
    py: Python<'py>,
    name: &str,
    bases: &[&Bound<'py, PyType>],
    doc: &str,
) -> PyResult<Bound<'py, PyType>> {
    let ns = PyDict::new(py);
    ns.set_item("__module__", "flakescatter")?;
    ns.set_item("__doc__", doc)?;
    let bases = PyTuple::new(py, bases)?;
    let ty = py
        .import("builtins")?
        .getattr("type")?
        .call1((name, bases, ns))?;
    Ok(ty.cast_into::<PyType>()?)
}

/// Creates the exception and warning classes and adds them to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let exception = py.get_type::<PyException>();
    let value_error = py.get_type::<PyValueError>();
    let os_error = py.get_type::<PyOSError>();
    let error = new_class(
        py,
        "Error",
        &[&exception],
        "Base class of the errors flakescatter raises.",
    )?;
    let input = new_class(
        py,
        "InputError",
        &[&error, &value_error],
        "A parameter out of range or inconsistent with the others (also a ValueError).",
    )?;
    let content = new_class(
        py,
        "FileFormatError",
        &[&error, &value_error],
        "A file that was read but whose content is not usable; the message names the file, \
         line or field (also a ValueError).",
    )?;
    let file = new_class(
        py,
        "FileError",
        &[&error, &os_error],
        "A file that cannot be opened, read or written (also an OSError; errno is set where \
         known, the message names the file).",
    )?;
    let internal = new_class(
        py,
        "InternalError",
        &[&error],
        "A bug: the Rust code panicked. The message says where; please report it.",
    )?;
    let warning = new_class(
        py,
        "FlakescatterWarning",
        &[&py.get_type::<PyUserWarning>()],
        "Warnings of flakescatter's models and fits (undefined values, few tiles, poor fits).",
    )?;
    for (name, ty, cell) in [
        ("Error", &error, &ERROR),
        ("InputError", &input, &INPUT),
        ("FileFormatError", &content, &CONTENT),
        ("FileError", &file, &FILE),
        ("InternalError", &internal, &INTERNAL),
        ("FlakescatterWarning", &warning, &WARNING),
    ] {
        m.add(name, ty)?;
        // A second import of the module in one interpreter keeps the first classes.
        let _ = cell.set(py, ty.clone().unbind());
    }
    Ok(())
}

/// The message of an error and its causes, each cause appended unless the message
/// already contains it (the facade's errors often repeat their source in their text).
pub fn message(err: &(dyn StdError + 'static)) -> String {
    let mut msg = err.to_string();
    let mut source = err.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        source = cause.source();
    }
    msg
}

/// The `std::io::Error` in an error's chain, if there is one.
fn io_source<'a>(err: &'a (dyn StdError + 'static)) -> Option<&'a std::io::Error> {
    let mut e: Option<&(dyn StdError + 'static)> = Some(err);
    while let Some(cur) = e {
        if let Some(io) = cur.downcast_ref::<std::io::Error>() {
            return Some(io);
        }
        e = cur.source();
    }
    None
}

/// A Python exception of `kind` with `msg`; a `FileError` gets `errno` when it is
/// given.
pub fn raise(py: Python<'_>, kind: Kind, msg: String, errno: Option<i32>) -> PyErr {
    let cell = match kind {
        Kind::Input => &INPUT,
        Kind::Content => &CONTENT,
        Kind::File => &FILE,
        Kind::Internal => &INTERNAL,
    };
    let Some(ty) = cell.get(py) else {
        // Only before module initialisation finished; never seen by users.
        return PyException::new_err(msg);
    };
    let ty = ty.bind(py);
    match ty.call1((msg.clone(),)) {
        Ok(value) => {
            // `errno` only: with `filename` or `strerror` set, OSError's str() would
            // reformat the message ("[Errno 2] ...: 'file'"); the message names the file.
            if kind == Kind::File
                && let Some(n) = errno
            {
                let _ = value.setattr("errno", n);
            }
            PyErr::from_value(value)
        }
        Err(e) => e,
    }
}

/// An error of the facade as a Python exception of `kind`; a `FileError` carries the
/// operating system's error number and `file`.
pub fn to_py(py: Python<'_>, kind: Kind, err: &(dyn StdError + 'static)) -> PyErr {
    let errno = io_source(err).and_then(std::io::Error::raw_os_error);
    raise(py, kind, message(err), errno)
}

/// An `InputError` with `msg` (a parameter checked at the boundary).
pub fn input(py: Python<'_>, msg: impl Into<String>) -> PyErr {
    raise(py, Kind::Input, msg.into(), None)
}

/// Emits `msg` as a `FlakescatterWarning` (stack level 2: the caller's line).
pub fn warn(py: Python<'_>, msg: &str) -> PyResult<()> {
    let Some(ty) = WARNING.get(py) else {
        return Ok(());
    };
    let text = CString::new(msg.replace('\0', " ")).unwrap_or_default();
    PyErr::warn(py, ty.bind(py).as_any(), &text, 2)
}

/// The payload with which a progress callback unwinds out of a long facade call when
/// Python has a pending signal (Ctrl-C): see [`interruptible`].
struct Interrupted;

/// Runs `work` with the GIL released, catching panics (→ `InternalError`) and turning a
/// pending Python signal seen by the progress callback into that signal's exception.
///
/// `work` receives the progress callback to hand to the facade. The callback
/// re-acquires the GIL briefly and calls `Python::check_signals`; when that raises
/// (Ctrl-C gives `KeyboardInterrupt`), it stores the exception and leaves the facade
/// call by `resume_unwind` with a private payload (no panic message: `resume_unwind`
/// does not run the panic hook). The facade calls its progress callbacks on the calling
/// thread between batches of work, outside any parallel section and with nothing but
/// the call's own buffers alive, so unwinding from there drops them and leaves no
/// shared state behind (the inputs are borrowed immutably). This needs no change to
/// the facade, whose progress callbacks return nothing.
pub fn interruptible<T, E>(
    py: Python<'_>,
    work: impl FnOnce(&(dyn Fn(u64, u64) + Sync)) -> Result<T, E> + Send,
) -> PyResult<Result<T, E>>
where
    T: Send,
    E: Send,
{
    let pending: Mutex<Option<PyErr>> = Mutex::new(None);
    let outcome = py.detach(|| {
        let progress = |_done: u64, _total: u64| {
            let signal = Python::attach(|py| py.check_signals());
            if let Err(e) = signal {
                if let Ok(mut slot) = pending.lock() {
                    *slot = Some(e);
                }
                resume_unwind(Box::new(Interrupted));
            }
        };
        catch_unwind(AssertUnwindSafe(|| work(&progress)))
    });
    match outcome {
        Ok(result) => Ok(result),
        Err(payload) => {
            if payload.is::<Interrupted>() {
                let e = pending.lock().ok().and_then(|mut s| s.take());
                Err(e.unwrap_or_else(|| raise(py, Kind::Internal, "interrupted".into(), None)))
            } else {
                Err(panic_error(py, payload.as_ref()))
            }
        }
    }
}

/// Runs `work` (which needs no Python) with the GIL released, panics caught.
pub fn released<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(work)))
        .map_err(|payload| panic_error(py, payload.as_ref()))
}

/// Runs `work` with the GIL held, panics caught (for short calls).
pub fn guarded<T>(py: Python<'_>, work: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(work))
        .unwrap_or_else(|payload| Err(panic_error(py, payload.as_ref())))
}

/// The `InternalError` for a caught panic.
fn panic_error(py: Python<'_>, payload: &(dyn std::any::Any + Send)) -> PyErr {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into());
    raise(
        py,
        Kind::Internal,
        format!("internal error (a bug in flakescatter, please report it): {what}"),
        None,
    )
}
