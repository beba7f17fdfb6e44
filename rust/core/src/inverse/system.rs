//! The linear map from a scene's albedo to the raw (docs/model.md §11, docs/reconstruct.md):
//! row = raw pixel, column = cell of a uniform grid over a region of the surface, entry =
//! the value the pixel records when the albedo is 1 on that cell and 0 elsewhere. It is
//! built with the forward model's own integration ([`crate::imaging::render`]), so that for an
//! image texture on the grid `A t` is the rendered raw.
//!
//! Today the map is built on the forward model's exact route: a fronto-parallel plane, a
//! rect grid, a square aperture and the ideal layout. A pixel's ray set is then the
//! product of its x and y polygons (§4), and its entry on cell (i, j) is the product of
//! the areas of the two 1-D polygons between the cell's edges: exact, no quadrature.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::imaging::recorder::Chunks;
use crate::imaging::recorder::Recorder;
pub use crate::imaging::recorder::{CellGrid, System, OUTSIDE_SHARE};
use crate::imaging::render::exact::{
    footprint_of, mean_ray, mean_ray_of, pixel_offset, polygon, profile, ray_set_area,
    tilted_profile, tilted_profile_of, Profile, Tilt,
};
use crate::imaging::render::{Chan, Work};
use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::Texture;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::{checkpoint, for_chunks};
use crate::model::design::{Aperture, Channel, Design, Grid, Layout};

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

/// One axis's profiles of one lens type against a grid's cell edges, as compressed sparse
/// rows: row = raw column (x) or raw row (y), column = grid column (x) or grid row from the
/// top (y), entry = the area of the pixel's 1-D ray polygon between the cell's edges; with
/// each row's total area (inside the grid or not).
#[derive(Debug, Default, Clone)]
pub struct AxisProfiles {
    pub indptr: Vec<u64>,
    pub indices: Vec<u32>,
    pub data: Vec<f64>,
    pub total: Vec<f64>,
}

/// The factors of one channel's map (exact route): per lens type t, the pixel (b, a) of type
/// t has the row norm · (y[t] row b) ⊗ (x[t] row a); `types` is the type of each pixel,
/// row-major.
#[derive(Debug, Default, Clone)]
pub struct Factors {
    pub norm: f64,
    pub x: Vec<AxisProfiles>,
    pub y: Vec<AxisProfiles>,
    pub types: Vec<u8>,
    pub rows: usize,
    pub cols: usize,
}

fn axis_csr(p: &[Profile], flip: Option<usize>) -> AxisProfiles {
    let mut out = AxisProfiles {
        indptr: vec![0],
        ..AxisProfiles::default()
    };
    for pr in p {
        let mut row: Vec<(u32, f64)> = pr
            .areas
            .iter()
            .enumerate()
            .filter(|(_, &v)| v != 0.0)
            .map(|(m, &v)| {
                let k = pr.first + m;
                (flip.map_or(k, |n| n - 1 - k) as u32, v)
            })
            .collect();
        row.sort_by_key(|e| e.0);
        for (k, v) in row {
            out.indices.push(k);
            out.data.push(v);
        }
        out.indptr.push(out.data.len() as u64);
        out.total.push(pr.total);
    }
    out
}

/// The factors of channel `i`'s map (module doc) for the plane at depth z and the grid.
pub fn factors(design: &Design, i: usize, z: f64, grid: &CellGrid) -> Result<Factors> {
    crate::model::optics::check_design_depths(design.f_main, &[z])?;
    let ch = channel(design, i)?;
    if let Err(need) = supported(design, ch) {
        return Err(unsupported(i, need));
    }
    let Layout::Ideal { q } = ch.layout else {
        unreachable!("checked by `supported`")
    };
    if ch.f.len() > u8::MAX as usize {
        return Err(Error::param("f", ch.f.len(), "at most 255 lens types"));
    }
    let chan = Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL);
    let pr = profiles(&chan, z, grid, q);
    let (rows, cols) = crate::imaging::render::raw_shape(ch);
    memory::check(
        "the reconstruction's pixel-type map",
        memory::bytes_of::<u8>(rows as u128 * cols as u128),
    )?;
    let mut types = Vec::with_capacity(rows * cols);
    for b in 0..rows {
        for a in 0..cols {
            types.push(ch.lens_type(a as u32 / q, b as u32 / q) as u8);
        }
    }
    Ok(Factors {
        norm: chan.norm,
        x: pr.px.iter().map(|p| axis_csr(p, None)).collect(),
        y: pr.py.iter().map(|p| axis_csr(p, Some(grid.ny))).collect(),
        types,
        rows,
        cols,
    })
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

/// One channel's profiles against the grid: x per (type, raw column), y per (type, raw row).
struct Profiles {
    px: Vec<Vec<Profile>>,
    py: Vec<Vec<Profile>>,
}

fn profiles(chan: &Chan, z: f64, grid: &CellGrid, q: u32) -> Profiles {
    let ch = chan.ch;
    let (rows, cols) = crate::imaging::render::raw_shape(ch);
    let theta = |i: u32| pixel_offset(ch.mu, q, i);
    let [gx0, _, gy0, _] = grid.extent();
    let h = grid.step;
    let nt = chan.types.len();
    let axis = |n: usize, y: bool, t: usize| -> Vec<Profile> {
        (0..n as u32)
            .into_par_iter()
            .map(|i| {
                let (c, e0, cells) = if y {
                    (ch.lens_center(0, i / q)[1], gy0, grid.ny)
                } else {
                    (ch.lens_center(i / q, 0)[0], gx0, grid.nx)
                };
                profile(chan, chan.types[t].0, c, theta(i), z, cells, |k| {
                    e0 + k as f64 * h
                })
            })
            .collect()
    };
    Profiles {
        px: (0..nt).map(|t| axis(cols, false, t)).collect(),
        py: (0..nt).map(|t| axis(rows, true, t)).collect(),
    }
}

/// Is the pixel's ray set (x profile `xp`, y profile `yp`) lit and inside the grid?
fn kept(xp: &Profile, yp: &Profile) -> bool {
    let total = xp.total * yp.total;
    if total <= 0.0 {
        return false;
    }
    let inside: f64 = xp.areas.iter().sum::<f64>() * yp.areas.iter().sum::<f64>();
    inside > 0.0 && total - inside <= OUTSIDE_SHARE * total
}

/// The map for the fronto-parallel plane at depth `z`, the grid `grid` and the channels
/// `channels` (numbered from 0). `done` counts the raw rows handled (for progress).
pub fn build(
    design: &Design,
    channels: &[usize],
    z: f64,
    grid: &CellGrid,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<System> {
    crate::model::optics::check_design_depths(design.f_main, &[z])?;
    if channels.is_empty() {
        return Err(Error::param("channels", "none", "at least one channel"));
    }
    if grid.cells() > u32::MAX as usize {
        return Err(Error::param(
            "region",
            grid.cells(),
            "fewer than 2^32 cells (a smaller region or a coarser step)",
        ));
    }
    for &i in channels {
        let ch = channel(design, i)?;
        if let Err(need) = supported(design, ch) {
            return Err(unsupported(i, need));
        }
    }
    let mut out = System {
        indptr: vec![0],
        ..System::default()
    };
    for &i in channels {
        let ch = &design.channels[i];
        let Layout::Ideal { q } = ch.layout else {
            unreachable!("checked by `supported`")
        };
        // The tolerance only sizes a circle's polygon (unused on this route).
        let chan = Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL);
        let pr = profiles(&chan, z, grid, q);
        let (rows, cols) = crate::imaging::render::raw_shape(ch);
        let typ = |a: usize, b: usize| ch.lens_type(a as u32 / q, b as u32 / q);
        // Count first, to check the memory before any entry is written.
        let counts: Vec<(usize, usize)> = (0..rows)
            .into_par_iter()
            .map(|b| {
                let (mut n, mut nnz) = (0usize, 0usize);
                for a in 0..cols {
                    let t = typ(a, b);
                    let (xp, yp) = (&pr.px[t][a], &pr.py[t][b]);
                    if kept(xp, yp) {
                        n += 1;
                        nnz += xp.areas.iter().filter(|&&v| v != 0.0).count()
                            * yp.areas.iter().filter(|&&v| v != 0.0).count();
                    }
                }
                (n, nnz)
            })
            .collect();
        let (n_rows, nnz) = counts.iter().fold((0u128, 0u128), |(r, z), &(a, b)| {
            (r + a as u128, z + b as u128)
        });
        let have = (out.channel.len() as u128, out.data.len() as u128);
        memory::check(
            "the reconstruction's system matrix",
            system_bytes(have.0 + n_rows, have.1 + nnz),
        )?;
        // Rows in parallel chunks, each chunk's entries in its own buffers, then appended.
        let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 64);
        let parts = Chunks::default();
        let norm = chan.norm;
        let nx = grid.nx;
        for_chunks(n_threads, rows, step, |range| {
            let chunk: Result<Vec<System>> = range
                .clone()
                .into_par_iter()
                .map(|b| -> Result<System> {
                    checkpoint()?;
                    let mut s = System {
                        indptr: Vec::with_capacity(counts[b].0),
                        ..System::default()
                    };
                    s.data.reserve(counts[b].1);
                    s.indices.reserve(counts[b].1);
                    for a in 0..cols {
                        let t = typ(a, b);
                        let (xp, yp) = (&pr.px[t][a], &pr.py[t][b]);
                        if !kept(xp, yp) {
                            continue;
                        }
                        // Top-down rows of the grid: bottom-up row bu is row ny − 1 − bu.
                        for (m, &ay) in yp.areas.iter().enumerate().rev() {
                            if ay == 0.0 {
                                continue;
                            }
                            let row = grid.ny - 1 - (yp.first + m);
                            for (n, &ax) in xp.areas.iter().enumerate() {
                                if ax != 0.0 {
                                    s.indices.push((row * nx + xp.first + n) as u32);
                                    s.data.push(norm * ax * ay);
                                }
                            }
                        }
                        s.end_row(i, b * cols + a);
                    }
                    done.fetch_add(1, Ordering::Relaxed);
                    Ok(s)
                })
                .collect();
            let chunk = chunk?;
            parts.push(range.start, chunk);
            Ok(())
        })?;
        out.append_chunks(parts);
    }
    Ok(out)
}

/// A raw row's entries are done: count their bytes against the memory limit (`bytes`
/// holds the map's so far) and the row for progress.
fn row_done(s: &System, bytes: &std::sync::atomic::AtomicU64, done: &AtomicUsize) -> Result<()> {
    let add = (s.data.len() * 12) as u64;
    let have = bytes.fetch_add(add, Ordering::Relaxed) as u128;
    memory::check("the reconstruction's system matrix", have + add as u128)?;
    done.fetch_add(1, Ordering::Relaxed);
    Ok(())
}

/// Bytes of the per-worker buffers of [`build_surface`] (a grid-sized accumulator each).
fn recorder_bytes(grid: &CellGrid, workers: usize) -> u128 {
    (grid.cells() as u128) * 9 * workers as u128
}

/// The depths at which a ray can meet the surface over the grid: a plane's range over the
/// grid's extent, a depth map's whole range.
fn depth_range(surface: &Surface, grid: &CellGrid) -> (f64, f64) {
    match surface {
        Surface::Plane { z0, g } => {
            let [x0, x1, y0, y1] = grid.extent();
            let d =
                [[x0, y0], [x0, y1], [x1, y0], [x1, y1]].map(|p| z0 + g[0] * p[0] + g[1] * p[1]);
            (
                d.iter().copied().fold(f64::INFINITY, f64::min),
                d.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        }
        Surface::Map(m) => (m.zmin, m.zmax),
    }
}

/// Per lens (row-major, k kx + j): can a ray through it meet the surface on the grid? A
/// ray P(z) = B(z) w − (z/L) x is affine in z, so between depths zlo and zhi it stays in
/// the bounding box of its points at the two; over the aperture's box of w and the lens
/// cell's box of x that is a box per depth.
fn lenses_seeing(design: &Design, ch: &Channel, surface: &Surface, grid: &CellGrid) -> Vec<bool> {
    let (zlo, zhi) = depth_range(surface, grid);
    let r = design.aperture / 2.0;
    let h = match ch.grid {
        Grid::Rect => [ch.d / 2.0, ch.d / 2.0],
        Grid::Hex => [ch.d / 2.0, ch.d / 3f64.sqrt()],
    };
    let [gx0, gx1, gy0, gy1] = grid.extent();
    let mut out = Vec::with_capacity((ch.kx * ch.ky) as usize);
    for k in 0..ch.ky {
        for j in 0..ch.kx {
            let c = ch.lens_center(j, k);
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for z in [zlo, zhi] {
                let b = (1.0 - z / design.f_main + z / ch.l).abs() * r;
                for i in 0..2 {
                    let m = z / ch.l;
                    lo[i] = lo[i].min(-m * c[i] - m * h[i] - b);
                    hi[i] = hi[i].max(-m * c[i] + m * h[i] + b);
                }
            }
            out.push(hi[0] >= gx0 && lo[0] <= gx1 && hi[1] >= gy0 && lo[1] <= gy1);
        }
    }
    out
}

/// Can the pixel (column a, row b) see the grid: does any lens that can light it see it?
fn pixel_may_see(design: &Design, chan: &Chan, sees: &[bool], a: u32, b: u32) -> bool {
    let ch = chan.ch;
    match ch.layout {
        Layout::Ideal { .. } => {
            let px = design.pixel(ch, a, b);
            sees[(px.k * ch.kx + px.j) as usize]
        }
        Layout::Sensor { mx, my } => {
            let s = [
                ch.mu * (a as f64 - (mx as f64 - 1.0) / 2.0),
                ch.mu * (b as f64 - (my as f64 - 1.0) / 2.0),
            ];
            let (ks, js) = chan.lens_window(s, chan.reach());
            ks.into_iter()
                .any(|k| js.clone().any(|j| sees[(k * ch.kx + j) as usize]))
        }
    }
}

/// The map for any surface (slanted plane, depth map) and any design (hex grids, circular
/// apertures, sensor layouts): the forward model's general route in record mode
/// ([`Recorder`]). The node polygons' images are clipped by the cells exactly; the outer
/// integral is the render's cuts (the lens's kinks and the grid's lines) with the fixed
/// rule. Only the pixels under lenses of `types` (type indices from 0; None: every type)
/// are rows. `done` counts the raw rows handled.
#[allow(clippy::too_many_arguments)]
pub fn build_surface(
    design: &Design,
    channels: &[usize],
    surface: &Surface,
    grid: &CellGrid,
    types: Option<&[usize]>,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<System> {
    if channels.is_empty() {
        return Err(Error::param("channels", "none", "at least one channel"));
    }
    for &i in channels {
        channel(design, i)?;
    }
    if let Some(ts) = types {
        let n = channels
            .iter()
            .map(|&i| design.channels[i].f.len())
            .max()
            .unwrap_or(1);
        if ts.is_empty() {
            return Err(Error::param("lens_types", "none", "at least one lens type"));
        }
        if let Some(&t) = ts.iter().find(|&&t| t >= n) {
            return Err(Error::param(
                "lens_types",
                t + 1,
                format!("lens type numbers in 1..={n} (the channels' lens types)"),
            ));
        }
    }
    let keeps = |t: usize| types.map_or(true, |ts| ts.contains(&t));
    if grid.cells() > u32::MAX as usize {
        return Err(Error::param(
            "region",
            grid.cells(),
            "fewer than 2^32 cells (a smaller region or a coarser step)",
        ));
    }
    // The map needs the surface only where the grid's cells are: a tilted plane is
    // checked over the grid (its depth there > F; rays that meet it elsewhere, nearer than
    // F or not at all, light no cell and their pixels are not rows), a depth map over its
    // whole range (the render's check).
    match surface {
        Surface::Plane { z0, g } if g != &[0.0, 0.0] => {
            let (zlo, _) = depth_range(surface, grid);
            let f = design.f_main;
            if zlo.is_nan() || zlo <= f {
                return Err(Error::param(
                    "plane",
                    format!("Z = {z0} + {} X + {} Y", g[0], g[1]),
                    format!(
                        "a plane deeper than F = {f} mm over the region (its least depth \
                         there is {zlo:.1} mm)"
                    ),
                ));
            }
        }
        _ => crate::imaging::render::check_surface(design, surface)?,
    }
    if let Surface::Plane { z0, g } = surface {
        let exact = channels
            .iter()
            .all(|&i| supported(design, &design.channels[i]).is_ok());
        // A tilted plane: the tilted route (None comes before any row is counted: the
        // general route starts afresh).
        if exact && g != &[0.0, 0.0] {
            if let Some(s) = build_tilted(design, channels, *z0, *g, grid, &keeps, n_threads, done)?
            {
                return Ok(s);
            }
        }
    }
    build_general(
        design, channels, surface, grid, types, &keeps, n_threads, done,
    )
}

/// The map on the forward model's general route in record mode (any surface, any design).
#[allow(clippy::too_many_arguments)]
fn build_general(
    design: &Design,
    channels: &[usize],
    surface: &Surface,
    grid: &CellGrid,
    types: Option<&[usize]>,
    keeps: &(dyn Fn(usize) -> bool + Sync),
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<System> {
    let workers = crate::infra::parallel::threads(n_threads);
    memory::check(
        "the reconstruction map's grid texture and row accumulators",
        recorder_bytes(grid, workers + 1) + memory::bytes_of::<f64>(grid.cells() as u128),
    )?;
    let ext = grid.extent();
    let lines = crate::imaging::texture::ImageTexture::new(
        &vec![0.0; grid.cells()],
        grid.ny,
        grid.nx,
        ext,
    )?;
    let scene = Scene::new(Texture::Image(Box::new(lines)), surface.clone(), 0.0)?;
    let mut out = System {
        indptr: vec![0],
        ..System::default()
    };
    for &i in channels {
        let ch = &design.channels[i];
        let chan = Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL);
        let (rows, cols) = crate::imaging::render::raw_shape(ch);
        let px = crate::imaging::render::Pixels {
            design,
            chan: &chan,
            scene: &scene,
            tol: 1.0,
        };
        let map_once = crate::imaging::render::map_seen_once(&chan, surface);
        let sees = lenses_seeing(design, ch, surface, grid);
        let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 4000);
        let parts = Chunks::default();
        let bytes = std::sync::atomic::AtomicU64::new((out.data.len() * 12) as u64);
        for_chunks(n_threads, rows, step, |range| {
            let chunk: Result<Vec<System>> = range
                .clone()
                .into_par_iter()
                .map_init(
                    || Recorder::new(*grid).map(|r| Work::recording(Box::new(r), map_once)),
                    |wk, b| -> Result<System> {
                        let wk = wk.as_mut().map_err(|e| e.clone())?;
                        let mut s = System::default();
                        for a in 0..cols {
                            checkpoint()?;
                            if !pixel_may_see(design, &chan, &sees, a as u32, b as u32) {
                                continue;
                            }
                            if types.is_some() && !keeps(design.pixel(ch, a as u32, b as u32).t) {
                                continue;
                            }
                            if let Some(r) = wk.rec.as_deref_mut() {
                                r.reset(chan.norm);
                            }
                            crate::imaging::render::pixel_value(&px, a as u32, b as u32, wk);
                            if wk.rec.as_deref_mut().is_some_and(|r| r.take(&mut s)) {
                                s.end_row(i, b * cols + a);
                            }
                        }
                        row_done(&s, &bytes, done)?;
                        Ok(s)
                    },
                )
                .collect();
            let chunk = chunk?;
            parts.push(range.start, chunk);
            Ok(())
        })?;
        out.append_chunks(parts);
    }
    Ok(out)
}

/// Sub-slabs of a grid row (or column) on the tilted route: enough that a slab spans at
/// most [`SLAB_DEPTH`] of its depth (the other axis's profile is taken at the slab's
/// middle depth).
const SLAB_DEPTH: f64 = 2e-4;
/// The most sub-slabs a grid row or column is cut into.
const MAX_SLABS: usize = 64;
/// The most parts per axis of (ξ, w) a pixel's o ray set is cut into on the tilted route
/// (m × m boxes).
const MAX_SIDE: usize = 16;
/// The share of its depth by which a row's plane may change across a pixel's footprint
/// along the smaller tilt's axis: g_o W / 2 over the depth where the pixel's mean ray meets
/// the plane, W the widest footprint along o over the slabs the pixel reaches. A pixel
/// within [`CUT_EPS`] is cut whole. A wider one is cut into m × m parts, m = ⌈share /
/// CUT_EPS⌉ (2 to [`MAX_SIDE`]), each part about that much narrower. When a part of the
/// finest cut is still past TILT_EPS, the plane is left to the general route.
const TILT_EPS: f64 = 1e-3;
/// The share past which a pixel is cut into parts (see [`TILT_EPS`]). Whole pixels' A t
/// stays within about 0.5 to 0.7 times their share of white (measured against the general
/// route on the seed: 2.2e-4 at a share of 4.4e-4, 4.6e-4 at 8.8e-4, when pixels were
/// cut whole up to 1e-3). With this cut every plane measured is within 0.7 to 2.4e-4 of
/// render's own raw, as the general route is (docs/reconstruct.md step 5).
const CUT_EPS: f64 = 2.5e-4;

/// The map for the plane Z = z0 + gx X + gy Y (not fronto-parallel) on the exact route's
/// designs (rect grid, square aperture, ideal layout), or None (the caller then takes the
/// general route): before any row is built when the plane is not in front of the lens over
/// the grid, and at the first row that finds it tilted along both axes too steeply even
/// for parts (the rows counted in `done` so far are then taken back). Pixels with rays
/// that miss the plane are not rows.
///
/// A pixel's ray set is the product of its x and y polygons. Call t the axis of the larger
/// tilt (Y on a tie) and o the other. Along t the polygon's areas between the grid's edges
/// are exact when the depth depends on U_t alone ([`tilted_profile`]: the cut at an edge
/// is the fronto-parallel cut at the edge's depth), and each grid row (column) is cut into
/// slabs of at most [`SLAB_DEPTH`] relative depth. Along o, each slab's areas are those of
/// the line of the plane through the slab's middle, Z = z_k + g_o U_o, cut the same exact
/// way; and a slab's t area times its o areas. With a tilt along o as well, the depth
/// along t's cuts depends on U_o too: each pixel's t areas are taken on the plane along t
/// that its mean o ray sees (U_o = w_o − Z a_o: Z = (z0 + g_o w_o) / (1 + g_o a_o) +
/// g_t U_t / (1 + g_o a_o), exact for that o ray with every t ray), so the error grows
/// with g_o times the pixel's footprint along o, not with the grid's. Where that footprint
/// is too wide for [`CUT_EPS`], the pixel's o polygon is cut into m × m boxes in (ξ, w)
/// (a box's rays are close in position and slope, so they meet the plane close together
/// at any depth), and each box takes the same two steps with its own mean o ray and its own
/// o areas per slab. Either way every pixel's areas add up to its whole ray set (the o
/// areas of each slab and box and the t areas do, and the boxes tile the polygon). The
/// two axes' geometry is the same per axis (a rect grid's lens centres, the ideal
/// layout's pixel offsets, a square aperture), so one code serves both.
#[allow(clippy::too_many_arguments)]
fn build_tilted(
    design: &Design,
    channels: &[usize],
    z0: f64,
    g: [f64; 2],
    grid: &CellGrid,
    keeps: &(dyn Fn(usize) -> bool + Sync),
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Option<System>> {
    let [gx0, gx1, gy0, gy1] = grid.extent();
    let corners = [[gx0, gy0], [gx0, gy1], [gx1, gy0], [gx1, gy1]];
    let depth = |c: &[f64; 2]| z0 + g[0] * c[0] + g[1] * c[1];
    let zmin = corners.iter().map(depth).fold(f64::INFINITY, f64::min);
    // `build_surface` has already required zmin > F over this grid; this check keeps the
    // slab count finite for direct callers (the tests).
    if zmin.is_nan() || zmin <= 0.0 {
        return Ok(None);
    }
    let axis = usize::from(g[1].abs() >= g[0].abs());
    let (gt, go) = (g[axis], g[1 - axis]);
    // Along the tilted axis (t): the grid's first edge and cells; along the other (o):
    // its first and last edges and cells.
    let ((t0, nct), (o0, o1, nco)) = if axis == 0 {
        ((gx0, grid.nx), (gy0, gy1, grid.ny))
    } else {
        ((gy0, grid.ny), (gx0, gx1, grid.nx))
    };
    let h = grid.step;
    let slabs = ((gt.abs() * h / (SLAB_DEPTH * zmin)).ceil() as usize).clamp(1, MAX_SLABS);
    let hs = h / slabs as f64;
    let ns = nct * slabs;
    let slab_z = |k: usize| z0 + gt * (t0 + (k as f64 + 0.5) * hs);
    let edge_t = |k: usize| t0 + k as f64 * hs;
    let (nx, ny) = (grid.nx, grid.ny);
    // The cell of slab k (counted from the tilted axis's low edge) and of cell n of the
    // other axis (counted from its low edge): rows run from the top (largest Y).
    let cell = |k: usize, n: usize| -> u32 {
        let (c, r) = if axis == 0 {
            (k / slabs, ny - 1 - n)
        } else {
            (n, ny - 1 - k / slabs)
        };
        (r * nx + c) as u32
    };
    // A channel's spec, its pixels a lens (the ideal layout), geometry and raw's shape.
    let open = |i: usize| {
        let ch = &design.channels[i];
        let Layout::Ideal { q } = ch.layout else {
            unreachable!("checked by `supported` in the caller")
        };
        let (rows, cols) = crate::imaging::render::raw_shape(ch);
        let chan = Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL);
        (ch, q, chan, rows, cols)
    };
    // A pixel line's lens centre along axis ax (raw columns run along X, rows along Y).
    let center = |ch: &Channel, q: u32, p: u32, ax: usize| {
        if ax == 0 {
            ch.lens_center(p / q, 0)[0]
        } else {
            ch.lens_center(0, p / q)[1]
        }
    };
    // The planes tilted along t alone between which the pixels' planes lie.
    let offsets = if go == 0.0 {
        vec![z0]
    } else {
        vec![z0 + go * o0, z0 + go * o1]
    };
    // Set by the first row too steep for this route (with a tilt along o); the rows
    // handled so far are then uncounted and the plane handed back.
    let steep = std::sync::atomic::AtomicBool::new(false);
    let done_before = done.load(Ordering::Relaxed);
    let mut out = System {
        indptr: vec![0],
        ..System::default()
    };
    for &i in channels {
        let (ch, q, chan, rows, cols) = open(i);
        // Pixels along the tilted and the other axis (raw columns run along X, rows along
        // Y), and a pixel line's lens centre along an axis.
        let (npt, npo) = if axis == 0 {
            (cols, rows)
        } else {
            (rows, cols)
        };
        let center = |p: u32, ax: usize| center(ch, q, p, ax);
        let theta = |i: u32| pixel_offset(ch.mu, q, i);
        let nt = chan.types.len();
        let kept = (0..nt).filter(|&t| keeps(t)).count() as u128;
        // Tilted profiles per type, offset plane and pixel line along t, against the slab
        // edges; None where some of the line's rays miss the plane (its pixels are then not
        // kept, as on the general route: part of their light is not on the grid). A type
        // not kept has no profiles (its pixels are no rows). Without a tilt along o these
        // are the pixels' profiles; with one, the bounds of the slabs they reach.
        let mut pt: Vec<Vec<Vec<Option<Profile>>>> = Vec::with_capacity(nt);
        for t in 0..nt {
            if !keeps(t) {
                pt.push(Vec::new());
                continue;
            }
            let mut per = Vec::with_capacity(offsets.len());
            for &zp in &offsets {
                per.push(
                    (0..npt as u32)
                        .into_par_iter()
                        .map(|b| {
                            let c = center(b, axis);
                            tilted_profile(
                                &chan,
                                chan.types[t].0,
                                c,
                                theta(b),
                                Tilt { z0: zp, g: gt },
                                ns,
                                edge_t,
                            )
                        })
                        .collect::<Vec<_>>(),
                );
                checkpoint()?;
            }
            pt.push(per);
        }
        // The slabs some kept pixel's rays reach (with a tilt along o: every slab between
        // a line's reach on the two bounding planes, the reach moving monotonically with
        // the plane's offset), and the other axis's profiles there.
        let mut used = vec![false; ns];
        for per in pt.iter().filter(|v| !v.is_empty()) {
            for it in 0..npt {
                let (mut lo, mut hi) = (usize::MAX, 0);
                for p in per.iter().filter_map(|v| v[it].as_ref()) {
                    for (j, &a) in p.areas.iter().enumerate() {
                        if a != 0.0 {
                            if go == 0.0 {
                                used[p.first + j] = true;
                            }
                            lo = lo.min(p.first + j);
                            hi = hi.max(p.first + j + 1);
                        }
                    }
                }
                if go != 0.0 && lo < hi {
                    used[lo..hi].fill(true);
                }
            }
        }
        memory::check(
            "the tilted route's profiles",
            (used.iter().filter(|&&u| u).count() as u128) * kept * (npo as u128) * 96,
        )?;
        // In blocks of slabs, with a check for Ctrl-C between them.
        type Slab = Option<Vec<Option<Profile>>>;
        let mut po: Vec<Vec<Slab>> = Vec::with_capacity(nt);
        for t in 0..nt {
            if !keeps(t) {
                po.push((0..ns).map(|_| None).collect());
                continue;
            }
            let mut v = Vec::with_capacity(ns);
            for start in (0..ns).step_by(64) {
                checkpoint()?;
                v.par_extend((start..(start + 64).min(ns)).into_par_iter().map(|k| {
                    used[k].then(|| {
                        (0..npo as u32)
                            .map(|a| {
                                tilted_profile(
                                    &chan,
                                    chan.types[t].0,
                                    center(a, 1 - axis),
                                    theta(a),
                                    Tilt {
                                        z0: slab_z(k),
                                        g: go,
                                    },
                                    nco,
                                    |n| o0 + n as f64 * h,
                                )
                            })
                            .collect()
                    })
                }));
            }
            po.push(v);
        }
        // The other axis's polygons' whole areas (its profile on any plane has the same
        // total), and with a tilt along o each pixel line's mean ray per axis.
        let ototal: Vec<Vec<f64>> = (0..nt)
            .map(|t| {
                (0..npo as u32)
                    .map(|a| ray_set_area(&chan, chan.types[t].0, theta(a)))
                    .collect()
            })
            .collect();
        let rays = |n: usize, ax: usize| -> Vec<Vec<Option<(f64, f64)>>> {
            (0..nt)
                .map(|t| {
                    if go == 0.0 {
                        return Vec::new();
                    }
                    (0..n as u32)
                        .map(|a| mean_ray(&chan, chan.types[t].0, center(a, ax), theta(a)))
                        .collect()
                })
                .collect()
        };
        let (rt, ro) = (rays(npt, axis), rays(npo, 1 - axis));
        checkpoint()?;
        let typ = |a: usize, b: usize| ch.lens_type(a as u32 / q, b as u32 / q);
        // The plane along t seen by the o rays around the mean o ray (w_o, a_o): the ray is
        // at U_o = w_o − Z a_o at depth Z, so Z = z0 + g_t U_t + g_o U_o is the plane
        // Z = (z0 + g_o w_o) / (1 + g_o a_o) + g_t / (1 + g_o a_o) U_t along t, exact for
        // that o ray with every t ray; None when the o ray runs away from the plane.
        let along_t = |wo: f64, ao: f64| -> Option<(f64, f64)> {
            let den = 1.0 + go * ao;
            (den > 0.0).then(|| ((z0 + go * wo) / den, gt / den))
        };
        // The depth at which the ray (w_t, a_t) along t and (w_o, a_o) along o meets the
        // plane (`Surface::hit`, with the axes put back in X, Y order); None when it runs
        // away from the plane or meets it behind the main lens.
        let plane = Surface::Plane { z0, g };
        let hit = |(wt, at): (f64, f64), (wo, ao): (f64, f64)| -> Option<f64> {
            let (w, a) = if axis == 0 {
                ([wt, wo], [at, ao])
            } else {
                ([wo, wt], [ao, at])
            };
            plane.hit(w, a).map(|(z, _)| z)
        };
        // Slab k's o areas times the t area a_t into a row's entries and its light on the
        // grid (`inside`); the number of o cells it reaches (0: none).
        let add = |k: usize,
                   op: &Profile,
                   a_t: f64,
                   entries: &mut Vec<(u32, f64)>,
                   inside: &mut f64|
         -> usize {
            let mut span = (usize::MAX, 0);
            for (n, &a_o) in op.areas.iter().enumerate() {
                if a_o != 0.0 {
                    *inside += a_o * a_t;
                    entries.push((cell(k, op.first + n), a_t * a_o));
                    span = (span.0.min(n), n);
                }
            }
            (span.1 + 1).saturating_sub(span.0)
        };
        let norm = chan.norm;
        let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 256);
        let parts = Chunks::default();
        let bytes = std::sync::atomic::AtomicU64::new((out.data.len() * 12) as u64);
        for_chunks(n_threads, rows, step, |range| {
            let chunk: Result<Vec<System>> = range
                .clone()
                .into_par_iter()
                .map(|b| -> Result<System> {
                    checkpoint()?;
                    let mut s = System::default();
                    if steep.load(Ordering::Relaxed) {
                        return Ok(s);
                    }
                    let mut entries: Vec<(u32, f64)> = Vec::new();
                    'pixel: for a in 0..cols {
                        let t = typ(a, b);
                        if !keeps(t) {
                            continue;
                        }
                        let (it, io) = if axis == 0 { (a, b) } else { (b, a) };
                        // The pixel's profile along t: its line's, or on the plane along t
                        // that its mean o ray sees (`along_t`).
                        let own;
                        let mut zp_mean = f64::NAN;
                        let mut ray_t = (f64::NAN, f64::NAN);
                        let tp = if go == 0.0 {
                            match &pt[t][0][it] {
                                Some(p) => p,
                                None => continue,
                            }
                        } else {
                            let (Some(rt), Some((wo, ao))) = (rt[t][it], ro[t][io]) else {
                                continue;
                            };
                            let Some(z) = hit(rt, (wo, ao)) else {
                                continue;
                            };
                            zp_mean = z;
                            ray_t = rt;
                            let Some((zp, gp)) = along_t(wo, ao) else {
                                continue;
                            };
                            let c = center(it as u32, axis);
                            match tilted_profile(
                                &chan,
                                chan.types[t].0,
                                c,
                                theta(it as u32),
                                Tilt { z0: zp, g: gp },
                                ns,
                                edge_t,
                            ) {
                                Some(p) => {
                                    own = p;
                                    &own
                                }
                                None => continue,
                            }
                        };
                        let total = tp.total * ototal[t][io];
                        if total <= 0.0 {
                            continue;
                        }
                        entries.clear();
                        let mut inside = 0.0;
                        // The pixel's widest footprint along o over the slabs it reaches,
                        // in cells.
                        let mut widest = 0;
                        for (m, &a_t) in tp.areas.iter().enumerate() {
                            if a_t == 0.0 {
                                continue;
                            }
                            let k = tp.first + m;
                            let Some(os) = po[t][k].as_ref() else {
                                continue;
                            };
                            let Some(op) = &os[io] else {
                                continue 'pixel;
                            };
                            widest = widest.max(add(k, op, a_t, &mut entries, &mut inside));
                        }
                        if !(inside > 0.0 && total - inside <= OUTSIDE_SHARE * total) {
                            continue;
                        }
                        // A row whose depth changes across its footprint along o by more
                        // than CUT_EPS: its o ray set is cut into m × m boxes in (ξ, w),
                        // each part with its own plane along t and its own o areas per
                        // slab (a box's rays meet any plane close together). The parts
                        // tile the o polygon, so the areas still add up to the whole.
                        let eps = go.abs() * widest as f64 * h / (2.0 * zp_mean);
                        if go != 0.0 && eps > CUT_EPS {
                            let m = ((eps / CUT_EPS).ceil() as usize).clamp(2, MAX_SIDE);
                            let alpha = chan.types[t].0;
                            let (co, tho) = (center(io as u32, 1 - axis), theta(io as u32));
                            let (ct, tht) = (center(it as u32, axis), theta(it as u32));
                            let poly = polygon(&chan, alpha, tho);
                            let (bx0, bx1, by0, by1) = crate::infra::polygon::bounds(&poly);
                            let split = |lo: f64, hi: f64, k: usize| {
                                if k == m {
                                    hi
                                } else {
                                    lo + (hi - lo) * k as f64 / m as f64
                                }
                            };
                            let (mut part, mut tmp) = (Vec::new(), Vec::new());
                            entries.clear();
                            inside = 0.0;
                            for (jx, jy) in (0..m).flat_map(|jx| (0..m).map(move |jy| (jx, jy))) {
                                part.clone_from(&poly);
                                crate::infra::polygon::clip_box(
                                    &mut part,
                                    &mut tmp,
                                    split(bx0, bx1, jx),
                                    split(bx0, bx1, jx + 1),
                                    split(by0, by1, jy),
                                    split(by0, by1, jy + 1),
                                );
                                let Some((wo, ao)) = mean_ray_of(&chan, co, &part) else {
                                    continue;
                                };
                                let Some(z) = hit(ray_t, (wo, ao)) else {
                                    continue 'pixel;
                                };
                                let Some((zp, gp)) = along_t(wo, ao) else {
                                    continue 'pixel;
                                };
                                let Some(tj) = tilted_profile(
                                    &chan,
                                    alpha,
                                    ct,
                                    tht,
                                    Tilt { z0: zp, g: gp },
                                    ns,
                                    edge_t,
                                ) else {
                                    continue 'pixel;
                                };
                                // The part's widest footprint along o over the slabs it
                                // reaches (at its own depth in each slab).
                                let mut width = 0.0f64;
                                for (n, &a_t) in tj.areas.iter().enumerate() {
                                    if a_t == 0.0 {
                                        continue;
                                    }
                                    let k = tj.first + n;
                                    let zk = zp + gp * (t0 + (k as f64 + 0.5) * hs);
                                    if let Some((lo, hi)) = footprint_of(&chan, co, &part, zk) {
                                        width = width.max(hi - lo);
                                    }
                                    let Some(op) = tilted_profile_of(
                                        &chan,
                                        co,
                                        &part,
                                        Tilt {
                                            z0: slab_z(k),
                                            g: go,
                                        },
                                        nco,
                                        |n| o0 + n as f64 * h,
                                    ) else {
                                        continue 'pixel;
                                    };
                                    add(k, &op, a_t, &mut entries, &mut inside);
                                }
                                // A part still too wide: the plane is too steep for this
                                // route.
                                if go.abs() * width / (2.0 * z) > TILT_EPS {
                                    steep.store(true, Ordering::Relaxed);
                                    return Ok(s);
                                }
                            }
                            if !(inside > 0.0 && total - inside <= OUTSIDE_SHARE * total) {
                                continue;
                            }
                        }
                        entries.sort_unstable_by_key(|e| e.0);
                        let mut last = u32::MAX;
                        for &(idx, v) in &entries {
                            if idx == last {
                                *s.data.last_mut().expect("an entry was pushed") += norm * v;
                            } else {
                                s.indices.push(idx);
                                s.data.push(norm * v);
                                last = idx;
                            }
                        }
                        s.end_row(i, b * cols + a);
                    }
                    row_done(&s, &bytes, done)?;
                    Ok(s)
                })
                .collect();
            parts.push(range.start, chunk?);
            Ok(())
        })?;
        if steep.load(Ordering::Relaxed) {
            done.store(done_before, Ordering::Relaxed);
            return Ok(None);
        }
        out.append_chunks(parts);
    }
    Ok(Some(out))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imaging::render::{render_into, RenderOptions};
    use crate::imaging::scene::{Scene, Surface};
    use crate::imaging::texture::{ImageTexture, Texture};

    fn seed_small() -> Design {
        let mut d = crate::model::presets::preset("seed").unwrap();
        for ch in d.channels.iter_mut() {
            ch.kx = 6;
            ch.ky = 5;
        }
        d
    }

    /// A tilted plane is checked over the grid, not over the design's whole view: one whose
    /// depth on the axis is nearer than F but deeper than F over the grid gives rows there;
    /// one nearer than F at a corner of the grid is refused, naming the plane.
    #[test]
    fn tilted_plane_is_checked_over_the_grid() {
        let mut d = seed_small();
        for ch in d.channels.iter_mut() {
            (ch.kx, ch.ky) = (3, 16);
        }
        let done = AtomicUsize::new(0);
        // Z = 40 + 100 Y: 560 to 640 mm over the grid, 40 mm (< F = 80 mm) on the axis.
        let surface = Surface::from_parts("plane", &[40.0, 0.0, 100.0], None).unwrap();
        let grid = CellGrid::covering([-0.5, 0.5, 5.2, 6.0], 0.05).unwrap();
        let sys = build_surface(&d, &[0, 1], &surface, &grid, None, None, &done).unwrap();
        assert!(!sys.channel.is_empty());
        assert!(sys.data.iter().all(|v| v.is_finite() && *v > 0.0));
        let near = CellGrid::covering([-0.5, 0.5, 0.3, 6.0], 0.05).unwrap();
        let err = build_surface(&d, &[0, 1], &surface, &near, None, None, &done).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("plane") && msg.contains("over the region"),
            "{msg}"
        );
    }

    /// A t equals the rendered raw of the image texture t on the grid, for every kept pixel
    /// (the pixels that see only the grid: their render does not use the mean beyond it).
    #[test]
    fn matrix_times_texture_is_the_render() {
        let d = seed_small();
        let z = 700.0;
        let grid = CellGrid::covering([-1.5, 2.0, -1.0, 1.2], 0.07).unwrap();
        let done = AtomicUsize::new(0);
        let sys = build(&d, &[0, 1], z, &grid, None, &done).unwrap();
        assert!(!sys.channel.is_empty());
        let n = grid.cells();
        let vals: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 / 100.0).collect();
        let [x0, x1, y0, y1] = grid.extent();
        let tex = ImageTexture::new(&vals, grid.ny, grid.nx, [x0, x1, y0, y1]).unwrap();
        let scene = Scene::new(
            Texture::Image(Box::new(tex)),
            Surface::from_parts("plane", &[z, 0.0, 0.0], None).unwrap(),
            0.5,
        )
        .unwrap();
        let mut raws: Vec<Vec<f64>> = d
            .channels
            .iter()
            .map(|ch| {
                let (r, c) = crate::imaging::render::raw_shape(ch);
                vec![0.0; r * c]
            })
            .collect();
        let outs: Vec<&mut [f64]> = raws.iter_mut().map(|v| v.as_mut_slice()).collect();
        render_into(&d, &scene, RenderOptions::default(), None, &done, outs).unwrap();
        let mut worst = 0.0f64;
        for r in 0..sys.channel.len() {
            let (lo, hi) = (sys.indptr[r] as usize, sys.indptr[r + 1] as usize);
            let v: f64 = (lo..hi)
                .map(|k| sys.data[k] * vals[sys.indices[k] as usize])
                .sum();
            let want = raws[sys.channel[r] as usize][sys.pixel[r] as usize];
            worst = worst.max((v - want).abs());
        }
        assert!(worst < 1e-12, "{worst}");
    }

    /// A plane tilted along one axis, either, or along both, on the tilted route against the
    /// general route (the footprint density integrated over the cells, crate::imaging::render::footprint):
    /// on the rows both keep, A t within 4e-4 of white for a random t (measured 4.1e-5 to
    /// 4.0e-4; the tilted route's own cut was measured within 3.5e-4 of the earlier general
    /// route), the row sums within 6e-4 of white (the tilted route's are exact; the general
    /// route's quadrature: 7.4e-6 to 4.7e-4 on these planes, the steepest, 87 degrees, the
    /// worst), and the rows kept the same but where a pixel's light touches the grid's edge.
    /// A plane too steep even for parts ((30, -30)) is left to the general route, its rows
    /// taken back from the progress.
    #[test]
    fn tilted_route_is_the_general_route() {
        let d = seed_small();
        let grid = CellGrid::covering([-1.3, 1.3, -1.1, 1.1], 0.06).unwrap();
        let done = AtomicUsize::new(0);
        let keeps = |_: usize| true;
        let steep = build_tilted(
            &d,
            &[0, 1],
            650.0,
            [30.0, -30.0],
            &grid,
            &keeps,
            None,
            &done,
        );
        assert!(steep.unwrap().is_none());
        assert_eq!(
            done.load(Ordering::Relaxed),
            0,
            "the refused plane's rows are taken back"
        );
        for g in [
            [0.0, -20.0],
            [-20.0, 0.0],
            [0.5, -20.0],
            [-20.0, 0.5],
            [0.6, 1.0],
            [1.0, -20.0],
            [-20.0, 1.0],
            [8.0, -20.0],
        ] {
            let plane = Surface::from_parts("plane", &[650.0, g[0], g[1]], None).unwrap();
            let tilted = build_tilted(&d, &[0, 1], 650.0, g, &grid, &keeps, None, &done)
                .unwrap()
                .unwrap();
            let general =
                build_general(&d, &[0, 1], &plane, &grid, None, &keeps, None, &done).unwrap();
            let vals: Vec<f64> = (0..grid.cells())
                .map(|i| ((i * 7919) % 101) as f64 / 100.0)
                .collect();
            let rows = |s: &System| -> std::collections::HashMap<(u32, u64), (f64, f64)> {
                (0..s.channel.len())
                    .map(|r| {
                        let (lo, hi) = (s.indptr[r] as usize, s.indptr[r + 1] as usize);
                        let at: f64 = (lo..hi)
                            .map(|k| s.data[k] * vals[s.indices[k] as usize])
                            .sum();
                        let sum: f64 = s.data[lo..hi].iter().sum();
                        ((s.channel[r], s.pixel[r]), (at, sum))
                    })
                    .collect()
            };
            let (rt, rg) = (rows(&tilted), rows(&general));
            let common: Vec<_> = rt.keys().filter(|k| rg.contains_key(k)).collect();
            assert!(common.len() > 300, "{g:?}: {}", common.len());
            assert!(
                common.len() as f64 >= 0.95 * rt.len().max(rg.len()) as f64,
                "{g:?}: {} {} {}",
                common.len(),
                rt.len(),
                rg.len()
            );
            let white = common.iter().map(|k| rg[k].1).fold(0.0, f64::max);
            let (mut worst, mut sums) = (0.0f64, 0.0f64);
            for k in common {
                worst = worst.max((rt[k].0 - rg[k].0).abs() / white);
                sums = sums.max((rt[k].1 - rg[k].1).abs() / white);
            }
            eprintln!(
                "{g:?}: A t within {worst:.2e} of white, sums {sums:.1e}, rows {} / {}",
                rt.len(),
                rg.len()
            );
            assert!(worst <= 4e-4, "{g:?}: {worst}");
            assert!(sums <= 6e-4, "{g:?}: {sums}");
        }
    }

    /// On a design with as many lenses per row as per column, the plane tilted about the
    /// Y axis is the plane tilted about the X axis with X and Y swapped: pixel (a, b) is
    /// pixel (b, a), and cell (row r, column c) of a square grid centred on the axis is
    /// cell (n - 1 - c, n - 1 - r). The two tilted routes agree to rounding, row by row.
    #[test]
    fn tilted_routes_are_mirror_images() {
        let mut d = seed_small();
        for ch in d.channels.iter_mut() {
            ch.ky = ch.kx;
        }
        let grid = CellGrid::covering([-1.4, 1.4, -1.4, 1.4], 0.07).unwrap();
        let n = grid.nx;
        assert_eq!(grid.ny, n);
        let done = AtomicUsize::new(0);
        let map = |g: [f64; 2]| {
            let plane = Surface::from_parts("plane", &[700.0, g[0], g[1]], None).unwrap();
            build_surface(&d, &[0, 1], &plane, &grid, None, None, &done).unwrap()
        };
        let (about_y, about_x) = (map([12.0, 0.0]), map([0.0, 12.0]));
        let rows = |s: &System| -> std::collections::HashMap<(u32, u64), Vec<(u32, f64)>> {
            (0..s.channel.len())
                .map(|r| {
                    let (lo, hi) = (s.indptr[r] as usize, s.indptr[r + 1] as usize);
                    let e = (lo..hi).map(|k| (s.indices[k], s.data[k])).collect();
                    ((s.channel[r], s.pixel[r]), e)
                })
                .collect()
        };
        let (ry, rx) = (rows(&about_y), rows(&about_x));
        assert_eq!(ry.len(), rx.len());
        assert!(ry.len() > 400, "{}", ry.len());
        let mut worst = 0.0f64;
        for ((ch, pixel), entries) in &ry {
            let cols = crate::imaging::render::raw_shape(&d.channels[*ch as usize]).1 as u64;
            let (a, b) = (pixel % cols, pixel / cols);
            let mut want: Vec<(u32, f64)> = rx[&(*ch, a * cols + b)]
                .iter()
                .map(|&(idx, v)| {
                    let (r, c) = (idx as usize / n, idx as usize % n);
                    (((n - 1 - c) * n + n - 1 - r) as u32, v)
                })
                .collect();
            want.sort_by_key(|e| e.0);
            assert_eq!(entries.len(), want.len());
            for (&(i, v), &(j, w)) in entries.iter().zip(&want) {
                assert_eq!(i, j);
                worst = worst.max((v - w).abs() / w.abs().max(1e-300));
            }
        }
        assert!(worst < 1e-12, "{worst}");
    }
}
