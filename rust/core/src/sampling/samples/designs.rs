//! New samples of a design at every depth: every channel along x and their union
//! (docs/model.md §9), in parallel over depths.

use rayon::prelude::*;

use super::sorted::{field_gap, line_samples, merge_into, scan, LineSamples, Scratch, Work};
use super::*;
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_reserve, try_vec};
use crate::infra::parallel::{checkpoint, chunk_items, for_chunks, threads};
use crate::model::design::Design;
use crate::model::lens::conjugate;
use crate::model::optics::check_design_depths;
use crate::sampling::line::Axis;
use crate::sampling::line::Line;
use crate::sampling::rayspace::{trace_line_threads, Sample, TRACE_BYTES_PER_PIXEL};

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
pub(super) fn check_line_size(lines: &[&Line]) -> Result<()> {
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
    /// The chief samples' lattices, or every lit pixel's centroid (traced on the pool of
    /// `n_threads` in chunks, with a check for Ctrl-C between them).
    pub(super) fn new(lines: &[Line], mode: Sample, n_threads: Option<usize>) -> Result<Sources> {
        Ok(match mode {
            Sample::Chief => Sources::Chief(lines.iter().map(LineSamples::new).collect()),
            Sample::Centroid => {
                let mut all = Vec::new();
                for line in lines {
                    let tr = trace_line_threads(line, n_threads)?;
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

    pub(super) fn sampled(&self) -> Vec<u64> {
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
    pub(super) pos: Vec<Vec<f64>>,
    pub(super) union: [Vec<f64>; 2],
    pub(super) work: Work,
}

impl DesignScratch {
    pub(super) fn reserved(sizes: &[usize], inner: usize, q: usize) -> Result<DesignScratch> {
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

    pub(super) fn bytes(sizes: &[usize], inner: usize, q: usize) -> u128 {
        let total: u128 = sizes.iter().map(|&n| n as u128).sum();
        24 * total + 40 * inner as u128 + 8 * q as u128
    }
}

/// What every depth of one design new_samples call shares: the channels' lines, their
/// sample sources, the merge tolerance eps = tol δ, the step δ (p' per δ(z)) and the
/// central field's half-width, in p' space.
struct DepthSetup<'a> {
    lines: &'a [Line],
    src: &'a Sources,
    eps: f64,
    step: f64,
    field: f64,
}

/// Distinct counts and gaps (in δ(z)) of every channel and of the union at one depth,
/// written to `d` and `g` (C + 1 entries each).
fn design_depth(
    setup: &DepthSetup<'_>,
    z: f64,
    s: &mut DesignScratch,
    d: &mut [u64],
    g: &mut [f64],
) {
    let &DepthSetup {
        lines,
        src,
        eps,
        step,
        field,
    } = setup;
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
    let src = Sources::new(&lines, mode, n_threads)?;
    let setup = DepthSetup {
        lines: &lines,
        src: &src,
        eps,
        step,
        field,
    };
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
                        // A depth sorts every pixel's sample (0.1 s at 10^5 lenses): a stop
                        // is checked per depth, not per chunk of them.
                        checkpoint()?;
                        let span = i * rows..(i + 1) * rows;
                        design_depth(&setup, zi, s, &mut dc[span.clone()], &mut gc[span]);
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
    use crate::model::camera::{Camera, CameraSpec};
    use crate::sampling::samples::test_designs::*;

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
        let d = Camera::new(&CameraSpec {
            f_main: 50.0,
            aperture: 2.65,
            v1: 52.0,
            kappa: 6.2e-6 / 52.0,
            d: 0.1,
            v: 1.0,
            mu: 0.05,
            q: 1,
            kx: 10,
            ky: 1,
            f1: None,
            f2: None,
        })
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
