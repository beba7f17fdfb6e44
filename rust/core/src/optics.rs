//! Closed-form optics over depth (docs/model.md §2: Eqs. 1, 4–7) and depth of field.
//!
//! Every expression is written in one fixed order so that a NumPy transcription of
//! docs/model.md evaluates to the same floating-point result.

use rayon::prelude::*;

use crate::camera::{Camera, Half};
use crate::error::{Error, Result};
use crate::memory;
use crate::parallel::for_chunks;

/// Default sharpness threshold on the blur radius, in pixels.
pub const DEFAULT_THRESHOLD_PX: f64 = 0.5;

/// Check a depth array: every element finite and > F (Eq. 1 is defined for z > F only).
pub fn check_depths(cam: &Camera, z: &[f64]) -> Result<()> {
    check_design_depths(cam.f_main, z)
}

/// [`check_depths`] for any main lens of focal length `f_main`.
pub fn check_design_depths(f_main: f64, z: &[f64]) -> Result<()> {
    for (index, &value) in z.iter().enumerate() {
        if !value.is_finite() {
            return Err(Error::InvalidDepth {
                index,
                value,
                reason: "depths must be finite".into(),
            });
        }
        if value <= f_main {
            return Err(Error::InvalidDepth {
                index,
                value,
                reason: format!(
                    "depths must be > F = {f_main} mm (Eq. 1 has no real conjugate at or inside the focal length)"
                ),
            });
        }
    }
    Ok(())
}

/// Eq. 1: z' = F z / (z − F), the conjugate of depth z (z > F).
///
/// For depths so large that F z overflows (z > f64::MAX / F) the algebraically equal
/// F / (1 − F/z) is used: it cannot overflow for z > F, while everywhere else the product
/// form is kept so that results equal a plain transcription of Eq. 1 bit for bit.
#[inline]
pub fn conjugate(f_main: f64, z: f64) -> f64 {
    let num = f_main * z;
    if num.is_finite() {
        num / (z - f_main)
    } else {
        f_main / (1.0 - f_main / z)
    }
}

/// Inverse of Eq. 1: the depth whose conjugate is z' (z' > F; z' = ∞ gives F).
#[inline]
pub fn depth_of_conjugate(f_main: f64, zc: f64) -> f64 {
    if zc.is_infinite() {
        f_main
    } else {
        f_main * zc / (zc - f_main)
    }
}

/// Eqs. 2–3 (missing in the paper): main-lens blur radius on array plane i,
/// H_i = (D L_i / 2) |1/z' − 1/L_i|.
#[inline]
pub fn main_blur(cam: &Camera, half: Half, zc: f64) -> f64 {
    let l = cam.array_plane(half);
    (cam.aperture * l / 2.0) * (1.0 / zc - 1.0 / l).abs()
}

/// Eqs. 4–5: repetitions rep_i = 2 H_i / d.
#[inline]
pub fn repetitions(cam: &Camera, h: f64) -> f64 {
    2.0 * h / cam.d
}

/// Eqs. 6–7: microlens blur b_i = (d v / 2) |1/f_i − 1/(L_i − z') − 1/v| (mm, unbounded).
#[inline]
pub fn microlens_blur(cam: &Camera, half: Half, zc: f64) -> f64 {
    let l = cam.array_plane(half);
    let f = cam.microlens_focal(half);
    (cam.d * cam.v / 2.0) * (1.0 / f - 1.0 / (l - zc) - 1.0 / cam.v).abs()
}

/// The bounded LF blur of Fig. 1 in pixels: min(b_i, R_i) / μ.
#[inline]
pub fn lf_blur_px(cam: &Camera, half: Half, b: f64) -> f64 {
    b.min(cam.image_radius(half)) / cam.mu
}

/// All closed-form curves for a set of depths. Two-row arrays are row-major (2, n):
/// row 0 is half 1, row 1 is half 2.
#[derive(Debug, Clone, PartialEq)]
pub struct Curves {
    pub conjugate: Vec<f64>,
    pub main_blur: Vec<f64>,
    pub repetitions: Vec<f64>,
    pub microlens_blur: Vec<f64>,
    pub blur_px: Vec<f64>,
    pub conventional_px: Vec<f64>,
}

/// Depths per parallel task: large enough to amortise scheduling, small enough to balance
/// (and to keep a task's 11 output streams short runs of fresh pages).
const CHUNK: usize = 16 * 1024;

/// Output buffers of [`curves_into`]: `conjugate` (n) and the two-row arrays (2 n,
/// row-major (2, n): row 0 half 1, row 1 half 2). Any initial content: every element is
/// written exactly once.
pub struct CurvesOut<'a> {
    pub conjugate: &'a mut [f64],
    pub main_blur: &'a mut [f64],
    pub repetitions: &'a mut [f64],
    pub microlens_blur: &'a mut [f64],
    pub blur_px: &'a mut [f64],
    pub conventional_px: &'a mut [f64],
}

/// Bytes of the outputs of [`curves`] at n depths: 11 f64 per depth (no working buffers).
pub fn curves_bytes(n: usize) -> u128 {
    memory::bytes_of::<f64>(11 * n as u128)
}

/// Evaluate every curve at every depth (validated first), in parallel.
pub fn curves(cam: &Camera, z: &[f64], n_threads: Option<usize>) -> Result<Curves> {
    check_depths(cam, z)?;
    let n = z.len();
    memory::check("curves", curves_bytes(n))?;
    let two = || memory::try_vec("curves", 2 * n, 0.0);
    let mut out = Curves {
        conjugate: memory::try_vec("curves", n, 0.0)?,
        main_blur: two()?,
        repetitions: two()?,
        microlens_blur: two()?,
        blur_px: two()?,
        conventional_px: two()?,
    };
    let buffers = CurvesOut {
        conjugate: &mut out.conjugate,
        main_blur: &mut out.main_blur,
        repetitions: &mut out.repetitions,
        microlens_blur: &mut out.microlens_blur,
        blur_px: &mut out.blur_px,
        conventional_px: &mut out.conventional_px,
    };
    curves_into(cam, z, buffers, n_threads)?;
    Ok(out)
}

/// [`curves`] written straight into caller-provided buffers (e.g. NumPy arrays), so the
/// outputs are the only large allocation and each is written once: one fused pass per
/// chunk of depths computes z' once and all ten per-half values from it, in parallel over
/// chunks. Depths are validated and lengths checked before any write.
pub fn curves_into(
    cam: &Camera,
    z: &[f64],
    out: CurvesOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    check_depths(cam, z)?;
    let n = z.len();
    let two = [
        out.main_blur.len(),
        out.repetitions.len(),
        out.microlens_blur.len(),
        out.blur_px.len(),
        out.conventional_px.len(),
    ];
    if out.conjugate.len() != n || two.iter().any(|&l| l != 2 * n) {
        return Err(Error::param(
            "output length",
            format!("{:?}", (out.conjugate.len(), two)),
            format!("{n} (conjugate) and {} (two-row arrays)", 2 * n),
        ));
    }
    let (h0, h1) = out.main_blur.split_at_mut(n);
    let (r0, r1) = out.repetitions.split_at_mut(n);
    let (b0, b1) = out.microlens_blur.split_at_mut(n);
    let (p0, p1) = out.blur_px.split_at_mut(n);
    let (c0, c1) = out.conventional_px.split_at_mut(n);
    // Chunks of depths with an interrupt checkpoint between them; inside a chunk one task
    // per CHUNK depths, each owning disjoint slices of every output.
    let step = CHUNK * 64;
    for_chunks(n_threads, n, step, |r| {
        let zs = &z[r.clone()];
        let one = [&mut *h0, &mut *r0, &mut *b0, &mut *p0, &mut *c0].map(|s| &mut s[r.clone()]);
        let two = [&mut *h1, &mut *r1, &mut *b1, &mut *p1, &mut *c1].map(|s| &mut s[r.clone()]);
        let [[h0, r0, b0, p0, c0], [h1, r1, b1, p1, c1]] =
            [one, two].map(|r| r.map(|s| s.par_chunks_mut(CHUNK)));
        out.conjugate[r.clone()]
            .par_chunks_mut(CHUNK)
            .zip(zs.par_chunks(CHUNK))
            .zip(h0.zip(r0).zip(b0).zip(p0).zip(c0))
            .zip(h1.zip(r1).zip(b1).zip(p1).zip(c1))
            .for_each(|(((zc, zs), one), two)| {
                let ((((h0, r0), b0), p0), c0) = one;
                let ((((h1, r1), b1), p1), c1) = two;
                curves_chunk(cam, zs, zc, [h0, r0, b0, p0, c0], [h1, r1, b1, p1, c1]);
            });
        Ok(())
    })
}

/// One chunk of [`curves_into`]: every output element written once, in one streaming pass.
#[inline]
fn curves_chunk(
    cam: &Camera,
    zs: &[f64],
    zc: &mut [f64],
    one: [&mut [f64]; 5],
    two: [&mut [f64]; 5],
) {
    let m = zs.len();
    // Re-slicing to the chunk length lets the compiler drop the bounds checks.
    let zc = &mut zc[..m];
    let [h0, r0, b0, p0, c0] = one.map(|s| &mut s[..m]);
    let [h1, r1, b1, p1, c1] = two.map(|s| &mut s[..m]);
    for k in 0..m {
        let zck = conjugate(cam.f_main, zs[k]);
        zc[k] = zck;
        let hk = main_blur(cam, Half::One, zck);
        let bk = microlens_blur(cam, Half::One, zck);
        h0[k] = hk;
        r0[k] = repetitions(cam, hk);
        b0[k] = bk;
        p0[k] = lf_blur_px(cam, Half::One, bk);
        c0[k] = hk / cam.mu;
        let hk = main_blur(cam, Half::Two, zck);
        let bk = microlens_blur(cam, Half::Two, zck);
        h1[k] = hk;
        r1[k] = repetitions(cam, hk);
        b1[k] = bk;
        p1[k] = lf_blur_px(cam, Half::Two, bk);
        c1[k] = hk / cam.mu;
    }
}

/// Sharp depth intervals (near, far) in mm, sorted; `far` may be +∞. Open intervals:
/// at a boundary the blur equals the threshold.
pub type Intervals = Vec<(f64, f64)>;

/// Depth of field of every configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthOfField {
    /// Each half as a LF camera (bounded blur min(b_i, R_i)/μ), [half 1, half 2].
    pub half: [Intervals; 2],
    /// Split sensor: sharp where either half is.
    pub split: Intervals,
    /// Conventional cameras (sensor on array plane i, blur H_i/μ), [plane 1, plane 2].
    pub conventional: [Intervals; 2],
}

/// Merge overlapping open intervals (sorted output). Touching intervals stay apart: the
/// shared endpoint is sharp in neither.
pub fn union_intervals(mut iv: Intervals) -> Intervals {
    iv.retain(|(a, b)| a < b);
    iv.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Intervals = Vec::with_capacity(iv.len());
    for (a, b) in iv {
        match out.last_mut() {
            Some(last) if a < last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}

/// LF half i: min(b_i, R_i)/μ < t. With y = 1/(L_i − z') and a = 1/f_i − 1/v,
/// b_i < tμ ⇔ a − c < y < a + c, c = 2tμ/(d v). y is increasing in z' on each branch
/// z' ∈ (F, L_i) (y > 1/(L_i − F)) and z' ∈ (L_i, ∞) (y < 0); z' = L_i − 1/y on both.
fn lf_sharp(cam: &Camera, half: Half, t: f64) -> Intervals {
    let f_main = cam.f_main;
    if cam.image_radius(half) / cam.mu < t {
        return vec![(f_main, f64::INFINITY)];
    }
    let l = cam.array_plane(half);
    let a = 1.0 / cam.microlens_focal(half) - 1.0 / cam.v;
    let c = 2.0 * t * cam.mu / (cam.d * cam.v);
    let zc_of = |y: f64| -> f64 {
        if y == 0.0 {
            f64::INFINITY
        } else {
            l - 1.0 / y
        }
    };
    let mut iv = Vec::new();
    // Branch z' ∈ (F, L): y ∈ (1/(L − F), ∞). The lower end y = 1/(L − F) is z' = F, z = ∞.
    let y_min = 1.0 / (l - f_main);
    let (lo, hi) = ((a - c).max(y_min), a + c);
    if lo < hi {
        let far = if lo == y_min {
            f64::INFINITY
        } else {
            depth_of_conjugate(f_main, zc_of(lo))
        };
        iv.push((depth_of_conjugate(f_main, zc_of(hi)), far));
    }
    // Branch z' ∈ (L, ∞): y ∈ (−∞, 0). y → 0⁻ is z' → ∞, z → F.
    let (lo, hi) = (a - c, (a + c).min(0.0));
    if lo < hi {
        iv.push((
            depth_of_conjugate(f_main, zc_of(hi)),
            depth_of_conjugate(f_main, zc_of(lo)),
        ));
    }
    union_intervals(iv)
}

/// Conventional camera on plane i: H_i/μ < t ⇔ |y − 1/L_i| < c', y = 1/z' ∈ (0, 1/F),
/// c' = 2tμ/(D L_i); the depth is z = 1/(1/F − y), increasing in y.
fn conventional_sharp(cam: &Camera, half: Half, t: f64) -> Intervals {
    let l = cam.array_plane(half);
    let c = 2.0 * t * cam.mu / (cam.aperture * l);
    let y_max = 1.0 / cam.f_main;
    let lo = (1.0 / l - c).max(0.0);
    let hi = 1.0 / l + c;
    let z_of = |y: f64| -> f64 {
        if y >= y_max {
            f64::INFINITY
        } else if y <= 0.0 {
            cam.f_main
        } else {
            depth_of_conjugate(cam.f_main, 1.0 / y)
        }
    };
    if lo < hi.min(y_max) {
        // Mapped to depth, a band of y narrower than the spacing of floats at z can
        // collapse to one depth: `union_intervals` drops such empty intervals.
        union_intervals(vec![(z_of(lo), z_of(hi))])
    } else {
        Vec::new()
    }
}

/// Depth of field, every boundary in closed form (the blur equations inverted).
pub fn depth_of_field(cam: &Camera, threshold_px: f64) -> Result<DepthOfField> {
    if !(threshold_px.is_finite() && threshold_px > 0.0) {
        return Err(Error::param(
            "threshold_px",
            threshold_px,
            "a finite number of pixels > 0",
        ));
    }
    let half = Half::BOTH.map(|h| lf_sharp(cam, h, threshold_px));
    let conventional = Half::BOTH.map(|h| conventional_sharp(cam, h, threshold_px));
    let split = union_intervals(half.iter().flatten().copied().collect());
    Ok(DepthOfField {
        half,
        split,
        conventional,
    })
}

/// Fraction of the depth range [lo, hi] covered by `intervals`, measured in log depth:
/// Σ |log(iv ∩ [lo, hi])| / log(hi / lo). The intervals must not overlap (as returned).
pub fn log_fraction(intervals: &[(f64, f64)], lo: f64, hi: f64) -> Result<f64> {
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
        return Err(Error::param(
            "depth range",
            format!("[{lo}, {hi}]"),
            "finite depths 0 < min < max",
        ));
    }
    let covered: f64 = intervals
        .iter()
        .map(|&(a, b)| (a.max(lo), b.min(hi)))
        .filter(|(a, b)| a < b)
        .map(|(a, b)| (b / a).ln())
        .sum();
    Ok((covered / (hi / lo).ln()).clamp(0.0, 1.0))
}

/// Sharp fractions (log depth) over [lo, hi] of every configuration of [`depth_of_field`]:
/// [half 1, half 2, split, conventional 1, conventional 2].
pub fn sharp_fractions(cam: &Camera, threshold_px: f64, lo: f64, hi: f64) -> Result<[f64; 5]> {
    let dof = depth_of_field(cam, threshold_px)?;
    Ok([
        log_fraction(&dof.half[0], lo, hi)?,
        log_fraction(&dof.half[1], lo, hi)?,
        log_fraction(&dof.split, lo, hi)?,
        log_fraction(&dof.conventional[0], lo, hi)?,
        log_fraction(&dof.conventional[1], lo, hi)?,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blur_at(cam: &Camera, half: Half, z: f64) -> f64 {
        let zc = conjugate(cam.f_main, z);
        lf_blur_px(cam, half, microlens_blur(cam, half, zc))
    }

    #[test]
    fn curves_match_scalar_functions() {
        let cam = Camera::paper();
        let z: Vec<f64> = (0..40_000).map(|i| 81.0 + i as f64 * 0.25).collect();
        let out = curves(&cam, &z, Some(2)).unwrap();
        for (k, &zk) in z.iter().enumerate().step_by(997) {
            let zc = conjugate(cam.f_main, zk);
            assert_eq!(out.conjugate[k], zc);
            assert_eq!(out.main_blur[z.len() + k], main_blur(&cam, Half::Two, zc));
            assert_eq!(out.blur_px[k], blur_at(&cam, Half::One, zk));
        }
    }

    #[test]
    fn rejects_depth_at_focal_length() {
        let cam = Camera::paper();
        let err = curves(&cam, &[100.0, 80.0], None).unwrap_err();
        assert!(matches!(err, Error::InvalidDepth { index: 1, .. }));
        assert!(curves(&cam, &[f64::NAN], None).is_err());
    }

    #[test]
    fn blur_is_bounded_at_out_of_focus_plane() {
        let cam = Camera::paper();
        for half in Half::BOTH {
            let z = cam.out_of_focus_depth(half);
            let px = blur_at(&cam, half, z);
            assert!((px - cam.image_radius(half) / cam.mu).abs() < 1e-9);
        }
    }

    #[test]
    fn dof_boundaries_hit_threshold() {
        let cam = Camera::paper();
        let dof = depth_of_field(&cam, 0.5).unwrap();
        for half in Half::BOTH {
            for &(near, far) in &dof.half[half.index()] {
                for b in [near, far] {
                    if b.is_finite() && b > cam.f_main {
                        assert!((blur_at(&cam, half, b) - 0.5).abs() < 1e-6, "{b}");
                    }
                }
                let mid = if far.is_finite() {
                    0.5 * (near + far)
                } else {
                    near * 2.0
                };
                assert!(blur_at(&cam, half, mid) < 0.5);
            }
        }
        // The split sensor covers at least what half 1 covers.
        assert!(dof.split.len() <= dof.half[0].len() + dof.half[1].len());
    }

    #[test]
    fn log_fraction_by_hand() {
        // [10, 1000] is two decades; (10, 100) covers one of them, (500, inf) log10(2) more.
        let f = log_fraction(&[(1.0, 100.0), (500.0, f64::INFINITY)], 10.0, 1000.0).unwrap();
        assert!((f - (1.0 + 2f64.log10()) / 2.0).abs() < 1e-15);
        assert_eq!(log_fraction(&[], 10.0, 1000.0).unwrap(), 0.0);
        assert!(log_fraction(&[], 10.0, 10.0).is_err());
        let s = sharp_fractions(&Camera::paper(), 0.5, 150.0, 10_000.0).unwrap();
        assert_eq!(s[2], 1.0);
        assert!(s[0] < 1.0 && s[1] < 1.0 && s[3] < 0.01);
    }
}
