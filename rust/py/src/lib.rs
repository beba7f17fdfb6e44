//! PyO3 bindings of splitlf-core. Nothing physical lives here: argument conversion,
//! GIL release around the core, and mapping of core errors to Python exceptions.

use std::borrow::Cow;

use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use splitlf_core::rayspace::{self, Sample};
use splitlf_core::samples::{self, SampleMode};
use splitlf_core::simulate::{self, Grid, Source};
use splitlf_core::{optics, Camera, Error, Half};

/// Core errors are all bad input: `ValueError` with the core's message (which names the
/// parameter, its value and the allowed range).
fn to_py(e: Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn internal(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("internal error: {e}"))
}

fn half(n: i64) -> PyResult<Half> {
    Half::from_number(n).map_err(to_py)
}

/// Borrow a 1-D float64 array as a slice, copying only when it is not contiguous.
fn as_slice<'a>(a: &'a PyReadonlyArray1<'_, f64>) -> Cow<'a, [f64]> {
    match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().to_vec()),
    }
}

/// Row-major (rows, n) array from a vector, without copying.
fn rows<'py, T: numpy::Element>(
    py: Python<'py>,
    v: Vec<T>,
    n_rows: usize,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let n = v.len() / n_rows.max(1);
    shaped(py, (n_rows, n), v)
}

/// An n-D array of `shape` from a vector, without copying.
fn shaped<'py, T, D, Sh>(
    py: Python<'py>,
    shape: Sh,
    v: Vec<T>,
) -> PyResult<Bound<'py, numpy::PyArray<T, D>>>
where
    T: numpy::Element,
    D: numpy::ndarray::Dimension,
    Sh: numpy::ndarray::ShapeBuilder<Dim = D>,
{
    let a = numpy::ndarray::Array::from_shape_vec(shape, v)
        .map_err(|e| PyValueError::new_err(format!("internal shape error: {e}")))?;
    Ok(a.into_pyarray(py))
}

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

    fn array_plane(&self, half_: i64) -> PyResult<f64> {
        Ok(self.inner.array_plane(half(half_)?))
    }

    fn out_of_focus_depth(&self, half_: i64) -> PyResult<f64> {
        Ok(self.inner.out_of_focus_depth(half(half_)?))
    }

    fn image_radius(&self, half_: i64) -> PyResult<f64> {
        Ok(self.inner.image_radius(half(half_)?))
    }

    fn lit_pixels(&self, half_: i64) -> PyResult<u32> {
        Ok(self.inner.lit_pixels(half(half_)?))
    }

    fn ng_focal_length(&self, half_: i64) -> PyResult<f64> {
        let h = half(half_)?;
        Ok(splitlf_core::camera::ng_focal_length(
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

type CurveArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
);

/// Closed-form curves (Eqs. 1–7) at every depth:
/// (conjugate, main_blur, repetitions, microlens_blur, blur_px, conventional_px).
#[pyfunction]
#[pyo3(signature = (camera, z, n_threads=None))]
fn curves<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'py, f64>,
    n_threads: Option<usize>,
) -> PyResult<CurveArrays<'py>> {
    let cam = camera.inner;
    let zs = as_slice(&z);
    // Validate, then let NumPy allocate the outputs (its allocator asks for huge pages) and
    // have the core write each element exactly once, in place, without the GIL.
    optics::check_depths(&cam, &zs).map_err(to_py)?;
    let n = zs.len();
    // SAFETY: uninitialised arrays; `curves_into` writes every element (it checks the
    // lengths first, and on error the arrays are dropped without being read).
    let conjugate = unsafe { PyArray1::<f64>::new(py, [n], false) };
    let two = || unsafe { PyArray2::<f64>::new(py, [2, n], false) };
    let arrays = [two(), two(), two(), two(), two()];
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
        py.detach(|| optics::curves_into(&cam, &zs, out, n_threads))
            .map_err(to_py)?;
    }
    let [h, r, b, p, c] = arrays;
    Ok((conjugate, h, r, b, p, c))
}

type Intervals = Vec<(f64, f64)>;

/// Sharp depth intervals: (half1, half2, split, conventional1, conventional2).
#[pyfunction]
#[pyo3(signature = (camera, threshold_px=0.5))]
fn depth_of_field(
    camera: &CameraCore,
    threshold_px: f64,
) -> PyResult<(Intervals, Intervals, Intervals, Intervals, Intervals)> {
    let dof = optics::depth_of_field(&camera.inner, threshold_px).map_err(to_py)?;
    let [h1, h2] = dof.half;
    let [c1, c2] = dof.conventional;
    Ok((h1, h2, dof.split, c1, c2))
}

/// Sharp fraction in log depth over [lo, hi]: (half1, half2, split, conventional1, conventional2).
#[pyfunction]
#[pyo3(signature = (camera, threshold_px, lo, hi))]
fn sharp_fractions(camera: &CameraCore, threshold_px: f64, lo: f64, hi: f64) -> PyResult<[f64; 5]> {
    optics::sharp_fractions(&camera.inner, threshold_px, lo, hi).map_err(to_py)
}

/// Counts are returned as int64 (they are far below 2^63: the core caps K Q per axis).
fn to_i64(v: Vec<u64>) -> Vec<i64> {
    v.into_iter().map(|x| x as i64).collect()
}

type NewSampleArrays<'py> = (
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
);

/// Genuinely new samples at every depth (docs/model.md §6):
/// (distinct (3, m), distinct_2d (3, m), max_gap (3, m), lit (3,)).
#[pyfunction]
#[pyo3(signature = (camera, z, tol=1e-6, sample="chief", n_threads=None))]
fn new_samples<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'py, f64>,
    tol: f64,
    sample: &str,
    n_threads: Option<usize>,
) -> PyResult<NewSampleArrays<'py>> {
    let cam = camera.inner;
    let mode = SampleMode::parse(sample).map_err(to_py)?;
    let zs = as_slice(&z);
    let out = py
        .detach(|| samples::new_samples(&cam, &zs, tol, mode, n_threads))
        .map_err(to_py)?;
    Ok((
        rows(py, to_i64(out.distinct), 3)?,
        rows(py, to_i64(out.distinct_2d), 3)?,
        rows(py, out.max_gap, 3)?,
        to_i64(out.lit.to_vec()).into_pyarray(py),
    ))
}

type PlaneColumns<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Vec<&'static str>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
);

/// Coincidence planes of one half, sorted by depth, as columns:
/// (N, T, side, conjugate, z, repetitions, new_samples_x, new_samples_y, new_samples, counted).
#[pyfunction]
#[pyo3(signature = (camera, half_, max_n=4, max_t=None, n_threads=None))]
fn coincidence_planes<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    half_: i64,
    max_n: i64,
    max_t: Option<i64>,
    n_threads: Option<usize>,
) -> PyResult<PlaneColumns<'py>> {
    let cam = camera.inner;
    let h = half(half_)?;
    let p = py
        .detach(|| samples::coincidence_planes(&cam, h, max_n, max_t, n_threads))
        .map_err(to_py)?;
    let int = |f: &dyn Fn(&samples::CoincidencePlane) -> u64| -> Vec<i64> {
        p.iter().map(|x| f(x) as i64).collect()
    };
    let real =
        |f: &dyn Fn(&samples::CoincidencePlane) -> f64| -> Vec<f64> { p.iter().map(f).collect() };
    Ok((
        int(&|x| x.n as u64).into_pyarray(py),
        int(&|x| x.t as u64).into_pyarray(py),
        p.iter().map(|x| x.side.name()).collect(),
        real(&|x| x.conjugate).into_pyarray(py),
        real(&|x| x.z).into_pyarray(py),
        real(&|x| x.repetitions).into_pyarray(py),
        int(&|x| x.new_samples_x).into_pyarray(py),
        int(&|x| x.new_samples_y).into_pyarray(py),
        int(&|x| x.new_samples).into_pyarray(py),
        int(&|x| x.counted).into_pyarray(py),
    ))
}

/// Figures of merit of one design over depths (see `splitlf.sweep.METRICS`).
#[pyfunction]
#[pyo3(signature = (camera, z, threshold_px=0.5, tol=1e-6, n_threads=None))]
fn figures_of_merit(
    py: Python<'_>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'_, f64>,
    threshold_px: f64,
    tol: f64,
    n_threads: Option<usize>,
) -> PyResult<[f64; splitlf_core::merit::N_MERITS]> {
    let cam = camera.inner;
    let zs = as_slice(&z);
    py.detach(|| splitlf_core::merit::figures_of_merit(&cam, &zs, threshold_px, tol, n_threads))
        .map_err(to_py)
}

type TraceArrays<'py> = (
    Bound<'py, numpy::PyArray3<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<bool>>,
);

/// Integration polygons of every pixel of one half along one axis (docs/model.md §3–4):
/// (vertices (n, 6, 2), n_vertices, area, centroid (n, 2), lens, pixel, chief (n, 2), lit).
#[pyfunction]
#[pyo3(signature = (camera, half, axis="x"))]
fn trace<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    half: i64,
    axis: &str,
) -> PyResult<TraceArrays<'py>> {
    let cam = camera.inner;
    let h = Half::from_number(half).map_err(to_py)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let tr = py.detach(|| rayspace::trace(&cam, h, ax)).map_err(to_py)?;
    let n = tr.polygons.len();
    let verts: Vec<f64> = tr
        .polygons
        .iter()
        .flat_map(|p| p.v.iter().flatten().copied())
        .collect();
    let nv: Vec<i64> = tr.polygons.iter().map(|p| p.n as i64).collect();
    let flat = |v: &[[f64; 2]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    let ints = |v: &[u32]| Array1::from_iter(v.iter().map(|&x| x as i64)).into_pyarray(py);
    Ok((
        shaped(py, (n, rayspace::MAX_VERTICES, 2), verts)?,
        nv.into_pyarray(py),
        tr.area.into_pyarray(py),
        shaped(py, (n, 2), flat(&tr.centroid))?,
        ints(&tr.lens),
        ints(&tr.pixel),
        shaped(py, (n, 2), flat(&tr.chief))?,
        tr.lit.into_pyarray(py),
    ))
}

type FootprintArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Option<Bound<'py, numpy::PyArray3<f64>>>,
    Option<Bound<'py, numpy::PyArray3<f64>>>,
);

/// Footprints of every pixel of one half along one axis at every depth (docs/model.md §5):
/// (position, lo, hi) each (m, n); with `kernel` also breaks and values (m, n, 6).
#[pyfunction]
#[pyo3(signature = (camera, z, half, axis="x", sample="centroid", kernel=false, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn footprints<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    z: PyReadonlyArray1<'py, f64>,
    half: i64,
    axis: &str,
    sample: &str,
    kernel: bool,
    n_threads: Option<usize>,
) -> PyResult<FootprintArrays<'py>> {
    let cam = camera.inner;
    let h = Half::from_number(half).map_err(to_py)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let s = Sample::from_name(sample).map_err(to_py)?;
    let zs = as_slice(&z);
    // Validate everything, then let NumPy allocate the outputs (its allocator asks for
    // huge pages) and have the core write straight into them without the GIL.
    let (m, n) = rayspace::check_footprints(&cam, &zs, ax, kernel, n_threads).map_err(to_py)?;
    let position = PyArray2::<f64>::zeros(py, [m, n], false);
    let lo = PyArray2::<f64>::zeros(py, [m, n], false);
    let hi = PyArray2::<f64>::zeros(py, [m, n], false);
    let k = kernel.then(|| {
        let dims = [m, n, rayspace::MAX_VERTICES];
        (
            numpy::PyArray3::<f64>::zeros(py, dims, false),
            numpy::PyArray3::<f64>::zeros(py, dims, false),
        )
    });
    {
        let mut pw = position.readwrite();
        let mut lw = lo.readwrite();
        let mut hw = hi.readwrite();
        let mut kw = k.as_ref().map(|(b, v)| (b.readwrite(), v.readwrite()));
        let ps = pw.as_slice_mut().map_err(internal)?;
        let ls = lw.as_slice_mut().map_err(internal)?;
        let hs = hw.as_slice_mut().map_err(internal)?;
        let ks = match kw.as_mut() {
            Some((b, v)) => Some((
                b.as_slice_mut().map_err(internal)?,
                v.as_slice_mut().map_err(internal)?,
            )),
            None => None,
        };
        let out = rayspace::FootprintsOut {
            position: ps,
            lo: ls,
            hi: hs,
            kernel: ks,
        };
        py.detach(|| rayspace::footprints_into(&cam, &zs, h, ax, s, out, n_threads))
            .map_err(to_py)?;
    }
    let (kb, kv) = match k {
        Some((b, v)) => (Some(b), Some(v)),
        None => (None, None),
    };
    Ok((position, lo, hi, kb, kv))
}

type GridArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// Object-space sample positions (X, Y), each (Ky Q, Kx Q), of every pixel of one half
/// on the plane at depth z; NaN where a pixel yields no sample.
#[pyfunction]
#[pyo3(signature = (camera, z, half, sample="chief", n_threads=None))]
fn sample_grid<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    z: f64,
    half: i64,
    sample: &str,
    n_threads: Option<usize>,
) -> PyResult<GridArrays<'py>> {
    let cam = camera.inner;
    let h = Half::from_number(half).map_err(to_py)?;
    let s = Sample::from_name(sample).map_err(to_py)?;
    let (rows, cols) = rayspace::check_sample_grid(&cam, z, n_threads).map_err(to_py)?;
    let gx = PyArray2::<f64>::zeros(py, [rows, cols], false);
    let gy = PyArray2::<f64>::zeros(py, [rows, cols], false);
    {
        let mut xw = gx.readwrite();
        let mut yw = gy.readwrite();
        let xs = xw.as_slice_mut().map_err(internal)?;
        let ys = yw.as_slice_mut().map_err(internal)?;
        py.detach(|| rayspace::sample_grid_into(&cam, z, h, s, xs, ys, n_threads))
            .map_err(to_py)?;
    }
    Ok((gx, gy))
}

/// Widest pixel kernel (hi − lo, mm in object-space X) of a source at depth z.
#[pyfunction]
#[pyo3(signature = (camera, z, source, n_threads=None))]
fn kernel_support(
    py: Python<'_>,
    camera: &CameraCore,
    z: f64,
    source: &str,
    n_threads: Option<usize>,
) -> PyResult<f64> {
    let cam = camera.inner;
    let src = Source::from_name(source).map_err(to_py)?;
    py.detach(|| simulate::kernel_support(&cam, z, src, n_threads))
        .map_err(to_py)
}

type CsrArrays<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    (usize, usize),
);

/// System matrix of a source at depth z on the grid (origin, step, n_cells), rows the
/// pixels whose kernels lie in [field_lo, field_hi]: (indptr, indices, data, pixels, shape).
#[pyfunction]
#[pyo3(signature = (camera, z, source, origin, step, n_cells, field_lo, field_hi, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn system_matrix<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    z: f64,
    source: &str,
    origin: f64,
    step: f64,
    n_cells: usize,
    field_lo: f64,
    field_hi: f64,
    n_threads: Option<usize>,
) -> PyResult<CsrArrays<'py>> {
    let cam = camera.inner;
    let src = Source::from_name(source).map_err(to_py)?;
    let grid = Grid::new(origin, step, n_cells).map_err(to_py)?;
    let sys = py
        .detach(|| simulate::system_matrix(&cam, z, src, grid, (field_lo, field_hi), n_threads))
        .map_err(to_py)?;
    let m = sys.matrix;
    let px: Vec<i64> = sys.pixels.iter().map(|&p| p as i64).collect();
    Ok((
        m.indptr.into_pyarray(py),
        m.indices.into_pyarray(py),
        m.data.into_pyarray(py),
        px.into_pyarray(py),
        (m.rows, m.cols),
    ))
}

type RenderArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<i64>>);

/// Noise-free pixel values of a source at depth z for textures (n_tex, n_cells) constant on
/// each cell of the grid: (values (n_tex, n_pix), pixels).
#[pyfunction]
#[pyo3(signature = (camera, z, source, origin, step, field_lo, field_hi, textures, n_threads=None))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    camera: &CameraCore,
    z: f64,
    source: &str,
    origin: f64,
    step: f64,
    field_lo: f64,
    field_hi: f64,
    textures: PyReadonlyArray2<'py, f64>,
    n_threads: Option<usize>,
) -> PyResult<RenderArrays<'py>> {
    let cam = camera.inner;
    let src = Source::from_name(source).map_err(to_py)?;
    let (n_tex, n_cells) = textures.as_array().dim();
    let grid = Grid::new(origin, step, n_cells).map_err(to_py)?;
    let flat: Cow<'_, [f64]> = match textures.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(textures.as_array().iter().copied().collect()),
    };
    let (values, pixels) = py
        .detach(|| simulate::render(&cam, z, src, grid, (field_lo, field_hi), &flat, n_threads))
        .map_err(to_py)?;
    let px: Vec<i64> = pixels.iter().map(|&p| p as i64).collect();
    Ok((rows(py, values, n_tex)?, px.into_pyarray(py)))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<CameraCore>()?;
    m.add_function(wrap_pyfunction!(curves, m)?)?;
    m.add_function(wrap_pyfunction!(depth_of_field, m)?)?;
    m.add_function(wrap_pyfunction!(sharp_fractions, m)?)?;
    m.add_function(wrap_pyfunction!(new_samples, m)?)?;
    m.add_function(wrap_pyfunction!(coincidence_planes, m)?)?;
    m.add_function(wrap_pyfunction!(figures_of_merit, m)?)?;
    m.add_function(wrap_pyfunction!(trace, m)?)?;
    m.add_function(wrap_pyfunction!(footprints, m)?)?;
    m.add_function(wrap_pyfunction!(sample_grid, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_support, m)?)?;
    m.add_function(wrap_pyfunction!(system_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    Ok(())
}
