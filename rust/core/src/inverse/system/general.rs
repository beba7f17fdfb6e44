//! The general route (module doc of [`super`]): any surface (slanted plane, depth map) and
//! any design, the forward model's general route in record mode; a tilted plane on the
//! exact route's designs goes to the tilted route first.

use std::sync::atomic::AtomicUsize;

use super::tilted::build_tilted;
use super::{append_rows, channel, row_done, supported, CellGrid, Job, System};
use crate::imaging::recorder::Recorder;
use crate::imaging::render::{Chan, Work};
use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::Texture;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::checkpoint;
use crate::model::design::{Channel, Design, Grid, Layout};

/// Bytes of the per-worker buffers of [`build_surface`] (a grid-sized accumulator each).
fn recorder_bytes(grid: &CellGrid, workers: usize) -> u128 {
    (grid.cells() as u128) * 9 * workers as u128
}

/// The depths at which a ray can meet the surface over the grid: a plane's range over the
/// grid's extent, a depth map's whole range.
pub(super) fn depth_range(surface: &Surface, grid: &CellGrid) -> (f64, f64) {
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
    if let Surface::Map(m) = surface {
        // A map that is a plane over the grid (an estimate's surface fitted into one,
        // docs/depth.md) is that plane: its rows are the plane's, on the plane's routes
        // (the tilted route's per-axis cuts, not the footprint lattice). Rays that land
        // beyond the grid drop their row on either, so the map's extent past the grid
        // changes nothing.
        if let Some((z0, g, [x0, x1, y0, y1])) = m.as_plane() {
            let [gx0, gx1, gy0, gy1] = grid.extent();
            if x0 <= gx0 && gx1 <= x1 && y0 <= gy0 && gy1 <= y1 {
                let plane = Surface::Plane { z0, g };
                crate::imaging::render::check_surface(design, surface)?;
                return build_surface(design, channels, &plane, grid, types, n_threads, done);
            }
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
    let job = Job {
        design,
        channels,
        grid,
        n_threads,
        done,
    };
    if let Surface::Plane { z0, g } = surface {
        let exact = channels
            .iter()
            .all(|&i| supported(design, &design.channels[i]).is_ok());
        // A tilted plane: the tilted route (None comes before any row is counted: the
        // general route starts afresh).
        if exact && g != &[0.0, 0.0] {
            if let Some(s) = build_tilted(&job, *z0, *g, &keeps)? {
                return Ok(s);
            }
        }
    }
    build_general(&job, surface, types, &keeps)
}

/// The map on the forward model's general route in record mode (any surface, any design).
/// Only the pixels under lenses of `types` (None: every type) are rows: those whose type
/// `keeps`.
pub(super) fn build_general(
    job: &Job,
    surface: &Surface,
    types: Option<&[usize]>,
    keeps: &(dyn Fn(usize) -> bool + Sync),
) -> Result<System> {
    let Job {
        design,
        channels,
        grid,
        n_threads,
        done,
    } = *job;
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
    let mut out = System::new(grid.cells());
    for &i in channels {
        let ch = &design.channels[i];
        let chan = Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL);
        let (rows, cols) = crate::imaging::render::raw_shape(ch);
        let px = crate::imaging::render::Pixels {
            design,
            chan: &chan,
            scene: &scene,
            tol: 1.0,
            weighting: None,
            sat: None,
        };
        let map_once = crate::imaging::render::map_seen_once(&chan, surface);
        let sees = lenses_seeing(design, ch, surface, grid);
        let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 4000);
        let bytes = std::sync::atomic::AtomicU64::new((out.rows.data.len() * 12) as u64);
        append_rows(
            &mut out,
            (n_threads, rows, step),
            || Recorder::new(*grid).map(|r| Work::recording(Box::new(r), map_once)),
            |wk, b| {
                let wk = wk.as_mut().map_err(|e| e.clone())?;
                let mut s = System::new(grid.cells());
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
        )?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::seed_small;
    use super::*;
    use std::sync::atomic::Ordering;

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
        assert!(sys.rows.data.iter().all(|v| v.is_finite() && *v > 0.0));
        let near = CellGrid::covering([-0.5, 0.5, 0.3, 6.0], 0.05).unwrap();
        let err = build_surface(&d, &[0, 1], &surface, &near, None, None, &done).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("plane") && msg.contains("over the region"),
            "{msg}"
        );
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
        let job = Job {
            design: &d,
            channels: &[0, 1],
            grid: &grid,
            n_threads: None,
            done: &done,
        };
        let steep = build_tilted(&job, 650.0, [30.0, -30.0], &keeps);
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
            let tilted = build_tilted(&job, 650.0, g, &keeps).unwrap().unwrap();
            let general = build_general(&job, &plane, None, &keeps).unwrap();
            let vals: Vec<f64> = (0..grid.cells())
                .map(|i| ((i * 7919) % 101) as f64 / 100.0)
                .collect();
            let rows = |s: &System| -> std::collections::HashMap<(u32, u64), (f64, f64)> {
                (0..s.channel.len())
                    .map(|r| {
                        let (cells, entries) = s.rows.row(r);
                        let at: f64 = cells
                            .iter()
                            .zip(entries)
                            .map(|(&k, &e)| e * vals[k as usize])
                            .sum();
                        let sum: f64 = entries.iter().sum();
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
                    let (cells, entries) = s.rows.row(r);
                    let e = cells.iter().copied().zip(entries.iter().copied()).collect();
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
