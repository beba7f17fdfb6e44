//! Bindings of image formation: the renderer.

pub(crate) mod render;
