//! The merits' patch (module doc of [`super`]): the cells at the field's centre, padded by
//! a pixel's span, the map's rows over them by the reconstruction's routes, each row's
//! noise σ (photon noise on a flat scene at the ensemble's mean, floored as a
//! reconstruction floors it), and the products the draws need (A x, Aᵀ v).

use std::sync::atomic::AtomicUsize;

use crate::imaging::scene::Surface;
use crate::infra::error::{Error, Result};
use crate::inverse::solve::Block;
use crate::inverse::system::{self, CellGrid};

use super::Request;

/// The patch: the padded grid, the central cells (`inner`, at column `left` and row
/// `top` of the grid), the blocks of rows with their weights, each row slot's σ (0 for a
/// slot that is no row), the rows and the slots.
pub struct Patch {
    pub grid: CellGrid,
    pub inner: CellGrid,
    pub left: usize,
    pub top: usize,
    blocks: Vec<Block>,
    sigma: Vec<Vec<f64>>,
    pub rows: usize,
}

impl Patch {
    /// The patch of `req` (its checks made by the caller but for the design's).
    pub fn build(req: &Request<'_>, done: &AtomicUsize) -> Result<Patch> {
        let d = req.design;
        let z = req.depth;
        crate::model::optics::check_design_depths(d.f_main, &[z])?;
        for &c in &req.channels {
            if c >= d.channels.len() {
                return Err(Error::param(
                    "channels",
                    c + 1,
                    format!("channel numbers in 1..={}", d.channels.len()),
                ));
            }
        }
        if req.channels.is_empty() {
            return Err(Error::param("channels", "none", "at least one channel"));
        }
        let h = match req.step {
            Some(h) if h.is_finite() && h > 0.0 => h,
            Some(h) => return Err(Error::param("step", h, "a finite length > 0 (mm)")),
            None => d.resolution_step(z),
        };
        let half = 0.5 * req.patch as f64 * h;
        let inner = CellGrid::covering([-half, half, -half, half], h)?;
        let span = system::pixel_span(d, &req.channels, z)?;
        let pad = (req.settings.margin * span / h).ceil() as usize;
        let p = pad as f64 * h;
        let [x0, x1, y0, y1] = inner.extent();
        let grid = CellGrid::covering([x0 - p, x1 + p, y0 - p, y1 + p], h)?;
        let left = ((inner.x0 - grid.x0) / h).round() as usize;
        let top = ((grid.y1 - inner.y1) / h).round() as usize;
        if left + inner.nx > grid.nx || top + inner.ny > grid.ny {
            return Err(Error::param(
                "patch",
                req.patch,
                "a patch whose padded grid holds it",
            ));
        }
        let exact = system::exact(d, &req.channels).is_ok();
        let (blocks, sigma) = if exact {
            factored(req, z, &grid)?
        } else {
            general(req, z, &grid, done)?
        };
        let rows = sigma.iter().flatten().filter(|&&s| s > 0.0).count();
        if rows == 0 {
            return Err(Error::param(
                "depth",
                z,
                "a depth at which some pixel of the chosen channels and lens types sees the \
                 field's centre",
            ));
        }
        Ok(Patch {
            grid,
            inner,
            left,
            top,
            blocks,
            sigma,
            rows,
        })
    }

    /// The blocks (a copy, for the normal equations).
    pub fn blocks(&self) -> Vec<Block> {
        self.blocks.clone()
    }

    /// The row slots, over every block in order (the noise draws' length).
    pub fn slots(&self) -> usize {
        self.sigma.iter().map(Vec::len).sum()
    }

    /// Aᵀ W y over the grid and Σ w y² for the data y = A x + σ ξ from image `x` with
    /// noise σ ξ per row slot (`xi` over [`Patch::slots`]; None: noise-free).
    pub fn data(&self, x: &[f64], xi: Option<&[f64]>) -> (Vec<f64>, f64) {
        let nx = self.grid.nx;
        let mut out = vec![0.0; self.grid.cells()];
        let (mut at, mut yy) = (0, 0.0);
        for (b, sig) in self.blocks.iter().zip(&self.sigma) {
            let mut v = forward(b, x, nx);
            let w = weights(b);
            for (i, vi) in v.iter_mut().enumerate() {
                let noise = xi.map_or(0.0, |xi| xi.get(at + i).copied().unwrap_or(0.0));
                let y = *vi + sig[i] * noise;
                yy += w[i] * y * y;
                *vi = w[i] * y;
            }
            at += sig.len();
            back(b, &v, nx, &mut out);
        }
        (out, yy)
    }

    /// The mean squared difference of `a` and `b` (grid vectors) over the inner cells.
    pub fn inner_mse(&self, a: &[f64], b: &[f64]) -> f64 {
        let ca = self.crop(a);
        let cb = self.crop(b);
        ca.iter()
            .zip(&cb)
            .map(|(u, v)| (u - v) * (u - v))
            .sum::<f64>()
            / ca.len() as f64
    }

    /// A grid vector's inner cells (row-major from the top).
    pub fn crop(&self, v: &[f64]) -> Vec<f64> {
        let nx = self.grid.nx;
        let mut out = Vec::with_capacity(self.inner.cells());
        for j in self.top..self.top + self.inner.ny {
            let r = j * nx + self.left;
            out.extend_from_slice(&v[r..r + self.inner.nx]);
        }
        out
    }
}

fn weights(b: &Block) -> &[f64] {
    match b {
        Block::Factored { w, .. } | Block::Rows { w, .. } => w,
    }
}

/// A x per row slot of the block.
fn forward(b: &Block, x: &[f64], nx: usize) -> Vec<f64> {
    match b {
        Block::Factored { norm, px, py, .. } => {
            let nc = px.nrows();
            let mut out = vec![0.0; py.nrows() * nc];
            let mut t = vec![0.0; nx];
            for r in 0..py.nrows() {
                t.iter_mut().for_each(|v| *v = 0.0);
                let (gy, vy) = py.row(r);
                for (&j, &a) in gy.iter().zip(vy) {
                    let row = &x[j as usize * nx..(j as usize + 1) * nx];
                    t.iter_mut().zip(row).for_each(|(t, x)| *t += a * x);
                }
                for c in 0..nc {
                    let (gx, vx) = px.row(c);
                    let s: f64 = gx.iter().zip(vx).map(|(&i, &a)| a * t[i as usize]).sum();
                    out[r * nc + c] = norm * s;
                }
            }
            out
        }
        Block::Rows { a, .. } => (0..a.nrows())
            .map(|r| {
                let (ci, v) = a.row(r);
                ci.iter().zip(v).map(|(&i, &v)| v * x[i as usize]).sum()
            })
            .collect(),
    }
}

/// out += Aᵀ v, v per row slot of the block.
fn back(b: &Block, v: &[f64], nx: usize, out: &mut [f64]) {
    match b {
        Block::Factored { norm, px, py, .. } => {
            let nc = px.nrows();
            let mut t = vec![0.0; nx];
            for r in 0..py.nrows() {
                t.iter_mut().for_each(|v| *v = 0.0);
                for c in 0..nc {
                    let s = v[r * nc + c];
                    if s != 0.0 {
                        let (gx, vx) = px.row(c);
                        gx.iter()
                            .zip(vx)
                            .for_each(|(&i, &a)| t[i as usize] += a * s);
                    }
                }
                let (gy, vy) = py.row(r);
                for (&j, &a) in gy.iter().zip(vy) {
                    let row = &mut out[j as usize * nx..(j as usize + 1) * nx];
                    row.iter_mut().zip(&t).for_each(|(o, t)| *o += norm * a * t);
                }
            }
        }
        Block::Rows { a, .. } => {
            for (r, &s) in v.iter().enumerate() {
                let (ci, vals) = a.row(r);
                ci.iter()
                    .zip(vals)
                    .for_each(|(&i, &a)| out[i as usize] += a * s);
            }
        }
    }
}

/// A row's σ and weight 1/σ²: photon noise at value `v` (N photo-electrons for white),
/// never below the floor (a share of the channel's white).
fn noise(req: &Request<'_>, v: f64, white: f64) -> (f64, f64) {
    let floor = req.settings.noise_floor * white;
    let sigma = (v.max(0.0) / req.photons).sqrt().max(floor);
    (sigma, 1.0 / (sigma * sigma))
}

/// The lens types kept (from 0) checked against the channels' types; None for every type.
fn types(req: &Request<'_>) -> Result<Option<Vec<usize>>> {
    let Some(ts) = &req.lens_types else {
        return Ok(None);
    };
    let n = req
        .channels
        .iter()
        .map(|&c| req.design.channels[c].f.len())
        .max()
        .unwrap_or(1);
    if ts.is_empty() || ts.iter().any(|&t| t >= n) {
        return Err(Error::param(
            "lens_types",
            format!("{:?}", ts.iter().map(|t| t + 1).collect::<Vec<_>>()),
            format!("lens type numbers in 1..={n} (the chosen channels' lens types)"),
        ));
    }
    Ok(Some(ts.clone()))
}

type Blocks = (Vec<Block>, Vec<Vec<f64>>);

/// The exact route's blocks (a reconstruction's `factored`, with each pixel's value that
/// of the flat scene at the ensemble's mean): per channel and lens type, the pixels that
/// see only the grid.
fn factored(req: &Request<'_>, z: f64, grid: &CellGrid) -> Result<Blocks> {
    let d = req.design;
    let kept_types = types(req)?;
    let (mut blocks, mut sigmas) = (vec![], vec![]);
    for &c in &req.channels {
        let f = system::factors(d, c, z, grid)?;
        let white = d.channels[c].share;
        for (t, (px, py)) in f.x.iter().zip(&f.y).enumerate() {
            if kept_types.as_ref().is_some_and(|ts| !ts.contains(&t)) {
                continue;
            }
            let Some(sel) = f.select_type(t, grid, |_, _| true)? else {
                continue;
            };
            let n = sel.kept.len();
            let (mut w, mut sig) = (vec![0.0; n], vec![0.0; n]);
            for (i, &b) in sel.rows.iter().enumerate() {
                for (k, &a) in sel.cols.iter().enumerate() {
                    let j = i * sel.cols.len() + k;
                    if sel.kept[j] {
                        let v = req.ensemble.mean * f.norm * py.total[b] * px.total[a];
                        (sig[j], w[j]) = noise(req, v, white);
                    }
                }
            }
            blocks.push(Block::Factored {
                norm: f.norm,
                px: sel.px,
                py: sel.py,
                w,
                y: vec![0.0; n],
            });
            sigmas.push(sig);
        }
    }
    Ok((blocks, sigmas))
}

/// The general route's rows over the grid, each weighted by its value on the flat scene.
fn general(req: &Request<'_>, z: f64, grid: &CellGrid, done: &AtomicUsize) -> Result<Blocks> {
    let d = req.design;
    let kept_types = types(req)?;
    let surface = Surface::Plane {
        z0: z,
        g: [0.0, 0.0],
    };
    let sys = system::build_surface(
        d,
        &req.channels,
        &surface,
        grid,
        kept_types.as_deref(),
        req.n_threads,
        done,
    )?;
    if sys.channel.is_empty() {
        return Ok((vec![], vec![]));
    }
    let sums = sys.rows.row_sums();
    let (mut w, mut sig) = (
        Vec::with_capacity(sums.len()),
        Vec::with_capacity(sums.len()),
    );
    for (&c, &s) in sys.channel.iter().zip(&sums) {
        let (si, wi) = noise(req, req.ensemble.mean * s, d.channels[c as usize].share);
        sig.push(si);
        w.push(wi);
    }
    let n = w.len();
    Ok((
        vec![Block::Rows {
            a: sys.rows,
            w,
            y: vec![0.0; n],
        }],
        vec![sig],
    ))
}
