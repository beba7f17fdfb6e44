//! 2-D samples of a design (docs/model.md §9): chief samples, distinct samples and the
//! covering radius on one plane and over depths.

use numpy::ndarray::Ix2;
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use splitlf_core::sampling::samples2d;

use crate::infra::args::{as_slice, channel_arg, threads_arg};
use crate::infra::arrays::{as_u64, empty, filled};
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::run;
use crate::model::design::DesignCore;

/// Every pixel of one channel (rows y, columns x of its pixel grid): chief sample (X, Y)
/// [mm] (NaN where unlit), lit flag, lens (j, k) and lens type.
#[pyclass(frozen, get_all, module = "splitlf._native")]
pub(crate) struct ChiefSampleArrays {
    #[pyo3(name = "X")]
    x: Py<PyArray2<f64>>,
    #[pyo3(name = "Y")]
    y: Py<PyArray2<f64>>,
    lit: Py<PyArray2<bool>>,
    lens: Py<PyArray3<i64>>,
    #[pyo3(name = "type")]
    types: Py<PyArray2<i64>>,
}

/// Chief samples of every pixel of channel `channel` on the plane at depth z (of the pixel
/// rows [start, stop) only when `rows` is given).
#[pyfunction]
#[pyo3(signature = (design, channel, z, n_threads=None, rows=None))]
pub(crate) fn chief_samples(
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
pub(crate) struct Samples2dArrays {
    /// One (n_k, 2) array [X, Y] per row: the representatives inside the central field.
    samples: Py<PyTuple>,
    distinct: Py<PyArray1<i64>>,
    covering_radius: Py<PyArray1<f64>>,
    covering_radius_mm: Py<PyArray1<f64>>,
}

/// Distinct samples and covering radius of every channel and of the union at depth z.
#[pyfunction]
#[pyo3(signature = (design, z, tol, window))]
pub(crate) fn samples_2d(
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
pub(crate) struct CoverageArrays {
    distinct: Py<PyArray2<i64>>,
    covering_radius: Py<PyArray2<f64>>,
    covering_radius_mm: Py<PyArray2<f64>>,
}

/// Distinct 2-D samples and covering radius of every channel and of the union at every
/// depth, parallel over depths.
#[pyfunction]
#[pyo3(signature = (design, z, tol, window, n_threads=None))]
pub(crate) fn coverage(
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
