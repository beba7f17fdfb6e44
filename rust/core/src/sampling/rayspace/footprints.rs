//! Footprints of every pixel on the planes at many depths: sample position, extent and the
//! piecewise-linear weight profile (docs/model.md §5, docs/rayspace.md).

use rayon::prelude::*;

use super::*;
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_vec, try_with_capacity};
use crate::infra::parallel::{check_threads, chunk_items, for_chunks, with_threads};
use crate::model::lens::conjugate;
use crate::model::optics::check_design_depths;
use crate::sampling::line::Line;

/// Footprints of n pixels at m depths, row-major (m, n); kernels (m, n, 6) when asked.
#[derive(Debug, Clone, PartialEq)]
pub struct Footprints {
    pub m: usize,
    pub n: usize,
    pub position: Vec<f64>,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    /// Breakpoints (object-space X, ascending) and values (aperture length along w, mm)
    /// of the piecewise-linear weight profile, NaN-padded to 6.
    pub kernel: Option<(Vec<f64>, Vec<f64>)>,
}

/// Per-pixel data of the footprint loops, structure-of-arrays so the depth loop vectorises:
/// vertex k of every pixel (padded with copies of vertex 0), and the sample ray.
struct Prepared {
    pub(super) n: usize,
    pub(super) vu: [Vec<f64>; MAX_VERTICES],
    pub(super) vw: [Vec<f64>; MAX_VERTICES],
    pub(super) su: Vec<f64>,
    pub(super) sw: Vec<f64>,
}

fn prepare(tr: &Trace, sample: Sample) -> Result<Prepared> {
    let n = tr.polygons.len();
    let what = "footprints (per-pixel vertices)";
    let mut vu: [Vec<f64>; MAX_VERTICES] = Default::default();
    let mut vw: [Vec<f64>; MAX_VERTICES] = Default::default();
    // Vertex k of every polygon, coordinate c (0: u, 1: w); short polygons repeat their
    // last vertex, empty ones are NaN.
    let column = |k: usize, c: usize| -> Result<Vec<f64>> {
        let mut v = try_with_capacity(what, n)?;
        v.extend(tr.polygons.iter().map(|p| {
            if p.n == 0 {
                f64::NAN
            } else {
                p.v[k.min(p.n - 1)][c]
            }
        }));
        Ok(v)
    };
    for k in 0..MAX_VERTICES {
        vu[k] = column(k, 0)?;
        vw[k] = column(k, 1)?;
    }
    let (mut su, mut sw) = (try_with_capacity(what, n)?, try_with_capacity(what, n)?);
    for i in 0..n {
        let (u, w) = match sample {
            Sample::Centroid => (tr.centroid[i][0], tr.centroid[i][1]),
            // Chief: the position comes from `Line::chief_projection` (see `footprints_line`);
            // the flag NaN marks an unlit pixel.
            Sample::Chief if tr.lit[i] => (0.0, 0.0),
            Sample::Chief => (f64::NAN, f64::NAN),
        };
        su.push(u);
        sw.push(w);
    }
    Ok(Prepared { n, vu, vw, su, sw })
}

/// Rows of output per parallel task (each row is one depth, n pixels).
pub(super) fn rows_per_task(n: usize) -> usize {
    (1usize << 15).div_ceil(n.max(1)).max(1)
}

/// Output buffers of [`footprints_line_into`], each row-major: (m, n) for `position`, `lo`,
/// `hi`; (m, n, 6) for the kernel's breakpoints and values. Any initial content.
pub struct FootprintsOut<'a> {
    pub position: &'a mut [f64],
    pub lo: &'a mut [f64],
    pub hi: &'a mut [f64],
    pub kernel: Option<(&'a mut [f64], &'a mut [f64])>,
}

/// Working bytes per pixel of a footprints call: its trace, the prepared vertex columns
/// and sample rays (14 f64) and the lens centre (1 f64).
const FOOTPRINT_WORK_PER_PIXEL: u128 = TRACE_BYTES_PER_PIXEL + 8 * 15;

/// Bytes a footprints call holds at its peak: the outputs (3 f64 per depth and pixel, 12
/// more with the kernel) and the working buffers (see `FOOTPRINT_WORK_PER_PIXEL`).
pub fn footprints_bytes(m: u128, n: u128, kernel: bool) -> u128 {
    let per = if kernel {
        3 + 2 * MAX_VERTICES as u128
    } else {
        3
    };
    m.saturating_mul(n)
        .saturating_mul(per * 8)
        .saturating_add(n * FOOTPRINT_WORK_PER_PIXEL)
}

/// Validate a footprints call of a line before anything is allocated: thread count, every
/// depth, and the memory it needs ([`footprints_bytes`]). Returns (m, n): depths and pixels.
pub fn check_footprints_line(
    line: &Line,
    z: &[f64],
    kernel: bool,
    n_threads: Option<usize>,
) -> Result<(usize, usize)> {
    check_threads(n_threads)?;
    check_design_depths(line.f_main, z)?;
    let n = line.pixel_count();
    let m = z.len() as u128;
    memory::check("footprints", footprints_bytes(m, n, kernel))?;
    Ok((m as usize, n as usize))
}

/// Footprints of every pixel of a line on the planes at depths `z` (docs/model.md §5):
/// sample position, extent [lo, hi] in object-space X (mm), and with `kernel` the weight
/// profile. Validated before any work; parallel over depths.
pub fn footprints_line(
    line: &Line,
    z: &[f64],
    sample: Sample,
    kernel: bool,
    n_threads: Option<usize>,
) -> Result<Footprints> {
    let (m, n) = check_footprints_line(line, z, kernel, n_threads)?;
    let what = "footprints";
    let mut position = try_vec(what, m * n, 0.0)?;
    let mut lo = try_vec(what, m * n, 0.0)?;
    let mut hi = try_vec(what, m * n, 0.0)?;
    let k = if kernel { m * n * MAX_VERTICES } else { 0 };
    let (mut kb, mut kv) = (try_vec(what, k, 0.0)?, try_vec(what, k, 0.0)?);
    let out = FootprintsOut {
        position: &mut position,
        lo: &mut lo,
        hi: &mut hi,
        kernel: kernel.then_some((&mut kb[..], &mut kv[..])),
    };
    footprints_line_into(line, z, sample, out, n_threads)?;
    Ok(Footprints {
        m,
        n,
        position,
        lo,
        hi,
        kernel: kernel.then_some((kb, kv)),
    })
}

/// [`footprints_line`] written straight into caller-provided buffers (e.g. NumPy arrays),
/// so the outputs are the only large allocation. Lengths are checked against (m, n). Runs
/// in chunks of depths with an interrupt checkpoint between chunks.
pub fn footprints_line_into(
    line: &Line,
    z: &[f64],
    sample: Sample,
    out: FootprintsOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    let (m, n) = check_footprints_line(line, z, out.kernel.is_some(), n_threads)?;
    let lens = [out.position.len(), out.lo.len(), out.hi.len()];
    if lens.iter().any(|&l| l != m * n) {
        return Err(Error::param(
            "output length",
            format!("{lens:?}"),
            format!("{} (m = {m} depths × n = {n} pixels)", m * n),
        ));
    }
    if let Some((b, v)) = &out.kernel {
        if b.len() != m * n * MAX_VERTICES || v.len() != m * n * MAX_VERTICES {
            return Err(Error::param(
                "kernel output length",
                format!("{:?}", (b.len(), v.len())),
                format!("{}", m * n * MAX_VERTICES),
            ));
        }
    }
    if n == 0 || z.is_empty() {
        return Ok(());
    }
    let work = with_threads(n_threads, || -> Result<_> {
        let tr = trace_line(line)?;
        let pre = prepare(&tr, sample)?;
        let mut centres = try_with_capacity("footprints (lens centres)", n)?;
        centres.extend(tr.lens.iter().map(|&j| line.lens_center(j)));
        Ok((tr, pre, centres))
    })??;
    let px = PixelSet {
        tr: &work.0,
        pre: &work.1,
        centres: &work.2[..],
    };
    let cost = n as u128 * if out.kernel.is_some() { 40 } else { 8 };
    let FootprintsOut {
        position,
        lo,
        hi,
        mut kernel,
    } = out;
    for_chunks(n_threads, m, chunk_items(n_threads, cost), |r| {
        let span = r.start * n..r.end * n;
        let rows = FootprintsOut {
            position: &mut position[span.clone()],
            lo: &mut lo[span.clone()],
            hi: &mut hi[span],
            kernel: kernel.as_mut().map(|(b, v)| {
                let w = r.start * n * MAX_VERTICES..r.end * n * MAX_VERTICES;
                (&mut b[w.clone()], &mut v[w])
            }),
        };
        footprint_rows(line, &z[r], &px, sample, rows);
        Ok(())
    })
}

/// What the footprint loops read of one half: its trace, the vertex columns and the lens
/// centre of every pixel.
struct PixelSet<'a> {
    pub(super) tr: &'a Trace,
    pub(super) pre: &'a Prepared,
    pub(super) centres: &'a [f64],
}

/// Footprints at the depths `z` into rows of the same count, in parallel over tasks of
/// [`rows_per_task`] depths.
fn footprint_rows(
    line: &Line,
    z: &[f64],
    px: &PixelSet<'_>,
    sample: Sample,
    out: FootprintsOut<'_>,
) {
    let n = px.pre.n;
    let rows = rows_per_task(n);
    out.position
        .par_chunks_mut(rows * n)
        .zip(out.lo.par_chunks_mut(rows * n))
        .zip(out.hi.par_chunks_mut(rows * n))
        .zip(z.par_chunks(rows))
        .for_each(|(((pos, lo), hi), zs)| {
            for (r, &zk) in zs.iter().enumerate() {
                let span = r * n..(r + 1) * n;
                let zc = conjugate(line.f_main, zk);
                // X = −p' z / v' (negative: lo comes from the largest p').
                let (sigma, scale) = (line.slope(zc), -zk / line.v_ref);
                extent_row(
                    px.pre,
                    sigma,
                    scale,
                    &mut lo[span.clone()],
                    &mut hi[span.clone()],
                );
                position_row(line, px, sample, zk, zc, &mut pos[span]);
            }
        });
    if let Some((br, va)) = out.kernel {
        kernel_rows(line, z, px.tr, br, va);
    }
}

/// Weight profiles of every pixel at the depths `z` (rows of n × 6 breakpoints and values).
fn kernel_rows(line: &Line, z: &[f64], tr: &Trace, br: &mut [f64], va: &mut [f64]) {
    let n = tr.polygons.len();
    let rows = rows_per_task(n);
    let w = n * MAX_VERTICES;
    br.par_chunks_mut(rows * w)
        .zip(va.par_chunks_mut(rows * w))
        .zip(z.par_chunks(rows))
        .for_each(|((br, va), zs)| {
            for (r, &zk) in zs.iter().enumerate() {
                let sigma = line.slope(conjugate(line.f_main, zk));
                let scale = -zk / line.v_ref;
                for (i, p) in tr.polygons.iter().enumerate() {
                    let o = (r * n + i) * MAX_VERTICES;
                    let (b, v) = weight_profile(p, sigma);
                    for t in 0..MAX_VERTICES {
                        // X = −p' z / v' reverses the order: write ascending in X,
                        // then the NaN padding.
                        let (bt, vt) = if t < p.n {
                            (b[p.n - 1 - t] * scale, v[p.n - 1 - t])
                        } else {
                            (f64::NAN, f64::NAN)
                        };
                        br[o + t] = bt;
                        va[o + t] = vt;
                    }
                }
            }
        });
}

/// Extents [lo, hi] of all n pixels at one depth (slope σ, object-space scale −z/v'),
/// written straight into the output rows.
#[inline]
fn extent_row(pre: &Prepared, sigma: f64, scale: f64, lo: &mut [f64], hi: &mut [f64]) {
    let n = pre.n;
    let (vu, vw) = (&pre.vu, &pre.vw);
    // Blocks of pixels, vertex by vertex inside a block: every inner loop runs over
    // equal-length slices (no bounds checks, vectorised), the running min/max stay in
    // registers/L1 and each output element is written once.
    const BLOCK: usize = 64;
    let mut start = 0;
    while start < n {
        let end = (start + BLOCK).min(n);
        let len = end - start;
        let mut mn = [0.0f64; BLOCK];
        let mut mx = [0.0f64; BLOCK];
        let (mn, mx) = (&mut mn[..len], &mut mx[..len]);
        for ((a, b), (&u, &w)) in mn
            .iter_mut()
            .zip(mx.iter_mut())
            .zip(vu[0][start..end].iter().zip(&vw[0][start..end]))
        {
            let p = u + sigma * w;
            *a = p;
            *b = p;
        }
        for k in 1..MAX_VERTICES {
            for ((a, b), (&u, &w)) in mn
                .iter_mut()
                .zip(mx.iter_mut())
                .zip(vu[k][start..end].iter().zip(&vw[k][start..end]))
            {
                let p = u + sigma * w;
                *a = if p < *a { p } else { *a };
                *b = if p > *b { p } else { *b };
            }
        }
        for ((l, h), (&a, &b)) in lo[start..end]
            .iter_mut()
            .zip(hi[start..end].iter_mut())
            .zip(mn.iter().zip(mx.iter()))
        {
            *l = b * scale;
            *h = a * scale;
        }
        start = end;
    }
}

/// Sample positions of all n pixels at one depth z (conjugate zc).
#[inline]
fn position_row(line: &Line, px: &PixelSet<'_>, sample: Sample, z: f64, zc: f64, pos: &mut [f64]) {
    let pre = px.pre;
    match sample {
        Sample::Centroid => {
            let (sigma, scale) = (line.slope(zc), -z / line.v_ref);
            for ((o, &u), &w) in pos.iter_mut().zip(&pre.su).zip(&pre.sw) {
                *o = (u + sigma * w) * scale;
            }
        }
        Sample::Chief => {
            for (i, o) in pos.iter_mut().enumerate().take(pre.n) {
                let p = line.chief_projection(px.centres[i], px.tr.chief[i][1], zc);
                // su is 0 for lit pixels and NaN for unlit ones.
                *o = line.object_position(p, z) + pre.su[i];
            }
        }
    }
}

/// Weight profile of a polygon on the lines u + σ w = p' (docs/model.md §5): breakpoints p'
/// (the vertex projections, ascending) and the chord length along w at each, the aperture
/// length of the rays from that point the pixel collects (∫ weight dp' = area).
/// An edge parallel to the lines makes a jump at an end of the support: the repeated
/// breakpoint carries 0 on the outside and the edge's length on the inside.
pub fn weight_profile(p: &Polygon, sigma: f64) -> ([f64; MAX_VERTICES], [f64; MAX_VERTICES]) {
    let mut br = [f64::NAN; MAX_VERTICES];
    let mut va = [f64::NAN; MAX_VERTICES];
    let n = p.n;
    if n == 0 {
        return (br, va);
    }
    let mut g = [0.0; MAX_VERTICES];
    for (gk, v) in g.iter_mut().zip(p.vertices()) {
        *gk = v[0] + sigma * v[1];
    }
    let mut order = [0usize; MAX_VERTICES];
    for (k, o) in order.iter_mut().enumerate().take(n) {
        *o = k;
    }
    order[..n].sort_by(|&x, &y| g[x].total_cmp(&g[y]));
    for (t, &k) in order[..n].iter().enumerate() {
        let at = g[k];
        let (mut wmin, mut wmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for e in 0..n {
            let (a, b) = (e, (e + 1) % n);
            if g[a] == at {
                wmin = wmin.min(p.v[a][1]);
                wmax = wmax.max(p.v[a][1]);
            }
            if (g[a] < at && at < g[b]) || (g[b] < at && at < g[a]) {
                let s = (at - g[a]) / (g[b] - g[a]);
                let w = p.v[a][1] + s * (p.v[b][1] - p.v[a][1]);
                wmin = wmin.min(w);
                wmax = wmax.max(w);
            }
        }
        br[t] = at;
        va[t] = wmax - wmin;
    }
    // Jumps at the ends: outermost copy of a repeated end breakpoint has weight 0.
    if n >= 2 && br[0] == br[1] {
        va[0] = 0.0;
    }
    if n >= 2 && br[n - 1] == br[n - 2] {
        va[n - 1] = 0.0;
    }
    (br, va)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera::{Camera, CameraSpec};
    use crate::model::lens::MAX_K;
    use crate::sampling::rayspace::test_designs::*;

    #[test]
    fn weight_profile_integrates_to_area() {
        let d = design(Some(0.4), Some(2.0));
        let ln = line(&d, 2, Axis::X);
        let rays = Rays::new(&ln, 0);
        for q in 0..15 {
            let p = rays.polygon(ln.lens_center(1), ln.ideal_offset(q, 15));
            for sigma in [-0.5, 0.0, 0.3, 2.0] {
                let (b, v) = weight_profile(&p, sigma);
                let mut integral = 0.0;
                for t in 1..p.n {
                    integral += 0.5 * (v[t] + v[t - 1]) * (b[t] - b[t - 1]);
                }
                assert!(close(integral, p.area(), 1e-10), "{integral} {}", p.area());
            }
        }
    }

    #[test]
    fn rejects_bad_input_before_work() {
        let d = Camera::paper().design();
        assert!(axis_from_name("z").is_err());
        assert!(Sample::from_name("mean").is_err());
        let bad = [f64::NAN, 80.0, 10.0, f64::INFINITY];
        for z in bad {
            let r = footprints_line(
                &line(&d, 1, Axis::X),
                &[500.0, z],
                Sample::Chief,
                false,
                None,
            );
            assert!(matches!(r, Err(Error::InvalidDepth { index: 1, .. })));
            assert!(matches!(
                check_design_sample_grid(&d, 1, z, Sample::Chief, None),
                Err(Error::InvalidDepth { .. })
            ));
        }
        let k = MAX_K as i64;
        let huge = Camera::new(&CameraSpec {
            v1: 90.0,
            kappa: 0.3,
            d: 0.1,
            v: 0.3,
            mu: 0.01,
            q: 65_535,
            kx: k,
            ky: k,
            ..CameraSpec::paper()
        })
        .unwrap()
        .design();
        assert!(matches!(
            check_design_sample_grid(&huge, 1, 500.0, Sample::Chief, None),
            Err(Error::TooLarge { .. })
        ));
        assert!(matches!(
            trace_line(&line(&huge, 1, Axis::X)),
            Err(Error::TooLarge { .. })
        ));
    }
}
