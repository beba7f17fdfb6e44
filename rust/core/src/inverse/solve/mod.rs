//! The reconstruction's solve (docs/model.md §11, docs/reconstruct.md): regularised,
//! weighted least squares on the map a reconstruction inverts,
//!
//! ```text
//!     min_t  Σ_rows w (A t − y)²  +  λ |D t|²,
//! ```
//!
//! D the differences between horizontal and vertical neighbour cells, solved matrix-free by
//! conjugate gradients on the normal equations (Aᵀ W A + λ DᵀD) t = Aᵀ W y with a Jacobi
//! (diagonal) preconditioner: the iteration of SciPy's `cg` (same start, same stop:
//! ‖r‖ < rtol ‖b‖), so the two agree to rounding.
//!
//! The map comes in blocks of rows:
//! - [`Block::Factored`]: the pixels of one lens type of one channel on the exact route,
//!   rows `norm · (py row b ⊗ px row a)` over a window of raw rows b and columns a (the
//!   map's Kronecker factors, never multiplied out: a half-2 pixel at 1 m touches ~6,000
//!   cells, its factors 2 × 78);
//! - [`Block::Rows`]: explicit rows (the general and tilted routes).
//!
//! Every product runs in parallel over rows with a fixed order of summation inside each
//! row, and every dot product over fixed chunks added in order: the result does not depend
//! on the thread count.
//!
//! The parts, by concept:
//! - the blocks are given as [`Csr`] matrices (the crate's one, in [`crate::infra::csr`]);
//! - `pieces`: a factor's rows cut for fast products (dense spans, affine runs, the y
//!   runs as events over grid rows);
//! - `kernels`: the fixed-order dot products and axpy every pass is made of;
//! - `block`: the blocks of rows the map comes in ([`Block`]);
//! - `normal`: the normal equations the blocks make ([`Normal`]),
//!   checked against the grid, and the scratch of one product ([`Work`]);
//! - `product`: the passes of one product: (AᵀWA + λDᵀD) t, AᵀWy and the diagonal;
//! - `coarse`: a coarse-grid correction for the preconditioner (an option of [`Normal`],
//!   [`Normal::precondition_coarse`]);
//! - `cg`: the conjugate gradients ([`solve`]) and when they stop, the noise stop
//!   included ([`Stop`]).

mod block;
mod cg;
mod coarse;
mod kernels;
mod normal;
mod pieces;
mod product;
#[cfg(test)]
mod testing;

pub use crate::infra::csr::Csr;
pub use block::Block;
pub use cg::{solve, solve_each, solve_from, Solution, Start, Stop};
pub use normal::{Normal, Penalty, Prior, Work};
pub(crate) use product::prior_row;
