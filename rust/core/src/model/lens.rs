//! The leaf every model module builds on: the thin-lens relations (Eq. 1 and its inverse,
//! Ng's setting) and the validation rules shared by cameras and designs (lengths, derived
//! lengths, counts and their limits). Uses nothing of the crate but its errors.

use crate::infra::error::{Error, Result};

/// Largest pixel count per microlens along one axis the core accepts.
pub const MAX_Q: u64 = 65_535;
/// Largest microlens count per channel (camera half) along one axis the core accepts.
pub const MAX_K: u64 = 10_000_000;

/// Eq. 1: z' = F z / (z − F), the conjugate of depth z (z > F).
///
/// For depths so large that F z overflows (z > f64::MAX / F) the algebraically equal
/// F / (1 − F/z) is used: it cannot overflow for z > F, while everywhere else the product
/// form is kept so that results equal a plain transcription of Eq. 1 bit for bit.
#[inline]
pub fn conjugate(f_main: f64, z: f64) -> f64 {
    let num = f_main * z;
    if num.is_finite() {
        num / (z - f_main)
    } else {
        f_main / (1.0 - f_main / z)
    }
}

/// Inverse of Eq. 1: the depth whose conjugate is z' (z' > F; z' = ∞ gives F).
#[inline]
pub fn depth_of_conjugate(f_main: f64, zc: f64) -> f64 {
    if zc.is_infinite() {
        f_main
    } else {
        f_main * zc / (zc - f_main)
    }
}

/// Ng's setting: microlenses focused on the main lens, 1/f = 1/L + 1/v.
pub fn ng_focal_length(l: f64, v: f64) -> f64 {
    1.0 / (1.0 / l + 1.0 / v)
}

/// Lengths must be normal floats (not subnormal): the formulas divide by them, and the
/// reciprocal of a subnormal length overflows.
pub(crate) fn positive(name: &'static str, x: f64) -> Result<f64> {
    if x.is_normal() && x > 0.0 {
        Ok(x)
    } else {
        Err(Error::param(
            name,
            x,
            "a finite length > 0 mm (a normal float, >= 2.2250738585072014e-308)",
        ))
    }
}

/// A value derived from the given fields must pass the same rule as a given one: a
/// positive, finite, normal float whose reciprocal is finite.
pub(crate) fn derived(name: &'static str, x: f64, from: &str) -> Result<()> {
    if x.is_normal() && x > 0.0 && (1.0 / x).is_finite() {
        Ok(())
    } else {
        Err(Error::param(
            name,
            x,
            format!("a finite length > 0 mm (a normal float); it is derived from {from}, so choose them so that it is"),
        ))
    }
}

/// A count in [1, max].
pub(crate) fn count(name: &'static str, n: i64, max: u64) -> Result<u32> {
    if n >= 1 && (n as u64) <= max {
        Ok(n as u32)
    } else {
        Err(Error::param(name, n, format!("an integer in [1, {max}]")))
    }
}
