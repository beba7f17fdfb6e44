//! Image formation: the scene (planes, slanted planes, depth maps; [`scene`]) and its
//! textures ([`texture`]), both sampled on a checked grid ([`grid`]), the renderer that
//! integrates each pixel's light exactly or to a stated error (§10, [`render`]), and the
//! recorder that turns that integration into the rows of a linear map over a grid of cells
//! ([`recorder`]), and the Bayer colour filter array that mosaics one render per colour
//! ([`cfa`]). Uses [`crate::infra`] and [`crate::model`].

pub mod cfa;
pub mod grid;
pub mod recorder;
pub mod render;
pub mod scene;
pub mod texture;
