//! Every mapping of a core error to a Python exception, in one place: bad input to
//! `splitlf.errors.InvalidParameter` (a `ValueError`), sizes and work limits to
//! `TooLargeError` (a `MemoryError`), an interrupt to `KeyboardInterrupt`, a fault of
//! splitlf itself to `RuntimeError`.

use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyInt};

use splitlf_core::Error;

/// A value of a core error message as a Python object: integers and floats as numbers, a
/// quoted name as the name, anything else as its text.
pub(crate) fn py_value(py: Python<'_>, text: &str) -> Py<PyAny> {
    let digits = text.strip_prefix('-').unwrap_or(text);
    if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) {
        // An integer of any size: Python's int() parses it.
        if let Ok(v) = py.get_type::<PyInt>().call1((text,)) {
            return v.unbind();
        }
    }
    if let Ok(x) = text.parse::<f64>() {
        return x
            .into_pyobject(py)
            .map_or_else(|e| match e {}, |v| v.into_any().unbind());
    }
    let unquoted = text
        .strip_prefix('"')
        .and_then(|t| t.strip_suffix('"'))
        .unwrap_or(text);
    unquoted
        .into_pyobject(py)
        .map_or_else(|e| match e {}, |v| v.into_any().unbind())
}

/// An exception class of `splitlf.errors`, or `fallback` when it cannot be imported.
pub(crate) fn raise(
    py: Python<'_>,
    class: &'static str,
    message: String,
    kwargs: impl FnOnce(&Bound<'_, PyDict>) -> PyResult<()>,
    fallback: impl FnOnce(String) -> PyErr,
) -> PyErr {
    let build = || -> PyResult<PyErr> {
        let cls = py.import("splitlf.errors")?.getattr(class)?;
        let kw = PyDict::new(py);
        kwargs(&kw)?;
        Ok(PyErr::from_value(cls.call((message.clone(),), Some(&kw))?))
    };
    build().unwrap_or_else(|_| fallback(message))
}

/// Map a core error to `splitlf.errors`: bad input to `InvalidParameter` (a `ValueError`;
/// a bad depth names `depth`, the call's depth parameter, with the element's index), sizes
/// to `TooLargeError` (a `MemoryError`). `Interrupted` is handled by [`run`].
pub(crate) fn core_error(py: Python<'_>, e: Error, depth: &'static str) -> PyErr {
    let message = e.to_string();
    let full_name = e.parameter_name();
    match e {
        Error::InvalidParameter { value, allowed, .. } => raise(
            py,
            "InvalidParameter",
            message,
            |kw| {
                kw.set_item("name", full_name.as_deref().unwrap_or_default())?;
                kw.set_item("value", py_value(py, &value))?;
                kw.set_item("allowed", allowed)
            },
            PyValueError::new_err,
        ),
        Error::InvalidDepth {
            index,
            value,
            reason,
        } => {
            let message = message.replacen("depth z[", &format!("depth {depth}["), 1);
            raise(
                py,
                "InvalidParameter",
                message,
                |kw| {
                    kw.set_item("name", depth)?;
                    kw.set_item("value", value)?;
                    kw.set_item("allowed", reason)?;
                    kw.set_item("index", index)
                },
                PyValueError::new_err,
            )
        }
        Error::TooLarge { what, bytes, limit } => too_large(py, message, what, Some(bytes), limit),
        Error::TooMuchWork {
            what, limit, unit, ..
        } => too_large(py, message, format!("{what} ({unit})"), None, limit),
        Error::Interrupted => PyKeyboardInterrupt::new_err(()),
    }
}

/// `TooLargeError` (a `MemoryError`): what was refused, the bytes it needed (a size) or
/// None (a work limit), and the limit.
fn too_large(
    py: Python<'_>,
    message: String,
    what: String,
    nbytes: Option<u128>,
    limit: u128,
) -> PyErr {
    let kwargs = |kw: &Bound<'_, PyDict>| {
        kw.set_item("what", what)?;
        if let Some(n) = nbytes {
            kw.set_item("nbytes", n)?;
        }
        kw.set_item("limit", limit)
    };
    raise(py, "TooLargeError", message, kwargs, PyMemoryError::new_err)
}

pub(crate) fn to_py(e: Error) -> PyErr {
    Python::attach(|py| core_error(py, e, "z"))
}

/// A fault of splitlf itself (never bad input): `RuntimeError`.
pub(crate) fn internal(e: impl std::fmt::Display) -> PyErr {
    PyRuntimeError::new_err(format!("splitlf internal error: {e}"))
}
