//! Ray-space engine (docs/model.md §3–5): every pixel's integration polygon in (u, w) and its
//! footprint on a scene plane at any depth.
//!
//! A ray is (u, w): w its height on the main lens, u where it crosses plane v' (the first
//! array's plane, common to both halves). On array plane L_i it is at x = a u + b w with
//! a = L_i/v', b = 1 − L_i/v'. Pixel q under microlens j (centre c) collects the rays in
//! three strips: the aperture |w| ≤ D/2, the microlens |x − c| ≤ d/2 and the pixel
//! |s' − s| ≤ μ/2 (s' the ray's sensor position). The first two make a parallelogram, the
//! third clips it: a convex polygon of at most 6 vertices, counter-clockwise.
//! A scene plane at depth z is the family of lines p' = u + σ w, σ = (v' − z')/z'; the
//! footprint of a pixel is the image of its polygon under that projection (docs/rayspace.md).

use rayon::prelude::*;

use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_vec, try_with_capacity};
use crate::infra::parallel::{check_threads, chunk_items, for_chunks, with_threads};
use crate::infra::polygon;
use crate::model::design::{Aperture, Design};
use crate::model::lens::conjugate;
use crate::model::optics::check_design_depths;
use crate::sampling::line::Axis;
use crate::sampling::line::Line;

/// Most vertices of an integration polygon (a parallelogram clipped by one strip).
pub const MAX_VERTICES: usize = 6;

/// Axis from its name, "x" or "y".
pub fn axis_from_name(name: &str) -> Result<Axis> {
    match name {
        "x" => Ok(Axis::X),
        "y" => Ok(Axis::Y),
        _ => Err(Error::param("axis", format!("{name:?}"), "\"x\" or \"y\"")),
    }
}

/// Which ray of a pixel stands for its sample position (docs/model.md §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sample {
    /// Projection of the polygon's centroid (aperture-integrated, physical).
    Centroid,
    /// Projection of the chief ray (the paper's convention).
    Chief,
}

impl Sample {
    /// Sample from its name, "centroid" or "chief".
    pub fn from_name(name: &str) -> Result<Sample> {
        match name {
            "centroid" => Ok(Sample::Centroid),
            "chief" => Ok(Sample::Chief),
            _ => Err(Error::param(
                "sample",
                format!("{name:?}"),
                "\"centroid\" or \"chief\"",
            )),
        }
    }
}

/// A convex polygon in (u, w), counter-clockwise; `n == 0` for an empty one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polygon {
    pub n: usize,
    pub v: [[f64; 2]; MAX_VERTICES],
}

impl Polygon {
    pub const EMPTY: Polygon = Polygon {
        n: 0,
        v: [[f64::NAN; 2]; MAX_VERTICES],
    };

    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.v[..self.n]
    }

    /// Shoelace area (relative to the first vertex, for accuracy); 0 when empty.
    pub fn area(&self) -> f64 {
        polygon::signed_area_about_first(self.vertices())
    }

    /// Centroid (u, w); NaN when empty (no positive area).
    pub fn centroid(&self) -> [f64; 2] {
        let p = self.vertices();
        if p.len() < 3 || self.area() <= 0.0 {
            return [f64::NAN; 2];
        }
        polygon::centroid(p)
    }
}

/// A strip lo ≤ n·(u, w) ≤ hi in ray space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strip {
    pub n: [f64; 2],
    pub lo: f64,
    pub hi: f64,
}

/// Largest working polygon during clipping (4 + 1 per clipping line, with slack).
const WORK: usize = 10;

/// Keep the part of `p` (convex, ccw) with n·x ≤ h (Sutherland–Hodgman, one line; a vertex
/// on the line is kept once and produces no extra intersection).
fn clip_half_plane(p: &[[f64; 2]], n: [f64; 2], h: f64, out: &mut [[f64; 2]; WORK]) -> usize {
    polygon::clip_keep(p, out, |x| h - (n[0] * x[0] + n[1] * x[1]))
}

/// Polygon from a clipped vertex list: drop repeated vertices, reduce to ≤ 6 vertices
/// (only reachable through rounding: drop the vertex whose removal changes the area
/// least), and call it empty when its area is not positive.
fn finish(buf: &[[f64; 2]]) -> Polygon {
    let mut v = [[0.0; 2]; WORK];
    let mut n = 0;
    for &p in buf {
        if n == 0 || v[n - 1] != p {
            v[n] = p;
            n += 1;
        }
    }
    while n > 1 && v[n - 1] == v[0] {
        n -= 1;
    }
    while n > MAX_VERTICES {
        let mut best = (f64::INFINITY, 0);
        for i in 0..n {
            let (a, b, c) = (v[(i + n - 1) % n], v[i], v[(i + 1) % n]);
            let t = ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs();
            if t < best.0 {
                best = (t, i);
            }
        }
        v.copy_within(best.1 + 1..n, best.1);
        n -= 1;
    }
    if n < 3 || polygon::signed_area_about_first(&v[..n]) <= 0.0 {
        return Polygon::EMPTY;
    }
    let mut out = Polygon::EMPTY;
    out.n = n;
    out.v[..n].copy_from_slice(&v[..n]);
    out
}

/// The ray-space geometry of one lens type of a line: x = a u + b w on the array plane
/// (a = L/v_ref, b = 1 − L/v_ref) and the pixel strip's normal (α a, α b − v/L),
/// α = 1 + v/L − v/f (docs/model.md §4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rays {
    pub a: f64,
    pub b: f64,
    pub alpha: f64,
    pub half_aperture: f64,
    /// Lens pitch d, pixel pitch μ and v/L.
    pub d: f64,
    pub mu: f64,
    pub v_l: f64,
}

impl Rays {
    /// Lens type `t` of `line`.
    pub fn new(line: &Line, t: usize) -> Rays {
        let l = line.l;
        Rays {
            a: l / line.v_ref,
            b: 1.0 - l / line.v_ref,
            alpha: 1.0 + line.v / l - line.v / line.focal[t],
            half_aperture: line.aperture / 2.0,
            d: line.d,
            mu: line.mu,
            v_l: line.v / l,
        }
    }

    /// The three strips of a pixel at offset θ from the image centre of the lens centred
    /// at c: aperture, microlens, pixel. The pixel strip |s' − s| ≤ μ/2 with
    /// s' = α x − (v/L) w + (v/f) c and s = c (1 + v/L) + θ reads
    /// α a u + (α b − v/L) w ∈ α c + θ ± μ/2, since s − (v/f) c = c (1 + v/L − v/f) + θ
    /// (the exact form, no cancellation).
    pub fn strips(&self, c: f64, theta: f64) -> [Strip; 3] {
        let h = self.half_aperture;
        let mid = self.alpha * c + theta;
        [
            Strip {
                n: [0.0, 1.0],
                lo: -h,
                hi: h,
            },
            Strip {
                n: [self.a, self.b],
                lo: c - self.d / 2.0,
                hi: c + self.d / 2.0,
            },
            Strip {
                n: [self.alpha * self.a, self.alpha * self.b - self.v_l],
                lo: mid - self.mu / 2.0,
                hi: mid + self.mu / 2.0,
            },
        ]
    }

    /// Integration polygon of the pixel at offset θ under the lens centred at c: the
    /// parallelogram aperture strip × microlens strip, clipped by the pixel strip.
    pub fn polygon(&self, c: f64, theta: f64) -> Polygon {
        let [_, lens, pixel] = self.strips(c, theta);
        let h = self.half_aperture;
        // u = (x − b w)/a at w = ∓D/2, x = c ∓ d/2: bottom-left, bottom-right, top-right,
        // top-left (a > 0, so counter-clockwise).
        let u = |x: f64, w: f64| (x - self.b * w) / self.a;
        let quad = [
            [u(lens.lo, -h), -h],
            [u(lens.hi, -h), -h],
            [u(lens.hi, h), h],
            [u(lens.lo, h), h],
        ];
        let mut b1 = [[0.0; 2]; WORK];
        let mut b2 = [[0.0; 2]; WORK];
        let n1 = clip_half_plane(&quad, pixel.n, pixel.hi, &mut b1);
        let neg = [-pixel.n[0], -pixel.n[1]];
        let n2 = clip_half_plane(&b1[..n1], neg, -pixel.lo, &mut b2);
        finish(&b2[..n2])
    }

    /// Chief ray (u, w) through the lens centre (x = c) at main-lens height w.
    pub fn chief(&self, c: f64, w: f64) -> [f64; 2] {
        [(c - self.b * w) / self.a, w]
    }
}

/// A polygon whose area is below this fraction of the largest polygon area of its half is
/// unlit (docs/model.md §9, "Lit by area"): such an area is the rounding residue of a
/// boundary contact (exact area 0), not light.
pub const LIT_AREA_RTOL: f64 = 1e-9;

/// Empty every polygon whose area is below [`LIT_AREA_RTOL`] of the largest in `polygons`.
pub fn drop_residue(polygons: &mut [Polygon]) {
    let floor = LIT_AREA_RTOL * polygons.iter().map(Polygon::area).fold(0.0, f64::max);
    for p in polygons.iter_mut() {
        if p.n > 0 && p.area() < floor {
            *p = Polygon::EMPTY;
        }
    }
}

/// Every pixel of one half (or channel) along one axis: microlens-major (index j Q + q) for
/// the ideal layout, sensor order (index m) for the sensor layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// The channel's index from 0 (half 1 is 0).
    pub channel: usize,
    pub axis: Axis,
    /// Polygons, each padded with NaN rows to 6 vertices.
    pub polygons: Vec<Polygon>,
    pub area: Vec<f64>,
    pub centroid: Vec<[f64; 2]>,
    pub lens: Vec<u32>,
    /// Pixel index under its lens, q (ideal layout), or on the sensor, m (sensor layout).
    pub pixel: Vec<u32>,
    /// Offset θ of the pixel centre from its lens's image centre c (1 + v/L).
    pub theta: Vec<f64>,
    /// Lens type of the pixel's lens (j mod T).
    pub types: Vec<u32>,
    pub chief: Vec<[f64; 2]>,
    /// The chief ray passes the main-lens aperture (docs/model.md §6, `Line::pixel`;
    /// sensor layout: and the pixel centre lies in its lens's image cell).
    pub lit: Vec<bool>,
}

/// Bytes per traced pixel (polygon, area, centroid, indices, offset, type, chief, lit):
/// 165, rounded up.
pub const TRACE_BYTES_PER_PIXEL: u128 = 8 * (12 + 1 + 2 + 2 + 2) + 8 + 8;

/// Bytes of the arrays a caller builds from a trace, per pixel: vertices (12 f64), vertex
/// count, lens, pixel and type (as i64), area, θ, centroid and chief ray (6 f64) and lit (1
/// byte).
pub const TRACE_OUTPUT_BYTES_PER_PIXEL: u128 = 8 * (12 + 4 + 6) + 1;

/// Bytes a top-level trace of n pixels holds at its peak: the trace and the arrays built
/// from it.
pub fn trace_call_bytes(n: u128) -> u128 {
    n.saturating_mul(TRACE_BYTES_PER_PIXEL + TRACE_OUTPUT_BYTES_PER_PIXEL)
}

/// Trace every pixel of a line (a design's channel along one axis): its integration
/// polygon, area, centroid, chief ray and lit flag (docs/model.md §3–4, §6, §9). Parallel
/// over pixels on the current rayon pool (callers run it inside their pool); the buffers
/// are allocated fallibly.
pub fn trace_line(line: &Line) -> Result<Trace> {
    let mut tr = alloc_trace(line)?;
    let n = tr.polygons.len();
    fill_trace(line, &mut tr, 0..n);
    drop_trace_residue(&mut tr);
    Ok(tr)
}

/// [`trace_line`] as a top-level call: memory checked first (the trace, 168 bytes per
/// pixel), run on the pool of `n_threads` in chunks of pixels with an interrupt checkpoint
/// between chunks.
pub fn trace_line_threads(line: &Line, n_threads: Option<usize>) -> Result<Trace> {
    check_threads(n_threads)?;
    let mut tr = alloc_trace(line)?;
    let n = tr.polygons.len();
    for_chunks(n_threads, n, chunk_items(n_threads, 64), |r| {
        fill_trace(line, &mut tr, r);
        Ok(())
    })?;
    drop_trace_residue(&mut tr);
    Ok(tr)
}

/// A trace's buffers, checked against the memory available and allocated fallibly.
fn alloc_trace(line: &Line) -> Result<Trace> {
    let n = line.pixel_count();
    memory::check("trace of one axis", n * TRACE_BYTES_PER_PIXEL)?;
    let n = n as usize;
    let what = "trace of one axis";
    Ok(Trace {
        channel: line.index,
        axis: line.axis,
        polygons: try_vec(what, n, Polygon::EMPTY)?,
        area: try_vec(what, n, 0.0)?,
        centroid: try_vec(what, n, [0.0; 2])?,
        lens: try_vec(what, n, 0)?,
        pixel: try_vec(what, n, 0)?,
        theta: try_vec(what, n, 0.0)?,
        types: try_vec(what, n, 0)?,
        chief: try_vec(what, n, [0.0; 2])?,
        lit: try_vec(what, n, false)?,
    })
}

/// [`drop_residue`] on a filled trace, keeping its area and centroid columns in step.
fn drop_trace_residue(tr: &mut Trace) {
    let floor = LIT_AREA_RTOL * tr.area.iter().copied().fold(0.0, f64::max);
    for ((p, a), c) in tr
        .polygons
        .iter_mut()
        .zip(&mut tr.area)
        .zip(&mut tr.centroid)
    {
        if p.n > 0 && *a < floor {
            *p = Polygon::EMPTY;
            *a = 0.0;
            *c = [f64::NAN; 2];
        }
    }
}

/// Trace pixels `r` of `line` into `tr`, in parallel.
fn fill_trace(line: &Line, tr: &mut Trace, r: std::ops::Range<usize>) {
    let rays: Vec<Rays> = (0..line.types()).map(|t| Rays::new(line, t)).collect();
    let q_count = line.q();
    let start = r.start;
    tr.polygons[r.clone()]
        .par_iter_mut()
        .zip(tr.area[r.clone()].par_iter_mut())
        .zip(tr.centroid[r.clone()].par_iter_mut())
        .zip(tr.lens[r.clone()].par_iter_mut())
        .zip(tr.pixel[r.clone()].par_iter_mut())
        .zip(tr.theta[r.clone()].par_iter_mut())
        .zip(tr.types[r.clone()].par_iter_mut())
        .zip(tr.chief[r.clone()].par_iter_mut())
        .zip(tr.lit[r].par_iter_mut())
        .with_min_len(1024)
        .enumerate()
        .for_each(|(o, ((((((((p, a), cen), l), q), th), ty), ch), lit))| {
            let i = (start + o) as u32;
            let px = line.pixel(i);
            let c = line.lens_center(px.j);
            let t = line.lens_type(px.j);
            let rays = &rays[t];
            *p = rays.polygon(c, px.theta);
            *a = p.area();
            *cen = p.centroid();
            *l = px.j;
            *q = q_count.map_or(i, |qc| i % qc);
            *th = px.theta;
            *ty = t as u32;
            *ch = rays.chief(c, line.chief_w(px.theta));
            *lit = px.lit;
        });
}

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
    n: usize,
    vu: [Vec<f64>; MAX_VERTICES],
    vw: [Vec<f64>; MAX_VERTICES],
    su: Vec<f64>,
    sw: Vec<f64>,
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
fn rows_per_task(n: usize) -> usize {
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
    tr: &'a Trace,
    pre: &'a Prepared,
    centres: &'a [f64],
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

/// Per-axis sample positions of one line on the plane at depth z: object-space position
/// of every pixel along the axis (NaN where it yields no sample).
pub(crate) fn axis_samples(line: &Line, sample: Sample, z: f64) -> Result<Vec<f64>> {
    let zc = conjugate(line.f_main, z);
    let sigma = line.slope(zc);
    let n = line.pixel_count() as usize;
    let what = "sample_grid (per-axis samples)";
    let mut polygons = Vec::new();
    if sample == Sample::Centroid {
        let rays: Vec<Rays> = (0..line.types()).map(|t| Rays::new(line, t)).collect();
        polygons = try_with_capacity(what, n)?;
        polygons.extend((0..n as u32).map(|i| {
            let px = line.pixel(i);
            rays[line.lens_type(px.j)].polygon(line.lens_center(px.j), px.theta)
        }));
        drop_residue(&mut polygons);
    }
    let mut out = try_with_capacity(what, n)?;
    for i in 0..n as u32 {
        let px = line.pixel(i);
        let x = match sample {
            Sample::Chief if px.lit => {
                let w = line.chief_w(px.theta);
                let p = line.chief_projection(line.lens_center(px.j), w, zc);
                line.object_position(p, z)
            }
            Sample::Chief => f64::NAN,
            Sample::Centroid => {
                let [u, w] = polygons[i as usize].centroid();
                (u + sigma * w) * (-z / line.v_ref)
            }
        };
        out.push(x);
    }
    Ok(out)
}

/// The 2-D grid of a pair of lines: X from the column's line, Y from the row's, NaN where
/// either axis yields no sample; with `disc` = Some(D/2) (a circular aperture, chief
/// samples) also NaN where the chief ray's (w_x, w_y) is not strictly inside the disc.
#[allow(clippy::too_many_arguments)]
fn grid_into(
    lx: &Line,
    ly: &Line,
    disc: Option<f64>,
    z: f64,
    sample: Sample,
    gx: &mut [f64],
    gy: &mut [f64],
    n_threads: Option<usize>,
) -> Result<()> {
    let (rows, cols) = (ly.pixel_count() as usize, lx.pixel_count() as usize);
    let (xs, ys) = with_threads(n_threads, || -> Result<_> {
        Ok((axis_samples(lx, sample, z)?, axis_samples(ly, sample, z)?))
    })??;
    let chief_w = |line: &Line, n: usize| -> Result<Vec<f64>> {
        let mut w = try_with_capacity("sample_grid (chief heights)", n)?;
        if disc.is_some() {
            w.extend((0..n as u32).map(|i| line.chief_w(line.pixel(i).theta)));
        }
        Ok(w)
    };
    let (wx, wy) = (chief_w(lx, cols)?, chief_w(ly, rows)?);
    let per = rows_per_task(cols);
    let step = chunk_items(n_threads, 2 * cols as u128);
    for_chunks(n_threads, rows, step, |r| {
        let span = r.start * cols..r.end * cols;
        let first = r.start;
        gx[span.clone()]
            .par_chunks_mut(per * cols)
            .zip(gy[span].par_chunks_mut(per * cols))
            .zip(ys[r].par_chunks(per))
            .enumerate()
            .for_each(|(task, ((gx, gy), yr))| {
                for (r, &y) in yr.iter().enumerate() {
                    let rx = &mut gx[r * cols..(r + 1) * cols];
                    let ry = &mut gy[r * cols..(r + 1) * cols];
                    if y.is_nan() {
                        rx.fill(f64::NAN);
                        ry.fill(f64::NAN);
                    } else {
                        rx.copy_from_slice(&xs);
                        for (oy, &x) in ry.iter_mut().zip(&xs) {
                            // y + 0·x is y where x is a sample, NaN where it is not.
                            *oy = y + 0.0 * x;
                        }
                        if let Some(rad) = disc {
                            let w2 = wy[first + task * per + r];
                            for ((ox, oy), &w1) in rx.iter_mut().zip(ry.iter_mut()).zip(&wx) {
                                if w1 * w1 + w2 * w2 >= rad * rad {
                                    *ox = f64::NAN;
                                    *oy = f64::NAN;
                                }
                            }
                        }
                    }
                }
            });
        Ok(())
    })
}

/// Validate a design's sample_grid call before anything is allocated: threads, the depth,
/// a rect channel, the aperture (centroid samples need the square aperture: only then is a
/// pixel's 4-D region the product of its two 1-D polygons) and the memory. Returns the
/// channel's lines along x and y.
pub fn check_design_sample_grid(
    design: &Design,
    channel: i64,
    z: f64,
    sample: Sample,
    n_threads: Option<usize>,
) -> Result<(Line, Line)> {
    check_threads(n_threads)?;
    check_design_depths(design.f_main, &[z])?;
    let lx = Line::of_channel(design, channel, Axis::X)?;
    let ly = Line::of_channel(design, channel, Axis::Y)?;
    if sample == Sample::Centroid && design.shape == Aperture::Circle {
        return Err(Error::param(
            "aperture",
            "\"circle\"",
            "\"square\" for sample=\"centroid\" (behind a circular aperture a pixel's \
             region in 4-D ray space is not the product of its x and y polygons; use \
             sample=\"chief\")",
        ));
    }
    let (rows, cols) = (ly.pixel_count(), lx.pixel_count());
    let bytes = (2 * 8 * rows)
        .saturating_mul(cols)
        .saturating_add(16 * (rows + cols));
    memory::check("sample_grid (two outputs)", bytes)?;
    Ok((lx, ly))
}

/// The sample positions (X, Y) of every pixel of channel `channel` (from 1) of a design
/// (rect grids) on the plane at depth z, written into caller-provided buffers: rows the
/// channel's pixel rows along y, columns along x ((K_y Q, K_x Q) or (M_y, M_x)), NaN where
/// a pixel yields no sample. Separable: X depends on the column only, Y on the row only,
/// and under the square aperture a pixel yields a sample iff it does along both axes (the
/// 4-D integration region is the product of the two 2-D polygons, so its centroid is the
/// pair of centroids). In chunks of rows with an interrupt checkpoint between chunks.
pub fn design_sample_grid_into(
    design: &Design,
    channel: i64,
    z: f64,
    sample: Sample,
    gx: &mut [f64],
    gy: &mut [f64],
    n_threads: Option<usize>,
) -> Result<()> {
    let (lx, ly) = check_design_sample_grid(design, channel, z, sample, n_threads)?;
    let n = (ly.pixel_count() * lx.pixel_count()) as usize;
    if gx.len() != n || gy.len() != n {
        return Err(Error::param(
            "output length",
            format!("{:?}", (gx.len(), gy.len())),
            format!("{n}"),
        ));
    }
    let disc = (design.shape == Aperture::Circle).then_some(design.aperture / 2.0);
    grid_into(&lx, &ly, disc, z, sample, gx, gy, n_threads)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::model::camera::Camera;
    use crate::model::lens::MAX_K;

    /// The seed with 6 x 4 lenses and the given microlens focal lengths, as its design.
    fn design(f1: Option<f64>, f2: Option<f64>) -> Design {
        let p = Camera::paper();
        Camera::new(
            p.f_main, p.aperture, p.v1, p.kappa, p.d, p.v, p.mu, 15, 6, 4, f1, f2,
        )
        .unwrap()
        .design()
    }

    fn line(d: &Design, channel: i64, axis: Axis) -> Line {
        Line::of_channel(d, channel, axis).unwrap()
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
    }

    #[test]
    fn strip_offset_matches_pixel_center() {
        // α c + θ_q is s − (v/f) c with s = c (1 + v/L) + θ_q, the pixel's sensor position.
        let d = design(Some(0.5), Some(0.9));
        for channel in [1, 2] {
            let ln = line(&d, channel, Axis::X);
            let rays = Rays::new(&ln, 0);
            for q in [0, 7, 14] {
                let c = ln.lens_center(5);
                let theta = ln.ideal_offset(q, 15);
                let s = rays.strips(c, theta)[2];
                let want = c * (1.0 + ln.v / ln.l) + theta - ln.v / ln.focal[0] * c;
                assert!(((s.lo + s.hi) / 2.0 - want).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn half1_ng_rectangles() {
        // docs/model.md §8: width d, height μ v'/v, axis-aligned, in Ng's setting.
        let d = Camera::paper().design();
        let ch = &d.channels[0];
        let tr = trace_line(&line(&d, 1, Axis::X)).unwrap();
        let h = ch.mu * ch.l / ch.v;
        for (i, p) in tr.polygons.iter().enumerate() {
            assert!(tr.lit[i]);
            assert_eq!(p.n, 4);
            let us: Vec<f64> = p.vertices().iter().map(|v| v[0]).collect();
            let ws: Vec<f64> = p.vertices().iter().map(|v| v[1]).collect();
            let umin = us.iter().cloned().fold(f64::INFINITY, f64::min);
            let umax = us.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let wmin = ws.iter().cloned().fold(f64::INFINITY, f64::min);
            let wmax = ws.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            assert!(close(umax - umin, ch.d, 1e-12));
            assert!(close(wmax - wmin, h, 1e-9));
            assert!(close(p.area(), ch.d * h, 1e-9));
        }
    }

    #[test]
    fn light_is_conserved_under_each_microlens() {
        // docs/model.md §8: Σ areas = D d v'/L_i when the microlens image fits in its Q pixels.
        let d = Camera::paper().design();
        for channel in [1, 2] {
            let ln = line(&d, channel, Axis::Y);
            let tr = trace_line(&ln).unwrap();
            let full = d.aperture * ln.d * ln.v_ref / ln.l;
            for lens in tr.area.chunks(15) {
                let s: f64 = lens.iter().sum();
                assert!(close(s, full, 1e-12), "{s} vs {full}");
            }
        }
    }

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
        let huge = Camera::new(
            80.0, 20.0, 90.0, 0.3, 0.1, 0.3, 0.01, 65_535, k, k, None, None,
        )
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

    #[test]
    fn chief_ray_lies_inside_lit_polygons() {
        let d = design(Some(0.7), None);
        for channel in [1, 2] {
            let tr = trace_line(&line(&d, channel, Axis::X)).unwrap();
            for i in 0..tr.polygons.len() {
                if tr.lit[i] {
                    assert!(tr.area[i] > 0.0);
                }
            }
        }
    }
}
