//! The window pooled along the surface's local slope (docs/depth.md, step 7): a second
//! pass over the cells' own costs, kept per candidate during the sweep.
//!
//! A fronto-parallel window over a sloping surface pools cells whose cost curves have
//! their minima at different candidates; the pooled curve's minimum is then a weighted
//! mean of theirs, the weights the cells' texture, and wherever the texture is not
//! symmetric about the window's centre the estimate is pulled towards the better
//! textured side. Here each cell's coarse estimate (the fronto-parallel window's) gives
//! the local slope of the candidate index, fitted over the window (least squares over
//! its confident cells, weighted by their confidence), and the window's cost is pooled again with each
//! cell d of the window taken at candidate j + g · d (g the slope in candidates per cell,
//! the cell's costs interpolated linearly between candidates),
//!
//!   C_t(j) = Σ_d S_d(j + g · d) / Σ_d W_d(j + g · d),
//!
//! S_d the cell's spread over the channel's scale and W_d its degrees of freedom (the
//! fronto-parallel cost is g = 0). C_t is evaluated at [`REACH`] candidates either side
//! of the coarse one; its least value, refined by the V through its neighbours, is the
//! estimate. The cell's confidence stays the fronto-parallel curve's.

use rayon::prelude::*;

use super::{depth_at, vertex, Sweep, MIN_WEIGHT};
use crate::imaging::recorder::CellGrid;
use crate::infra::error::Result;
use crate::infra::parallel::{chunk_items, for_chunks};

/// Candidates evaluated either side of the coarse estimate.
pub(super) const REACH: usize = 3;
/// The least confidence of a cell whose coarse estimate takes part in the slope's fit
/// (the default `min_confidence`: with every cell weighted by its confidence, the
/// unconfident cells' wrong estimates tilted the windows of a fronto-parallel plane, and
/// the 90th percentile of the confident cells' error rose from 0.8 % to 8.6 %).
const MIN_SLOPE_CONFIDENCE: f64 = 0.5;
/// The largest slope fitted, in candidates per cell (steeper fits are clamped: the window
/// would reach beyond the candidates evaluated).
const MAX_SLOPE: f64 = 1.0;

/// The cells' own costs: per candidate, per chosen channel, per widened cell (the grid
/// widened by the window's radius on every side) the pair (spread over the scale,
/// degrees of freedom).
pub(super) struct CellCosts<'a> {
    pub(super) values: &'a [f32],
    pub(super) channels: usize,
    pub(super) n: usize,
}

impl CellCosts<'_> {
    /// The pair of widened cell `w` of channel `ch` at fractional candidate `t` (clamped
    /// to the candidates), interpolated linearly.
    #[inline(always)]
    fn at(&self, ch: usize, w: usize, per: usize, t: f64) -> (f64, f64) {
        let t = t.clamp(0.0, (self.n - 1) as f64);
        let k0 = (t.floor() as usize).min(self.n - 2);
        let f = t - k0 as f64;
        let idx = |k: usize| 2 * ((k * self.channels + ch) * per + w);
        let (a, b) = (idx(k0), idx(k0 + 1));
        let v = self.values;
        let s = (1.0 - f) * v[a] as f64 + f * v[b] as f64;
        let d = (1.0 - f) * v[a + 1] as f64 + f * v[b + 1] as f64;
        (s, d)
    }
}

/// The slope (candidates per cell, along X and down the rows) of the coarse index over
/// the window of cell (x, y): a plane fitted by weighted least squares to the cells of
/// confidence at least [`MIN_SLOPE_CONFIDENCE`] (weights: their confidences); (0, 0)
/// where the fit is degenerate.
fn slope(sweep: &Sweep, grid: &CellGrid, r: usize, x: usize, y: usize) -> (f64, f64) {
    let (nx, ny) = (grid.nx, grid.ny);
    let r = r as isize;
    // Sums of w, w dx, w dy, w dx², w dy², w dx dy, w i, w dx i, w dy i.
    let mut s = [0.0f64; 9];
    for dy in -r..=r {
        let yy = y as isize + dy;
        if yy < 0 || yy >= ny as isize {
            continue;
        }
        for dx in -r..=r {
            let xx = x as isize + dx;
            if xx < 0 || xx >= nx as isize {
                continue;
            }
            let c = yy as usize * nx + xx as usize;
            let (i, w) = (sweep.index[c], sweep.confidence[c]);
            if !(i.is_finite() && w >= MIN_SLOPE_CONFIDENCE) {
                continue;
            }
            let (fx, fy) = (dx as f64, dy as f64);
            let t = [1.0, fx, fy, fx * fx, fy * fy, fx * fy, i, fx * i, fy * i];
            for (a, b) in s.iter_mut().zip(t) {
                *a += w * b;
            }
        }
    }
    // Centred normal equations for (gx, gy).
    if s[0] <= 0.0 {
        return (0.0, 0.0);
    }
    let (mx, my, mi) = (s[1] / s[0], s[2] / s[0], s[6] / s[0]);
    let sxx = s[3] - s[0] * mx * mx;
    let syy = s[4] - s[0] * my * my;
    let sxy = s[5] - s[0] * mx * my;
    let sxi = s[7] - s[0] * mx * mi;
    let syi = s[8] - s[0] * my * mi;
    let det = sxx * syy - sxy * sxy;
    if det.is_nan() || det <= 1e-9 * (sxx * syy).max(1e-300) {
        return (0.0, 0.0);
    }
    let gx = (syy * sxi - sxy * syi) / det;
    let gy = (sxx * syi - sxy * sxi) / det;
    (
        gx.clamp(-MAX_SLOPE, MAX_SLOPE),
        gy.clamp(-MAX_SLOPE, MAX_SLOPE),
    )
}

/// The tilted window's cost of cell (x, y) of channel ch at candidate j, slope g; NaN
/// where its window holds under [`MIN_WEIGHT`] degrees of freedom.
fn tilted(
    costs: &CellCosts,
    grid: &CellGrid,
    r: usize,
    (x, y, ch): (usize, usize, usize),
    j: f64,
    (gx, gy): (f64, f64),
) -> f64 {
    let enx = grid.nx + 2 * r;
    let per = enx * (grid.ny + 2 * r);
    let (mut s, mut w) = (0.0, 0.0);
    for dy in 0..=2 * r {
        let row = (y + dy) * enx + x;
        let ty = j + gy * (dy as f64 - r as f64);
        for dx in 0..=2 * r {
            let (a, b) = costs.at(ch, row + dx, per, ty + gx * (dx as f64 - r as f64));
            s += a;
            w += b;
        }
    }
    if w >= MIN_WEIGHT {
        s.max(0.0) / w
    } else {
        f64::NAN
    }
}

/// Re-estimate every cell with its window pooled along the local slope (the module's
/// doc), in parallel on `n_threads` (Ctrl-C between chunks of cells): `sweep`'s depth
/// and index are replaced where the tilted curve has an interior minimum within
/// [`REACH`] candidates of the coarse one.
pub(super) fn refine(
    sweep: &mut Sweep,
    costs: &CellCosts,
    grid: &CellGrid,
    r: usize,
    cand: &[f64],
    n_threads: Option<usize>,
) -> Result<()> {
    let cells = grid.cells();
    let d = 2 * r + 1;
    let chunk = chunk_items(
        n_threads,
        ((2 * REACH + 1) * d * d * 4 + d * d * 10) as u128,
    );
    let mut found: Vec<Option<f64>> = Vec::with_capacity(cells);
    let coarse: &Sweep = sweep;
    for_chunks(n_threads, cells, chunk, |range| {
        let part: Vec<Option<f64>> = range
            .into_par_iter()
            .map(|cell| refine_cell(coarse, costs, grid, r, cand, cell))
            .collect();
        found.extend(part);
        Ok(())
    })?;
    let n = cand.len();
    for (cell, f) in found.into_iter().enumerate() {
        if let Some(kf) = f {
            sweep.index[cell] = kf;
            sweep.depth[cell] = depth_at(cand, kf, n);
        }
    }
    Ok(())
}

/// One cell's fractional candidate index from its tilted window (None: keep the coarse
/// one).
fn refine_cell(
    sweep: &Sweep,
    costs: &CellCosts,
    grid: &CellGrid,
    r: usize,
    cand: &[f64],
    cell: usize,
) -> Option<f64> {
    let kf = sweep.index[cell];
    if !kf.is_finite() {
        return None;
    }
    let n = cand.len();
    let (x, y) = (cell % grid.nx, cell / grid.nx);
    let g = slope(sweep, grid, r, x, y);
    let ch = sweep.channel[cell] as usize;
    let k0 = kf.round() as usize;
    let lo = k0.saturating_sub(REACH);
    let hi = (k0 + REACH).min(n - 1);
    let mut curve = [f64::NAN; 2 * REACH + 1];
    for j in lo..=hi {
        curve[j - lo] = tilted(costs, grid, r, (x, y, ch), j as f64, g);
    }
    let len = hi - lo + 1;
    let (b, &m) = curve[..len]
        .iter()
        .enumerate()
        .filter(|e| e.1.is_finite())
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    if b == 0 || b + 1 == len {
        return None;
    }
    let (l, rr) = (curve[b - 1], curve[b + 1]);
    let off = if l.is_finite() && rr.is_finite() {
        vertex(l, m, rr)
    } else {
        0.0
    };
    Some((lo + b) as f64 + off)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sloping surface: cell (x, y) of the grid (and of the widened grid, shifted by r)
    /// has its cost's minimum at candidate 10 + 0.4 x − 0.3 y, its cost a V of slope
    /// 1 + 3 x / nx (texture stronger to the right) over 1 degree of freedom.
    #[test]
    fn tilted_window_removes_the_slopes_bias() {
        let (nx, ny, r, n) = (9usize, 7usize, 3usize, 24usize);
        let grid = CellGrid {
            x0: 0.0,
            y1: 0.0,
            step: 1.0,
            nx,
            ny,
        };
        let truth = |x: f64, y: f64| 10.0 + 0.4 * x - 0.3 * y;
        let (enx, eny) = (nx + 2 * r, ny + 2 * r);
        let mut values = vec![0.0f32; n * enx * eny * 2];
        for k in 0..n {
            for wy in 0..eny {
                for wx in 0..enx {
                    let (x, y) = (wx as f64 - r as f64, wy as f64 - r as f64);
                    let w = 1.0 + 3.0 * x.max(0.0) / nx as f64;
                    let i = 2 * ((k * enx * eny) + wy * enx + wx);
                    values[i] = (w * (k as f64 - truth(x, y)).abs()) as f32;
                    values[i + 1] = 1.0;
                }
            }
        }
        let costs = CellCosts {
            values: &values,
            channels: 1,
            n,
        };
        let cells = nx * ny;
        let idx: Vec<f64> = (0..cells)
            .map(|c| truth((c % nx) as f64, (c / nx) as f64))
            .collect();
        let cand: Vec<f64> = (0..n)
            .map(|k| 1.0 / (1.0 / 200.0 - k as f64 * 1e-4))
            .collect();
        let sweep = Sweep {
            depth: vec![f64::NAN; cells],
            index: idx.clone(),
            confidence: vec![1.0; cells],
            min_cost: vec![0.0; cells],
            mean_cost: vec![1.0; cells],
            channel: vec![0; cells],
            samples: 0,
            volume: None,
        };
        // The fitted slope is the surface's.
        let (gx, gy) = slope(&sweep, &grid, r, 4, 3);
        assert!(
            (gx - 0.4).abs() < 1e-9 && (gy + 0.3).abs() < 1e-9,
            "{gx} {gy}"
        );
        let c = 3 * nx + 4;
        let got = refine_cell(&sweep, &costs, &grid, r, &cand, c).unwrap();
        assert!((got - idx[c]).abs() < 0.05, "{got} against {}", idx[c]);
        // The fronto-parallel window (slope 0) on the same costs is off by more.
        let flat: Vec<f64> = (8..13)
            .map(|j| tilted(&costs, &grid, r, (4, 3, 0), j as f64, (0.0, 0.0)))
            .collect();
        let b = (0..5).min_by(|&a, &b| flat[a].total_cmp(&flat[b])).unwrap();
        let off = if b > 0 && b < 4 {
            vertex(flat[b - 1], flat[b], flat[b + 1])
        } else {
            0.0
        };
        assert!((8.0 + b as f64 + off - idx[c]).abs() > 0.1, "{b} {off}");
    }
}
