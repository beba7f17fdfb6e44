//! Depth from the raw (docs/model.md §11, docs/depth.md): a plane sweep over candidate
//! depths.
//!
//! Each pixel's value divided by its white (its value under a white albedo: vignetting and
//! the channel's share removed) is a sample of the albedo near the point where the pixel's
//! mean ray meets the surface. Under a square aperture on a rect lattice that is the
//! centroid ray of its 4-D ray set (the product of its x and y polygons, §4: the
//! `centroid` sample of `rayspace`); elsewhere (hexagonal lattices, circular apertures)
//! the chief ray, X(z) = B(z) w − (z/L) c, B(z) = 1 − z/F + z/L (c: the lens centre, w:
//! the chief ray's main-lens height). Either is affine in z, X(z) = p + z q, so two depths
//! fix it for all.
//!
//! For each candidate z every sample is splatted bilinearly onto a grid of cells (weight
//! b = a ω, a the bilinear weight, ω the pixel's white relative to a fully lit pixel: its
//! photon-noise weight). At the true depth the samples one cell gathers — from several
//! lenses and channels — saw the same patch and agree; at a wrong depth they saw
//! different patches. The cost of a cell at z is the pooled within-cell variance over a
//! (2r + 1)² window of cells, each channel's samples pooled apart (the channels' blurs
//! differ, so their samples of one patch need not agree: they are never compared),
//!
//!   C(z) = Σ_window Σ_ch Σ_i b_i (v_i − v̄)² / Σ_window Σ_ch (B − Σ_i b_i² / B),
//!
//! (per cell and channel: B = Σ_i b_i, v̄ the weighted mean): the denominator is the cells'
//! degrees of freedom, so that samples of one variance cost that variance however sparse
//! they are (a lone sample in a cell tells nothing). The cost is missing where the window
//! holds less than [`MIN_WEIGHT`] degrees of freedom.
//!
//! The estimate per cell is the candidate of least cost, refined by the vertex of the
//! symmetric V through it and its two neighbours ([`vertex`]), and its confidence the
//! contrast 1 − min / m', m' the least of the curve's mean and of its least local minimum
//! more than n/16 candidates away (a second dip of the same depth makes a cell ambiguous).
//! A textureless patch costs the same (its noise) at every depth: its contrast is small.
//!
//! The candidates are swept in parallel, each layer of costs folded in candidate order
//! into running minima, so the cost volume is never held whole (unless asked for).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;

use crate::cells::CellGrid;
use crate::design::{Aperture, Design, Grid};
use crate::error::{Error, Result};
use crate::line::{Axis, Line};
use crate::memory;
use crate::parallel::{checkpoint, for_chunks, threads};
use crate::rayspace::{axis_samples, Sample};

/// Least degrees of freedom (in fully lit pixels) a window must hold for its cost to
/// count.
pub const MIN_WEIGHT: f64 = 2.0;
/// Pixels whose white is below this fraction of a fully lit pixel's are left out (their
/// values are mostly noise).
pub const MIN_WHITE: f64 = 0.05;
/// Local minima kept per cell (for the confidence's rival minimum).
const KEEP_MINIMA: usize = 4;
/// A rival minimum lies more than n / RIVAL_SEPARATION (at least 2) candidates from the
/// least cost.
const RIVAL_SEPARATION: u32 = 16;
/// Largest window radius, in cells.
pub const MAX_RADIUS: usize = 64;

/// Samples of the sweep: X(z) = p + z q per axis, the value v and the weight ω.
#[derive(Default)]
struct Samples {
    p: Vec<[f64; 2]>,
    q: Vec<[f64; 2]>,
    v: Vec<f64>,
    w: Vec<f64>,
    /// The sample's channel, as its index among the chosen channels.
    ch: Vec<u8>,
    /// The chosen channels' count.
    channels: usize,
}

/// The result of a sweep, row-major over the grid (row 0 at the top, Y1).
pub struct Sweep {
    /// The refined depth (mm); NaN where no candidate had a cost.
    pub depth: Vec<f64>,
    /// The refined candidate index (fractional); NaN where no candidate had a cost.
    pub index: Vec<f64>,
    /// 1 − min / min(mean, rival minimum) of the cost curve (see the module's doc), in
    /// [0, 1]; 0 where no candidate had a cost.
    pub confidence: Vec<f64>,
    /// The least cost; NaN where no candidate had a cost.
    pub min_cost: Vec<f64>,
    /// The mean cost over the candidates that had one; NaN where none had.
    pub mean_cost: Vec<f64>,
    /// Samples used (pixels of the chosen channels whose mean rays can meet the grid).
    pub samples: usize,
    /// The whole cost volume (candidate-major), when asked for; NaN where missing.
    pub volume: Option<Vec<f64>>,
}

/// Check the candidates: at least 3, finite, > F, strictly increasing.
pub fn check_candidates(design: &Design, candidates: &[f64]) -> Result<()> {
    if candidates.len() < 3 {
        return Err(Error::param(
            "depths",
            format!("{} candidates", candidates.len()),
            "at least 3 candidate depths",
        ));
    }
    let f = design.f_main;
    for (i, &z) in candidates.iter().enumerate() {
        if !(z.is_finite() && z > f) {
            return Err(Error::param(
                "depths",
                format!("{z} (candidate {i})"),
                format!("finite depths > F = {f} mm"),
            ));
        }
        if i > 0 && z <= candidates[i - 1] {
            return Err(Error::param(
                "depths",
                format!("{z} after {} (candidate {i})", candidates[i - 1]),
                "strictly increasing candidate depths",
            ));
        }
    }
    Ok(())
}

/// The samples of the chosen channels whose rays meet the expanded grid somewhere between
/// the first and the last candidate.
#[allow(clippy::too_many_arguments)]
fn collect(
    design: &Design,
    channels: &[usize],
    raws: &[&[f64]],
    whites: &[&[f64]],
    grid: &CellGrid,
    radius: usize,
    zs: (f64, f64),
    n_threads: Option<usize>,
) -> Result<Samples> {
    let pad = (radius + 1) as f64 * grid.step;
    let [gx0, gx1, gy0, gy1] = grid.extent();
    let (lo, hi) = ([gx0 - pad, gy0 - pad], [gx1 + pad, gy1 + pad]);
    let inv_f = 1.0 / design.f_main;
    let mut out = Samples {
        channels: channels.len(),
        ..Samples::default()
    };
    for (n, &i) in channels.iter().enumerate() {
        let ch = &design.channels[i];
        let (rows, cols) = crate::render::raw_shape(ch);
        let (raw, white) = (raws[n], whites[n]);
        let share = ch.share;
        let inv_l = 1.0 / ch.l;
        // Rect lattice, square aperture: each pixel's centroid ray (the mean of the rays it
        // collects, per axis: the 4-D region is the product of its x and y polygons), as
        // its sample at the first and the last candidate (affine in z between).
        let centroids = if design.shape == Aperture::Square && ch.grid == Grid::Rect {
            let number = i as i64 + 1;
            let (lx, ly) = (
                Line::of_channel(design, number, Axis::X)?,
                Line::of_channel(design, number, Axis::Y)?,
            );
            let at = |l: &Line, z| axis_samples(l, Sample::Centroid, z);
            Some([
                at(&lx, zs.0)?,
                at(&lx, zs.1)?,
                at(&ly, zs.0)?,
                at(&ly, zs.1)?,
            ])
        } else {
            None
        };
        let dz = zs.1 - zs.0;
        // Centroid samples are separable (X from the column, Y from the row): the columns
        // and rows whose samples can meet the widened grid, found once.
        let within = |v0: f64, v1: f64, ax: usize| {
            v0.is_finite() && v1.is_finite() && v0.max(v1) >= lo[ax] && v0.min(v1) <= hi[ax]
        };
        let (col_list, row_ok): (Vec<usize>, Vec<bool>) = match &centroids {
            Some([x0, x1, y0, y1]) => (
                (0..cols).filter(|&a| within(x0[a], x1[a], 0)).collect(),
                (0..rows).map(|b| within(y0[b], y1[b], 1)).collect(),
            ),
            None => ((0..cols).collect(), vec![true; rows]),
        };
        let row = |b: usize| {
            let mut s = Samples::default();
            if !row_ok[b] {
                return s;
            }
            for &a in &col_list {
                let k = b * cols + a;
                let wt = white[k] / share;
                if wt < MIN_WHITE {
                    continue;
                }
                let (w, q) = if let Some([x0, x1, y0, y1]) = &centroids {
                    let (p0, p1) = ([x0[a], y0[b]], [x1[a], y1[b]]);
                    if !(p0.iter().chain(&p1).all(|v| v.is_finite())) {
                        continue;
                    }
                    let q = [(p1[0] - p0[0]) / dz, (p1[1] - p0[1]) / dz];
                    ([p0[0] - zs.0 * q[0], p0[1] - zs.0 * q[1]], q)
                } else {
                    let px = design.pixel(ch, a as u32, b as u32);
                    if !px.lit {
                        continue;
                    }
                    let c = ch.lens_center(px.j, px.k);
                    let w = ch.chief_w(px.theta);
                    let q = [
                        w[0] * (inv_l - inv_f) - c[0] * inv_l,
                        w[1] * (inv_l - inv_f) - c[1] * inv_l,
                    ];
                    (w, q)
                };
                let meets = (0..2).all(|ax| {
                    let (x0, x1) = (w[ax] + zs.0 * q[ax], w[ax] + zs.1 * q[ax]);
                    x0.max(x1) >= lo[ax] && x0.min(x1) <= hi[ax]
                });
                if meets {
                    s.p.push(w);
                    s.q.push(q);
                    s.v.push(raw[k] / white[k]);
                    s.w.push(wt);
                    s.ch.push(n as u8);
                }
            }
            s
        };
        let step = crate::parallel::chunk_items(n_threads, cols as u128 * 32);
        for_chunks(n_threads, rows, step, |range| {
            let parts: Vec<Samples> = range.into_par_iter().map(row).collect();
            let n_new: usize = parts.iter().map(|s| s.v.len()).sum();
            memory::check(
                "the depth sweep's samples",
                ((out.v.len() + n_new) as u128) * 49,
            )?;
            for s in parts {
                out.p.extend(s.p);
                out.q.extend(s.q);
                out.v.extend(s.v);
                out.w.extend(s.w);
                out.ch.extend(s.ch);
            }
            Ok(())
        })?;
    }
    Ok(out)
}

/// Per-worker buffers of one candidate's layer.
struct Layer {
    /// The cell's Σ b, Σ b v, Σ b v² and Σ b² (b = a ω).
    s0: Vec<f64>,
    s1: Vec<f64>,
    s2: Vec<f64>,
    s3: Vec<f64>,
    /// Prefix sums (one row and column of zeros first) of the cells' SSD and weight.
    ps: Vec<f64>,
    pw: Vec<f64>,
}

impl Layer {
    fn new(ex: (usize, usize), channels: usize) -> Layer {
        let n = ex.0 * ex.1 * channels;
        let np = (ex.0 + 1) * (ex.1 + 1);
        Layer {
            s0: vec![0.0; n],
            s1: vec![0.0; n],
            s2: vec![0.0; n],
            s3: vec![0.0; n],
            ps: vec![0.0; np],
            pw: vec![0.0; np],
        }
    }
}

/// The layer of costs at depth z over the grid (row-major, NaN where missing).
fn layer(smp: &Samples, grid: &CellGrid, radius: usize, z: f64, buf: &mut Layer, out: &mut [f64]) {
    let r = radius;
    let (enx, eny) = (grid.nx + 2 * r, grid.ny + 2 * r);
    let h = grid.step;
    let ex0 = grid.x0 - r as f64 * h;
    let ey1 = grid.y1 + r as f64 * h;
    buf.s0.fill(0.0);
    buf.s1.fill(0.0);
    buf.s2.fill(0.0);
    buf.s3.fill(0.0);
    let inv_h = 1.0 / h;
    for i in 0..smp.v.len() {
        let (p, q) = (smp.p[i], smp.q[i]);
        let fx = (p[0] + z * q[0] - ex0) * inv_h - 0.5;
        let fy = (ey1 - (p[1] + z * q[1])) * inv_h - 0.5;
        if !(fx > -1.0 && fy > -1.0 && fx < enx as f64 && fy < eny as f64) {
            continue;
        }
        let (ix, iy) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - ix, fy - iy);
        let (ix, iy) = (ix as isize, iy as isize);
        let (v, w, ch) = (smp.v[i], smp.w[i], smp.ch[i] as usize);
        let nch = smp.channels;
        for (dy, wy) in [(0isize, 1.0 - ty), (1, ty)] {
            let y = iy + dy;
            if y < 0 || y >= eny as isize {
                continue;
            }
            for (dx, wx) in [(0isize, 1.0 - tx), (1, tx)] {
                let x = ix + dx;
                if x < 0 || x >= enx as isize {
                    continue;
                }
                let k = (y as usize * enx + x as usize) * nch + ch;
                let a = w * wx * wy;
                buf.s0[k] += a;
                buf.s1[k] += a * v;
                buf.s2[k] += a * v * v;
                buf.s3[k] += a * a;
            }
        }
    }
    // Prefix sums of the cells' weighted SSD about their mean, and of their degrees of
    // freedom: for independent samples of variance σ² per unit weight,
    // E[SSD] = σ² (S0 − Σ b² / S0), so the pooled ratio is unbiased however sparse the
    // samples (a lone sample adds 0 to both).
    let pc = enx + 1;
    for y in 0..eny {
        let (mut rs, mut rw) = (0.0, 0.0);
        for x in 0..enx {
            let k = y * enx + x;
            for k in k * smp.channels..(k + 1) * smp.channels {
                let s0 = buf.s0[k];
                if s0 > 0.0 {
                    rs += (buf.s2[k] - buf.s1[k] * buf.s1[k] / s0).max(0.0);
                    rw += (s0 - buf.s3[k] / s0).max(0.0);
                }
            }
            buf.ps[(y + 1) * pc + x + 1] = buf.ps[y * pc + x + 1] + rs;
            buf.pw[(y + 1) * pc + x + 1] = buf.pw[y * pc + x + 1] + rw;
        }
    }
    let d = 2 * r + 1;
    for y in 0..grid.ny {
        for x in 0..grid.nx {
            let rect = |p: &[f64]| {
                p[(y + d) * pc + x + d] - p[y * pc + x + d] - p[(y + d) * pc + x] + p[y * pc + x]
            };
            let w = rect(&buf.pw);
            out[y * grid.nx + x] = if w >= MIN_WEIGHT {
                rect(&buf.ps).max(0.0) / w
            } else {
                f64::NAN
            };
        }
    }
}

/// Running minima of the cost curves (candidates folded in order).
struct Fold {
    /// The least cost, its candidate and its two neighbours' costs.
    min: Vec<f64>,
    arg: Vec<u32>,
    left: Vec<f64>,
    right: Vec<f64>,
    /// Per cell the [`KEEP_MINIMA`] least local minima of the curve (a missing cost counts
    /// as +∞), as (cost, candidate) in increasing cost.
    lm: Vec<(f64, u32)>,
    sum: Vec<f64>,
    count: Vec<u32>,
    /// The costs of the last two candidates folded (k − 1 and k − 2).
    prev: Vec<f64>,
    prev2: Vec<f64>,
}

/// A missing cost as +∞ (for comparisons).
fn or_inf(v: f64) -> f64 {
    if v.is_nan() {
        f64::INFINITY
    } else {
        v
    }
}

impl Fold {
    fn new(cells: usize) -> Fold {
        Fold {
            min: vec![f64::INFINITY; cells],
            arg: vec![u32::MAX; cells],
            left: vec![f64::NAN; cells],
            right: vec![f64::NAN; cells],
            lm: vec![(f64::INFINITY, u32::MAX); cells * KEEP_MINIMA],
            sum: vec![0.0; cells],
            count: vec![0; cells],
            prev: vec![f64::NAN; cells],
            prev2: vec![f64::NAN; cells],
        }
    }

    /// Note `m`, the cost of candidate k lower than both its neighbours', as a local
    /// minimum.
    fn local(&mut self, c: usize, m: f64, k: u32) {
        let kept = &mut self.lm[c * KEEP_MINIMA..(c + 1) * KEEP_MINIMA];
        if m < kept[KEEP_MINIMA - 1].0 {
            let at = kept.partition_point(|e| e.0 <= m);
            kept[at..].rotate_right(1);
            kept[at] = (m, k);
        }
    }

    /// The least local minimum more than `sep` candidates from the least cost (+∞: none
    /// among those kept).
    fn rival(&self, c: usize, sep: u32) -> f64 {
        let arg = self.arg[c];
        self.lm[c * KEEP_MINIMA..(c + 1) * KEEP_MINIMA]
            .iter()
            .find(|e| e.1 != u32::MAX && e.1.abs_diff(arg) > sep)
            .map_or(f64::INFINITY, |e| e.0)
    }

    fn add(&mut self, k: u32, layer: &[f64]) {
        for (c, &v) in layer.iter().enumerate() {
            if self.arg[c] != u32::MAX && k > 0 && self.arg[c] == k - 1 {
                self.right[c] = v;
            }
            let p = or_inf(self.prev[c]);
            if k > 0 && p.is_finite() && p < or_inf(self.prev2[c]) && p <= or_inf(v) {
                self.local(c, p, k - 1);
            }
            if v.is_finite() {
                self.sum[c] += v;
                self.count[c] += 1;
                if v < self.min[c] {
                    self.min[c] = v;
                    self.arg[c] = k;
                    self.left[c] = self.prev[c];
                    self.right[c] = f64::NAN;
                }
            }
        }
        std::mem::swap(&mut self.prev2, &mut self.prev);
        self.prev.copy_from_slice(layer);
    }

    /// After the last candidate: it is a local minimum when lower than the one before.
    fn end(&mut self, n: u32) {
        for c in 0..self.min.len() {
            let p = or_inf(self.prev[c]);
            if n > 0 && p.is_finite() && p < or_inf(self.prev2[c]) {
                self.local(c, p, n - 1);
            }
        }
    }
}

/// The sweep's bytes: samples, per-worker layers, the fold and the outputs.
fn sweep_bytes(
    samples: usize,
    grid: &CellGrid,
    radius: usize,
    workers: usize,
    n_cand: usize,
    keep: bool,
    channels: usize,
) -> u128 {
    let ex = ((grid.nx + 2 * radius + 1) * (grid.ny + 2 * radius + 1)) as u128;
    let cells = grid.cells() as u128;
    let volume = if keep { cells * n_cand as u128 * 8 } else { 0 };
    samples as u128 * 49
        + workers as u128 * (ex * (16 + 32 * channels as u128) + cells * 8)
        + cells * (80 + 12 * KEEP_MINIMA as u128)
        + volume
}

/// The plane sweep of `raws` (one per chosen channel, row-major, the §10 layout) over the
/// increasing `candidates` on `grid`, with `whites` the raws under a white albedo and
/// windows of (2 radius + 1)² cells. `done` counts candidates. See the module's doc.
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    design: &Design,
    channels: &[usize],
    raws: &[&[f64]],
    whites: &[&[f64]],
    grid: &CellGrid,
    candidates: &[f64],
    radius: usize,
    keep_volume: bool,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Sweep> {
    crate::parallel::check_threads(n_threads)?;
    check_candidates(design, candidates)?;
    if channels.is_empty() || channels.len() > u8::MAX as usize {
        return Err(Error::param(
            "channels",
            channels.len(),
            "1 to 255 channels",
        ));
    }
    if radius > MAX_RADIUS {
        return Err(Error::param(
            "window",
            radius,
            format!("a window radius in [0, {MAX_RADIUS}] cells"),
        ));
    }
    if raws.len() != channels.len() || whites.len() != channels.len() {
        return Err(Error::param(
            "raw",
            format!("{} images", raws.len()),
            format!("one image per chosen channel ({})", channels.len()),
        ));
    }
    for (n, &i) in channels.iter().enumerate() {
        if i >= design.channels.len() {
            return Err(Error::param(
                "channels",
                i + 1,
                format!("channel numbers in 1..={}", design.channels.len()),
            ));
        }
        let (rows, cols) = crate::render::raw_shape(&design.channels[i]);
        for (name, img) in [("raw", raws[n]), ("white", whites[n])] {
            if img.len() != rows * cols {
                return Err(Error::param(
                    name,
                    format!("{} values for channel {}", img.len(), i + 1),
                    format!("{rows} x {cols} = {} values", rows * cols),
                ));
            }
            if let Some(k) = img.iter().position(|v| !v.is_finite()) {
                return Err(Error::param(
                    name,
                    format!("{} at channel {} pixel {k}", img[k], i + 1),
                    "finite values",
                ));
            }
        }
    }
    let cells = grid.cells();
    let workers = threads(n_threads);
    // The memory without the samples first, then with them once counted.
    let need = |samples: usize| {
        let bytes = sweep_bytes(
            samples,
            grid,
            radius,
            workers,
            candidates.len(),
            keep_volume,
            channels.len(),
        );
        memory::check("the depth sweep", bytes)
    };
    need(0)?;
    let zs = (candidates[0], candidates[candidates.len() - 1]);
    let smp = collect(design, channels, raws, whites, grid, radius, zs, n_threads)?;
    need(smp.v.len())?;
    let mut fold = Fold::new(cells);
    let mut volume = if keep_volume {
        Some(Vec::with_capacity(cells * candidates.len()))
    } else {
        None
    };
    let ex = (grid.nx + 2 * radius, grid.ny + 2 * radius);
    let pool: Mutex<Vec<Layer>> = Mutex::new(Vec::new());
    for_chunks(n_threads, candidates.len(), workers, |range| {
        let start = range.start;
        let layers: Vec<Result<Vec<f64>>> = range
            .into_par_iter()
            .map(|k| {
                checkpoint()?;
                let mut buf = pool
                    .lock()
                    .map_err(|_| Error::param("n_threads", 1, "a worker that does not panic"))?
                    .pop()
                    .unwrap_or_else(|| Layer::new(ex, smp.channels));
                let mut out = vec![0.0; cells];
                layer(&smp, grid, radius, candidates[k], &mut buf, &mut out);
                if let Ok(mut p) = pool.lock() {
                    p.push(buf);
                }
                done.fetch_add(1, Ordering::Relaxed);
                Ok(out)
            })
            .collect();
        for (i, l) in layers.into_iter().enumerate() {
            let l = l?;
            fold.add((start + i) as u32, &l);
            if let Some(v) = volume.as_mut() {
                v.extend_from_slice(&l);
            }
        }
        Ok(())
    })?;
    fold.end(candidates.len() as u32);
    Ok(finish(fold, candidates, smp.v.len(), volume))
}

/// Refine each cell's minimum and derive its depth and confidence.
fn finish(fold: Fold, candidates: &[f64], samples: usize, volume: Option<Vec<f64>>) -> Sweep {
    let cells = fold.min.len();
    let n = candidates.len();
    let mut s = Sweep {
        depth: vec![f64::NAN; cells],
        index: vec![f64::NAN; cells],
        confidence: vec![0.0; cells],
        min_cost: vec![f64::NAN; cells],
        mean_cost: vec![f64::NAN; cells],
        samples,
        volume,
    };
    for c in 0..cells {
        let k = fold.arg[c];
        if k == u32::MAX {
            continue;
        }
        let (m, l, r) = (fold.min[c], fold.left[c], fold.right[c]);
        let mean = fold.sum[c] / fold.count[c] as f64;
        let mut off = 0.0;
        if l.is_finite() && r.is_finite() {
            off = vertex(l, m, r);
        }
        let kf = k as f64 + off;
        s.index[c] = kf;
        s.depth[c] = depth_at(candidates, kf, n);
        s.min_cost[c] = m;
        s.mean_cost[c] = mean;
        // The contrast against the curve's mean and against its least local minimum away
        // from the best (a curve with two dips of one depth is ambiguous).
        let sep = (n as u32 / RIVAL_SEPARATION).max(2);
        let against = mean.min(fold.rival(c, sep));
        s.confidence[c] = if against > 0.0 && against.is_finite() {
            (1.0 - m / against).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    s
}

/// The offset in (−½, ½) of a cost curve's minimum from the candidate of least cost m,
/// from its neighbours' costs l and r: the vertex of the symmetric V through the three
/// (equiangular fit: the cost rises linearly with the misregistration near its minimum,
/// as a sum of squared differences of a sharp texture does, more than quadratically).
fn vertex(l: f64, m: f64, r: f64) -> f64 {
    let rise = l.max(r) - m;
    if rise > 0.0 {
        (0.5 * (l - r) / rise).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// The depth at fractional candidate index kf: linear in 1/z between the two candidates
/// around it (the default candidates are uniform in 1/z).
fn depth_at(candidates: &[f64], kf: f64, n: usize) -> f64 {
    let k0 = (kf.floor() as usize).min(n - 2);
    let t = kf - k0 as f64;
    let inv = (1.0 - t) / candidates[k0] + t / candidates[k0 + 1];
    1.0 / inv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_of_a_symmetric_v() {
        // |x − 0.3| sampled at −1, 0, 1: l = 1.3, m = 0.3, r = 0.7.
        assert!((vertex(1.3, 0.3, 0.7) - 0.3).abs() < 1e-12);
        assert!((vertex(0.7, 0.3, 1.3) + 0.3).abs() < 1e-12);
        assert_eq!(vertex(1.0, 1.0, 1.0), 0.0);
    }

    #[test]
    fn depth_at_interpolates_in_inverse_depth() {
        let c = [500.0, 1000.0, 2000.0];
        assert!((depth_at(&c, 1.0, 3) - 1000.0).abs() < 1e-9);
        assert!((depth_at(&c, 0.5, 3) - 1.0 / (0.5 / 500.0 + 0.5 / 1000.0)).abs() < 1e-9);
        assert!((depth_at(&c, 2.0, 3) - 2000.0).abs() < 1e-9);
    }

    #[test]
    fn fold_tracks_the_neighbours_of_the_minimum() {
        let mut f = Fold::new(1);
        for (k, v) in [5.0, 3.0, 1.0, 2.0, 4.0].into_iter().enumerate() {
            f.add(k as u32, &[v]);
        }
        assert_eq!(
            (f.arg[0], f.min[0], f.left[0], f.right[0]),
            (2, 1.0, 3.0, 2.0)
        );
        assert_eq!((f.sum[0], f.count[0]), (15.0, 5));
        f.end(5);
        assert_eq!(f.lm[0], (1.0, 2));
        assert_eq!(f.rival(0, 1), f64::INFINITY);
    }

    #[test]
    fn fold_keeps_the_least_local_minima() {
        let mut f = Fold::new(1);
        for (k, v) in [1.0, 4.0, 2.0, 3.0, f64::NAN, 5.0, 0.5]
            .into_iter()
            .enumerate()
        {
            f.add(k as u32, &[v]);
        }
        f.end(7);
        // Local minima: 1 (first, a missing neighbour counts as +inf), 2, 0.5 (last).
        assert_eq!(
            &f.lm[..4],
            &[(0.5, 6), (1.0, 0), (2.0, 2), (f64::INFINITY, u32::MAX)]
        );
        assert_eq!((f.arg[0], f.min[0]), (6, 0.5));
        assert_eq!((f.rival(0, 3), f.rival(0, 6)), (1.0, f64::INFINITY));
    }
}
