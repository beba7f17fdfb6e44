//! Closed-form optics over depth (docs/model.md §2: Eqs. 1, 4–7) and depth of field.
//!
//! Every expression is written in one fixed order so that a NumPy transcription of
//! docs/model.md evaluates to the same floating-point result.

use rayon::prelude::*;

use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::for_chunks;
use crate::model::design::{Channel, Design};
use crate::model::lens::{conjugate, depth_of_conjugate};
use std::ops::Range;

/// Default sharpness threshold on the blur radius, in pixels.
pub const DEFAULT_THRESHOLD_PX: f64 = 0.5;

/// Check a depth array: every element finite and > F (Eq. 1 is defined for z > F only),
/// for a main lens of focal length `f_main`.
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

/// One light field array as the closed forms of docs/model.md §2 see it: the main lens
/// (focal length F, aperture D), the array plane L, the microlens pitch d, the distance v
/// from the array to the sensor, the pixel pitch μ and one microlens focal length f.
///
/// Every formula of §2 is written here once. A channel of a design gives one per lens type
/// ([`LensOptics::of_channel`], docs/model.md §9); a half of the paper's split sensor is
/// channel i of its two-channel design (`Camera::design`). Every expression keeps the
/// order of operations of docs/model.md, so the seed's numbers are those of its closed
/// forms bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LensOptics {
    /// F, main lens focal length.
    pub f_main: f64,
    /// D, main lens aperture width (the blur formulas use D / 2 as the cone's radius).
    pub aperture: f64,
    /// L, main lens to microlens array.
    pub l: f64,
    /// d, microlens pitch (= microlens aperture).
    pub d: f64,
    /// v, microlens array to sensor.
    pub v: f64,
    /// μ, pixel pitch.
    pub mu: f64,
    /// f, microlens focal length of this lens type.
    pub f: f64,
}

impl LensOptics {
    /// Lens type `t` (from 0) of channel `ch` of `design` (docs/model.md §9: the microlens
    /// and LF blur of type t are §2 with f_t). `t` must be below `ch.types()`.
    pub fn of_channel(design: &Design, ch: &Channel, t: usize) -> LensOptics {
        LensOptics {
            f_main: design.f_main,
            aperture: design.aperture,
            l: ch.l,
            d: ch.d,
            v: ch.v,
            mu: ch.mu,
            f: ch.f[t],
        }
    }

    /// Eqs. 2–3 (missing in the paper): main-lens blur radius on the array plane,
    /// H = (D L / 2) |1/z' − 1/L|.
    #[inline]
    pub fn main_blur(&self, zc: f64) -> f64 {
        (self.aperture * self.l / 2.0) * (1.0 / zc - 1.0 / self.l).abs()
    }

    /// Eqs. 4–5: repetitions rep = 2 H / d.
    #[inline]
    pub fn repetitions(&self, h: f64) -> f64 {
        2.0 * h / self.d
    }

    /// Eqs. 6–7: microlens blur b = (d v / 2) |1/f − 1/(L − z') − 1/v| (mm, unbounded).
    #[inline]
    pub fn microlens_blur(&self, zc: f64) -> f64 {
        (self.d * self.v / 2.0) * (1.0 / self.f - 1.0 / (self.l - zc) - 1.0 / self.v).abs()
    }

    /// R = D v / (2 L): radius of one microlens image on the sensor (the LF blur's bound).
    #[inline]
    pub fn image_radius(&self) -> f64 {
        self.aperture * self.v / (2.0 * self.l)
    }

    /// The bounded LF blur of Fig. 1 in pixels: min(b, R) / μ.
    #[inline]
    pub fn lf_blur_px(&self, b: f64) -> f64 {
        b.min(self.image_radius()) / self.mu
    }

    /// Conventional blur in pixels (the sensor on the array plane, no microlenses): H / μ.
    #[inline]
    pub fn conventional_px(&self, h: f64) -> f64 {
        h / self.mu
    }

    /// Out-of-focus plane: the depth whose conjugate lies on the array, F L / (L − F).
    pub fn out_of_focus_depth(&self) -> f64 {
        self.f_main * self.l / (self.l - self.f_main)
    }

    /// The depth this lens type is focused on (b = 0): the conjugate z' with
    /// 1/(L − z') = 1/f − 1/v, mapped to depth by the inverse of Eq. 1. `None` when no
    /// real depth has b = 0 (z' = L − 1/(1/f − 1/v) not beyond F, or 1/f = 1/v: focused at
    /// z' = ∞, i.e. on the main lens's front focal plane). In Ng's setting 1/f − 1/v = 1/L,
    /// so z' = 0: the microlenses are focused on the main lens, and there is none.
    pub fn focus_depth(&self) -> Option<f64> {
        let a = 1.0 / self.f - 1.0 / self.v;
        if a == 0.0 {
            return None;
        }
        let zc = self.l - 1.0 / a;
        (zc.is_finite() && zc > self.f_main).then(|| depth_of_conjugate(self.f_main, zc))
    }
}

/// Depths per parallel task: large enough to amortise scheduling, small enough to balance
/// (and to keep a task's output streams short runs of fresh pages).
const CHUNK: usize = 16 * 1024;

/// Sharp depth intervals (near, far) in mm, sorted; `far` may be +∞. Open intervals:
/// at a boundary the blur equals the threshold.
pub type Intervals = Vec<(f64, f64)>;

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

impl LensOptics {
    /// Sharp depths of the light field camera: min(b, R)/μ < t. With y = 1/(L − z') and
    /// a = 1/f − 1/v, b < tμ ⇔ a − c < y < a + c, c = 2tμ/(d v). y is increasing in z' on
    /// each branch z' ∈ (F, L) (y > 1/(L − F)) and z' ∈ (L, ∞) (y < 0); z' = L − 1/y on
    /// both.
    pub fn lf_sharp(&self, t: f64) -> Intervals {
        let f_main = self.f_main;
        if self.image_radius() / self.mu < t {
            return vec![(f_main, f64::INFINITY)];
        }
        let l = self.l;
        let a = 1.0 / self.f - 1.0 / self.v;
        let c = 2.0 * t * self.mu / (self.d * self.v);
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

    /// Sharp depths of the conventional camera with its sensor on the array plane:
    /// H/μ < t ⇔ |y − 1/L| < c', y = 1/z' ∈ (0, 1/F), c' = 2tμ/(D L); the depth is
    /// z = 1/(1/F − y), increasing in y. (f does not enter.)
    pub fn conventional_sharp(&self, t: f64) -> Intervals {
        let l = self.l;
        let c = 2.0 * t * self.mu / (self.aperture * l);
        let y_max = 1.0 / self.f_main;
        let lo = (1.0 / l - c).max(0.0);
        let hi = 1.0 / l + c;
        let z_of = |y: f64| -> f64 {
            if y >= y_max {
                f64::INFINITY
            } else if y <= 0.0 {
                self.f_main
            } else {
                depth_of_conjugate(self.f_main, 1.0 / y)
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
}

/// A sharpness threshold must be a finite number of pixels > 0.
fn check_threshold(threshold_px: f64) -> Result<()> {
    if threshold_px.is_finite() && threshold_px > 0.0 {
        Ok(())
    } else {
        Err(Error::param(
            "threshold_px",
            threshold_px,
            "a finite number of pixels > 0",
        ))
    }
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

// ---- general designs (docs/model.md §9) ----------------------------------------------

/// The per-type rows of a design's outputs: (channel, lens type), both from 0, channels in
/// order and each channel's types in order. A channel in Ng's setting has one type.
pub fn type_rows(design: &Design) -> Vec<(usize, usize)> {
    design
        .channels
        .iter()
        .enumerate()
        .flat_map(|(i, ch)| (0..ch.types()).map(move |t| (i, t)))
        .collect()
}

/// Closed-form curves of a design at n depths. Per-channel arrays are row-major (C, n),
/// one row per channel; per-type arrays (R, n), one row per [`type_rows`] entry. `B` is
/// the storage of each array: owned (`Vec<f64>`, what [`design_curves`] returns) or the
/// caller's buffers ([`DesignCurvesOut`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DesignCurves<B = Vec<f64>> {
    /// z' (n).
    pub conjugate: B,
    /// H of each channel (C, n).
    pub main_blur: B,
    /// rep = 2 H / d of each channel (C, n).
    pub repetitions: B,
    /// H / μ of each channel (C, n).
    pub conventional_px: B,
    /// b of each (channel, type) (R, n).
    pub microlens_blur: B,
    /// min(b, R) / μ of each (channel, type) (R, n).
    pub blur_px: B,
    /// The smallest `blur_px` of each channel's types (C, n): the channel is sharp where it
    /// is below the threshold.
    pub channel_blur_px: B,
    /// The smallest `blur_px` of every row (n): the design is sharp where it is below the
    /// threshold.
    pub union_blur_px: B,
}

/// Output buffers of [`design_curves_into`] (shapes as in [`DesignCurves`]). Any initial
/// content: every element is written exactly once.
pub type DesignCurvesOut<'a> = DesignCurves<&'a mut [f64]>;

impl DesignCurves {
    /// The owned arrays as the output buffers of [`design_curves_into`].
    pub fn as_out(&mut self) -> DesignCurvesOut<'_> {
        DesignCurves {
            conjugate: &mut self.conjugate,
            main_blur: &mut self.main_blur,
            repetitions: &mut self.repetitions,
            conventional_px: &mut self.conventional_px,
            microlens_blur: &mut self.microlens_blur,
            blur_px: &mut self.blur_px,
            channel_blur_px: &mut self.channel_blur_px,
            union_blur_px: &mut self.union_blur_px,
        }
    }
}

/// Bytes of the outputs of [`design_curves`] at n depths: (2 + 4 C + 2 R) f64 per depth.
pub fn design_curves_bytes(design: &Design, n: usize) -> u128 {
    let c = design.channels.len() as u128;
    let r = type_rows(design).len() as u128;
    memory::bytes_of::<f64>((2 + 4 * c + 2 * r) * n as u128)
}

/// Evaluate every curve of a design at every depth (validated first), in parallel.
pub fn design_curves(design: &Design, z: &[f64], n_threads: Option<usize>) -> Result<DesignCurves> {
    check_design_depths(design.f_main, z)?;
    let n = z.len();
    memory::check("curves", design_curves_bytes(design, n))?;
    let c = design.channels.len();
    let r = type_rows(design).len();
    let buf = |rows: usize| memory::try_vec("curves", rows * n, 0.0);
    let mut out = DesignCurves {
        conjugate: buf(1)?,
        main_blur: buf(c)?,
        repetitions: buf(c)?,
        conventional_px: buf(c)?,
        microlens_blur: buf(r)?,
        blur_px: buf(r)?,
        channel_blur_px: buf(c)?,
        union_blur_px: buf(1)?,
    };
    design_curves_into(design, z, out.as_out(), n_threads)?;
    Ok(out)
}

/// The rows of a row-major (rows × n) buffer restricted to the depths `span`, each cut
/// into pieces of [`CHUNK`] depths: `pieces[j][row]` is row `row`'s piece `j`.
fn pieces<'a>(buf: &'a mut [f64], n: usize, span: &Range<usize>) -> Vec<Vec<&'a mut [f64]>> {
    let mut out: Vec<Vec<&'a mut [f64]>> = (0..span.len().div_ceil(CHUNK))
        .map(|_| Vec::new())
        .collect();
    if n > 0 {
        for row in buf.chunks_mut(n) {
            for (j, p) in row[span.clone()].chunks_mut(CHUNK).enumerate() {
                out[j].push(p);
            }
        }
    }
    out
}

/// One piece of [`CHUNK`] depths of every output of [`design_curves_into`], one slice
/// per row of each output.
struct Piece<'a> {
    start: usize,
    conjugate: Vec<&'a mut [f64]>,
    main_blur: Vec<&'a mut [f64]>,
    repetitions: Vec<&'a mut [f64]>,
    conventional_px: Vec<&'a mut [f64]>,
    microlens_blur: Vec<&'a mut [f64]>,
    blur_px: Vec<&'a mut [f64]>,
    channel_blur_px: Vec<&'a mut [f64]>,
    union_blur_px: Vec<&'a mut [f64]>,
}

/// [`design_curves`] written straight into caller-provided buffers (e.g. NumPy arrays).
/// Each row is computed by the [`LensOptics`] formulas, every output of a depth in one
/// pass (the conjugate once per depth; memory is touched once). Depths are validated and
/// lengths checked before any write.
pub fn design_curves_into(
    design: &Design,
    z: &[f64],
    out: DesignCurvesOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    check_design_depths(design.f_main, z)?;
    let n = z.len();
    let rows = type_rows(design);
    let (c, r) = (design.channels.len(), rows.len());
    let lengths = [
        (out.conjugate.len(), n),
        (out.main_blur.len(), c * n),
        (out.repetitions.len(), c * n),
        (out.conventional_px.len(), c * n),
        (out.microlens_blur.len(), r * n),
        (out.blur_px.len(), r * n),
        (out.channel_blur_px.len(), c * n),
        (out.union_blur_px.len(), n),
    ];
    if lengths.iter().any(|&(got, want)| got != want) {
        return Err(Error::param(
            "output length",
            format!("{:?}", lengths.map(|l| l.0)),
            format!("{:?}", lengths.map(|l| l.1)),
        ));
    }
    let f_main = design.f_main;
    // The channel-level formulas (H, rep, H/μ) do not read f: any type stands for them.
    let channel: Vec<LensOptics> = design
        .channels
        .iter()
        .map(|ch| LensOptics::of_channel(design, ch, 0))
        .collect();
    let typed: Vec<(usize, LensOptics)> = rows
        .iter()
        .map(|&(i, t)| (i, LensOptics::of_channel(design, &design.channels[i], t)))
        .collect();
    let DesignCurvesOut {
        conjugate: conj_buf,
        main_blur,
        repetitions,
        conventional_px,
        microlens_blur,
        blur_px,
        channel_blur_px,
        union_blur_px,
    } = out;
    let step = CHUNK * 64;
    for_chunks(n_threads, n, step, |span| {
        let mut parts: Vec<Piece> = Vec::new();
        let mut conj = pieces(conj_buf, n, &span).into_iter();
        let mut mb = pieces(main_blur, n, &span).into_iter();
        let mut rep = pieces(repetitions, n, &span).into_iter();
        let mut conv = pieces(conventional_px, n, &span).into_iter();
        let mut micro = pieces(microlens_blur, n, &span).into_iter();
        let mut blur = pieces(blur_px, n, &span).into_iter();
        let mut chan = pieces(channel_blur_px, n, &span).into_iter();
        let mut uni = pieces(union_blur_px, n, &span).into_iter();
        for j in 0..span.len().div_ceil(CHUNK) {
            parts.push(Piece {
                start: span.start + j * CHUNK,
                conjugate: conj.next().unwrap_or_default(),
                main_blur: mb.next().unwrap_or_default(),
                repetitions: rep.next().unwrap_or_default(),
                conventional_px: conv.next().unwrap_or_default(),
                microlens_blur: micro.next().unwrap_or_default(),
                blur_px: blur.next().unwrap_or_default(),
                channel_blur_px: chan.next().unwrap_or_default(),
                union_blur_px: uni.next().unwrap_or_default(),
            });
        }
        parts.into_par_iter().for_each(|mut p| {
            // Row by row over the piece (each loop vectorises; the piece stays in cache).
            let zs = &z[p.start..(p.start + CHUNK).min(n)];
            let m = zs.len();
            let zc = &mut p.conjugate[0][..m];
            for (o, &zk) in zc.iter_mut().zip(zs) {
                *o = conjugate(f_main, zk);
            }
            let zc: &[f64] = zc;
            for (i, o) in channel.iter().enumerate() {
                let (h, rep) = (&mut p.main_blur[i][..m], &mut p.repetitions[i][..m]);
                let conv = &mut p.conventional_px[i][..m];
                for k in 0..m {
                    let hk = o.main_blur(zc[k]);
                    h[k] = hk;
                    rep[k] = o.repetitions(hk);
                    conv[k] = o.conventional_px(hk);
                }
                p.channel_blur_px[i][..m].fill(f64::INFINITY);
            }
            p.union_blur_px[0][..m].fill(f64::INFINITY);
            for (row, (i, o)) in typed.iter().enumerate() {
                let (b, px) = (&mut p.microlens_blur[row][..m], &mut p.blur_px[row][..m]);
                for k in 0..m {
                    let bk = o.microlens_blur(zc[k]);
                    b[k] = bk;
                    px[k] = o.lf_blur_px(bk);
                }
                let px: &[f64] = px;
                for (c, &x) in p.channel_blur_px[*i][..m].iter_mut().zip(px) {
                    *c = c.min(x);
                }
                for (u, &x) in p.union_blur_px[0][..m].iter_mut().zip(px) {
                    *u = u.min(x);
                }
            }
        });
        Ok(())
    })
}

/// Depth of field of a design (docs/model.md §9): sharp intervals of each lens type of
/// each channel (the LF blur of §2 with f_t), of each channel (sharp where any of its
/// types is), of the design (where any channel is), and of the conventional camera with
/// its sensor on each channel's array plane.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignDepthOfField {
    /// One entry per [`type_rows`] row.
    pub types: Vec<Intervals>,
    /// One entry per channel: the union of its types' intervals.
    pub channels: Vec<Intervals>,
    /// The union over channels.
    pub union: Intervals,
    /// One entry per channel: blur H/μ with the sensor on its array plane.
    pub conventional: Vec<Intervals>,
}

/// Depth of field of a design, every boundary in closed form ([`LensOptics::lf_sharp`],
/// [`LensOptics::conventional_sharp`], [`union_intervals`]).
pub fn design_depth_of_field(design: &Design, threshold_px: f64) -> Result<DesignDepthOfField> {
    check_threshold(threshold_px)?;
    let mut types = Vec::new();
    let mut channels = Vec::with_capacity(design.channels.len());
    let mut conventional = Vec::with_capacity(design.channels.len());
    for ch in &design.channels {
        let first = types.len();
        for t in 0..ch.types() {
            types.push(LensOptics::of_channel(design, ch, t).lf_sharp(threshold_px));
        }
        channels.push(union_intervals(
            types[first..].iter().flatten().copied().collect(),
        ));
        conventional.push(LensOptics::of_channel(design, ch, 0).conventional_sharp(threshold_px));
    }
    let union = union_intervals(channels.iter().flatten().copied().collect());
    Ok(DesignDepthOfField {
        types,
        channels,
        union,
        conventional,
    })
}

/// Sharp fractions (log depth) over [lo, hi] of every row of [`design_depth_of_field`]:
/// (per [`type_rows`] row, per channel, the union, per channel's conventional camera).
pub type DesignFractions = (Vec<f64>, Vec<f64>, f64, Vec<f64>);

/// [`DesignFractions`] of a design.
pub fn design_sharp_fractions(
    design: &Design,
    threshold_px: f64,
    lo: f64,
    hi: f64,
) -> Result<DesignFractions> {
    let dof = design_depth_of_field(design, threshold_px)?;
    let each = |rows: &[Intervals]| -> Result<Vec<f64>> {
        rows.iter().map(|iv| log_fraction(iv, lo, hi)).collect()
    };
    Ok((
        each(&dof.types)?,
        each(&dof.channels)?,
        log_fraction(&dof.union, lo, hi)?,
        each(&dof.conventional)?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::model::camera::Camera;

    /// The seed's two-channel design (channel i is the paper's half i).
    fn seed() -> Design {
        Camera::paper().design()
    }

    /// Channel `c`'s (from 0) bounded LF blur in pixels at depth z (type 0).
    fn blur_at(d: &Design, c: usize, z: f64) -> f64 {
        let o = LensOptics::of_channel(d, &d.channels[c], 0);
        o.lf_blur_px(o.microlens_blur(conjugate(d.f_main, z)))
    }

    #[test]
    fn curves_match_scalar_functions() {
        let d = seed();
        let z: Vec<f64> = (0..40_000).map(|i| 81.0 + i as f64 * 0.25).collect();
        let out = design_curves(&d, &z, Some(2)).unwrap();
        let two = LensOptics::of_channel(&d, &d.channels[1], 0);
        for (k, &zk) in z.iter().enumerate().step_by(997) {
            let zc = conjugate(d.f_main, zk);
            assert_eq!(out.conjugate[k], zc);
            assert_eq!(out.main_blur[z.len() + k], two.main_blur(zc));
            assert_eq!(out.blur_px[k], blur_at(&d, 0, zk));
        }
    }

    #[test]
    fn rejects_depth_at_focal_length() {
        let d = seed();
        let err = design_curves(&d, &[100.0, 80.0], None).unwrap_err();
        assert!(matches!(err, Error::InvalidDepth { index: 1, .. }));
        assert!(design_curves(&d, &[f64::NAN], None).is_err());
    }

    #[test]
    fn blur_is_bounded_at_out_of_focus_plane() {
        let d = seed();
        for (c, ch) in d.channels.iter().enumerate() {
            let o = LensOptics::of_channel(&d, ch, 0);
            let px = blur_at(&d, c, o.out_of_focus_depth());
            assert!((px - o.image_radius() / ch.mu).abs() < 1e-9);
        }
    }

    #[test]
    fn dof_boundaries_hit_threshold() {
        let d = seed();
        let dof = design_depth_of_field(&d, 0.5).unwrap();
        for (c, iv) in dof.channels.iter().enumerate() {
            for &(near, far) in iv {
                for b in [near, far] {
                    if b.is_finite() && b > d.f_main {
                        assert!((blur_at(&d, c, b) - 0.5).abs() < 1e-6, "{b}");
                    }
                }
                let mid = if far.is_finite() {
                    0.5 * (near + far)
                } else {
                    near * 2.0
                };
                assert!(blur_at(&d, c, mid) < 0.5);
            }
        }
        // The union covers at least what channel 1 covers.
        assert!(dof.union.len() <= dof.channels[0].len() + dof.channels[1].len());
    }

    #[test]
    fn log_fraction_by_hand() {
        // [10, 1000] is two decades; (10, 100) covers one of them, (500, inf) log10(2) more.
        let f = log_fraction(&[(1.0, 100.0), (500.0, f64::INFINITY)], 10.0, 1000.0).unwrap();
        assert!((f - (1.0 + 2f64.log10()) / 2.0).abs() < 1e-15);
        assert_eq!(log_fraction(&[], 10.0, 1000.0).unwrap(), 0.0);
        assert!(log_fraction(&[], 10.0, 10.0).is_err());
        let (_, channels, union, conventional) =
            design_sharp_fractions(&seed(), 0.5, 150.0, 10_000.0).unwrap();
        assert_eq!(union, 1.0);
        assert!(channels[0] < 1.0 && channels[1] < 1.0 && conventional[0] < 0.01);
    }

    fn multi_focus() -> Design {
        use crate::model::design::{Aperture, ChannelSpec, Grid};
        let spec = ChannelSpec {
            l: 56.86,
            d: 0.12744,
            v: 0.33713,
            mu: 0.0055,
            kx: 12,
            ky: 10,
            grid: Grid::Hex,
            f: Some(vec![0.58267, 0.52402, 0.56057]),
            layout: "sensor".into(),
            q: None,
            mx: None,
            my: None,
            share: 0.6,
        };
        let plain = ChannelSpec {
            f: None,
            l: 70.0,
            share: 0.4,
            ..spec.clone()
        };
        Design::new(49.885, 21.0, Aperture::Circle, &[spec, plain]).unwrap()
    }

    #[test]
    fn design_rows_minima_and_dof_agree() {
        let design = multi_focus();
        let rows = type_rows(&design);
        assert_eq!(rows, vec![(0, 0), (0, 1), (0, 2), (1, 0)]);
        let z: Vec<f64> = (0..20_000).map(|i| 50.0 + 0.05 * i as f64).collect();
        let n = z.len();
        let c = design_curves(&design, &z, Some(2)).unwrap();
        let t = 0.5;
        let dof = design_depth_of_field(&design, t).unwrap();
        let inside = |iv: &Intervals, x: f64| iv.iter().any(|&(a, b)| a < x && x < b);
        for (k, &zk) in z.iter().enumerate() {
            let row = |r: usize| c.blur_px[r * n + k];
            let ch0 = row(0).min(row(1)).min(row(2));
            assert_eq!(c.channel_blur_px[k], ch0);
            assert_eq!(c.channel_blur_px[n + k], row(3));
            assert_eq!(c.union_blur_px[k], ch0.min(row(3)));
            // Membership in the closed-form intervals is sharpness, away from the boundaries.
            for (iv, blur) in [
                (&dof.types[1], row(1)),
                (&dof.channels[0], ch0),
                (&dof.union, c.union_blur_px[k]),
            ] {
                if (blur / t - 1.0).abs() > 1e-9 {
                    assert_eq!(inside(iv, zk), blur < t, "z = {zk}");
                }
            }
            let zc = c.conjugate[k];
            let o = LensOptics::of_channel(&design, &design.channels[0], 2);
            assert_eq!(c.microlens_blur[2 * n + k], o.microlens_blur(zc));
        }
        // Each lens type is sharp around the depth it is focused on.
        for (r, &(i, t)) in rows.iter().enumerate() {
            let o = LensOptics::of_channel(&design, &design.channels[i], t);
            match o.focus_depth() {
                Some(zf) => {
                    assert!(inside(&dof.types[r], zf), "type {t}: {zf}");
                    let zc = conjugate(design.f_main, zf);
                    assert!(o.microlens_blur(zc) < 1e-12);
                }
                None => assert_eq!(i, 1),
            }
        }
    }
}
