//! The super-resolution simulation's forward model: kernel support, system matrix and
//! noise-free rendering of a source.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

use splitlf_core::inverse::simulate::{self, DesignSource, Grid, Pixels};
use splitlf_core::Design;

use crate::infra::args::{as_flat, threads_arg};
use crate::infra::arrays::filled;
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::run;
use crate::model::design::DesignCore;

/// A design's source from its name ("channel<c>", "conventional<c>").
pub(crate) fn design_source(design: &Design, source: &str) -> PyResult<Pixels> {
    let src = DesignSource::from_name(design, source).map_err(to_py)?;
    Pixels::of_design(design, src).map_err(to_py)
}

/// What a system matrix and a rendering share: the design's source, the grid of n_cells
/// cells of width `step` from `origin`, and the field [field_lo, field_hi].
fn forward_model(
    design: &Design,
    source: &str,
    (origin, step, n_cells): (f64, f64, usize),
    field: (f64, f64),
) -> PyResult<(Pixels, Grid, (f64, f64))> {
    let px = design_source(design, source)?;
    let grid = Grid::new(origin, step, n_cells).map_err(to_py)?;
    Ok((px, grid, field))
}

/// Widest pixel kernel (hi − lo, mm in object-space X) of a design's source at depth z.
#[pyfunction]
#[pyo3(signature = (design, z, source, n_threads=None))]
pub(crate) fn design_kernel_support(
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
pub(crate) struct SystemMatrixArrays {
    indptr: Py<PyArray1<i64>>,
    indices: Py<PyArray1<i64>>,
    data: Py<PyArray1<f64>>,
    pixels: Py<PyArray1<i64>>,
    shape: (usize, usize),
}

/// System matrix of a design's source ("channel<c>", "conventional<c>") at depth z on the
/// grid (origin, step, n_cells), rows the pixels whose kernels lie in the field [lo, hi].
#[pyfunction]
#[pyo3(signature = (design, z, source, grid, field, n_threads=None))]
pub(crate) fn design_system_matrix(
    py: Python<'_>,
    design: &DesignCore,
    z: f64,
    source: &str,
    grid: (f64, f64, usize),
    field: (f64, f64),
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<SystemMatrixArrays> {
    let (px, grid, field) = forward_model(&design.inner, source, grid, field)?;
    let threads = threads_arg(n_threads)?;
    let sys = run(py, || {
        simulate::system_matrix_of(&px, z, grid, field, threads)
    })?;
    let m = sys.matrix;
    let what = "system_matrix";
    // SciPy's csr_matrix((data, indices, indptr), shape) with int64 index arrays.
    let int64 = |v: &[usize]| filled::<i64, _>(py, &[v.len()], what, v.iter().map(|&k| k as i64));
    let indices = m.indices.iter().map(|&c| c as i64);
    let px = sys.pixels.iter().map(|&p| p as i64);
    Ok(SystemMatrixArrays {
        indptr: int64(&m.indptr)?.unbind(),
        indices: filled::<i64, _>(py, &[m.indices.len()], what, indices)?.unbind(),
        shape: (m.nrows(), m.ncols),
        data: m.data.into_pyarray(py).unbind(),
        pixels: filled::<i64, _>(py, &[sys.pixels.len()], what, px)?.unbind(),
    })
}

/// Noise-free pixel values (n_tex, n_pix) and the pixels they belong to.
#[pyclass(frozen, get_all, module = "splitlf._native")]
pub(crate) struct RenderArrays {
    values: Py<PyArray2<f64>>,
    pixels: Py<PyArray1<i64>>,
}

/// Noise-free pixel values of a design's source ("channel<c>", "conventional<c>") at depth
/// z for textures (n_tex, n_cells) constant on each cell of the grid (origin, step), rows
/// the pixels whose kernels lie in the field [lo, hi] (the GIL token comes from `textures`).
#[pyfunction]
#[pyo3(signature = (design, z, source, grid, field, textures, n_threads=None))]
pub(crate) fn design_render(
    design: &DesignCore,
    z: f64,
    source: &str,
    grid: (f64, f64),
    field: (f64, f64),
    textures: PyReadonlyArray2<'_, f64>,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderArrays> {
    let py = textures.py();
    let (n_tex, n_cells) = textures.as_array().dim();
    let cells = (grid.0, grid.1, n_cells);
    let (px, grid, field) = forward_model(&design.inner, source, cells, field)?;
    let threads = threads_arg(n_threads)?;
    let flat = as_flat(&textures, "textures")?;
    let (values, pixels) = run(py, || {
        simulate::render_of(&px, z, grid, field, &flat, threads)
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
