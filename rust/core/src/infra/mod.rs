//! Infrastructure: what every domain uses and that knows no optics. The error type that
//! maps to Python's exceptions ([`error`]), the rayon pool with its thread count and
//! Ctrl-C flag ([`parallel`]), memory budgets and fallible allocation ([`memory`]),
//! small SIMD kernels ([`simd`]), the one polygon geometry of the crate ([`polygon`]), its
//! one compressed-row matrix ([`csr`]) and its one pseudo-random generator ([`random`]).
//! Uses nothing else of the crate.

pub mod csr;
pub mod error;
pub mod fft;
pub mod memory;
pub mod parallel;
pub mod polygon;
pub mod random;
pub(crate) mod simd;
