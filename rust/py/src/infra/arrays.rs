//! Fallible NumPy outputs: arrays allocated by NumPy (a failed allocation is a
//! `TooLargeError`, never a panic) and filled by the core without the GIL.

use numpy::ndarray::Dimension;
use numpy::{Element, PyArray, PyArrayMethods};
use pyo3::exceptions::PyMemoryError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyTuple;

use splitlf_core::{infra::memory, Error};

use crate::infra::errors::{internal, to_py};

/// An uninitialised C-contiguous NumPy array, allocated by `numpy.empty` so that a failed
/// allocation is a `TooLargeError` naming the call (rust-numpy's constructors would panic).
pub(crate) fn empty<'py, T: Element, D: Dimension>(
    py: Python<'py>,
    shape: &[usize],
    what: &str,
) -> PyResult<Bound<'py, PyArray<T, D>>> {
    static EMPTY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    let empty = EMPTY.import(py, "numpy", "empty")?;
    let dims = PyTuple::new(py, shape)?;
    match empty.call1((dims, numpy::dtype::<T>(py))) {
        Ok(a) => a.cast_into::<PyArray<T, D>>().map_err(internal),
        Err(e) if e.is_instance_of::<PyMemoryError>(py) => {
            let n: u128 = shape.iter().map(|&d| d as u128).product();
            Err(to_py(Error::TooLarge {
                what: format!("{what} (NumPy output {shape:?})"),
                bytes: n * std::mem::size_of::<T>() as u128,
                limit: memory::available(),
            }))
        }
        Err(e) => Err(e),
    }
}

/// A NumPy array holding `values`, allocated fallibly (see [`empty`]).
pub(crate) fn filled<'py, T: Element + Copy, D: Dimension>(
    py: Python<'py>,
    shape: &[usize],
    what: &str,
    values: impl Iterator<Item = T>,
) -> PyResult<Bound<'py, PyArray<T, D>>> {
    let a = empty::<T, D>(py, shape, what)?;
    {
        let mut w = a.readwrite();
        let s = w.as_slice_mut().map_err(internal)?;
        let mut written = 0;
        for (o, v) in s.iter_mut().zip(values) {
            *o = v;
            written += 1;
        }
        if written != s.len() {
            return Err(internal(format!(
                "{what}: {written} values for {}",
                s.len()
            )));
        }
    }
    Ok(a)
}

/// An int64 array's buffer seen as u64 (the core's counts; every count is < 2^63).
pub(crate) fn as_u64(s: &mut [i64]) -> &mut [u64] {
    // SAFETY: i64 and u64 have the same size and alignment and every bit pattern is valid
    // for both; the borrow of `s` is carried over.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<u64>(), s.len()) }
}

/// Bytes the memory guard lets one call allocate now (see `splitlf_core::infra::memory`).
#[pyfunction]
pub(crate) fn available_memory() -> u128 {
    memory::available()
}
