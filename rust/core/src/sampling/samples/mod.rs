//! Coincidence planes, genuinely new samples (Eqs. 8–9) and resolution at every depth
//! (docs/model.md §3, §5, §6). Derivations: `docs/samples.md`.
//!
//! The sample positions are the chief samples p' of [`Line::chief_projection`] (docs/model.md
//! §5), the same function the ray-space engine's `sample = "chief"` footprints use, over
//! every lit pixel ([`Line::pixel`]) of a channel. Everything is computed on plane
//! v_ref = L_1 (p' space); object space is the linear map X = −p' z / L_1, so with
//! δ(z) = μ_1 z / L_1 (docs/model.md §9)
//! - the merge tolerance `tol · δ(z)` is `tol · μ_1` in p' space (independent of z),
//! - the central field |X| ≤ K_x d_1 z / (4 L_1) is |p'| ≤ K_x d_1 / 4,
//! - a gap g in p' is g / μ_1 in units of δ(z).
//!
//! This δ is the one step of every design, a Camera too: for a camera it is μ z / v',
//! docs/model.md §6's d z / (Q v') only when d = Q μ. Where positions are a fraction of the
//! tolerance apart (channels whose array planes differ by a few ppm) the count depends on
//! it; it is μ_1, for the tolerance as for the gaps.
//!
//! Merge rule: the distinct count of a set of positions is the least number of closed
//! intervals of length `tol · δ(z)` that cover it (computed greedily on the sorted positions:
//! a position opens a new sample when it lies more than `tol · δ(z)` beyond the first
//! position of the current sample). This count is monotone (adding positions never lowers
//! it), so the union of both halves never counts fewer samples than either half.
//!
//! Parts: `sorted` (one line's sorted chief samples, merging, the scans that count and
//! measure gaps), `coincidence` (the coincidence planes and Eqs. 8–9), `designs` (every
//! channel of a design and their union over depths). This file holds the limits and the
//! closed forms they share.
//!
//! [`Line::chief_projection`]: crate::sampling::line::Line::chief_projection
//! [`Line::pixel`]: crate::sampling::line::Line::pixel

mod coincidence;
mod designs;
mod sorted;
#[cfg(test)]
mod test_designs;

pub use coincidence::*;
pub use designs::*;

use crate::infra::error::{Error, Result};

/// Depths per parallel task.
const CHUNK: usize = 8;
/// Largest number of pixels along one axis of one channel (K · Q) the brute-force count
/// accepts (a cap on the work per depth; the memory a call needs is estimated separately
/// and checked against what is available).
pub const MAX_SAMPLES_PER_AXIS: u64 = 1 << 24;
/// Largest number of (N, T) pairs `design_coincidence_planes` enumerates.
pub const MAX_PAIRS: u64 = 1_000_000;
/// Largest brute-force work of `coincidence_planes`: planes × (K_x + K_y) × Q_lit sample
/// positions generated, sorted and scanned (about half a minute on one core).
pub const MAX_COINCIDENCE_WORK: u64 = 1 << 33;
/// Default largest N of `coincidence_planes`.
pub const DEFAULT_MAX_N: i64 = 4;
/// Default merge tolerance of the distinct counts, in units of δ(z).
pub const DEFAULT_TOL: f64 = 1e-6;

/// Validate the merge tolerance (a multiple of δ(z); 0 merges exactly equal positions only).
pub fn check_tol(tol: f64) -> Result<f64> {
    if tol.is_finite() && tol >= 0.0 {
        Ok(tol)
    } else {
        Err(Error::param(
            "tol",
            tol,
            "a finite number >= 0 (a multiple of the resolution step delta(z))",
        ))
    }
}

/// Greatest common divisor.
pub fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Eqs. 8–9, one axis, with the lit pixel count: genuinely new samples of K microlenses
/// with `q_lit` lit pixels each on the coincidence plane (N, T).
/// n = N Q_lit + T (K − N) when T ≤ Q_lit and K ≥ N; in general
/// n = K Q_lit − max(K − N, 0) · max(Q_lit − T, 0) (which is K Q_lit when nothing overlaps).
pub fn closed_form_new_samples(k: u64, q_lit: u64, n: u64, t: u64) -> u64 {
    k * q_lit - k.saturating_sub(n) * q_lit.saturating_sub(t)
}
