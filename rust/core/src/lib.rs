//! splitlf-core: the optics and ray-space engine of split-sensor light field cameras.
//!
//! Pure Rust (no Python), one folder per domain; each folder's `mod.rs` says what it owns
//! and what it may use (docs/architecture.md is the map). Lower rooms never use higher ones:
//!
//! 1. [`infra`]: errors, the thread pool and Ctrl-C, memory budgets, SIMD, polygon geometry;
//! 2. [`model`]: the camera model: lenses, designs, the paper's camera, presets, and the
//!    closed forms over depth (Eqs. 1–7);
//! 3. [`sampling`]: what a design samples: one channel along one axis, the ray space
//!    (§3–5), coincidence planes and new samples (Eqs. 8–9), 2-D samples and coverage
//!    (§9), and the figures of merit sweeps compare;
//! 4. [`imaging`]: image formation: scenes, textures, the renderer (§10) and the recorder
//!    that turns its integration into rows of a linear map;
//! 5. [`inverse`]: inversion: the 1-D simulation, the linear map of a reconstruction, its
//!    regularised solve, and the plane sweep that estimates depth (§11).
//!
//! Every parallel entry point takes `n_threads` (see [`infra::parallel`]).

pub mod imaging;
pub mod infra;
pub mod inverse;
pub mod model;
pub mod sampling;

pub use infra::error::{Error, Result};
pub use model::camera::{Camera, Half};
pub use model::design::{Aperture, Channel, ChannelSpec, Design, Grid, Layout};
pub use sampling::line::Axis;
