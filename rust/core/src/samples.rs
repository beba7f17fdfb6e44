//! Coincidence planes, genuinely new samples (Eqs. 8–9) and resolution at every depth
//! (MODEL.md §3, §5, §6). Derivations: `docs/samples.md`.
//!
//! The sample positions are the chief samples p' of [`Camera::chief_projection`] (MODEL §5),
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
use crate::error::{Error, Result};
use crate::optics::{check_depths, conjugate, depth_of_conjugate, main_blur, repetitions};
use crate::parallel::with_threads;

/// Largest number of lit pixels along one axis of one half (K · Q_lit) the brute-force
/// count accepts: each worker holds three buffers of this many f64.
pub const MAX_SAMPLES_PER_AXIS: u64 = 1 << 24;
/// Largest number of (N, T) pairs `coincidence_planes` enumerates.
pub const MAX_PAIRS: u64 = 1_000_000;

/// Which sample position of a pixel is counted (MODEL §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleMode {
    /// The chief ray's projection (the paper's convention).
    Chief,
}

impl SampleMode {
    /// Parse `"chief"`. `"centroid"` needs the polygon centroids of the ray-space engine
    /// (`rayspace`), which is not part of this module: it is refused with that reason.
    pub fn parse(s: &str) -> Result<SampleMode> {
        match s {
            "chief" => Ok(SampleMode::Chief),
            "centroid" => Err(Error::param(
                "sample",
                "\"centroid\"",
                "\"chief\" (centroid samples arrive with the ray-space engine's footprints)",
            )),
            other => Err(Error::param(
                "sample",
                format!("{other:?}"),
                "\"chief\" (the paper's convention)",
            )),
        }
    }
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
        return Err(Error::TooLarge {
            what: format!(
                "the brute-force sample count over K = {k} microlenses x Q = {} pixels",
                cam.q
            ),
            bytes: 24 * n as u128,
            limit: 24 * MAX_SAMPLES_PER_AXIS as u128,
        });
    }
    Ok(())
}

/// Per-half, per-axis constants: lens centres c_j and lit pixel indices.
#[derive(Debug, Clone)]
struct Layout {
    /// c_j, j = 0..K (x axis).
    cx: Vec<f64>,
    /// c_j, j = 0..K (y axis).
    cy: Vec<f64>,
    /// Lit pixel indices of half 1 and half 2.
    lit: [Vec<u32>; 2],
}

impl Layout {
    fn new(cam: &Camera) -> Layout {
        Layout {
            cx: (0..cam.kx).map(|j| cam.lens_center(j, cam.kx)).collect(),
            cy: (0..cam.ky).map(|j| cam.lens_center(j, cam.ky)).collect(),
            lit: Half::BOTH.map(|h| lit_indices(cam, h)),
        }
    }

    fn centers(&self, axis: Axis) -> &[f64] {
        match axis {
            Axis::X => &self.cx,
            Axis::Y => &self.cy,
        }
    }
}

/// Reusable buffers of one worker thread.
#[derive(Debug, Default)]
struct Scratch {
    /// Sorted chief samples of half 1 and half 2 (p' space).
    pos: [Vec<f64>; 2],
    work: Work,
}

/// Working buffers of [`half_samples`].
#[derive(Debug, Default)]
struct Work {
    /// Per inner index: (fractional offset in its window, window shift, index).
    perm: Vec<(f64, usize, usize)>,
    /// Pixel terms t_l = w_q (L − z')/z' of the lit pixels at the current depth.
    t: Vec<f64>,
}

/// Fill `out` with `value(i, l)` for i < n_outer, l < n_inner in ascending order, given that
/// value(i, l) ≈ base + i·a + l·b (a > 0, b ≥ 0) up to rounding.
///
/// Window trick: write l·b = m_l a + f_l with m_l = ⌊l b / a⌋, 0 ≤ f_l < a. Then the value
/// lies in window w = i + m_l (of width a) at offset f_l, so the sorted order is: windows in
/// order, and inside every window the inner indices in order of f_l — one permutation for
/// all windows. Cost O(n_inner log n_inner + (n_outer + m_max) n_inner). Rounding can leave
/// values that are equal up to a few ulps out of order: a final insertion pass (linear on
/// such nearly sorted data) makes `out` exactly sorted.
#[allow(clippy::too_many_arguments)]
fn emit_sorted(
    out: &mut Vec<f64>,
    perm: &mut Vec<(f64, usize, usize)>,
    n_outer: usize,
    n_inner: usize,
    a: f64,
    b: f64,
    value: impl Fn(usize, usize) -> f64,
) {
    out.clear();
    perm.clear();
    if n_outer == 0 || n_inner == 0 {
        return;
    }
    for l in 0..n_inner {
        let x = l as f64 * b / a;
        let m = x.floor();
        perm.push(((x - m) * a, m as usize, l));
    }
    perm.sort_unstable_by(|p, q| p.0.total_cmp(&q.0));
    let m_max = perm.iter().map(|p| p.1).max().unwrap_or(0);
    for w in 0..n_outer + m_max {
        for &(_, m, l) in perm.iter() {
            // outer index i = w − m must lie in [0, n_outer)
            if w >= m && w - m < n_outer {
                out.push(value(w - m, l));
            }
        }
    }
    insertion_fixup(out);
}

/// Insertion sort: linear on data whose elements are at most a few places out of order.
fn insertion_fixup(x: &mut [f64]) {
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

/// Sorted chief samples p' (MODEL §5) of every lit pixel of `half` along `axis` on the plane
/// with conjugate `zc`. Values are bit-identical to [`Camera::chief_projection`].
fn half_samples(
    cam: &Camera,
    layout: &Layout,
    half: Half,
    axis: Axis,
    zc: f64,
    out: &mut Vec<f64>,
    work: &mut Work,
) {
    let Work { perm, t } = work;
    let l = cam.array_plane(half);
    let c = layout.centers(axis);
    let lit = &layout.lit[half.index()];
    // Pixel terms, in the exact operation order of Camera::chief_projection.
    t.clear();
    t.extend(lit.iter().map(|&q| cam.chief_w(half, q) * (l - zc) / zc));
    let scale = cam.v1 / l;
    // Step between neighbouring lenses (a) and neighbouring lit pixels (|Δ|), in p'.
    let a = scale * cam.d;
    let g = (l - zc) / zc;
    let dq = -(cam.v1 / cam.v) * cam.mu * g; // p'(q + 1) − p'(q)
    let b = dq.abs();
    let nl = t.len();
    // Inner index l ↦ lit pixel in order of increasing p'.
    let pix = |l_: usize| if dq >= 0.0 { l_ } else { nl - 1 - l_ };
    let k = c.len();
    let t = &*t;
    let value = |j: usize, p: usize| scale * (c[j] + t[p]);
    // Orientation: windows over lenses (inner = pixels) or over pixels (inner = lenses),
    // whichever visits fewer (window, inner) pairs.
    let cost_lens = (k as f64 + ((nl.max(1) - 1) as f64 * b / a).floor()) * nl as f64;
    let cost_pix = if b > 0.0 {
        (nl as f64 + ((k.max(1) - 1) as f64 * a / b).floor()) * k as f64
    } else {
        f64::INFINITY
    };
    if cost_lens <= cost_pix {
        emit_sorted(out, perm, k, nl, a, b, |j, li| value(j, pix(li)));
    } else {
        emit_sorted(out, perm, nl, k, b, a, |li, j| value(j, pix(li)));
    }
}

/// Streaming count and gap scan over positions given in ascending order (p' space).
#[derive(Debug, Clone, Copy)]
struct Scan {
    eps: f64,
    field: f64,
    count: u64,
    anchor: f64,
    prev: f64,
    first: f64,
    max_gap: f64,
}

impl Scan {
    fn new(eps: f64, field: f64) -> Scan {
        Scan {
            eps,
            field,
            count: 0,
            anchor: f64::NAN,
            prev: f64::NAN,
            first: f64::NAN,
            max_gap: 0.0,
        }
    }

    #[inline]
    fn push(&mut self, x: f64) {
        if self.count == 0 {
            self.count = 1;
            self.anchor = x;
            self.first = x;
        } else {
            if x - self.anchor > self.eps {
                self.count += 1;
                self.anchor = x;
            }
            // A gap counts when its interval [prev, x] meets the field [−W, W].
            if x >= -self.field && self.prev <= self.field {
                self.max_gap = self.max_gap.max(x - self.prev);
            }
        }
        self.prev = x;
    }

    /// Largest gap in p' units; +∞ when the samples do not reach both field edges
    /// (part of the field has no sample on one side), or when there are none.
    fn gap(&self) -> f64 {
        if self.count == 0 || self.first > -self.field || self.prev < self.field {
            f64::INFINITY
        } else {
            self.max_gap
        }
    }
}

fn scan_one(x: &[f64], eps: f64, field: f64) -> Scan {
    let mut s = Scan::new(eps, field);
    for &v in x {
        s.push(v);
    }
    s
}

fn scan_union(x: &[f64], y: &[f64], eps: f64, field: f64) -> Scan {
    let mut s = Scan::new(eps, field);
    let (mut i, mut k) = (0, 0);
    while i < x.len() && k < y.len() {
        if x[i] <= y[k] {
            s.push(x[i]);
            i += 1;
        } else {
            s.push(y[k]);
            k += 1;
        }
    }
    for &v in &x[i..] {
        s.push(v);
    }
    for &v in &y[k..] {
        s.push(v);
    }
    s
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
    let to_delta = cam.q as f64 / cam.d;
    let a = scan_one(&s.pos[0], eps, field);
    let b = scan_one(&s.pos[1], eps, field);
    let u = scan_union(&s.pos[0], &s.pos[1], eps, field);
    (
        [a.count, b.count, u.count],
        [a.gap() * to_delta, b.gap() * to_delta, u.gap() * to_delta],
    )
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
    let eps = tol * cam.d / cam.q as f64; // tol · δ(z) in p' space
    let field = cam.kx as f64 * cam.d / 4.0; // |X| ≤ K_x d z / (4 v') in p' space
    let (dx, gap) = axis_counts(cam, layout, Axis::X, zc, eps, field, s);
    let dy = if cam.ky == cam.kx {
        dx
    } else {
        axis_counts(cam, layout, Axis::Y, zc, eps, field, s).0
    };
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
    /// Lit pixels along x: K_x Q_lit,1, K_x Q_lit,2 and their sum.
    pub lit: [u64; 3],
}

/// Depths per parallel task.
const CHUNK: usize = 8;

/// Distinct chief samples and max gaps at every depth (validated first), parallel over depths.
pub fn new_samples(
    cam: &Camera,
    z: &[f64],
    tol: f64,
    mode: SampleMode,
    n_threads: Option<usize>,
) -> Result<NewSamples> {
    let SampleMode::Chief = mode;
    let tol = check_tol(tol)?;
    check_depths(cam, z)?;
    check_size(cam)?;
    let layout = Layout::new(cam);
    let m = z.len();
    let mut res = vec![DepthResult::default(); m];
    with_threads(n_threads, || {
        res.par_chunks_mut(CHUNK)
            .zip(z.par_chunks(CHUNK))
            .for_each_init(Scratch::default, |s, (r, zs)| {
                for (ri, &zi) in r.iter_mut().zip(zs) {
                    *ri = depth_result(cam, &layout, zi, tol, s);
                }
            });
    })?;
    let mut out = NewSamples {
        distinct: vec![0; 3 * m],
        distinct_2d: vec![0; 3 * m],
        max_gap: vec![0.0; 3 * m],
        lit: [0; 3],
    };
    for (k, r) in res.iter().enumerate() {
        for row in 0..3 {
            out.distinct[row * m + k] = r.distinct[row];
            out.distinct_2d[row * m + k] = r.distinct_2d[row];
            out.max_gap[row * m + k] = r.max_gap[row];
        }
    }
    let kx = cam.kx as u64;
    let l1 = kx * layout.lit[0].len() as u64;
    let l2 = kx * layout.lit[1].len() as u64;
    out.lit = [l1, l2, l1 + l2];
    Ok(out)
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
    Ok(scan_one(&s.pos[0], tol * cam.d / cam.q as f64, f64::INFINITY).count)
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

/// One coincidence plane of a half (MODEL §6).
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
/// sides of the out-of-focus plane where it exists (1 − r > 0, z' > F), sorted by depth z.
/// r = N d v / (T μ L_i); z' = L_i / (1 ± r).
pub fn coincidence_planes(
    cam: &Camera,
    half: Half,
    max_n: i64,
    max_t: Option<i64>,
    n_threads: Option<usize>,
) -> Result<Vec<CoincidencePlane>> {
    if !(1..=MAX_PAIRS as i64).contains(&max_n) {
        return Err(Error::param(
            "max_n",
            max_n,
            format!("an integer in [1, {MAX_PAIRS}]"),
        ));
    }
    let max_t = max_t.unwrap_or(cam.q as i64);
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
    check_size(cam)?;
    let l = cam.array_plane(half);
    let q_lit = cam.lit_pixels(half) as u64;
    let mut planes = Vec::new();
    for n in 1..=max_n as u32 {
        for t in 1..=max_t as u32 {
            if gcd(n as u64, t as u64) != 1 {
                continue;
            }
            let r = n as f64 * cam.d * cam.v / (t as f64 * cam.mu * l);
            let far = l / (1.0 + r);
            let sides = [(Side::Far, far), (Side::Near, l / (1.0 - r))];
            for (side, zc) in sides {
                let valid = match side {
                    Side::Far => zc > cam.f_main,
                    Side::Near => 1.0 - r > 0.0 && zc > cam.f_main && zc.is_finite(),
                };
                if !valid {
                    continue;
                }
                let nx = closed_form_new_samples(cam.kx as u64, q_lit, n as u64, t as u64);
                let ny = closed_form_new_samples(cam.ky as u64, q_lit, n as u64, t as u64);
                planes.push(CoincidencePlane {
                    n,
                    t,
                    side,
                    conjugate: zc,
                    z: depth_of_conjugate(cam.f_main, zc),
                    repetitions: repetitions(cam, main_blur(cam, half, zc)),
                    new_samples_x: nx,
                    new_samples_y: ny,
                    new_samples: nx * ny,
                    counted: 0,
                });
            }
        }
    }
    planes.sort_by(|a, b| a.z.total_cmp(&b.z));
    let layout = Layout::new(cam);
    let eps = COINCIDENCE_TOL * cam.d / cam.q as f64;
    with_threads(n_threads, || {
        planes
            .par_iter_mut()
            .for_each_init(Scratch::default, |s, p| {
                // The count runs at the plane's own conjugate z' (not re-derived from z).
                let mut count = 1;
                for axis in [Axis::X, Axis::Y] {
                    half_samples(
                        cam,
                        &layout,
                        half,
                        axis,
                        p.conjugate,
                        &mut s.pos[0],
                        &mut s.work,
                    );
                    count *= scan_one(&s.pos[0], eps, f64::INFINITY).count;
                }
                p.counted = count;
            });
    })?;
    Ok(planes)
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
            small(0.2, 30.0, 4, 3, 2),
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
        let r = new_samples(&cam, &[z1], 1e-6, SampleMode::Chief, Some(1)).unwrap();
        assert!((r.max_gap[0] - cam.q as f64).abs() < 1e-9);
    }

    #[test]
    fn union_bounds_and_threads_agree() {
        let cam = Camera::paper();
        let z: Vec<f64> = (0..200)
            .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 199.0))
            .collect();
        let a = new_samples(&cam, &z, 1e-6, SampleMode::Chief, Some(1)).unwrap();
        let b = new_samples(&cam, &z, 1e-6, SampleMode::Chief, Some(2)).unwrap();
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
    fn bad_input() {
        let cam = Camera::paper();
        assert!(new_samples(&cam, &[500.0], -1.0, SampleMode::Chief, None).is_err());
        assert!(new_samples(&cam, &[500.0], f64::NAN, SampleMode::Chief, None).is_err());
        assert!(new_samples(&cam, &[80.0], 1e-6, SampleMode::Chief, None).is_err());
        assert!(SampleMode::parse("centroid").is_err());
        assert!(SampleMode::parse("foo").is_err());
        assert!(coincidence_planes(&cam, Half::One, 0, None, None).is_err());
        assert!(coincidence_planes(&cam, Half::One, 2, Some(0), None).is_err());
    }
}
