//! Depth from the raw: the core's plane sweep (docs/model.md §11, docs/depth.md).

use numpy::{PyArray2, PyArray4, PyReadonlyArray2};
use pyo3::prelude::*;

use splitlf_core::inverse::depth;

use crate::infra::args::threads_arg;
use crate::infra::arrays::filled;
use crate::infra::errors::internal;
use crate::infra::interrupt::{counted, run_reporting};
use crate::inverse::reconstruct::{channel_indices, checked_grid};
use crate::model::design::DesignCore;

type SweepTuple<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<i64>>,
    usize,
    Option<Bound<'py, PyArray4<f64>>>,
);

/// The plane sweep of `raws` (one C-contiguous image per chosen channel) with `whites`
/// (the same channels' raws under a white albedo) over the increasing `candidates` on the
/// grid (X0, Y1, step, nx, ny), windows of (2 radius + 1)^2 cells: (depth, fractional
/// candidate index, confidence, least cost, mean cost, the channel (numbered from 1) whose
/// curve gave the estimate) per cell (ny, nx), the pixels used, and the cost volume
/// (candidates, chosen channels, ny, nx) when `keep_volume`. `progress(done, total)` counts
/// candidates.
#[pyfunction]
#[pyo3(signature = (design, raws, whites, grid, candidates, channels=None, radius=3, keep_volume=false, n_threads=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn depth_sweep<'py>(
    py: Python<'py>,
    design: &DesignCore,
    raws: Vec<PyReadonlyArray2<'py, f64>>,
    whites: Vec<PyReadonlyArray2<'py, f64>>,
    grid: (f64, f64, f64, usize, usize),
    candidates: Vec<f64>,
    channels: Option<Vec<i64>>,
    radius: usize,
    keep_volume: bool,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<SweepTuple<'py>> {
    let threads = threads_arg(n_threads)?;
    let ch = channel_indices(design, channels)?;
    let g = checked_grid(grid)?;
    let d = design.inner.clone();
    let mut raw_s = Vec::with_capacity(raws.len());
    for a in &raws {
        raw_s.push(a.as_slice().map_err(internal)?);
    }
    let mut white_s = Vec::with_capacity(whites.len());
    for a in &whites {
        white_s.push(a.as_slice().map_err(internal)?);
    }
    let (report, counter) = counted(progress, candidates.len());
    let chosen = ch.clone();
    let s = run_reporting(py, "depths", report, move || {
        depth::sweep(
            &d,
            &ch,
            &raw_s,
            &white_s,
            &g,
            &candidates,
            radius,
            keep_volume,
            threads,
            &counter,
        )
    })?;
    let shape = [g.ny, g.nx];
    let arr = |v: Vec<f64>, what: &str| filled::<f64, numpy::Ix2>(py, &shape, what, v.into_iter());
    let nch = chosen.len();
    let volume = match s.volume {
        Some(v) => {
            let n = v.len() / (nch * g.ny * g.nx).max(1);
            Some(filled::<f64, numpy::Ix4>(
                py,
                &[n, nch, g.ny, g.nx],
                "the depth sweep's cost volume",
                v.into_iter(),
            )?)
        }
        None => None,
    };
    Ok((
        arr(s.depth, "the depth estimate")?,
        arr(s.index, "the depth estimate's candidate index")?,
        arr(s.confidence, "the depth estimate's confidence")?,
        arr(s.min_cost, "the depth estimate's least cost")?,
        arr(s.mean_cost, "the depth estimate's mean cost")?,
        filled::<i64, numpy::Ix2>(
            py,
            &shape,
            "the depth estimate's channel",
            s.channel.iter().map(|&c| chosen[c as usize] as i64 + 1),
        )?,
        s.samples,
        volume,
    ))
}
