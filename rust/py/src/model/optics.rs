//! Closed forms over depth (docs/model.md §2, §9): curves, depth of field, sharp fractions.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;

use splitlf_core::{infra::memory, model::optics};

use crate::infra::args::{as_slice, threads_arg};
use crate::infra::arrays::empty;
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::run;
use crate::model::design::DesignCore;

pub(crate) type Intervals = Vec<(f64, f64)>;

/// Sharp fractions in log depth over [lo, hi] of every row of a design's depth of field:
/// (per (channel, type) row, per channel, union, per channel's conventional camera).
#[pyfunction]
#[pyo3(signature = (design, threshold_px, lo, hi))]
pub(crate) fn design_sharp_fractions(
    design: &DesignCore,
    threshold_px: f64,
    lo: f64,
    hi: f64,
) -> PyResult<optics::DesignFractions> {
    optics::design_sharp_fractions(&design.inner, threshold_px, lo, hi).map_err(to_py)
}

/// Closed-form curves of a design at n depths: per-channel arrays (C, n), per-type arrays
/// (R, n) in `splitlf_core::model::optics::type_rows` order, the union (n).
#[pyclass(frozen, get_all, module = "splitlf._native")]
pub(crate) struct DesignCurvesArrays {
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
pub(crate) fn design_curves(
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
pub(crate) struct DesignDepthOfFieldIntervals {
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
pub(crate) fn design_depth_of_field(
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
