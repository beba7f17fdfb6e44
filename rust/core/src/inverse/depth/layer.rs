//! One candidate's layer of costs (docs/depth.md, steps 2 and 3): every kept lens's
//! micro-image resampled at the cell centres by tents, the lenses' spread within each cell
//! and its degrees of freedom, pooled over the window, over the channel's scale.

use super::micro::{Lens, Micro};
use super::{MIN_WEIGHT, MIN_WHITE, M_CAP};
use crate::imaging::recorder::CellGrid;
use crate::infra::error::Result;
use crate::infra::parallel::checkpoint;

/// Lenses between two checks for a stop inside a layer: a layer of few large micro-images
/// (a cut of the seed design: 160 lenses, 0.2-0.6 s a layer) must still stop within a
/// second under load; one check is an atomic load on a pool's worker.
const CHECK_EVERY_LENSES: usize = 16;

/// One axis's tents of one lens: (pixel index in the box, weight) for each cell of its
/// range, and each cell's first pair (and one past the last).
#[derive(Default)]
pub(super) struct Tents {
    pairs: Vec<(u32, f64)>,
    starts: Vec<usize>,
}

impl Tents {
    /// The pairs of the range's cell i.
    #[inline(always)]
    fn cell(&self, i: usize) -> &[(u32, f64)] {
        &self.pairs[self.starts[i]..self.starts[i + 1]]
    }
}

/// Per-worker buffers of one candidate's layer.
pub(super) struct Layer {
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
    /// One lens's tents per axis.
    tx: Tents,
    ty: Tents,
    /// The axis's finite positions of one lens, sorted, with their indices.
    sorted: Vec<(f64, u32)>,
    /// One full lens's tents summed per cell column.
    cover: Vec<f64>,
    /// Every lens's extents along X and Y at this layer's depth ([`Lens::extent`]).
    extents: Vec<LensExtents>,
}

/// A lens's extents along X and Y at one depth ([`Lens::extent`]).
type LensExtents = [Option<(f64, f64, f64)>; 2];

/// Bytes of a value of the layer's per-lens extents.
const EXTENT_BYTES: u128 = std::mem::size_of::<LensExtents>() as u128;

impl Layer {
    pub(super) fn new(ex: (usize, usize), channels: usize) -> Layer {
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
            tx: Tents::default(),
            ty: Tents::default(),
            sorted: Vec::new(),
            cover: Vec::new(),
            extents: Vec::new(),
        }
    }

    /// An upper bound of the bytes a worker's layer holds at its peak: the planes of
    /// [`Layer::new`] over the widened grid `ex` (6 of cells, 2 of prefix sums, 8 bytes
    /// each), the lenses' extents, and one lens's scratch: its box rows resampled (5 arrays
    /// of `box_rows` × the widened grid's columns at most, sized exactly), one cell row
    /// (5 × columns, sized exactly), its tents per axis (at most a pair per cell and box
    /// pixel of the axis: `box_cols` and `box_rows` pixels, 16 bytes a pair, 8 a start),
    /// its sorted positions and a full lens's coverage. A lens whose footprint spans a fine
    /// grid resamples its rows at every column: on a grid of one row that scratch is most
    /// of the sweep's memory.
    pub(super) fn bytes(
        ex: (usize, usize),
        channels: usize,
        lenses: u128,
        boxes: (u128, u128),
    ) -> u128 {
        let (ex0, ex1) = (ex.0 as u128, ex.1 as u128);
        let planes =
            6 * ex0 * ex1 * channels as u128 + 2 * (ex0 + 1) * (ex1 + 1) * channels as u128;
        let (na, nb) = boxes;
        let exact = 5 * nb * ex0 * 8 + 5 * ex0 * 8;
        let pairs = ex0 * na + ex1 * nb;
        let grown = pairs * 16 + (ex0 + ex1 + 2) * 8 + na.max(nb) * 16 + ex0 * 8;
        // Vectors grown by pushes may hold up to twice what they need.
        planes * 8 + exact + 2 * (lenses * EXTENT_BYTES + grown)
    }

    #[inline(always)]
    fn clear_sums(&mut self) {
        self.s0.fill(0.0);
        self.s1.fill(0.0);
        self.s2.fill(0.0);
        self.s3.fill(0.0);
        self.s4.fill(0.0);
        self.s5.fill(0.0);
    }
}

/// The cells along one axis: centres c0 + (i + 0.5) h · dir for i in 0..n (dir = ±1).
type AxisCells = (f64, f64, f64, usize);

/// The tents of one lens along one axis at depth z over `cells`: into `out` the (index,
/// weight) pairs of each cell of the returned range. Weights t = max(0, 1 − |x − X|/H),
/// H = max(h, spacing); (lo, hi, spacing) is the lens's extent along the axis.
#[inline(always)]
fn tents(
    pos: &[[f64; 2]],
    z: f64,
    (c0, dir, h, n): AxisCells,
    (lo, hi, s): (f64, f64, f64),
    sorted: &mut Vec<(f64, u32)>,
    out: &mut Tents,
) -> std::ops::Range<usize> {
    let (t, starts) = (&mut out.pairs, &mut out.starts);
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

/// The grid widened by the window's radius r on every side: enx × eny cells of pitch h
/// from (ex0, ey1), the top left corner.
#[derive(Clone, Copy)]
struct Widened {
    enx: usize,
    eny: usize,
    h: f64,
    ex0: f64,
    ey1: f64,
}

impl Widened {
    fn of(grid: &CellGrid, r: usize) -> Widened {
        let h = grid.step;
        Widened {
            enx: grid.nx + 2 * r,
            eny: grid.ny + 2 * r,
            h,
            ex0: grid.x0 - r as f64 * h,
            ey1: grid.y1 + r as f64 * h,
        }
    }
}

/// The layer of costs at depth z: per chosen channel, over the grid (row-major, NaN where
/// missing). Compiled twice, for the baseline and for AVX2 (chosen at run time): its loops
/// are element-wise or summed in order, and Rust never fuses a multiply and an add, so the
/// two give the same bits; AVX2 does four cells (and four divisions) at a time.
/// With `cells`, also each cell's own (unpooled) spread over the channel's scale and its
/// degrees of freedom, per channel over the widened grid (for the tilted pooling,
/// [`super::tilt`]). Stops with [`crate::Error::Interrupted`] when its call is stopped
/// (checked every [`CHECK_EVERY_LENSES`] lenses).
pub(super) fn layer(
    mi: &Micro,
    grid: &CellGrid,
    radius: usize,
    z: f64,
    buf: &mut Layer,
    out: &mut [f64],
    cells: Option<&mut [f32]>,
) -> Result<()> {
    crate::infra::simd::dispatch(
        #[inline(always)]
        |_| {
            let wd = Widened::of(grid, radius);
            buf.clear_sums();
            buf.extents.clear();
            buf.extents
                .extend(mi.lenses.iter().map(|l| [l.extent(0, z), l.extent(1, z)]));
            let keep = keep_rates(mi, &buf.extents, &wd);
            let extents = std::mem::take(&mut buf.extents);
            for (i, (l, &[ex, ey])) in mi.lenses.iter().zip(&extents).enumerate() {
                if i % CHECK_EVERY_LENSES == 0 {
                    if let Err(e) = checkpoint() {
                        buf.extents = extents;
                        return Err(e);
                    }
                }
                if l.u >= keep[l.ch] {
                    continue;
                }
                let (Some(ex), Some(ey)) = (ex, ey) else {
                    continue;
                };
                add_lens(l, (ex, ey), z, &wd, buf);
            }
            buf.extents = extents;
            let scale = costs(mi.channels, grid, radius, buf, out);
            if let Some(cells) = cells {
                cell_costs(buf, &scale, cells);
            }
            Ok(())
        },
    )
}

/// Each widened cell's own spread (over the channel's scale) and degrees of freedom, as
/// pairs, per channel: what [`costs`] pools over the window.
#[inline(always)]
fn cell_costs(buf: &Layer, scale: &[f64], cells: &mut [f32]) {
    let per = buf.s0.len() / scale.len().max(1);
    for (k, pair) in cells.chunks_exact_mut(2).enumerate() {
        let s0 = buf.s0[k];
        let (spread, dof) = if s0 > 0.0 {
            (
                (buf.s2[k] - buf.s1[k] * buf.s1[k] / s0).max(0.0) + buf.s4[k],
                (s0 - buf.s3[k] / s0).max(0.0) + buf.s5[k],
            )
        } else {
            (0.0, 0.0)
        };
        pair[0] = (spread * scale[k / per]) as f32;
        pair[1] = dof as f32;
    }
}

/// Per channel the keep rate: M_CAP over the mean number of its lenses whose footprints
/// (clipped to the widened grid) cover a cell.
#[inline(always)]
fn keep_rates(mi: &Micro, extents: &[LensExtents], wd: &Widened) -> Vec<f64> {
    let h = wd.h;
    let (wx0, wx1) = (wd.ex0, wd.ex0 + wd.enx as f64 * h);
    let (wy0, wy1) = (wd.ey1 - wd.eny as f64 * h, wd.ey1);
    let clip = |a: f64, b: f64, c: f64, d: f64| (b.min(d) - a.max(c)).max(0.0);
    let mut area = vec![0.0; mi.channels];
    for (l, &[ex, ey]) in mi.lenses.iter().zip(extents) {
        if let (Some((x0, x1, sx)), Some((y0, y1, sy))) = (ex, ey) {
            let (hx, hy) = (h.max(sx), h.max(sy));
            area[l.ch] += clip(x0 - hx, x1 + hx, wx0, wx1) * clip(y0 - hy, y1 + hy, wy0, wy1);
        }
    }
    let grid_area = (wx1 - wx0) * (wy1 - wy0);
    area.iter()
        .map(|&a| {
            if a > 0.0 {
                (M_CAP * grid_area / a).min(1.0)
            } else {
                1.0
            }
        })
        .collect()
}

/// Add one kept lens (its extents `ext` along X and Y at depth z) to the layer's sums.
#[inline(always)]
fn add_lens(
    l: &Lens,
    ext: ((f64, f64, f64), (f64, f64, f64)),
    z: f64,
    wd: &Widened,
    buf: &mut Layer,
) {
    let (ex, ey) = ext;
    let h = wd.h;
    let cols = tents(
        &l.x,
        z,
        (wd.ex0, 1.0, h, wd.enx),
        ex,
        &mut buf.sorted,
        &mut buf.tx,
    );
    if cols.is_empty() {
        return;
    }
    let rows = tents(
        &l.y,
        z,
        (wd.ey1, -1.0, h, wd.eny),
        ey,
        &mut buf.sorted,
        &mut buf.ty,
    );
    // The lens's own pixels count only where they are denser than the cells (near its
    // channel's out-of-focus plane, where they see one point): weight (1 − s/h) per axis.
    let gate = (1.0 - ex.2 / h).max(0.0) * (1.0 - ey.2 / h).max(0.0);
    resample_rows(l, cols.len(), gate > 0.0, buf);
    // A full box's coverage is (Σ t over the row tents) (Σ t over the column tents).
    if l.full {
        buf.cover.clear();
        let tx = &buf.tx;
        buf.cover.extend(
            tx.starts
                .windows(2)
                .map(|w| tx.pairs[w[0]..w[1]].iter().map(|e| e.1).sum::<f64>()),
        );
    }
    add_cells(l, (rows, cols), gate, wd, buf);
}

/// Separably, first along the rows of the box: A[b][ix] = Σ_a t_a ω[b][a] (and with t²,
/// with ω v, with ω v² / ω where `own`, and the tents over valid pixels alone) for the
/// `lx` cells of the lens's column range.
#[inline(always)]
fn resample_rows(l: &Lens, lx: usize, own: bool, buf: &mut Layer) {
    let (block, na, nb) = (&l.block, l.x.len(), l.y.len());
    let nl = nb * lx;
    if buf.a.len() < 5 * nl {
        buf.a.reserve_exact(5 * nl - buf.a.len());
        buf.a.resize(5 * nl, 0.0);
    }
    let (a1, rest) = buf.a[..5 * nl].split_at_mut(nl);
    let (a2, rest) = rest.split_at_mut(nl);
    let (a3, rest) = rest.split_at_mut(nl);
    let (a4, a5) = rest.split_at_mut(nl);
    let tx = &buf.tx;
    for b in 0..nb {
        let row = &block[b * na..(b + 1) * na];
        let o = b * lx;
        let (r1, r2, r3) = (&mut a1[o..o + lx], &mut a2[o..o + lx], &mut a3[o..o + lx]);
        for ix in 0..lx {
            let (mut s1, mut s2, mut s3) = (0.0, 0.0, 0.0);
            for &(a, wa) in tx.cell(ix) {
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
                for &(a, wa) in tx.cell(ix) {
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
                for &(a, wa) in tx.cell(ix) {
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

/// The value m = Σ t ω v / Σ t ω has the variance of a pixel of weight Ω = (Σ t ω)² /
/// Σ t² ω (each pixel's variance ∝ 1 / ω), counted in the share c = min(1, Σ t) of the
/// tents its valid pixels cover: a cell beyond the lens's last pixel is an extrapolation,
/// and its weight falls to 0 with the tent instead of jumping. Returns c Ω and c / Σ t² ω,
/// or zeros where the lens gives the cell too little weight (branch-free: such a cell adds
/// zeros).
#[inline(always)]
fn weight(w1: f64, w2: f64, cover: f64) -> (f64, f64) {
    let inv = 1.0 / w2.max(f64::MIN_POSITIVE);
    let c = cover.min(1.0);
    let om = w1 * w1 * inv * c;
    let keep = if w2 > 0.0 && om >= MIN_WHITE {
        inv * c
    } else {
        0.0
    };
    (om, keep)
}

/// Then down the columns for each cell row of the lens's range: its value and weight in
/// each cell added to the layer's sums (and, where `gate` > 0, its own pixels' spread).
#[inline(always)]
fn add_cells(
    l: &Lens,
    (rows, cols): (std::ops::Range<usize>, std::ops::Range<usize>),
    gate: f64,
    wd: &Widened,
    buf: &mut Layer,
) {
    let own = gate > 0.0;
    let lx = cols.len();
    let nl = l.y.len() * lx;
    let plane = l.ch * wd.enx * wd.eny;
    if buf.row.len() < 5 * lx {
        buf.row.reserve_exact(5 * lx - buf.row.len());
        buf.row.resize(5 * lx, 0.0);
    }
    let (a1, rest) = buf.a.split_at(nl);
    let (a2, rest) = rest.split_at(nl);
    let (a3, rest) = rest.split_at(nl);
    let (a4, a5) = rest.split_at(nl);
    for (iy, cy) in rows.enumerate() {
        let ty = buf.ty.cell(iy);
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
        let k0 = plane + cy * wd.enx + cols.start;
        let (d0, d1, d2, d3) = (
            &mut buf.s0[k0..k0 + lx],
            &mut buf.s1[k0..k0 + lx],
            &mut buf.s2[k0..k0 + lx],
            &mut buf.s3[k0..k0 + lx],
        );
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

/// The layer's costs from its sums: per channel, prefix sums of the cells' weighted spread
/// about their mean and of their degrees of freedom (for independent values of variance
/// σ² per unit weight, E[spread] = σ² (S0 − Σ Ω² / S0), so the pooled ratio is unbiased
/// however few lenses a cell has: a lone lens adds 0 to both), pooled over each cell's
/// window, over the channel's scale ([`scales`], returned).
#[inline(always)]
fn costs(nch: usize, grid: &CellGrid, r: usize, buf: &mut Layer, out: &mut [f64]) -> Vec<f64> {
    let (enx, eny) = (grid.nx + 2 * r, grid.ny + 2 * r);
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
    let scale = scales(&totals);
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
    scale
}

/// Per channel the spread of all its lens values over the widened grid at this depth
/// (from the totals Σ S0, Σ S1, Σ S2, Σ S3), inverted: the scale of a mismatch, which
/// shrinks where the lenses' pixels are far apart (their resampled micro-images are
/// smooth) or averaged.
#[inline(always)]
fn scales(totals: &[[f64; 4]]) -> Vec<f64> {
    totals
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
        .collect()
}
