//! The sorted chief samples of one line at one depth, merged across lines, and the scans
//! that count the distinct ones and measure their gaps (docs/model.md §5, §6).

use crate::infra::error::Result;
use crate::infra::memory::try_reserve;
use crate::sampling::line::Line;

/// The chief-sample generator of one line (a design channel along one axis): its lens centres and lit pixels, and the constants of p' = (v_ref/L)(c + w g),
/// g = (L − z')/z' (docs/model.md §5).
#[derive(Debug, Clone)]
pub(super) struct LineSamples {
    pub(super) l: f64,
    /// v_ref / L.
    pub(super) scale: f64,
    /// v_ref / v · μ: the step of p' between neighbouring ideal pixels is this times −g.
    pub(super) pixel_scale: f64,
    /// Step between neighbouring lenses in p', (v_ref/L) d.
    pub(super) lens_step: f64,
    /// c_j, j = 0..K.
    pub(super) centers: Vec<f64>,
    pub(super) pixels: LitPixels,
}

/// The lit pixels of a line.
#[derive(Debug, Clone)]
pub(super) enum LitPixels {
    /// Ideal layout: the chief heights w_q of the lit pixels, the same under every lens,
    /// in order of increasing q.
    Same(Vec<f64>),
    /// Sensor layout: (c_j, w) of every lit pixel, in sensor order.
    Each(Vec<(f64, f64)>),
}

impl LineSamples {
    pub(super) fn new(line: &Line) -> LineSamples {
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
    pub(super) fn lit(&self) -> usize {
        match &self.pixels {
            LitPixels::Same(w) => self.centers.len() * w.len(),
            LitPixels::Each(p) => p.len(),
        }
    }
}

/// Reusable buffers of one worker thread (allocated once per worker, grown as needed).
#[derive(Debug, Default)]
pub(super) struct Scratch {
    /// Sorted chief samples of half 1, half 2 and their union (p' space).
    pub(super) pos: [Vec<f64>; 3],
    pub(super) work: Work,
}

impl Scratch {
    /// Buffers reserved up front (fallibly, exactly), so that no later resize reallocates:
    /// positions of at most `n[0]` and `n[1]` samples of each half along one axis (and
    /// their union), `inner` inner terms of the window sort, `q` pixel terms.
    pub(super) fn reserved(n: [usize; 2], inner: usize, q: usize) -> Result<Scratch> {
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
    pub(super) fn bytes(n: [usize; 2], inner: usize, q: usize) -> u128 {
        let n = n[0] as u128 + n[1] as u128;
        16 * n + 40 * inner as u128 + 8 * q as u128
    }
}

/// Working buffers of [`line_samples`].
#[derive(Debug, Default)]
pub(super) struct Work {
    /// Per inner index: (fractional offset in its window, window shift, index).
    pub(super) perm: Vec<(f64, usize, usize)>,
    /// Pixel terms t_l = w_q (L − z')/z' of the lit pixels, in order of increasing p'.
    pub(super) t: Vec<f64>,
    /// Inner terms and window shifts in window order.
    pub(super) inner: Vec<(f64, usize)>,
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
pub(super) fn line_samples(ls: &LineSamples, zc: f64, out: &mut Vec<f64>, work: &mut Work) {
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
pub(super) fn scan(x: &[f64], eps: f64, field: f64) -> (u64, f64) {
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
pub(super) fn field_gap(x: &[f64], field: f64) -> f64 {
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
pub(super) fn merge_into(out: &mut Vec<f64>, x: &[f64], y: &[f64]) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::lens::conjugate;
    use crate::sampling::line::Axis;
    use crate::sampling::samples::test_designs::*;

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
}
