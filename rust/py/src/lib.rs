//! PyO3 bindings of splitlf-core. Nothing physical lives here: argument conversion
//! ([`args`]), GIL release around the core with Ctrl-C checked between the core's chunks of
//! work ([`interrupt`]), fallible allocation of the NumPy outputs ([`arrays`]), named
//! result objects, and the mapping of core errors to the exceptions of `splitlf.errors`
//! ([`errors`]). The bindings are split by domain: [`design`] (the validated models),
//! [`optics`], [`samples`], [`rayspace`], [`coverage`], [`simulate`] and [`render`]; this file only
//! registers them.

mod args;
mod arrays;
mod coverage;
mod depth;
mod design;
mod errors;
mod interrupt;
mod optics;
mod rayspace;
mod reconstruct;
mod render;
mod samples;
mod simulate;

use pyo3::prelude::*;

use splitlf_core::{
    infra::parallel, model::design as core_design, model::lens, model::optics as core_optics,
};
use splitlf_core::{
    inverse::simulate as core_simulate, sampling::samples as core_samples, sampling::samples2d,
};

/// Limits and defaults: the single source for the Python layer and the CLI.
fn constants(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("MAX_THREADS", parallel::MAX_THREADS)?;
    m.add("MAX_POOLS", parallel::MAX_POOLS)?;
    m.add("MAX_Q", lens::MAX_Q)?;
    m.add("MAX_K", lens::MAX_K)?;
    m.add("DEFAULT_TOL", core_samples::DEFAULT_TOL)?;
    m.add("DEFAULT_THRESHOLD_PX", core_optics::DEFAULT_THRESHOLD_PX)?;
    m.add("DEFAULT_MAX_N", core_samples::DEFAULT_MAX_N)?;
    m.add("MAX_PAIRS", core_samples::MAX_PAIRS)?;
    m.add("MAX_SAMPLES_PER_AXIS", core_samples::MAX_SAMPLES_PER_AXIS)?;
    m.add("MAX_COINCIDENCE_WORK", core_samples::MAX_COINCIDENCE_WORK)?;
    m.add("MAX_CELLS", core_simulate::MAX_CELLS)?;
    m.add("MAX_CHANNELS", core_design::MAX_CHANNELS)?;
    m.add("MAX_TYPES", core_design::MAX_TYPES)?;
    m.add("MAX_M", core_design::MAX_M)?;
    m.add("DEFAULT_WINDOW", samples2d::DEFAULT_WINDOW)?;
    m.add("MAX_TOL_2D", samples2d::MAX_TOL_2D)?;
    m.add("MAX_COVERAGE_WORK", samples2d::MAX_COVERAGE_WORK)?;
    m.add("RENDER_TOL", splitlf_core::imaging::render::DEFAULT_TOL)?;
    m.add(
        "OUTSIDE_SHARE",
        splitlf_core::inverse::system::OUTSIDE_SHARE,
    )?;
    m.add("MIN_RENDER_TOL", splitlf_core::imaging::render::MIN_TOL)?;
    Ok(())
}

/// Register classes and functions: `classes!(m, path::A, path::B)` and
/// `functions!(m, path::f, path::g)`.
macro_rules! classes {
    ($m:expr, $($c:path),+ $(,)?) => { $($m.add_class::<$c>()?;)+ };
}
macro_rules! functions {
    ($m:expr, $($f:path),+ $(,)?) => { $($m.add_function(wrap_pyfunction!($f, $m)?)?;)+ };
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    interrupt::numpy_ready(m.py())?;
    constants(m)?;
    classes!(m, design::CameraCore, design::DesignCore);
    classes!(
        m,
        optics::DesignCurvesArrays,
        optics::DesignDepthOfFieldIntervals,
        samples::DesignSamplesArrays,
        samples::PlaneColumns,
        rayspace::TraceArrays,
        rayspace::FootprintArrays,
        rayspace::SampleGridArrays,
        coverage::ChiefSampleArrays,
        coverage::Samples2dArrays,
        coverage::CoverageArrays,
        simulate::SystemMatrixArrays,
        simulate::RenderArrays,
        render::RenderScene,
    );
    // Closed forms; samples along one axis and figures of merit; ray space; 2-D samples;
    // the simulation's forward model; the memory guard.
    functions!(
        m,
        optics::design_curves,
        optics::design_depth_of_field,
        optics::design_sharp_fractions,
        samples::design_new_samples,
        samples::design_coincidence_planes,
        samples::design_figures_of_merit,
        samples::design_metrics,
        rayspace::design_trace,
        rayspace::design_footprints,
        rayspace::design_sample_grid,
        coverage::chief_samples,
        coverage::samples_2d,
        coverage::coverage,
        simulate::design_kernel_support,
        simulate::design_system_matrix,
        simulate::design_render,
        render::render,
        render::render_extent,
        reconstruct::seen_region,
        reconstruct::pixel_span,
        reconstruct::cell_grid,
        reconstruct::reconstruction_system,
        reconstruct::surface_system,
        reconstruct::reconstruction_factors,
        reconstruct::solve_normal,
        reconstruct::cell_averages,
        depth::depth_sweep,
        arrays::available_memory,
    );
    Ok(())
}
