//! The one interruption mechanism of the seam: a core call runs without the GIL and stops
//! between its chunks of work when a signal handler (Ctrl-C) raised.

use std::sync::{Arc, Mutex};

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use splitlf_core::{parallel, Error};

use crate::errors::core_error;

/// Run a core call without the GIL, checking for signals (Ctrl-C) between the core's
/// chunks: the check re-attaches briefly on this (the calling) thread, and the Python
/// exception a signal handler raised is returned as is. When the interpreter is shutting
/// down (a daemon thread still inside the core at exit) the check cannot attach and stops
/// the call instead of panicking.
pub(crate) fn run_as<R: Send>(
    py: Python<'_>,
    depth: &'static str,
    f: impl FnOnce() -> splitlf_core::Result<R> + Send,
) -> PyResult<R> {
    let caught: Arc<Mutex<Option<PyErr>>> = Arc::default();
    let slot = Arc::clone(&caught);
    let result = py.detach(move || {
        let stop = move || {
            Python::try_attach(|py| match py.check_signals() {
                Ok(()) => false,
                Err(e) => {
                    *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                    true
                }
            })
            .unwrap_or(true)
        };
        parallel::interruptible(stop, f)
    });
    match result {
        Ok(v) => Ok(v),
        Err(Error::Interrupted) => {
            let e = caught.lock().unwrap_or_else(|p| p.into_inner()).take();
            Err(e.unwrap_or_else(|| PyKeyboardInterrupt::new_err(())))
        }
        Err(e) => Err(core_error(py, e, depth)),
    }
}

pub(crate) fn run<R: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> splitlf_core::Result<R> + Send,
) -> PyResult<R> {
    run_as(py, "z", f)
}
