//! Inversion: from a raw back to the scene. The 1-D super-resolution simulation
//! ([`simulate`]), the linear map a reconstruction inverts ([`system`]), its regularised
//! least squares by matrix-free conjugate gradients ([`solve`]) and the plane sweep that
//! estimates depth from a raw ([`depth`]) (§11). Uses every room below it.

pub mod choose;
pub mod depth;
pub mod merit;
pub mod plan;
pub mod reconstruct;
pub mod simulate;
pub mod solve;
pub mod system;
