//! PyO3 bindings of splitlf-core. Nothing physical lives here. The bindings mirror the
//! core's domains: [`infra`] (argument conversion, NumPy arrays in and out, error mapping to
//! the exceptions of `splitlf.errors`, GIL release with Ctrl-C checked between the core's
//! chunks of work), [`model`], [`sampling`], [`imaging`] and [`inverse`]; this file only
//! registers them.

mod imaging;
mod infra;
mod inverse;
mod model;
mod sampling;

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
    m.add(
        "DEPTH_DEFAULT_STEP",
        splitlf_core::inverse::depth::DEFAULT_STEP,
    )?;
    m.add(
        "PAD_NEAREST",
        splitlf_core::inverse::reconstruct::PAD_NEAREST,
    )?;
    m.add("DEPTH_MAX_WINDOW", splitlf_core::inverse::depth::MAX_RADIUS)?;
    m.add(
        "DEPTH_MAX_CANDIDATES",
        splitlf_core::inverse::depth::MAX_CANDIDATES,
    )?;
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
    infra::interrupt::numpy_ready(m.py())?;
    constants(m)?;
    classes!(m, model::design::CameraCore, model::design::DesignCore);
    classes!(
        m,
        model::optics::DesignCurvesArrays,
        model::optics::DesignDepthOfFieldIntervals,
        sampling::samples::DesignSamplesArrays,
        sampling::samples::PlaneColumns,
        sampling::rayspace::TraceArrays,
        sampling::rayspace::FootprintArrays,
        sampling::rayspace::SampleGridArrays,
        sampling::samples2d::ChiefSampleArrays,
        sampling::samples2d::Samples2dArrays,
        sampling::samples2d::CoverageArrays,
        inverse::simulate::SystemMatrixArrays,
        inverse::simulate::RenderArrays,
        imaging::render::RenderScene,
    );
    // Closed forms; samples along one axis and figures of merit; ray space; 2-D samples;
    // the simulation's forward model; the memory guard.
    functions!(
        m,
        model::optics::design_curves,
        model::optics::design_depth_of_field,
        model::optics::design_sharp_fractions,
        sampling::samples::design_new_samples,
        sampling::samples::design_coincidence_planes,
        sampling::samples::design_figures_of_merit,
        sampling::samples::design_metrics,
        sampling::rayspace::design_trace,
        sampling::rayspace::design_footprints,
        sampling::rayspace::design_sample_grid,
        sampling::samples2d::chief_samples,
        sampling::samples2d::samples_2d,
        sampling::samples2d::coverage,
        inverse::simulate::design_kernel_support,
        inverse::simulate::design_system_matrix,
        inverse::simulate::design_render,
        imaging::render::render,
        imaging::render::render_band,
        imaging::render::render_quadrature,
        imaging::render::render_extent,
        imaging::cfa::cfa_colours,
        imaging::cfa::cfa_mosaic,
        imaging::cfa::cfa_grey,
        inverse::reconstruct::seen_region,
        inverse::reconstruct::pixel_span,
        inverse::reconstruct::cell_grid,
        inverse::reconstruct::reconstruction_system,
        inverse::reconstruct::surface_system,
        inverse::reconstruct::reconstruction_factors,
        inverse::reconstruct::solve_normal,
        inverse::reconstruct::reconstruct,
        inverse::reconstruct::cell_averages,
        inverse::depth::estimate_depth,
        inverse::depth::depth_whites,
        inverse::depth::depth_surface,
        inverse::merit::image_merits,
        infra::arrays::available_memory,
    );
    Ok(())
}
