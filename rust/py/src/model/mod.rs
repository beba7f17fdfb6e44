//! Bindings of the camera model: designs, the paper's camera, presets and the closed forms over depth.

pub(crate) mod design;
pub(crate) mod optics;
