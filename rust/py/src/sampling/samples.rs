//! Samples along one axis (docs/model.md §6, §9): genuinely new samples, coincidence
//! planes, and the figures of merit sweeps compare.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;

use splitlf_core::{model::optics, sampling::merit, sampling::samples, Error};

use crate::infra::args::{
    as_slice, channel_arg, int_arg, sample_arg, saturate, threads_arg, with_given,
};
use crate::infra::arrays::{as_u64, empty, filled};
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::{run, run_as};
use crate::model::design::DesignCore;

/// Coincidence planes of one half sorted by depth, one column per field.
#[pyclass(frozen, get_all, module = "splitlf._native")]
pub(crate) struct PlaneColumns {
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

/// max_n and max_t as given (any size), or their defaults: (value, text) each.
pub(crate) type PairArgs = ((i128, String), Option<(i128, String)>);

pub(crate) fn pair_args(
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
pub(crate) fn pair_error(e: Error, n_text: &str, t_text: &str) -> Error {
    match &e {
        Error::InvalidParameter { name: "max_n", .. } => with_given(e, n_text),
        Error::InvalidParameter { name: "max_t", .. } => with_given(e, t_text),
        _ => e,
    }
}

pub(crate) fn plane_columns(
    py: Python<'_>,
    p: &[samples::CoincidencePlane],
) -> PyResult<PlaneColumns> {
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
pub(crate) fn design_coincidence_planes(
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
pub(crate) struct DesignSamplesArrays {
    distinct: Py<PyArray2<i64>>,
    max_gap: Py<PyArray2<f64>>,
    /// Pixels along x that yield a sample, per channel and in all (C + 1).
    sampled: Py<PyArray1<i64>>,
}

/// Distinct samples along x and max gaps of every channel of a design and of their union
/// at every depth (docs/model.md §6, §9).
#[pyfunction]
#[pyo3(signature = (design, z, tol=samples::DEFAULT_TOL, sample="chief", n_threads=None))]
pub(crate) fn design_new_samples(
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

/// Names of a design's figures of merit, in the order of `design_figures_of_merit`; with
/// `merits_2d`, followed by the names of its 2-D merits.
#[pyfunction]
#[pyo3(signature = (design, merits_2d=false))]
pub(crate) fn design_metrics(design: &DesignCore, merits_2d: bool) -> Vec<String> {
    let c = design.inner.channels.len();
    let mut out = merit::design_metrics(c);
    if merits_2d {
        out.extend(merit::design_metrics_2d(c));
    }
    out
}

/// Figures of merit of a design over depths, per channel and union (see
/// `splitlf.merits.merit_names`), followed by its 2-D merits when `window` is given.
#[pyfunction]
#[pyo3(signature = (design, z, threshold_px=optics::DEFAULT_THRESHOLD_PX, tol=samples::DEFAULT_TOL, n_threads=None, window=None))]
pub(crate) fn design_figures_of_merit(
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
