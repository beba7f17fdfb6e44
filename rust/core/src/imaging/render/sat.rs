//! Closed forms of the general route on a fronto-parallel plane (docs/render.md, "The
//! interior in closed form"): the integral of an image (or constant) texture over a
//! rectangle of translates of a fixed polygon, ∫_{Q ∈ R} ∫_{u ∈ U} T(Q + u) du dQ, from the
//! texture's summed-area function S by Green's theorem: a cost in the texture cells the
//! polygon's translated boundary crosses, not in those its footprint covers.

use crate::imaging::grid::{walk, Lines};
use crate::imaging::texture::{ImageTexture, Texture};
use crate::infra::error::Result;
use crate::infra::polygon::{signed_area, Pt};
use std::sync::Mutex;

/// T = mean + T', T' an image's deviation from its mean (zero beyond the array). `n` holds
/// S(X, Y) = ∫∫_{X' < X, Y' < Y} T' at the grid's nodes (bilinear between them, constant
/// beyond the array in Y and beyond its right edge in X, zero to its left and below);
/// `cum` holds S1(X, Y) = ∫_{X' < X} S(X', Y) dX' at the nodes (the trapezoid rule of S
/// along each node row, exact as S is linear there).
pub(crate) struct SatTable {
    mean: f64,
    x0: f64,
    y0: f64,
    hx: f64,
    hy: f64,
    cols: usize,
    rows: usize,
    n: Vec<f64>,
    cum: Vec<f64>,
}

/// 2-point Gauss–Legendre on [0, 1]: exact for the cubics S1 is along a segment in a cell.
const G2_LO: f64 = 0.211_324_865_405_187_1;
const G2_HI: f64 = 0.788_675_134_594_812_9;

impl SatTable {
    /// The table of a texture the closed form handles: an image or a constant.
    pub(crate) fn of(texture: &Texture) -> Result<Option<SatTable>> {
        Ok(match texture {
            Texture::Constant(c) => Some(SatTable::constant(*c)),
            Texture::Image(im) => Some(SatTable::image(im)?),
            _ => None,
        })
    }

    fn constant(c: f64) -> SatTable {
        SatTable {
            mean: c,
            x0: 0.0,
            y0: 0.0,
            hx: 1.0,
            hy: 1.0,
            cols: 0,
            rows: 0,
            n: Vec::new(),
            cum: Vec::new(),
        }
    }

    fn image(im: &ImageTexture) -> Result<SatTable> {
        let (x0, x1, y0, y1) = im.extent();
        let (rows, cols) = im.shape();
        let (hx, hy) = ((x1 - x0) / cols as f64, (y1 - y0) / rows as f64);
        let mean = im.mean_value();
        let len = (rows + 1) * (cols + 1);
        let mut n = crate::infra::memory::try_vec("the texture's summed areas", len, 0.0)?;
        let mut cum = crate::infra::memory::try_vec("the texture's summed areas", len, 0.0)?;
        let w = cols + 1;
        for b in 0..rows {
            let row = im.row_bottom_up(b);
            let mut acc = 0.0;
            for (i, &v) in row.iter().enumerate() {
                acc += (v - mean) * hx * hy;
                n[(b + 1) * w + i + 1] = n[b * w + i + 1] + acc;
            }
        }
        for j in 0..=rows {
            for i in 0..cols {
                cum[j * w + i + 1] = cum[j * w + i] + 0.5 * hx * (n[j * w + i] + n[j * w + i + 1]);
            }
        }
        Ok(SatTable {
            mean,
            x0,
            y0,
            hx,
            hy,
            cols,
            rows,
            n,
            cum,
        })
    }

    /// The smallest side of a texture cell (0 for a constant).
    pub(crate) fn cell(&self) -> f64 {
        if self.cols == 0 {
            0.0
        } else {
            self.hx.min(self.hy)
        }
    }

    /// The node rows below and above walk row r (as offsets into the tables) and y's share
    /// between them: beyond the array in Y, S and S1 are their values on its edge.
    fn rows_at(&self, r: i64, y: f64) -> (usize, usize, f64) {
        let (r, ty) = if r < 0 {
            (0, 0.0)
        } else if r >= self.rows as i64 {
            (self.rows - 1, 1.0)
        } else {
            (r as usize, (y - r as f64).clamp(0.0, 1.0))
        };
        let w = self.cols + 1;
        (r * w, (r + 1) * w, ty)
    }

    /// S1 at (x, y) in grid units (x = (X − X0)/hx), in cell (c, r) of the walk (−1 and
    /// cols / rows beyond the array), whose cell it is up to rounding.
    fn s1(&self, c: i64, r: i64, x: f64, y: f64) -> f64 {
        let cols = self.cols as i64;
        if c < 0 {
            return 0.0;
        }
        let (j0, j1, ty) = self.rows_at(r, y);
        if c >= cols {
            let i = self.cols;
            let s = (1.0 - ty) * self.n[j0 + i] + ty * self.n[j1 + i];
            let s1 = (1.0 - ty) * self.cum[j0 + i] + ty * self.cum[j1 + i];
            return s1 + (x - cols as f64) * self.hx * s;
        }
        let i = c as usize;
        let tx = (x - c as f64).clamp(0.0, 1.0);
        let (a0, a1) = (self.n[j0 + i], self.n[j0 + i + 1]);
        let (b0, b1) = (self.n[j1 + i], self.n[j1 + i + 1]);
        let lo = self.cum[j0 + i] + self.hx * tx * (a0 + 0.5 * tx * (a1 - a0));
        let hi = self.cum[j1 + i] + self.hx * tx * (b0 + 0.5 * tx * (b1 - b0));
        (1.0 - ty) * lo + ty * hi
    }

    /// S at (x, y) in grid units, in cell (c, r) of the walk (as [`s1`](Self::s1)):
    /// bilinear in the cell, constant beyond the array in Y and beyond its right edge in X,
    /// zero to its left and below.
    fn s(&self, c: i64, r: i64, x: f64, y: f64) -> f64 {
        let cols = self.cols as i64;
        if c < 0 {
            return 0.0;
        }
        let (j0, j1, ty) = self.rows_at(r, y);
        let (i, tx) = if c >= cols {
            (self.cols - 1, 1.0)
        } else {
            (c as usize, (x - c as f64).clamp(0.0, 1.0))
        };
        let lo = self.n[j0 + i] + tx * (self.n[j0 + i + 1] - self.n[j0 + i]);
        let hi = self.n[j1 + i] + tx * (self.n[j1 + i + 1] - self.n[j1 + i]);
        (1.0 - ty) * lo + ty * hi
    }

    /// ∫ S1 dY along the segment a → b (scene coordinates), less `s1_ref` along it (a
    /// constant, whose closed integral is zero: it keeps the sum's terms small), cut at
    /// the grid's lines (the cells it crosses, by [`walk`] as `ImageTexture::edge`), each
    /// piece by the 2-point rule, exact for its cubic.
    fn edge(&self, a: Pt, b: Pt, s1_ref: f64) -> f64 {
        self.edge_of(a, b, s1_ref, |c, r, x, y| self.s1(c, r, x, y))
    }

    /// ∫ f dY along the segment a → b less `f_ref` along it, `f(c, r, x, y)` a cubic at
    /// most within a cell (S1 or S, in grid units): cut at the grid's lines, each piece by
    /// the 2-point rule.
    fn edge_of(&self, a: Pt, b: Pt, s1_ref: f64, f: impl Fn(i64, i64, f64, f64) -> f64) -> f64 {
        let (ax, ay) = ((a[0] - self.x0) / self.hx, (a[1] - self.y0) / self.hy);
        let (dx, dy) = ((b[0] - a[0]) / self.hx, (b[1] - a[1]) / self.hy);
        if dy == 0.0 {
            return 0.0;
        }
        let lines = |origin, step, cells| Lines {
            origin,
            step,
            cells,
        };
        let x = lines(self.x0, self.hx, self.cols);
        let y = lines(self.y0, self.hy, self.rows);
        let mut total = 0.0;
        walk(x, y, a, b, |c, r, t0, t1| {
            let h = t1 - t0;
            let (p, q) = (t0 + G2_LO * h, t0 + G2_HI * h);
            let v = f(c, r, ax + p * dx, ay + p * dy) + f(c, r, ax + q * dx, ay + q * dy);
            total += 0.5 * h * (v - 2.0 * s1_ref);
        });
        total * (b[1] - a[1])
    }

    /// ∫_U S(Q + u) du = ∮ S1 dY around the translate Q + U (counter-clockwise).
    pub(crate) fn over_polygon(&self, q: Pt, u: &[Pt]) -> f64 {
        self.around(q, u, false)
    }

    /// ∫_U S_Y(Q + u) du = ∮ S dY around the translate Q + U (S_Y = ∫^Y T′ dY′): the
    /// derivative in X of [`over_polygon`](Self::over_polygon), the integrand of its
    /// boundary form along an arc ([`disc_rect_polygon`](Self::disc_rect_polygon)).
    fn over_polygon_dx(&self, q: Pt, u: &[Pt]) -> f64 {
        self.around(q, u, true)
    }

    /// ∮ S1 dY (`of_s` false) or ∮ S dY (true) around Q + U, less the value at its first
    /// vertex (a constant, whose closed integral is zero: it keeps the terms small).
    fn around(&self, q: Pt, u: &[Pt], of_s: bool) -> f64 {
        let at = |k: usize| [q[0] + u[k][0], q[1] + u[k][1]];
        let p0 = at(0);
        let (c0, r0) = (
            ((p0[0] - self.x0) / self.hx).floor(),
            ((p0[1] - self.y0) / self.hy).floor(),
        );
        let clamp = |v: f64, n: usize| v.clamp(-1.0, n as f64) as i64;
        let (c0, r0) = (clamp(c0, self.cols), clamp(r0, self.rows));
        let (x, y) = ((p0[0] - self.x0) / self.hx, (p0[1] - self.y0) / self.hy);
        if of_s {
            let s_ref = self.s(c0, r0, x, y);
            (0..u.len())
                .map(|k| {
                    self.edge_of(at(k), at((k + 1) % u.len()), s_ref, |c, r, x, y| {
                        self.s(c, r, x, y)
                    })
                })
                .sum()
        } else {
            let s1_ref = self.s1(c0, r0, x, y);
            (0..u.len())
                .map(|k| self.edge(at(k), at((k + 1) % u.len()), s1_ref))
                .sum()
        }
    }

    /// ∫_{Q ∈ [X0, X1] × [Y0, Y1]} ∫_{u ∈ U} T(Q + u) du dQ for a counter-clockwise polygon
    /// U: the mean's part by area, T′'s from S at the rectangle's four corners.
    #[cfg(test)]
    pub(crate) fn rect_polygon(&self, rect: [f64; 4], u: &[Pt]) -> f64 {
        self.rect_polygon_by(rect, u, |q| self.over_polygon(q, u))
    }

    /// [`rect_polygon`](Self::rect_polygon) with `corner(Q)` standing for
    /// [`over_polygon`](Self::over_polygon)`(Q, u)` (a memo of it, [`CornerMemo`]).
    pub(crate) fn rect_polygon_by(
        &self,
        rect: [f64; 4],
        u: &[Pt],
        mut corner: impl FnMut(Pt) -> f64,
    ) -> f64 {
        let [x0, x1, y0, y1] = rect;
        let base = self.mean * (x1 - x0) * (y1 - y0) * signed_area(u);
        if self.cols == 0 {
            return base;
        }
        base + corner([x1, y1]) - corner([x0, y1]) - corner([x1, y0]) + corner([x0, y0])
    }
}

impl SatTable {
    /// ∫_{Q ∈ R ∩ C} ∫_{u ∈ U} T(Q + u) du dQ for the rectangle R = `rect` cut by the disc
    /// C = `disc` (centre, radius), a counter-clockwise polygon U. By Green's theorem it
    /// is −∮ K dX around R ∩ C, K = ∫^Y G dY the antiderivative in Y of G(Q) = ∫_U T′(Q+u)
    /// du: along R's bottom and top edges K's antiderivative in X is
    /// [`over_polygon`](Self::over_polygon) at the ends (`corner`, as in
    /// [`rect_polygon_by`](Self::rect_polygon_by)); its vertical edges give nothing; along
    /// an arc of C (X = X_C + ρ cos θ) it is ∫ ρ sin θ K dθ, K =
    /// [`over_polygon_dx`](Self::over_polygon_dx), by an adaptive 1-D Gauss rule to `tol`
    /// (smooth between its kinks, below).
    /// The arc is cut where K kinks, where a vertex of Q + U crosses a texture line (an edge
    /// of U along a line's direction crossing it makes the kink as large as K's slope: the
    /// Gauss rules' nodes could straddle it unseen). The mean's part is the mean × |U| ×
    /// the exact area of R ∩ C.
    pub(crate) fn disc_rect_polygon(
        &self,
        rect: [f64; 4],
        (centre, rho): (Pt, f64),
        u: &[Pt],
        tol: f64,
        mut corner: impl FnMut(Pt) -> f64,
    ) -> f64 {
        let [x0, x1, y0, y1] = rect;
        // The area as −∮ (Y − Y_C) dX (the shift integrates to zero around a closed curve).
        let mut area = 0.0;
        let mut total = 0.0;
        for (y, sign) in [(y0, -1.0), (y1, 1.0)] {
            let d = y - centre[1];
            if !crosses(d / rho) {
                continue;
            }
            let h = (rho * rho - d * d).sqrt();
            let (a, b) = (x0.max(centre[0] - h), x1.min(centre[0] + h));
            if b > a {
                area += sign * d * (b - a);
                if self.cols > 0 {
                    total += sign * (corner([b, y]) - corner([a, y]));
                }
            }
        }
        let arcs = arcs_inside(rect, centre, rho);
        for &(ta, tb) in &arcs {
            let sin2 = (2.0 * tb).sin() - (2.0 * ta).sin();
            area += rho * rho * (0.5 * (tb - ta) - 0.25 * sin2);
            if self.cols > 0 {
                let k = |t: f64| {
                    let q = [centre[0] + rho * t.cos(), centre[1] + rho * t.sin()];
                    rho * t.sin() * self.over_polygon_dx(q, u)
                };
                let t = tol / arcs.len() as f64;
                let cuts = self.arc_kinks(u, (centre, rho), (ta, tb));
                total += cuts
                    .windows(2)
                    .map(|w| adaptive_1d(&k, (w[0], w[1]), t * (w[1] - w[0]) / (tb - ta), 0))
                    .sum::<f64>();
            }
        }
        self.mean * area * signed_area(u) + total
    }
}

impl SatTable {
    /// The angles in [ta, tb], ends included and sorted, where the circle (centre, ρ)
    /// carries a vertex of Q + U across a line of the texture's grid.
    fn arc_kinks(&self, u: &[Pt], (centre, rho): (Pt, f64), (ta, tb): (f64, f64)) -> Vec<f64> {
        let tau = 2.0 * std::f64::consts::PI;
        let mut cuts = vec![ta, tb];
        let mut keep = |t: f64| {
            for t in [t, t + tau, t - tau] {
                if t > ta && t < tb {
                    cuts.push(t);
                }
            }
        };
        // The arc's span per axis (the chord's ends and the circle's extreme points in it).
        let span = |f: fn(f64) -> f64, c: f64| {
            let (mut lo, mut hi) = (f(ta).min(f(tb)), f(ta).max(f(tb)));
            for k in -4..=4 {
                let t = k as f64 * std::f64::consts::FRAC_PI_2;
                if t > ta && t < tb {
                    lo = lo.min(f(t));
                    hi = hi.max(f(t));
                }
            }
            (c + rho * lo, c + rho * hi)
        };
        let (xs, ys) = (span(f64::cos, centre[0]), span(f64::sin, centre[1]));
        for v in u {
            for (axis, (lo, hi)) in [(0, xs), (1, ys)] {
                let (origin, step, n) = if axis == 0 {
                    (self.x0, self.hx, self.cols)
                } else {
                    (self.y0, self.hy, self.rows)
                };
                let first = (((lo + v[axis] - origin) / step).ceil().max(0.0)) as usize;
                let last = ((hi + v[axis] - origin) / step).floor().min(n as f64);
                let mut i = first;
                while (i as f64) <= last {
                    let q = (origin + i as f64 * step - v[axis] - centre[axis]) / rho;
                    if q.abs() <= 1.0 {
                        if axis == 0 {
                            keep(q.acos());
                            keep(-q.acos());
                        } else {
                            keep(q.asin());
                            keep(std::f64::consts::PI - q.asin());
                        }
                    }
                    i += 1;
                }
            }
        }
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        cuts
    }
}

/// Does a line at signed distance d·ρ from the circle's centre cross it? Not when it is
/// tangent to 10⁻¹² of ρ (a box clipped to the aperture's square has an edge exactly
/// tangent, up to rounding): the edge's piece inside the disc and the arc between its two
/// crossings are then one decision, not two (the sliver between them is ~10⁻¹⁸ ρ²).
fn crosses(d: f64) -> bool {
    d.abs() < 1.0 - 1e-12
}

/// The arcs of the circle (centre, ρ) inside the rectangle, as angle intervals
/// (θa, θb) ⊂ [0, 2π] counter-clockwise: the circle cut where it crosses the rectangle's
/// lines, each piece kept when its middle point is inside.
fn arcs_inside(rect: [f64; 4], centre: Pt, rho: f64) -> Vec<(f64, f64)> {
    let [x0, x1, y0, y1] = rect;
    let tau = 2.0 * std::f64::consts::PI;
    let mut cuts = vec![0.0, tau];
    for x in [x0, x1] {
        let c = (x - centre[0]) / rho;
        if crosses(c) {
            let p = c.acos();
            cuts.extend([p, tau - p]);
        }
    }
    for y in [y0, y1] {
        let s = (y - centre[1]) / rho;
        if crosses(s) {
            let p = s.asin();
            cuts.extend([p.rem_euclid(tau), std::f64::consts::PI - p]);
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.windows(2)
        .filter_map(|w| {
            let (a, b) = (w[0], w[1]);
            let m = 0.5 * (a + b);
            let p = [centre[0] + rho * m.cos(), centre[1] + rho * m.sin()];
            (b > a && (x0..=x1).contains(&p[0]) && (y0..=y1).contains(&p[1])).then_some((a, b))
        })
        .collect()
}

/// Deepest halving of [`adaptive_1d`].
const MAX_DEPTH_1D: u32 = 24;

/// ∫_a^b f by the 3-point Gauss–Legendre rule, accepted when it differs from the 2-point
/// rule (exact for cubics) by at most `tol`, else over the two halves with `tol`/2 each.
fn adaptive_1d(f: &impl Fn(f64) -> f64, (a, b): (f64, f64), tol: f64, depth: u32) -> f64 {
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    let g2 = h * (f(m - h * G2_NODE) + f(m + h * G2_NODE));
    let g3 = h * (G3_W0 * f(m) + G3_W1 * (f(m - h * G3_NODE) + f(m + h * G3_NODE)));
    if (g3 - g2).abs() <= tol || depth >= MAX_DEPTH_1D {
        return g3;
    }
    adaptive_1d(f, (a, m), 0.5 * tol, depth + 1) + adaptive_1d(f, (m, b), 0.5 * tol, depth + 1)
}

/// Gauss–Legendre on [−1, 1]: the 2-point node (weights 1), the 3-point nodes and weights.
const G2_NODE: f64 = 0.577_350_269_189_625_8;
const G3_NODE: f64 = 0.774_596_669_241_483_4;
const G3_W0: f64 = 8.0 / 9.0;
const G3_W1: f64 = 5.0 / 9.0;

/// A memo of [`SatTable::over_polygon`] by the exact bits of its corner Q and of the
/// polygon's key (direct-mapped: a slot holds the last value hashed to it). The boxes of
/// neighbouring pixels of one lens share their corners bit for bit (`general::PixelAt`),
/// so a raw row's pixels take about two corners each instead of four, and a row's lower
/// corners are the next row's upper ones while the memo still holds them. A hit returns
/// the value the evaluation would give, bit for bit: the render does not depend on the
/// order its pixels are taken in.
#[derive(Default)]
pub(crate) struct CornerMemo {
    keys: Vec<[u64; 4]>,
    vals: Vec<f64>,
    /// Look-ups and hits (for the tests and benches).
    pub(crate) looks: u64,
    pub(crate) hits: u64,
}

/// log2 of the memo's slots: 2^15 slots of 40 bytes (1.3 MB a worker), about two raw rows'
/// corners of a full `lytro-illum` sensor (7,728 columns).
const MEMO_BITS: u32 = 15;

/// The memos of one render's workers, one a pool thread, kept across the rayon jobs a
/// render's rows are split into (a job's [`super::chan::Work`] takes its thread's memo and
/// puts it back when dropped): a memo lives for one render, its keys fixed by its table.
pub(crate) struct MemoShelf(Vec<Mutex<CornerMemo>>);

impl MemoShelf {
    pub(crate) fn new(threads: usize) -> MemoShelf {
        MemoShelf((0..threads.max(1)).map(|_| Mutex::default()).collect())
    }

    fn slot(&self) -> std::sync::MutexGuard<'_, CornerMemo> {
        let i = rayon::current_thread_index().unwrap_or(0) % self.0.len();
        self.0[i].lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The calling thread's memo (an empty one if another job holds it).
    pub(crate) fn take(&self) -> CornerMemo {
        std::mem::take(&mut *self.slot())
    }

    /// Give a memo back to the calling thread's slot (the fuller one stays).
    pub(crate) fn put(&self, memo: CornerMemo) {
        let mut slot = self.slot();
        if slot.keys.is_empty() {
            *slot = memo;
        }
    }
}

impl CornerMemo {
    /// The value for corner `q` of the polygon keyed `poly` (two words that fix the
    /// polygon exactly within one render), from the memo or from `eval`.
    pub(crate) fn get(&mut self, q: Pt, poly: [u64; 2], eval: impl FnOnce() -> f64) -> f64 {
        if self.keys.is_empty() {
            // Allocated on first use: renders that never take the closed form pay nothing.
            self.keys = vec![[u64::MAX; 4]; 1 << MEMO_BITS];
            self.vals = vec![0.0; 1 << MEMO_BITS];
        }
        let key = [q[0].to_bits(), q[1].to_bits(), poly[0], poly[1]];
        let mut h = 0u64;
        for w in key {
            h = (h.rotate_left(5) ^ w).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
        }
        let slot = (h >> (64 - MEMO_BITS)) as usize;
        self.looks += 1;
        if self.keys[slot] == key {
            self.hits += 1;
            return self.vals[slot];
        }
        let v = eval();
        self.keys[slot] = key;
        self.vals[slot] = v;
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against an independent sum: the midpoint rule over Q on a 240 × 240 grid of the
    /// texture's exact polygon integral ([`Texture::average`]) over Q + U, on a 3 × 4
    /// image with a hexagon straddling its edges; and a constant by area.
    #[test]
    fn rect_polygon_matches_a_fine_sum() {
        let vals: Vec<f64> = (0..12).map(|i| ((i * 7 % 5) as f64) * 0.2 + 0.1).collect();
        let im = ImageTexture::new(&vals, 3, 4, [-1.0, 3.0, -0.5, 1.0]).unwrap();
        let tex = Texture::Image(Box::new(im));
        let sat = SatTable::of(&tex).unwrap().unwrap();
        let hex: Vec<Pt> = (0..6)
            .map(|k| {
                let t = std::f64::consts::PI / 3.0 * k as f64 + 0.2;
                [0.9 * t.cos() + 0.1, 0.7 * t.sin()]
            })
            .collect();
        let rect = [-0.7, 2.9, -0.9, 0.8];
        let got = sat.rect_polygon(rect, &hex);
        let n = 240;
        let mut want = 0.0;
        let mut scratch = crate::imaging::texture::Scratch::default();
        let (dx, dy) = (
            (rect[1] - rect[0]) / n as f64,
            (rect[3] - rect[2]) / n as f64,
        );
        for i in 0..n {
            for j in 0..n {
                let q = [
                    rect[0] + (i as f64 + 0.5) * dx,
                    rect[2] + (j as f64 + 0.5) * dy,
                ];
                let p: Vec<Pt> = hex.iter().map(|v| [v[0] + q[0], v[1] + q[1]]).collect();
                want += tex.average(&p, &mut scratch) * signed_area(&p) * dx * dy;
            }
        }
        // The midpoint rule over Q of a piecewise-smooth function: error ~ (1/n)².
        assert!((got - want).abs() < 2e-4 * want.abs(), "{got} {want}");
        let c = SatTable::of(&Texture::Constant(0.3)).unwrap().unwrap();
        let area = signed_area(&hex) * 3.6 * 1.7;
        assert!((c.rect_polygon(rect, &hex) - 0.3 * area).abs() < 1e-14);
    }

    /// The hexagon of `rect_polygon_matches_a_fine_sum`, on a 3 × 4 image.
    fn hex_and_image() -> (Vec<Pt>, Texture) {
        let vals: Vec<f64> = (0..12).map(|i| ((i * 7 % 5) as f64) * 0.2 + 0.1).collect();
        let im = ImageTexture::new(&vals, 3, 4, [-1.0, 3.0, -0.5, 1.0]).unwrap();
        let hex = (0..6)
            .map(|k| {
                let t = std::f64::consts::PI / 3.0 * k as f64 + 0.2;
                [0.3 * t.cos() + 0.1, 0.2 * t.sin()]
            })
            .collect();
        (hex, Texture::Image(Box::new(im)))
    }

    /// ∫ over R ∩ C of the texture's exact polygon integral over Q + U, independently: Q's
    /// X = X_C + ρ sin φ (no square-root edge at the circle's sides) and Y across the
    /// region's height at that X, each by an n-point midpoint rule.
    fn fine_sum(tex: &Texture, rect: [f64; 4], (c, rho): (Pt, f64), u: &[Pt], n: usize) -> f64 {
        let [x0, x1, y0, y1] = rect;
        let lo = ((x0 - c[0]) / rho).clamp(-1.0, 1.0).asin();
        let hi = ((x1 - c[0]) / rho).clamp(-1.0, 1.0).asin();
        let mut scratch = crate::imaging::texture::Scratch::default();
        let mut sum = 0.0;
        for i in 0..n {
            let p = lo + (hi - lo) * (i as f64 + 0.5) / n as f64;
            let x = c[0] + rho * p.sin();
            let h = rho * p.cos();
            let (ya, yb) = (y0.max(c[1] - h), y1.min(c[1] + h));
            if yb <= ya {
                continue;
            }
            for j in 0..n {
                let y = ya + (yb - ya) * (j as f64 + 0.5) / n as f64;
                let poly: Vec<Pt> = u.iter().map(|v| [v[0] + x, v[1] + y]).collect();
                let w = rho * p.cos() * (hi - lo) / n as f64 * (yb - ya) / n as f64;
                sum += w * tex.average(&poly, &mut scratch) * signed_area(&poly);
            }
        }
        sum
    }

    /// A rectangle cut by a disc (arcs through one, two and four of its sides, a disc
    /// inside it, a disc beyond it) against the fine sum; a disc holding the rectangle is
    /// the rectangle's closed form; and on a constant texture the exact area.
    #[test]
    fn disc_rect_polygon_matches_a_fine_sum() {
        let (hex, tex) = hex_and_image();
        let sat = SatTable::of(&tex).unwrap().unwrap();
        // Translates beyond the image on every side (it spans [−1, 3] × [−0.5, 1]).
        let rect = [-1.4, 2.9, -0.8, 0.95];
        let discs = [
            ([3.3, 0.1], 0.9),    // through the right side
            ([2.6, 1.1], 0.8),    // through the top and right sides
            ([0.75, 0.075], 2.2), // through all four sides
            ([0.5, 0.0], 0.45),   // inside
            ([5.0, 3.0], 0.5),    // beyond
        ];
        // And a square: its edges along the texture's lines make K's largest kinks.
        let square = [[-0.25, -0.2], [0.25, -0.2], [0.25, 0.2], [-0.25, 0.2]];
        for u in [&hex[..], &square[..]] {
            for (c, rho) in discs {
                let got =
                    sat.disc_rect_polygon(rect, (c, rho), u, 1e-9, |q| sat.over_polygon(q, u));
                let want = fine_sum(&tex, rect, (c, rho), u, 200);
                assert!(
                    (got - want).abs() <= 1e-4 * want.abs().max(1e-3),
                    "disc {c:?} {rho}: {got} {want}"
                );
            }
        }
        // A thin box whose bottom edge is the circle's tangent, bit for bit (an outer box
        // clipped to the aperture's square): one cap, not a chord and an arc both.
        // (Y0 = p + m r with m < 0, ρ = |m| r: (Y0 − Y_C)/ρ = −1 + 1.1·10⁻¹⁶ here.)
        let (c, rho): (Pt, f64) = ([1.0, 0.931_189_343_296_763_5], 0.409_388_731_435_729_24);
        let y0: f64 = 0.521_800_611_861_034_3;
        assert!(((y0 - c[1]) / rho).abs() < 1.0);
        let cap = [0.9, 1.12, y0, y0 + 0.01];
        for u in [&hex[..], &square[..]] {
            let got = sat.disc_rect_polygon(cap, (c, rho), u, 1e-12, |q| sat.over_polygon(q, u));
            let want = fine_sum(&tex, cap, (c, rho), u, 300);
            assert!((got - want).abs() <= 1e-5 * want.abs(), "cap: {got} {want}");
        }
        let whole = sat.disc_rect_polygon(rect, ([0.75, 0.075], 5.0), &hex, 1e-12, |q| {
            sat.over_polygon(q, &hex)
        });
        assert!((whole - sat.rect_polygon(rect, &hex)).abs() < 1e-13);
        // A constant: the mean × |U| × the region's exact area (a quarter disc here).
        let k = SatTable::of(&Texture::Constant(0.3)).unwrap().unwrap();
        let quarter =
            k.disc_rect_polygon([0.0, 2.0, 0.0, 2.0], ([0.0, 0.0], 1.5), &hex, 0.0, |_| 0.0);
        let want = 0.3 * signed_area(&hex) * std::f64::consts::PI * 1.5 * 1.5 / 4.0;
        assert!((quarter - want).abs() < 1e-14, "{quarter} {want}");
    }
}
