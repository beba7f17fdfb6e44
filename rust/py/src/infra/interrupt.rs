//! The one interruption mechanism of the seam: a core call runs without the GIL and stops
//! between its chunks of work when a signal handler (Ctrl-C) raised.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use splitlf_core::{infra::parallel, Error};

use crate::infra::errors::core_error;

/// Time between two signal checks of a call on the main thread: the core's chunks can be
/// much shorter, and each check takes the GIL.
const CHECK_EVERY: Duration = Duration::from_millis(25);

/// Whether the calling thread is Python's main thread, the only one that runs signal
/// handlers (`threading.get_ident() == threading.main_thread().ident`; the main thread's
/// ident cached per process: a child forked from another thread has that one as main).
fn on_main_thread(py: Python<'_>) -> bool {
    static MAIN: Mutex<Option<(u32, u64)>> = Mutex::new(None);
    let ident = |main: bool| -> PyResult<u64> {
        let threading = py.import("threading")?;
        if main {
            threading
                .call_method0("main_thread")?
                .getattr("ident")?
                .extract()
        } else {
            threading.call_method0("get_ident")?.extract()
        }
    };
    let pid = std::process::id();
    let main = {
        let cached = *MAIN.lock().unwrap_or_else(|p| p.into_inner());
        match cached {
            Some((p, id)) if p == pid => Ok(id),
            _ => ident(true).inspect(|&id| {
                *MAIN.lock().unwrap_or_else(|p| p.into_inner()) = Some((pid, id));
            }),
        }
    };
    match (main, ident(false)) {
        (Ok(main), Ok(me)) => main == me,
        _ => true, // unsure: check signals (the cost of a check, never a missed Ctrl-C)
    }
}

/// Run a core call without the GIL, checking for signals (Ctrl-C) between the core's
/// chunks. Only the main thread can receive a signal: there the check re-attaches briefly
/// (at most every [`CHECK_EVERY`]) and the Python exception a signal handler raised is
/// returned as is; on any other thread the check never takes the GIL (concurrent calls
/// from several threads do not queue on it) and only asks whether the interpreter is still
/// running. When the interpreter is shutting down (a daemon thread still inside the core
/// at exit) the check stops the call instead of attaching (PyO3 would panic).
pub(crate) fn run_as<R: Send>(
    py: Python<'_>,
    depth: &'static str,
    f: impl FnOnce() -> splitlf_core::Result<R> + Send,
) -> PyResult<R> {
    run_reporting(py, depth, None, f)
}

/// A progress report: `callback(done, total)` called with the GIL at each signal check on
/// the main thread, `done` read from the counter the core advances.
pub(crate) struct Progress {
    pub callback: Py<PyAny>,
    pub done: Arc<std::sync::atomic::AtomicUsize>,
    pub total: usize,
}

/// A progress report of `total` items to `progress` (if any) and the counter the core's
/// workers add to.
pub(crate) fn counted(
    progress: Option<Py<PyAny>>,
    total: usize,
) -> (Option<Progress>, Arc<std::sync::atomic::AtomicUsize>) {
    let done = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let report = progress.map(|callback| Progress {
        callback,
        done: Arc::clone(&done),
        total,
    });
    (report, done)
}

/// [`run_as`] with an optional progress report (main thread only: elsewhere the report
/// would have to take the GIL).
pub(crate) fn run_reporting<R: Send>(
    py: Python<'_>,
    depth: &'static str,
    progress: Option<Progress>,
    f: impl FnOnce() -> splitlf_core::Result<R> + Send,
) -> PyResult<R> {
    let caught: Arc<Mutex<Option<PyErr>>> = Arc::default();
    let slot = Arc::clone(&caught);
    let main = on_main_thread(py);
    let result = py.detach(move || {
        // SAFETY: Py_IsInitialized may be called at any time, without the GIL.
        let finalizing = || unsafe { pyo3::ffi::Py_IsInitialized() } == 0;
        let mut next = Instant::now() + CHECK_EVERY;
        let stop = move || {
            if !main {
                return finalizing();
            }
            let now = Instant::now();
            if now < next {
                return finalizing();
            }
            next = now + CHECK_EVERY;
            Python::try_attach(|py| {
                match py.check_signals().and_then(|()| {
                    if let Some(p) = &progress {
                        let done = p
                            .done
                            .load(std::sync::atomic::Ordering::Relaxed)
                            .min(p.total);
                        p.callback.call1(py, (done, p.total))?;
                    }
                    Ok(())
                }) {
                    Ok(()) => false,
                    Err(e) => {
                        *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                        true
                    }
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

/// Load NumPy's C API and rust-numpy's borrow-checking API now, at import: both are
/// loaded on first use by running Python code, and rust-numpy panics when that code
/// fails, e.g. when a Ctrl-C pressed during a process's first long call is raised there
/// as the call makes its first array ("Failed to access NumPy array API capsule").
pub(crate) fn numpy_ready(py: Python<'_>) -> PyResult<()> {
    // The Python side first, its errors raised as they are (an import error, a pending
    // KeyboardInterrupt) rather than as a panic of rust-numpy.
    numpy::get_array_module(py)?;
    py.import("numpy")?.getattr("__version__")?;
    let a = numpy::PyArray1::<f64>::zeros(py, 1, false);
    drop(numpy::PyArrayMethods::readwrite(&a));
    drop(numpy::PyArrayMethods::readonly(&a));
    Ok(())
}
