//! splitlf-core: the optics and ray-space engine of split-sensor light field cameras.
//!
//! Pure Rust (no Python): [`lens`] the thin-lens relations and validation rules every model
//! shares, [`design`] the validated architectures (channels, lattices, lens types, layouts;
//! §9), [`camera`] the paper's split-sensor parametrisation, which builds a two-channel
//! design (§1, §3, §7),
//! [`presets`] named designs (the seed, its variants, a Raytrix R12, a Lytro Illum),
//! [`optics`] the closed forms over depth (Eqs. 1–7) and the depth of field,
//! [`rayspace`] every pixel's integration polygon in (u, w) and its footprints (§3–5),
//! [`line`] one channel along one axis, the view the 1-D engine runs on,
//! [`samples`] the coincidence planes and genuinely new samples (Eqs. 8–9, docs/model.md §6),
//! [`samples2d`] the 2-D chief samples, distinct samples and covering radius of a design (§9),
//! [`merit`] the figures of merit of one design that sweeps compare,
//! [`simulate`] the forward model and system matrix of the super-resolution simulation,
//! [`render`] the 2-D forward model (raw images, §10) with [`scene`], [`texture`] and
//! [`polygon`]; [`system`] the linear map a reconstruction inverts, [`solve`] its
//! regularised least squares (matrix-free conjugate gradients), and [`depth`] the
//! plane sweep that estimates depth from a raw.
//! Every parallel entry point takes `n_threads` (see [`parallel`]).

pub mod camera;
pub mod cells;
pub mod depth;
pub mod design;
pub mod error;
pub mod lens;
pub mod line;
pub mod memory;
pub mod merit;
pub mod optics;
pub mod parallel;
pub mod polygon;
pub mod presets;
pub mod rayspace;
pub mod render;
pub mod samples;
pub mod samples2d;
pub mod scene;
mod simd;
pub mod simulate;
pub mod solve;
pub mod system;
pub mod texture;

pub use camera::{Camera, Half};
pub use design::{Aperture, Channel, ChannelSpec, Design, Grid, Layout};
pub use error::{Error, Result};
pub use line::Axis;
