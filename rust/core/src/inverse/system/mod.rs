//! The linear map from a scene's albedo to the raw (docs/model.md §11, docs/reconstruct.md):
//! row = raw pixel, column = cell of a uniform grid over a region of the surface, entry =
//! the value the pixel records when the albedo is 1 on that cell and 0 elsewhere. It is
//! built with the forward model's own integration ([`crate::imaging::render`]), so that for an
//! image texture on the grid `A t` is the rendered raw.
//!
//! On the forward model's exact route (a fronto-parallel plane, a rect grid, a square
//! aperture and the ideal layout) a pixel's ray set is the product of its x and y polygons
//! (§4), and its entry on cell (i, j) is the product of the areas of the two 1-D polygons
//! between the cell's edges: exact, no quadrature.
//!
//! This module owns the checks shared by every route (which channels the exact route
//! takes, the default region, a pixel's span, the map's bytes) and the cell averages of a
//! texture; the routes live in their own files:
//! - `factored`: the exact route, per-axis factors ([`factors`]) and the explicit map
//!   on a fronto-parallel plane ([`build`]);
//! - `general`: any surface and any design ([`build_surface`]), the general route in
//!   record mode, and the choice of the tilted route for a tilted plane;
//! - `tilted`: a tilted plane on the exact route's designs, its geometry and profiles in
//!   `slabs`.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::imaging::recorder::Chunks;
pub use crate::imaging::recorder::{CellGrid, System, OUTSIDE_SHARE};
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::for_chunks;
use crate::model::design::{Aperture, Channel, Design, Grid, Layout};

mod factored;
mod general;
mod slabs;
mod tilted;

pub use factored::{build, factors, AxisProfiles, Factors, TypeSelection};
pub use general::build_surface;

/// One map's build: the design, the channels (numbered from 0), the grid, the worker
/// threads and the count of raw rows handled (for progress).
#[derive(Clone, Copy)]
struct Job<'a> {
    design: &'a Design,
    channels: &'a [usize],
    grid: &'a CellGrid,
    n_threads: Option<usize>,
    done: &'a AtomicUsize,
}

/// A raw row's entries are done: count their bytes against the memory limit (`bytes`
/// holds the map's so far) and the row for progress.
fn row_done(s: &System, bytes: &AtomicU64, done: &AtomicUsize) -> Result<()> {
    let add = (s.rows.data.len() * 12) as u64;
    let have = bytes.fetch_add(add, Ordering::Relaxed) as u128;
    memory::check("the reconstruction's system matrix", have + add as u128)?;
    done.fetch_add(1, Ordering::Relaxed);
    Ok(())
}

/// Append to `out` the rows of one channel's raw, built on the pool of `n_threads` in
/// chunks of `step` raw rows (a checkpoint between chunks): raw row b's rows are
/// `row(state, b)`, each worker holding its own `init()` state; appended in raw-row order.
fn append_rows<T: Send>(
    out: &mut System,
    (n_threads, rows, step): (Option<usize>, usize, usize),
    init: impl Fn() -> T + Sync + Send,
    row: impl Fn(&mut T, usize) -> Result<System> + Sync + Send,
) -> Result<()> {
    let parts = Chunks::default();
    for_chunks(n_threads, rows, step, |range| {
        let chunk: Result<Vec<System>> = range
            .clone()
            .into_par_iter()
            .map_init(&init, &row)
            .collect();
        parts.push(range.start, chunk?);
        Ok(())
    })?;
    out.append_chunks(parts);
    Ok(())
}

/// Can the map be built for this channel (the exact route)? The reason when not.
fn supported(design: &Design, ch: &Channel) -> std::result::Result<(), &'static str> {
    if ch.grid != Grid::Rect {
        return Err("a rect grid");
    }
    if design.shape != Aperture::Square {
        return Err("a square aperture");
    }
    if !matches!(ch.layout, Layout::Ideal { .. }) {
        return Err("the ideal layout");
    }
    Ok(())
}

/// Can the map of these channels (numbered from 0) be built in factored form, the exact
/// route (on a fronto-parallel plane)? The first channel's reason when not.
pub fn exact(design: &Design, channels: &[usize]) -> Result<()> {
    for &i in channels {
        if let Err(need) = supported(design, channel(design, i)?) {
            return Err(unsupported(i, need));
        }
    }
    Ok(())
}

/// The default region: the rectangle of the plane at depth z that each of `channels` sees
/// through at least half its aperture per axis. A point P is seen from main-lens point w
/// through array point x = (B w − P) L / z (B = 1 − z/F + z/L); for |w| ≤ r/2 that x lies
/// inside the array (half-width W/2) when |P| ≤ (z/L) W/2 − |B| r/2.
pub fn seen_region(design: &Design, channels: &[usize], z: f64) -> Result<[f64; 4]> {
    crate::model::optics::check_design_depths(design.f_main, &[z])?;
    let r = design.aperture / 2.0;
    let (mut hx, mut hy) = (f64::INFINITY, f64::INFINITY);
    for &i in channels {
        let ch = channel(design, i)?;
        let (w, h) = ch.array_extent();
        let b = (1.0 - z / design.f_main + z / ch.l).abs() * r / 2.0;
        hx = hx.min(z / ch.l * w / 2.0 - b);
        hy = hy.min(z / ch.l * h / 2.0 - b);
    }
    if !(hx > 0.0 && hy > 0.0) {
        return Err(Error::param(
            "region",
            "none",
            format!(
                "a region: at z = {z} mm no point is seen by the chosen channels through \
                 half the aperture; give one explicitly"
            ),
        ));
    }
    Ok([-hx, hx, -hy, hy])
}

/// The widest object-space span (mm, either axis) of one pixel's rays on the plane at
/// depth z among `channels`: X = B w − (z/L)(c + ξ) with |ξ| ≤ h (the cell's bounding
/// box) and w in the pixel's preimage on the main lens, |α ξ − (v/L) w − θ| ≤ μ/2, of
/// width (L/v)(|α| 2h + μ) (at most D): at most (z/L) 2h + |B| min(D, (L/v)(|α| 2h + μ)).
/// A pixel that sees any point of a region sees only points within this margin of it.
pub fn pixel_span(design: &Design, channels: &[usize], z: f64) -> Result<f64> {
    crate::model::optics::check_design_depths(design.f_main, &[z])?;
    let mut span = 0.0f64;
    for &i in channels {
        let ch = channel(design, i)?;
        let h = match ch.grid {
            Grid::Rect => ch.d / 2.0,
            Grid::Hex => ch.d / 3f64.sqrt(),
        };
        let b = (1.0 - z / design.f_main + z / ch.l).abs();
        for &f in &ch.f {
            let alpha = 1.0 + ch.v / ch.l - ch.v / f;
            let w = (ch.l / ch.v * (alpha.abs() * 2.0 * h + ch.mu)).min(design.aperture);
            span = span.max(z / ch.l * 2.0 * h + b * w);
        }
    }
    Ok(span)
}

fn unsupported(i: usize, need: &str) -> Error {
    Error::param(
        "design",
        format!("channel {}", i + 1),
        format!(
            "{need}: the system is built today on the forward model's exact route \
             (rect grid, square aperture, ideal layout, fronto-parallel plane)"
        ),
    )
}

fn channel(design: &Design, i: usize) -> Result<&Channel> {
    design.channels.get(i).ok_or_else(|| {
        Error::param(
            "channels",
            i + 1,
            format!("channel numbers in 1..={}", design.channels.len()),
        )
    })
}

/// Bytes of a map of `rows` rows and `nnz` entries (CSR, u32 indices, u64 row offsets).
pub fn system_bytes(rows: u128, nnz: u128) -> u128 {
    memory::bytes_of::<f64>(nnz)
        .saturating_add(memory::bytes_of::<u32>(nnz))
        .saturating_add(memory::bytes_of::<u64>(rows.saturating_mul(3)))
}

/// The texture averaged over each cell of the grid, row-major from the top row.
pub fn cell_averages(texture: &crate::imaging::texture::Texture, grid: &CellGrid) -> Vec<f64> {
    let mut v = vec![0.0; grid.cells()];
    v.par_chunks_mut(grid.nx.max(1)).enumerate().for_each_init(
        crate::imaging::texture::Scratch::default,
        |s, (r, row)| {
            let y1 = grid.y1 - r as f64 * grid.step;
            let y0 = y1 - grid.step;
            for (c, out) in row.iter_mut().enumerate() {
                let x0 = grid.x0 + c as f64 * grid.step;
                let x1 = x0 + grid.step;
                *out = texture.average(&[[x0, y0], [x1, y0], [x1, y1], [x0, y1]], s);
            }
        },
    );
    v
}

/// The seed with 6 x 5 lenses per channel: a small design for the routes' tests.
#[cfg(test)]
fn seed_small() -> Design {
    let mut d = crate::model::presets::preset("seed").unwrap();
    for ch in d.channels.iter_mut() {
        ch.kx = 6;
        ch.ky = 5;
    }
    d
}
