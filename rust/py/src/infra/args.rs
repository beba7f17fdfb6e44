//! Argument conversion: integers of any size (never a bool), halves, channels, thread
//! counts, sample modes and borrowed depth arrays. A value out of range is the core's own
//! error, showing the value as given.

use std::borrow::Cow;

use numpy::ndarray::Dimension;
use numpy::{PyReadonlyArray, PyReadonlyArray1};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyBool;

use splitlf_core::sampling::rayspace::Sample;
use splitlf_core::{infra::memory, infra::parallel, Design, Error, Half};

use crate::infra::errors::to_py;

/// An integer argument of any size (a Python int or anything with `__index__`, never a
/// bool), or a `TypeError` naming it: its value saturated to i128 (every range is far
/// inside) and its decimal text.
pub(crate) fn int_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(i128, String)> {
    let type_name = obj.get_type().name()?.to_string();
    let refuse = || -> PyResult<PyErr> {
        Ok(PyTypeError::new_err(format!(
            "{name} must be an integer, got {type_name} {}",
            obj.repr()?
        )))
    };
    if obj.is_instance_of::<PyBool>() || type_name == "bool_" {
        return Err(refuse()?);
    }
    let Ok(index) = obj.call_method0("__index__") else {
        return Err(refuse()?);
    };
    let text = index.str()?.to_string();
    let value = match index.extract::<i128>() {
        Ok(v) => v,
        Err(_) if index.lt(0)? => i128::MIN,
        Err(_) => i128::MAX,
    };
    Ok((value, text))
}

/// The core's range check applied to a value that may not fit its integer type: the core
/// sees the value saturated (out of every range) and its error shows the value given.
pub(crate) fn with_given(e: Error, given: &str) -> Error {
    match e {
        Error::InvalidParameter {
            name,
            allowed,
            channel,
            ..
        } => Error::InvalidParameter {
            name,
            value: given.to_string(),
            allowed,
            channel,
        },
        other => other,
    }
}

pub(crate) fn saturate(v: i128) -> i64 {
    v.clamp(i64::MIN as i128, i64::MAX as i128) as i64
}

pub(crate) fn half_arg(obj: &Bound<'_, PyAny>) -> PyResult<Half> {
    let (v, text) = int_arg(obj, "half")?;
    Half::from_number(saturate(v)).map_err(|e| to_py(with_given(e, &text)))
}

pub(crate) fn threads_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let (v, text) = int_arg(obj, "n_threads")?;
    let n = v.clamp(0, parallel::MAX_THREADS as i128 + 1) as usize;
    parallel::check_threads(Some(n)).map_err(|e| to_py(with_given(e, &text)))?;
    Ok(Some(n))
}

/// Borrow a 1-D float64 array as a slice, copying (fallibly) only when it is not contiguous.
pub(crate) fn as_slice<'a>(a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<Cow<'a, [f64]>> {
    as_flat(a, "z")
}

/// Borrow a float64 array of any shape as its C-order elements, copying (fallibly) only
/// when it is not C-contiguous; `what` names it in a size error.
pub(crate) fn as_flat<'a, D: Dimension>(
    a: &'a PyReadonlyArray<'_, f64, D>,
    what: &str,
) -> PyResult<Cow<'a, [f64]>> {
    match a.as_slice() {
        Ok(s) => Ok(Cow::Borrowed(s)),
        Err(_) => {
            let view = a.as_array();
            let mut v =
                memory::try_with_capacity(&format!("contiguous copy of {what}"), view.len())
                    .map_err(to_py)?;
            v.extend(view.iter().copied());
            Ok(Cow::Owned(v))
        }
    }
}

pub(crate) fn sample_arg(sample: &str) -> PyResult<Sample> {
    Sample::from_name(sample).map_err(to_py)
}

/// A channel number (an int from 1, never a bool), checked against the design.
pub(crate) fn channel_arg(design: &Design, obj: &Bound<'_, PyAny>) -> PyResult<i64> {
    let (v, text) = int_arg(obj, "channel")?;
    let n = saturate(v);
    design.channel(n).map_err(|e| to_py(with_given(e, &text)))?;
    Ok(n)
}
