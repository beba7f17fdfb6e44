//! The validated models held by the core: `CameraCore` (the paper's parametrisation, which
//! builds a two-channel design) and `DesignCore` (docs/model.md §9).

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use splitlf_core::model::camera::CameraSpec;
use splitlf_core::model::optics::LensOptics;
use splitlf_core::{model::design, model::lens, model::optics, model::presets, Camera, Design};

use crate::infra::args::{half_arg, int_arg, saturate, with_given};
use crate::infra::arrays::filled;
use crate::infra::errors::to_py;

/// A validated camera held by the core (wrapped by `splitlf.Camera`): the paper's
/// parametrisation and the two-channel design it builds (channel i is half i), validated
/// as that design is.
#[pyclass(frozen, skip_from_py_object, module = "splitlf._native")]
pub(crate) struct CameraCore {
    pub(crate) inner: Camera,
    design: Design,
}

impl CameraCore {
    fn of(inner: Camera) -> Self {
        CameraCore {
            design: inner.design(),
            inner,
        }
    }

    /// The design's channel of half `half_` (1 or 2).
    fn half(&self, half_: &Bound<'_, PyAny>) -> PyResult<LensOptics> {
        let ch = &self.design.channels[half_arg(half_)?.index()];
        Ok(LensOptics::of_channel(&self.design, ch, 0))
    }
}

#[pymethods]
impl CameraCore {
    /// The camera of `fields`, a dict keyed by `splitlf.Camera`'s field names (F, D, v1,
    /// kappa, d, v, mu, Q, Kx, Ky, f1, f2; f1/f2 None for Ng's setting).
    #[new]
    fn new(fields: &Bound<'_, PyDict>) -> PyResult<Self> {
        let inner = Camera::new(&camera_spec(fields)?).map_err(to_py)?;
        Ok(CameraCore::of(inner))
    }

    /// The seed design of docs/model.md §7.
    #[staticmethod]
    fn paper() -> Self {
        CameraCore::of(Camera::paper())
    }

    /// (F, D, v1, kappa, d, v, mu, Q, Kx, Ky, f1, f2), with f1/f2 resolved.
    fn fields(&self) -> (f64, f64, f64, f64, f64, f64, f64, u32, u32, u32, f64, f64) {
        let c = &self.inner;
        (
            c.f_main, c.aperture, c.v1, c.kappa, c.d, c.v, c.mu, c.q, c.kx, c.ky, c.f1, c.f2,
        )
    }

    /// L_i, channel i's array plane.
    fn array_plane(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.half(half_)?.l)
    }

    fn out_of_focus_depth(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.half(half_)?.out_of_focus_depth())
    }

    fn image_radius(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.half(half_)?.image_radius())
    }

    /// Lit pixels per lens along x of channel i (its first lens's Q pixels).
    fn lit_pixels(&self, half_: &Bound<'_, PyAny>) -> PyResult<u32> {
        Ok(self.inner.lit_pixels(half_arg(half_)?))
    }

    fn ng_focal_length(&self, half_: &Bound<'_, PyAny>) -> PyResult<f64> {
        let o = self.half(half_)?;
        Ok(lens::ng_focal_length(o.l, o.v))
    }

    fn rho(&self) -> f64 {
        self.inner.rho()
    }

    fn f_number(&self) -> f64 {
        self.inner.f_number()
    }

    /// δ(z) = d z / (Q v') (docs/model.md §6); z must be a valid depth.
    fn resolution_step(&self, z: f64) -> PyResult<f64> {
        optics::check_design_depths(self.design.f_main, &[z]).map_err(to_py)?;
        Ok(self.inner.resolution_step(z))
    }
}

// ---- designs (docs/model.md §9) ----------------------------------------------------------

/// One key of a channel's dict (see `splitlf.design.Channel`), converted.
pub(crate) fn item<'py, T: FromPyObjectOwned<'py>>(
    d: &Bound<'py, PyDict>,
    key: &str,
) -> PyResult<T> {
    match d.get_item(key)? {
        Some(v) => v.extract::<T>().map_err(Into::into),
        None => Err(PyRuntimeError::new_err(format!(
            "internal: dict without {key:?}"
        ))),
    }
}

/// The core's [`CameraSpec`] from `splitlf.Camera`'s fields as its constructor checked
/// their types (a dict keyed by the Python names).
fn camera_spec(d: &Bound<'_, PyDict>) -> PyResult<CameraSpec> {
    Ok(CameraSpec {
        f_main: item(d, "F")?,
        aperture: item(d, "D")?,
        v1: item(d, "v1")?,
        kappa: item(d, "kappa")?,
        d: item(d, "d")?,
        v: item(d, "v")?,
        mu: item(d, "mu")?,
        q: item(d, "Q")?,
        kx: item(d, "Kx")?,
        ky: item(d, "Ky")?,
        f1: item(d, "f1")?,
        f2: item(d, "f2")?,
    })
}

pub(crate) fn channel_spec(d: &Bound<'_, PyDict>) -> PyResult<design::ChannelSpec> {
    let grid: String = item(d, "grid")?;
    let grid = design::Grid::from_name(&grid).map_err(to_py)?;
    Ok(design::ChannelSpec {
        l: item(d, "L")?,
        d: item(d, "d")?,
        v: item(d, "v")?,
        mu: item(d, "mu")?,
        kx: item(d, "Kx")?,
        ky: item(d, "Ky")?,
        grid,
        f: item(d, "f")?,
        layout: item(d, "layout")?,
        q: item(d, "Q")?,
        mx: item(d, "Mx")?,
        my: item(d, "My")?,
        share: item(d, "share")?,
    })
}

/// A validated design (docs/model.md §9): main lens and channels.
#[pyclass(frozen, skip_from_py_object, module = "splitlf._native")]
pub(crate) struct DesignCore {
    pub(crate) inner: Design,
}

impl DesignCore {
    /// The design and its channel `number` (an integer from 1; other values are named errors).
    fn channel_arg(&self, number: &Bound<'_, PyAny>) -> PyResult<(&Design, &design::Channel)> {
        let (v, text) = int_arg(number, "channel")?;
        let ch = self
            .inner
            .channel(saturate(v))
            .map_err(|e| to_py(with_given(e, &text)))?;
        Ok((&self.inner, ch))
    }
}

#[pymethods]
impl DesignCore {
    /// `channels`: one dict per channel with the keys L, d, v, mu, Kx, Ky, grid, f (None or
    /// a list), layout, Q, Mx, My, share.
    #[new]
    fn new(
        f_main: f64,
        aperture: f64,
        shape: &str,
        channels: Vec<Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let shape = design::Aperture::from_name(shape).map_err(to_py)?;
        let specs = channels
            .iter()
            .map(channel_spec)
            .collect::<PyResult<Vec<_>>>()?;
        let inner = Design::new(f_main, aperture, shape, &specs).map_err(to_py)?;
        Ok(DesignCore { inner })
    }

    /// The camera as its two-channel design.
    #[staticmethod]
    fn from_camera(camera: &CameraCore) -> Self {
        DesignCore {
            inner: camera.design.clone(),
        }
    }

    /// The named design `name` (see `splitlf_core::model::presets`).
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        let inner = presets::preset(name).map_err(to_py)?;
        Ok(DesignCore { inner })
    }

    /// The preset names, in the documented order.
    #[staticmethod]
    fn presets() -> Vec<&'static str> {
        presets::PRESETS.to_vec()
    }

    /// Out-of-focus plane of channel `channel` (from 1): F L / (L − F).
    fn out_of_focus_depth(&self, channel: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (d, ch) = self.channel_arg(channel)?;
        Ok(optics::LensOptics::of_channel(d, ch, 0).out_of_focus_depth())
    }

    /// Microlens image radius of channel `channel` (from 1): R = D v / (2 L).
    fn image_radius(&self, channel: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (d, ch) = self.channel_arg(channel)?;
        Ok(optics::LensOptics::of_channel(d, ch, 0).image_radius())
    }

    /// The depth each lens type of channel `channel` (from 1) is focused on (b = 0), None
    /// where there is none (Ng's setting: focused on the main lens).
    fn focus_depths(&self, channel: &Bound<'_, PyAny>) -> PyResult<Vec<Option<f64>>> {
        let (d, ch) = self.channel_arg(channel)?;
        Ok((0..ch.types())
            .map(|t| optics::LensOptics::of_channel(d, ch, t).focus_depth())
            .collect())
    }

    /// (F, D, aperture) of the main lens.
    fn main_lens(&self) -> (f64, f64, &'static str) {
        let d = &self.inner;
        (d.f_main, d.aperture, d.shape.name())
    }

    /// Each channel's fields as validated (f resolved: Ng's setting as one value; the
    /// sensor layout's M_x, M_y resolved), as dicts with the constructor's keys plus "ng".
    fn channels<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner
            .channels
            .iter()
            .map(|c| {
                let d = PyDict::new(py);
                d.set_item("L", c.l)?;
                d.set_item("d", c.d)?;
                d.set_item("v", c.v)?;
                d.set_item("mu", c.mu)?;
                d.set_item("Kx", c.kx)?;
                d.set_item("Ky", c.ky)?;
                d.set_item("grid", c.grid.name())?;
                d.set_item("f", c.f.clone())?;
                d.set_item("ng", c.ng)?;
                d.set_item("layout", c.layout.name())?;
                let (q, mx, my) = match c.layout {
                    design::Layout::Ideal { q } => (Some(q), None, None),
                    design::Layout::Sensor { mx, my } => (None, Some(mx), Some(my)),
                };
                d.set_item("Q", q)?;
                d.set_item("Mx", mx)?;
                d.set_item("My", my)?;
                d.set_item("share", c.share)?;
                Ok(d)
            })
            .collect()
    }

    /// Channel `channel`'s (from 1) micro-image centres in raw pixel coordinates: one row
    /// [row, column, k, j] per lens, lattice rows first (`splitlf_core::model::centers`).
    fn micro_image_centers<'py>(
        &self,
        py: Python<'py>,
        channel: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let (_, ch) = self.channel_arg(channel)?;
        let centers = py.detach(|| ch.micro_image_centers());
        let values = centers
            .iter()
            .flat_map(|m| [m.row, m.col, f64::from(m.k), f64::from(m.j)]);
        filled(py, &[centers.len(), 4], "micro-image centres", values)
    }

    /// Channel `channel`'s (from 1) steps between micro-image centres in raw pixels, (row
    /// step, column step) (`splitlf_core::model::centers`).
    fn micro_image_steps(&self, channel: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
        let (_, ch) = self.channel_arg(channel)?;
        Ok(ch.micro_image_steps())
    }

    /// δ(z) = μ_1 z / L_1 (docs/model.md §9); z must be finite and > F.
    fn resolution_step(&self, z: f64) -> PyResult<f64> {
        optics::check_design_depths(self.inner.f_main, &[z]).map_err(to_py)?;
        Ok(self.inner.resolution_step(z))
    }
}
