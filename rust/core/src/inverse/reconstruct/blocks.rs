//! A reconstruction's equations as blocks (module doc of [`super`]): the exact route's
//! factored blocks (per channel and lens type, the pixels that see only the grid), the
//! explicit rows of the tilted and general routes, each row weighted from the raw's noise;
//! and the prior weight's meaningful range over those blocks.

use std::sync::atomic::AtomicUsize;

use super::{Noise, Plan, MAX_PRIOR_SHARE};
use crate::imaging::render::raw_shape;
use crate::infra::error::{Error, Result};
use crate::inverse::solve::{Block, Csr};
use crate::inverse::system::{self, CellGrid};

impl Plan<'_> {
    /// A row's weight 1/σ²: σ the raw's noise at value y (Poisson(N v)/N plus read noise
    /// r/N, render's model), never below the floor (a share of the channel's white).
    pub(super) fn weight(&self, y: f64, white: f64) -> f64 {
        let floor = self.req.settings.noise_floor * white;
        let [n, r] = match self.noise {
            Noise::Free => return 1.0 / (floor * floor),
            Noise::Photons(p) => p,
            // Not known yet: its shape (photon noise) with N = 1, scaled once estimated.
            Noise::Unknown => [1.0, 0.0],
        };
        let sigma = ((y.max(0.0) / n + (r / n) * (r / n)).sqrt()).max(floor);
        1.0 / (sigma * sigma)
    }

    /// The exact route's blocks: per channel and lens type kept, the pixels that see only
    /// the grid, as the factors restricted to the raw rows and columns holding them.
    pub(super) fn factored(&self, z: f64, grid: &CellGrid) -> Result<Vec<Block>> {
        let d = self.req.design;
        let mut blocks = vec![];
        for &c in &self.req.channels {
            let f = system::factors(d, c, z, grid)?;
            let img = self.req.images[c];
            let white = d.channels[c].share;
            for t in 0..f.x.len() {
                if self.types.as_ref().is_some_and(|ts| !ts.contains(&t)) {
                    continue;
                }
                let colour =
                    |b: usize, a: usize| self.req.colour.map_or(true, |(p, k)| p.colour(b, a) == k);
                let Some(sel) = f.select_type(t, grid, colour)? else {
                    continue;
                };
                let n = sel.kept.len();
                let (mut w, mut y) = (vec![0.0; n], vec![0.0; n]);
                for (i, &b) in sel.rows.iter().enumerate() {
                    for (k, &a) in sel.cols.iter().enumerate() {
                        let j = i * sel.cols.len() + k;
                        if sel.kept[j] {
                            let v = img[b * f.cols + a];
                            y[j] = v;
                            w[j] = self.weight(v, white);
                        }
                    }
                }
                blocks.push(Block::Factored {
                    norm: f.norm,
                    px: sel.px,
                    py: sel.py,
                    w,
                    y,
                });
            }
        }
        Ok(blocks)
    }

    /// The explicit rows of the tilted or general route, weighted.
    pub(super) fn explicit(&self, grid: &CellGrid, done: &AtomicUsize) -> Result<Vec<Block>> {
        let d = self.req.design;
        let sys = system::build_surface(
            d,
            &self.req.channels,
            &self.surface,
            grid,
            self.types.as_deref(),
            self.req.n_threads,
            done,
        )?;
        if sys.channel.is_empty() {
            return Ok(vec![]);
        }
        // The rows kept: every pixel's, or a CFA colour's only (docs/model.md §12).
        let cols: Vec<_> = d.channels.iter().map(|ch| raw_shape(ch).1).collect();
        let keep: Vec<bool> = sys
            .channel
            .iter()
            .zip(&sys.pixel)
            .map(|(&c, &p)| {
                self.req.colour.map_or(true, |(pattern, k)| {
                    let cols = cols[c as usize];
                    pattern.colour(p as usize / cols, p as usize % cols) == k
                })
            })
            .collect();
        let n = keep.iter().filter(|&&k| k).count();
        if n == 0 {
            return Ok(vec![]);
        }
        let (mut w, mut y) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for ((&c, &p), _) in sys
            .channel
            .iter()
            .zip(&sys.pixel)
            .zip(&keep)
            .filter(|t| *t.1)
        {
            let v = self.req.images[c as usize][p as usize];
            y.push(v);
            w.push(self.weight(v, d.channels[c as usize].share));
        }
        let r = sys.rows;
        let (indptr, indices, data) = if n == keep.len() {
            (r.indptr, r.indices, r.data)
        } else {
            let (mut ptr, mut idx, mut val) = (vec![0], vec![], vec![]);
            for (i, _) in keep.iter().enumerate().filter(|t| *t.1) {
                let (lo, hi) = (r.indptr[i], r.indptr[i + 1]);
                idx.extend_from_slice(&r.indices[lo..hi]);
                val.extend_from_slice(&r.data[lo..hi]);
                ptr.push(val.len());
            }
            (ptr, idx, val)
        };
        let a = Csr::new("rows", indptr, indices, data, grid.cells())?;
        Ok(vec![Block::Rows { a, w, y }])
    }
}

/// Refuse a prior weight whose solve is not meaningful (see [`MAX_PRIOR_SHARE`]).
pub(super) fn check_regularization(lam: f64, blocks: &[Block], cells: usize) -> Result<()> {
    let most = max_regularization(blocks, cells);
    if lam > most {
        return Err(Error::param(
            "regularization",
            lam,
            format!(
                "a finite value in (0, {most:.3e}] for this raw and grid ({MAX_PRIOR_SHARE:.0e} \
                 times the data's mean weight per cell: beyond it the prior drowns the data \
                 and the solve loses its precision)"
            ),
        ));
    }
    Ok(())
}

/// The largest λ a solve over `blocks` on `cells` cells takes: [`MAX_PRIOR_SHARE`] times
/// the data's mean weight per cell.
pub(super) fn max_regularization(blocks: &[Block], cells: usize) -> f64 {
    let sq = |c: &Csr, r: usize| {
        c.data[c.indptr[r]..c.indptr[r + 1]]
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
    };
    let trace: f64 = blocks
        .iter()
        .map(|b| match b {
            Block::Factored {
                norm, px, py, w, ..
            } => {
                let nc = px.nrows();
                (0..py.nrows())
                    .map(|b| {
                        let yb = sq(py, b);
                        (0..nc).map(|a| w[b * nc + a] * sq(px, a)).sum::<f64>() * yb
                    })
                    .sum::<f64>()
                    * norm
                    * norm
            }
            Block::Rows { a, w, .. } => (0..a.nrows()).map(|r| w[r] * sq(a, r)).sum(),
        })
        .sum();
    MAX_PRIOR_SHARE * trace / cells.max(1) as f64
}

pub(super) fn block_rows(b: &Block) -> usize {
    match b {
        Block::Factored { w, .. } => w.iter().filter(|&&v| v != 0.0).count(),
        Block::Rows { a, .. } => a.nrows(),
    }
}
