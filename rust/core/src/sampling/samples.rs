//! Coincidence planes, genuinely new samples (Eqs. 8–9) and resolution at every depth
//! (docs/model.md §3, §5, §6). Derivations: `docs/samples.md`.
//!
//! The sample positions are the chief samples p' of [`Line::chief_projection`] (docs/model.md
//! §5), the same function the ray-space engine's `sample = "chief"` footprints use, over
//! every lit pixel ([`Line::pixel`]) of a channel. Everything is computed on plane
//! v_ref = L_1 (p' space); object space is the linear map X = −p' z / L_1, so with
//! δ(z) = μ_1 z / L_1 (docs/model.md §9)
//! - the merge tolerance `tol · δ(z)` is `tol · μ_1` in p' space (independent of z),
//! - the central field |X| ≤ K_x d_1 z / (4 L_1) is |p'| ≤ K_x d_1 / 4,
//! - a gap g in p' is g / μ_1 in units of δ(z).
//!
//! This δ is the one step of every design, a Camera too: for a camera it is μ z / v',
//! docs/model.md §6's d z / (Q v') only when d = Q μ. Where positions are a fraction of the
//! tolerance apart (channels whose array planes differ by a few ppm) the count depends on
//! it; it is μ_1, for the tolerance as for the gaps.
//!
//! Merge rule: the distinct count of a set of positions is the least number of closed
//! intervals of length `tol · δ(z)` that cover it (computed greedily on the sorted positions:
//! a position opens a new sample when it lies more than `tol · δ(z)` beyond the first
//! position of the current sample). This count is monotone (adding positions never lowers
//! it), so the union of both halves never counts fewer samples than either half.

use rayon::prelude::*;

use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_reserve, try_vec};
use crate::infra::parallel::{chunk_items, for_chunks, threads, with_threads};
use crate::model::design::Design;
use crate::model::lens::{conjugate, depth_of_conjugate};
use crate::model::optics::{check_design_depths, LensOptics};
use crate::sampling::line::Axis;
use crate::sampling::line::{check_coincidence_channel, Line};
use crate::sampling::rayspace::{trace_line, Sample, TRACE_BYTES_PER_PIXEL};

/// Largest number of pixels along one axis of one channel (K · Q) the brute-force count
/// accepts (a cap on the work per depth; the memory a call needs is estimated separately
/// and checked against what is available).
pub const MAX_SAMPLES_PER_AXIS: u64 = 1 << 24;
/// Largest number of (N, T) pairs `design_coincidence_planes` enumerates.
pub const MAX_PAIRS: u64 = 1_000_000;
/// Largest brute-force work of `coincidence_planes`: planes × (K_x + K_y) × Q_lit sample
/// positions generated, sorted and scanned (about half a minute on one core).
pub const MAX_COINCIDENCE_WORK: u64 = 1 << 33;
/// Default largest N of `coincidence_planes`.
pub const DEFAULT_MAX_N: i64 = 4;
/// Default merge tolerance of the distinct counts, in units of δ(z).
pub const DEFAULT_TOL: f64 = 1e-6;

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

/// The chief-sample generator of one line (a design channel along one axis): its lens centres and lit pixels, and the constants of p' = (v_ref/L)(c + w g),
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
}

/// Working buffers of [`line_samples`].
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

/// Sorted chief samples p' of every lit pixel of a line on the plane with conjugate `zc`.
/// Values are bit-identical to [`Line::chief_projection`]: p' = (v_ref/L)·(c_j + t) with
/// t = w (L − z')/z' evaluated in the same order.
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

/// Depths per parallel task.
const CHUNK: usize = 8;

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

/// Every coincidence plane (docs/model.md §6) of channel `channel` (from 1) of a design, with
/// coprime N ≤ max_n, T ≤ max_t (default Q), on both sides of the out-of-focus plane where
/// it exists (1 − r > 0, z' > F), sorted by depth z, each with the closed form of
/// Eqs. 8–9 and the brute-force count. The channel must have a rect grid, the
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
    crate::infra::parallel::check_threads(n_threads)?;
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

    use crate::model::camera::Camera;

    /// The seed's design, or a variant of it with F = 80 (as the paper's camera).
    fn small(kappa: f64, aperture: f64, q: i64, kx: i64, ky: i64) -> Design {
        let p = Camera::paper();
        Camera::new(
            80.0, aperture, p.v1, kappa, p.d, p.v, p.mu, q, kx, ky, None, None,
        )
        .unwrap()
        .design()
    }

    fn seed() -> Design {
        Camera::paper().design()
    }

    /// Reference: every chief sample of the line via `Line::chief_projection` (the
    /// paper's p' = (v'/L) [c + w (L − z')/z']), full sort.
    fn brute(line: &Line, zc: f64) -> Vec<f64> {
        let mut v: Vec<f64> = (0..line.pixel_count() as u32)
            .map(|i| line.pixel(i))
            .filter(|p| p.lit)
            .map(|p| line.chief_projection(line.lens_center(p.j), line.chief_w(p.theta), zc))
            .collect();
        v.sort_by(|a, b| a.total_cmp(b));
        v
    }

    /// Distinct chief samples of channel `c` along `axis` at depth z (merge tolerance
    /// `tol` δ(z)).
    fn count(d: &Design, c: i64, axis: Axis, z: f64, tol: f64) -> u64 {
        let ls = LineSamples::new(&Line::of_channel(d, c, axis).unwrap());
        let mut s = Scratch::default();
        line_samples(&ls, conjugate(d.f_main, z), &mut s.pos[0], &mut s.work);
        scan(&s.pos[0], tol * design_step(d), f64::INFINITY).0
    }

    #[test]
    fn sorted_samples_are_bitwise_chief_projections() {
        for d in [
            seed(),
            small(0.8, 20.0, 10, 37, 5),
            small(0.2, 20.0, 4, 3, 2),
        ] {
            let mut s = Scratch::default();
            for z in [81.0, 100.0, 150.0, 217.0, 300.0, 642.0, 1000.0, 5e3, 1e5] {
                let zc = conjugate(d.f_main, z);
                for c in [1, 2] {
                    for axis in [Axis::X, Axis::Y] {
                        let line = Line::of_channel(&d, c, axis).unwrap();
                        line_samples(&LineSamples::new(&line), zc, &mut s.pos[0], &mut s.work);
                        let want = brute(&line, zc);
                        assert_eq!(s.pos[0].len(), want.len());
                        for (a, b) in s.pos[0].iter().zip(&want) {
                            assert_eq!(a.to_bits(), b.to_bits(), "z={z} {c} {axis:?}");
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
            seed(),
            small(0.8, 14.0, 10, 23, 7),
            small(0.39, 20.0, 15, 40, 9),
        ];
        let mut checked = 0;
        for d in designs {
            for c in [1, 2] {
                let planes = design_coincidence_planes(&d, c, 5, None, Some(1)).unwrap();
                assert!(planes.iter().any(|p| p.side == Side::Near));
                assert!(planes.iter().any(|p| p.side == Side::Far));
                for p in &planes {
                    assert_eq!(p.counted, p.new_samples, "{c} {p:?}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 100);
    }

    #[test]
    fn out_of_focus_plane_collapses_to_k() {
        let d = seed();
        for (c, ch) in (1..).zip(&d.channels) {
            let z = LensOptics::of_channel(&d, ch, 0).out_of_focus_depth();
            assert_eq!(count(&d, c, Axis::X, z, 1e-6), ch.kx as u64);
            assert_eq!(design_count_distinct(&d, c, z, 1e-6).unwrap(), ch.kx as u64);
            assert_eq!(count(&d, c, Axis::Y, z, 1e-6), ch.ky as u64);
        }
        // Half 1 on its out-of-focus plane: pixelization, max gap = Q steps (one lens
        // pitch d in δ = μ z / L_1: d / μ = Q up to rounding, as d z / (Q v') did).
        let ch = &d.channels[0];
        let z1 = LensOptics::of_channel(&d, ch, 0).out_of_focus_depth();
        let r = design_new_samples(&d, &[z1], 1e-6, Sample::Chief, Some(1)).unwrap();
        assert!((r.max_gap[0] - 15.0).abs() < 1e-9);
    }

    #[test]
    fn union_bounds_and_threads_agree() {
        let d = seed();
        let z: Vec<f64> = (0..200)
            .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 199.0))
            .collect();
        let a = design_new_samples(&d, &z, 1e-6, Sample::Chief, Some(1)).unwrap();
        let b = design_new_samples(&d, &z, 1e-6, Sample::Chief, Some(2)).unwrap();
        assert_eq!(a, b);
        let m = z.len();
        for k in 0..m {
            let d = |r: usize| a.distinct[r * m + k];
            let g = |r: usize| a.max_gap[r * m + k];
            assert!(d(2) >= d(0).max(d(1)) && d(2) <= d(0) + d(1));
            assert!(g(2) <= g(0).min(g(1)));
        }
        assert_eq!(a.sampled, [266 * 15, 266 * 11, 266 * 26]);
    }

    #[test]
    fn near_coincident_channels_merge_in_mu_1() {
        // L = 52 and 52.0000062 mm, Q = 1 (w = 0): half 2's samples are (L_1/L_2) c_j,
        // |c_j| (1 − L_1/L_2) = 5.37e-8, 4.17e-8, … mm from half 1's. tol · μ_1 = 5e-8 keeps
        // the outermost pairs apart (10 + 2); tol · d/Q = 1e-7 (d = 2 Q μ) would merge all.
        let d = Camera::new(
            50.0,
            2.65,
            52.0,
            6.2e-6 / 52.0,
            0.1,
            1.0,
            0.05,
            1,
            10,
            1,
            None,
            None,
        )
        .unwrap()
        .design();
        let z = [100.0, 2600.0];
        let r = design_new_samples(&d, &z, 1e-6, Sample::Chief, Some(1)).unwrap();
        assert_eq!(r.distinct, [10, 10, 10, 10, 12, 12]);
        let r = design_new_samples(&d, &z, 2e-6, Sample::Chief, Some(1)).unwrap();
        assert_eq!(r.distinct, [10; 6]);
    }

    #[test]
    fn bad_input() {
        let d = seed();
        assert!(design_new_samples(&d, &[500.0], -1.0, Sample::Chief, None).is_err());
        assert!(design_new_samples(&d, &[500.0], f64::NAN, Sample::Chief, None).is_err());
        assert!(design_new_samples(&d, &[80.0], 1e-6, Sample::Chief, None).is_err());
        assert_eq!(Sample::from_name("centroid").unwrap(), Sample::Centroid);
        assert!(Sample::from_name("foo").is_err());
        assert!(design_coincidence_planes(&d, 1, 0, None, None).is_err());
        assert!(design_coincidence_planes(&d, 1, 2, Some(0), None).is_err());
    }
}
