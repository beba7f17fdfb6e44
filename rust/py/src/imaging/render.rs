//! The 2-D forward model: a scene (texture, surface, background) and the raws of every
//! channel of a design (docs/render.md).

use std::borrow::Cow;
use std::sync::Arc;

use numpy::{PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;

use splitlf_core::imaging::render::{self as core_render, Falloff, NoiseTarget, RenderOptions};
use splitlf_core::imaging::scene::{Scene, Surface};
use splitlf_core::imaging::texture::Texture;

use crate::infra::args::{int_arg, threads_arg, with_given};
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

/// A render's error target: `tol`, or (photons, read noise, fraction) of the noise.
#[derive(FromPyObject)]
pub(crate) enum Tol {
    Absolute(f64),
    Noise((f64, f64, f64)),
}

/// The core's `tol` and noise target from the binding's `tol`.
fn tol_options(tol: Option<Tol>) -> (f64, Option<NoiseTarget>) {
    match tol {
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
    }
}

/// The core's falloff from the binding's name (None: off; an unknown name is refused
/// naming `falloff`).
fn falloff_arg(name: Option<&str>) -> PyResult<Falloff> {
    name.map_or(Ok(Falloff::None), |n| Falloff::from_name(n).map_err(to_py))
}

/// Every channel's raw image of `scene` (docs/model.md §10 layout), one float64 array per
/// channel. `tol`: the general route's error target per pixel, relative to a fully lit
/// pixel under the scene's largest albedo. `own_lens`: each pixel takes its own lens's
/// light alone (on a sensor layout, not its neighbours'; the depth sweep's test of clean
/// pixels).
/// `tol` may instead be (photons, read_noise, fraction): each pixel's error target is the
/// fraction of the noise's standard deviation at its value (docs/render.md, "A target
/// relative to the noise").
/// `falloff`: None, "none", "microlens", "main" or "both", the cos⁴ factors that weight
/// each ray (docs/model.md §10, "Radiometric falloff").
/// `progress(done, total)` is called on the main thread while the render runs.
#[pyfunction]
#[pyo3(signature = (design, scene, tol=None, n_threads=None, progress=None, own_lens=false, falloff=None))]
pub(crate) fn render<'py>(
    design: &DesignCore,
    scene: &Bound<'py, RenderScene>,
    tol: Option<Tol>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    own_lens: bool,
    falloff: Option<String>,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    let base = RenderOptions {
        own_lens,
        falloff: falloff_arg(falloff.as_deref())?,
        closed_form: true,
        ..RenderOptions::default()
    };
    render_raws(design, scene, (tol, base), n_threads, progress)
}

/// Every channel's raw as [`render`] makes it at `tol`, but with each of the general
/// route's boxes by the adaptive quadrature, none in closed form (docs/render.md, "The
/// interior in closed form"): the reference the closed form's tests and benches compare
/// with.
#[pyfunction]
#[pyo3(signature = (design, scene, tol=None, n_threads=None))]
pub(crate) fn render_quadrature<'py>(
    design: &DesignCore,
    scene: &Bound<'py, RenderScene>,
    tol: Option<Tol>,
    n_threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    let base = RenderOptions {
        closed_form: false,
        ..RenderOptions::default()
    };
    render_raws(design, scene, (tol, base), n_threads, None)
}

/// The raws of [`render`] and [`render_quadrature`]: `base`'s options with the error
/// target `tol` ([`tol_options`]); `progress(done, total)` counts raw rows.
fn render_raws<'py>(
    design: &DesignCore,
    scene: &Bound<'py, RenderScene>,
    (tol, base): (Option<Tol>, RenderOptions),
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    // (The GIL token from the scene.)
    let py = scene.py();
    let threads = threads_arg(n_threads)?;
    let d = design.inner.clone();
    let sc = Arc::clone(&scene.get().inner);
    let total: usize = d
        .channels
        .iter()
        .map(|ch| core_render::raw_shape(ch).0)
        .sum();
    let (report, counter) = counted(progress, total);
    let (tol, noise) = tol_options(tol);
    let opts = RenderOptions { tol, noise, ..base };
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

/// An index argument as the core's usize: a negative or huge value saturates out of
/// every range (the core's error then shows the value as given).
fn index_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(usize, String)> {
    let (v, text) = int_arg(obj, name)?;
    Ok((usize::try_from(v).unwrap_or(usize::MAX), text))
}

/// The raw rows [r0, r1) of channel `channel` (from 0) of `scene`, `band` = (channel, r0,
/// r1): a 2-D float64 array of r1 − r0 rows, bit for bit those rows of [`render`]'s raw (a
/// band of a render split over tasks). `tol`, `n_threads`, `progress` (in rows of the
/// band) and `falloff` as [`render`]; a channel or rows outside the design are refused
/// naming `channel` or `rows`.
#[pyfunction]
#[pyo3(signature = (design, scene, band, tol=None, n_threads=None, progress=None, falloff=None))]
pub(crate) fn render_band<'py>(
    design: &DesignCore,
    scene: &Bound<'py, RenderScene>,
    band: &Bound<'py, PyAny>,
    tol: Option<Tol>,
    n_threads: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    falloff: Option<String>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (py, scene) = (scene.py(), scene.get());
    let parts: Vec<Bound<'py, PyAny>> = match band.extract() {
        Ok(v) if !band.is_instance_of::<pyo3::types::PyString>() => v,
        _ => Vec::new(),
    };
    let [c, r0, r1] = &parts[..] else {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "band must be (channel, r0, r1), three integers, got {}",
            band.repr()?
        )));
    };
    let threads = threads_arg(n_threads)?;
    let (channel, c_text) = index_arg(c, "channel")?;
    let ((a, a_text), (b, b_text)) = (index_arg(r0, "r0")?, index_arg(r1, "r1")?);
    let d = design.inner.clone();
    let sc = Arc::clone(&scene.inner);
    let band = core_render::Band {
        channel,
        rows: a..b,
    };
    let (tol, noise) = tol_options(tol);
    let opts = RenderOptions {
        tol,
        noise,
        falloff: falloff_arg(falloff.as_deref())?,
        ..RenderOptions::default()
    };
    core_render::check_render(&d, &sc, opts).map_err(to_py)?;
    let (_, cols) = core_render::check_band(&d, &band).map_err(|e| {
        let given = match &e {
            splitlf_core::Error::InvalidParameter {
                name: "channel", ..
            } => c_text.clone(),
            _ => format!("[{a_text}, {b_text})"),
        };
        to_py(with_given(e, &given))
    })?;
    let n = b - a;
    let bytes = (n as u128) * (cols as u128) * 8;
    splitlf_core::infra::memory::check("a band of a rendered raw", bytes).map_err(to_py)?;
    let out = empty::<f64, numpy::Ix2>(py, &[n, cols], "a band of a rendered raw")?;
    let (report, counter) = counted(progress, n);
    {
        let mut guard = out.readwrite();
        let slice = guard.as_slice_mut().map_err(internal)?;
        run_reporting(py, "z0", report, move || {
            core_render::render_band_into(&d, &sc, opts, &band, (threads, &counter), slice)
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
