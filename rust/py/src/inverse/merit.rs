//! Image merits (docs/merits.md): the expected error and the edge response of a design's
//! reconstruction at one depth, computed in the core (`inverse::merit`).

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use splitlf_core::inverse::merit as core_merit;

use crate::infra::args::threads_arg;
use crate::infra::errors::to_py;
use crate::infra::interrupt::{counted, run_reporting};
use crate::inverse::reconstruct::{channel_indices, from_one};
use crate::model::design::DesignCore;

/// A merit's request, from a dict (Python has checked the types and ranges; the core
/// checks again): `channels` (numbered from 1), `lens_types` (from 1; None: every type),
/// `photons` for white, `ensemble` (mean, amplitude, exponent, floor, spectrum: knots (f, S),
/// empty for the power law), `patch` (cells a side),
/// `step` (None: δ(z)), `regularization` (None: chosen by `rule`, "gcv" from the draws'
/// data as a reconstruction chooses it, "weighted gcv" the same with the fit's degrees of
/// freedom charged `df_weight` times, or "oracle", the least expected error) and
/// `settings` (noise floor, CG rtol, CG max_iter, draws, λ lo, λ hi, golden steps, seed,
/// margin in pixel spans, GCV's probes, the probes' rtol, GCV's parabolic step instead of
/// golden sections) and `coarse` (CG's two-level preconditioner instead of Jacobi alone).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct MeritRequest {
    channels: Vec<i64>,
    lens_types: Option<Vec<i64>>,
    photons: f64,
    ensemble: (f64, f64, f64, f64, Vec<(f64, f64)>),
    patch: usize,
    step: Option<f64>,
    regularization: Option<f64>,
    rule: String,
    df_weight: f64,
    settings: (
        f64,
        f64,
        usize,
        usize,
        f64,
        f64,
        usize,
        u64,
        f64,
        usize,
        f64,
        bool,
    ),
    coarse: bool,
}

/// The merits of `design` at depth `z` (a fronto-parallel plane) as `request` asks
/// ([`MeritRequest`]), with the mean response to the texture of `edge` (a scene; None:
/// none). Returns a dict: lam, mse, error, draws, trials ((lam, mse, error) each), gcv
/// ((lam, score, RSS, df) each, GCV's trials), edge
/// ((ny, nx) array or None), extent, step, padded (nx, ny), rows, iterations.
/// `progress(done, total)` counts CG iterations.
#[pyfunction]
#[pyo3(signature = (design, z, request, edge=None, n_threads=None, progress=None))]
pub(crate) fn image_merits<'py>(
    py: Python<'py>,
    design: &DesignCore,
    z: f64,
    request: MeritRequest,
    edge: Option<&Bound<'py, crate::imaging::render::RenderScene>>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let threads = threads_arg(n_threads)?;
    let channels = channel_indices(design, Some(request.channels))?;
    let lens_types = request
        .lens_types
        .map(|v| from_one("lens_types", v))
        .transpose()?;
    let (
        noise_floor,
        rtol,
        max_iter,
        samples,
        lo,
        hi,
        golden_steps,
        seed,
        margin,
        probes,
        probe_rtol,
        parabola,
    ) = request.settings;
    let coarse = request.coarse;
    let lambda = match (request.regularization, request.rule.as_str()) {
        (Some(l), _) => core_merit::Lambda::Given(l),
        (None, "gcv") => core_merit::Lambda::Gcv(1.0),
        (None, "weighted gcv") => core_merit::Lambda::Gcv(request.df_weight),
        (None, "oracle") => core_merit::Lambda::Oracle,
        (None, r) => {
            return Err(to_py(splitlf_core::Error::param(
                "rule",
                r,
                "\"gcv\", \"weighted gcv\" or \"oracle\"",
            )))
        }
    };
    let (mean, amplitude, exponent, floor, knots) = request.ensemble;
    let spectrum: Vec<[f64; 2]> = knots.into_iter().map(|(f, s)| [f, s]).collect();
    let scene = edge.map(|s| Arc::clone(&s.get().inner));
    let d = &design.inner;
    let (report, counter) = counted(progress, 0);
    let out = run_reporting(py, "z", report, || {
        let req = core_merit::Request {
            design: d,
            depth: z,
            channels,
            lens_types,
            photons: request.photons,
            ensemble: core_merit::Ensemble {
                mean,
                amplitude,
                exponent,
                floor,
                spectrum,
            },
            edge: scene.as_ref().map(|s| &s.texture),
            patch: request.patch,
            step: request.step,
            lambda,
            settings: core_merit::Settings {
                noise_floor,
                rtol,
                max_iter,
                samples,
                lo,
                hi,
                golden_steps,
                seed,
                margin,
                probes,
                probe_rtol,
                parabola,
                coarse,
            },
            n_threads: threads,
        };
        core_merit::image_merits(&req, &counter)
    })?;
    let dict = PyDict::new(py);
    dict.set_item("lam", out.lam)?;
    dict.set_item("mse", out.mse)?;
    dict.set_item("error", out.error)?;
    dict.set_item("draws", out.draws)?;
    let trials: Vec<(f64, f64, f64)> = out.trials.iter().map(|t| (t.lam, t.mse, t.error)).collect();
    dict.set_item("trials", trials)?;
    let gcv: Vec<(f64, f64, f64, f64)> = out
        .gcv
        .iter()
        .map(|t| (t.lam, t.score, t.rss, t.df))
        .collect();
    dict.set_item("gcv", gcv)?;
    let edge = match out.edge {
        Some(v) => Some(crate::infra::arrays::filled::<f64, numpy::Ix2>(
            py,
            &[out.ny, out.nx],
            "the edge's expected image",
            v.into_iter(),
        )?),
        None => None,
    };
    dict.set_item("edge", edge)?;
    dict.set_item(
        "extent",
        (out.extent[0], out.extent[1], out.extent[2], out.extent[3]),
    )?;
    dict.set_item("step", out.step)?;
    dict.set_item("padded", (out.padded[0], out.padded[1]))?;
    dict.set_item("rows", out.rows)?;
    dict.set_item("iterations", out.iterations)?;
    Ok(dict)
}
