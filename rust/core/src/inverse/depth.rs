//! Depth from the raw (docs/model.md §11, docs/depth.md): a plane sweep over candidate
//! depths that compares the lenses' micro-images.
//!
//! Each pixel's value divided by its white (its value under a white albedo: vignetting and
//! the channel's share removed) is a sample of the albedo near the point where the pixel's
//! mean ray meets the surface. Under a square aperture on a rect lattice that is the
//! centroid ray of its 4-D ray set (the product of its x and y polygons, §4: the
//! `centroid` sample of `rayspace`); elsewhere (hexagonal lattices, circular apertures)
//! the chief ray, X(z) = B(z) w − (z/L) c, B(z) = 1 − z/F + z/L (c: the lens centre, w:
//! the chief ray's main-lens height). Either is affine in z, X(z) = p + z q, and within
//! one lens X depends on the pixel's column alone and Y on its row alone.
//!
//! **One lens, one value per cell.** At a candidate z each lens's micro-image is
//! resampled at the centres of a grid of cells: per axis a tent t of half-width
//! H = max(h, s) in object space around each of the lens's column (row) positions (h the
//! cell pitch, s the lens's mean column spacing at z). Where the lens's pixels are sparser
//! than the cells (s ≥ h) that is linear interpolation between its pixels; where they are
//! denser, the average of those within about a cell. The lens's value in the cell is the
//! mean m = Σ t ω v / Σ t ω over its own valid pixels (ω the pixel's white relative to a
//! fully lit pixel, its photon-noise weight) with weight Ω = (Σ t ω)² / Σ t² ω (the weight
//! of a pixel of m's variance), times the coverage c = min(1, Σ t) over its valid pixels:
//! beyond the lens's last pixel the tents are an extrapolation, and the weight falls to 0
//! with them (without c a cell that one edge pixel barely reaches would count in full,
//! and the cost would jump wherever a pixel's tent enters or leaves a cell as z varies).
//! Cells where c Ω < [`MIN_WHITE`] take nothing from the lens.
//!
//! **Cost.** At the true depth the lenses that see a cell agree (up to noise and
//! interpolation); at a wrong depth they saw different patches. Per channel and cell the
//! spread of the lenses' values is pooled over a (2r + 1)² window,
//!
//!   C(z) = Σ_window Σ_lens Ω (m − m̄)² / Σ_window (S0 − Σ Ω² / S0) / V(z),
//!
//! (S0 = Σ Ω per cell, m̄ the Ω-weighted mean; Ω = (Σ t ω)² / Σ t² ω, the weight of a
//! pixel of the value's variance): the denominator is the cells' degrees of freedom, so a
//! lone lens tells nothing, and V(z), the same spread of all the channel's lens values over
//! the grid at z, is the scale of a mismatch at that depth (resampled micro-images are
//! smoother where the pixels lie far apart). A channel's cost is missing where its window
//! holds less than [`MIN_WEIGHT`] degrees of freedom. Comparing lens with lens, never
//! pixel with pixel, keeps the pairs compared the same at every candidate: pooling single
//! pixels that happen to fall into one cell compared, at some candidates, mostly pixels
//! that see nearly the same ray, whose agreement says nothing of the depth, and the cost
//! curves dipped there.
//!
//! **Thinning.** Far from a channel's focus hundreds of its lenses see each cell. Where
//! more than [`M_CAP`] do on average (the summed areas of their footprints over the grid's
//! area), each lens is kept with probability M_CAP / M(z), by a fixed pseudo-random number
//! per lens, so the kept sets are nested as z varies.
//!
//! Each channel's estimate per cell is the candidate of least cost, refined by the vertex
//! of the symmetric V through it and its two neighbours ([`vertex`]), and its confidence
//! the contrast 1 − min / m', m' the least of the curve's mean and of its least local
//! minimum more than n/16 candidates away (a second dip of the same depth makes a cell
//! ambiguous). A textureless patch costs the same (its noise) at every depth: its contrast
//! is small. Each cell takes the estimate of its most confident channel: the channels'
//! blurs differ, so their values of one patch are never compared, and a channel that sees
//! no texture at some depth has a shallow, sloping curve that would add rival minima to a
//! sum.
//!
//! The candidates are swept in parallel, each layer of costs folded in candidate order
//! into running minima, so the cost volume is never held whole (unless asked for).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;

use crate::imaging::recorder::CellGrid;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::{checkpoint, for_chunks, threads};
use crate::model::design::{Aperture, Design, Grid, Layout};
use crate::sampling::line::{Axis, Line};
use crate::sampling::rayspace::{axis_samples, Sample};

/// Least degrees of freedom (in fully lit lenses) a channel's window must hold for its cost
/// to count.
pub const MIN_WEIGHT: f64 = 2.0;
/// Pixels whose white is below this fraction of a fully lit pixel's are left out (their
/// values are mostly noise); a lens's value in a cell needs this much weight.
pub const MIN_WHITE: f64 = 0.05;
/// Lenses of a channel that see a cell, on average, beyond which the sweep thins them.
pub const M_CAP: f64 = 48.0;
/// Local minima kept per cell (for the confidence's rival minimum).
const KEEP_MINIMA: usize = 4;
/// A rival minimum lies more than n / RIVAL_SEPARATION (at least 2) candidates from the
/// least cost.
const RIVAL_SEPARATION: u32 = 16;
/// Largest window radius, in cells.
pub const MAX_RADIUS: usize = 64;
/// Bytes held per pixel of a lens's box (its ω and ω v).
const BYTES_PER_PIXEL: u128 = 16;

/// One lens's micro-image: its box of pixels and its columns' and rows' sample positions.
struct Lens {
    /// The lens's channel, as its index among the chosen channels.
    ch: usize,
    /// A fixed pseudo-random number in [0, 1): the lens is kept where it is below the
    /// layer's keep rate.
    u: f64,
    /// Per column of its box: (p, q) of its X(z) = p + z q; NaN where the column has no
    /// valid pixel of the lens.
    x: Vec<[f64; 2]>,
    /// Per row of its box: (p, q) of Y(z).
    y: Vec<[f64; 2]>,
    /// Per box pixel, row-major: (ω, ω v) = (white, raw) / share; zeros where the pixel is
    /// not the lens's or not valid.
    block: Vec<[f64; 2]>,
    /// Every pixel of the box whose column and row have positions is valid (ω > 0): the
    /// valid pixels are a product of columns and rows, and the tents' coverage (which only
    /// columns and rows with positions have) is separable.
    full: bool,
    /// Per axis, when its finite positions are monotone at every candidate: the (p, q) of
    /// the first and the last finite one and their count (the extent from two positions,
    /// held here so that a layer's pass over every lens does not visit `x` and `y`).
    ends: [Option<Ends>; 2],
}

/// An axis's first and last finite positions, (p, q) each, and the count of finite ones.
type Ends = ([f64; 2], [f64; 2], usize);

impl Lens {
    /// [`axis_extent`] of the lens's columns (axis 0) or rows (axis 1) at depth z.
    fn extent(&self, axis: usize, z: f64) -> Option<(f64, f64, f64)> {
        let pos = if axis == 0 { &self.x } else { &self.y };
        match self.ends[axis] {
            Some((pi, pj, n)) => {
                let (a, b) = (pi[0] + z * pi[1], pj[0] + z * pj[1]);
                Some(spaced(a.min(b), a.max(b), n))
            }
            None => axis_extent(pos, z),
        }
    }
}

/// The first and last finite positions of an axis and their count, when the finite
/// positions are monotone at both ends of the candidates (then at every candidate: each
/// difference is affine in z).
fn monotone_ends(pos: &[[f64; 2]], zs: (f64, f64)) -> Option<(usize, usize, usize)> {
    let idx: Vec<usize> = (0..pos.len())
        .filter(|&i| (pos[i][0] + zs.0 * pos[i][1]).is_finite())
        .collect();
    let (&first, &last) = (idx.first()?, idx.last()?);
    for z in [zs.0, zs.1] {
        let x: Vec<f64> = idx.iter().map(|&i| pos[i][0] + z * pos[i][1]).collect();
        let up = x.windows(2).all(|w| w[0] <= w[1]);
        let down = x.windows(2).all(|w| w[0] >= w[1]);
        if !(up || down) || x.iter().any(|v| !v.is_finite()) {
            return None;
        }
    }
    Some((first, last, idx.len()))
}

/// The micro-images of the chosen channels' lenses that can see the widened grid.
#[derive(Default)]
struct Micro {
    lenses: Vec<Lens>,
    /// Valid pixels of the kept lenses, and the pixels of their boxes.
    pixels: usize,
    boxed: usize,
    channels: usize,
}

/// SplitMix64's finaliser: a fixed pseudo-random number per lens.
fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The lens's number in [0, 1): SplitMix64 of j | k << 24 | channel << 48.
fn lens_u(channel: usize, j: u32, k: u32) -> f64 {
    let key = j as u64 | (k as u64) << 24 | (channel as u64) << 48;
    (splitmix(key) >> 11) as f64 / (1u64 << 53) as f64
}

/// A lens's extent along one axis at depth z: (min, max) of its finite positions and its
/// mean spacing (0 with fewer than two); None without a finite position.
fn axis_extent(pos: &[[f64; 2]], z: f64) -> Option<(f64, f64, f64)> {
    let (mut lo, mut hi, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0usize);
    for pq in pos {
        let x = pq[0] + z * pq[1];
        if x.is_finite() {
            lo = lo.min(x);
            hi = hi.max(x);
            n += 1;
        }
    }
    (n > 0).then(|| spaced(lo, hi, n))
}

/// (lo, hi, mean spacing) of n positions spanning [lo, hi] (spacing 0 for one).
fn spaced(lo: f64, hi: f64, n: usize) -> (f64, f64, f64) {
    let s = if n > 1 {
        (hi - lo) / (n - 1) as f64
    } else {
        0.0
    };
    (lo, hi, s)
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
    /// The channel whose curve gave the estimate, as its index among the chosen channels.
    pub channel: Vec<u8>,
    /// Valid pixels of the lenses whose footprints can meet the grid.
    pub samples: usize,
    /// The whole cost volume (candidate, then chosen channel, then cell), when asked for;
    /// NaN where missing.
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

/// The micro-images of the chosen channels' lenses whose footprints (their pixels'
/// positions widened by the tent) meet the widened grid somewhere between the first and
/// the last candidate.
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
) -> Result<Micro> {
    let r = radius as f64 * grid.step;
    let [gx0, gx1, gy0, gy1] = grid.extent();
    let (lo, hi) = ([gx0 - r, gy0 - r], [gx1 + r, gy1 + r]);
    let h = grid.step;
    let inv_f = 1.0 / design.f_main;
    let mut out = Micro {
        channels: channels.len(),
        ..Micro::default()
    };
    for (n, &i) in channels.iter().enumerate() {
        let ch = &design.channels[i];
        let (rows, cols) = crate::imaging::render::raw_shape(ch);
        let (raw, white) = (raws[n], whites[n]);
        let share = ch.share;
        let inv_l = 1.0 / ch.l;
        let dz = zs.1 - zs.0;
        // Rect lattice, square aperture: each pixel's centroid ray (per axis: X from its
        // column, Y from its row), from its samples at the first and the last candidate.
        let centroids = if design.shape == Aperture::Square && ch.grid == Grid::Rect {
            let number = i as i64 + 1;
            let (lx, ly) = (
                Line::of_channel(design, number, Axis::X)?,
                Line::of_channel(design, number, Axis::Y)?,
            );
            let at = |l: &Line, z| axis_samples(l, Sample::Centroid, z);
            let pq = |l: &Line| -> Result<Vec<[f64; 2]>> {
                let (s0, s1) = rayon::join(|| at(l, zs.0), || at(l, zs.1));
                Ok(s0?
                    .iter()
                    .zip(&s1?)
                    .map(|(&a, &b)| {
                        let q = (b - a) / dz;
                        [a - zs.0 * q, q]
                    })
                    .collect())
            };
            let (xs, ys) = crate::infra::parallel::with_threads(n_threads, || {
                rayon::join(|| pq(&lx), || pq(&ly))
            })?;
            Some((xs?, ys?))
        } else {
            None
        };
        // The pixel's lens and its mean ray (p, q) per axis; None where it is not valid.
        let ray = |a: usize, b: usize| -> (u32, u32, Option<[[f64; 2]; 2]>) {
            let px = design.pixel(ch, a as u32, b as u32);
            let k = b * cols + a;
            if white[k] / share < MIN_WHITE {
                return (px.j, px.k, None);
            }
            let rays = match &centroids {
                Some((xs, ys)) => [xs[a], ys[b]],
                None => {
                    if !px.lit {
                        return (px.j, px.k, None);
                    }
                    let c = ch.lens_center(px.j, px.k);
                    let w = ch.chief_w(px.theta);
                    [
                        [w[0], w[0] * (inv_l - inv_f) - c[0] * inv_l],
                        [w[1], w[1] * (inv_l - inv_f) - c[1] * inv_l],
                    ]
                }
            };
            let ok = rays.iter().flatten().all(|v| v.is_finite());
            (px.j, px.k, ok.then_some(rays))
        };
        // Each lens's box of pixels: the Q × Q block of an ideal layout; on a sensor
        // layout the bounds of the pixels nearest to it, from one scan.
        let (kx, ky) = (ch.kx as usize, ch.ky as usize);
        let boxes: Vec<[usize; 4]> = match ch.layout {
            Layout::Ideal { q } => {
                let q = q as usize;
                (0..kx * ky)
                    .map(|l| {
                        let (j, k) = (l % kx, l / kx);
                        [j * q, (j + 1) * q, k * q, (k + 1) * q]
                    })
                    .collect()
            }
            Layout::Sensor { .. } => {
                memory::check("the depth sweep's lens boxes", (kx * ky) as u128 * 32)?;
                let mut b = vec![[usize::MAX, 0, usize::MAX, 0]; kx * ky];
                let step = crate::infra::parallel::chunk_items(n_threads, cols as u128 * 8);
                for_chunks(n_threads, rows, step, |range| {
                    let parts: Vec<Vec<(usize, usize, usize)>> = range
                        .into_par_iter()
                        .map(|row| {
                            (0..cols)
                                .map(|a| {
                                    let px = design.pixel(ch, a as u32, row as u32);
                                    (px.k as usize * kx + px.j as usize, a, row)
                                })
                                .collect()
                        })
                        .collect();
                    for (l, a, row) in parts.into_iter().flatten() {
                        let e = &mut b[l];
                        e[0] = e[0].min(a);
                        e[1] = e[1].max(a + 1);
                        e[2] = e[2].min(row);
                        e[3] = e[3].max(row + 1);
                    }
                    Ok(())
                })?;
                b
            }
        };
        // Per lens: its columns' and rows' rays (from the first valid pixel of each), its
        // box of (ω, ω v), and whether it can meet the grid.
        let lens = |l: usize| -> Option<(Lens, usize)> {
            let [a0, a1, b0, b1] = boxes[l];
            if a0 >= a1 || b0 >= b1 {
                return None;
            }
            let (j, k) = ((l % kx) as u32, (l / kx) as u32);
            let (na, nb) = (a1 - a0, b1 - b0);
            let mut x = vec![[f64::NAN; 2]; na];
            let mut y = vec![[f64::NAN; 2]; nb];
            let mut block = vec![[0.0; 2]; na * nb];
            let mut pixels = 0;
            for b in b0..b1 {
                for a in a0..a1 {
                    let (pj, pk, rays) = ray(a, b);
                    let Some([rx, ry]) = rays.filter(|_| (pj, pk) == (j, k)) else {
                        continue;
                    };
                    if x[a - a0][0].is_nan() {
                        x[a - a0] = rx;
                    }
                    if y[b - b0][0].is_nan() {
                        y[b - b0] = ry;
                    }
                    let p = b * cols + a;
                    let (w, wv) = (white[p] / share, raw[p] / share);
                    block[(b - b0) * na + a - a0] = [w, wv];
                    pixels += 1;
                }
            }
            if pixels == 0 {
                return None;
            }
            // The footprint's hull over the candidates (positions affine in z: the
            // extremes are at the ends), widened by the tent.
            let meets = |pos: &[[f64; 2]], ax: usize| {
                let (mut l0, mut h0) = (f64::INFINITY, f64::NEG_INFINITY);
                for z in [zs.0, zs.1] {
                    if let Some((a, b, s)) = axis_extent(pos, z) {
                        let w = h.max(s);
                        l0 = l0.min(a - w);
                        h0 = h0.max(b + w);
                    }
                }
                h0 >= lo[ax] && l0 <= hi[ax]
            };
            if !(meets(&x, 0) && meets(&y, 1)) {
                return None;
            }
            let end =
                |pos: &[[f64; 2]]| monotone_ends(pos, zs).map(|(i, j, n)| (pos[i], pos[j], n));
            let ends = [end(&x), end(&y)];
            let full = y.iter().enumerate().all(|(b, yb)| {
                yb[0].is_nan()
                    || x.iter()
                        .enumerate()
                        .all(|(a, xa)| xa[0].is_nan() || block[b * na + a][0] > 0.0)
            });
            Some((
                Lens {
                    ch: n,
                    u: lens_u(i, j, k),
                    x,
                    y,
                    block,
                    full,
                    ends,
                },
                pixels,
            ))
        };
        let step = crate::infra::parallel::chunk_items(n_threads, 64 * 64);
        for_chunks(n_threads, kx * ky, step, |range| {
            let found: Vec<Option<(Lens, usize)>> = range.into_par_iter().map(lens).collect();
            let bytes: u128 = found
                .iter()
                .flatten()
                .map(|f| f.0.block.len() as u128 * BYTES_PER_PIXEL)
                .sum();
            memory::check(
                "the depth sweep's micro-images",
                out.boxed as u128 * BYTES_PER_PIXEL + bytes,
            )?;
            for (lens, pixels) in found.into_iter().flatten() {
                out.boxed += lens.block.len();
                out.pixels += pixels;
                out.lenses.push(lens);
            }
            Ok(())
        })?;
    }
    Ok(out)
}

/// Per-worker buffers of one candidate's layer.
struct Layer {
    /// Per channel (planes of cells): Σ Ω, Σ Ω m, Σ Ω m² and Σ Ω² over the lenses.
    s0: Vec<f64>,
    s1: Vec<f64>,
    s2: Vec<f64>,
    s3: Vec<f64>,
    /// Per channel: Σ over lenses of their own pixels' spread and its degrees of freedom.
    s4: Vec<f64>,
    s5: Vec<f64>,
    /// Per channel, prefix sums (one row and column of zeros first) of the cells' spread
    /// and degrees of freedom.
    ps: Vec<f64>,
    pw: Vec<f64>,
    /// One lens's box resampled along its rows (5 arrays of rows × cells: the fourth only
    /// near the out-of-focus plane), and one cell row's sums (5 × cells).
    a: Vec<f64>,
    row: Vec<f64>,
    /// One lens's tents per axis: (pixel index in the box, weight) for each cell of its
    /// range, and each cell's start in it.
    tx: Vec<(u32, f64)>,
    txs: Vec<usize>,
    ty: Vec<(u32, f64)>,
    tys: Vec<usize>,
    /// The axis's finite positions of one lens, sorted, with their indices.
    sorted: Vec<(f64, u32)>,
    /// One full lens's tents summed per cell column.
    cover: Vec<f64>,
    /// Every lens's extents along X and Y at this layer's depth ([`Lens::extent`]).
    extents: Vec<[Option<(f64, f64, f64)>; 2]>,
}

impl Layer {
    fn new(ex: (usize, usize), channels: usize) -> Layer {
        let n = ex.0 * ex.1 * channels;
        let np = (ex.0 + 1) * (ex.1 + 1) * channels;
        Layer {
            s0: vec![0.0; n],
            s1: vec![0.0; n],
            s2: vec![0.0; n],
            s3: vec![0.0; n],
            s4: vec![0.0; n],
            s5: vec![0.0; n],
            ps: vec![0.0; np],
            pw: vec![0.0; np],
            a: Vec::new(),
            row: Vec::new(),
            tx: Vec::new(),
            txs: Vec::new(),
            ty: Vec::new(),
            tys: Vec::new(),
            sorted: Vec::new(),
            cover: Vec::new(),
            extents: Vec::new(),
        }
    }
}

/// The tents of one lens along one axis at depth z over the cells whose centres are
/// c0 + (i + 0.5) h · dir for i in 0..n (dir = ±1): into `t` the (index, weight) pairs of
/// each cell of the returned range, `starts` each cell's first pair (and one past the
/// last). Weights t = max(0, 1 − |x − X|/H), H = max(h, spacing).
#[allow(clippy::too_many_arguments)]
fn tents(
    pos: &[[f64; 2]],
    z: f64,
    (c0, dir, h, n): (f64, f64, f64, usize),
    (lo, hi, s): (f64, f64, f64),
    sorted: &mut Vec<(f64, u32)>,
    t: &mut Vec<(u32, f64)>,
    starts: &mut Vec<usize>,
) -> std::ops::Range<usize> {
    t.clear();
    starts.clear();
    let hw = h.max(s);
    // The cells whose centres lie strictly within (lo − H, hi + H).
    let f = |x: f64| (x - c0) * dir / h - 0.5;
    let (e0, e1) = if dir > 0.0 {
        (f(lo - hw), f(hi + hw))
    } else {
        (f(hi + hw), f(lo - hw))
    };
    let first = (e0.floor() + 1.0).max(0.0);
    let last = (e1.ceil() - 1.0).min(n as f64 - 1.0);
    if first.is_nan() || last.is_nan() || first > last {
        return 0..0;
    }
    let (first, last) = (first as usize, last as usize);
    sorted.clear();
    sorted.extend(pos.iter().enumerate().filter_map(|(i, pq)| {
        let x = pq[0] + z * pq[1];
        x.is_finite().then_some((x, i as u32))
    }));
    // Within a lens the positions are affine in the column: sorted one way or the other.
    if sorted.windows(2).all(|w| w[0].0 >= w[1].0) {
        sorted.reverse();
    } else if !sorted.windows(2).all(|w| w[0].0 <= w[1].0) {
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    for i in first..=last {
        let x = c0 + dir * (i as f64 + 0.5) * h;
        starts.push(t.len());
        let start = sorted.partition_point(|e| e.0 <= x - hw);
        for &(xp, idx) in &sorted[start..] {
            if xp >= x + hw {
                break;
            }
            let w = 1.0 - (x - xp).abs() / hw;
            if w > 0.0 {
                t.push((idx, w));
            }
        }
    }
    starts.push(t.len());
    first..last + 1
}

/// The layer of costs at depth z: per chosen channel, over the grid (row-major, NaN where
/// missing). Compiled twice, for the baseline and for AVX2 (chosen at run time): its loops
/// are element-wise or summed in order, and Rust never fuses a multiply and an add, so the
/// two give the same bits; AVX2 does four cells (and four divisions) at a time.
fn layer(mi: &Micro, grid: &CellGrid, radius: usize, z: f64, buf: &mut Layer, out: &mut [f64]) {
    crate::infra::simd::dispatch(
        #[inline(always)]
        |_| layer_in(mi, grid, radius, z, buf, out),
    )
}

#[inline(always)]
fn layer_in(mi: &Micro, grid: &CellGrid, radius: usize, z: f64, buf: &mut Layer, out: &mut [f64]) {
    let r = radius;
    let (enx, eny) = (grid.nx + 2 * r, grid.ny + 2 * r);
    let h = grid.step;
    let ex0 = grid.x0 - r as f64 * h;
    let ey1 = grid.y1 + r as f64 * h;
    let nch = mi.channels;
    buf.s0.fill(0.0);
    buf.s1.fill(0.0);
    buf.s2.fill(0.0);
    buf.s3.fill(0.0);
    buf.s4.fill(0.0);
    buf.s5.fill(0.0);
    // Per channel the keep rate: M_CAP over the mean number of its lenses whose
    // footprints (clipped to the widened grid) cover a cell.
    let (wx0, wx1, wy0, wy1) = (ex0, ex0 + enx as f64 * h, ey1 - eny as f64 * h, ey1);
    let clip = |a: f64, b: f64, c: f64, d: f64| (b.min(d) - a.max(c)).max(0.0);
    let mut area = vec![0.0; nch];
    buf.extents.clear();
    buf.extents
        .extend(mi.lenses.iter().map(|l| [l.extent(0, z), l.extent(1, z)]));
    for (l, &[ex, ey]) in mi.lenses.iter().zip(&buf.extents) {
        if let (Some((x0, x1, sx)), Some((y0, y1, sy))) = (ex, ey) {
            let (hx, hy) = (h.max(sx), h.max(sy));
            area[l.ch] += clip(x0 - hx, x1 + hx, wx0, wx1) * clip(y0 - hy, y1 + hy, wy0, wy1);
        }
    }
    let grid_area = (wx1 - wx0) * (wy1 - wy0);
    let keep: Vec<f64> = area
        .iter()
        .map(|&a| {
            if a > 0.0 {
                (M_CAP * grid_area / a).min(1.0)
            } else {
                1.0
            }
        })
        .collect();
    for (l, &[ex, ey]) in mi.lenses.iter().zip(&buf.extents) {
        if l.u >= keep[l.ch] {
            continue;
        }
        let (xs, ys) = (&l.x, &l.y);
        let (Some(ex), Some(ey)) = (ex, ey) else {
            continue;
        };
        let cols = tents(
            xs,
            z,
            (ex0, 1.0, h, enx),
            ex,
            &mut buf.sorted,
            &mut buf.tx,
            &mut buf.txs,
        );
        if cols.is_empty() {
            continue;
        }
        let rows = tents(
            ys,
            z,
            (ey1, -1.0, h, eny),
            ey,
            &mut buf.sorted,
            &mut buf.ty,
            &mut buf.tys,
        );
        // Separably: first along the rows of the box, A[b][ix] = Σ_a t_a ω[b][a] (and
        // with t², with ω v, with ω v², and the tents over valid pixels alone), then down
        // the columns for each cell row.
        let (block, na, nb, lx) = (&l.block, l.x.len(), l.y.len(), cols.len());
        let nl = nb * lx;
        // The lens's own pixels count only where they are denser than the cells (near its
        // channel's out-of-focus plane, where they see one point): weight (1 − s/h) per axis.
        let gate = (1.0 - ex.2 / h).max(0.0) * (1.0 - ey.2 / h).max(0.0);
        let own = gate > 0.0;
        if buf.a.len() < 5 * nl {
            buf.a.resize(5 * nl, 0.0);
        }
        {
            let (a1, rest) = buf.a[..5 * nl].split_at_mut(nl);
            let (a2, rest) = rest.split_at_mut(nl);
            let (a3, rest) = rest.split_at_mut(nl);
            let (a4, a5) = rest.split_at_mut(nl);
            let (tx, txs) = (&buf.tx, &buf.txs[..lx + 1]);
            for b in 0..nb {
                let row = &block[b * na..(b + 1) * na];
                let o = b * lx;
                let (r1, r2, r3) = (&mut a1[o..o + lx], &mut a2[o..o + lx], &mut a3[o..o + lx]);
                for ix in 0..lx {
                    let tents = &tx[txs[ix]..txs[ix + 1]];
                    let (mut s1, mut s2, mut s3) = (0.0, 0.0, 0.0);
                    for &(a, wa) in tents {
                        let [w, wv] = row[a as usize];
                        s1 += wa * w;
                        s2 += wa * wa * w;
                        s3 += wa * wv;
                    }
                    r1[ix] = s1;
                    r2[ix] = s2;
                    r3[ix] = s3;
                }
                if !l.full {
                    for (ix, r5) in a5[o..o + lx].iter_mut().enumerate() {
                        let mut s5 = 0.0;
                        for &(a, wa) in &tx[txs[ix]..txs[ix + 1]] {
                            if row[a as usize][0] > 0.0 {
                                s5 += wa;
                            }
                        }
                        *r5 = s5;
                    }
                }
                if own {
                    for (ix, r4) in a4[o..o + lx].iter_mut().enumerate() {
                        let mut s4 = 0.0;
                        for &(a, wa) in &tx[txs[ix]..txs[ix + 1]] {
                            let [w, wv] = row[a as usize];
                            if w > 0.0 {
                                s4 += wa * wv * wv / w;
                            }
                        }
                        *r4 = s4;
                    }
                }
            }
        }
        // A full box's coverage is (Σ t over the row tents) (Σ t over the column tents).
        if l.full {
            buf.cover.clear();
            buf.cover.extend(
                buf.txs
                    .windows(2)
                    .map(|w| buf.tx[w[0]..w[1]].iter().map(|e| e.1).sum::<f64>()),
            );
        }
        let plane = l.ch * enx * eny;
        if buf.row.len() < 5 * lx {
            buf.row.resize(5 * lx, 0.0);
        }
        let (a1, rest) = buf.a.split_at(nl);
        let (a2, rest) = rest.split_at(nl);
        let (a3, rest) = rest.split_at(nl);
        let (a4, a5) = rest.split_at(nl);
        for (iy, cy) in rows.clone().enumerate() {
            let ty = &buf.ty[buf.tys[iy]..buf.tys[iy + 1]];
            if ty.is_empty() {
                continue;
            }
            let (tw, rest) = buf.row[..5 * lx].split_at_mut(lx);
            let (ttw, rest) = rest.split_at_mut(lx);
            let (twv, rest) = rest.split_at_mut(lx);
            let (tv2, tt) = rest.split_at_mut(lx);
            tw.fill(0.0);
            ttw.fill(0.0);
            twv.fill(0.0);
            if own {
                tv2.fill(0.0);
            }
            if !l.full {
                tt.fill(0.0);
            }
            for &(b, wb) in ty {
                let o = b as usize * lx;
                let wb2 = wb * wb;
                let rows3 = (&a1[o..o + lx], &a2[o..o + lx], &a3[o..o + lx]);
                for (((t1, t2), t3), ((r1, r2), r3)) in tw
                    .iter_mut()
                    .zip(ttw.iter_mut())
                    .zip(twv.iter_mut())
                    .zip(rows3.0.iter().zip(rows3.1).zip(rows3.2))
                {
                    *t1 += wb * r1;
                    *t2 += wb2 * r2;
                    *t3 += wb * r3;
                }
                if !l.full {
                    for (t5, r5) in tt.iter_mut().zip(&a5[o..o + lx]) {
                        *t5 += wb * r5;
                    }
                }
                if own {
                    for (t4, r4) in tv2.iter_mut().zip(&a4[o..o + lx]) {
                        *t4 += wb * r4;
                    }
                }
            }
            if l.full {
                let sy: f64 = ty.iter().map(|e| e.1).sum();
                for (t5, cx) in tt.iter_mut().zip(&buf.cover) {
                    *t5 = sy * cx;
                }
            }
            let k0 = plane + cy * enx + cols.start;
            let (d0, d1, d2, d3) = (
                &mut buf.s0[k0..k0 + lx],
                &mut buf.s1[k0..k0 + lx],
                &mut buf.s2[k0..k0 + lx],
                &mut buf.s3[k0..k0 + lx],
            );
            // The value m = Σ t ω v / Σ t ω has the variance of a pixel of weight
            // Ω = (Σ t ω)² / Σ t² ω (each pixel's variance ∝ 1 / ω), counted in the share
            // c = min(1, Σ t) of the tents its valid pixels cover: a cell beyond the lens's
            // last pixel is an extrapolation, and its weight falls to 0 with the tent
            // instead of jumping. Returns c Ω and c / Σ t² ω, or zeros where the lens gives
            // the cell too little weight (branch-free: such a cell adds zeros).
            let weight = |w1: f64, w2: f64, cover: f64| {
                let inv = 1.0 / w2.max(f64::MIN_POSITIVE);
                let c = cover.min(1.0);
                let om = w1 * w1 * inv * c;
                let keep = if w2 > 0.0 && om >= MIN_WHITE {
                    inv * c
                } else {
                    0.0
                };
                (om, keep)
            };
            for ix in 0..lx {
                let (w1, w3) = (tw[ix], twv[ix]);
                let (om, keep) = weight(w1, ttw[ix], tt[ix]);
                let omk = w1 * w1 * keep;
                d0[ix] += omk;
                d1[ix] += w1 * w3 * keep;
                d2[ix] += w3 * w3 * keep;
                d3[ix] += omk * om;
            }
            if own {
                // The spread of the lens's own pixels about m, Σ t ω (v − m)², and its
                // degrees of freedom Σ t − Σ t² ω / Σ t ω: a lens whose pixels see one
                // point (near its channel's out-of-focus plane) agrees with itself.
                let (d4, d5) = (&mut buf.s4[k0..k0 + lx], &mut buf.s5[k0..k0 + lx]);
                for ix in 0..lx {
                    let (w1, w2, w3) = (tw[ix], ttw[ix], twv[ix]);
                    if weight(w1, w2, tt[ix]).1 > 0.0 {
                        d4[ix] += (tv2[ix] - w3 * w3 / w1).max(0.0) * gate;
                        d5[ix] += (tt[ix] - w2 / w1).max(0.0) * gate;
                    }
                }
            }
        }
    }
    // Per channel, prefix sums of the cells' weighted spread about their mean and of
    // their degrees of freedom: for independent values of variance σ² per unit weight,
    // E[spread] = σ² (S0 − Σ Ω² / S0), so the pooled ratio is unbiased however few
    // lenses a cell has (a lone lens adds 0 to both); and the totals over the grid.
    let pc = enx + 1;
    let plane = pc * (eny + 1);
    let mut totals = vec![[0.0; 4]; nch];
    for (c, tot) in totals.iter_mut().enumerate() {
        let (ps, pw) = (
            &mut buf.ps[c * plane..(c + 1) * plane],
            &mut buf.pw[c * plane..(c + 1) * plane],
        );
        let base = c * enx * eny;
        for y in 0..eny {
            let (mut rs, mut rw) = (0.0, 0.0);
            for x in 0..enx {
                let k = base + y * enx + x;
                let s0 = buf.s0[k];
                if s0 > 0.0 {
                    rs += (buf.s2[k] - buf.s1[k] * buf.s1[k] / s0).max(0.0) + buf.s4[k];
                    rw += (s0 - buf.s3[k] / s0).max(0.0) + buf.s5[k];
                    tot[0] += s0;
                    tot[1] += buf.s1[k];
                    tot[2] += buf.s2[k];
                    tot[3] += buf.s3[k];
                }
                let at = (y + 1) * pc + x + 1;
                ps[at] = ps[y * pc + x + 1] + rs;
                pw[at] = pw[y * pc + x + 1] + rw;
            }
        }
    }
    // Per channel the spread of all its lens values over the widened grid at this depth:
    // the scale of a mismatch, which shrinks where the lenses' pixels are far apart (their
    // resampled micro-images are smooth) or averaged.
    let scale: Vec<f64> = totals
        .iter()
        .map(|&[t0, t1, t2, t3]| {
            let mean = if t0 > 0.0 { t1 / t0 } else { 0.0 };
            let dof = if t0 > 0.0 { t0 - t3 / t0 } else { 0.0 };
            let total = if dof > 0.0 {
                (t2 - t1 * mean).max(0.0) / dof
            } else {
                0.0
            };
            if total > 1e-12 * (mean * mean).max(1e-300) {
                1.0 / total
            } else {
                0.0
            }
        })
        .collect();
    let d = 2 * r + 1;
    let cells = grid.cells();
    for y in 0..grid.ny {
        for x in 0..grid.nx {
            let rect = |p: &[f64]| {
                p[(y + d) * pc + x + d] - p[y * pc + x + d] - p[(y + d) * pc + x] + p[y * pc + x]
            };
            for c in 0..nch {
                let sl = |v: &[f64]| rect(&v[c * plane..(c + 1) * plane]);
                let w = sl(&buf.pw);
                out[c * cells + y * grid.nx + x] = if w >= MIN_WEIGHT {
                    sl(&buf.ps).max(0.0) / w * scale[c]
                } else {
                    f64::NAN
                };
            }
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

/// The sweep's bytes: the micro-images (`pixels` in the lenses' boxes), per-worker layers
/// (with 64 bytes a lens), the fold and the outputs.
#[allow(clippy::too_many_arguments)]
fn sweep_bytes(
    pixels: u128,
    lenses: u128,
    grid: &CellGrid,
    radius: usize,
    workers: usize,
    n_cand: usize,
    keep: bool,
    channels: usize,
) -> u128 {
    let ex = ((grid.nx + 2 * radius + 1) * (grid.ny + 2 * radius + 1)) as u128;
    let entries = grid.cells() as u128 * channels as u128;
    let volume = if keep {
        entries * n_cand as u128 * 8
    } else {
        0
    };
    pixels * BYTES_PER_PIXEL
        + workers as u128 * (ex * 80 * channels as u128 + entries * 8 + lenses * 64)
        + entries * (80 + 12 * KEEP_MINIMA as u128)
        + grid.cells() as u128 * 41
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
    crate::infra::parallel::check_threads(n_threads)?;
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
        let (rows, cols) = crate::imaging::render::raw_shape(&design.channels[i]);
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
    let need = |pixels: u128, lenses: u128| {
        let bytes = sweep_bytes(
            pixels,
            lenses,
            grid,
            radius,
            workers,
            candidates.len(),
            keep_volume,
            channels.len(),
        );
        memory::check("the depth sweep", bytes)
    };
    need(0, 0)?;
    let zs = (candidates[0], candidates[candidates.len() - 1]);
    let mi = collect(design, channels, raws, whites, grid, radius, zs, n_threads)?;
    need(mi.boxed as u128, mi.lenses.len() as u128)?;
    let entries = cells * channels.len();
    let fold = Fold::new(entries);
    let volume = if keep_volume {
        Some(Vec::with_capacity(entries * candidates.len()))
    } else {
        None
    };
    let ex = (grid.nx + 2 * radius, grid.ny + 2 * radius);
    // Each worker takes the next candidate in turn and folds, under the lock, every layer
    // that is next in order (the others keep computing meanwhile): at most a few layers
    // wait, and no worker idles at the end of a chunk.
    struct Folding {
        fold: Fold,
        volume: Option<Vec<f64>>,
        pending: std::collections::BTreeMap<usize, Vec<f64>>,
        next: usize,
    }
    let state = Mutex::new(Folding {
        fold,
        volume,
        pending: std::collections::BTreeMap::new(),
        next: 0,
    });
    let next = AtomicUsize::new(0);
    let n = candidates.len();
    let poisoned = || Error::param("n_threads", 1, "a worker that does not panic");
    for_chunks(n_threads, workers, workers, |range| {
        range.into_par_iter().try_for_each(|_| -> Result<()> {
            let mut buf = Layer::new(ex, mi.channels);
            loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                if k >= n {
                    return Ok(());
                }
                checkpoint()?;
                let mut out = vec![0.0; entries];
                layer(&mi, grid, radius, candidates[k], &mut buf, &mut out);
                done.fetch_add(1, Ordering::Relaxed);
                let mut st = state.lock().map_err(|_| poisoned())?;
                st.pending.insert(k, out);
                loop {
                    let at = st.next;
                    let Some(l) = st.pending.remove(&at) else {
                        break;
                    };
                    st.fold.add(at as u32, &l);
                    if let Some(v) = st.volume.as_mut() {
                        v.extend_from_slice(&l);
                    }
                    st.next += 1;
                }
            }
        })
    })?;
    let Folding {
        mut fold, volume, ..
    } = state.into_inner().map_err(|_| poisoned())?;
    fold.end(candidates.len() as u32);
    Ok(finish(fold, channels.len(), candidates, mi.pixels, volume))
}

/// Refine each channel's minimum in each cell, derive its depth and confidence, and keep
/// per cell the channel of highest confidence (the first on a tie).
fn finish(
    fold: Fold,
    channels: usize,
    candidates: &[f64],
    samples: usize,
    volume: Option<Vec<f64>>,
) -> Sweep {
    let cells = fold.min.len() / channels;
    let n = candidates.len();
    let mut s = Sweep {
        depth: vec![f64::NAN; cells],
        index: vec![f64::NAN; cells],
        confidence: vec![0.0; cells],
        min_cost: vec![f64::NAN; cells],
        mean_cost: vec![f64::NAN; cells],
        channel: vec![0; cells],
        samples,
        volume,
    };
    let sep = (n as u32 / RIVAL_SEPARATION).max(2);
    for cell in 0..cells {
        let mut best: Option<(f64, usize)> = None;
        for ch in 0..channels {
            let e = ch * cells + cell;
            if fold.arg[e] == u32::MAX {
                continue;
            }
            // The contrast against the curve's mean and against its least local minimum
            // away from the best (a curve with two dips of one depth is ambiguous).
            let mean = fold.sum[e] / fold.count[e] as f64;
            let against = mean.min(fold.rival(e, sep));
            let conf = if against > 0.0 && against.is_finite() {
                (1.0 - fold.min[e] / against).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if best.map_or(true, |(c, _)| conf > c) {
                best = Some((conf, ch));
            }
        }
        let Some((conf, ch)) = best else {
            continue;
        };
        let e = ch * cells + cell;
        let (k, m, l, r) = (fold.arg[e], fold.min[e], fold.left[e], fold.right[e]);
        let off = if l.is_finite() && r.is_finite() {
            vertex(l, m, r)
        } else {
            0.0
        };
        let kf = k as f64 + off;
        s.index[cell] = kf;
        s.depth[cell] = depth_at(candidates, kf, n);
        s.min_cost[cell] = m;
        s.mean_cost[cell] = fold.sum[e] / fold.count[e] as f64;
        s.confidence[cell] = conf;
        s.channel[cell] = ch as u8;
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
