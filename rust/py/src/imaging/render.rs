//! The 2-D forward model: a scene (texture, surface, background) and the raws of every
//! channel of a design (docs/render.md).

use std::borrow::Cow;
use std::sync::Arc;

use numpy::{PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;

use splitlf_core::imaging::render::{self as core_render, NoiseTarget, RenderOptions};
use splitlf_core::imaging::scene::{Scene, Surface};
use splitlf_core::imaging::texture::Texture;

use crate::infra::args::threads_arg;
use crate::infra::arrays::empty;
use crate::infra::errors::{internal, to_py};
use crate::infra::interrupt::{counted, run_reporting};
use crate::model::design::DesignCore;

/// A validated scene of the forward model.
#[pyclass(frozen, module = "splitlf._native")]
pub(crate) struct RenderScene {
    pub(crate) inner: Arc<Scene>,
}

/// A 2-D float array's values in C order (borrowed when the array is C-contiguous, as
/// the Python side passes them: a random texture's 1e8 cells are not copied once more
/// before the core's own tables) and its shape.
fn array_parts<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> (Cow<'a, [f64]>, usize, usize) {
    let view = a.as_array();
    let (r, c) = view.dim();
    match a.as_slice() {
        Ok(v) => (Cow::Borrowed(v), r, c),
        Err(_) => (Cow::Owned(view.iter().copied().collect()), r, c),
    }
}

/// An optional array's parts as the core's constructors take them: (values, rows, cols).
fn values<'a>(
    parts: &'a Option<(Cow<'_, [f64]>, usize, usize)>,
) -> Option<(&'a [f64], usize, usize)> {
    parts.as_ref().map(|(v, r, c)| (&v[..], *r, *c))
}

#[pymethods]
impl RenderScene {
    #[new]
    #[pyo3(signature = (texture, texture_params, texture_image, surface, surface_params, depth_map, background))]
    fn new(
        texture: &str,
        texture_params: Vec<f64>,
        texture_image: Option<PyReadonlyArray2<'_, f64>>,
        surface: &str,
        surface_params: Vec<f64>,
        depth_map: Option<PyReadonlyArray2<'_, f64>>,
        background: f64,
    ) -> PyResult<Self> {
        let image = texture_image.as_ref().map(array_parts);
        let tex = Texture::from_parts(texture, &texture_params, values(&image)).map_err(to_py)?;
        let map = depth_map.as_ref().map(array_parts);
        let surf = Surface::from_parts(surface, &surface_params, values(&map)).map_err(to_py)?;
        let scene = Scene::new(tex, surf, background).map_err(to_py)?;
        Ok(RenderScene {
            inner: Arc::new(scene),
        })
    }

    /// The texture's mean albedo.
    #[getter]
    fn texture_mean(&self) -> f64 {
        self.inner.texture.mean()
    }
}

/// Every channel's raw image of `scene` (docs/model.md §10 layout), one float64 array per
/// channel. `tol`: the general route's error target per pixel, relative to a fully lit
/// pixel under the scene's largest albedo. `own_lens`: each pixel takes its own lens's
/// light alone (on a sensor layout, not its neighbours'; the depth sweep's test of clean
/// pixels).
/// A render's error target: `tol`, or (photons, read noise, fraction) of the noise.
#[derive(FromPyObject)]
pub(crate) enum Tol {
    Absolute(f64),
    Noise((f64, f64, f64)),
}

/// `tol` may instead be (photons, read_noise, fraction): each pixel's error target is the
/// fraction of the noise's standard deviation at its value (docs/render.md, "A target
/// relative to the noise").
/// `progress(done, total)` is called on the main thread while the render runs.
#[pyfunction]
#[pyo3(signature = (design, scene, tol=None, n_threads=None, progress=None, own_lens=false))]
pub(crate) fn render<'py>(
    py: Python<'py>,
    design: &DesignCore,
    scene: &RenderScene,
    tol: Option<Tol>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    own_lens: bool,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    let threads = threads_arg(n_threads)?;
    let d = design.inner.clone();
    let sc = Arc::clone(&scene.inner);
    let total: usize = d
        .channels
        .iter()
        .map(|ch| core_render::raw_shape(ch).0)
        .sum();
    let (report, counter) = counted(progress, total);
    let (tol, noise) = match tol {
        None => (core_render::DEFAULT_TOL, None),
        Some(Tol::Absolute(t)) => (t, None),
        Some(Tol::Noise((photons, read_noise, fraction))) => (
            core_render::DEFAULT_TOL,
            Some(NoiseTarget {
                photons,
                read_noise,
                fraction,
            }),
        ),
    };
    let opts = RenderOptions {
        tol,
        own_lens,
        noise,
    };
    core_render::check_render(&d, &sc, opts).map_err(to_py)?;
    let bytes = core_render::render_bytes(&d);
    splitlf_core::infra::memory::check("the rendered raw images", bytes).map_err(to_py)?;
    let mut out = Vec::with_capacity(d.channels.len());
    for ch in &d.channels {
        let (r, c) = core_render::raw_shape(ch);
        out.push(empty::<f64, numpy::Ix2>(
            py,
            &[r, c],
            "a rendered raw image",
        )?);
    }
    {
        let mut guards: Vec<_> = out.iter().map(|a| a.readwrite()).collect();
        let mut slices = Vec::with_capacity(guards.len());
        for g in guards.iter_mut() {
            slices.push(g.as_slice_mut().map_err(internal)?);
        }
        run_reporting(py, "z0", report, move || {
            core_render::render_into(&d, &sc, opts, threads, &counter, slices)
        })?;
    }
    Ok(out)
}

/// The object-space rectangle (X0, X1, Y0, Y1) on the fronto-parallel plane at depth z
/// holding every point any pixel of the design can see.
#[pyfunction]
pub(crate) fn render_extent(design: &DesignCore, z: f64) -> PyResult<(f64, f64, f64, f64)> {
    let e = core_render::view_extent(&design.inner, z).map_err(to_py)?;
    Ok((e[0], e[1], e[2], e[3]))
}
