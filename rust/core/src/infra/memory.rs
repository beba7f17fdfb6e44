//! The memory guard: what a call may allocate, and fallible allocation.
//!
//! Every entry point estimates, before any work, the bytes of all it will hold at its peak
//! (outputs, working buffers, one set of per-thread buffers per worker) and refuses with
//! [`Error::TooLarge`] when that exceeds [`available`]. The estimate is an upper bound, not
//! a guess: each function's doc lists the buffers it counts. Large buffers are then
//! allocated fallibly ([`try_vec`]), so an allocation that fails anyway (the estimate is
//! checked against a moment's free memory) is the same error, never an abort.

use crate::infra::error::{Error, Result};

/// Used when neither /proc/meminfo nor /proc/self/limits can be read (not Linux).
const UNKNOWN: u128 = 1 << 40;

/// A `key: value kB` line of a /proc file, in bytes.
fn proc_kb(path: &str, key: &str) -> Option<u128> {
    let text = std::fs::read_to_string(path).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u128 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kb * 1024)
}

/// Headroom under the address-space limit (`ulimit -v`, RLIMIT_AS): the soft "Max address
/// space" of /proc/self/limits minus the current VmSize of /proc/self/status; None when
/// unlimited or unreadable.
fn address_space_headroom() -> Option<u128> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft = line["Max address space".len()..]
        .split_whitespace()
        .next()?;
    let soft: u128 = soft.parse().ok()?; // "unlimited" does not parse: no limit
    let used = proc_kb("/proc/self/status", "VmSize:")?;
    Some(soft.saturating_sub(used))
}

/// Bytes a call may allocate now: the smaller of MemAvailable (/proc/meminfo: free memory
/// plus what the kernel can reclaim without swapping) and the headroom under RLIMIT_AS
/// (its soft limit minus the current VmSize); 2^40 where neither can be read.
pub fn available() -> u128 {
    let mem = proc_kb("/proc/meminfo", "MemAvailable:");
    let limit = match (mem, address_space_headroom()) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => UNKNOWN,
    };
    limit.min(isize::MAX as u128)
}

/// Refuse `bytes` for `what` (the call and its buffers) when it exceeds [`available`].
pub fn check(what: &str, bytes: u128) -> Result<()> {
    let limit = available();
    if bytes > limit {
        return Err(Error::TooLarge {
            what: what.to_string(),
            bytes,
            limit,
        });
    }
    Ok(())
}

/// Bytes of `n` values of type T (saturating: an impossible count stays impossible).
pub fn bytes_of<T>(n: u128) -> u128 {
    n.saturating_mul(std::mem::size_of::<T>() as u128)
}

/// The error of a failed allocation of `n` values of T for `what`.
pub fn alloc_error<T>(what: &str, n: usize) -> Error {
    Error::TooLarge {
        what: format!("{what} (allocation failed)"),
        bytes: bytes_of::<T>(n as u128),
        limit: available(),
    }
}

/// An empty vector with room for exactly `n` values, or [`Error::TooLarge`].
pub fn try_with_capacity<T>(what: &str, n: usize) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|_| alloc_error::<T>(what, n))?;
    Ok(v)
}

/// `vec![value; n]`, or [`Error::TooLarge`] when it cannot be allocated.
pub fn try_vec<T: Clone>(what: &str, n: usize, value: T) -> Result<Vec<T>> {
    let mut v = try_with_capacity(what, n)?;
    v.resize(n, value);
    Ok(v)
}

/// [`try_vec`] filled in slices with a [`crate::infra::parallel::checkpoint`] between
/// them: for a buffer of hundreds of megabytes, whose filling alone (a second or more under
/// load) must not delay a Ctrl-C.
pub fn try_vec_interruptible<T: Clone>(what: &str, n: usize, value: T) -> Result<Vec<T>> {
    const SLICE_BYTES: usize = 1 << 24;
    let slice = (SLICE_BYTES / std::mem::size_of::<T>().max(1)).max(1);
    let mut v = try_with_capacity(what, n)?;
    while v.len() < n {
        crate::infra::parallel::checkpoint()?;
        let end = (v.len() + slice).min(n);
        v.resize(end, value.clone());
    }
    Ok(v)
}

/// Grow `v` to hold at least `n` values without reallocating later, or [`Error::TooLarge`].
pub fn try_reserve<T>(v: &mut Vec<T>, what: &str, n: usize) -> Result<()> {
    let extra = n.saturating_sub(v.len());
    v.try_reserve_exact(extra)
        .map_err(|_| alloc_error::<T>(what, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn available_is_positive_and_checked() {
        let a = available();
        assert!(a > 0);
        assert!(check("nothing", 0).is_ok());
        assert!(matches!(
            check("everything", u128::MAX),
            Err(Error::TooLarge { .. })
        ));
    }

    #[test]
    fn impossible_allocations_are_errors() {
        let e = try_vec::<f64>("huge", usize::MAX / 4, 0.0).unwrap_err();
        assert!(matches!(e, Error::TooLarge { .. }), "{e}");
        assert!(e.to_string().contains("huge"));
        assert_eq!(try_vec("small", 3, 1u8).unwrap(), vec![1, 1, 1]);
        let mut v: Vec<u64> = Vec::new();
        assert!(try_reserve(&mut v, "grow", usize::MAX / 2).is_err());
        assert!(try_reserve(&mut v, "grow", 10).is_ok() && v.capacity() >= 10);
    }
}
