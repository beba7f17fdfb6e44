//! Ray-space engine (docs/model.md §3–5): every pixel's integration polygon in (u, w) and its
//! footprint on a scene plane at any depth.
//!
//! A ray is (u, w): w its height on the main lens, u where it crosses plane v' (the first
//! array's plane, common to both halves). On array plane L_i it is at x = a u + b w with
//! a = L_i/v', b = 1 − L_i/v'. Pixel q under microlens j (centre c) collects the rays in
//! three strips: the aperture |w| ≤ D/2, the microlens |x − c| ≤ d/2 and the pixel
//! |s' − s| ≤ μ/2 (s' the ray's sensor position). The first two make a parallelogram, the
//! third clips it: a convex polygon of at most 6 vertices, counter-clockwise.
//! A scene plane at depth z is the family of lines p' = u + σ w, σ = (v' − z')/z'; the
//! footprint of a pixel is the image of its polygon under that projection (docs/rayspace.md).
//!
//! Parts: `polygons` (the strips, the clipped polygon through `infra::polygon`, the
//! residue rule), `trace` (every pixel's polygon along a line), `footprints` (positions,
//! extents and weight profiles over depth), `grid` (the 2-D sample grid of a channel).
//! This file holds the names they share: [`MAX_VERTICES`], [`Sample`], [`axis_from_name`].

mod footprints;
mod grid;
mod polygons;
#[cfg(test)]
mod test_designs;
mod trace;

pub use footprints::*;
pub use grid::*;
pub use polygons::*;
pub use trace::*;

use crate::infra::error::{Error, Result};
use crate::sampling::line::Axis;

/// Most vertices of an integration polygon (a parallelogram clipped by one strip).
pub const MAX_VERTICES: usize = 6;

/// Axis from its name, "x" or "y".
pub fn axis_from_name(name: &str) -> Result<Axis> {
    match name {
        "x" => Ok(Axis::X),
        "y" => Ok(Axis::Y),
        _ => Err(Error::param("axis", format!("{name:?}"), "\"x\" or \"y\"")),
    }
}

/// Which ray of a pixel stands for its sample position (docs/model.md §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sample {
    /// Projection of the polygon's centroid (aperture-integrated, physical).
    Centroid,
    /// Projection of the chief ray (the paper's convention).
    Chief,
}

impl Sample {
    /// Sample from its name, "centroid" or "chief".
    pub fn from_name(name: &str) -> Result<Sample> {
        match name {
            "centroid" => Ok(Sample::Centroid),
            "chief" => Ok(Sample::Chief),
            _ => Err(Error::param(
                "sample",
                format!("{name:?}"),
                "\"centroid\" or \"chief\"",
            )),
        }
    }
}
