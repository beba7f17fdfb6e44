//! The camera model: thin-lens relations and the validation rules every model shares
//! ([`lens`]), validated architectures (channels, lattices, lens types, layouts; §9,
//! [`design`]), the paper's split-sensor parametrisation ([`camera`]), named designs
//! ([`presets`]), the micro-image centres in raw pixels ([`centers`]) and the closed
//! forms over depth with the depth of field (Eqs. 1–7, [`optics`]). Uses
//! [`crate::infra`] only.

pub mod camera;
pub mod centers;
pub mod design;
pub mod lens;
pub mod optics;
pub mod presets;
