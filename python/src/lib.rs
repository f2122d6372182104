//! `powertwin._powertwin`: the Python bindings of the powertwin library (PyO3, numpy).
//!
//! Thin: every computation is a call into `powertwin` made with the GIL released
//! (`Python::detach`), with the arguments the CLI would pass for the same command line, so
//! that Python and the CLI give the same numbers. Argument checks that name the argument and
//! its expected shape live in the pure-Python layer (`powertwin/__init__.py`); the errors of
//! the library come back as `ValueError` (bad input) or `OSError` (files), with the CLI's
//! messages.

mod cells;
mod excite;
mod model;
mod robot;
mod runs;
mod sweep;
mod validate;

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

/// A library error as a Python exception: `OSError` for files, `ValueError` for the rest;
/// `context` (as the CLI's) leads the message when not empty.
pub(crate) fn py_err(context: &str, e: &powertwin::Error) -> PyErr {
    let msg = if context.is_empty() {
        e.to_string()
    } else {
        format!("{context}: {e}")
    };
    match e {
        powertwin::Error::Io { .. } => PyOSError::new_err(msg),
        _ => PyValueError::new_err(msg),
    }
}

/// `map_err` helper: the library error with the CLI's context.
pub(crate) fn ctx(context: impl Into<String>) -> impl FnOnce(powertwin::Error) -> PyErr {
    let context = context.into();
    move |e| py_err(&context, &e)
}

/// A `ValueError` with `msg`.
pub(crate) fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// An `OSError` for `path` with the CLI's wording (`writing PATH: ...`).
pub(crate) fn os_error(what: &str, path: &std::path::Path, e: &std::io::Error) -> PyErr {
    PyOSError::new_err(format!("{what} {}: {e}", path.display()))
}

/// Parse an option string with its `FromStr` (the CLI's parser), naming the argument.
pub(crate) fn parse<T: std::str::FromStr>(arg: &str, value: &str) -> PyResult<T>
where
    T::Err: std::fmt::Display,
{
    value
        .parse()
        .map_err(|e| value_error(format!("{arg}={value:?}: {e}")))
}

#[pymodule]
fn _powertwin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The twin's default Rapier substeps, as the CLI's `--substeps` default.
    m.add(
        "DEFAULT_SUBSTEPS",
        powertwin::twin::physics::PhysicsSettings::default().substeps,
    )?;
    m.add_class::<robot::PyRobot>()?;
    m.add_class::<runs::PyLog>()?;
    m.add_class::<model::PyModel>()?;
    m.add_function(wrap_pyfunction!(runs::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(runs::dataset_item, m)?)?;
    m.add_function(wrap_pyfunction!(runs::read_log, m)?)?;
    m.add_function(wrap_pyfunction!(runs::read_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(model::identify, m)?)?;
    m.add_function(wrap_pyfunction!(model::holdout, m)?)?;
    m.add_function(wrap_pyfunction!(excite::excite_set, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_cell, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_assemble, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate_motion, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate_assemble, m)?)?;
    m.add(
        "MAX_FIT_RATE_HZ",
        powertwin::identification::tuning::MAX_FIT_RATE_HZ,
    )?;
    Ok(())
}
