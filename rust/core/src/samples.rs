//! Coincidence planes, genuinely new samples (Eqs. 8–9) and resolution at every depth
//! (docs/model.md §3, §5, §6). Derivations: `docs/samples.md`.
//!
//! The sample positions are the chief samples p' of [`Camera::chief_projection`] (docs/model.md §5),
//! the same function the ray-space engine's `sample = "chief"` footprints use, over every
//! lit pixel ([`Camera::is_lit`]) of a half. Everything is computed on plane v' (p' space);
//! object space is the linear map X = −p' z / v', so
//! - the merge tolerance `tol · δ(z)` is `tol · d / Q` in p' space (independent of z),
//! - the central field |X| ≤ K_x d z / (4 v') is |p'| ≤ K_x d / 4,
//! - a gap g in p' is g Q / d in units of δ(z).
//!
//! Merge rule: the distinct count of a set of positions is the least number of closed
//! intervals of length `tol · δ(z)` that cover it (computed greedily on the sorted positions:
//! a position opens a new sample when it lies more than `tol · δ(z)` beyond the first
//! position of the current sample). This count is monotone (adding positions never lowers
//! it), so the union of both halves never counts fewer samples than either half.

use rayon::prelude::*;

use crate::camera::{Axis, Camera, Half};
use crate::design::Design;
use crate::error::{Error, Result};
use crate::lens::{conjugate, depth_of_conjugate};
use crate::line::{check_coincidence_channel, Line};
use crate::memory::{self, try_reserve, try_vec};
use crate::optics::{check_depths, check_design_depths, LensOptics};
use crate::parallel::{chunk_items, for_chunks, threads, with_threads};
use crate::rayspace::{slope, trace, trace_line, Sample, TRACE_BYTES_PER_PIXEL};

/// Largest number of pixels along one axis of one half (K · Q) the brute-force count
/// accepts (a cap on the work per depth; the memory a call needs is estimated separately,
/// see [`new_samples_bytes`], and checked against what is available).
pub const MAX_SAMPLES_PER_AXIS: u64 = 1 << 24;
/// Largest number of (N, T) pairs `coincidence_planes` enumerates.
pub const MAX_PAIRS: u64 = 1_000_000;
/// Largest brute-force work of `coincidence_planes`: planes × (K_x + K_y) × Q_lit sample
/// positions generated, sorted and scanned (about half a minute on one core).
pub const MAX_COINCIDENCE_WORK: u64 = 1 << 33;
/// Default largest N of `coincidence_planes`.
pub const DEFAULT_MAX_N: i64 = 4;
/// Default merge tolerance of the distinct counts, in units of δ(z).
pub const DEFAULT_TOL: f64 = 1e-6;

/// The merge tolerance `tol · δ(z)` in p' space: δ(z) = d z / (Q v') maps to d / Q on
/// plane v' (X = −p' z / v'), independent of the depth.
#[inline]
pub fn merge_eps(cam: &Camera, tol: f64) -> f64 {
    tol * cam.d / cam.q as f64
}

/// Validate the merge tolerance (a multiple of δ(z); 0 merges exactly equal positions only).
pub fn check_tol(tol: f64) -> Result<f64> {
    if tol.is_finite() && tol >= 0.0 {
        Ok(tol)
    } else {
        Err(Error::param(
            "tol",
            tol,
            "a finite number >= 0 (a multiple of the resolution step delta(z))",
        ))
    }
}

/// Greatest common divisor.
pub fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Eqs. 8–9, one axis, with the lit pixel count: genuinely new samples of K microlenses
/// with `q_lit` lit pixels each on the coincidence plane (N, T).
/// n = N Q_lit + T (K − N) when T ≤ Q_lit and K ≥ N; in general
/// n = K Q_lit − max(K − N, 0) · max(Q_lit − T, 0) (which is K Q_lit when nothing overlaps).
pub fn closed_form_new_samples(k: u64, q_lit: u64, n: u64, t: u64) -> u64 {
    k * q_lit - k.saturating_sub(n) * q_lit.saturating_sub(t)
}

/// The lit pixels of a half along one axis, in order of increasing q. The lit set is
/// contiguous and symmetric about the microlens image centre (|w_q| grows away from it).
pub fn lit_indices(cam: &Camera, half: Half) -> Vec<u32> {
    (0..cam.q).filter(|&q| cam.is_lit(half, q)).collect()
}

fn check_size(cam: &Camera) -> Result<()> {
    let k = cam.kx.max(cam.ky) as u64;
    let n = k * cam.q as u64;
    if n > MAX_SAMPLES_PER_AXIS {
        return Err(Error::TooMuchWork {
            what: format!(
                "the brute-force sample count over K = {k} microlenses x Q = {} pixels",
                cam.q
            ),
            amount: n as u128,
            limit: MAX_SAMPLES_PER_AXIS as u128,
            unit: "pixels per axis",
        });
    }
    Ok(())
}

/// The chief-sample generator of one line (a camera half or a design channel along one
/// axis): its lens centres and lit pixels, and the constants of p' = (v_ref/L)(c + w g),
/// g = (L − z')/z' (docs/model.md §5).
#[derive(Debug, Clone)]
struct LineSamples {
    l: f64,
    /// v_ref / L.
    scale: f64,
    /// v_ref / v · μ: the step of p' between neighbouring ideal pixels is this times −g.
    pixel_scale: f64,
    /// Step between neighbouring lenses in p', (v_ref/L) d.
    lens_step: f64,
    /// c_j, j = 0..K.
    centers: Vec<f64>,
    pixels: LitPixels,
}

/// The lit pixels of a line.
#[derive(Debug, Clone)]
enum LitPixels {
    /// Ideal layout: the chief heights w_q of the lit pixels, the same under every lens,
    /// in order of increasing q.
    Same(Vec<f64>),
    /// Sensor layout: (c_j, w) of every lit pixel, in sensor order.
    Each(Vec<(f64, f64)>),
}

impl LineSamples {
    fn new(line: &Line) -> LineSamples {
        let centers = (0..line.k).map(|j| line.lens_center(j)).collect();
        let pixels = match line.q() {
            Some(q) => LitPixels::Same(
                (0..q)
                    .map(|i| line.chief_w(line.ideal_offset(i, q)))
                    .filter(|&w| line.passes(w))
                    .collect(),
            ),
            None => LitPixels::Each(
                (0..line.pixel_count() as u32)
                    .map(|i| line.pixel(i))
                    .filter(|p| p.lit)
                    .map(|p| (line.lens_center(p.j), line.chief_w(p.theta)))
                    .collect(),
            ),
        };
        LineSamples {
            l: line.l,
            scale: line.v_ref / line.l,
            pixel_scale: (line.v_ref / line.v) * line.mu,
            lens_step: line.v_ref / line.l * line.d,
            centers,
            pixels,
        }
    }

    /// Lit pixels along the line (K Q_lit for the ideal layout).
    fn lit(&self) -> usize {
        match &self.pixels {
            LitPixels::Same(w) => self.centers.len() * w.len(),
            LitPixels::Each(p) => p.len(),
        }
    }
}

/// Per-half, per-axis generators of the camera, and its lit pixel indices.
#[derive(Debug, Clone)]
struct Layout {
    /// [half][axis: 0 x, 1 y].
    lines: [[LineSamples; 2]; 2],
    /// Lit pixel indices of half 1 and half 2.
    lit: [Vec<u32>; 2],
    /// The y lens centres are x lens centres, bit for bit (K_y ≤ K_x, K_x − K_y even:
    /// c^y_j = c^x_{j + (K_x − K_y)/2}, both exact half-integer multiples of d), so every
    /// y sample of a half is one of its x samples.
    y_within_x: bool,
}

impl Layout {
    fn new(cam: &Camera) -> Layout {
        let of = |h: Half| [Axis::X, Axis::Y].map(|a| LineSamples::new(&Line::of_half(cam, h, a)));
        Layout {
            lines: [of(Half::One), of(Half::Two)],
            lit: Half::BOTH.map(|h| lit_indices(cam, h)),
            y_within_x: cam.ky <= cam.kx && (cam.kx - cam.ky) % 2 == 0,
        }
    }

    fn line(&self, half: Half, axis: Axis) -> &LineSamples {
        &self.lines[half.index()][match axis {
            Axis::X => 0,
            Axis::Y => 1,
        }]
    }
}

/// Reusable buffers of one worker thread (allocated once per worker, grown as needed).
#[derive(Debug, Default)]
struct Scratch {
    /// Sorted chief samples of half 1, half 2 and their union (p' space).
    pos: [Vec<f64>; 3],
    work: Work,
}

impl Scratch {
    /// Buffers reserved up front (fallibly, exactly), so that no later resize reallocates:
    /// positions of at most `n[0]` and `n[1]` samples of each half along one axis (and
    /// their union), `inner` inner terms of the window sort, `q` pixel terms.
    fn reserved(n: [usize; 2], inner: usize, q: usize) -> Result<Scratch> {
        let what = "new_samples (per-thread buffers)";
        let mut s = Scratch::default();
        try_reserve(&mut s.pos[0], what, n[0])?;
        try_reserve(&mut s.pos[1], what, n[1])?;
        try_reserve(&mut s.pos[2], what, n[0] + n[1])?;
        try_reserve(&mut s.work.perm, what, inner)?;
        try_reserve(&mut s.work.inner, what, inner)?;
        try_reserve(&mut s.work.t, what, q)?;
        Ok(s)
    }

    /// Bytes of [`Scratch::reserved`] with the same arguments.
    fn bytes(n: [usize; 2], inner: usize, q: usize) -> u128 {
        let n = n[0] as u128 + n[1] as u128;
        16 * n + 40 * inner as u128 + 8 * q as u128
    }

    /// Sizes for the chief samples of a camera: (per-half positions, inner, pixel terms).
    fn chief_sizes(cam: &Camera) -> ([usize; 2], usize, usize) {
        let k = cam.kx.max(cam.ky) as usize;
        let lit = Half::BOTH.map(|h| k * cam.lit_pixels(h) as usize);
        (lit, k.max(cam.q as usize), cam.q as usize)
    }

    /// Sizes for the centroid samples: every pixel of a half along the longer axis.
    fn centroid_sizes(cam: &Camera) -> ([usize; 2], usize, usize) {
        let n = cam.kx.max(cam.ky) as usize * cam.q as usize;
        ([n, n], 0, 0)
    }
}

/// Working buffers of [`half_samples`].
#[derive(Debug, Default)]
struct Work {
    /// Per inner index: (fractional offset in its window, window shift, index).
    perm: Vec<(f64, usize, usize)>,
    /// Pixel terms t_l = w_q (L − z')/z' of the lit pixels, in order of increasing p'.
    t: Vec<f64>,
    /// Inner terms and window shifts in window order.
    inner: Vec<(f64, usize)>,
}

/// Fill `out` with scale · (outer[i] + inner[l]) for every (i, l), in ascending order, given
/// that outer[i] ≈ i·a/scale + const and inner[l] ≈ l·b/scale + const (a > 0, b ≥ 0).
///
/// Window trick: write l·b = m_l a + f_l with m_l = ⌊l b / a⌋, 0 ≤ f_l < a. The value (i, l)
/// lies in window w = i + m_l (of width a) at offset f_l, so the sorted order is: windows in
/// order, and inside every window the inner indices in order of f_l — one permutation for
/// all windows. Cost O(n_inner log n_inner + (n_outer + m_max) n_inner). Rounding can leave
/// values that are equal up to a few ulps out of order: a final insertion pass (linear on
/// such nearly sorted data) makes `out` exactly sorted.
fn emit_sorted(
    out: &mut Vec<f64>,
    work: &mut Work,
    outer: &[f64],
    inner_terms: &[f64],
    a: f64,
    b: f64,
    scale: f64,
) {
    let (n_outer, n_inner) = (outer.len(), inner_terms.len());
    if n_outer == 0 || n_inner == 0 {
        out.clear();
        return;
    }
    let perm = &mut work.perm;
    perm.clear();
    for l in 0..n_inner {
        let x = l as f64 * b / a;
        let m = x.floor();
        perm.push(((x - m) * a, m as usize, l));
    }
    perm.sort_unstable_by(|p, q| p.0.total_cmp(&q.0));
    let inner = &mut work.inner;
    inner.clear();
    inner.extend(perm.iter().map(|&(_, m, l)| (inner_terms[l], m)));
    let m_max = inner.iter().map(|p| p.1).max().unwrap_or(0);
    // Every element is overwritten below: resize without clearing (no memset per depth).
    out.resize(n_outer * n_inner, 0.0);
    // Edge windows: only the inner indices whose outer index w − m lies in [0, n_outer).
    let edge = |out: &mut [f64], w: usize, o: &mut usize| {
        for &(t, m) in inner.iter() {
            if w >= m && w - m < n_outer {
                out[*o] = scale * (outer[w - m] + t);
                *o += 1;
            }
        }
    };
    let mut o = 0;
    let interior = m_max..n_outer.max(m_max);
    for w in 0..interior.start {
        edge(out, w, &mut o);
    }
    for w in interior.clone() {
        // every inner index is valid: w − m ∈ [w − m_max, w] ⊂ [0, n_outer)
        let dst = &mut out[o..o + n_inner];
        for (d, &(t, m)) in dst.iter_mut().zip(inner.iter()) {
            *d = scale * (outer[w - m] + t);
        }
        o += n_inner;
    }
    for w in interior.end..n_outer + m_max {
        edge(out, w, &mut o);
    }
    debug_assert_eq!(o, n_outer * n_inner);
    insertion_fixup(out);
}

/// Insertion sort: linear on data whose elements are at most a few places out of order.
/// A vectorised scan for descents comes first: the emitted data is usually already sorted,
/// and then the (serial, branchy) insertion pass is skipped.
fn insertion_fixup(x: &mut [f64]) {
    if x.len() < 2 {
        return;
    }
    let descents: usize = x[1..]
        .iter()
        .zip(&x[..x.len() - 1])
        .map(|(h, l)| (h < l) as usize)
        .sum();
    if descents == 0 {
        return;
    }
    for i in 1..x.len() {
        let v = x[i];
        if v < x[i - 1] {
            let mut k = i;
            while k > 0 && v < x[k - 1] {
                x[k] = x[k - 1];
                k -= 1;
            }
            x[k] = v;
        }
    }
}

/// Sorted chief samples p' (docs/model.md §5) of every lit pixel of `half` along `axis` on the plane
/// with conjugate `zc` ([`line_samples`] of the half's line).
fn half_samples(
    _cam: &Camera,
    layout: &Layout,
    half: Half,
    axis: Axis,
    zc: f64,
    out: &mut Vec<f64>,
    work: &mut Work,
) {
    line_samples(layout.line(half, axis), zc, out, work);
}

/// Sorted chief samples p' of every lit pixel of a line on the plane with conjugate `zc`.
/// Values are bit-identical to [`Line::chief_projection`] (and so to
/// [`Camera::chief_projection`]): p' = (v_ref/L)·(c_j + t) with t = w (L − z')/z'
/// evaluated in the same order.
fn line_samples(ls: &LineSamples, zc: f64, out: &mut Vec<f64>, work: &mut Work) {
    let l = ls.l;
    let scale = ls.scale;
    let ws = match &ls.pixels {
        LitPixels::Same(w) => w,
        LitPixels::Each(p) => {
            // Every lens has its own offsets: no common lattice, a plain sort.
            out.clear();
            out.extend(p.iter().map(|&(c, w)| scale * (c + w * (l - zc) / zc)));
            out.sort_unstable_by(f64::total_cmp);
            return;
        }
    };
    let c = &ls.centers;
    // Step between neighbouring lenses (a) and neighbouring lit pixels (|Δ|), in p'.
    let a = ls.lens_step;
    let g = (l - zc) / zc;
    let dq = -ls.pixel_scale * g; // p'(q + 1) − p'(q)
    let b = dq.abs();
    // Pixel terms in order of increasing p' (q ascending when Δ ≥ 0, else descending).
    let mut t = std::mem::take(&mut work.t);
    t.clear();
    let term = |&w: &f64| w * (l - zc) / zc;
    if dq >= 0.0 {
        t.extend(ws.iter().map(term));
    } else {
        t.extend(ws.iter().rev().map(term));
    }
    let (k, nl) = (c.len(), t.len());
    // Orientation: windows over lenses (inner = pixels) or over pixels (inner = lenses),
    // whichever visits fewer (window, inner) pairs. c_j + t_q = t_q + c_j exactly.
    let cost_lens = (k as f64 + ((nl.max(1) - 1) as f64 * b / a).floor()) * nl as f64;
    let cost_pix = if b > 0.0 {
        (nl as f64 + ((k.max(1) - 1) as f64 * a / b).floor()) * k as f64
    } else {
        f64::INFINITY
    };
    if cost_lens <= cost_pix {
        emit_sorted(out, work, c, &t, a, b, scale);
    } else {
        emit_sorted(out, work, &t, c, b, a, scale);
    }
    work.t = t;
}

/// Largest consecutive difference of ascending x (0 for fewer than two values). Four
/// independent accumulators keep the loop free of a serial max dependency.
fn max_step(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return 0.0;
    }
    let (hi, lo) = (&x[1..], &x[..x.len() - 1]);
    let mut acc = [0.0f64; 4];
    let (ch, cl) = (hi.chunks_exact(4), lo.chunks_exact(4));
    let (rh, rl) = (ch.remainder(), cl.remainder());
    for (h, l) in ch.zip(cl) {
        for j in 0..4 {
            let d = h[j] - l[j];
            acc[j] = if d > acc[j] { d } else { acc[j] };
        }
    }
    for (h, l) in rh.iter().zip(rl) {
        acc[0] = acc[0].max(h - l);
    }
    acc[0].max(acc[1]).max(acc[2].max(acc[3]))
}

/// Distinct count (merge rule of the module doc) and largest gap over the field [−W, W]
/// (p' units; +∞ when the samples do not reach both field edges, or when there are none)
/// of ascending positions.
fn scan(x: &[f64], eps: f64, field: f64) -> (u64, f64) {
    let n = x.len();
    if n == 0 {
        return (0, f64::INFINITY);
    }
    // Fast path: no two neighbours within eps → every position is its own sample.
    let close: usize = x[1..]
        .iter()
        .zip(&x[..n - 1])
        .map(|(h, l)| (h - l <= eps) as usize)
        .sum();
    let count = if close == 0 {
        n as u64
    } else {
        let (mut count, mut anchor) = (1u64, x[0]);
        for &v in &x[1..] {
            if v - anchor > eps {
                count += 1;
                anchor = v;
            }
        }
        count
    };
    (count, field_gap(x, field))
}

/// Largest gap over the field [−W, W] of ascending positions (+∞ when they do not reach
/// both field edges, or when there are none): the gaps [x_k, x_{k+1}] that overlap the
/// open field, x_{k+1} > −W and x_k < W. A gap that only touches an edge from outside
/// does not count (the sample on the edge covers it): otherwise a sample added outside the
/// field could make the gap larger, and the union's gap could exceed a half's.
fn field_gap(x: &[f64], field: f64) -> f64 {
    let n = x.len();
    if n == 0 || x[0] > -field || x[n - 1] < field {
        return f64::INFINITY;
    }
    // x[0] <= −W gives lo >= 0; x[n−1] >= W gives hi <= n − 1; −W < W gives lo < hi.
    let lo = x.partition_point(|&v| v <= -field) - 1;
    let hi = x.partition_point(|&v| v < field);
    max_step(&x[lo..=hi])
}

/// Merge two ascending arrays into `out`, branch-free, from both ends at once: the front
/// takes the smallest values (x first on ties), the back the largest (y first on ties, the
/// same total order reversed), so each element is written exactly once and the two
/// independent dependency chains overlap. (Cutting the inputs in two and running four
/// chains in lockstep measured slower here: the cursors no longer fit in registers.)
fn merge_into(out: &mut Vec<f64>, x: &[f64], y: &[f64]) {
    let n = x.len() + y.len();
    out.resize(n, 0.0); // every element is overwritten: no clear, no memset per depth
    let out = &mut out[..];
    let at = |v: &[f64], i: usize, none: f64| v.get(i).copied().unwrap_or(none);
    let (mut i, mut k) = (0usize, 0usize); // front cursors
    let (mut ib, mut kb) = (x.len(), y.len()); // back cursors (one past)
    let half = n / 2;
    for o in 0..half {
        // Plain selects (positions are never NaN): f64::min's NaN handling would add four
        // instructions to each of the two dependency chains.
        let (xa, yb) = (at(x, i, f64::INFINITY), at(y, k, f64::INFINITY));
        let tx = (xa <= yb) as usize;
        out[o] = if xa <= yb { xa } else { yb };
        i += tx;
        k += 1 - tx;
        let (xe, ye) = (
            at(x, ib.wrapping_sub(1), f64::NEG_INFINITY),
            at(y, kb.wrapping_sub(1), f64::NEG_INFINITY),
        );
        let te = (xe > ye) as usize;
        out[n - 1 - o] = if xe > ye { xe } else { ye };
        ib -= te;
        kb -= 1 - te;
    }
    if n % 2 == 1 {
        // The middle element: whichever back cursor still holds an untaken value.
        out[half] = if ib > i { x[ib - 1] } else { y[kb - 1] };
    }
}

/// Results at one depth.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct DepthResult {
    distinct: [u64; 3],
    distinct_2d: [u64; 3],
    max_gap: [f64; 3],
}

/// Distinct counts along one axis (half 1, half 2, union) and, when `field` is given,
/// the max gaps in δ(z) units.
fn axis_counts(
    cam: &Camera,
    layout: &Layout,
    axis: Axis,
    zc: f64,
    eps: f64,
    field: f64,
    s: &mut Scratch,
) -> ([u64; 3], [f64; 3]) {
    for h in Half::BOTH {
        half_samples(cam, layout, h, axis, zc, &mut s.pos[h.index()], &mut s.work);
    }
    let [p1, p2, pu] = &mut s.pos;
    merge_into(pu, p1, p2);
    let to_delta = cam.q as f64 / cam.d;
    let (cu, gu) = scan(pu, eps, field);
    let halves = if cu == pu.len() as u64 {
        // Every union sample is its own: so is every sample of each half (a subset), and
        // only the gaps are left to find.
        [&*p1, &*p2].map(|x| (x.len() as u64, field_gap(x, field)))
    } else {
        [&*p1, &*p2].map(|x| scan(x, eps, field))
    };
    let r = [halves[0], halves[1], (cu, gu)];
    (r.map(|x| x.0), r.map(|x| x.1 * to_delta))
}

/// 2D distinct counts from the per-axis counts (separability, inclusion–exclusion):
/// |A1×B1 ∪ A2×B2| = |A1||B1| + |A2||B2| − |A1∩A2||B1∩B2|, |A1∩A2| = |A1| + |A2| − |A1∪A2|.
pub fn distinct_2d(x: [u64; 3], y: [u64; 3]) -> [u64; 3] {
    let ix = x[0] + x[1] - x[2];
    let iy = y[0] + y[1] - y[2];
    [
        x[0] * y[0],
        x[1] * y[1],
        x[0] * y[0] + x[1] * y[1] - ix * iy,
    ]
}

fn depth_result(cam: &Camera, layout: &Layout, z: f64, tol: f64, s: &mut Scratch) -> DepthResult {
    let zc = conjugate(cam.f_main, z);
    let eps = merge_eps(cam, tol);
    let field = cam.kx as f64 * cam.d / 4.0; // |X| ≤ K_x d z / (4 v') in p' space
    let (dx, gap) = axis_counts(cam, layout, Axis::X, zc, eps, field, s);
    let lit = [&layout.lit[0], &layout.lit[1]].map(|l| l.len() as u64);
    let all_distinct_x = dx[2] == cam.kx as u64 * (lit[0] + lit[1]);
    let dy = if cam.ky == cam.kx {
        dx
    } else if all_distinct_x && layout.y_within_x {
        // No two x samples of either half lie within eps of each other, and the y samples
        // of each half are x samples (those of the central K_y lenses): so no two y samples
        // do either, and every count is the number of samples. The usual case away from
        // coincidence planes; it skips the whole y pass.
        let (n1, n2) = (cam.ky as u64 * lit[0], cam.ky as u64 * lit[1]);
        [n1, n2, n1 + n2]
    } else {
        // Counts only: an infinite field skips the gap scan.
        axis_counts(cam, layout, Axis::Y, zc, eps, f64::INFINITY, s).0
    };
    DepthResult {
        distinct: dx,
        distinct_2d: distinct_2d(dx, dy),
        max_gap: gap,
    }
}

/// Centroid samples of every half and axis: the (u, w) centroids of the pixels that
/// collect light. On the plane with conjugate z' the sample is p' = u + σ w with
/// σ = (v' − z')/z' (docs/model.md §5), the projection the engine's `footprints` use.
struct CentroidLayout {
    /// [half][axis: 0 x, 1 y] → centroids of the pixels with area > 0.
    uw: [[Vec<[f64; 2]>; 2]; 2],
}

impl CentroidLayout {
    fn new(cam: &Camera) -> Result<CentroidLayout> {
        let mut uw: [[Vec<[f64; 2]>; 2]; 2] = Default::default();
        for h in Half::BOTH {
            for (a, axis) in [Axis::X, Axis::Y].into_iter().enumerate() {
                let tr = trace(cam, h, axis)?;
                uw[h.index()][a] = tr
                    .centroid
                    .iter()
                    .zip(&tr.area)
                    .filter(|(_, &area)| area > 0.0)
                    .map(|(c, _)| *c)
                    .collect();
            }
        }
        Ok(CentroidLayout { uw })
    }
}

/// Distinct centroid samples along one axis (half 1, half 2, union) and max gaps in δ(z).
fn centroid_axis_counts(
    cam: &Camera,
    cl: &CentroidLayout,
    axis: usize,
    zc: f64,
    eps: f64,
    field: f64,
    s: &mut Scratch,
) -> ([u64; 3], [f64; 3]) {
    let sigma = slope(cam, zc);
    for h in Half::BOTH {
        let pos = &mut s.pos[h.index()];
        pos.clear();
        pos.extend(cl.uw[h.index()][axis].iter().map(|[u, w]| u + sigma * w));
        pos.sort_unstable_by(f64::total_cmp);
    }
    let [p1, p2, pu] = &mut s.pos;
    merge_into(pu, p1, p2);
    let to_delta = cam.q as f64 / cam.d;
    let r = [&*p1, &*p2, &*pu].map(|x| scan(x, eps, field));
    (r.map(|x| x.0), r.map(|x| x.1 * to_delta))
}

fn centroid_depth_result(
    cam: &Camera,
    cl: &CentroidLayout,
    z: f64,
    tol: f64,
    s: &mut Scratch,
) -> DepthResult {
    let zc = conjugate(cam.f_main, z);
    let eps = merge_eps(cam, tol);
    let field = cam.kx as f64 * cam.d / 4.0;
    let (dx, gap) = centroid_axis_counts(cam, cl, 0, zc, eps, field, s);
    let dy = centroid_axis_counts(cam, cl, 1, zc, eps, f64::INFINITY, s).0;
    DepthResult {
        distinct: dx,
        distinct_2d: distinct_2d(dx, dy),
        max_gap: gap,
    }
}

/// Genuinely new samples at m depths. Row-major (3, m) arrays: rows half 1, half 2, union.
#[derive(Debug, Clone, PartialEq)]
pub struct NewSamples {
    /// Distinct chief samples along x.
    pub distinct: Vec<u64>,
    /// Distinct chief samples over the 2D half-sensors (K_x × K_y lenses).
    pub distinct_2d: Vec<u64>,
    /// Largest gap between consecutive samples along x over the central field, in δ(z)
    /// (+∞ when the samples do not cover the field).
    pub max_gap: Vec<f64>,
    /// Pixels that yield a sample along x (chief: lit, K_x Q_lit; centroid: area > 0), for
    /// half 1, half 2 and their sum.
    pub lit: [u64; 3],
}

/// Depths per parallel task.
const CHUNK: usize = 8;

/// Output buffers of [`new_samples_into`], each row-major (3, m): rows half 1, half 2,
/// union. Any initial content: every element is written once.
pub struct NewSamplesOut<'a> {
    pub distinct: &'a mut [u64],
    pub distinct_2d: &'a mut [u64],
    pub max_gap: &'a mut [f64],
}

/// Bytes a new_samples call at `m` depths holds at its peak, for `mode` on `threads`
/// threads: the outputs (9 values per depth), one chunk of per-depth results, the layout
/// (chief: lens centres and lit pixels; centroid: the centroids of every pixel of both
/// halves and axes, plus the trace of one half and axis while they are collected) and one
/// set of per-thread buffers per thread ([`Scratch::reserved`]).
pub fn new_samples_bytes(cam: &Camera, m: usize, mode: Sample, threads: usize) -> u128 {
    let m = m as u128;
    let depth_result = std::mem::size_of::<DepthResult>() as u128;
    let outputs = 72 * m;
    let chunk = depth_result * m.min(1 << 20);
    let (kx, ky, q) = (cam.kx as u128, cam.ky as u128, cam.q as u128);
    let (layout, sizes) = match mode {
        Sample::Chief => (8 * (kx + ky) + 8 * q, Scratch::chief_sizes(cam)),
        Sample::Centroid => {
            let centroids = 2 * 16 * q * (kx + ky);
            let trace = TRACE_BYTES_PER_PIXEL * q * kx.max(ky);
            (centroids + trace, Scratch::centroid_sizes(cam))
        }
    };
    let workers = (threads as u128).min(m.div_ceil(CHUNK as u128)).max(1);
    let scratch = workers * Scratch::bytes(sizes.0, sizes.1, sizes.2);
    outputs + chunk + layout + scratch
}

/// Evaluate `f` at every depth in parallel, in chunks of depths with an interrupt
/// checkpoint between chunks (CHUNK depths per task, one scratch per worker built by
/// `scratch`), writing each depth's result into `out`.
fn per_depth<F, S>(
    z: &[f64],
    n_threads: Option<usize>,
    cost: u128,
    scratch: S,
    out: NewSamplesOut<'_>,
    f: F,
) -> Result<()>
where
    F: Fn(f64, &mut Scratch) -> DepthResult + Sync,
    S: Fn() -> Result<Scratch> + Sync,
{
    let m = z.len();
    let step = chunk_items(n_threads, cost)
        .max(CHUNK * threads(n_threads))
        .min(1 << 20);
    let mut res = try_vec(
        "new_samples (per-depth results)",
        step.min(m),
        DepthResult::default(),
    )?;
    for_chunks(n_threads, m, step, |r| {
        let res = &mut res[..r.len()];
        res.par_chunks_mut(CHUNK)
            .zip(z[r.clone()].par_chunks(CHUNK))
            .try_for_each_init(&scratch, |s, (rs, zs)| -> Result<()> {
                let s = s.as_mut().map_err(|e| e.clone())?;
                for (ri, &zi) in rs.iter_mut().zip(zs) {
                    *ri = f(zi, s);
                }
                Ok(())
            })?;
        for (k, d) in r.zip(res.iter()) {
            for row in 0..3 {
                out.distinct[row * m + k] = d.distinct[row];
                out.distinct_2d[row * m + k] = d.distinct_2d[row];
                out.max_gap[row * m + k] = d.max_gap[row];
            }
        }
        Ok(())
    })
}

/// Validate a new_samples call before any work: threads, tolerance, depths, the work cap
/// ([`MAX_SAMPLES_PER_AXIS`]) and the memory ([`new_samples_bytes`]). Returns the tolerance.
pub fn check_new_samples(
    cam: &Camera,
    z: &[f64],
    tol: f64,
    mode: Sample,
    n_threads: Option<usize>,
) -> Result<f64> {
    crate::parallel::check_threads(n_threads)?;
    let tol = check_tol(tol)?;
    check_depths(cam, z)?;
    check_size(cam)?;
    let bytes = new_samples_bytes(cam, z.len(), mode, threads(n_threads));
    memory::check("new_samples", bytes)?;
    Ok(tol)
}

/// Distinct samples (chief or centroid) and max gaps at every depth (validated first),
/// parallel over depths.
pub fn new_samples(
    cam: &Camera,
    z: &[f64],
    tol: f64,
    mode: Sample,
    n_threads: Option<usize>,
) -> Result<NewSamples> {
    check_new_samples(cam, z, tol, mode, n_threads)?;
    let m = z.len();
    let what = "new_samples";
    let mut distinct = try_vec(what, 3 * m, 0)?;
    let mut distinct_2d = try_vec(what, 3 * m, 0)?;
    let mut max_gap = try_vec(what, 3 * m, 0.0)?;
    let out = NewSamplesOut {
        distinct: &mut distinct,
        distinct_2d: &mut distinct_2d,
        max_gap: &mut max_gap,
    };
    let lit = new_samples_into(cam, z, tol, mode, out, n_threads)?;
    Ok(NewSamples {
        distinct,
        distinct_2d,
        max_gap,
        lit,
    })
}

/// [`new_samples`] written into caller-provided (3, m) buffers; returns `lit`.
pub fn new_samples_into(
    cam: &Camera,
    z: &[f64],
    tol: f64,
    mode: Sample,
    out: NewSamplesOut<'_>,
    n_threads: Option<usize>,
) -> Result<[u64; 3]> {
    let tol = check_new_samples(cam, z, tol, mode, n_threads)?;
    let m = z.len();
    let lens = [out.distinct.len(), out.distinct_2d.len(), out.max_gap.len()];
    if lens.iter().any(|&l| l != 3 * m) {
        return Err(Error::param(
            "output length",
            format!("{lens:?}"),
            format!("{} (3 rows × m = {m} depths)", 3 * m),
        ));
    }
    let kx = cam.kx as u64;
    // Elementary steps per depth: every sample position of both halves along both axes.
    let cost = 4 * (cam.kx as u128 + cam.ky as u128) * cam.q as u128;
    let lit = match mode {
        Sample::Chief => {
            let layout = Layout::new(cam);
            let (n, inner, q) = Scratch::chief_sizes(cam);
            let scratch = || Scratch::reserved(n, inner, q);
            per_depth(z, n_threads, cost, scratch, out, |zi, s| {
                depth_result(cam, &layout, zi, tol, s)
            })?;
            layout.lit.map(|l| kx * l.len() as u64)
        }
        Sample::Centroid => {
            let cl = with_threads(n_threads, || CentroidLayout::new(cam))??;
            let (n, inner, q) = Scratch::centroid_sizes(cam);
            let scratch = || Scratch::reserved(n, inner, q);
            per_depth(z, n_threads, cost, scratch, out, |zi, s| {
                centroid_depth_result(cam, &cl, zi, tol, s)
            })?;
            cl.uw.map(|h| h[0].len() as u64)
        }
    };
    Ok([lit[0], lit[1], lit[0] + lit[1]])
}

/// Distinct chief samples of one half along one axis at depth z (the brute-force count).
pub fn count_distinct(cam: &Camera, half: Half, axis: Axis, z: f64, tol: f64) -> Result<u64> {
    let tol = check_tol(tol)?;
    check_depths(cam, &[z])?;
    check_size(cam)?;
    let layout = Layout::new(cam);
    let mut s = Scratch::default();
    let zc = conjugate(cam.f_main, z);
    half_samples(cam, &layout, half, axis, zc, &mut s.pos[0], &mut s.work);
    Ok(scan(&s.pos[0], merge_eps(cam, tol), f64::INFINITY).0)
}

/// Side of a coincidence plane relative to the half's out-of-focus plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Beyond the out-of-focus plane: z' = L_i / (1 + r) < L_i.
    Far,
    /// In front of it: z' = L_i / (1 − r) > L_i (needs r < 1).
    Near,
}

impl Side {
    pub fn name(self) -> &'static str {
        match self {
            Side::Far => "far",
            Side::Near => "near",
        }
    }
}

/// One coincidence plane of a half (docs/model.md §6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoincidencePlane {
    pub n: u32,
    pub t: u32,
    pub side: Side,
    /// z' of the plane [mm].
    pub conjugate: f64,
    /// z [mm].
    pub z: f64,
    /// rep_i = 2 H_i / d at z' (Eqs. 4–5).
    pub repetitions: f64,
    /// One factor of Eq. 8/9 with K_x (and Q_lit).
    pub new_samples_x: u64,
    /// One factor of Eq. 8/9 with K_y (and Q_lit).
    pub new_samples_y: u64,
    /// Their product (Eq. 8 for half 1, Eq. 9 for half 2).
    pub new_samples: u64,
    /// Brute-force count of distinct chief samples over every lit pixel of the 2D half.
    pub counted: u64,
}

/// Tolerance (in δ(z)) of the brute-force count of `coincidence_planes`.
pub const COINCIDENCE_TOL: f64 = 1e-6;

/// Every coincidence plane of `half` with coprime N ≤ max_n, T ≤ max_t (default Q), on both
/// sides of the out-of-focus plane where it exists (1 − r > 0, z' > F), sorted by depth z,
/// each with the closed form of Eqs. 8–9 and the brute-force count.
pub fn coincidence_planes(
    cam: &Camera,
    half: Half,
    max_n: i64,
    max_t: Option<i64>,
    n_threads: Option<usize>,
) -> Result<Vec<CoincidencePlane>> {
    let (max_n, max_t) = check_pairs(cam.q, max_n, max_t)?;
    check_size(cam)?;
    let pl = PlaneLines {
        x: LineSamples::new(&Line::of_half(cam, half, Axis::X)),
        y: LineSamples::new(&Line::of_half(cam, half, Axis::Y)),
        kx: cam.kx,
        ky: cam.ky,
        q: cam.q,
        eps: merge_eps(cam, COINCIDENCE_TOL),
        optics: LensOptics::of_half(cam, half),
    };
    planes_of(&pl, max_n, max_t, n_threads)
}

/// [`coincidence_planes`] of channel `channel` (from 1) of a design: a rect grid, the
/// ideal layout and a square aperture, where docs/model.md §6 holds (anything else is
/// refused with the parameter named). The merge tolerance is [`COINCIDENCE_TOL`] δ(z),
/// δ(z) = μ_1 z / L_1 (docs/model.md §9). Chief samples do not depend on the lens types.
pub fn design_coincidence_planes(
    design: &Design,
    channel: i64,
    max_n: i64,
    max_t: Option<i64>,
    n_threads: Option<usize>,
) -> Result<Vec<CoincidencePlane>> {
    let lx = Line::of_channel(design, channel, Axis::X)?;
    check_coincidence_channel(design, channel)?;
    let ly = Line::of_channel(design, channel, Axis::Y)?;
    let q = lx.q().unwrap_or(1);
    let (max_n, max_t) = check_pairs(q, max_n, max_t)?;
    check_line_size(&[&lx, &ly])?;
    let ch = design.channel(channel)?;
    let pl = PlaneLines {
        x: LineSamples::new(&lx),
        y: LineSamples::new(&ly),
        kx: ch.kx,
        ky: ch.ky,
        q,
        eps: COINCIDENCE_TOL * design_step(design),
        optics: LensOptics::of_channel(design, ch, 0),
    };
    planes_of(&pl, max_n, max_t, n_threads)
}

/// What the coincidence planes of one half or channel need: its two lines, K_x, K_y, Q,
/// the merge tolerance in p' and its closed forms.
struct PlaneLines {
    x: LineSamples,
    y: LineSamples,
    kx: u32,
    ky: u32,
    q: u32,
    eps: f64,
    optics: LensOptics,
}

impl PlaneLines {
    fn q_lit(&self) -> u64 {
        match &self.x.pixels {
            LitPixels::Same(w) => w.len() as u64,
            LitPixels::Each(_) => 0,
        }
    }
}

fn planes_of(
    pl: &PlaneLines,
    max_n: u32,
    max_t: u32,
    n_threads: Option<usize>,
) -> Result<Vec<CoincidencePlane>> {
    let mut planes = enumerate_planes(pl, max_n, max_t)?;
    check_coincidence_work(pl, planes.len(), max_n, max_t)?;
    count_planes(pl, &mut planes, n_threads)?;
    Ok(planes)
}

/// Validate max_n and max_t (None: Q) and their product against [`MAX_PAIRS`].
fn check_pairs(q: u32, max_n: i64, max_t: Option<i64>) -> Result<(u32, u32)> {
    if !(1..=MAX_PAIRS as i64).contains(&max_n) {
        return Err(Error::param(
            "max_n",
            max_n,
            format!("an integer in [1, {MAX_PAIRS}]"),
        ));
    }
    let max_t = max_t.unwrap_or(q as i64);
    if !(1..=MAX_PAIRS as i64).contains(&max_t) {
        return Err(Error::param(
            "max_t",
            max_t,
            format!("an integer in [1, {MAX_PAIRS}] or None for Q"),
        ));
    }
    if (max_n as u64) * (max_t as u64) > MAX_PAIRS {
        return Err(Error::param(
            "max_n * max_t",
            max_n * max_t,
            format!("at most {MAX_PAIRS} (N, T) pairs"),
        ));
    }
    Ok((max_n as u32, max_t as u32))
}

/// The planes of docs/model.md §6 with r = N d v / (T μ L_i), z' = L_i / (1 ± r), sorted by
/// depth, with Eqs. 8–9 (Q_lit for Q) and `counted` still 0.
fn enumerate_planes(pl: &PlaneLines, max_n: u32, max_t: u32) -> Result<Vec<CoincidencePlane>> {
    let o = &pl.optics;
    let l = o.l;
    let q_lit = pl.q_lit();
    let mut planes = Vec::new();
    try_reserve(
        &mut planes,
        "coincidence_planes",
        2 * max_n as usize * max_t as usize,
    )?;
    for n in 1..=max_n {
        for t in (1..=max_t).filter(|&t| gcd(n as u64, t as u64) == 1) {
            let r = n as f64 * o.d * o.v / (t as f64 * o.mu * l);
            let sides = [(Side::Far, l / (1.0 + r)), (Side::Near, l / (1.0 - r))];
            for (side, zc) in sides {
                let valid = match side {
                    Side::Far => zc > o.f_main,
                    Side::Near => 1.0 - r > 0.0 && zc > o.f_main && zc.is_finite(),
                };
                if !valid {
                    continue;
                }
                let nx = closed_form_new_samples(pl.kx as u64, q_lit, n as u64, t as u64);
                let ny = closed_form_new_samples(pl.ky as u64, q_lit, n as u64, t as u64);
                planes.push(CoincidencePlane {
                    n,
                    t,
                    side,
                    conjugate: zc,
                    z: depth_of_conjugate(o.f_main, zc),
                    repetitions: o.repetitions(o.main_blur(zc)),
                    new_samples_x: nx,
                    new_samples_y: ny,
                    new_samples: nx * ny,
                    counted: 0,
                });
            }
        }
    }
    planes.sort_by(|a, b| a.z.total_cmp(&b.z));
    Ok(planes)
}

/// Sample positions the brute force generates, sorts and scans per plane: (K_x + K_y) Q_lit.
fn positions_per_plane(pl: &PlaneLines) -> u128 {
    (pl.kx as u128 + pl.ky as u128) * pl.q_lit() as u128
}

/// Refuse a brute-force count above [`MAX_COINCIDENCE_WORK`] before it starts.
fn check_coincidence_work(pl: &PlaneLines, n_planes: usize, max_n: u32, max_t: u32) -> Result<()> {
    let per_plane = positions_per_plane(pl);
    let work = n_planes as u128 * per_plane;
    if work > MAX_COINCIDENCE_WORK as u128 {
        return Err(Error::TooMuchWork {
            what: format!(
                "coincidence_planes with max_n = {max_n}, max_t = {max_t}: {n_planes} planes x \
                 {per_plane} lit pixels (lower max_n or max_t)"
            ),
            amount: work,
            limit: MAX_COINCIDENCE_WORK as u128,
            unit: "sample positions",
        });
    }
    Ok(())
}

/// The brute-force count of every plane: distinct chief samples along x times along y,
/// at the plane's own conjugate z' (not re-derived from z), in interruptible chunks.
fn count_planes(
    pl: &PlaneLines,
    planes: &mut [CoincidencePlane],
    n_threads: Option<usize>,
) -> Result<()> {
    let eps = pl.eps;
    let k = pl.kx.max(pl.ky) as usize;
    let n = k * pl.q_lit() as usize;
    let (inner, q) = (k.max(pl.q as usize), pl.q as usize);
    memory::check(
        "coincidence_planes",
        memory::bytes_of::<CoincidencePlane>(planes.len() as u128)
            + threads(n_threads) as u128 * Scratch::bytes([n, 0], inner, q),
    )?;
    let step = chunk_items(n_threads, 4 * positions_per_plane(pl));
    for_chunks(n_threads, planes.len(), step, |r| {
        planes[r].par_iter_mut().try_for_each_init(
            || Scratch::reserved([n, 0], inner, q),
            |s, p| -> Result<()> {
                let s = s.as_mut().map_err(|e| e.clone())?;
                let mut count = 1;
                for ls in [&pl.x, &pl.y] {
                    line_samples(ls, p.conjugate, &mut s.pos[0], &mut s.work);
                    count *= scan(&s.pos[0], eps, f64::INFINITY).0;
                }
                p.counted = count;
                Ok(())
            },
        )
    })
}

// ---- designs (docs/model.md §9): every channel along x, and their union ------------------

/// δ(z) = μ_1 z / L_1 in p' space on plane v_ref = L_1: μ_1 (docs/model.md §9, "Scale and
/// field"; X = −p' z / L_1).
pub fn design_step(design: &Design) -> f64 {
    design.channels[0].mu
}

/// The 1-D central field |X| ≤ K_x d_1 z / (4 L_1) of channel 1 in p' space: K_x d_1 / 4.
pub fn design_field(design: &Design) -> f64 {
    let ch = &design.channels[0];
    ch.kx as f64 * ch.d / 4.0
}

/// Refuse a line set whose brute-force count exceeds [`MAX_SAMPLES_PER_AXIS`] per line.
fn check_line_size(lines: &[&Line]) -> Result<()> {
    for line in lines {
        let n = line.pixel_count();
        if n > MAX_SAMPLES_PER_AXIS as u128 {
            return Err(Error::TooMuchWork {
                what: format!(
                    "the brute-force sample count over the {} pixels of channel {} along one axis",
                    n,
                    line.index + 1
                ),
                amount: n,
                limit: MAX_SAMPLES_PER_AXIS as u128,
                unit: "pixels per axis",
            });
        }
    }
    Ok(())
}

/// Genuinely new samples of a design at m depths: row-major (C + 1, m) arrays, rows the
/// channels in order and then their union.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSamples {
    pub rows: usize,
    /// Distinct samples along x.
    pub distinct: Vec<u64>,
    /// Largest gap over the central field along x, in δ(z) = μ_1 z / L_1 (+∞ when the
    /// samples do not cover the field).
    pub max_gap: Vec<f64>,
    /// Pixels along x that yield a sample, per channel and in all.
    pub sampled: Vec<u64>,
}

/// Output buffers of [`design_new_samples_into`], each row-major (C + 1, m).
pub struct DesignSamplesOut<'a> {
    pub distinct: &'a mut [u64],
    pub max_gap: &'a mut [f64],
}

/// The sample sources of each channel: the chief generator, or the centroids (u, w) of the
/// pixels that collect light.
enum Sources {
    Chief(Vec<LineSamples>),
    Centroid(Vec<Vec<[f64; 2]>>),
}

impl Sources {
    fn new(lines: &[Line], mode: Sample) -> Result<Sources> {
        Ok(match mode {
            Sample::Chief => Sources::Chief(lines.iter().map(LineSamples::new).collect()),
            Sample::Centroid => {
                let mut all = Vec::new();
                for line in lines {
                    let tr = trace_line(line)?;
                    all.push(
                        tr.centroid
                            .iter()
                            .zip(&tr.area)
                            .filter(|(_, &area)| area > 0.0)
                            .map(|(c, _)| *c)
                            .collect(),
                    );
                }
                Sources::Centroid(all)
            }
        })
    }

    fn sampled(&self) -> Vec<u64> {
        match self {
            Sources::Chief(l) => l.iter().map(|x| x.lit() as u64).collect(),
            Sources::Centroid(c) => c.iter().map(|x| x.len() as u64).collect(),
        }
    }
}

/// Per-thread buffers of the design counts: one position buffer per channel, two for the
/// running union.
#[derive(Default)]
struct DesignScratch {
    pos: Vec<Vec<f64>>,
    union: [Vec<f64>; 2],
    work: Work,
}

impl DesignScratch {
    fn reserved(sizes: &[usize], inner: usize, q: usize) -> Result<DesignScratch> {
        let what = "new_samples (per-thread buffers)";
        let mut s = DesignScratch::default();
        let total: usize = sizes.iter().sum();
        for &n in sizes {
            let mut v = Vec::new();
            try_reserve(&mut v, what, n)?;
            s.pos.push(v);
        }
        try_reserve(&mut s.union[0], what, total)?;
        try_reserve(&mut s.union[1], what, total)?;
        try_reserve(&mut s.work.perm, what, inner)?;
        try_reserve(&mut s.work.inner, what, inner)?;
        try_reserve(&mut s.work.t, what, q)?;
        Ok(s)
    }

    fn bytes(sizes: &[usize], inner: usize, q: usize) -> u128 {
        let total: u128 = sizes.iter().map(|&n| n as u128).sum();
        24 * total + 40 * inner as u128 + 8 * q as u128
    }
}

/// Distinct counts and gaps (in δ(z)) of every channel and of the union at one depth,
/// written to `d` and `g` (C + 1 entries each).
#[allow(clippy::too_many_arguments)]
fn design_depth(
    lines: &[Line],
    src: &Sources,
    z: f64,
    eps: f64,
    step: f64,
    field: f64,
    s: &mut DesignScratch,
    d: &mut [u64],
    g: &mut [f64],
) {
    let zc = conjugate(lines[0].f_main, z);
    for (c, pos) in s.pos.iter_mut().enumerate() {
        match src {
            Sources::Chief(ls) => line_samples(&ls[c], zc, pos, &mut s.work),
            Sources::Centroid(uw) => {
                let sigma = lines[c].slope(zc);
                pos.clear();
                pos.extend(uw[c].iter().map(|[u, w]| u + sigma * w));
                pos.sort_unstable_by(f64::total_cmp);
            }
        }
    }
    // The union: merge the channels one by one (the result is the sorted multiset).
    let [u0, u1] = &mut s.union;
    u0.clear();
    u0.extend_from_slice(&s.pos[0]);
    for pos in &s.pos[1..] {
        merge_into(u1, u0, pos);
        std::mem::swap(u0, u1);
    }
    let n = s.pos.len();
    let (cu, gu) = scan(u0, eps, field);
    for (c, pos) in s.pos.iter().enumerate() {
        let (dc, gc) = if cu == u0.len() as u64 {
            // Every union sample is its own: so is every sample of each channel.
            (pos.len() as u64, field_gap(pos, field))
        } else {
            scan(pos, eps, field)
        };
        d[c] = dc;
        g[c] = gc / step;
    }
    d[n] = cu;
    g[n] = gu / step;
}

/// Bytes a design new_samples call at `m` depths holds: the outputs (16 bytes per depth
/// and row), the sources and one set of per-thread buffers per thread.
fn design_samples_bytes(lines: &[Line], m: usize, mode: Sample, threads: usize) -> u128 {
    let (m, rows) = (m as u128, lines.len() as u128 + 1);
    let outputs = 16 * rows * m;
    let px: u128 = lines.iter().map(|l| l.pixel_count()).sum();
    let sources = match mode {
        Sample::Chief => 16 * px + lines.iter().map(|l| 8 * l.k as u128).sum::<u128>(),
        Sample::Centroid => {
            16 * px
                + TRACE_BYTES_PER_PIXEL * lines.iter().map(|l| l.pixel_count()).max().unwrap_or(0)
        }
    };
    let (sizes, inner, q) = design_sizes(lines);
    let workers = (threads as u128).min(m.div_ceil(CHUNK as u128)).max(1);
    outputs + sources + workers * DesignScratch::bytes(&sizes, inner, q)
}

/// Buffer sizes of [`DesignScratch`]: every pixel of each line (an upper bound of its
/// samples in either mode), the window sort's inner terms and pixel terms.
fn design_sizes(lines: &[Line]) -> (Vec<usize>, usize, usize) {
    let sizes = lines.iter().map(|l| l.pixel_count() as usize).collect();
    let q = lines.iter().filter_map(|l| l.q()).max().unwrap_or(0) as usize;
    let k = lines.iter().map(|l| l.k).max().unwrap_or(0) as usize;
    (sizes, k.max(q), q)
}

/// Validate a design new_samples call before any work: threads, tolerance, depths, rect
/// grids ([`Line::of_channel`]), the work cap and the memory. Returns the lines along x.
pub fn check_design_new_samples(
    design: &Design,
    z: &[f64],
    tol: f64,
    mode: Sample,
    n_threads: Option<usize>,
) -> Result<Vec<Line>> {
    crate::parallel::check_threads(n_threads)?;
    check_tol(tol)?;
    check_design_depths(design.f_main, z)?;
    let lines = Line::of_design(design, Axis::X)?;
    check_line_size(&lines.iter().collect::<Vec<_>>())?;
    let bytes = design_samples_bytes(&lines, z.len(), mode, threads(n_threads));
    memory::check("new_samples", bytes)?;
    Ok(lines)
}

/// Distinct samples (chief or centroid) along x and max gaps of every channel of a design
/// and of their union at every depth (docs/model.md §6 per channel, §9 "Scale and field").
pub fn design_new_samples(
    design: &Design,
    z: &[f64],
    tol: f64,
    mode: Sample,
    n_threads: Option<usize>,
) -> Result<DesignSamples> {
    check_design_new_samples(design, z, tol, mode, n_threads)?;
    let (rows, m) = (design.channels.len() + 1, z.len());
    let what = "new_samples";
    let mut distinct = try_vec(what, rows * m, 0)?;
    let mut max_gap = try_vec(what, rows * m, 0.0)?;
    let out = DesignSamplesOut {
        distinct: &mut distinct,
        max_gap: &mut max_gap,
    };
    let sampled = design_new_samples_into(design, z, tol, mode, out, n_threads)?;
    Ok(DesignSamples {
        rows,
        distinct,
        max_gap,
        sampled,
    })
}

/// [`design_new_samples`] written into caller-provided (C + 1, m) buffers; returns the
/// pixels that yield a sample per channel and in all.
pub fn design_new_samples_into(
    design: &Design,
    z: &[f64],
    tol: f64,
    mode: Sample,
    out: DesignSamplesOut<'_>,
    n_threads: Option<usize>,
) -> Result<Vec<u64>> {
    let lines = check_design_new_samples(design, z, tol, mode, n_threads)?;
    let (rows, m) = (lines.len() + 1, z.len());
    if out.distinct.len() != rows * m || out.max_gap.len() != rows * m {
        return Err(Error::param(
            "output length",
            format!("{:?}", (out.distinct.len(), out.max_gap.len())),
            format!("{} ({rows} rows × m = {m} depths)", rows * m),
        ));
    }
    let (step, field) = (design_step(design), design_field(design));
    let eps = tol * step;
    let src = with_threads(n_threads, || Sources::new(&lines, mode))??;
    let (sizes, inner, q) = design_sizes(&lines);
    let cost = 4 * lines.iter().map(|l| l.pixel_count()).sum::<u128>();
    let chunk = chunk_items(n_threads, cost)
        .max(CHUNK * threads(n_threads))
        .min(1 << 20);
    let what = "new_samples (per-depth results)";
    let mut dres = try_vec(what, chunk.min(m) * rows, 0u64)?;
    let mut gres = try_vec(what, chunk.min(m) * rows, 0.0)?;
    for_chunks(n_threads, m, chunk, |r| {
        let len = r.len();
        let (dr, gr) = (&mut dres[..len * rows], &mut gres[..len * rows]);
        dr.par_chunks_mut(CHUNK * rows)
            .zip(gr.par_chunks_mut(CHUNK * rows))
            .zip(z[r.clone()].par_chunks(CHUNK))
            .try_for_each_init(
                || DesignScratch::reserved(&sizes, inner, q),
                |s, ((dc, gc), zs)| -> Result<()> {
                    let s = s.as_mut().map_err(|e| e.clone())?;
                    for (i, &zi) in zs.iter().enumerate() {
                        let span = i * rows..(i + 1) * rows;
                        design_depth(
                            &lines,
                            &src,
                            zi,
                            eps,
                            step,
                            field,
                            s,
                            &mut dc[span.clone()],
                            &mut gc[span],
                        );
                    }
                    Ok(())
                },
            )?;
        for (o, k) in r.enumerate() {
            for row in 0..rows {
                out.distinct[row * m + k] = dr[o * rows + row];
                out.max_gap[row * m + k] = gr[o * rows + row];
            }
        }
        Ok(())
    })?;
    let mut sampled = src.sampled();
    sampled.push(sampled.iter().sum());
    Ok(sampled)
}

/// Distinct chief samples of channel `channel` (from 1) of a design along x at depth z.
pub fn design_count_distinct(design: &Design, channel: i64, z: f64, tol: f64) -> Result<u64> {
    let tol = check_tol(tol)?;
    check_design_depths(design.f_main, &[z])?;
    let line = Line::of_channel(design, channel, Axis::X)?;
    check_line_size(&[&line])?;
    let ls = LineSamples::new(&line);
    let mut s = Scratch::default();
    let zc = conjugate(design.f_main, z);
    line_samples(&ls, zc, &mut s.pos[0], &mut s.work);
    Ok(scan(&s.pos[0], tol * design_step(design), f64::INFINITY).0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(kappa: f64, aperture: f64, q: i64, kx: i64, ky: i64) -> Camera {
        let p = Camera::paper();
        Camera::new(
            80.0, aperture, p.v1, kappa, p.d, p.v, p.mu, q, kx, ky, None, None,
        )
        .unwrap()
    }

    /// Reference: every chief sample via Camera::chief_projection, full sort.
    fn brute(cam: &Camera, half: Half, k: u32, zc: f64) -> Vec<f64> {
        let mut v: Vec<f64> = (0..k)
            .flat_map(|j| {
                (0..cam.q)
                    .filter(move |&q| cam.is_lit(half, q))
                    .map(move |q| cam.chief_projection(half, cam.lens_center(j, k), q, zc))
            })
            .collect();
        v.sort_by(|a, b| a.total_cmp(b));
        v
    }

    #[test]
    fn sorted_samples_are_bitwise_chief_projections() {
        for cam in [
            Camera::paper(),
            small(0.8, 20.0, 10, 37, 5),
            small(0.2, 20.0, 4, 3, 2),
        ] {
            let layout = Layout::new(&cam);
            let mut s = Scratch::default();
            for z in [81.0, 100.0, 150.0, 217.0, 300.0, 642.0, 1000.0, 5e3, 1e5] {
                let zc = conjugate(cam.f_main, z);
                for half in Half::BOTH {
                    for axis in [Axis::X, Axis::Y] {
                        let k = cam.lenses(axis);
                        half_samples(&cam, &layout, half, axis, zc, &mut s.pos[0], &mut s.work);
                        let want = brute(&cam, half, k, zc);
                        assert_eq!(s.pos[0].len(), want.len());
                        for (a, b) in s.pos[0].iter().zip(&want) {
                            assert_eq!(a.to_bits(), b.to_bits(), "z={z} {half:?} {axis:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn merge_and_scan_are_exact() {
        let cases: [(&[f64], &[f64]); 6] = [
            (&[], &[]),
            (&[1.0], &[]),
            (&[], &[2.0, 3.0]),
            (&[1.0, 2.0, 2.0, 5.0], &[0.0, 2.0, 6.0]),
            (&[1.0, 3.0, 5.0], &[2.0, 4.0]),
            (&[-3.0, -1.0, 0.0, 0.5, 7.0], &[-2.0, 0.0, 0.0]),
        ];
        let mut out = Vec::new();
        for (x, y) in cases {
            merge_into(&mut out, x, y);
            let mut want: Vec<f64> = x.iter().chain(y).copied().collect();
            want.sort_by(f64::total_cmp);
            assert_eq!(out, want);
        }
        // Random lengths, many ties (values on a coarse grid), every split position.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % m
        };
        for _ in 0..500 {
            let mut x: Vec<f64> = (0..next(40)).map(|_| next(30) as f64 - 15.0).collect();
            let mut y: Vec<f64> = (0..next(40)).map(|_| next(30) as f64 - 15.0).collect();
            x.sort_by(f64::total_cmp);
            y.sort_by(f64::total_cmp);
            merge_into(&mut out, &x, &y);
            let mut want: Vec<f64> = x.iter().chain(&y).copied().collect();
            want.sort_by(f64::total_cmp);
            assert_eq!(out, want, "{x:?} {y:?}");
        }
        // Greedy cover: {0, 0.6, 1.2} with eps 1 -> 2 intervals (single linkage would say 1).
        assert_eq!(scan(&[0.0, 0.6, 1.2], 1.0, 0.5).0, 2);
        // Field [-1, 1]: gaps meeting it are [-3,-0.5], [-0.5,0.2], [0.2,4]; [4,10] is outside.
        assert_eq!(scan(&[-3.0, -0.5, 0.2, 4.0, 10.0], 0.0, 1.0), (5, 3.8));
        assert_eq!(scan(&[-0.5, 2.0], 0.0, 1.0).1, f64::INFINITY); // field not covered
        assert_eq!(max_step(&[0.0, 1.0, 1.5, 4.0, 4.1, 4.2, 4.3, 9.0]), 4.7);
    }

    #[test]
    fn closed_form_cases() {
        // N Q + T (K − N) inside the validity range, K Q outside it.
        assert_eq!(closed_form_new_samples(266, 15, 1, 1), 15 + 265);
        assert_eq!(closed_form_new_samples(266, 15, 2, 3), 30 + 3 * 264);
        assert_eq!(closed_form_new_samples(266, 15, 1, 15), 266 * 15);
        assert_eq!(closed_form_new_samples(266, 11, 1, 13), 266 * 11);
        assert_eq!(closed_form_new_samples(3, 15, 5, 2), 45);
    }

    #[test]
    fn counted_equals_eqs_8_9_on_every_plane() {
        let designs = [
            Camera::paper(),
            small(0.8, 14.0, 10, 23, 7),
            small(0.39, 20.0, 15, 40, 9),
        ];
        let mut checked = 0;
        for cam in designs {
            for half in Half::BOTH {
                let planes = coincidence_planes(&cam, half, 5, None, Some(1)).unwrap();
                assert!(planes.iter().any(|p| p.side == Side::Near));
                assert!(planes.iter().any(|p| p.side == Side::Far));
                for p in &planes {
                    assert_eq!(p.counted, p.new_samples, "{half:?} {p:?}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 100);
    }

    #[test]
    fn out_of_focus_plane_collapses_to_k() {
        let cam = Camera::paper();
        for half in Half::BOTH {
            let z = cam.out_of_focus_depth(half);
            assert_eq!(
                count_distinct(&cam, half, Axis::X, z, 1e-6).unwrap(),
                cam.kx as u64
            );
            assert_eq!(
                count_distinct(&cam, half, Axis::Y, z, 1e-6).unwrap(),
                cam.ky as u64
            );
        }
        // Half 1 on its out-of-focus plane: pixelization, max gap = Q steps.
        let z1 = cam.out_of_focus_depth(Half::One);
        let r = new_samples(&cam, &[z1], 1e-6, Sample::Chief, Some(1)).unwrap();
        assert!((r.max_gap[0] - cam.q as f64).abs() < 1e-9);
    }

    #[test]
    fn union_bounds_and_threads_agree() {
        let cam = Camera::paper();
        let z: Vec<f64> = (0..200)
            .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 199.0))
            .collect();
        let a = new_samples(&cam, &z, 1e-6, Sample::Chief, Some(1)).unwrap();
        let b = new_samples(&cam, &z, 1e-6, Sample::Chief, Some(2)).unwrap();
        assert_eq!(a, b);
        let m = z.len();
        for k in 0..m {
            let d = |r: usize| a.distinct[r * m + k];
            let g = |r: usize| a.max_gap[r * m + k];
            assert!(d(2) >= d(0).max(d(1)) && d(2) <= d(0) + d(1));
            assert!(g(2) <= g(0).min(g(1)));
            assert!(a.distinct_2d[2 * m + k] >= a.distinct_2d[k].max(a.distinct_2d[m + k]));
        }
        assert_eq!(a.lit, [266 * 15, 266 * 11, 266 * 26]);
    }

    #[test]
    fn y_shortcut_equals_the_full_y_pass() {
        // The all-distinct shortcut for the y counts against the full y pass: generic
        // depths, every coincidence plane and both out-of-focus planes (where samples
        // coincide and the full pass runs), and a coarse tolerance that merges samples.
        for cam in [Camera::paper(), small(0.3866, 20.0, 9, 12, 6)] {
            let mut z: Vec<f64> = (0..300)
                .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 299.0))
                .collect();
            for h in Half::BOTH {
                z.push(cam.out_of_focus_depth(h));
                let planes = coincidence_planes(&cam, h, 3, None, Some(1)).unwrap();
                z.extend(planes.iter().map(|p| p.z).filter(|&v| v > 100.0 && v < 1e5));
            }
            let fast = Layout::new(&cam);
            assert!(fast.y_within_x);
            let slow = Layout {
                y_within_x: false,
                ..fast.clone()
            };
            let mut s = Scratch::default();
            let every = cam.kx as u64 * (fast.lit[0].len() + fast.lit[1].len()) as u64;
            let mut taken = [0, 0]; // [shortcut, full y pass]
            for tol in [1e-6, 0.3] {
                for &zi in &z {
                    let a = depth_result(&cam, &fast, zi, tol, &mut s);
                    let b = depth_result(&cam, &slow, zi, tol, &mut s);
                    assert_eq!(a, b, "z = {zi}, tol = {tol}");
                    taken[(a.distinct[2] != every) as usize] += 1;
                }
            }
            assert!(taken[0] > 0 && taken[1] > 0, "{taken:?}");
        }
    }

    #[test]
    fn camera_design_counts_equal_the_camera_counts() {
        // The design path on Camera::design: the same distinct counts, lit pixels and
        // coincidence planes bit for bit; gaps in μ_1 z/L_1 instead of d z/(Q v').
        for cam in [Camera::paper(), small(0.8, 14.0, 10, 23, 7)] {
            let d = cam.design();
            let z: Vec<f64> = (0..120)
                .map(|i| 120.0 * (20_000.0f64 / 120.0).powf(i as f64 / 119.0))
                .collect();
            for mode in [Sample::Chief, Sample::Centroid] {
                let a = new_samples(&cam, &z, 1e-6, mode, Some(2)).unwrap();
                let b = design_new_samples(&d, &z, 1e-6, mode, Some(2)).unwrap();
                assert_eq!(a.distinct, b.distinct);
                assert_eq!(a.lit.to_vec(), b.sampled);
                let scale = cam.q as f64 * cam.mu / cam.d;
                for (x, y) in a.max_gap.iter().zip(&b.max_gap) {
                    assert!(x == y || ((y * scale - x) / x).abs() < 1e-14, "{x} {y}");
                }
            }
            for half in Half::BOTH {
                let a = coincidence_planes(&cam, half, 3, None, Some(1)).unwrap();
                let b = design_coincidence_planes(&d, half.index() as i64 + 1, 3, None, Some(1))
                    .unwrap();
                assert_eq!(a, b);
            }
        }
    }

    #[test]
    fn bad_input() {
        let cam = Camera::paper();
        assert!(new_samples(&cam, &[500.0], -1.0, Sample::Chief, None).is_err());
        assert!(new_samples(&cam, &[500.0], f64::NAN, Sample::Chief, None).is_err());
        assert!(new_samples(&cam, &[80.0], 1e-6, Sample::Chief, None).is_err());
        assert_eq!(Sample::from_name("centroid").unwrap(), Sample::Centroid);
        assert!(Sample::from_name("foo").is_err());
        assert!(coincidence_planes(&cam, Half::One, 0, None, None).is_err());
        assert!(coincidence_planes(&cam, Half::One, 2, Some(0), None).is_err());
    }
}
