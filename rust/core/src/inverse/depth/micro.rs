//! The lenses' micro-images the sweep resamples (docs/depth.md, step 1): per lens of the
//! chosen channels, its box of pixels' (ω, ω v) and its columns' and rows' mean rays
//! X(z) = p + z q, kept only where its footprint can meet the widened grid.

use rayon::prelude::*;

use super::{Images, BYTES_PER_PIXEL, MIN_WHITE};
use crate::imaging::recorder::CellGrid;
use crate::infra::error::Result;
use crate::infra::memory;
use crate::infra::parallel::for_chunks;
use crate::infra::random::splitmix64;
use crate::model::design::{Aperture, Channel, Design, Grid, Layout};
use crate::sampling::line::{Axis, Line};
use crate::sampling::rayspace::{axis_samples, Sample};

/// One lens's micro-image: its box of pixels and its columns' and rows' sample positions.
pub(super) struct Lens {
    /// The lens's channel, as its index among the chosen channels.
    pub(super) ch: usize,
    /// A fixed pseudo-random number in [0, 1): the lens is kept where it is below the
    /// layer's keep rate.
    pub(super) u: f64,
    /// Per column of its box: (p, q) of its X(z) = p + z q; NaN where the column has no
    /// valid pixel of the lens.
    pub(super) x: Vec<[f64; 2]>,
    /// Per row of its box: (p, q) of Y(z).
    pub(super) y: Vec<[f64; 2]>,
    /// Per box pixel, row-major: (ω, ω v) = (white, raw) / share; zeros where the pixel is
    /// not the lens's or not valid.
    pub(super) block: Vec<[f64; 2]>,
    /// Every pixel of the box whose column and row have positions is valid (ω > 0): the
    /// valid pixels are a product of columns and rows, and the tents' coverage (which only
    /// columns and rows with positions have) is separable.
    pub(super) full: bool,
    /// Per axis, when its finite positions are monotone at every candidate: the (p, q) of
    /// the first and the last finite one and their count (the extent from two positions,
    /// held here so that a layer's pass over every lens does not visit `x` and `y`).
    pub(super) ends: [Option<Ends>; 2],
}

/// An axis's first and last finite positions, (p, q) each, and the count of finite ones.
type Ends = ([f64; 2], [f64; 2], usize);

impl Lens {
    /// Bytes the lens holds: its box (16 bytes a pixel), its rays (16 bytes a column and a
    /// row) and its record.
    fn bytes(&self) -> u128 {
        self.block.len() as u128 * BYTES_PER_PIXEL
            + (self.x.len() + self.y.len()) as u128 * 16
            + std::mem::size_of::<Lens>() as u128
    }

    /// [`axis_extent`] of the lens's columns (axis 0) or rows (axis 1) at depth z.
    pub(super) fn extent(&self, axis: usize, z: f64) -> Option<(f64, f64, f64)> {
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
pub(super) struct Micro {
    pub(super) lenses: Vec<Lens>,
    /// Valid pixels of the kept lenses, and the pixels of their boxes.
    pub(super) pixels: usize,
    pub(super) boxed: usize,
    pub(super) channels: usize,
    /// Bytes the lenses hold (their boxes, rays and records), and the most columns and
    /// rows of a lens's box.
    pub(super) bytes: u128,
    pub(super) box_max: (usize, usize),
}

/// The lens's number in [0, 1): SplitMix64 of j | k << 24 | channel << 48.
fn lens_u(channel: usize, j: u32, k: u32) -> f64 {
    let key = j as u64 | (k as u64) << 24 | (channel as u64) << 48;
    (splitmix64(key) >> 11) as f64 / (1u64 << 53) as f64
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

/// Where a lens must reach to be kept: the grid widened by the window, [lo, hi] per axis,
/// at some depth between the first and the last candidate, its positions widened by the
/// tent (half-width max(h, spacing)).
struct Reach {
    lo: [f64; 2],
    hi: [f64; 2],
    h: f64,
    zs: (f64, f64),
}

impl Reach {
    /// The footprint's hull over the candidates (positions affine in z: the extremes are
    /// at the ends), widened by the tent, meets [lo, hi] along axis `ax`.
    fn meets(&self, pos: &[[f64; 2]], ax: usize) -> bool {
        let (mut l0, mut h0) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in [self.zs.0, self.zs.1] {
            if let Some((a, b, s)) = axis_extent(pos, z) {
                let w = self.h.max(s);
                l0 = l0.min(a - w);
                h0 = h0.max(b + w);
            }
        }
        h0 >= self.lo[ax] && l0 <= self.hi[ax]
    }
}

/// Per column and per row of a channel: the (p, q) of its centroid ray.
type Rays = (Vec<[f64; 2]>, Vec<[f64; 2]>);

/// One chosen channel's pixels: its raw and white, and the rays its pixels' values sample.
struct ChannelPixels<'a> {
    design: &'a Design,
    ch: &'a Channel,
    /// The channel's index among the chosen ones and in the design.
    n: usize,
    i: usize,
    raw: &'a [f64],
    white: &'a [f64],
    cols: usize,
    /// Rect lattice, square aperture: each column's and row's centroid ray (p, q).
    centroids: Option<Rays>,
}

/// Rect lattice, square aperture: each pixel's centroid ray (per axis: X from its column,
/// Y from its row), from its samples at the first and the last candidate; None elsewhere.
fn centroid_rays(
    design: &Design,
    i: usize,
    zs: (f64, f64),
    n_threads: Option<usize>,
) -> Result<Option<Rays>> {
    let ch = &design.channels[i];
    if !(design.shape == Aperture::Square && ch.grid == Grid::Rect) {
        return Ok(None);
    }
    let dz = zs.1 - zs.0;
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
    let (xs, ys) =
        crate::infra::parallel::with_threads(n_threads, || rayon::join(|| pq(&lx), || pq(&ly)))?;
    Ok(Some((xs?, ys?)))
}

/// Each lens's box of pixels [a0, a1, b0, b1]: the Q × Q block of an ideal layout; on a
/// sensor layout the bounds of the pixels nearest to it, from one scan.
fn lens_boxes(design: &Design, ch: &Channel, n_threads: Option<usize>) -> Result<Vec<[usize; 4]>> {
    let (kx, ky) = (ch.kx as usize, ch.ky as usize);
    let (rows, cols) = crate::imaging::render::raw_shape(ch);
    if let Layout::Ideal { q } = ch.layout {
        let q = q as usize;
        return Ok((0..kx * ky)
            .map(|l| {
                let (j, k) = (l % kx, l / kx);
                [j * q, (j + 1) * q, k * q, (k + 1) * q]
            })
            .collect());
    }
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
    Ok(b)
}

impl ChannelPixels<'_> {
    /// The pixel's lens and its mean ray (p, q) per axis; None where it is not valid.
    fn ray(&self, a: usize, b: usize) -> (u32, u32, Option<[[f64; 2]; 2]>) {
        let (design, ch) = (self.design, self.ch);
        let px = design.pixel(ch, a as u32, b as u32);
        let k = b * self.cols + a;
        if self.white[k] / ch.share < MIN_WHITE {
            return (px.j, px.k, None);
        }
        let rays = match &self.centroids {
            Some((xs, ys)) => [xs[a], ys[b]],
            None => {
                if !px.lit {
                    return (px.j, px.k, None);
                }
                let inv_f = 1.0 / design.f_main;
                let inv_l = 1.0 / ch.l;
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
    }

    /// Lens l (of box `bx`): its columns' and rows' rays (from the first valid pixel of
    /// each), its box of (ω, ω v) and its valid pixels; None when it has none or cannot
    /// meet the grid.
    fn lens(&self, l: usize, bx: [usize; 4], reach: &Reach) -> Option<(Lens, usize)> {
        let [a0, a1, b0, b1] = bx;
        if a0 >= a1 || b0 >= b1 {
            return None;
        }
        let kx = self.ch.kx as usize;
        let (j, k) = ((l % kx) as u32, (l / kx) as u32);
        let (na, nb) = (a1 - a0, b1 - b0);
        let mut x = vec![[f64::NAN; 2]; na];
        let mut y = vec![[f64::NAN; 2]; nb];
        let mut block = vec![[0.0; 2]; na * nb];
        let mut pixels = 0;
        let share = self.ch.share;
        for b in b0..b1 {
            for a in a0..a1 {
                let (pj, pk, rays) = self.ray(a, b);
                let Some([rx, ry]) = rays.filter(|_| (pj, pk) == (j, k)) else {
                    continue;
                };
                if x[a - a0][0].is_nan() {
                    x[a - a0] = rx;
                }
                if y[b - b0][0].is_nan() {
                    y[b - b0] = ry;
                }
                let p = b * self.cols + a;
                let (w, wv) = (self.white[p] / share, self.raw[p] / share);
                block[(b - b0) * na + a - a0] = [w, wv];
                pixels += 1;
            }
        }
        if pixels == 0 || !(reach.meets(&x, 0) && reach.meets(&y, 1)) {
            return None;
        }
        let zs = reach.zs;
        let end = |pos: &[[f64; 2]]| monotone_ends(pos, zs).map(|(i, j, n)| (pos[i], pos[j], n));
        let ends = [end(&x), end(&y)];
        let full = y.iter().enumerate().all(|(b, yb)| {
            yb[0].is_nan()
                || x.iter()
                    .enumerate()
                    .all(|(a, xa)| xa[0].is_nan() || block[b * na + a][0] > 0.0)
        });
        let lens = Lens {
            ch: self.n,
            u: lens_u(self.i, j, k),
            x,
            y,
            block,
            full,
            ends,
        };
        Some((lens, pixels))
    }
}

/// The most columns and rows of a lens's box among the chosen channels that have the ideal
/// layout (Q × Q; a sensor layout's boxes are known once scanned).
pub(super) fn ideal_boxes(design: &Design, channels: &[usize]) -> (usize, usize) {
    let q = channels
        .iter()
        .filter_map(|&i| match design.channels.get(i)?.layout {
            Layout::Ideal { q } => Some(q as usize),
            Layout::Sensor { .. } => None,
        })
        .max()
        .unwrap_or(0);
    (q, q)
}

/// The micro-images of the chosen channels' lenses whose footprints (their pixels'
/// positions widened by the tent) meet the widened grid somewhere between the first and
/// the last candidate.
pub(super) fn collect(
    design: &Design,
    images: &Images,
    grid: &CellGrid,
    radius: usize,
    zs: (f64, f64),
    n_threads: Option<usize>,
) -> Result<Micro> {
    let r = radius as f64 * grid.step;
    let [gx0, gx1, gy0, gy1] = grid.extent();
    let reach = Reach {
        lo: [gx0 - r, gy0 - r],
        hi: [gx1 + r, gy1 + r],
        h: grid.step,
        zs,
    };
    let mut out = Micro {
        channels: images.channels.len(),
        ..Micro::default()
    };
    for (n, &i) in images.channels.iter().enumerate() {
        let ch = &design.channels[i];
        let pixels = ChannelPixels {
            design,
            ch,
            n,
            i,
            raw: images.raws[n],
            white: images.whites[n],
            cols: crate::imaging::render::raw_shape(ch).1,
            centroids: centroid_rays(design, i, zs, n_threads)?,
        };
        let boxes = lens_boxes(design, ch, n_threads)?;
        let lens = |l: usize| pixels.lens(l, boxes[l], &reach);
        let step = crate::infra::parallel::chunk_items(n_threads, 64 * 64);
        for_chunks(n_threads, boxes.len(), step, |range| {
            let found: Vec<Option<(Lens, usize)>> = range.into_par_iter().map(lens).collect();
            let bytes: u128 = found.iter().flatten().map(|f| f.0.bytes()).sum();
            memory::check("the depth sweep's micro-images", out.bytes + bytes)?;
            for (lens, pixels) in found.into_iter().flatten() {
                out.boxed += lens.block.len();
                out.pixels += pixels;
                out.bytes += lens.bytes();
                out.box_max.0 = out.box_max.0.max(lens.x.len());
                out.box_max.1 = out.box_max.1.max(lens.y.len());
                out.lenses.push(lens);
            }
            Ok(())
        })?;
    }
    Ok(out)
}
