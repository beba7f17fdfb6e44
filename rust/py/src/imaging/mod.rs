//! Bindings of image formation: the renderer and the colour filter array.

pub(crate) mod cfa;
pub(crate) mod render;
