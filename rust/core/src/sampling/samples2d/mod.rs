//! Chief samples, distinct samples and the covering radius in 2-D, for any design
//! (docs/model.md §9: "Chief samples in 2-D", "Scale and field", "Distinct samples in
//! 2-D", "Covering radius"; the implementation is described in its "§9 implementation"
//! subsection).
//!
//! - [`chief_samples_into`]: every pixel of one channel's layout, its lens, type, lit flag
//!   and chief sample (X, Y) on the plane at depth z, row by row in parallel. The
//!   nearest-lens rule of the sensor layout is [`Channel::nearest_lens`] evaluated from
//!   per-column and per-row tables: the same candidates, the same floating-point
//!   expressions and the same tie rule, so the result is bit for bit that of
//!   [`Design::pixel`] and [`Design::chief_sample`] (a unit test checks every pixel).
//! - [`samples_2d`] and [`coverage`]: the distinct samples of each channel and of the
//!   union of all channels (connected components of |ΔX|, |ΔY| < tol·δ(z), found with a
//!   hash grid of cell tol·δ and union-find), their number inside the 2-D central field,
//!   and the covering radius ρ(z) of that field (Delaunay triangulation by the `spade`
//!   crate, whose predicates are exact: the sample sets are lattices, massively cocircular
//!   and collinear, which a non-robust triangulator such as `delaunator` gets wrong).
//!
//! Only samples near the field can matter, so each depth is computed from the samples
//! within a margin m of the field (Chebyshev distance), starting at two lens pitches imaged
//! on the plane, and the margin is widened (up to every pixel) until the result is provably
//! that of the full sample set: the representatives that can be wrong (those of
//! components reaching the margin's edge) lie farther than m₂ from the field, and ρ < m₂.
//! A trial pass at a narrower margin ([`TRIAL_MARGIN`] δ) comes first and is kept only when
//! its result is provably the first margin's, bit for bit (see `rows::row_pass`).
//!
//! Parts: `tables` (per-channel pixel tables, the nearest-lens candidates) and `gather`
//! (the pixels whose samples can fall near the field), `chief` ([`chief_samples_into`]),
//! `components` (hash grid and union-find), `cover` (the covering radius, and the 1-D
//! covers of the separable form), `rows` (one depth, the margin widened until exact, or
//! the separable form where the samples are a product of two 1-D sets), `coverage`
//! (validation and the entry points). This file holds the limits they share.
//!
//! [`Channel::nearest_lens`]: crate::model::design::Channel::nearest_lens
//! [`Design::pixel`]: crate::model::design::Design::pixel
//! [`Design::chief_sample`]: crate::model::design::Design::chief_sample

mod chief;
mod components;
mod cover;
mod coverage;
mod gather;
mod rows;
mod tables;
#[cfg(test)]
mod test_designs;

pub use chief::*;
pub use cover::*;
pub use coverage::*;

/// Default width of the 2-D central field, in lens pitches of channel 1.
pub const DEFAULT_WINDOW: f64 = 16.0;
/// Largest merge tolerance of the 2-D distinct samples, in δ(z): samples farther apart
/// than one conventional pixel are never "the same sample".
pub const MAX_TOL_2D: f64 = 1.0;
/// Largest |X| / (tol δ(z)) a sample may reach (2^42): the hash grid's integer cell
/// indices then stay exact with a wide margin, whatever the rounding of X / cell.
pub const MAX_CELL_INDEX: f64 = 4_398_046_511_104.0;
/// Largest work of one `coverage` call: pixels of all channels × depths (each depth may,
/// in the worst case, have to look at every pixel).
pub const MAX_COVERAGE_WORK: u128 = 1 << 36;
/// Relative slack of the covering radius's pruning: a candidate point whose upper bound
/// exceeds the largest distance found so far by less than this fraction is not evaluated
/// (the candidates are themselves rounded at about 1e-13 of ρ).
pub const PRUNE_RTOL: f64 = 1e-9;
/// Hash-grid cells are this fraction wider than tol·δ: two samples closer than tol·δ then
/// always fall in the same or adjacent cells despite the rounding of X / cell.
const CELL_SLACK: f64 = 1.0 / 1024.0;
/// The margin of the trial pass (see [`row_pass`]), in δ(z): wider than the covering
/// radius of the presets' sample sets (about 1–7 δ) and the margin of representatives its
/// triangulation takes (4 sample spacings of about a δ, widened to 2 ρ), narrower than the
/// first margin (two lens pitches on the plane, 2 d/μ δ: 30–46 δ for the presets), so a
/// depth usually settles at a fraction of the first pass's samples.
const TRIAL_MARGIN: f64 = 16.0;
/// Bytes one worker holds per sample near the field, at most: the sample, its cell key,
/// union-find entries, its representative, spade's triangulation (vertex, half-edges,
/// faces, hierarchy) and the candidate points of the covering radius.
const SAMPLE_BYTES: u128 = 640;
/// Coordinates (in δ) smaller than this are set to 0 before triangulation (spade refuses
/// nonzero coordinates below 2^-142): a shift far below any distance of interest.
const FLUSH: f64 = 1e-30;
