//! Record mode on a plane (docs/reconstruct.md): one lens's share of a pixel's rays,
//! integrated over the reconstruction grid's cells in scene coordinates.
//!
//! Call P the point where a ray meets the plane Z = z0 + g · P and Z its depth there. For
//! a fixed main-lens point w, the ray through w and P crosses the array plane at the lens
//! point ξ = (L/Z)(B w − P) − c (B = 1 − Z/F + Z/L, c the lens centre), a one-to-one map of
//! Jacobian |∂ξ/∂P| = (L/Z)² (1 − g · (P − w)/Z). So the pixel's ray measure ∫∫ dξ dw over
//! a cell C of the grid is ∫_C ρ(P) dP with the footprint density
//!
//!   ρ(P) = (L/Z)² ∫_{W(P)} (1 − g · (P − w)/Z) dw,
//!
//! W(P) the main-lens points whose ray through P reaches the pixel through this lens: the
//! aperture clipped by the half-planes in w of the lens cell (ξ ∈ cell) and of the pixel
//! (σ = α ξ − (v/L) w in the pixel). W(P) is a convex polygon and the integrand is affine
//! in w, so ρ(P) is exact: area and centroid. Where B = 0 (the plane conjugate to the
//! array) or α B L/Z = v/L (the pixel in focus) a half-plane's normal vanishes and it is
//! all or nothing: ρ stays bounded (the map ξ → P always has Jacobian (L/Z)² or near it),
//! unlike the map w → P that the render's outer integral uses.
//!
//! On a fronto-parallel plane W(P) is fixed polygons translated linearly with P, so ρ is a
//! quadratic polynomial in P wherever W(P) keeps the same edges (on a tilted plane, smooth
//! there); it kinks (or, where a normal vanishes, jumps) on the lines where an edge appears
//! or vanishes. Each evaluation of ρ records W's edges (its signature). The footprint's
//! box (on a tilted plane, over the depths its rays can meet the plane at) is cut into a
//! lattice of the grid's cells, or of sub-cells when the footprint spans fewer than
//! [`MIN_NODES`] cells, and ρ is evaluated at its nodes:
//! - a sub-cell whose 3 × 3 block of nodes (itself and a neighbour each way) all see the
//!   same edges lies on one quadratic: the block's tensor rule, exact for it, integrates
//!   it without another evaluation;
//! - otherwise the 5-node rule (mean ≈ corner mean / 3 + 2/3 centre, exact for cubics),
//!   exact when the 5 nodes agree; when they do not, the sub-cell is quartered, the
//!   quarters' rules accepted when they agree with the whole's to the sub-cell's share of
//!   [`TOL`] (not before [`MIN_ACCEPT`] quarterings), else quartered again, up to
//!   [`MAX_DEPTH`] times.
//!
//! Where a half-plane of the pixel or the lens cell is axis-aligned and sweeps across the
//! rays' main-lens points within less than a sub-cell of P (the pixel nearly in focus on
//! the plane, or a pixel that sees a small part of the aperture behind a sharply imaged
//! lens edge), ρ nearly jumps: the lattice gets two node lines a hair (1e-7 sub-cells)
//! either side of the jump, so that no node sits on it.
//!
//! Lit nodes off the grid mean rays off the grid: the row is not kept ([`Recorder::lose`]).
//! Measured: row sums within 1e-5 of the exact ray measure on the seed (fronto-parallel
//! and tilted planes, footprint_integrates_to_the_ray_measure); on the seed's rect design
//! at 1 m, entries within 1.7e-5 (L1 over a row, of the row's sum) of the exact route's.

use super::Chan;
use crate::imaging::recorder::Recorder;
use crate::imaging::scene::DepthMap;
use crate::infra::polygon::Pt;
use crate::model::design::Aperture;

/// Quarterings before the refined rule may be accepted on its agreement with the coarser
/// one: the two can agree by chance on a sub-cell that an edge of W crosses (measured on
/// the seed at 650 mm, tilts (0.6, 1.0) and (-20, 0), cells of 0.06 mm: row sums off by up
/// to 5.3e-4 when accepted at once, 1.6e-5 and 9.2e-5 from the second quartering on).
pub(crate) const MIN_ACCEPT: u32 = 2;
/// Most quarterings of a (sub-)cell whose nodes see different edges of W.
pub(crate) const MAX_DEPTH: u32 = 6;
/// Error target of a pixel's row per lens, relative to its ray measure (split evenly
/// over the sub-cells; only those whose nodes see different edges of W spend it).
pub(crate) const TOL: f64 = 1e-4;
/// Fewest sub-cells per axis across a pixel's footprint box.
pub(crate) const MIN_NODES: f64 = 6.0;
/// Half the width of the sliver about a line where ρ jumps, in sub-cells.
const SLIVER: f64 = 1e-7;
/// Most sub-cells per cell and axis.
const MAX_SUB: usize = 64;

/// Edge labels (bit numbers of a node's signature): the square aperture's four edges,
/// the lens cell's six (a rect cell uses four), the pixel's four, the disc's polygon.
const AP: u8 = 0;
const CELL: u8 = 4;
const PIX: u8 = 10;
const DISC: u8 = 14;
/// A node not evaluated yet.
const UNSET: u32 = u32::MAX;

/// Per-worker buffers.
#[derive(Default)]
pub(crate) struct Scratch {
    a: Vec<(Pt, u8)>,
    b: Vec<(Pt, u8)>,
    /// Corner nodes of the sub-cell lattice: (ρ, signature).
    nodes: Vec<(f64, u32)>,
    /// The lattice's node lines.
    xs: Vec<f64>,
    ys: Vec<f64>,
    /// Extra node lines per axis (`Lens::sharp_lines`).
    extra: [Vec<f64>; 2],
}

/// The surface a footprint is taken on: the plane Z = z0 + g · P, or a depth map that
/// every ray meets at most once ([`DepthMap::seen_once`]), continued beyond its extent
/// ([`DepthMap::depth_grad`]) only to find the rays that miss it.
#[derive(Clone, Copy)]
pub(crate) enum Surf<'m> {
    Plane { z0: f64, g: Pt },
    Map(&'m DepthMap),
}

/// One pixel seen through one lens on one surface.
struct Lens<'a> {
    chan: &'a Chan<'a>,
    c: Pt,
    alpha: f64,
    /// The pixel's σ range per axis.
    lo: Pt,
    hi: Pt,
    surf: Surf<'a>,
    /// The lens cell as half-planes n · ξ ≤ d (n, d + n · c).
    cell: Vec<(Pt, f64)>,
}

/// Clip the labelled convex polygon `src` by a · w ≤ b into `out` (Sutherland–Hodgman;
/// each vertex carries the label of the edge that leaves it).
fn clip(src: &[(Pt, u8)], out: &mut Vec<(Pt, u8)>, a: Pt, b: f64, label: u8) {
    out.clear();
    let n = src.len();
    for i in 0..n {
        let (p, l) = src[i];
        let (q, _) = src[(i + 1) % n];
        let fp = b - (a[0] * p[0] + a[1] * p[1]);
        let fq = b - (a[0] * q[0] + a[1] * q[1]);
        let cut = |t: f64| [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])];
        if fp >= 0.0 {
            out.push((p, l));
            if fq < 0.0 {
                out.push((cut(fp / (fp - fq)), label));
            }
        } else if fq >= 0.0 {
            out.push((cut(fp / (fp - fq)), l));
        }
    }
}

impl<'a> Lens<'a> {
    fn new(chan: &'a Chan<'a>, c: Pt, alpha: f64, e: Pt, surf: Surf<'a>) -> Lens<'a> {
        let mu = chan.ch.mu;
        let cell = chan
            .cell
            .iter()
            .enumerate()
            .map(|(i, &u)| {
                let v = chan.cell[(i + 1) % chan.cell.len()];
                let n = [v[1] - u[1], u[0] - v[0]];
                let d = n[0] * u[0] + n[1] * u[1];
                (n, d + n[0] * c[0] + n[1] * c[1])
            })
            .collect();
        Lens {
            chan,
            c,
            alpha,
            lo: [-e[0] - mu / 2.0, -e[1] - mu / 2.0],
            hi: [-e[0] + mu / 2.0, -e[1] + mu / 2.0],
            surf,
            cell,
        }
    }
}

impl Lens<'_> {
    /// The surface's depth at P.
    fn depth(&self, p: Pt) -> f64 {
        self.depth_grad(p).0
    }

    /// The surface's depth and gradient at P.
    fn depth_grad(&self, p: Pt) -> (f64, Pt) {
        match self.surf {
            Surf::Plane { z0, g } => (z0 + g[0] * p[0] + g[1] * p[1], g),
            Surf::Map(m) => m.depth_grad(p),
        }
    }

    /// W(P) at depth z = Z(P) into `s.a`, a counter-clockwise polygon each of whose
    /// vertices carries the label of the edge that leaves it; false when W(P) is empty.
    fn w_set(&self, p: Pt, z: f64, s: &mut Scratch) -> bool {
        let chan = self.chan;
        let l = chan.ch.l;
        let gl = z / l;
        let bz = 1.0 - z / chan.f_main + z / l;
        // The axis-aligned constraints make a box (each side labelled with the constraint
        // it comes from); the slanted ones clip it.
        let rb = chan.aperture_box();
        let mut lo = [(-rb, AP + 3), (-rb, AP)];
        let mut hi = [(rb, AP + 1), (rb, AP + 2)];
        let mut slanted = [([0.0; 2], 0.0, 0u8); 6];
        let mut ns = 0;
        // a · w ≤ b, labelled: a bound, a slanted half-plane or all or nothing.
        let mut half = |a: Pt, b: f64, lab: u8| -> bool {
            if a[1] == 0.0 || a[0] == 0.0 {
                let i = if a[1] == 0.0 { 0 } else { 1 };
                if a[i] > 0.0 {
                    let v = b / a[i];
                    if v < hi[i].0 {
                        hi[i] = (v, lab);
                    }
                } else if a[i] < 0.0 {
                    let v = b / a[i];
                    if v > lo[i].0 {
                        lo[i] = (v, lab);
                    }
                } else if b < 0.0 {
                    return false;
                }
            } else {
                slanted[ns] = (a, b, lab);
                ns += 1;
            }
            true
        };
        for (k, &(n, d)) in self.cell.iter().enumerate() {
            // n · ξ ≤ d with ξ = (B w − P)/gl − c: B n · w ≤ gl (d + n · c) + n · P.
            let b = gl * d + n[0] * p[0] + n[1] * p[1];
            if !half([bz * n[0], bz * n[1]], b, CELL + k as u8) {
                return false;
            }
        }
        // σ_i = k w_i − α (P_i/gl + c_i) in [lo_i, hi_i].
        let k = self.alpha * bz / gl - chan.vl;
        for i in 0..2 {
            let o = self.alpha * (p[i] / gl + self.c[i]);
            let mut n = [0.0; 2];
            n[i] = k;
            if !half(n, self.hi[i] + o, PIX + 2 * i as u8) {
                return false;
            }
            n[i] = -k;
            if !half(n, -(self.lo[i] + o), PIX + 2 * i as u8 + 1) {
                return false;
            }
        }
        if !(hi[0].0 > lo[0].0 && hi[1].0 > lo[1].0) {
            return false;
        }
        let (a, b) = (&mut s.a, &mut s.b);
        a.clear();
        // Counter-clockwise from the lower left; each vertex labels the edge leaving it.
        a.extend_from_slice(&[
            ([lo[0].0, lo[1].0], lo[1].1),
            ([hi[0].0, lo[1].0], hi[0].1),
            ([hi[0].0, hi[1].0], hi[1].1),
            ([lo[0].0, hi[1].0], lo[0].1),
        ]);
        for &(n, d, lab) in &slanted[..ns] {
            clip(a, b, n, d, lab);
            std::mem::swap(a, b);
            if a.len() < 3 {
                return false;
            }
        }
        if chan.shape == Aperture::Circle {
            clip_disc(chan, a, b);
            if a.len() < 3 {
                return false;
            }
        }
        true
    }

    /// ρ(P) (before the channel's norm) and the signature of W(P): the bits of the labels
    /// of its edges (0 and 0 when W(P) is empty).
    fn eval(&self, p: Pt, s: &mut Scratch) -> (f64, u32) {
        let (z, grad) = self.depth_grad(p);
        if !self.w_set(p, z, s) {
            return (0.0, 0);
        }
        let l = self.chan.ch.l;
        let a = &s.a;
        // Area, first moment and the labels of the edges of non-zero length.
        let (mut ar, mut mx, mut my) = (0.0, 0.0, 0.0);
        let o = a[0].0;
        let (bx0, bx1, by0, by1) = a.iter().fold(
            (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ),
            |(x0, x1, y0, y1), (q, _)| (x0.min(q[0]), x1.max(q[0]), y0.min(q[1]), y1.max(q[1])),
        );
        let eps = 1e-12 * (bx1 - bx0).max(by1 - by0);
        let mut sig = 0u32;
        let n = a.len();
        for i in 0..n {
            let (q0, lab) = a[i];
            let q1 = a[(i + 1) % n].0;
            let (x0, y0, x1, y1) = (q0[0] - o[0], q0[1] - o[1], q1[0] - o[0], q1[1] - o[1]);
            let cr = x0 * y1 - x1 * y0;
            ar += cr;
            mx += (x0 + x1) * cr;
            my += (y0 + y1) * cr;
            if (q1[0] - q0[0]).abs() > eps || (q1[1] - q0[1]).abs() > eps {
                sig |= 1 << lab;
            }
        }
        let area = 0.5 * ar;
        if area <= 0.0 {
            return (0.0, 0);
        }
        let jac = (l / z) * (l / z);
        let f = if grad == [0.0, 0.0] {
            area
        } else {
            // ∫ (1 − g · (P − w)/Z) dw = area (1 − g · (P − w̄)/Z), g the local gradient (on
            // a depth map the ray map's Jacobian is the tangent plane's).
            let wbar = [o[0] + mx / (3.0 * ar), o[1] + my / (3.0 * ar)];
            area * (1.0 - (grad[0] * (p[0] - wbar[0]) + grad[1] * (p[1] - wbar[1])) / z)
        };
        (jac * f, sig)
    }

    /// Per axis, the pixel's 1-D ray set through the lens, (ξ_i, w_i) in the cell's and the
    /// aperture's boxes with α ξ_i − (v/L) w_i in the pixel (the 2-D set relaxed: the cell
    /// to its bounding box, a disc to its square); None when either is empty.
    fn axis_sets(&self) -> Option<[Vec<Pt>; 2]> {
        let chan = self.chan;
        let h = [chan.hx, chan.hy];
        let r = chan.r_ap;
        let (mut a, mut b) = (Vec::with_capacity(8), Vec::with_capacity(8));
        let mut out: [Vec<Pt>; 2] = Default::default();
        for i in 0..2 {
            a.clear();
            a.extend_from_slice(&[
                ([-h[i], -r], 0),
                ([h[i], -r], 0),
                ([h[i], r], 0),
                ([-h[i], r], 0),
            ]);
            clip(&a, &mut b, [self.alpha, -chan.vl], self.hi[i], 0);
            clip(&b, &mut a, [-self.alpha, chan.vl], -self.lo[i], 0);
            if labelled_area(&a) <= 0.0 {
                return None;
            }
            out[i] = a.iter().map(|v| v.0).collect();
        }
        Some(out)
    }

    /// The box of scene points [X0, X1, Y0, Y1] that the rays of `sets` can meet between
    /// depths z1 and z2 (a ray's point P(Z) = B(Z) w − (Z/L)(c + ξ) is affine in Z and in
    /// the ray).
    fn reach(&self, sets: &[Vec<Pt>; 2], z1: f64, z2: f64) -> [f64; 4] {
        let chan = self.chan;
        let mut out = [0.0; 4];
        for (i, set) in sets.iter().enumerate() {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for z in [z1, z2] {
                let bz = 1.0 - z / chan.f_main + z / chan.ch.l;
                let gl = z / chan.ch.l;
                for q in set {
                    let p = bz * q[1] - gl * (self.c[i] + q[0]);
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            }
            out[2 * i] = lo;
            out[2 * i + 1] = hi;
        }
        out
    }

    /// Per axis, the scene coordinates of the lines where ρ turns from all to nothing
    /// within `q` (per axis) at depth z: an axis-aligned edge of the pixel or the lens cell
    /// whose half-plane in w sweeps across the rays' main-lens points (their range `wr`
    /// per axis) over less than q of P. The pixel's edge σ_i = k w_i − α (P_i/gl + c_i)
    /// (k = α B/gl − v/L) moves over gl |k| |wr|/|α| of P_i; the cell's, B n_i w_i ≤
    /// gl d + n_i P_i, over |B| |wr|. Each line is taken at the range's middle w.
    fn sharp_lines(&self, z: f64, q: [f64; 2], wr: [[f64; 2]; 2], out: &mut [Vec<f64>; 2]) {
        let chan = self.chan;
        let gl = z / chan.ch.l;
        let bz = 1.0 - z / chan.f_main + z / chan.ch.l;
        let k = self.alpha * bz / gl - chan.vl;
        for i in 0..2 {
            out[i].clear();
            let (width, mid) = (wr[i][1] - wr[i][0], 0.5 * (wr[i][0] + wr[i][1]));
            if self.alpha != 0.0 && gl * k.abs() * width / self.alpha.abs() < q[i] {
                for e in [self.lo[i], self.hi[i]] {
                    out[i].push((gl / self.alpha) * (k * mid - e) - gl * self.c[i]);
                }
            }
            if bz.abs() * width < q[i] {
                for &(n, d) in &self.cell {
                    if n[1 - i] == 0.0 && n[i] != 0.0 {
                        out[i].push(bz * mid - gl * d / n[i]);
                    }
                }
            }
        }
    }

    /// Bounds on the depth at which the rays of `sets` meet the plane: Z = (z0 + g · w) /
    /// (1 + g · a), a = w/F + (c + ξ − w)/L the ray's slope, with numerator and denominator
    /// bounded over the sets (interval arithmetic); None when the denominator may vanish.
    fn hit_depths(&self, sets: &[Vec<Pt>; 2]) -> Option<(f64, f64)> {
        let Surf::Plane { z0, g: grad } = self.surf else {
            return None;
        };
        let chan = self.chan;
        let (f, l) = (chan.f_main, chan.ch.l);
        let (mut num, mut den) = ([z0, z0], [1.0, 1.0]);
        for (i, set) in sets.iter().enumerate() {
            let g = grad[i];
            let range = |v: &dyn Fn(&Pt) -> f64| {
                let (lo, hi) = set
                    .iter()
                    .map(v)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                        (a.min(x), b.max(x))
                    });
                if g >= 0.0 {
                    [g * lo, g * hi]
                } else {
                    [g * hi, g * lo]
                }
            };
            let w = range(&|q: &Pt| q[1]);
            let a = range(&|q: &Pt| q[1] / f + (self.c[i] + q[0] - q[1]) / l);
            num = [num[0] + w[0], num[1] + w[1]];
            den = [den[0] + a[0], den[1] + a[1]];
        }
        if den[0].is_nan() || den[0] <= 0.0 {
            return None;
        }
        let q = [
            num[0] / den[0],
            num[0] / den[1],
            num[1] / den[0],
            num[1] / den[1],
        ];
        Some((
            q.iter().copied().fold(f64::INFINITY, f64::min),
            q.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ))
    }
}

/// The range of main-lens points w per axis over the 1-D ray sets.
fn w_ranges(sets: &[Vec<Pt>; 2]) -> [[f64; 2]; 2] {
    sets.each_ref().map(|set| {
        set.iter()
            .fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], q| {
                [a.min(q[1]), b.max(q[1])]
            })
    })
}

/// The signed area of a labelled polygon.
fn labelled_area(p: &[(Pt, u8)]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i].0, p[(i + 1) % n].0);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        * 0.5
}

/// Clip the labelled polygon `a` by the disc's equal-area polygon (the render's, radius
/// r_ap about the aperture's centre), `b` a buffer; a quick accept when every vertex lies
/// in its inscribed circle.
fn clip_disc(chan: &Chan, a: &mut Vec<(Pt, u8)>, b: &mut Vec<(Pt, u8)>) {
    let ngon = &chan.ngon;
    let n = ngon.len();
    let r = chan.r_ap;
    let inscribed = r * ngon[0][0] * (std::f64::consts::PI / n as f64).cos();
    if a.iter()
        .all(|(p, _)| p[0] * p[0] + p[1] * p[1] <= inscribed * inscribed)
    {
        return;
    }
    for i in 0..n {
        let (u, v) = (ngon[i], ngon[(i + 1) % n]);
        // Left of the edge u → v: e_y w_x − e_x w_y ≤ e_y u_x − e_x u_y (scaled by r).
        let e = [v[0] - u[0], v[1] - u[1]];
        let nrm = [e[1], -e[0]];
        let d = r * (nrm[0] * u[0] + nrm[1] * u[1]);
        if a.iter().all(|(p, _)| nrm[0] * p[0] + nrm[1] * p[1] <= d) {
            continue;
        }
        clip(a, b, nrm, d, DISC);
        std::mem::swap(a, b);
        if a.len() < 3 {
            return;
        }
    }
}

/// Record one lens's share of a pixel (lens centre c, type α, e = m c − s the pixel's
/// offset) on the surface `surf` into `rec`: each grid cell's ∫ ρ. A lit node off the grid
/// (or off a depth map's extent, where the rays miss the surface), or on a tilted plane
/// rays that cannot meet it on the grid or its margin, mark the row as not kept.
pub(crate) fn record(
    chan: &Chan,
    c: Pt,
    alpha: f64,
    e: Pt,
    surf: Surf,
    rec: &mut Recorder,
    s: &mut Scratch,
) {
    if rec.lost() {
        return;
    }
    let lens = Lens::new(chan, c, alpha, e, surf);
    let Some(sets) = lens.axis_sets() else {
        return;
    };
    let grid = *rec.grid();
    let mut keep = grid.extent();
    if let Surf::Plane { z0, g: [0.0, 0.0] } = surf {
        let bx = lens.reach(&sets, z0, z0);
        integrate(&lens, bx, bx, keep, w_ranges(&sets), rec, s);
        return;
    }
    // A tilted plane or a depth map. A ray of the pixel that meets the surface on the grid
    // does so at a depth in the surface's range over the grid and in the rays' bounds;
    // and if some of the rays meet it on the grid and some off it, some meet it just off
    // the grid's edge (the hits are connected), at depths in the range over the grid
    // widened by a margin. The footprint's box over those depths, cut to the grid widened
    // by the margin, holds both.
    let m = grid.step;
    let [x0, x1, y0, y1] = keep;
    let wide = [x0 - m, x1 + m, y0 - m, y1 + m];
    let (mut z1, mut z2) = match surf {
        Surf::Plane { .. } => {
            let d = [
                [wide[0], wide[2]],
                [wide[0], wide[3]],
                [wide[1], wide[2]],
                [wide[1], wide[3]],
            ]
            .map(|p| lens.depth(p));
            (
                d.iter().copied().fold(f64::INFINITY, f64::min),
                d.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        }
        Surf::Map(dm) => {
            // The map's range over the widened grid (its continuation beyond the extent
            // stays in the extent's range), then twice over the footprint's box in that
            // range (the hits lie in it, so their depths in the map's range there); rays
            // that land beyond the extent miss the surface.
            let Some(k) = meet(keep, dm.extent()) else {
                rec.lose();
                return;
            };
            keep = k;
            let mut zr = dm.range_over(wide);
            for _ in 0..2 {
                let Some(b) = meet(lens.reach(&sets, zr.0, zr.1), wide) else {
                    break;
                };
                zr = dm.range_over(b);
            }
            zr
        }
    };
    if let Some((h1, h2)) = lens.hit_depths(&sets) {
        (z1, z2) = (z1.max(h1), z2.min(h2));
    }
    if z1.is_nan() || z2.is_nan() || z1 > z2 {
        // The rays meet the surface off the grid and its margin.
        rec.lose();
        return;
    }
    let Some(bx) = meet(lens.reach(&sets, z1, z2), wide) else {
        rec.lose();
        return;
    };
    // The lattice is sized by the footprint at the middle depth.
    let zm = 0.5 * (z1 + z2);
    integrate(
        &lens,
        bx,
        lens.reach(&sets, zm, zm),
        keep,
        w_ranges(&sets),
        rec,
        s,
    );
}

/// The common part of two boxes [X0, X1, Y0, Y1], if it has an interior.
fn meet(a: [f64; 4], b: [f64; 4]) -> Option<[f64; 4]> {
    let m = [
        a[0].max(b[0]),
        a[1].min(b[1]),
        a[2].max(b[2]),
        a[3].min(b[3]),
    ];
    (m[0] < m[1] && m[2] < m[3]).then_some(m)
}

/// ∫ ρ over each grid cell (and sub-cell lattice) that meets the box `bx`, into `rec`; the
/// lattice's pitch set by the footprint box `size`.
fn integrate(
    lens: &Lens,
    bx: [f64; 4],
    size: [f64; 4],
    keep: [f64; 4],
    wr: [[f64; 2]; 2],
    rec: &mut Recorder,
    s: &mut Scratch,
) {
    let grid = *rec.grid();
    let h = grid.step;
    let [gx0, _, _, gy1] = grid.extent();
    let sub = |w: f64| ((h * MIN_NODES / w).ceil() as usize).clamp(1, MAX_SUB);
    let (sx, sy) = (sub(size[1] - size[0]), sub(size[3] - size[2]));
    let (qx, qy) = (h / sx as f64, h / sy as f64);
    // Node lines: the sub-cell lattice (X from gx0, Y down from gy1) over the box, and the
    // lines where the pixel's edges fall when the pixel is so nearly in focus on the plane
    // that its half-planes turn from all to nothing within a sub-cell (ρ nearly jumps
    // there: a node line on the jump leaves each side smooth).
    let (mut xs, mut ys) = (std::mem::take(&mut s.xs), std::mem::take(&mut s.ys));
    xs.clear();
    ys.clear();
    let i0 = ((bx[0] - gx0) / qx).floor() as i64;
    let i1 = ((bx[1] - gx0) / qx).ceil() as i64;
    let j0 = ((gy1 - bx[3]) / qy).floor() as i64;
    let j1 = ((gy1 - bx[2]) / qy).ceil() as i64;
    xs.extend((i0..=i1).map(|i| gx0 + i as f64 * qx));
    ys.extend((j0..=j1).map(|j| gy1 - j as f64 * qy));
    let zc = lens.depth([0.5 * (bx[0] + bx[1]), 0.5 * (bx[2] + bx[3])]);
    let mut extra = std::mem::take(&mut s.extra);
    lens.sharp_lines(zc, [qx, qy], wr, &mut extra);
    if let Surf::Map(m) = lens.surf {
        // A depth map's gradient jumps on its sample-centre lines: those no finer than the
        // lattice join the lines above.
        for (axis, lines, q) in [(0, &xs, qx), (1, &ys, qy)] {
            let (first, step, n) = m.creases(axis);
            if step < q {
                continue;
            }
            let (a, b) = (lines[0], lines[lines.len() - 1]);
            let (lo, hi) = (a.min(b), a.max(b));
            let k0 = ((lo - first) / step).ceil().max(0.0) as usize;
            extra[axis].extend(
                (k0..n)
                    .map(|k| first + k as f64 * step)
                    .take_while(|&t| t < hi),
            );
        }
    }
    // Each such line as two a hair apart: the jump falls in a sliver between them (its
    // measure negligible), not on a node, whose value would be one side's.
    for (lines, e, q) in [(&mut xs, &extra[0], qx), (&mut ys, &extra[1], qy)] {
        let (a, b) = (lines[0], lines[lines.len() - 1]);
        let (lo, hi) = (a.min(b), a.max(b));
        let eps = SLIVER * q;
        lines.extend(
            e.iter()
                .flat_map(|&t| [t - eps, t + eps])
                .filter(|&t| t > lo && t < hi),
        );
    }
    s.extra = extra;
    xs.sort_by(f64::total_cmp);
    xs.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * qx);
    ys.sort_by(|a, b| b.total_cmp(a));
    ys.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * qy);
    let (ni, nj) = (xs.len() - 1, ys.len() - 1);
    let mut nodes = std::mem::take(&mut s.nodes);
    nodes.clear();
    nodes.resize((ni + 1) * (nj + 1), (0.0, UNSET));
    let idx = |i: usize, j: usize| j * (ni + 1) + i;
    // The nodes off the grid (or a depth map's extent) first: light at any of them and
    // the row cannot be kept.
    let [ex0, ex1, ey0, ey1] = keep;
    let mut lost = false;
    if bx[0] < ex0 || bx[1] > ex1 || bx[2] < ey0 || bx[3] > ey1 {
        'off: for j in 0..=nj {
            for i in 0..=ni {
                let p = [xs[i], ys[j]];
                if p[0] < ex0 || p[0] > ex1 || p[1] < ey0 || p[1] > ey1 {
                    let n = lens.eval(p, s);
                    if n.0 > 0.0 {
                        lost = true;
                        break 'off;
                    }
                    nodes[idx(i, j)] = n;
                }
            }
        }
    }
    if lost {
        rec.lose();
    } else {
        for j in 0..=nj {
            for i in 0..=ni {
                if nodes[idx(i, j)].1 == UNSET {
                    nodes[idx(i, j)] = lens.eval([xs[i], ys[j]], s);
                }
            }
        }
        cells(lens, &xs, &ys, &nodes, [qx, qy], rec, s);
    }
    s.nodes = nodes;
    s.xs = xs;
    s.ys = ys;
}

/// ∫ ρ over each interval box of the node lines `xs` (ascending) and `ys` (descending)
/// from the nodes' values, into `rec` (each box in the grid cell holding its centre).
fn cells(
    lens: &Lens,
    xs: &[f64],
    ys: &[f64],
    nodes: &[(f64, u32)],
    [qx, qy]: [f64; 2],
    rec: &mut Recorder,
    s: &mut Scratch,
) {
    let grid = *rec.grid();
    let h = grid.step;
    let [gx0, _, _, gy1] = grid.extent();
    let (ni, nj) = (xs.len() - 1, ys.len() - 1);
    let at = |i: usize, j: usize| nodes[j * (ni + 1) + i];
    let norm = rec.norm;
    // The error budget of a sub-cell whose corners see different edges of W: an equal
    // share of TOL times the footprint's measure (the lattice's estimate).
    let mass: f64 = nodes.iter().map(|n| n.0).sum::<f64>() * qx * qy;
    let kinked = (0..nj)
        .flat_map(|j| (0..ni).map(move |i| (i, j)))
        .filter(|&(i, j)| {
            let s0 = at(i, j).1;
            at(i + 1, j).1 != s0 || at(i, j + 1).1 != s0 || at(i + 1, j + 1).1 != s0
        })
        .count();
    let tol = TOL * mass / kinked.max(1) as f64;
    // Weights of the three equally spaced nodes k0, k0 + 1, k0 + 2 for the interval between
    // the first two (pos 0) or the last two (pos 1): exact for quadratics.
    const W3: [[f64; 3]; 2] = [
        [5.0 / 12.0, 8.0 / 12.0, -1.0 / 12.0],
        [-1.0 / 12.0, 8.0 / 12.0, 5.0 / 12.0],
    ];
    let even = |v: &[f64], k: usize| {
        let (a, b) = (v[k + 1] - v[k], v[k + 2] - v[k + 1]);
        (a - b).abs() <= 1e-9 * a.abs()
    };
    for j in 0..nj {
        for i in 0..ni {
            let cs = [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)];
            let (dx, dy) = (xs[i + 1] - xs[i], ys[j] - ys[j + 1]);
            let s0 = cs[0].1;
            let mut v = None;
            if cs.iter().all(|n| n.1 == s0) {
                // A 3 × 3 block of evenly spaced nodes around the sub-cell that all see the
                // same edges: one quadratic there (on a fronto-parallel plane), integrated
                // exactly.
                let bxs = [
                    (i + 2 <= ni && even(xs, i)).then_some((i, 0)),
                    (i >= 1 && even(xs, i - 1)).then(|| (i - 1, 1)),
                ];
                let bys = [
                    (j + 2 <= nj && even(ys, j)).then_some((j, 0)),
                    (j >= 1 && even(ys, j - 1)).then(|| (j - 1, 1)),
                ];
                let block = |(bi, pi): (usize, usize), (bj, pj): (usize, usize)| {
                    let mut acc = 0.0;
                    for (b, wy) in W3[pj].iter().enumerate() {
                        for (a, wx) in W3[pi].iter().enumerate() {
                            let n = at(bi + a, bj + b);
                            if n.1 != s0 {
                                return None;
                            }
                            acc += wx * wy * n.0;
                        }
                    }
                    Some(if s0 == 0 { 0.0 } else { acc * dx * dy })
                };
                v = bxs
                    .iter()
                    .flatten()
                    .flat_map(|&x| bys.iter().flatten().map(move |&y| (x, y)))
                    .find_map(|(x, y)| block(x, y));
            }
            let v = match v {
                Some(v) => v,
                None => {
                    let (x0, x1, ya, yb) = (xs[i], xs[i + 1], ys[j], ys[j + 1]);
                    let mid = lens.eval([0.5 * (x0 + x1), 0.5 * (ya + yb)], s);
                    cell_rule(lens, (x0, x1, yb, ya), cs, mid, 0, tol, s)
                }
            };
            if v != 0.0 {
                let col = ((0.5 * (xs[i] + xs[i + 1]) - gx0) / h).floor() as i64;
                let row = ((gy1 - 0.5 * (ys[j] + ys[j + 1])) / h).floor() as i64;
                rec.add_cell(col, row, norm * v);
            }
        }
    }
}

/// The 5-node rule on a box of area `area`: corners `cs`, centre `mid`.
fn rule(area: f64, cs: &[(f64, u32); 4], mid: (f64, u32)) -> f64 {
    area * ((cs[0].0 + cs[1].0 + cs[2].0 + cs[3].0) / 12.0 + mid.0 * (2.0 / 3.0))
}

/// Do the corners and the centre see the same edges of W?
fn same(cs: &[(f64, u32); 4], mid: (f64, u32)) -> bool {
    cs.iter().all(|n| n.1 == mid.1)
}

/// ∫ ρ over the box [x0, x1] × [y0, y1] given its corners' nodes (x0 y1, x1 y1, x0 y0,
/// x1 y0: the lattice's top row first) and centre: the 5-node rule when the nodes see the
/// same edges of W; otherwise the sum of the rule over the four quarters, accepted when it
/// is within `tol` of the whole box's rule, else each quarter whose nodes disagree is
/// refined the same way with half the tolerance, to [`MAX_DEPTH`] quarterings.
fn cell_rule(
    lens: &Lens,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    cs: [(f64, u32); 4],
    mid: (f64, u32),
    depth: u32,
    tol: f64,
    s: &mut Scratch,
) -> f64 {
    let area = (x1 - x0) * (y1 - y0);
    let whole = rule(area, &cs, mid);
    if same(&cs, mid) || depth >= MAX_DEPTH {
        return whole;
    }
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let top = lens.eval([xm, y1], s);
    let bot = lens.eval([xm, y0], s);
    let left = lens.eval([x0, ym], s);
    let right = lens.eval([x1, ym], s);
    let boxes = [
        (x0, xm, ym, y1),
        (xm, x1, ym, y1),
        (x0, xm, y0, ym),
        (xm, x1, y0, ym),
    ];
    let corners = [
        [cs[0], top, left, mid],
        [top, cs[1], mid, right],
        [left, mid, cs[2], bot],
        [mid, right, bot, cs[3]],
    ];
    let mut mids = [(0.0, 0u32); 4];
    let mut parts = [0.0; 4];
    for q in 0..4 {
        let b = boxes[q];
        mids[q] = lens.eval([0.5 * (b.0 + b.1), 0.5 * (b.2 + b.3)], s);
        parts[q] = rule(0.25 * area, &corners[q], mids[q]);
    }
    let sum: f64 = parts.iter().sum();
    if ((sum - whole).abs() <= tol && depth >= MIN_ACCEPT) || depth + 1 >= MAX_DEPTH {
        return sum;
    }
    let mut out = 0.0;
    for q in 0..4 {
        out += if same(&corners[q], mids[q]) {
            parts[q]
        } else {
            cell_rule(lens, boxes[q], corners[q], mids[q], depth + 1, 0.5 * tol, s)
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imaging::recorder::CellGrid;
    use crate::imaging::render::exact::ray_set_area;

    /// On rect cells and a square aperture a pixel's ray measure through its lens is the
    /// product of its two 1-D ray sets' areas (docs/model.md §4): ∫ ρ over a grid that
    /// holds the footprint is that measure, on fronto-parallel and tilted planes, at
    /// depths on both sides of the array's conjugate and near it.
    #[test]
    fn footprint_integrates_to_the_ray_measure() {
        let d = crate::model::presets::preset("seed").unwrap();
        let (mut worst, mut skipped) = (0.0f64, 0);
        for (ci, ch) in d.channels.iter().enumerate() {
            let chan = Chan::new(&d, ch, crate::imaging::render::DEFAULT_TOL);
            let crate::model::design::Layout::Ideal { q } = ch.layout else {
                panic!("the seed's layout is ideal")
            };
            // Pixels under the lens at the array's centre.
            let (j, k) = (ch.kx / 2, ch.ky / 2);
            for (z0, g) in [
                (650.0, [0.0, 0.0]),
                (1000.0, [0.0, 0.0]),
                (200.0, [0.0, 0.0]),
                (650.0, [0.0, -20.0]),
                (650.0, [8.0, -20.0]),
                (400.0, [3.0, 1.0]),
            ] {
                for (u, v) in [
                    (q / 2, q / 2),
                    (q / 2 + 1, q / 2 - 2),
                    (q / 2 + 3, q / 2 + 2),
                    (1, q - 2),
                ] {
                    let (a, b) = (j * q + u, k * q + v);
                    let px = d.pixel(ch, a, b);
                    let c = ch.lens_center(px.j, px.k);
                    let (alpha, _) = chan.types[px.t];
                    let want = chan.norm
                        * ray_set_area(&chan, alpha, px.theta[0])
                        * ray_set_area(&chan, alpha, px.theta[1]);
                    let e = [-px.theta[0], -px.theta[1]];
                    // A grid holding every hit: the footprint's box over the rays' depth
                    // bounds, widened by a fifth each side.
                    let lens = Lens::new(&chan, c, alpha, e, Surf::Plane { z0, g });
                    let Some(sets) = lens.axis_sets() else {
                        assert_eq!(want, 0.0);
                        continue;
                    };
                    let (h1, h2) = lens.hit_depths(&sets).unwrap();
                    let bx = lens.reach(&sets, h1, h2);
                    let w = 0.2 * (bx[1] - bx[0]).max(bx[3] - bx[2]);
                    let ext = [bx[0] - w, bx[1] + w, bx[2] - w, bx[3] + w];
                    let grid = CellGrid::covering(ext, 7.0 * w / 100.0).unwrap();
                    let corners = [
                        [ext[0], ext[2]],
                        [ext[0], ext[3]],
                        [ext[1], ext[2]],
                        [ext[1], ext[3]],
                    ];
                    if corners.iter().any(|&p| lens.depth(p) <= d.f_main) {
                        // The plane comes nearer than F over the grid: refused by the map.
                        skipped += 1;
                        continue;
                    }
                    let mut rec = Recorder::new(grid).unwrap();
                    rec.reset(chan.norm);
                    record(
                        &chan,
                        c,
                        alpha,
                        e,
                        Surf::Plane { z0, g },
                        &mut rec,
                        &mut Scratch::default(),
                    );
                    assert!(
                        !rec.lost() && rec.outside == 0.0,
                        "channel {ci} z {z0} g {g:?} pixel ({a}, {b})"
                    );
                    let err = (rec.total - want).abs() / want;
                    eprintln!("channel {ci} z {z0} g {g:?} pixel ({a}, {b}): {err:.2e}");
                    worst = worst.max(err);
                }
            }
        }
        assert!(skipped <= 8, "{skipped}");
        assert!(worst < 1e-4, "{worst}");
    }
}
