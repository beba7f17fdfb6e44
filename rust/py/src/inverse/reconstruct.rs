//! The linear map of a reconstruction (docs/model.md §11, docs/reconstruct.md): built in
//! the core with the forward model's integration, handed to Python as CSR arrays.

use std::sync::Arc;

use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use splitlf_core::imaging::cfa::Pattern;
use splitlf_core::inverse::reconstruct as rc;
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

/// (channel, pixel, indptr, indices, data); indptr's usize is NumPy's uint64 on the 64-bit
/// platforms the package builds for.
type Csr<'py> = (
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<usize>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<f64>>,
);

/// The map's arrays for Python: (channel from 0, pixel flat index, indptr, indices, data).
fn csr(py: Python<'_>, sys: system::System) -> Csr<'_> {
    (
        sys.channel.into_pyarray(py),
        sys.pixel.into_pyarray(py),
        sys.rows.indptr.into_pyarray(py),
        sys.rows.indices.into_pyarray(py),
        sys.rows.data.into_pyarray(py),
    )
}

/// Raw rows over the chosen channels (the unit of a map build's progress).
fn raw_rows(d: &splitlf_core::Design, channels: &[usize]) -> usize {
    channels
        .iter()
        .map(|&i| splitlf_core::imaging::render::raw_shape(&d.channels[i]).0)
        .sum()
}

/// What Python asks of a map build: the design, the grid (X0, Y1, step, nx, ny), the
/// channels (numbered from 1; None: all), the threads and the progress callback.
struct MapRequest<'a, 'py> {
    design: &'a DesignCore,
    grid: (f64, f64, f64, usize, usize),
    channels: Option<Vec<i64>>,
    n_threads: Option<&'a Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
}

/// A map build's shared hand-off: the threads, channels and grid checked, `build` run
/// without the GIL (progress counting raw rows, Ctrl-C polled), the map as CSR arrays.
fn build_map<'py>(
    py: Python<'py>,
    req: MapRequest<'_, 'py>,
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
    let threads = threads_arg(req.n_threads)?;
    let ch = channel_indices(req.design, req.channels)?;
    let g = checked_grid(req.grid)?;
    let d = req.design.inner.clone();
    let (report, counter) = counted(req.progress, raw_rows(&d, &ch));
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
    let req = MapRequest {
        design,
        grid,
        channels,
        n_threads,
        progress,
    };
    build_map(py, req, "z", move |d, ch, g, t, c| {
        system::build(d, ch, z, g, t, c)
    })
}

/// The map for any surface over the grid (X0, Y1, step, nx, ny): the scene's surface (its
/// texture is not used), any design; the forward model's general route in record mode.
/// Only the pixels under lenses of `lens_types` (numbered from 1; None: every type) are
/// rows. Returns what [`reconstruction_system`] returns.
#[pyfunction]
#[pyo3(signature = (design, scene, grid, channels=None, n_threads=None, progress=None,
                    lens_types=None))]
pub(crate) fn surface_system<'py>(
    design: &DesignCore,
    scene: &Bound<'py, crate::imaging::render::RenderScene>,
    grid: (f64, f64, f64, usize, usize),
    channels: Option<Vec<i64>>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    lens_types: Option<Vec<i64>>,
) -> PyResult<Csr<'py>> {
    let sc = Arc::clone(&scene.get().inner);
    let types = lens_types.map(|v| from_one("lens_types", v)).transpose()?;
    let req = MapRequest {
        design,
        grid,
        channels,
        n_threads,
        progress,
    };
    build_map(scene.py(), req, "depth", move |d, ch, g, t, c| {
        system::build_surface(d, ch, &sc.surface, g, types.as_deref(), t, c)
    })
}

type Axis<'py> = (
    Bound<'py, PyArray1<usize>>,
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
            a.rows.indptr.into_pyarray(py),
            a.rows.indices.into_pyarray(py),
            a.rows.data.into_pyarray(py),
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

/// The prior of [`solve_normal`]: its weight λ alone (quadratic), or (λ, name, threshold,
/// passes, tol) (see `splitlf_core::inverse::solve::Prior`).
#[derive(FromPyObject)]
pub(crate) enum RegularizationIn {
    Weight(f64),
    Prior((f64, String, f64, usize, f64)),
}

/// Solve the regularised least squares of a reconstruction over a grid of `shape` (ny, nx)
/// cells: `blocks` = (factored blocks, blocks of explicit rows) (see `splitlf_core::inverse::solve`), prior
/// `regularization` (its weight λ for the quadratic prior, or (λ, name, threshold,
/// passes, tol) for any prior), conjugate gradients until `stop` = (rtol, max_iter, noise_tol):
/// to `rtol`, to `noise_tol` of the noise's expected norm in the right-hand side (0: not
/// used), or `max_iter` steps (in each pass of an edge-preserving prior). Returns
/// (cells (ny, nx), iterations over every pass, the normal equations' relative residual).
/// `progress(done, total)` counts iterations out of `max_iter` times the passes.
#[pyfunction]
#[pyo3(signature = (shape, regularization, blocks, stop, n_threads=None, progress=None))]
pub(crate) fn solve_normal<'py>(
    py: Python<'py>,
    shape: (usize, usize),
    regularization: RegularizationIn,
    blocks: (Vec<FactoredIn<'py>>, Vec<RowsIn<'py>>),
    stop: (f64, usize, f64),
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, numpy::PyArray2<f64>>, usize, f64)> {
    let threads = threads_arg(n_threads)?;
    let (regularization, prior) = match regularization {
        RegularizationIn::Weight(lam) => (lam, None),
        RegularizationIn::Prior((lam, name, threshold, passes, tol)) => {
            (lam, Some((name, threshold, passes, tol)))
        }
    };
    let prior = prior_arg(prior)?;
    let (ny, nx) = shape;
    let (rtol, max_iter, noise_tol) = stop;
    let (factored, rows) = blocks;
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
    let (report, counter) = counted(progress, max_iter.saturating_mul(prior.passes));
    // The label names the depth parameter in an invalid-depth error: the solve takes no
    // depth, so it raises none and the label is unused (reconstruct's, as below).
    let sol = run_reporting(py, "depth", report, move || {
        let normal = solve::Normal::new(nx, ny, regularization, blocks)?.with_prior(prior)?;
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

/// The prior from (name, threshold, passes, tol), checked (None: quadratic).
fn prior_arg(prior: Option<(String, f64, usize, f64)>) -> PyResult<solve::Prior> {
    match prior {
        None => Ok(solve::Prior::quadratic()),
        Some((name, threshold, passes, tol)) => {
            solve::Prior::from_parts(&name, threshold, passes, tol).map_err(to_py)
        }
    }
}

/// The reconstruction's progress for Python: called by the seam's signal checks, it
/// passes `callback(phase, done, total, notes)` the core's phase ("plan", "map", "solve",
/// "done"), its work done and total, and the notes written since the last call.
#[pyclass(module = "splitlf._native")]
struct Forward {
    callback: Py<PyAny>,
    state: Arc<rc::Progress>,
}

impl Forward {
    fn send(&self, py: Python<'_>, finished: bool) -> PyResult<()> {
        use std::sync::atomic::Ordering::Relaxed;
        let notes: Vec<String> =
            std::mem::take(&mut *self.state.notes.lock().unwrap_or_else(|p| p.into_inner()));
        let phase = if finished {
            "done"
        } else {
            ["plan", "map", "solve"][self.state.phase.load(Relaxed).min(2)]
        };
        let total = self.state.total.load(Relaxed);
        let done = self.state.done.load(Relaxed).min(total);
        self.callback.call1(py, (phase, done, total, notes))?;
        Ok(())
    }
}

#[pymethods]
impl Forward {
    fn __call__(&self, py: Python<'_>, _done: usize, _total: usize) -> PyResult<()> {
        self.send(py, false)
    }
}

/// An option of [`reconstruct`]'s dict, None when absent or None.
fn option<'py, T: FromPyObjectOwned<'py>>(
    options: &Bound<'py, PyDict>,
    key: &str,
) -> PyResult<Option<T>> {
    match options.get_item(key)? {
        Some(v) if !v.is_none() => Ok(Some(v.extract().map_err(Into::into)?)),
        _ => Ok(None),
    }
}

/// Numbers from 1 to indices from 0 (a number below 1 named as given; the core names those
/// beyond the channels' types).
pub(crate) fn from_one(field: &'static str, v: Vec<i64>) -> PyResult<Vec<usize>> {
    v.into_iter()
        .map(|t| {
            usize::try_from(t.saturating_sub(1))
                .map_err(|_| to_py(splitlf_core::Error::param(field, t, "numbers from 1")))
        })
        .collect()
}

type Reconstructed<'py> = (
    Bound<'py, numpy::PyArray2<f64>>,
    (f64, f64, f64, f64),
    f64,
    usize,
    usize,
    f64,
    usize,
    usize,
    Option<Vec<usize>>,
    Choice,
);

/// How λ and the noise were set: (λ, rule, (photons, read noise) with photons = inf for
/// noise-free, whether the noise was estimated, the λ tried as (λ, score, RSS, df,
/// iterations)).
type Choice = (
    f64,
    &'static str,
    (f64, f64),
    bool,
    Vec<(f64, f64, f64, f64, usize)>,
);

/// The `choose` option as Python passes it: (lo, hi, (photons lo, hi), golden_steps,
/// probes, side, max_iter, probe_rtol, budget, df_weight).
type ChooseTuple = (
    f64,
    f64,
    (f64, f64),
    usize,
    usize,
    usize,
    usize,
    f64,
    usize,
    f64,
);

/// A whole reconstruction in one call (`splitlf_core::inverse::reconstruct`): `images`
/// the raw's channels, `surface` (kind, params, depth map or None) as `RenderScene` takes
/// it, `options` a dict of channels and lens_types (numbered from 1; None: all), colour
/// ((CFA pattern, colour 0 red / 1 green / 2 blue): only that colour's pixels; None: all),
/// region, step, regularization (None: chosen from the data), noise ((photons, read
/// noise), photons = inf for noise-free; None: not known, estimated), prior ((name,
/// threshold, passes, tol) or None: quadratic), tile, allow_slow, n_threads,
/// memory_limit (bytes, tests), settings (noise_floor, rtol, max_iter, noise_tol,
/// overlap, min_tile, max_seconds) and choose (the bracket's lo and hi, the photon counts
/// an estimate can find (lo, hi), golden-section steps, probes, the sub-grid's side, each
/// search solve's iteration cap, the probes' rtol, the search's budget of iterations,
/// the weight on the degrees of freedom).
/// `progress(phase, done, total, notes)` is
/// called at the signal checks and once at the end. Returns (image, extent, step, rows,
/// iterations, residual, the prior's passes, tiles, lens types from 1 or None).
#[pyfunction]
#[pyo3(signature = (design, images, surface, options, progress=None))]
pub(crate) fn reconstruct<'py>(
    py: Python<'py>,
    design: &DesignCore,
    images: Vec<numpy::PyReadonlyArray2<'py, f64>>,
    surface: (String, Vec<f64>, Option<numpy::PyReadonlyArray2<'py, f64>>),
    options: &Bound<'py, PyDict>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Reconstructed<'py>> {
    let images: Vec<Vec<f64>> = images
        .iter()
        .map(|a| a.as_array().iter().copied().collect())
        .collect();
    let map = surface.2.as_ref().map(|a| {
        let v = a.as_array();
        let (r, c) = v.dim();
        (v.iter().copied().collect::<Vec<f64>>(), r, c)
    });
    let settings: (f64, f64, usize, f64, usize, usize, f64) = option(options, "settings")?
        .ok_or_else(|| pyo3::exceptions::PyTypeError::new_err("options need settings"))?;
    let choose: ChooseTuple = option(options, "choose")?
        .ok_or_else(|| pyo3::exceptions::PyTypeError::new_err("options need choose"))?;
    let channels = match option::<Vec<i64>>(options, "channels")? {
        Some(v) => from_one("channels", v)?,
        None => (0..design.inner.channels.len()).collect(),
    };
    let lens_types = option::<Vec<i64>>(options, "lens_types")?
        .map(|v| from_one("lens_types", v))
        .transpose()?;
    let colour = match option::<(String, usize)>(options, "colour")? {
        Some((p, k)) if k < 3 => Some((Pattern::parse(&p).map_err(to_py)?, k)),
        Some((_, k)) => return Err(to_py(splitlf_core::Error::param("colour", k, "0, 1 or 2"))),
        None => None,
    };
    let regularization: Option<f64> = option(options, "regularization")?;
    let n_threads = threads_arg(options.get_item("n_threads")?.as_ref())?;
    let noise: Option<(f64, f64)> = option(options, "noise")?;
    let region: Option<(f64, f64, f64, f64)> = option(options, "region")?;
    let prior = prior_arg(option(options, "prior")?)?;
    let d = design.inner.clone();
    let state = Arc::new(rc::Progress::default());
    let forward = progress
        .map(|callback| {
            Py::new(
                py,
                Forward {
                    callback,
                    state: Arc::clone(&state),
                },
            )
        })
        .transpose()?;
    let report = forward.as_ref().map(|f| crate::infra::interrupt::Progress {
        callback: f.clone_ref(py).into_any(),
        done: Arc::new(std::sync::atomic::AtomicUsize::new(0)),
        total: 1,
    });
    let request = rc::Request {
        design: &d,
        images: images.iter().map(Vec::as_slice).collect(),
        surface: rc::SurfaceSpec {
            kind: &surface.0,
            params: &surface.1,
            map: map.as_ref().map(|(v, r, c)| (v.as_slice(), *r, *c)),
        },
        channels,
        lens_types,
        colour,
        region: region.map(|r| [r.0, r.1, r.2, r.3]),
        step: option(options, "step")?,
        regularization,
        noise: match noise {
            None => rc::Noise::Unknown,
            Some((n, _)) if n == f64::INFINITY => rc::Noise::Free,
            Some((n, r)) => rc::Noise::Photons([n, r]),
        },
        prior,
        tile: option(options, "tile")?,
        allow_slow: option(options, "allow_slow")?.unwrap_or(false),
        n_threads,
        memory_limit: option(options, "memory_limit")?,
        settings: rc::Settings {
            noise_floor: settings.0,
            rtol: settings.1,
            max_iter: settings.2,
            noise_tol: settings.3,
            overlap: settings.4,
            min_tile: settings.5,
            max_seconds: settings.6,
            choose: rc::ChooseSettings {
                lo: choose.0,
                hi: choose.1,
                photons: [choose.2 .0, choose.2 .1],
                golden_steps: choose.3,
                probes: choose.4,
                side: choose.5,
                max_iter: choose.6,
                probe_rtol: choose.7,
                budget: choose.8,
                df_weight: choose.9,
            },
        },
    };
    let st = Arc::clone(&state);
    // An invalid depth (a plane nearer than F) is named `depth`, reconstruct's parameter.
    let result = run_reporting(py, "depth", report, move || rc::reconstruct(&request, &st));
    if let Some(f) = &forward {
        f.borrow(py).send(py, true)?;
    }
    let out = result?;
    let image = crate::infra::arrays::filled::<f64, numpy::ndarray::Ix2>(
        py,
        &[out.ny, out.nx],
        "the reconstruction",
        out.image.into_iter(),
    )?;
    let e = out.extent;
    Ok((
        image,
        (e[0], e[1], e[2], e[3]),
        out.step,
        out.rows,
        out.iterations,
        out.residual,
        out.passes,
        out.tiles,
        out.lens_types
            .map(|v| v.into_iter().map(|t| t + 1).collect()),
        (
            out.regularization,
            out.rule,
            match out.noise {
                rc::Noise::Photons([n, r]) => (n, r),
                _ => (f64::INFINITY, 0.0),
            },
            out.estimated,
            out.trials
                .iter()
                .map(|t| (t.lam, t.score, t.rss, t.df, t.iterations))
                .collect(),
        ),
    ))
}
