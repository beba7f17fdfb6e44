//! Depth from the raw: the core's whole estimate in one call (docs/model.md §11,
//! docs/depth.md).

use numpy::{PyArray2, PyArray4, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;

use splitlf_core::inverse::depth;

use crate::infra::args::threads_arg;
use crate::infra::arrays::filled;
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::{counted, run_as, run_reporting};
use crate::inverse::reconstruct::channel_indices;
use crate::model::design::DesignCore;

/// An estimate's request, from a dict (Python has checked the types and ranges; the core
/// checks again): `channels` (numbered from 1), `candidates` (mm, increasing), `region`
/// ((X0, X1, Y0, Y1) mm or None: the default), `step` (mm or None: the default),
/// `window` (radius, cells), `min_own_share`, `keep_volume` and `tilt` (the window pooled
/// again along the surface's local slope).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct DepthRequest {
    channels: Vec<i64>,
    candidates: Vec<f64>,
    region: Option<(f64, f64, f64, f64)>,
    step: Option<f64>,
    window: usize,
    min_own_share: f64,
    keep_volume: bool,
    tilt: bool,
}

type EstimateTuple<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<i64>>,
    usize,
    Option<Bound<'py, PyArray4<f64>>>,
    (f64, f64, f64, usize, usize),
);

/// The depth of the scene from `raws` (one C-contiguous image per chosen channel) as
/// `request` asks ([`DepthRequest`]): per cell (ny, nx) the depth, the fractional
/// candidate index, the confidence, the least and the mean cost, the channel (numbered
/// from 1) whose curve gave the estimate; the pixels used; the cost volume (candidates,
/// chosen channels, ny, nx) when asked for; and the grid (X0, Y1, step, nx, ny).
/// `progress(done, total)` counts candidates.
#[pyfunction]
#[pyo3(signature = (design, raws, request, n_threads=None, progress=None))]
pub(crate) fn estimate_depth<'py>(
    py: Python<'py>,
    design: &DesignCore,
    raws: Vec<PyReadonlyArray2<'py, f64>>,
    request: DepthRequest,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<EstimateTuple<'py>> {
    let threads = threads_arg(n_threads)?;
    let channels = channel_indices(design, Some(request.channels))?;
    let mut raw_s = Vec::with_capacity(raws.len());
    for a in &raws {
        raw_s.push(a.as_slice().map_err(internal)?);
    }
    let req = depth::Request {
        channels,
        candidates: request.candidates,
        region: request.region.map(|r| [r.0, r.1, r.2, r.3]),
        step: request.step,
        radius: request.window,
        min_own_share: request.min_own_share,
        keep_volume: request.keep_volume,
        tilt: request.tilt,
    };
    let d = &design.inner;
    let (report, counter) = counted(progress, req.candidates.len());
    let e = run_reporting(py, "depths", report, || {
        depth::estimate(d, &raw_s, &req, threads, &counter)
    })?;
    let (g, s) = (e.grid, e.sweep);
    let shape = [g.ny, g.nx];
    let arr = |v: Vec<f64>, what: &str| filled::<f64, numpy::Ix2>(py, &shape, what, v.into_iter());
    let nch = req.channels.len();
    let volume = match s.volume {
        Some(v) => Some(filled::<f64, numpy::Ix4>(
            py,
            &[req.candidates.len(), nch, g.ny, g.nx],
            "the depth sweep's cost volume",
            v.into_iter(),
        )?),
        None => None,
    };
    let channel = s
        .channel
        .iter()
        .map(|&c| req.channels[c as usize] as i64 + 1);
    Ok((
        arr(s.depth, "the depth estimate")?,
        arr(s.index, "the depth estimate's candidate index")?,
        arr(s.confidence, "the depth estimate's confidence")?,
        arr(s.min_cost, "the depth estimate's least cost")?,
        arr(s.mean_cost, "the depth estimate's mean cost")?,
        filled::<i64, numpy::Ix2>(py, &shape, "the depth estimate's channel", channel)?,
        s.samples,
        volume,
        (g.x0, g.y1, g.step, g.nx, g.ny),
    ))
}

/// The whites the depth estimate takes, one array per channel of the design: its raws
/// under a white albedo, with 0 for the pixels of a sensor layout that take less than
/// `min_own_share` of their white through their own lens.
#[pyfunction]
#[pyo3(signature = (design, min_own_share, n_threads=None))]
pub(crate) fn depth_whites<'py>(
    py: Python<'py>,
    design: &DesignCore,
    min_own_share: f64,
    n_threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    let threads = threads_arg(n_threads)?;
    let d = &design.inner;
    if !(0.0..=1.0).contains(&min_own_share) {
        let e = splitlf_core::Error::param("min_own_share", min_own_share, "a share in [0, 1]");
        return Err(to_py(e));
    }
    splitlf_core::infra::memory::check("the depth sweep's whites", depth::whites_bytes(d))
        .map_err(to_py)?;
    let w = run_as(py, "depths", || {
        depth::sweep_whites(d, min_own_share, threads)
    })?;
    d.channels
        .iter()
        .zip(w.iter())
        .map(|(ch, v)| {
            let (r, c) = splitlf_core::imaging::render::raw_shape(ch);
            filled::<f64, numpy::Ix2>(py, &[r, c], "the depth sweep's whites", v.iter().copied())
        })
        .collect()
}

/// `depth_surface`'s result: the surface, its rounds, cuts and last-resort scale, and the
/// plane (z0, gx, gy) it was fitted into, if it was.
type SurfaceOut<'py> = (
    Bound<'py, PyArray2<f64>>,
    usize,
    usize,
    f64,
    Option<(f64, f64, f64)>,
);

/// The surface of a depth estimate that every ray through the design's main lens meets
/// at most once (`splitlf_core::inverse::depth::surface`): from its depths (rows from the
/// top, mm) over `extent`, its confidence and confident cells (None: every cell, fully):
/// (the surface's depths, the stiffening rounds, the edges cut as jumps, the last
/// resort's scale, the plane (z0, gx, gy) the surface was fitted into or None).
#[pyfunction]
#[pyo3(signature = (design, depth, extent, confidence=None, confident=None))]
pub(crate) fn depth_surface<'py>(
    py: Python<'py>,
    design: &DesignCore,
    depth: PyReadonlyArray2<'py, f64>,
    extent: (f64, f64, f64, f64),
    confidence: Option<PyReadonlyArray2<'py, f64>>,
    confident: Option<PyReadonlyArray2<'py, bool>>,
) -> PyResult<SurfaceOut<'py>> {
    let shape = depth.shape();
    let (rows, cols) = (shape[0], shape[1]);
    let z = depth.as_slice().map_err(internal)?;
    let c = confidence
        .as_ref()
        .map(|a| a.as_slice())
        .transpose()
        .map_err(internal)?;
    let k = confident
        .as_ref()
        .map(|a| a.as_slice())
        .transpose()
        .map_err(internal)?;
    let inp = depth::surface::Input {
        depth: z,
        confidence: c,
        confident: k,
        rows,
        cols,
        extent: [extent.0, extent.1, extent.2, extent.3],
        r: depth::surface::aperture_box(&design.inner),
    };
    let s = run_as(py, "depths", || depth::surface::surface(&inp))?;
    let arr = filled::<f64, numpy::Ix2>(py, &[rows, cols], "the surface", s.depth.into_iter())?;
    let plane = s.plane.map(|p| (p[0], p[1], p[2]));
    Ok((arr, s.rounds, s.cuts, s.scale, plane))
}
