//! Bindings of the Bayer colour filter array (`splitlf_core::imaging::cfa`, docs/model.md
//! §12): the colour of each pixel, the mosaic of one raw per colour, the grey raw of a
//! mosaic.

use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

use splitlf_core::imaging::cfa::{self, Pattern};

use crate::infra::arrays::filled;
use crate::infra::errors::to_py;

/// A raw's values in C order and its shape.
fn parts(a: &PyReadonlyArray2<'_, f64>) -> (Vec<f64>, usize, usize) {
    let v = a.as_array();
    let (r, c) = v.dim();
    (v.iter().copied().collect(), r, c)
}

/// The colour (0 red, 1 green, 2 blue) of every pixel of a `rows` × `cols` raw under
/// `pattern` ("RGGB", "GRBG", "GBRG" or "BGGR").
#[pyfunction]
pub(crate) fn cfa_colours<'py>(
    py: Python<'py>,
    pattern: &str,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<u8>>> {
    let p = Pattern::parse(pattern).map_err(to_py)?;
    filled(
        py,
        &[rows, cols],
        "the colour index",
        cfa::colours(p, rows, cols).into_iter(),
    )
}

/// The mosaic of three noise-free raws of one channel (red, green, blue; same shape):
/// each pixel its colour's raw times that colour's quantum efficiency `qe`.
#[pyfunction]
pub(crate) fn cfa_mosaic<'py>(
    py: Python<'py>,
    planes: [PyReadonlyArray2<'py, f64>; 3],
    pattern: &str,
    qe: [f64; 3],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let p = Pattern::parse(pattern).map_err(to_py)?;
    let [r, g, b] = planes.each_ref().map(parts);
    let (rows, cols) = (r.1, r.2);
    let out = py
        .detach(|| cfa::mosaic([&r.0, &g.0, &b.0], rows, cols, p, qe))
        .map_err(to_py)?;
    filled(py, &[rows, cols], "the mosaic", out.into_iter())
}

/// The grey raw of a mosaic: each pixel divided by its colour's quantum efficiency.
#[pyfunction]
pub(crate) fn cfa_grey<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'py, f64>,
    pattern: &str,
    qe: [f64; 3],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let p = Pattern::parse(pattern).map_err(to_py)?;
    let (v, rows, cols) = parts(&raw);
    let out = py
        .detach(|| cfa::grey(&v, rows, cols, p, qe))
        .map_err(to_py)?;
    filled(py, &[rows, cols], "the grey raw", out.into_iter())
}
