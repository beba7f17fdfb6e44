//! The exact route (module doc of [`super`]): a fronto-parallel plane, a rect grid, a square
//! aperture and the ideal layout. Each channel's map is per lens type the product of an x
//! and a y profile per raw column and row ([`factors`]), or built out as explicit rows
//! ([`build`]).

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::{append_rows, channel, supported, unsupported, CellGrid, System, OUTSIDE_SHARE};
use crate::imaging::render::exact::{pixel_offset, profile, Profile};
use crate::imaging::render::Chan;
use crate::infra::csr::Csr;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::checkpoint;
use crate::model::design::{Design, Layout};

/// One axis's profiles of one lens type against a grid's cell edges: `rows`, row = raw
/// column (x) or raw row (y), column = grid column (x) or grid row from the top (y), entry
/// = the area of the pixel's 1-D ray polygon between the cell's edges; with each row's
/// total area (inside the grid or not).
#[derive(Debug, Clone)]
pub struct AxisProfiles {
    pub rows: Csr,
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

/// One lens type's pixels of a channel that see only the grid ([`Factors::select_type`]):
/// the raw rows `rows` and columns `cols` holding them, the factors restricted to those
/// (`py` rows per raw row, `px` per raw column), and `kept[i · cols.len() + k]` whether
/// pixel (rows[i], cols[k]) is one of them.
#[derive(Debug, Clone)]
pub struct TypeSelection {
    pub rows: Vec<usize>,
    pub cols: Vec<usize>,
    pub px: Csr,
    pub py: Csr,
    pub kept: Vec<bool>,
}

impl Factors {
    /// The pixels of lens type `t` whose ray sets are lit and inside the grid (no more than
    /// [`OUTSIDE_SHARE`] of their rays off it) and that pass `also(row, col)`; None when
    /// there are none. `grid` is the grid the factors were computed on.
    pub fn select_type(
        &self,
        t: usize,
        grid: &CellGrid,
        also: impl Fn(usize, usize) -> bool,
    ) -> Result<Option<TypeSelection>> {
        let (px, py) = (&self.x[t], &self.y[t]);
        let (sx, sy) = (px.rows.row_sums(), py.rows.row_sums());
        let rows_in: Vec<usize> = (0..self.rows)
            .filter(|&b| py.total[b] > 0.0 && sy[b] > 0.0)
            .collect();
        let cols_in: Vec<usize> = (0..self.cols)
            .filter(|&a| px.total[a] > 0.0 && sx[a] > 0.0)
            .collect();
        let kept = |b: usize, a: usize| {
            let total = py.total[b] * px.total[a];
            self.types[b * self.cols + a] as usize == t
                && total - sy[b] * sx[a] <= OUTSIDE_SHARE * total
                && also(b, a)
        };
        let rows: Vec<usize> = rows_in
            .iter()
            .copied()
            .filter(|&b| cols_in.iter().any(|&a| kept(b, a)))
            .collect();
        if rows.is_empty() {
            return Ok(None);
        }
        let cols: Vec<usize> = cols_in
            .iter()
            .copied()
            .filter(|&a| rows_in.iter().any(|&b| kept(b, a)))
            .collect();
        let mask = rows
            .iter()
            .flat_map(|&b| cols.iter().map(move |&a| (b, a)))
            .map(|(b, a)| kept(b, a))
            .collect();
        Ok(Some(TypeSelection {
            px: select(&px.rows, &cols, grid.nx)?,
            py: select(&py.rows, &rows, grid.ny)?,
            rows,
            cols,
            kept: mask,
        }))
    }
}

/// The rows `sel` of `p` as a checked CSR matrix over `ncols` columns.
fn select(p: &Csr, sel: &[usize], ncols: usize) -> Result<Csr> {
    let mut indptr = Vec::with_capacity(sel.len() + 1);
    indptr.push(0);
    let (mut indices, mut data) = (vec![], vec![]);
    for &r in sel {
        let (cells, entries) = p.row(r);
        indices.extend_from_slice(cells);
        data.extend_from_slice(entries);
        indptr.push(data.len());
    }
    Csr::new("factors", indptr, indices, data, ncols)
}

/// The profiles `p` against `cells` cells, numbered from the far end when `flip`.
fn axis_csr(p: &[Profile], cells: usize, flip: bool) -> AxisProfiles {
    let mut out = AxisProfiles {
        rows: Csr::empty(cells),
        total: Vec::with_capacity(p.len()),
    };
    for pr in p {
        let mut row: Vec<(u32, f64)> = pr
            .areas
            .iter()
            .enumerate()
            .filter(|(_, &v)| v != 0.0)
            .map(|(m, &v)| {
                let k = pr.first + m;
                (if flip { cells - 1 - k } else { k } as u32, v)
            })
            .collect();
        row.sort_by_key(|e| e.0);
        for (k, v) in row {
            out.rows.indices.push(k);
            out.rows.data.push(v);
        }
        out.rows.end_row();
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
        x: pr.px.iter().map(|p| axis_csr(p, grid.nx, false)).collect(),
        y: pr.py.iter().map(|p| axis_csr(p, grid.ny, true)).collect(),
        types,
        rows,
        cols,
    })
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
    let mut out = System::new(grid.cells());
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
        let have = (out.channel.len() as u128, out.rows.data.len() as u128);
        memory::check(
            "the reconstruction's system matrix",
            super::system_bytes(have.0 + n_rows, have.1 + nnz),
        )?;
        // Rows in parallel chunks, each chunk's entries in its own buffers, then appended.
        let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 64);
        let norm = chan.norm;
        let nx = grid.nx;
        append_rows(
            &mut out,
            (n_threads, rows, step),
            || (),
            |_, b| {
                checkpoint()?;
                let mut s = System::new(grid.cells());
                s.rows.indptr.reserve(counts[b].0);
                s.rows.data.reserve(counts[b].1);
                s.rows.indices.reserve(counts[b].1);
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
                                s.rows.indices.push((row * nx + xp.first + n) as u32);
                                s.rows.data.push(norm * ax * ay);
                            }
                        }
                    }
                    s.end_row(i, b * cols + a);
                }
                done.fetch_add(1, Ordering::Relaxed);
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
    use crate::imaging::render::{render_into, RenderOptions};
    use crate::imaging::scene::{Scene, Surface};
    use crate::imaging::texture::{ImageTexture, Texture};

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
            let (cells, entries) = sys.rows.row(r);
            let v: f64 = cells
                .iter()
                .zip(entries)
                .map(|(&k, &e)| e * vals[k as usize])
                .sum();
            let want = raws[sys.channel[r] as usize][sys.pixel[r] as usize];
            worst = worst.max((v - want).abs());
        }
        assert!(worst < 1e-12, "{worst}");
    }
}
