//! PyO3 bindings of splitlf-core. Nothing physical lives here: argument conversion, GIL
//! release around the core (with Ctrl-C checked between the core's chunks of work),
//! fallible allocation of the NumPy outputs, named result objects, and mapping of core
//! errors to the exceptions of `splitlf.errors`.

use std::borrow::Cow;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use numpy::ndarray::{Dimension, Ix2};
use numpy::{
    Element, IntoPyArray, PyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1,
    PyReadonlyArray2,
};
use pyo3::exceptions::{
    PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyDict, PyInt, PyTuple};

use splitlf_core::line::Line;
use splitlf_core::presets;
use splitlf_core::rayspace::{self, Sample};
use splitlf_core::samples;
use splitlf_core::samples2d;
use splitlf_core::simulate::{self, DesignSource, Grid, Pixels, Source};
use splitlf_core::{camera, design, memory, merit, optics, parallel, Camera, Design, Error, Half};

// ---- errors ------------------------------------------------------------------------------

/// A value of a core error message as a Python object: integers and floats as numbers, a
/// quoted name as the name, anything else as its text.
fn py_value(py: Python<'_>, text: &str) -> Py<PyAny> {
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
fn raise(
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
fn core_error(py: Python<'_>, e: Error, depth: &'static str) -> PyErr {
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
        Error::TooLarge { what, bytes, limit } => raise(
            py,
            "TooLargeError",
            message,
            |kw| {
                kw.set_item("what", what)?;
                kw.set_item("nbytes", bytes)?;
                kw.set_item("limit", limit)
            },
            PyMemoryError::new_err,
        ),
        Error::TooMuchWork {
            what, limit, unit, ..
        } => raise(
            py,
            "TooLargeError",
            message,
            |kw| {
                kw.set_item("what", format!("{what} ({unit})"))?;
                kw.set_item("limit", limit)
            },
            PyMemoryError::new_err,
        ),
        Error::Interrupted => PyKeyboardInterrupt::new_err(()),
    }
}

fn to_py(e: Error) -> PyErr {
    Python::attach(|py| core_error(py, e, "z"))
}

/// A fault of splitlf itself (never bad input): `RuntimeError`.
fn internal(e: impl std::fmt::Display) -> PyErr {
    PyRuntimeError::new_err(format!("splitlf internal error: {e}"))
}

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
fn run_as<R: Send>(
    py: Python<'_>,
    depth: &'static str,
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

fn run<R: Send>(py: Python<'_>, f: impl FnOnce() -> splitlf_core::Result<R> + Send) -> PyResult<R> {
    run_as(py, "z", f)
}

// ---- arguments ---------------------------------------------------------------------------

/// An integer argument of any size (a Python int or anything with `__index__`, never a
/// bool), or a `TypeError` naming it: its value saturated to i128 (every range is far
/// inside) and its decimal text.
fn int_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(i128, String)> {
    let type_name = obj.get_type().name()?.to_string();
    let refuse = || -> PyResult<PyErr> {
        Ok(PyTypeError::new_err(format!(
            "{name} must be an integer, got {type_name} {}",
            obj.repr()?
        )))
    };
    if obj.is_instance_of::<PyBool>() || type_name == "bool_" {
        return Err(refuse()?);
    }
    let Ok(index) = obj.call_method0("__index__") else {
        return Err(refuse()?);
    };
    let text = index.str()?.to_string();
    let value = match index.extract::<i128>() {
        Ok(v) => v,
        Err(_) if index.lt(0)? => i128::MIN,
        Err(_) => i128::MAX,
    };
    Ok((value, text))
}

/// The core's range check applied to a value that may not fit its integer type: the core
/// sees the value saturated (out of every range) and its error shows the value given.
fn with_given(e: Error, given: &str) -> Error {
    match e {
        Error::InvalidParameter {
            name,
            allowed,
            channel,
            ..
        } => Error::InvalidParameter {
            name,
            value: given.to_string(),
            allowed,
            channel,
        },
        other => other,
    }
}

fn saturate(v: i128) -> i64 {
    v.clamp(i64::MIN as i128, i64::MAX as i128) as i64
}

fn half_arg(obj: &Bound<'_, PyAny>) -> PyResult<Half> {
    let (v, text) = int_arg(obj, "half")?;
    Half::from_number(saturate(v)).map_err(|e| to_py(with_given(e, &text)))
}

fn threads_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let (v, text) = int_arg(obj, "n_threads")?;
    let n = v.clamp(0, parallel::MAX_THREADS as i128 + 1) as usize;
    parallel::check_threads(Some(n)).map_err(|e| to_py(with_given(e, &text)))?;
    Ok(Some(n))
}

/// Borrow a 1-D float64 array as a slice, copying (fallibly) only when it is not contiguous.
fn as_slice<'a>(a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<Cow<'a, [f64]>> {
    match a.as_slice() {
        Ok(s) => Ok(Cow::Borrowed(s)),
        Err(_) => {
            let view = a.as_array();
            let mut v =
                memory::try_with_capacity("contiguous copy of z", view.len()).map_err(to_py)?;
            v.extend(view.iter().copied());
            Ok(Cow::Owned(v))
        }
    }
}

// ---- outputs -----------------------------------------------------------------------------

/// An uninitialised C-contiguous NumPy array, allocated by `numpy.empty` so that a failed
/// allocation is a `TooLargeError` naming the call (rust-numpy's constructors would panic).
fn empty<'py, T: Element, D: Dimension>(
    py: Python<'py>,
    shape: &[usize],
    what: &str,
) -> PyResult<Bound<'py, PyArray<T, D>>> {
    static EMPTY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    let empty = EMPTY.import(py, "numpy", "empty")?;
    let dims = PyTuple::new(py, shape)?;
    match empty.call1((dims, numpy::dtype::<T>(py))) {
        Ok(a) => a.cast_into::<PyArray<T, D>>().map_err(internal),
        Err(e) if e.is_instance_of::<PyMemoryError>(py) => {
            let n: u128 = shape.iter().map(|&d| d as u128).product();
            Err(to_py(Error::TooLarge {
                what: format!("{what} (NumPy output {shape:?})"),
                bytes: n * std::mem::size_of::<T>() as u128,
                limit: memory::available(),
            }))
        }
        Err(e) => Err(e),
    }
}

/// A NumPy array holding `values`, allocated fallibly (see [`empty`]).
fn filled<'py, T: Element + Copy, D: Dimension>(
    py: Python<'py>,
    shape: &[usize],
    what: &str,
    values: impl Iterator<Item = T>,
) -> PyResult<Bound<'py, PyArray<T, D>>> {
    let a = empty::<T, D>(py, shape, what)?;
    {
        let mut w = a.readwrite();
        let s = w.as_slice_mut().map_err(internal)?;
        let mut written = 0;
        for (o, v) in s.iter_mut().zip(values) {
            *o = v;
            written += 1;
        }
        if written != s.len() {
            return Err(internal(format!(
                "{what}: {written} values for {}",
                s.len()
            )));
        }
    }
    Ok(a)
}

/// An int64 array's buffer seen as u64 (the core's counts; every count is < 2^63).
fn as_u64(s: &mut [i64]) -> &mut [u64] {
    // SAFETY: i64 and u64 have the same size and alignment and every bit pattern is valid
    // for both; the borrow of `s` is carried over.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<u64>(), s.len()) }
}

// ---- the camera --------------------------------------------------------------------------

/// A validated camera held by the core (wrapped by `splitlf.Camera`).
#[pyclass(
    frozen,
    skip_from_py_object,
    name = "CameraCore",
    module = "splitlf._native"
)]
struct CameraCore {
    inner: Camera,
}

#[pymethods]
impl CameraCore {
    #[new]
    #[pyo3(signature = (f_main, aperture, v1, kappa, d, v, mu, q, kx, ky, f1=None, f2=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        f_main: f64,
        aperture: f64,
        v1: f64,
        kappa: f64,
        d: f64,
        v: f64,
        mu: f64,
        q: i64,
        kx: i64,
        ky: i64,
        f1: Option<f64>,
        f2: Option<f64>,
    ) -> PyResult<Self> {
        let inner =
            Camera::new(f_main, aperture, v1, kappa, d, v, mu, q, kx, ky, f1, f2).map_err(to_py)?;
        Ok(CameraCore { inner })
    }

    /// The seed design of docs/model.md §7.
    #[staticmethod]
    fn paper() -> Self {
        CameraCore {
            inner: Camera::paper(),
        }
    }

    /// (F, D, v1, kappa, d, v, mu, Q, Kx, Ky, f1, f2), with f1/f2 resolved.
    fn fields(&self) -> (f64, f64, f64, f64, f64, f64, f64, u32, u32, u32, f64, f64) {
        let c = &self.inner;
        (
            c.f_main, c.aperture, c.v1, c.kappa, c.d, c.v, c.mu, c.q, c.kx, c.ky, c.f1, c.f2,
        )
    }

    fn array_plane(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.inner.array_plane(half_arg(half_)?))
    }

    fn out_of_focus_depth(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.inner.out_of_focus_depth(half_arg(half_)?))
    }

    fn image_radius(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.inner.image_radius(half_arg(half_)?))
    }

    fn lit_pixels(&self, half_: &Bound<'_, PyAny>) -> PyResult<u32> {
        Ok(self.inner.lit_pixels(half_arg(half_)?))
    }

    fn ng_focal_length(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        let h = half_arg(half_)?;
        Ok(camera::ng_focal_length(
            self.inner.array_plane(h),
            self.inner.v,
        ))
    }

    fn rho(&self) -> f64 {
        self.inner.rho()
    }

    fn f_number(&self) -> f64 {
        self.inner.f_number()
    }

    /// δ(z) = d z / (Q v') (docs/model.md §6); z must be a valid depth.
    fn resolution_step(&self, z: f64) -> PyResult<f64> {
        optics::check_depths(&self.inner, &[z]).map_err(to_py)?;
        Ok(self.inner.resolution_step(z))
    }
}

// ---- designs (docs/model.md §9) ----------------------------------------------------------

/// One key of a channel's dict (see `splitlf.design.Channel`), converted.
fn item<'py, T: FromPyObjectOwned<'py>>(d: &Bound<'py, PyDict>, key: &str) -> PyResult<T> {
    match d.get_item(key)? {
        Some(v) => v.extract::<T>().map_err(Into::into),
        None => Err(PyRuntimeError::new_err(format!(
            "internal: channel dict without {key:?}"
        ))),
    }
}

fn channel_spec(d: &Bound<'_, PyDict>) -> PyResult<design::ChannelSpec> {
    let grid: String = item(d, "grid")?;
    let grid = design::Grid::from_name(&grid).map_err(to_py)?;
    Ok(design::ChannelSpec {
        l: item(d, "L")?,
        d: item(d, "d")?,
        v: item(d, "v")?,
        mu: item(d, "mu")?,
        kx: item(d, "Kx")?,
        ky: item(d, "Ky")?,
        grid,
        f: item(d, "f")?,
        layout: item(d, "layout")?,
        q: item(d, "Q")?,
        mx: item(d, "Mx")?,
        my: item(d, "My")?,
        share: item(d, "share")?,
    })
}

/// A validated design (docs/model.md §9): main lens and channels.
#[pyclass(
    frozen,
    skip_from_py_object,
    name = "DesignCore",
    module = "splitlf._native"
)]
struct DesignCore {
    inner: Design,
}

impl DesignCore {
    /// The design and its channel `number` (an integer from 1; other values are named errors).
    fn channel_arg(&self, number: &Bound<'_, PyAny>) -> PyResult<(&Design, &design::Channel)> {
        let (v, text) = int_arg(number, "channel")?;
        let ch = self
            .inner
            .channel(saturate(v))
            .map_err(|e| to_py(with_given(e, &text)))?;
        Ok((&self.inner, ch))
    }
}

#[pymethods]
impl DesignCore {
    /// `channels`: one dict per channel with the keys L, d, v, mu, Kx, Ky, grid, f (None or
    /// a list), layout, Q, Mx, My, share.
    #[new]
    fn new(
        f_main: f64,
        aperture: f64,
        shape: &str,
        channels: Vec<Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let shape = design::Aperture::from_name(shape).map_err(to_py)?;
        let specs = channels
            .iter()
            .map(channel_spec)
            .collect::<PyResult<Vec<_>>>()?;
        let inner = Design::new(f_main, aperture, shape, &specs).map_err(to_py)?;
        Ok(DesignCore { inner })
    }

    /// The camera as its two-channel design.
    #[staticmethod]
    fn from_camera(camera: &CameraCore) -> Self {
        DesignCore {
            inner: Design::from_camera(&camera.inner),
        }
    }

    /// The named design `name` (see `splitlf_core::presets`).
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        let inner = presets::preset(name).map_err(to_py)?;
        Ok(DesignCore { inner })
    }

    /// The preset names, in the documented order.
    #[staticmethod]
    fn presets() -> Vec<&'static str> {
        presets::PRESETS.to_vec()
    }

    /// Out-of-focus plane of channel `channel` (from 1): F L / (L − F).
    fn out_of_focus_depth(&self, channel: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (d, ch) = self.channel_arg(channel)?;
        Ok(optics::LensOptics::of_channel(d, ch, 0).out_of_focus_depth())
    }

    /// Microlens image radius of channel `channel` (from 1): R = D v / (2 L).
    fn image_radius(&self, channel: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (d, ch) = self.channel_arg(channel)?;
        Ok(optics::LensOptics::of_channel(d, ch, 0).image_radius())
    }

    /// The depth each lens type of channel `channel` (from 1) is focused on (b = 0), None
    /// where there is none (Ng's setting: focused on the main lens).
    fn focus_depths(&self, channel: &Bound<'_, PyAny>) -> PyResult<Vec<Option<f64>>> {
        let (d, ch) = self.channel_arg(channel)?;
        Ok((0..ch.types())
            .map(|t| optics::LensOptics::of_channel(d, ch, t).focus_depth())
            .collect())
    }

    /// (F, D, aperture) of the main lens.
    fn main_lens(&self) -> (f64, f64, &'static str) {
        let d = &self.inner;
        (d.f_main, d.aperture, d.shape.name())
    }

    /// Each channel's fields as validated (f resolved: Ng's setting as one value; the
    /// sensor layout's M_x, M_y resolved), as dicts with the constructor's keys plus "ng".
    fn channels<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner
            .channels
            .iter()
            .map(|c| {
                let d = PyDict::new(py);
                d.set_item("L", c.l)?;
                d.set_item("d", c.d)?;
                d.set_item("v", c.v)?;
                d.set_item("mu", c.mu)?;
                d.set_item("Kx", c.kx)?;
                d.set_item("Ky", c.ky)?;
                d.set_item("grid", c.grid.name())?;
                d.set_item("f", c.f.clone())?;
                d.set_item("ng", c.ng)?;
                d.set_item("layout", c.layout.name())?;
                let (q, mx, my) = match c.layout {
                    design::Layout::Ideal { q } => (Some(q), None, None),
                    design::Layout::Sensor { mx, my } => (None, Some(mx), Some(my)),
                };
                d.set_item("Q", q)?;
                d.set_item("Mx", mx)?;
                d.set_item("My", my)?;
                d.set_item("share", c.share)?;
                Ok(d)
            })
            .collect()
    }

    /// δ(z) = μ_1 z / L_1 (docs/model.md §9); z must be finite and > F.
    fn resolution_step(&self, z: f64) -> PyResult<f64> {
        optics::check_design_depths(self.inner.f_main, &[z]).map_err(to_py)?;
        Ok(self.inner.resolution_step(z))
    }
}

// ---- closed forms ------------------------------------------------------------------------

/// Closed-form curves (Eqs. 1–7) at n depths; two-row arrays (2, n), row 0 half 1.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct CurvesArrays {
    conjugate: Py<PyArray1<f64>>,
    main_blur: Py<PyArray2<f64>>,
    repetitions: Py<PyArray2<f64>>,
    microlens_blur: Py<PyArray2<f64>>,
    blur_px: Py<PyArray2<f64>>,
    conventional_px: Py<PyArray2<f64>>,
}

/// Closed-form curves (Eqs. 1–7) at every depth.
#[pyfunction]
#[pyo3(signature = (camera, z, n_threads=None))]
fn curves(
    py: Python<'_>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'_, f64>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<CurvesArrays> {
    let cam = camera.inner;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    // Validate and check the memory, then let NumPy allocate the outputs (fallibly) and
    // have the core write each element exactly once, in place, without the GIL.
    optics::check_depths(&cam, &zs).map_err(to_py)?;
    let n = zs.len();
    memory::check("curves", optics::curves_bytes(n)).map_err(to_py)?;
    let conjugate = empty::<f64, _>(py, &[n], "curves")?;
    let two = || empty::<f64, _>(py, &[2, n], "curves");
    let arrays = [two()?, two()?, two()?, two()?, two()?];
    {
        let mut zw = conjugate.readwrite();
        let mut w = arrays.each_ref().map(|a| a.readwrite());
        let [h, r, b, p, c] = w.each_mut().map(|a| a.as_slice_mut());
        let out = optics::CurvesOut {
            conjugate: zw.as_slice_mut().map_err(internal)?,
            main_blur: h.map_err(internal)?,
            repetitions: r.map_err(internal)?,
            microlens_blur: b.map_err(internal)?,
            blur_px: p.map_err(internal)?,
            conventional_px: c.map_err(internal)?,
        };
        run(py, || optics::curves_into(&cam, &zs, out, threads))?;
    }
    let [h, r, b, p, c] = arrays.map(Bound::unbind);
    Ok(CurvesArrays {
        conjugate: conjugate.unbind(),
        main_blur: h,
        repetitions: r,
        microlens_blur: b,
        blur_px: p,
        conventional_px: c,
    })
}

type Intervals = Vec<(f64, f64)>;

/// Sharp depth intervals (near, far) in mm of every configuration.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct DepthOfFieldIntervals {
    half1: Intervals,
    half2: Intervals,
    split: Intervals,
    conventional1: Intervals,
    conventional2: Intervals,
}

/// Sharp depth intervals of each half, the split sensor and the conventional cameras.
#[pyfunction]
#[pyo3(signature = (camera, threshold_px=optics::DEFAULT_THRESHOLD_PX))]
fn depth_of_field(camera: &CameraCore, threshold_px: f64) -> PyResult<DepthOfFieldIntervals> {
    let dof = optics::depth_of_field(&camera.inner, threshold_px).map_err(to_py)?;
    let [half1, half2] = dof.half;
    let [conventional1, conventional2] = dof.conventional;
    Ok(DepthOfFieldIntervals {
        half1,
        half2,
        split: dof.split,
        conventional1,
        conventional2,
    })
}

/// Sharp fraction in log depth over [lo, hi]: (half1, half2, split, conventional1, conventional2).
#[pyfunction]
#[pyo3(signature = (camera, threshold_px, lo, hi))]
fn sharp_fractions(camera: &CameraCore, threshold_px: f64, lo: f64, hi: f64) -> PyResult<[f64; 5]> {
    optics::sharp_fractions(&camera.inner, threshold_px, lo, hi).map_err(to_py)
}

/// Sharp fractions in log depth over [lo, hi] of every row of a design's depth of field:
/// (per (channel, type) row, per channel, union, per channel's conventional camera).
#[pyfunction]
#[pyo3(signature = (design, threshold_px, lo, hi))]
fn design_sharp_fractions(
    design: &DesignCore,
    threshold_px: f64,
    lo: f64,
    hi: f64,
) -> PyResult<optics::DesignFractions> {
    optics::design_sharp_fractions(&design.inner, threshold_px, lo, hi).map_err(to_py)
}

/// Closed-form curves of a design at n depths: per-channel arrays (C, n), per-type arrays
/// (R, n) in `splitlf_core::optics::type_rows` order, the union (n).
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct DesignCurvesArrays {
    conjugate: Py<PyArray1<f64>>,
    main_blur: Py<PyArray2<f64>>,
    repetitions: Py<PyArray2<f64>>,
    conventional_px: Py<PyArray2<f64>>,
    microlens_blur: Py<PyArray2<f64>>,
    blur_px: Py<PyArray2<f64>>,
    channel_blur_px: Py<PyArray2<f64>>,
    union_blur_px: Py<PyArray1<f64>>,
    /// (channel, type) of each per-type row, both from 0.
    rows: Vec<(usize, usize)>,
}

/// Closed-form curves (docs/model.md §2 per channel and lens type, §9) at every depth.
#[pyfunction]
#[pyo3(signature = (design, z, n_threads=None))]
fn design_curves(
    py: Python<'_>,
    design: &DesignCore,
    z: PyReadonlyArray1<'_, f64>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<DesignCurvesArrays> {
    let d = &design.inner;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    optics::check_design_depths(d.f_main, &zs).map_err(to_py)?;
    let n = zs.len();
    memory::check("curves", optics::design_curves_bytes(d, n)).map_err(to_py)?;
    let rows = optics::type_rows(d);
    let (c, r) = (d.channels.len(), rows.len());
    let one = || empty::<f64, _>(py, &[n], "curves");
    let grid = |k: usize| empty::<f64, _>(py, &[k, n], "curves");
    let (conjugate, union) = (one()?, one()?);
    let per_channel = [grid(c)?, grid(c)?, grid(c)?, grid(c)?];
    let per_type = [grid(r)?, grid(r)?];
    {
        let mut zw = conjugate.readwrite();
        let mut uw = union.readwrite();
        let mut cw = per_channel.each_ref().map(|a| a.readwrite());
        let mut tw = per_type.each_ref().map(|a| a.readwrite());
        let [h, rep, conv, chan] = cw.each_mut().map(|a| a.as_slice_mut());
        let [b, p] = tw.each_mut().map(|a| a.as_slice_mut());
        let out = optics::DesignCurvesOut {
            conjugate: zw.as_slice_mut().map_err(internal)?,
            main_blur: h.map_err(internal)?,
            repetitions: rep.map_err(internal)?,
            conventional_px: conv.map_err(internal)?,
            microlens_blur: b.map_err(internal)?,
            blur_px: p.map_err(internal)?,
            channel_blur_px: chan.map_err(internal)?,
            union_blur_px: uw.as_slice_mut().map_err(internal)?,
        };
        run(py, || optics::design_curves_into(d, &zs, out, threads))?;
    }
    let [h, rep, conv, chan] = per_channel.map(Bound::unbind);
    let [b, p] = per_type.map(Bound::unbind);
    Ok(DesignCurvesArrays {
        conjugate: conjugate.unbind(),
        main_blur: h,
        repetitions: rep,
        conventional_px: conv,
        microlens_blur: b,
        blur_px: p,
        channel_blur_px: chan,
        union_blur_px: union.unbind(),
        rows,
    })
}

/// Sharp depth intervals (near, far) in mm of a design: per (channel, type) row, per
/// channel, their union, and the conventional camera on each channel's array plane.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct DesignDepthOfFieldIntervals {
    types: Vec<Intervals>,
    channels: Vec<Intervals>,
    union: Intervals,
    conventional: Vec<Intervals>,
    /// (channel, type) of each entry of `types`, both from 0.
    rows: Vec<(usize, usize)>,
}

/// Depth of field of a design, every boundary in closed form.
#[pyfunction]
#[pyo3(signature = (design, threshold_px=optics::DEFAULT_THRESHOLD_PX))]
fn design_depth_of_field(
    design: &DesignCore,
    threshold_px: f64,
) -> PyResult<DesignDepthOfFieldIntervals> {
    let d = &design.inner;
    let dof = optics::design_depth_of_field(d, threshold_px).map_err(to_py)?;
    Ok(DesignDepthOfFieldIntervals {
        types: dof.types,
        channels: dof.channels,
        union: dof.union,
        conventional: dof.conventional,
        rows: optics::type_rows(d),
    })
}

// ---- samples -----------------------------------------------------------------------------

/// Genuinely new samples at m depths, rows (half 1, half 2, union).
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct NewSamplesArrays {
    distinct: Py<PyArray2<i64>>,
    distinct_2d: Py<PyArray2<i64>>,
    max_gap: Py<PyArray2<f64>>,
    /// Pixels along x that yield a sample (half 1, half 2, their sum).
    sampled: Py<PyArray1<i64>>,
}

fn sample_arg(sample: &str) -> PyResult<Sample> {
    Sample::from_name(sample).map_err(to_py)
}

/// Genuinely new samples at every depth (docs/model.md §6).
#[pyfunction]
#[pyo3(signature = (camera, z, tol=samples::DEFAULT_TOL, sample="chief", n_threads=None))]
fn new_samples(
    py: Python<'_>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'_, f64>,
    tol: f64,
    sample: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<NewSamplesArrays> {
    let cam = camera.inner;
    let mode = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    samples::check_new_samples(&cam, &zs, tol, mode, threads).map_err(to_py)?;
    let m = zs.len();
    let what = "new_samples";
    let distinct = empty::<i64, _>(py, &[3, m], what)?;
    let distinct_2d = empty::<i64, _>(py, &[3, m], what)?;
    let max_gap = empty::<f64, _>(py, &[3, m], what)?;
    let lit = {
        let mut d = distinct.readwrite();
        let mut d2 = distinct_2d.readwrite();
        let mut g = max_gap.readwrite();
        let out = samples::NewSamplesOut {
            distinct: as_u64(d.as_slice_mut().map_err(internal)?),
            distinct_2d: as_u64(d2.as_slice_mut().map_err(internal)?),
            max_gap: g.as_slice_mut().map_err(internal)?,
        };
        run(py, || {
            samples::new_samples_into(&cam, &zs, tol, mode, out, threads)
        })?
    };
    Ok(NewSamplesArrays {
        distinct: distinct.unbind(),
        distinct_2d: distinct_2d.unbind(),
        max_gap: max_gap.unbind(),
        sampled: lit.map(|x| x as i64).to_vec().into_pyarray(py).unbind(),
    })
}

/// Coincidence planes of one half sorted by depth, one column per field.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct PlaneColumns {
    #[pyo3(name = "N")]
    n: Py<PyArray1<i64>>,
    #[pyo3(name = "T")]
    t: Py<PyArray1<i64>>,
    side: Vec<&'static str>,
    conjugate: Py<PyArray1<f64>>,
    z: Py<PyArray1<f64>>,
    repetitions: Py<PyArray1<f64>>,
    new_samples_x: Py<PyArray1<i64>>,
    new_samples_y: Py<PyArray1<i64>>,
    new_samples: Py<PyArray1<i64>>,
    counted: Py<PyArray1<i64>>,
}

/// Coincidence planes of one half (docs/model.md §6), with Eqs. 8–9 and the brute-force count.
#[pyfunction]
#[pyo3(signature = (camera, half_, max_n=None, max_t=None, n_threads=None))]
fn coincidence_planes(
    py: Python<'_>,
    camera: &CameraCore,
    half_: &Bound<'_, PyAny>,
    max_n: Option<&Bound<'_, PyAny>>,
    max_t: Option<&Bound<'_, PyAny>>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<PlaneColumns> {
    let cam = camera.inner;
    let h = half_arg(half_)?;
    let ((n_given, n_text), t_given) = pair_args(max_n, max_t)?;
    let threads = threads_arg(n_threads)?;
    let (mn, mt) = (saturate(n_given), t_given.as_ref().map(|t| saturate(t.0)));
    let t_text = t_given.map(|t| t.1).unwrap_or_default();
    let p = run(py, || {
        samples::coincidence_planes(&cam, h, mn, mt, threads)
            .map_err(|e| pair_error(e, &n_text, &t_text))
    })?;
    plane_columns(py, &p)
}

/// max_n and max_t as given (any size), or their defaults: (value, text) each.
type PairArgs = ((i128, String), Option<(i128, String)>);

fn pair_args(
    max_n: Option<&Bound<'_, PyAny>>,
    max_t: Option<&Bound<'_, PyAny>>,
) -> PyResult<PairArgs> {
    let n = match max_n.filter(|o| !o.is_none()) {
        Some(o) => int_arg(o, "max_n")?,
        None => {
            let n = samples::DEFAULT_MAX_N;
            (n as i128, n.to_string())
        }
    };
    let t = match max_t.filter(|o| !o.is_none()) {
        Some(o) => Some(int_arg(o, "max_t")?),
        None => None,
    };
    Ok((n, t))
}

/// A max_n / max_t range error shows the value given.
fn pair_error(e: Error, n_text: &str, t_text: &str) -> Error {
    match &e {
        Error::InvalidParameter { name: "max_n", .. } => with_given(e, n_text),
        Error::InvalidParameter { name: "max_t", .. } => with_given(e, t_text),
        _ => e,
    }
}

fn plane_columns(py: Python<'_>, p: &[samples::CoincidencePlane]) -> PyResult<PlaneColumns> {
    let n = p.len();
    let what = "coincidence_planes";
    let int = |f: &dyn Fn(&samples::CoincidencePlane) -> u64| {
        filled::<i64, _>(py, &[n], what, p.iter().map(|x| f(x) as i64)).map(Bound::unbind)
    };
    let real = |f: &dyn Fn(&samples::CoincidencePlane) -> f64| {
        filled::<f64, _>(py, &[n], what, p.iter().map(f)).map(Bound::unbind)
    };
    Ok(PlaneColumns {
        n: int(&|x| x.n as u64)?,
        t: int(&|x| x.t as u64)?,
        side: p.iter().map(|x| x.side.name()).collect(),
        conjugate: real(&|x| x.conjugate)?,
        z: real(&|x| x.z)?,
        repetitions: real(&|x| x.repetitions)?,
        new_samples_x: int(&|x| x.new_samples_x)?,
        new_samples_y: int(&|x| x.new_samples_y)?,
        new_samples: int(&|x| x.new_samples)?,
        counted: int(&|x| x.counted)?,
    })
}

/// Coincidence planes of one channel of a design (rect grid, ideal layout, square
/// aperture; docs/model.md §6, §9), with Eqs. 8–9 and the brute-force count.
#[pyfunction]
#[pyo3(signature = (design, channel, max_n=None, max_t=None, n_threads=None))]
fn design_coincidence_planes(
    py: Python<'_>,
    design: &DesignCore,
    channel: &Bound<'_, PyAny>,
    max_n: Option<&Bound<'_, PyAny>>,
    max_t: Option<&Bound<'_, PyAny>>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<PlaneColumns> {
    let d = &design.inner;
    let ch = channel_arg(d, channel)?;
    let ((n_given, n_text), t_given) = pair_args(max_n, max_t)?;
    let threads = threads_arg(n_threads)?;
    let (mn, mt) = (saturate(n_given), t_given.as_ref().map(|t| saturate(t.0)));
    let t_text = t_given.map(|t| t.1).unwrap_or_default();
    let p = run(py, || {
        samples::design_coincidence_planes(d, ch, mn, mt, threads)
            .map_err(|e| pair_error(e, &n_text, &t_text))
    })?;
    plane_columns(py, &p)
}

/// Genuinely new samples of a design at m depths: (C + 1, m) arrays, rows the channels and
/// then their union.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct DesignSamplesArrays {
    distinct: Py<PyArray2<i64>>,
    max_gap: Py<PyArray2<f64>>,
    /// Pixels along x that yield a sample, per channel and in all (C + 1).
    sampled: Py<PyArray1<i64>>,
}

/// Distinct samples along x and max gaps of every channel of a design and of their union
/// at every depth (docs/model.md §6, §9).
#[pyfunction]
#[pyo3(signature = (design, z, tol=samples::DEFAULT_TOL, sample="chief", n_threads=None))]
fn design_new_samples(
    py: Python<'_>,
    design: &DesignCore,
    z: PyReadonlyArray1<'_, f64>,
    tol: f64,
    sample: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<DesignSamplesArrays> {
    let d = &design.inner;
    let mode = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    samples::check_design_new_samples(d, &zs, tol, mode, threads).map_err(to_py)?;
    let (rows, m) = (d.channels.len() + 1, zs.len());
    let what = "new_samples";
    let distinct = empty::<i64, _>(py, &[rows, m], what)?;
    let max_gap = empty::<f64, _>(py, &[rows, m], what)?;
    let sampled = {
        let mut dw = distinct.readwrite();
        let mut gw = max_gap.readwrite();
        let out = samples::DesignSamplesOut {
            distinct: as_u64(dw.as_slice_mut().map_err(internal)?),
            max_gap: gw.as_slice_mut().map_err(internal)?,
        };
        run(py, || {
            samples::design_new_samples_into(d, &zs, tol, mode, out, threads)
        })?
    };
    Ok(DesignSamplesArrays {
        distinct: distinct.unbind(),
        max_gap: max_gap.unbind(),
        sampled: filled::<i64, _>(py, &[rows], what, sampled.iter().map(|&x| x as i64))?.unbind(),
    })
}

/// Figures of merit of one design over depths (see `splitlf.sweep.METRICS`), followed by
/// its 2-D merits (`camera_metrics_2d`) when `window` is given.
#[pyfunction]
#[pyo3(signature = (camera, z, threshold_px=optics::DEFAULT_THRESHOLD_PX, tol=samples::DEFAULT_TOL, n_threads=None, window=None))]
fn figures_of_merit(
    py: Python<'_>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'_, f64>,
    threshold_px: f64,
    tol: f64,
    n_threads: Option<&Bound<'_, PyAny>>,
    window: Option<f64>,
) -> PyResult<Vec<f64>> {
    let cam = camera.inner;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    run_as(py, "depths", || {
        if let Some(w) = window {
            merit::check_merits_2d(tol, w)?;
        }
        let mut out = merit::figures_of_merit(&cam, &zs, threshold_px, tol, threads)?.to_vec();
        if let Some(w) = window {
            out.extend(merit::figures_of_merit_2d(&cam, &zs, tol, w, threads)?);
        }
        Ok(out)
    })
}

/// Names of the 2-D merits of a camera, in the order `figures_of_merit` appends them.
#[pyfunction]
fn camera_metrics_2d() -> Vec<String> {
    merit::camera_metrics_2d()
}

/// Names of a design's figures of merit, in the order of `design_figures_of_merit`; with
/// `merits_2d`, followed by the names of its 2-D merits.
#[pyfunction]
#[pyo3(signature = (design, merits_2d=false))]
fn design_metrics(design: &DesignCore, merits_2d: bool) -> Vec<String> {
    let c = design.inner.channels.len();
    let mut out = merit::design_metrics(c);
    if merits_2d {
        out.extend(merit::design_metrics_2d(c));
    }
    out
}

/// Figures of merit of a design over depths, per channel and union (see
/// `splitlf.sweep.design_metrics`), followed by its 2-D merits when `window` is given.
#[pyfunction]
#[pyo3(signature = (design, z, threshold_px=optics::DEFAULT_THRESHOLD_PX, tol=samples::DEFAULT_TOL, n_threads=None, window=None))]
fn design_figures_of_merit(
    py: Python<'_>,
    design: &DesignCore,
    z: PyReadonlyArray1<'_, f64>,
    threshold_px: f64,
    tol: f64,
    n_threads: Option<&Bound<'_, PyAny>>,
    window: Option<f64>,
) -> PyResult<Vec<f64>> {
    let d = &design.inner;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    run_as(py, "depths", || {
        if let Some(w) = window {
            merit::check_merits_2d(tol, w)?;
        }
        let mut out = merit::design_figures_of_merit(d, &zs, threshold_px, tol, threads)?;
        if let Some(w) = window {
            out.extend(merit::design_figures_of_merit_2d(d, &zs, tol, w, threads)?);
        }
        Ok(out)
    })
}

// ---- ray space ---------------------------------------------------------------------------

/// Integration polygons of n pixels of one half (or channel) along one axis.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct TraceArrays {
    vertices: Py<PyArray3<f64>>,
    n_vertices: Py<PyArray1<i64>>,
    area: Py<PyArray1<f64>>,
    centroid: Py<PyArray2<f64>>,
    lens: Py<PyArray1<i64>>,
    pixel: Py<PyArray1<i64>>,
    chief: Py<PyArray2<f64>>,
    lit: Py<PyArray1<bool>>,
    theta: Py<PyArray1<f64>>,
    #[pyo3(name = "type")]
    types: Py<PyArray1<i64>>,
}

/// Trace a line and hand its columns to NumPy.
fn trace_arrays(py: Python<'_>, line: &Line, threads: Option<usize>) -> PyResult<TraceArrays> {
    memory::check("trace", rayspace::trace_call_bytes(line.pixel_count())).map_err(to_py)?;
    let tr = run(py, || rayspace::trace_line_threads(line, threads))?;
    let n = tr.polygons.len();
    let what = "trace";
    let v = MAX_VERTICES;
    let verts = tr
        .polygons
        .iter()
        .flat_map(|p| p.v.iter().flatten().copied());
    Ok(TraceArrays {
        vertices: filled::<f64, _>(py, &[n, v, 2], what, verts)?.unbind(),
        n_vertices: filled::<i64, _>(py, &[n], what, tr.polygons.iter().map(|p| p.n as i64))?
            .unbind(),
        area: filled::<f64, _>(py, &[n], what, tr.area.iter().copied())?.unbind(),
        centroid: filled::<f64, _>(py, &[n, 2], what, tr.centroid.iter().flatten().copied())?
            .unbind(),
        lens: filled::<i64, _>(py, &[n], what, tr.lens.iter().map(|&x| x as i64))?.unbind(),
        pixel: filled::<i64, _>(py, &[n], what, tr.pixel.iter().map(|&x| x as i64))?.unbind(),
        chief: filled::<f64, _>(py, &[n, 2], what, tr.chief.iter().flatten().copied())?.unbind(),
        lit: filled::<bool, _>(py, &[n], what, tr.lit.iter().copied())?.unbind(),
        theta: filled::<f64, _>(py, &[n], what, tr.theta.iter().copied())?.unbind(),
        types: filled::<i64, _>(py, &[n], what, tr.types.iter().map(|&x| x as i64))?.unbind(),
    })
}

/// Integration polygons of every pixel of one half along one axis (docs/model.md §3–4).
#[pyfunction]
#[pyo3(signature = (camera, half, axis="x", n_threads=None))]
fn trace(
    py: Python<'_>,
    camera: &CameraCore,
    half: &Bound<'_, PyAny>,
    axis: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<TraceArrays> {
    let cam = camera.inner;
    let h = half_arg(half)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let threads = threads_arg(n_threads)?;
    trace_arrays(py, &Line::of_half(&cam, h, ax), threads)
}

/// Integration polygons of every pixel of one channel of a design along one axis (rect
/// grids; docs/model.md §3–4, §9).
#[pyfunction]
#[pyo3(signature = (design, channel, axis="x", n_threads=None))]
fn design_trace(
    py: Python<'_>,
    design: &DesignCore,
    channel: &Bound<'_, PyAny>,
    axis: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<TraceArrays> {
    let d = &design.inner;
    let ch = channel_arg(d, channel)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let threads = threads_arg(n_threads)?;
    let line = Line::of_channel(d, ch, ax).map_err(to_py)?;
    trace_arrays(py, &line, threads)
}

use rayspace::MAX_VERTICES;

/// Footprints of n pixels at m depths: (m, n) arrays; the kernel (m, n, 6) when asked.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct FootprintArrays {
    position: Py<PyArray2<f64>>,
    lo: Py<PyArray2<f64>>,
    hi: Py<PyArray2<f64>>,
    kernel_breaks: Option<Py<PyArray3<f64>>>,
    kernel_values: Option<Py<PyArray3<f64>>>,
}

/// Footprints of every pixel of one half along one axis at every depth (docs/model.md §5).
#[pyfunction]
#[pyo3(signature = (camera, z, half, axis="x", sample="centroid", kernel=false, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn footprints(
    py: Python<'_>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'_, f64>,
    half: &Bound<'_, PyAny>,
    axis: &str,
    sample: &str,
    kernel: bool,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<FootprintArrays> {
    let cam = camera.inner;
    let h = half_arg(half)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let s = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    footprint_arrays(py, &Line::of_half(&cam, h, ax), &zs, s, kernel, threads)
}

/// Footprints of every pixel of one channel of a design along one axis at every depth
/// (rect grids; docs/model.md §5, §9).
#[pyfunction]
#[pyo3(signature = (design, z, channel, axis="x", sample="centroid", kernel=false, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn design_footprints(
    py: Python<'_>,
    design: &DesignCore,
    z: PyReadonlyArray1<'_, f64>,
    channel: &Bound<'_, PyAny>,
    axis: &str,
    sample: &str,
    kernel: bool,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<FootprintArrays> {
    let d = &design.inner;
    let ch = channel_arg(d, channel)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let s = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    let line = Line::of_channel(d, ch, ax).map_err(to_py)?;
    footprint_arrays(py, &line, &zs, s, kernel, threads)
}

/// Validate, let NumPy allocate the outputs (fallibly) and have the core write the
/// footprints of a line straight into them without the GIL.
fn footprint_arrays(
    py: Python<'_>,
    line: &Line,
    zs: &[f64],
    s: Sample,
    kernel: bool,
    threads: Option<usize>,
) -> PyResult<FootprintArrays> {
    let (m, n) = rayspace::check_footprints_line(line, zs, kernel, threads).map_err(to_py)?;
    let what = "footprints";
    let position = empty::<f64, _>(py, &[m, n], what)?;
    let lo = empty::<f64, _>(py, &[m, n], what)?;
    let hi = empty::<f64, _>(py, &[m, n], what)?;
    let k = if kernel {
        let dims = [m, n, MAX_VERTICES];
        Some((
            empty::<f64, _>(py, &dims, what)?,
            empty::<f64, _>(py, &dims, what)?,
        ))
    } else {
        None
    };
    {
        let mut pw = position.readwrite();
        let mut lw = lo.readwrite();
        let mut hw = hi.readwrite();
        let mut kw = k.as_ref().map(|(b, v)| (b.readwrite(), v.readwrite()));
        let ks = match kw.as_mut() {
            Some((b, v)) => Some((
                b.as_slice_mut().map_err(internal)?,
                v.as_slice_mut().map_err(internal)?,
            )),
            None => None,
        };
        let out = rayspace::FootprintsOut {
            position: pw.as_slice_mut().map_err(internal)?,
            lo: lw.as_slice_mut().map_err(internal)?,
            hi: hw.as_slice_mut().map_err(internal)?,
            kernel: ks,
        };
        run(py, || {
            rayspace::footprints_line_into(line, zs, s, out, threads)
        })?;
    }
    let (kb, kv) = match k {
        Some((b, v)) => (Some(b.unbind()), Some(v.unbind())),
        None => (None, None),
    };
    Ok(FootprintArrays {
        position: position.unbind(),
        lo: lo.unbind(),
        hi: hi.unbind(),
        kernel_breaks: kb,
        kernel_values: kv,
    })
}

/// Object-space sample positions (X, Y), each (Ky Q, Kx Q), of one half on one plane.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct SampleGridArrays {
    #[pyo3(name = "X")]
    x: Py<PyArray2<f64>>,
    #[pyo3(name = "Y")]
    y: Py<PyArray2<f64>>,
}

/// Sample positions of every pixel of one half on the plane at depth z; NaN where a pixel
/// yields no sample.
#[pyfunction]
#[pyo3(signature = (camera, z, half, sample="chief", n_threads=None))]
fn sample_grid(
    py: Python<'_>,
    camera: &CameraCore,
    z: f64,
    half: &Bound<'_, PyAny>,
    sample: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<SampleGridArrays> {
    let cam = camera.inner;
    let h = half_arg(half)?;
    let s = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let (rows, cols) = rayspace::check_sample_grid(&cam, z, threads).map_err(to_py)?;
    let gx = empty::<f64, _>(py, &[rows, cols], "sample_grid")?;
    let gy = empty::<f64, _>(py, &[rows, cols], "sample_grid")?;
    {
        let mut xw = gx.readwrite();
        let mut yw = gy.readwrite();
        let xs = xw.as_slice_mut().map_err(internal)?;
        let ys = yw.as_slice_mut().map_err(internal)?;
        run(py, || {
            rayspace::sample_grid_into(&cam, z, h, s, xs, ys, threads)
        })?;
    }
    Ok(SampleGridArrays {
        x: gx.unbind(),
        y: gy.unbind(),
    })
}

/// Sample positions of every pixel of one channel of a design (rect grid) on the plane at
/// depth z; NaN where a pixel yields no sample.
#[pyfunction]
#[pyo3(signature = (design, z, channel, sample="chief", n_threads=None))]
fn design_sample_grid(
    py: Python<'_>,
    design: &DesignCore,
    z: f64,
    channel: &Bound<'_, PyAny>,
    sample: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<SampleGridArrays> {
    let d = &design.inner;
    let ch = channel_arg(d, channel)?;
    let s = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let (lx, ly) = rayspace::check_design_sample_grid(d, ch, z, s, threads).map_err(to_py)?;
    let (rows, cols) = (ly.pixel_count() as usize, lx.pixel_count() as usize);
    let gx = empty::<f64, _>(py, &[rows, cols], "sample_grid")?;
    let gy = empty::<f64, _>(py, &[rows, cols], "sample_grid")?;
    {
        let mut xw = gx.readwrite();
        let mut yw = gy.readwrite();
        let xs = xw.as_slice_mut().map_err(internal)?;
        let ys = yw.as_slice_mut().map_err(internal)?;
        run(py, || {
            rayspace::design_sample_grid_into(d, ch, z, s, xs, ys, threads)
        })?;
    }
    Ok(SampleGridArrays {
        x: gx.unbind(),
        y: gy.unbind(),
    })
}

// ---- 2-D samples (docs/model.md §9) -------------------------------------------------------

/// Every pixel of one channel (rows y, columns x of its pixel grid): chief sample (X, Y)
/// [mm] (NaN where unlit), lit flag, lens (j, k) and lens type.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct ChiefSampleArrays {
    #[pyo3(name = "X")]
    x: Py<PyArray2<f64>>,
    #[pyo3(name = "Y")]
    y: Py<PyArray2<f64>>,
    lit: Py<PyArray2<bool>>,
    lens: Py<PyArray3<i64>>,
    #[pyo3(name = "type")]
    types: Py<PyArray2<i64>>,
}

/// A channel number (an int from 1, never a bool), checked against the design.
fn channel_arg(design: &Design, obj: &Bound<'_, PyAny>) -> PyResult<i64> {
    let (v, text) = int_arg(obj, "channel")?;
    let n = saturate(v);
    design.channel(n).map_err(|e| to_py(with_given(e, &text)))?;
    Ok(n)
}

/// Chief samples of every pixel of channel `channel` on the plane at depth z (of the pixel
/// rows [start, stop) only when `rows` is given).
#[pyfunction]
#[pyo3(signature = (design, channel, z, n_threads=None, rows=None))]
fn chief_samples(
    py: Python<'_>,
    design: &DesignCore,
    channel: &Bound<'_, PyAny>,
    z: f64,
    n_threads: Option<&Bound<'_, PyAny>>,
    rows: Option<(i64, i64)>,
) -> PyResult<ChiefSampleArrays> {
    let d = design.inner.clone();
    let ch = channel_arg(&d, channel)?;
    let threads = threads_arg(n_threads)?;
    let window = rows;
    let (_, _, rows, cols) =
        samples2d::check_chief_rows(&d, ch, z, threads, window).map_err(to_py)?;
    let what = "chief_samples";
    let gx = empty::<f64, _>(py, &[rows, cols], what)?;
    let gy = empty::<f64, _>(py, &[rows, cols], what)?;
    let lit = empty::<bool, _>(py, &[rows, cols], what)?;
    let lens = empty::<i64, _>(py, &[rows, cols, 2], what)?;
    let types = empty::<i64, _>(py, &[rows, cols], what)?;
    {
        let mut xw = gx.readwrite();
        let mut yw = gy.readwrite();
        let mut lw = lit.readwrite();
        let mut jw = lens.readwrite();
        let mut tw = types.readwrite();
        let out = samples2d::ChiefSamplesOut {
            x: xw.as_slice_mut().map_err(internal)?,
            y: yw.as_slice_mut().map_err(internal)?,
            lit: lw.as_slice_mut().map_err(internal)?,
            lens: jw.as_slice_mut().map_err(internal)?,
            types: tw.as_slice_mut().map_err(internal)?,
        };
        run(py, || {
            samples2d::chief_samples_rows_into(&d, ch, z, window, out, threads)
        })?;
    }
    Ok(ChiefSampleArrays {
        x: gx.unbind(),
        y: gy.unbind(),
        lit: lit.unbind(),
        lens: lens.unbind(),
        types: types.unbind(),
    })
}

/// Distinct 2-D samples at one depth, one entry per row (channels, then the union).
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct Samples2dArrays {
    /// One (n_k, 2) array [X, Y] per row: the representatives inside the central field.
    samples: Py<PyTuple>,
    distinct: Py<PyArray1<i64>>,
    covering_radius: Py<PyArray1<f64>>,
    covering_radius_mm: Py<PyArray1<f64>>,
}

/// Distinct samples and covering radius of every channel and of the union at depth z.
#[pyfunction]
#[pyo3(signature = (design, z, tol, window))]
fn samples_2d(
    py: Python<'_>,
    design: &DesignCore,
    z: f64,
    tol: f64,
    window: f64,
) -> PyResult<Samples2dArrays> {
    let d = design.inner.clone();
    let r = run(py, || samples2d::samples_2d(&d, z, tol, window))?;
    let what = "samples_2d";
    let arrays = r
        .samples
        .iter()
        .map(|s| filled::<f64, Ix2>(py, &[s.len(), 2], what, s.iter().flatten().copied()))
        .collect::<PyResult<Vec<_>>>()?;
    let n = r.distinct.len();
    Ok(Samples2dArrays {
        samples: PyTuple::new(py, arrays)?.unbind(),
        distinct: filled::<i64, _>(py, &[n], what, r.distinct.iter().map(|&v| v as i64))?.unbind(),
        covering_radius: filled::<f64, _>(py, &[n], what, r.covering_radius.iter().copied())?
            .unbind(),
        covering_radius_mm: filled::<f64, _>(py, &[n], what, r.covering_radius_mm.iter().copied())?
            .unbind(),
    })
}

/// Distinct 2-D samples and covering radii at m depths, (n_channels + 1, m) arrays.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct CoverageArrays {
    distinct: Py<PyArray2<i64>>,
    covering_radius: Py<PyArray2<f64>>,
    covering_radius_mm: Py<PyArray2<f64>>,
}

/// Distinct 2-D samples and covering radius of every channel and of the union at every
/// depth, parallel over depths.
#[pyfunction]
#[pyo3(signature = (design, z, tol, window, n_threads=None))]
fn coverage(
    py: Python<'_>,
    design: &DesignCore,
    z: PyReadonlyArray1<'_, f64>,
    tol: f64,
    window: f64,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<CoverageArrays> {
    let d = design.inner.clone();
    let threads = threads_arg(n_threads)?;
    let zs = as_slice(&z)?;
    let (rows, m) = (d.channels.len() + 1, zs.len());
    let what = "coverage";
    let distinct = empty::<i64, _>(py, &[rows, m], what)?;
    let radius = empty::<f64, _>(py, &[rows, m], what)?;
    let radius_mm = empty::<f64, _>(py, &[rows, m], what)?;
    {
        let mut dw = distinct.readwrite();
        let mut rw = radius.readwrite();
        let mut mw = radius_mm.readwrite();
        let out = samples2d::CoverageOut {
            distinct: as_u64(dw.as_slice_mut().map_err(internal)?),
            covering_radius: rw.as_slice_mut().map_err(internal)?,
            covering_radius_mm: mw.as_slice_mut().map_err(internal)?,
        };
        run(py, || {
            samples2d::coverage_into(&d, &zs, tol, window, out, threads)
        })?;
    }
    Ok(CoverageArrays {
        distinct: distinct.unbind(),
        covering_radius: radius.unbind(),
        covering_radius_mm: radius_mm.unbind(),
    })
}

// ---- simulation --------------------------------------------------------------------------

/// Widest pixel kernel (hi − lo, mm in object-space X) of a source at depth z.
#[pyfunction]
#[pyo3(signature = (camera, z, source, n_threads=None))]
fn kernel_support(
    py: Python<'_>,
    camera: &CameraCore,
    z: f64,
    source: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<f64> {
    let cam = camera.inner;
    let src = Source::from_name(source).map_err(to_py)?;
    let threads = threads_arg(n_threads)?;
    run(py, || simulate::kernel_support(&cam, z, src, threads))
}

/// A design's source from its name ("channel<c>", "conventional<c>").
fn design_source(design: &Design, source: &str) -> PyResult<Pixels> {
    let src = DesignSource::from_name(design, source).map_err(to_py)?;
    Pixels::of_design(design, src).map_err(to_py)
}

/// Widest pixel kernel (hi − lo, mm in object-space X) of a design's source at depth z.
#[pyfunction]
#[pyo3(signature = (design, z, source, n_threads=None))]
fn design_kernel_support(
    py: Python<'_>,
    design: &DesignCore,
    z: f64,
    source: &str,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<f64> {
    let px = design_source(&design.inner, source)?;
    let threads = threads_arg(n_threads)?;
    run(py, || simulate::kernel_support_of(&px, z, threads))
}

/// A system matrix in CSR form (SciPy's `csr_matrix((data, indices, indptr), shape)`) and
/// the pixel each row stands for.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct SystemMatrixArrays {
    indptr: Py<PyArray1<i64>>,
    indices: Py<PyArray1<i64>>,
    data: Py<PyArray1<f64>>,
    pixels: Py<PyArray1<i64>>,
    shape: (usize, usize),
}

/// System matrix of a source at depth z on the grid (origin, step, n_cells), rows the
/// pixels whose kernels lie in [field_lo, field_hi].
#[pyfunction]
#[pyo3(signature = (camera, z, source, origin, step, n_cells, field_lo, field_hi, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn system_matrix(
    py: Python<'_>,
    camera: &CameraCore,
    z: f64,
    source: &str,
    origin: f64,
    step: f64,
    n_cells: usize,
    field_lo: f64,
    field_hi: f64,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<SystemMatrixArrays> {
    let px = Pixels::of_camera(&camera.inner, Source::from_name(source).map_err(to_py)?);
    system_arrays(
        py,
        &px,
        z,
        (origin, step, n_cells),
        (field_lo, field_hi),
        n_threads,
    )
}

/// System matrix of a design's source ("channel<c>", "conventional<c>") at depth z on the
/// grid (origin, step, n_cells), rows the pixels whose kernels lie in [field_lo, field_hi].
#[pyfunction]
#[pyo3(signature = (design, z, source, origin, step, n_cells, field_lo, field_hi, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn design_system_matrix(
    py: Python<'_>,
    design: &DesignCore,
    z: f64,
    source: &str,
    origin: f64,
    step: f64,
    n_cells: usize,
    field_lo: f64,
    field_hi: f64,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<SystemMatrixArrays> {
    let px = design_source(&design.inner, source)?;
    system_arrays(
        py,
        &px,
        z,
        (origin, step, n_cells),
        (field_lo, field_hi),
        n_threads,
    )
}

fn system_arrays(
    py: Python<'_>,
    px: &Pixels,
    z: f64,
    (origin, step, n_cells): (f64, f64, usize),
    field: (f64, f64),
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<SystemMatrixArrays> {
    let grid = Grid::new(origin, step, n_cells).map_err(to_py)?;
    let threads = threads_arg(n_threads)?;
    let sys = run(py, || {
        simulate::system_matrix_of(px, z, grid, field, threads)
    })?;
    let m = sys.matrix;
    let px = sys.pixels.iter().map(|&p| p as i64);
    Ok(SystemMatrixArrays {
        indptr: m.indptr.into_pyarray(py).unbind(),
        indices: m.indices.into_pyarray(py).unbind(),
        data: m.data.into_pyarray(py).unbind(),
        pixels: filled::<i64, _>(py, &[sys.pixels.len()], "system_matrix", px)?.unbind(),
        shape: (m.rows, m.cols),
    })
}

/// Noise-free pixel values (n_tex, n_pix) and the pixels they belong to.
#[pyclass(frozen, get_all, module = "splitlf._native")]
struct RenderArrays {
    values: Py<PyArray2<f64>>,
    pixels: Py<PyArray1<i64>>,
}

/// Noise-free pixel values of a source at depth z for textures (n_tex, n_cells) constant on
/// each cell of the grid.
#[pyfunction]
#[pyo3(signature = (camera, z, source, origin, step, field_lo, field_hi, textures, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn render(
    py: Python<'_>,
    camera: &CameraCore,
    z: f64,
    source: &str,
    origin: f64,
    step: f64,
    field_lo: f64,
    field_hi: f64,
    textures: PyReadonlyArray2<'_, f64>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderArrays> {
    let px = Pixels::of_camera(&camera.inner, Source::from_name(source).map_err(to_py)?);
    render_arrays(
        py,
        &px,
        z,
        (origin, step),
        (field_lo, field_hi),
        textures,
        n_threads,
    )
}

/// Noise-free pixel values of a design's source ("channel<c>", "conventional<c>") at depth
/// z for textures (n_tex, n_cells) constant on each cell of the grid.
#[pyfunction]
#[pyo3(signature = (design, z, source, origin, step, field_lo, field_hi, textures, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn design_render(
    py: Python<'_>,
    design: &DesignCore,
    z: f64,
    source: &str,
    origin: f64,
    step: f64,
    field_lo: f64,
    field_hi: f64,
    textures: PyReadonlyArray2<'_, f64>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderArrays> {
    let px = design_source(&design.inner, source)?;
    render_arrays(
        py,
        &px,
        z,
        (origin, step),
        (field_lo, field_hi),
        textures,
        n_threads,
    )
}

fn render_arrays(
    py: Python<'_>,
    px: &Pixels,
    z: f64,
    (origin, step): (f64, f64),
    field: (f64, f64),
    textures: PyReadonlyArray2<'_, f64>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderArrays> {
    let (n_tex, n_cells) = textures.as_array().dim();
    let grid = Grid::new(origin, step, n_cells).map_err(to_py)?;
    let threads = threads_arg(n_threads)?;
    let flat: Cow<'_, [f64]> = match textures.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => {
            let view = textures.as_array();
            let mut v = memory::try_with_capacity("contiguous copy of textures", view.len())
                .map_err(to_py)?;
            v.extend(view.iter().copied());
            Cow::Owned(v)
        }
    };
    let (values, pixels) = run(py, || {
        simulate::render_of(px, z, grid, field, &flat, threads)
    })?;
    let n_pix = pixels.len();
    let values = numpy::ndarray::Array2::from_shape_vec((n_tex, n_pix), values)
        .map_err(internal)?
        .into_pyarray(py);
    let px = pixels.iter().map(|&p| p as i64);
    Ok(RenderArrays {
        values: values.unbind(),
        pixels: filled::<i64, _>(py, &[n_pix], "render", px)?.unbind(),
    })
}

/// Bytes the memory guard lets one call allocate now (see `splitlf_core::memory`).
#[pyfunction]
fn available_memory() -> u128 {
    memory::available()
}

/// Load NumPy's C API and rust-numpy's borrow-checking API now, at import: both are
/// loaded on first use by running Python code, and rust-numpy panics when that code
/// fails, e.g. when a Ctrl-C pressed during a process's first long call is raised there
/// as the call makes its first array ("Failed to access NumPy array API capsule").
fn numpy_ready(py: Python<'_>) -> PyResult<()> {
    // The Python side first, its errors raised as they are (an import error, a pending
    // KeyboardInterrupt) rather than as a panic of rust-numpy.
    numpy::get_array_module(py)?;
    py.import("numpy")?.getattr("__version__")?;
    let a = PyArray1::<f64>::zeros(py, 1, false);
    drop(a.readwrite());
    drop(a.readonly());
    Ok(())
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    numpy_ready(m.py())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Limits and defaults: the single source for the Python layer and the CLI.
    m.add("MAX_THREADS", parallel::MAX_THREADS)?;
    m.add("MAX_POOLS", parallel::MAX_POOLS)?;
    m.add("MAX_Q", camera::MAX_Q)?;
    m.add("MAX_K", camera::MAX_K)?;
    m.add("DEFAULT_TOL", samples::DEFAULT_TOL)?;
    m.add("DEFAULT_THRESHOLD_PX", optics::DEFAULT_THRESHOLD_PX)?;
    m.add("DEFAULT_MAX_N", samples::DEFAULT_MAX_N)?;
    m.add("MAX_PAIRS", samples::MAX_PAIRS)?;
    m.add("MAX_SAMPLES_PER_AXIS", samples::MAX_SAMPLES_PER_AXIS)?;
    m.add("MAX_COINCIDENCE_WORK", samples::MAX_COINCIDENCE_WORK)?;
    m.add("MAX_CELLS", simulate::MAX_CELLS)?;
    m.add_class::<CameraCore>()?;
    m.add_class::<DesignCore>()?;
    m.add("MAX_CHANNELS", design::MAX_CHANNELS)?;
    m.add("MAX_TYPES", design::MAX_TYPES)?;
    m.add("MAX_M", design::MAX_M)?;
    m.add("DEFAULT_WINDOW", samples2d::DEFAULT_WINDOW)?;
    m.add("MAX_TOL_2D", samples2d::MAX_TOL_2D)?;
    m.add("MAX_COVERAGE_WORK", samples2d::MAX_COVERAGE_WORK)?;
    m.add_class::<CurvesArrays>()?;
    m.add_class::<DepthOfFieldIntervals>()?;
    m.add_class::<DesignCurvesArrays>()?;
    m.add_class::<DesignDepthOfFieldIntervals>()?;
    m.add_class::<NewSamplesArrays>()?;
    m.add_class::<DesignSamplesArrays>()?;
    m.add_class::<PlaneColumns>()?;
    m.add_class::<TraceArrays>()?;
    m.add_class::<FootprintArrays>()?;
    m.add_class::<SampleGridArrays>()?;
    m.add_class::<SystemMatrixArrays>()?;
    m.add_class::<RenderArrays>()?;
    m.add_class::<ChiefSampleArrays>()?;
    m.add_class::<Samples2dArrays>()?;
    m.add_class::<CoverageArrays>()?;
    m.add_function(wrap_pyfunction!(curves, m)?)?;
    m.add_function(wrap_pyfunction!(depth_of_field, m)?)?;
    m.add_function(wrap_pyfunction!(sharp_fractions, m)?)?;
    m.add_function(wrap_pyfunction!(design_curves, m)?)?;
    m.add_function(wrap_pyfunction!(design_depth_of_field, m)?)?;
    m.add_function(wrap_pyfunction!(new_samples, m)?)?;
    m.add_function(wrap_pyfunction!(coincidence_planes, m)?)?;
    m.add_function(wrap_pyfunction!(figures_of_merit, m)?)?;
    m.add_function(wrap_pyfunction!(design_figures_of_merit, m)?)?;
    m.add_function(wrap_pyfunction!(design_metrics, m)?)?;
    m.add_function(wrap_pyfunction!(camera_metrics_2d, m)?)?;
    m.add_function(wrap_pyfunction!(trace, m)?)?;
    m.add_function(wrap_pyfunction!(footprints, m)?)?;
    m.add_function(wrap_pyfunction!(sample_grid, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_support, m)?)?;
    m.add_function(wrap_pyfunction!(system_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(design_kernel_support, m)?)?;
    m.add_function(wrap_pyfunction!(design_system_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(design_render, m)?)?;
    m.add_function(wrap_pyfunction!(available_memory, m)?)?;
    m.add_function(wrap_pyfunction!(chief_samples, m)?)?;
    m.add_function(wrap_pyfunction!(samples_2d, m)?)?;
    m.add_function(wrap_pyfunction!(coverage, m)?)?;
    m.add_function(wrap_pyfunction!(design_new_samples, m)?)?;
    m.add_function(wrap_pyfunction!(design_coincidence_planes, m)?)?;
    m.add_function(wrap_pyfunction!(design_trace, m)?)?;
    m.add_function(wrap_pyfunction!(design_sharp_fractions, m)?)?;
    m.add_function(wrap_pyfunction!(design_footprints, m)?)?;
    m.add_function(wrap_pyfunction!(design_sample_grid, m)?)?;
    Ok(())
}
