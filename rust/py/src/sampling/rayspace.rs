//! Ray space (docs/model.md §3–5): integration polygons, footprints over depth and the
//! sample grid on one plane.

use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;

use splitlf_core::infra::memory;
use splitlf_core::sampling::line::Line;
use splitlf_core::sampling::rayspace::{self, MAX_VERTICES};

use crate::infra::args::{as_slice, channel_arg, sample_arg, threads_arg};
use crate::infra::arrays::{empty, filled};
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::run;
use crate::model::design::DesignCore;

/// Integration polygons of n pixels of one half (or channel) along one axis.
#[pyclass(frozen, get_all, module = "splitlf._native")]
pub(crate) struct TraceArrays {
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

/// Integration polygons of every pixel of one channel of a design along one axis (rect
/// grids; docs/model.md §3–4, §9).
#[pyfunction]
#[pyo3(signature = (design, channel, axis="x", n_threads=None))]
pub(crate) fn design_trace(
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
    let line = &Line::of_channel(d, ch, ax).map_err(to_py)?;
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

/// Footprints of n pixels at m depths: (m, n) arrays; the kernel (m, n, 6) when asked.
#[pyclass(frozen, get_all, module = "splitlf._native")]
pub(crate) struct FootprintArrays {
    position: Py<PyArray2<f64>>,
    lo: Py<PyArray2<f64>>,
    hi: Py<PyArray2<f64>>,
    kernel_breaks: Option<Py<PyArray3<f64>>>,
    kernel_values: Option<Py<PyArray3<f64>>>,
}

/// Footprints of every pixel of one channel of a design along one axis at every depth
/// (rect grids; docs/model.md §5, §9).
#[pyfunction]
#[pyo3(signature = (design, z, channel, axis="x", sample="centroid", kernel=false, n_threads=None))]
pub(crate) fn design_footprints(
    design: &DesignCore,
    z: PyReadonlyArray1<'_, f64>,
    channel: &Bound<'_, PyAny>,
    axis: &str,
    sample: &str,
    kernel: bool,
    n_threads: Option<&Bound<'_, PyAny>>,
) -> PyResult<FootprintArrays> {
    let py = z.py();
    let d = &design.inner;
    let ch = channel_arg(d, channel)?;
    let ax = rayspace::axis_from_name(axis).map_err(to_py)?;
    let s = sample_arg(sample)?;
    let threads = threads_arg(n_threads)?;
    let zs = &*as_slice(&z)?;
    let line = &Line::of_channel(d, ch, ax).map_err(to_py)?;
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
pub(crate) struct SampleGridArrays {
    #[pyo3(name = "X")]
    x: Py<PyArray2<f64>>,
    #[pyo3(name = "Y")]
    y: Py<PyArray2<f64>>,
}

/// Sample positions of every pixel of one channel of a design (rect grid) on the plane at
/// depth z; NaN where a pixel yields no sample.
#[pyfunction]
#[pyo3(signature = (design, z, channel, sample="chief", n_threads=None))]
pub(crate) fn design_sample_grid(
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
