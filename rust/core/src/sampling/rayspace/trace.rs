//! The trace of a line: every pixel's integration polygon, area, centroid, lens and chief
//! ray, filled in parallel (docs/model.md §3–4).

use rayon::prelude::*;

use super::*;
use crate::infra::error::Result;
use crate::infra::memory::{self, try_vec};
use crate::infra::parallel::{check_threads, chunk_items, for_chunks};
use crate::sampling::line::Axis;
use crate::sampling::line::Line;

/// Every pixel of one half (or channel) along one axis: microlens-major (index j Q + q) for
/// the ideal layout, sensor order (index m) for the sensor layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// The channel's index from 0 (half 1 is 0).
    pub channel: usize,
    pub axis: Axis,
    /// Polygons, each padded with NaN rows to 6 vertices.
    pub polygons: Vec<Polygon>,
    pub area: Vec<f64>,
    pub centroid: Vec<[f64; 2]>,
    pub lens: Vec<u32>,
    /// Pixel index under its lens, q (ideal layout), or on the sensor, m (sensor layout).
    pub pixel: Vec<u32>,
    /// Offset θ of the pixel centre from its lens's image centre c (1 + v/L).
    pub theta: Vec<f64>,
    /// Lens type of the pixel's lens (j mod T).
    pub types: Vec<u32>,
    pub chief: Vec<[f64; 2]>,
    /// The chief ray passes the main-lens aperture (docs/model.md §6, `Line::pixel`;
    /// sensor layout: and the pixel centre lies in its lens's image cell).
    pub lit: Vec<bool>,
}

/// Bytes per traced pixel (polygon, area, centroid, indices, offset, type, chief, lit):
/// 165, rounded up.
pub const TRACE_BYTES_PER_PIXEL: u128 = 8 * (12 + 1 + 2 + 2 + 2) + 8 + 8;

/// Bytes of the arrays a caller builds from a trace, per pixel: vertices (12 f64), vertex
/// count, lens, pixel and type (as i64), area, θ, centroid and chief ray (6 f64) and lit (1
/// byte).
pub const TRACE_OUTPUT_BYTES_PER_PIXEL: u128 = 8 * (12 + 4 + 6) + 1;

/// Bytes a top-level trace of n pixels holds at its peak: the trace and the arrays built
/// from it.
pub fn trace_call_bytes(n: u128) -> u128 {
    n.saturating_mul(TRACE_BYTES_PER_PIXEL + TRACE_OUTPUT_BYTES_PER_PIXEL)
}

/// Trace every pixel of a line (a design's channel along one axis): its integration
/// polygon, area, centroid, chief ray and lit flag (docs/model.md §3–4, §6, §9). Parallel
/// over pixels on the current rayon pool (callers run it inside their pool); the buffers
/// are allocated fallibly.
pub fn trace_line(line: &Line) -> Result<Trace> {
    let mut tr = alloc_trace(line)?;
    let n = tr.polygons.len();
    fill_trace(line, &mut tr, 0..n);
    drop_trace_residue(&mut tr);
    Ok(tr)
}

/// [`trace_line`] as a top-level call: memory checked first (the trace, 168 bytes per
/// pixel), run on the pool of `n_threads` in chunks of pixels with an interrupt checkpoint
/// between chunks.
pub fn trace_line_threads(line: &Line, n_threads: Option<usize>) -> Result<Trace> {
    check_threads(n_threads)?;
    let mut tr = alloc_trace(line)?;
    let n = tr.polygons.len();
    for_chunks(n_threads, n, chunk_items(n_threads, 64), |r| {
        fill_trace(line, &mut tr, r);
        Ok(())
    })?;
    drop_trace_residue(&mut tr);
    Ok(tr)
}

/// A trace's buffers, checked against the memory available and allocated fallibly.
fn alloc_trace(line: &Line) -> Result<Trace> {
    let n = line.pixel_count();
    memory::check("trace of one axis", n * TRACE_BYTES_PER_PIXEL)?;
    let n = n as usize;
    let what = "trace of one axis";
    Ok(Trace {
        channel: line.index,
        axis: line.axis,
        polygons: try_vec(what, n, Polygon::EMPTY)?,
        area: try_vec(what, n, 0.0)?,
        centroid: try_vec(what, n, [0.0; 2])?,
        lens: try_vec(what, n, 0)?,
        pixel: try_vec(what, n, 0)?,
        theta: try_vec(what, n, 0.0)?,
        types: try_vec(what, n, 0)?,
        chief: try_vec(what, n, [0.0; 2])?,
        lit: try_vec(what, n, false)?,
    })
}

/// [`drop_residue`] on a filled trace, keeping its area and centroid columns in step.
fn drop_trace_residue(tr: &mut Trace) {
    let floor = LIT_AREA_RTOL * tr.area.iter().copied().fold(0.0, f64::max);
    for ((p, a), c) in tr
        .polygons
        .iter_mut()
        .zip(&mut tr.area)
        .zip(&mut tr.centroid)
    {
        if p.n > 0 && *a < floor {
            *p = Polygon::EMPTY;
            *a = 0.0;
            *c = [f64::NAN; 2];
        }
    }
}

/// Trace pixels `r` of `line` into `tr`, in parallel.
fn fill_trace(line: &Line, tr: &mut Trace, r: std::ops::Range<usize>) {
    let rays: Vec<Rays> = (0..line.types()).map(|t| Rays::new(line, t)).collect();
    let q_count = line.q();
    let start = r.start;
    tr.polygons[r.clone()]
        .par_iter_mut()
        .zip(tr.area[r.clone()].par_iter_mut())
        .zip(tr.centroid[r.clone()].par_iter_mut())
        .zip(tr.lens[r.clone()].par_iter_mut())
        .zip(tr.pixel[r.clone()].par_iter_mut())
        .zip(tr.theta[r.clone()].par_iter_mut())
        .zip(tr.types[r.clone()].par_iter_mut())
        .zip(tr.chief[r.clone()].par_iter_mut())
        .zip(tr.lit[r].par_iter_mut())
        .with_min_len(1024)
        .enumerate()
        .for_each(|(o, ((((((((p, a), cen), l), q), th), ty), ch), lit))| {
            let i = (start + o) as u32;
            let px = line.pixel(i);
            let c = line.lens_center(px.j);
            let t = line.lens_type(px.j);
            let rays = &rays[t];
            *p = rays.polygon(c, px.theta);
            *a = p.area();
            *cen = p.centroid();
            *l = px.j;
            *q = q_count.map_or(i, |qc| i % qc);
            *th = px.theta;
            *ty = t as u32;
            *ch = rays.chief(c, line.chief_w(px.theta));
            *lit = px.lit;
        });
}
