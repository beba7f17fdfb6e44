//! The linear map of a reconstruction (docs/model.md §11, docs/reconstruct.md): built in
//! the core with the forward model's integration, handed to Python as CSR arrays.

use std::sync::Arc;

use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use splitlf_core::inverse::solve;
use splitlf_core::inverse::system::{self, CellGrid};

use crate::infra::args::threads_arg;
use crate::infra::errors::to_py;
use crate::infra::interrupt::{counted, run_reporting};
use crate::model::design::DesignCore;

/// Channels numbered from 1 (Python) to indices from 0, every channel when None.
pub(crate) fn channel_indices(
    design: &DesignCore,
    channels: Option<Vec<i64>>,
) -> PyResult<Vec<usize>> {
    let n = design.inner.channels.len();
    match channels {
        None => Ok((0..n).collect()),
        Some(v) => v
            .into_iter()
            .map(|c| {
                if c >= 1 && (c as u128) <= n as u128 {
                    Ok(c as usize - 1)
                } else {
                    Err(to_py(splitlf_core::Error::param(
                        "channels",
                        c,
                        format!("channel numbers in 1..={n}"),
                    )))
                }
            })
            .collect(),
    }
}

/// The default region (X0, X1, Y0, Y1) at depth z: what each chosen channel sees through at
/// least half its aperture.
#[pyfunction]
#[pyo3(signature = (design, z, channels=None))]
pub(crate) fn seen_region(
    design: &DesignCore,
    z: f64,
    channels: Option<Vec<i64>>,
) -> PyResult<(f64, f64, f64, f64)> {
    let ch = channel_indices(design, channels)?;
    let e = system::seen_region(&design.inner, &ch, z).map_err(to_py)?;
    Ok((e[0], e[1], e[2], e[3]))
}

/// The widest span (mm) of one pixel's rays on the plane at depth z.
#[pyfunction]
#[pyo3(signature = (design, z, channels=None))]
pub(crate) fn pixel_span(design: &DesignCore, z: f64, channels: Option<Vec<i64>>) -> PyResult<f64> {
    let ch = channel_indices(design, channels)?;
    system::pixel_span(&design.inner, &ch, z).map_err(to_py)
}

/// The grid of pitch `step` covering `extent`: (X0, Y1, step, nx, ny).
#[pyfunction]
pub(crate) fn cell_grid(
    extent: (f64, f64, f64, f64),
    step: f64,
) -> PyResult<(f64, f64, f64, usize, usize)> {
    let g = CellGrid::covering([extent.0, extent.1, extent.2, extent.3], step).map_err(to_py)?;
    Ok((g.x0, g.y1, g.step, g.nx, g.ny))
}

/// A grid tuple (X0, Y1, step, nx, ny), checked by re-deriving it from its extent.
pub(crate) fn checked_grid(grid: (f64, f64, f64, usize, usize)) -> PyResult<CellGrid> {
    let g = CellGrid {
        x0: grid.0,
        y1: grid.1,
        step: grid.2,
        nx: grid.3,
        ny: grid.4,
    };
    let checked = CellGrid::covering(g.extent(), g.step).map_err(to_py)?;
    if checked.nx != g.nx || checked.ny != g.ny {
        return Err(to_py(splitlf_core::Error::param(
            "grid",
            format!("{grid:?}"),
            "a grid from cell_grid",
        )));
    }
    Ok(g)
}

type Csr<'py> = (
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<f64>>,
);

/// The map's arrays for Python: (channel from 0, pixel flat index, indptr, indices, data).
fn csr(py: Python<'_>, sys: system::System) -> Csr<'_> {
    (
        sys.channel.into_pyarray(py),
        sys.pixel.into_pyarray(py),
        sys.indptr.into_pyarray(py),
        sys.indices.into_pyarray(py),
        sys.data.into_pyarray(py),
    )
}

/// Raw rows over the chosen channels (the unit of a map build's progress).
fn raw_rows(d: &splitlf_core::Design, channels: &[usize]) -> usize {
    channels
        .iter()
        .map(|&i| splitlf_core::imaging::render::raw_shape(&d.channels[i]).0)
        .sum()
}

/// A map build's shared hand-off: the threads, channels and grid checked, `build` run
/// without the GIL (progress counting raw rows, Ctrl-C polled), the map as CSR arrays.
#[allow(clippy::too_many_arguments)]
fn build_map<'py>(
    py: Python<'py>,
    design: &DesignCore,
    grid: (f64, f64, f64, usize, usize),
    channels: Option<Vec<i64>>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    field: &'static str,
    build: impl FnOnce(
            &splitlf_core::Design,
            &[usize],
            &CellGrid,
            Option<usize>,
            &std::sync::atomic::AtomicUsize,
        ) -> splitlf_core::Result<system::System>
        + Send,
) -> PyResult<Csr<'py>> {
    let threads = threads_arg(n_threads)?;
    let ch = channel_indices(design, channels)?;
    let g = checked_grid(grid)?;
    let d = design.inner.clone();
    let (report, counter) = counted(progress, raw_rows(&d, &ch));
    let sys = run_reporting(py, field, report, move || {
        build(&d, &ch, &g, threads, &counter)
    })?;
    Ok(csr(py, sys))
}

/// The map for the fronto-parallel plane at depth z over the grid (X0, Y1, step, nx, ny):
/// (channel from 0, pixel flat index, indptr, indices, data) per kept row.
/// `progress(done, total)` counts raw rows.
#[pyfunction]
#[pyo3(signature = (design, z, grid, channels=None, n_threads=None, progress=None))]
pub(crate) fn reconstruction_system<'py>(
    py: Python<'py>,
    design: &DesignCore,
    z: f64,
    grid: (f64, f64, f64, usize, usize),
    channels: Option<Vec<i64>>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Csr<'py>> {
    build_map(
        py,
        design,
        grid,
        channels,
        n_threads,
        progress,
        "z",
        move |d, ch, g, t, c| system::build(d, ch, z, g, t, c),
    )
}

/// The map for any surface over the grid (X0, Y1, step, nx, ny): the scene's surface (its
/// texture is not used), any design; the forward model's general route in record mode.
/// Only the pixels under lenses of `lens_types` (numbered from 1; None: every type) are
/// rows. Returns what [`reconstruction_system`] returns.
#[pyfunction]
#[pyo3(signature = (design, scene, grid, channels=None, n_threads=None, progress=None,
                    lens_types=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn surface_system<'py>(
    py: Python<'py>,
    design: &DesignCore,
    scene: &crate::imaging::render::RenderScene,
    grid: (f64, f64, f64, usize, usize),
    channels: Option<Vec<i64>>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    lens_types: Option<Vec<i64>>,
) -> PyResult<Csr<'py>> {
    let sc = Arc::clone(&scene.inner);
    let types: Option<Vec<usize>> = lens_types
        .map(|v| {
            v.into_iter()
                .map(|t| {
                    // Numbers from 1; a number below 1 is named as given (the core names
                    // those beyond the channels' types).
                    usize::try_from(t.saturating_sub(1)).map_err(|_| {
                        to_py(splitlf_core::Error::param(
                            "lens_types",
                            t,
                            "lens type numbers from 1",
                        ))
                    })
                })
                .collect::<PyResult<Vec<usize>>>()
        })
        .transpose()?;
    build_map(
        py,
        design,
        grid,
        channels,
        n_threads,
        progress,
        "depth",
        move |d, ch, g, t, c| system::build_surface(d, ch, &sc.surface, g, types.as_deref(), t, c),
    )
}

type Axis<'py> = (
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

type FactorTuple<'py> = (
    f64,
    Bound<'py, numpy::PyArray2<u8>>,
    Vec<Axis<'py>>,
    Vec<Axis<'py>>,
);

/// The factors of channel `channel`'s map (numbered from 1) for the fronto-parallel plane
/// at depth z over the grid (X0, Y1, step, nx, ny): (norm, the pixels' lens types, per type
/// the x profiles (raw column → grid column) and the y profiles (raw row → grid row from
/// the top), each as (indptr, indices, data, total area)). Pixel (b, a) of type t reads
/// norm · Σ y[t][b, r] x[t][a, c] T[r, c].
#[pyfunction]
pub(crate) fn reconstruction_factors<'py>(
    py: Python<'py>,
    design: &DesignCore,
    z: f64,
    grid: (f64, f64, f64, usize, usize),
    channel: i64,
) -> PyResult<FactorTuple<'py>> {
    let ch = channel_indices(design, Some(vec![channel]))?[0];
    let g = checked_grid(grid)?;
    let d = design.inner.clone();
    let f = py
        .detach(move || system::factors(&d, ch, z, &g))
        .map_err(to_py)?;
    let types = numpy::ndarray::Array2::from_shape_vec((f.rows, f.cols), f.types)
        .map_err(crate::infra::errors::internal)?;
    let axis = |a: system::AxisProfiles| -> Axis<'py> {
        (
            a.indptr.into_pyarray(py),
            a.indices.into_pyarray(py),
            a.data.into_pyarray(py),
            a.total.into_pyarray(py),
        )
    };
    Ok((
        f.norm,
        types.into_pyarray(py),
        f.x.into_iter().map(axis).collect(),
        f.y.into_iter().map(axis).collect(),
    ))
}

/// The scene's texture averaged over each cell of the grid (X0, Y1, step, nx, ny): an
/// (ny, nx) array, row 0 at the top (the truth a reconstruction is measured against).
#[pyfunction]
pub(crate) fn cell_averages<'py>(
    py: Python<'py>,
    scene: &crate::imaging::render::RenderScene,
    grid: (f64, f64, f64, usize, usize),
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let g = checked_grid(grid)?;
    splitlf_core::infra::memory::check(
        "the cell averages",
        splitlf_core::infra::memory::bytes_of::<f64>(g.cells() as u128),
    )
    .map_err(to_py)?;
    let sc = Arc::clone(&scene.inner);
    let values = py.detach(move || system::cell_averages(&sc.texture, &g));
    let a = numpy::ndarray::Array2::from_shape_vec((g.ny, g.nx), values)
        .map_err(crate::infra::errors::internal)?;
    Ok(a.into_pyarray(py))
}

/// A CSR matrix from Python: (indptr, indices, data, number of columns).
type CsrIn<'py> = (
    numpy::PyReadonlyArray1<'py, u64>,
    numpy::PyReadonlyArray1<'py, u32>,
    numpy::PyReadonlyArray1<'py, f64>,
    usize,
);

/// The rows of a factored block: (norm, px, py, weights, values), weights and values over
/// the raw window row-major.
type FactoredIn<'py> = (
    f64,
    CsrIn<'py>,
    CsrIn<'py>,
    numpy::PyReadonlyArray1<'py, f64>,
    numpy::PyReadonlyArray1<'py, f64>,
);

/// Explicit rows: (A, weights, values).
type RowsIn<'py> = (
    CsrIn<'py>,
    numpy::PyReadonlyArray1<'py, f64>,
    numpy::PyReadonlyArray1<'py, f64>,
);

fn slice<'a, T: numpy::Element>(
    a: &'a numpy::PyReadonlyArray1<'_, T>,
    field: &'static str,
) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| {
        to_py(splitlf_core::Error::param(
            field,
            "a non-contiguous array",
            "a C-contiguous array",
        ))
    })
}

fn csr_in(field: &'static str, c: &CsrIn<'_>) -> PyResult<solve::Csr> {
    let indptr = slice(&c.0, field)?
        .iter()
        .map(|&v| {
            usize::try_from(v).map_err(|_| splitlf_core::Error::param(field, v, "indptr < 2^64"))
        })
        .collect::<splitlf_core::Result<Vec<usize>>>()
        .map_err(to_py)?;
    if indptr.is_empty() {
        return Err(to_py(splitlf_core::Error::param(
            field,
            "an empty indptr",
            "at least one entry",
        )));
    }
    solve::Csr::new(
        field,
        indptr,
        slice(&c.1, field)?.to_vec(),
        slice(&c.2, field)?.to_vec(),
        c.3,
    )
    .map_err(to_py)
}

/// Solve the regularised least squares of a reconstruction over a grid of `shape` (ny, nx)
/// cells: blocks of factored rows and of explicit rows (see `splitlf_core::inverse::solve`), prior
/// weight `regularization`, conjugate gradients to `rtol`, to `noise_tol` of the noise's
/// expected norm in the right-hand side (0: not used), or `max_iter` steps. Returns
/// (cells (ny, nx), iterations, the normal equations' relative residual).
/// `progress(done, total)` counts iterations out of `max_iter`.
#[pyfunction]
#[pyo3(signature = (shape, regularization, factored, rows, rtol, max_iter, noise_tol=0.0, n_threads=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_normal<'py>(
    py: Python<'py>,
    shape: (usize, usize),
    regularization: f64,
    factored: Vec<FactoredIn<'py>>,
    rows: Vec<RowsIn<'py>>,
    rtol: f64,
    max_iter: usize,
    noise_tol: f64,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, numpy::PyArray2<f64>>, usize, f64)> {
    let threads = threads_arg(n_threads)?;
    let (ny, nx) = shape;
    let mut blocks = Vec::with_capacity(factored.len() + rows.len());
    for (norm, px, pyf, w, y) in &factored {
        blocks.push(solve::Block::Factored {
            norm: *norm,
            px: csr_in("px", px)?,
            py: csr_in("py", pyf)?,
            w: slice(w, "weights")?.to_vec(),
            y: slice(y, "values")?.to_vec(),
        });
    }
    for (a, w, y) in &rows {
        blocks.push(solve::Block::Rows {
            a: csr_in("rows", a)?,
            w: slice(w, "weights")?.to_vec(),
            y: slice(y, "values")?.to_vec(),
        });
    }
    drop((factored, rows));
    let (report, counter) = counted(progress, max_iter);
    let sol = run_reporting(py, "depth", report, move || {
        let normal = solve::Normal::new(nx, ny, regularization, blocks)?;
        let stop = solve::Stop {
            rtol,
            noise: noise_tol,
            max_iter,
        };
        solve::solve(&normal, stop, threads, &counter)
    })?;
    let cells = crate::infra::arrays::filled::<f64, numpy::ndarray::Ix2>(
        py,
        &[ny, nx],
        "the reconstruction",
        sol.cells.into_iter(),
    )?;
    Ok((cells, sol.iterations, sol.residual))
}
