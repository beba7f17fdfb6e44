//! Forward model of the super-resolution simulation (docs/simulate.md): pixel values of a
//! textured Lambertian plane at depth z, and the sparse system matrix of pixels × cells of
//! a reconstruction grid, both exact for piecewise-constant textures.
//!
//! A pixel's value is ∫ T(p') k(p') dp' with k its weight profile on the plane (docs/model.md §5,
//! [`weight_profile`]: the chord length along w of polygon ∩ line, ∫ k dp' = polygon
//! area). With X = −p' z / v' the integral reads (v'/z) ∫ T(X) k(X) dX. Values are
//! normalised by D μ, the (u, w) area of a pixel of width μ on plane v' that sees the full
//! aperture (a white texture fills it with 1), and multiplied by the transmission of the
//! light path: 1/2 for either light-field half (beam splitter), 1 for the conventional
//! camera. The kernel is piecewise linear in X, so its integral over a constant cell is
//! exact (trapezoid rule on each linear piece).
//!
//! The conventional camera (the same sensor without microlenses, on array plane L_i) has
//! pixels of width μ centred at s_k = (k − (K Q − 1)/2) μ. Its rays are the parallelogram
//! |w| ≤ D/2, |x − s_k| ≤ μ/2 (x = a u + b w on plane L_i); on the plane at depth z that is
//! a box of half-width μ/(2a) in p' (the pixel) convolved with a box of half-width
//! B = H_i v'/L_i (the main-lens blur H_i of Eqs. 2–3 seen from plane v'): a trapezoid.

use rayon::prelude::*;

use crate::infra::csr::Csr;
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_vec};
use crate::infra::parallel::{check_threads, chunk_items, for_chunks, with_threads};
use crate::model::design::Design;
use crate::model::lens::conjugate;
use crate::model::optics::{check_design_depths, LensOptics};
use crate::sampling::line::Axis;
use crate::sampling::line::Line;
use crate::sampling::rayspace::{trace_line, weight_profile, MAX_VERTICES, TRACE_BYTES_PER_PIXEL};

/// Which pixels of a design (docs/simulate.md, "Designs"): channel c's light field, or the
/// conventional camera with a sensor of pitch μ_c on channel c's array plane (c from 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DesignSource {
    Channel(i64),
    Conventional(i64),
}

impl DesignSource {
    /// Source from its name: "channel1", …, "channelC", "conventional1", …,
    /// "conventionalC" (C channels of `design`).
    pub fn from_name(design: &Design, name: &str) -> Result<DesignSource> {
        let n = design.channels.len();
        let number = |rest: &str| -> Option<i64> {
            let c: i64 = rest.parse().ok()?;
            (rest == c.to_string() && c >= 1 && c as u64 <= n as u64).then_some(c)
        };
        let parsed = if let Some(rest) = name.strip_prefix("channel") {
            number(rest).map(DesignSource::Channel)
        } else if let Some(rest) = name.strip_prefix("conventional") {
            number(rest).map(DesignSource::Conventional)
        } else {
            None
        };
        parsed.ok_or_else(|| {
            Error::param(
                "source",
                format!("{name:?}"),
                format!("\"channel<c>\" or \"conventional<c>\" with c in [1, {n}]"),
            )
        })
    }
}

/// The pixels of one source along x, as the forward model sees them: the 1-D line of a
/// design channel ([`Line`]), whether they are that line's light field or the
/// conventional camera on its array plane, and the pixel pitch of the unit pixel.
///
/// Values are normalised by D μ_ref, μ_ref the design's μ_1 (channel 1, as δ(z) is), so
/// that every source of one design shares one unit; the light field is multiplied by the
/// line's `share` (½ for a half of the paper's camera), the conventional camera by 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Pixels {
    /// The line along x (ray space referred to v' or L_1).
    pub line: Line,
    /// The conventional camera on the line's array plane instead of its light field.
    pub conventional: bool,
    /// μ of the unit pixel.
    pub mu_ref: f64,
}

impl Pixels {
    /// A source of the design (its channel must have a rect grid: the refusal names
    /// `channels[i].grid`).
    pub fn of_design(design: &Design, source: DesignSource) -> Result<Pixels> {
        let (c, conventional) = match source {
            DesignSource::Channel(c) => (c, false),
            DesignSource::Conventional(c) => (c, true),
        };
        Ok(Pixels {
            line: Line::of_channel(design, c, Axis::X)?,
            conventional,
            mu_ref: design.channels[0].mu,
        })
    }

    /// Transmission of the light path: the channel's share (light field), 1 (conventional).
    pub fn transmission(&self) -> f64 {
        if self.conventional {
            1.0
        } else {
            self.line.share
        }
    }
}

/// A uniform 1D grid of cells along object-space X: cell k is
/// [origin + k step, origin + (k + 1) step].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub origin: f64,
    pub step: f64,
    pub n: usize,
}

/// Largest number of cells a grid may have (far beyond any sensor; guards typos).
pub const MAX_CELLS: usize = 1 << 28;

impl Grid {
    pub fn new(origin: f64, step: f64, n: usize) -> Result<Grid> {
        if !origin.is_finite() {
            return Err(Error::param(
                "grid origin",
                origin,
                "a finite position in mm",
            ));
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(Error::param("grid step", step, "a finite width > 0 mm"));
        }
        if n == 0 || n > MAX_CELLS {
            return Err(Error::param(
                "grid cells",
                n,
                format!("an integer in [1, {MAX_CELLS}]"),
            ));
        }
        if !(origin + n as f64 * step).is_finite() {
            return Err(Error::param("grid", n, "a grid with a finite end"));
        }
        Ok(Grid { origin, step, n })
    }

    /// Left edge of cell k (k = n is the right end of the grid).
    #[inline]
    pub fn edge(&self, k: usize) -> f64 {
        self.origin + k as f64 * self.step
    }

    /// Index of the cell holding x, clamped to [0, n − 1].
    #[inline]
    fn cell(&self, x: f64) -> usize {
        let t = ((x - self.origin) / self.step).floor();
        if t <= 0.0 {
            0
        } else {
            (t as usize).min(self.n - 1)
        }
    }
}

/// One pixel's kernel on the plane: breakpoints X ascending (mm) and the weight at each,
/// normalised so that ∫ weight dX is the pixel's value for a white texture (see module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kernel {
    /// Index of the pixel along x (microlens-major j Q + q for a half; k for conventional).
    pub pixel: u32,
    pub n: usize,
    pub x: [f64; MAX_VERTICES],
    pub w: [f64; MAX_VERTICES],
}

impl Kernel {
    pub fn lo(&self) -> f64 {
        self.x[0]
    }

    pub fn hi(&self) -> f64 {
        self.x[self.n - 1]
    }

    /// ∫ weight dX (exact: trapezoid rule on each linear piece).
    pub fn integral(&self) -> f64 {
        (1..self.n)
            .map(|t| 0.5 * (self.w[t] + self.w[t - 1]) * (self.x[t] - self.x[t - 1]))
            .sum()
    }

    /// Exact integral of the kernel over each cell of `grid` it touches, ascending by cell,
    /// appended to `out` (cells with zero weight are skipped). Parts outside the grid are
    /// dropped.
    pub fn integrate_cells(&self, grid: &Grid, out: &mut Vec<(u32, f64)>) {
        let start = out.len();
        let end = grid.edge(grid.n);
        for t in 1..self.n {
            let (x0, x1) = (self.x[t - 1], self.x[t]);
            let (w0, w1) = (self.w[t - 1], self.w[t]);
            let (a, b) = (x0.max(grid.origin), x1.min(end));
            if b <= a {
                continue;
            }
            let slope = (w1 - w0) / (x1 - x0);
            let at = |x: f64| w0 + slope * (x - x0);
            let (k0, k1) = (grid.cell(a), grid.cell(b));
            for k in k0..=k1 {
                let lo = a.max(grid.edge(k));
                let hi = b.min(grid.edge(k + 1));
                if hi <= lo {
                    continue;
                }
                let v = 0.5 * (at(lo) + at(hi)) * (hi - lo);
                if v <= 0.0 {
                    continue;
                }
                let len = out.len();
                match out.last_mut() {
                    Some(last) if len > start && last.0 == k as u32 => last.1 += v,
                    _ => out.push((k as u32, v)),
                }
            }
        }
    }
}

/// Conjugate and validated depth, thread count and source checks shared by every entry.
fn check_plane(px: &Pixels, z: f64, n_threads: Option<usize>) -> Result<()> {
    check_threads(n_threads)?;
    check_design_depths(px.line.f_main, &[z])
}

/// Kernels of every pixel of a source along x on the plane at depth z that collects light
/// (pixels with an empty integration polygon are left out), in pixel order.
pub fn kernels_of(px: &Pixels, z: f64) -> Result<Vec<Kernel>> {
    let line = &px.line;
    check_design_depths(line.f_main, &[z])?;
    let zc = conjugate(line.f_main, z);
    let scale = -z / line.v_ref; // X = −p' z / v'
    let norm = px.transmission() * (line.v_ref / z) / (line.aperture * px.mu_ref);
    if px.conventional {
        conventional_kernels(line, zc, scale, norm)
    } else {
        light_field_kernels(line, zc, scale, norm)
    }
}

/// A kernel from breakpoints in p' (ascending) and weights: X = −p' z/v' (scale < 0)
/// reverses the order, so the kernel is ascending in X.
fn kernel_from(pixel: u32, br: &[f64], va: &[f64], scale: f64, norm: f64) -> Kernel {
    let n = br.len();
    let mut k = Kernel {
        pixel,
        n,
        x: [f64::NAN; MAX_VERTICES],
        w: [f64::NAN; MAX_VERTICES],
    };
    for t in 0..n {
        k.x[t] = br[n - 1 - t] * scale;
        k.w[t] = va[n - 1 - t] * norm;
    }
    k
}

/// A light field line: the weight profile of every pixel's integration polygon.
fn light_field_kernels(line: &Line, zc: f64, scale: f64, norm: f64) -> Result<Vec<Kernel>> {
    let n_px = line.pixel_count();
    let per = TRACE_BYTES_PER_PIXEL + memory::bytes_of::<Kernel>(1);
    memory::check("kernels (trace and kernels)", n_px * per)?;
    let tr = trace_line(line)?;
    let sigma = line.slope(zc);
    Ok(tr
        .polygons
        .par_iter()
        .enumerate()
        .filter(|(_, p)| p.n > 0)
        .map(|(i, p)| {
            let (b, v) = weight_profile(p, sigma);
            kernel_from(i as u32, &b[..p.n], &v[..p.n], scale, norm)
        })
        .collect())
}

/// The camera without microlenses, sensor of the line's pitch μ and pixel count on the
/// line's array plane L: a trapezoid per pixel (pixel box convolved with the main-lens
/// blur).
fn conventional_kernels(line: &Line, zc: f64, scale: f64, norm: f64) -> Result<Vec<Kernel>> {
    let l = line.l;
    let a = l / line.v_ref;
    let n_px = line.pixel_count() as u64;
    memory::check(
        "conventional kernels",
        memory::bytes_of::<Kernel>(n_px as u128),
    )?;
    // Pixel box half-width A = μ/(2a) and blur half-width B = H v_ref/L, in p'
    // (H of Eqs. 2–3 does not depend on the microlenses: f is not read).
    let optics = LensOptics {
        f_main: line.f_main,
        aperture: line.aperture,
        l,
        d: line.d,
        v: line.v,
        mu: line.mu,
        f: line.focal[0],
    };
    let half_px = line.mu / (2.0 * a);
    let blur = optics.main_blur(zc) * line.v_ref / l;
    // Weight on the plateau: the aperture length min(2A, 2B)/|g| with
    // |g| = 2B/D the shear of w into p'; D when in focus (B ≤ A).
    let plateau = if blur <= half_px {
        line.aperture
    } else {
        line.aperture * half_px / blur
    };
    let (outer, inner) = (half_px + blur, (half_px - blur).abs());
    let mu = line.mu;
    Ok((0..n_px)
        .into_par_iter()
        .map(|k| {
            let s = (k as f64 - (n_px as f64 - 1.0) / 2.0) * mu;
            let c = s / a;
            // Ascending in p' (`kernel_from` reverses them into ascending X).
            let br = [c - outer, c - inner, c + inner, c + outer];
            let va = [0.0, plateau, plateau, 0.0];
            kernel_from(k as u32, &br, &va, scale, norm)
        })
        .collect())
}

/// Widest kernel support (hi − lo, mm in X) over the pixels of a source at depth z.
pub fn kernel_support_of(px: &Pixels, z: f64, n_threads: Option<usize>) -> Result<f64> {
    check_plane(px, z, n_threads)?;
    with_threads(n_threads, || {
        kernels_of(px, z).map(|ks| ks.iter().map(|k| k.hi() - k.lo()).fold(0.0, f64::max))
    })?
}

/// System matrix and the pixels its rows stand for.
#[derive(Debug, Clone, PartialEq)]
pub struct System {
    /// Rows the pixels, columns the grid's cells.
    pub matrix: Csr,
    /// Pixel index along x of each row (see [`Kernel::pixel`]).
    pub pixels: Vec<u32>,
}

fn check_field(field: (f64, f64)) -> Result<()> {
    let (lo, hi) = field;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(Error::param(
            "field",
            format!("({lo}, {hi})"),
            "finite bounds lo < hi in mm",
        ));
    }
    Ok(())
}

/// The system matrix on the plane at depth z: one row per pixel of a source whose kernel
/// support lies inside `field` = (lo, hi) (mm in X), one column per cell of `grid`; entry
/// (p, k) is the exact integral of pixel p's kernel over cell k, so that for a texture
/// constant on each cell the pixel values are A t. Parallel over pixels.
pub fn system_matrix_of(
    px: &Pixels,
    z: f64,
    grid: Grid,
    field: (f64, f64),
    n_threads: Option<usize>,
) -> Result<System> {
    check_plane(px, z, n_threads)?;
    check_field(field)?;
    let grid = Grid::new(grid.origin, grid.step, grid.n)?;
    with_threads(n_threads, || system_unchecked(px, z, grid, field))?
}

fn system_unchecked(px: &Pixels, z: f64, grid: Grid, field: (f64, f64)) -> Result<System> {
    let ks: Vec<Kernel> = kernels_of(px, z)?
        .into_iter()
        .filter(|k| k.lo() >= field.0 && k.hi() <= field.1)
        .collect();
    // Exact size before allocating: cells spanned by each support.
    let nnz: u128 = ks
        .iter()
        .map(|k| (grid.cell(k.hi()) - grid.cell(k.lo()) + 1) as u128)
        .sum();
    // Per row: its own vector of (cell, value), then the CSR arrays (index and value).
    memory::check("system matrix", nnz * 32 + ks.len() as u128 * 48)?;
    let rows: Vec<Vec<(u32, f64)>> = ks
        .par_iter()
        .with_min_len(64)
        .map(|k| {
            let mut r = Vec::new();
            k.integrate_cells(&grid, &mut r);
            r
        })
        .collect();
    Ok(System {
        matrix: Csr::from_rows("system matrix", &rows, grid.n)?,
        pixels: ks.iter().map(|k| k.pixel).collect(),
    })
}

/// Pixel values of a source on the plane at depth z for textures that are constant on each
/// cell of `grid`: `textures` holds n_tex rows of grid.n albedos (row-major, finite, ≥ 0).
/// Returns (values (n_tex, n_pix) row-major, pixels), the pixels those of
/// [`system_matrix_of`] with the same `field`. Noise-free expected signal, in units of a
/// full-aperture pixel of width μ on plane v' under a white texture (module doc).
pub fn render_of(
    px: &Pixels,
    z: f64,
    grid: Grid,
    field: (f64, f64),
    textures: &[f64],
    n_threads: Option<usize>,
) -> Result<(Vec<f64>, Vec<u32>)> {
    check_plane(px, z, n_threads)?;
    check_field(field)?;
    let grid = Grid::new(grid.origin, grid.step, grid.n)?;
    if textures.is_empty() || textures.len() % grid.n != 0 {
        return Err(Error::param(
            "textures length",
            textures.len(),
            format!("a positive multiple of the grid's {} cells", grid.n),
        ));
    }
    if let Some(i) = textures.iter().position(|t| !(t.is_finite() && *t >= 0.0)) {
        return Err(Error::param(
            "texture",
            format!("{} at flat index {i}", textures[i]),
            "finite albedos >= 0",
        ));
    }
    let n_tex = textures.len() / grid.n;
    let sys = with_threads(n_threads, || system_unchecked(px, z, grid, field))??;
    let m = &sys.matrix;
    let n_pix = m.nrows();
    check_rendered(n_tex, n_pix)?;
    // (n_pix, n_tex) in parallel over pixels, in chunks of pixels with an interrupt
    // checkpoint between them, then transposed to (n_tex, n_pix).
    let mut by_pixel = try_vec("rendered values", n_pix * n_tex, 0.0)?;
    let per_row = (m.data.len() / n_pix.max(1)).max(1) as u128;
    let step = chunk_items(n_threads, per_row * n_tex as u128);
    for_chunks(n_threads, n_pix, step, |r| {
        let first = r.start;
        by_pixel[r.start * n_tex..r.end * n_tex]
            .par_chunks_mut(n_tex)
            .enumerate()
            .with_min_len(16)
            .for_each(|(o, out)| {
                let (cells, vals) = m.row(first + o);
                for (t, o) in out.iter_mut().enumerate() {
                    let tex = &textures[t * grid.n..(t + 1) * grid.n];
                    *o = cells
                        .iter()
                        .zip(vals)
                        .map(|(&c, &v)| v * tex[c as usize])
                        .sum();
                }
            });
        Ok(())
    })?;
    let mut values = try_vec("rendered values", n_pix * n_tex, 0.0)?;
    for p in 0..n_pix {
        for t in 0..n_tex {
            values[t * n_pix + p] = by_pixel[p * n_tex + t];
        }
    }
    Ok((values, sys.pixels))
}

/// The rendered values: two (n_tex, n_pix) f64 buffers (by pixel, then transposed).
fn check_rendered(n_tex: usize, n_pix: usize) -> Result<()> {
    memory::check("rendered values", (n_tex as u128 * n_pix as u128) * 16)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera::Camera;
    use crate::sampling::rayspace::{Polygon, Rays};

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
    }

    /// A grid of `cells` × `sub` cells of δ(z)/`sub` centred on the axis.
    fn grid_around(d: &Design, z: f64, cells: usize, sub: usize) -> Grid {
        let step = d.resolution_step(z) / sub as f64;
        let n = cells * sub;
        Grid::new(-(n as f64) * step / 2.0, step, n).unwrap()
    }

    /// The seed's sources: each half's light field and its conventional camera.
    const SOURCES: [DesignSource; 4] = [
        DesignSource::Channel(1),
        DesignSource::Channel(2),
        DesignSource::Conventional(1),
        DesignSource::Conventional(2),
    ];

    #[test]
    fn rows_integrate_to_the_collected_light() {
        // Σ_k A[p, k] = ∫ kernel dX = T · area / (D μ) for every pixel inside the field.
        let d = Camera::paper().design();
        for z in [217.0, 400.0, 642.0, 2000.0] {
            for src in SOURCES {
                let px = Pixels::of_design(&d, src).unwrap();
                let line = &px.line;
                let grid = grid_around(&d, z, 1500, 2);
                let field = (grid.edge(0), grid.edge(grid.n));
                let sys = system_matrix_of(&px, z, grid, field, Some(2)).unwrap();
                assert!(sys.matrix.nrows() > 100, "{src:?} {z}");
                let ks = kernels_of(&px, z).unwrap();
                let traced = trace_line(line).unwrap();
                let area = |p: u32| {
                    if px.conventional {
                        // Parallelogram |w| ≤ D/2, |x − s| ≤ μ/2 on plane L: area D μ v'/L.
                        d.aperture * line.mu * line.v_ref / line.l
                    } else {
                        traced.area[p as usize]
                    }
                };
                for (r, &p) in sys.pixels.iter().enumerate().step_by(37) {
                    let m = &sys.matrix;
                    let s: f64 = m.row(r).1.iter().sum();
                    let want = px.transmission() * area(p) / (d.aperture * line.mu);
                    assert!(close(s, want, 1e-9), "{src:?} z={z} px={p}: {s} vs {want}");
                    let k = ks.iter().find(|k| k.pixel == p).unwrap();
                    assert!(close(k.integral(), want, 1e-9));
                    assert!(k.lo() >= field.0 && k.hi() <= field.1);
                }
            }
        }
    }

    #[test]
    fn conventional_kernel_is_the_projected_parallelogram() {
        // The trapezoid from main_blur equals weight_profile of the ray-space parallelogram
        // |w| ≤ D/2, |a u + b w − s| ≤ μ/2 (sensor on plane L without microlenses).
        let d = Camera::paper().design();
        for c in [1, 2] {
            let px = Pixels::of_design(&d, DesignSource::Conventional(c)).unwrap();
            let line = &px.line;
            let rays = Rays::new(line, 0);
            let (a, b, h) = (rays.a, rays.b, rays.half_aperture);
            for z in [150.0, 217.0, 400.0, 642.0, 5000.0] {
                let ks = kernels_of(&px, z).unwrap();
                let sigma = line.slope(conjugate(d.f_main, z));
                for k in ks.iter().step_by(501) {
                    let n_px = line.pixel_count() as f64;
                    let s = (k.pixel as f64 - (n_px - 1.0) / 2.0) * line.mu;
                    let u = |x: f64, w: f64| (x - b * w) / a;
                    let (lo, hi) = (s - line.mu / 2.0, s + line.mu / 2.0);
                    let mut p = Polygon::EMPTY;
                    p.n = 4;
                    p.v[..4].copy_from_slice(&[
                        [u(lo, -h), -h],
                        [u(hi, -h), -h],
                        [u(hi, h), h],
                        [u(lo, h), h],
                    ]);
                    let (br, va) = weight_profile(&p, sigma);
                    let scale = -z / line.v_ref;
                    let norm = (line.v_ref / z) / (d.aperture * line.mu);
                    // Compare the two piecewise-linear functions at many points.
                    let f = |x: f64, xs: &[f64], ws: &[f64]| -> f64 {
                        for t in 1..xs.len() {
                            if x >= xs[t - 1] && x <= xs[t] && xs[t] > xs[t - 1] {
                                let s = (x - xs[t - 1]) / (xs[t] - xs[t - 1]);
                                return ws[t - 1] + s * (ws[t] - ws[t - 1]);
                            }
                        }
                        0.0
                    };
                    let xs: Vec<f64> = (0..4).rev().map(|t| br[t] * scale).collect();
                    let ws: Vec<f64> = (0..4).rev().map(|t| va[t] * norm).collect();
                    assert!(close(xs[0], k.lo(), 1e-9) && close(xs[3], k.hi(), 1e-9));
                    let peak = k.w[1];
                    for i in 1..200 {
                        let x = k.lo() + (k.hi() - k.lo()) * i as f64 / 200.0;
                        let (g1, g2) = (f(x, &k.x[..4], &k.w[..4]), f(x, &xs, &ws));
                        assert!((g1 - g2).abs() <= 1e-7 * peak, "z={z} x={x}: {g1} {g2}");
                    }
                }
            }
        }
    }

    #[test]
    fn render_is_the_matrix_times_the_texture_and_refines_exactly() {
        // A texture constant on coarse cells, rendered on a grid 4× finer, gives the same
        // values as the coarse matrix times the coarse texture.
        let d = Camera::paper().design();
        for src in SOURCES {
            let px = Pixels::of_design(&d, src).unwrap();
            let z = 1000.0;
            let coarse = grid_around(&d, z, 300, 1);
            let fine = grid_around(&d, z, 300, 4);
            let field = (coarse.edge(2), coarse.edge(coarse.n - 2));
            let t: Vec<f64> = (0..coarse.n)
                .map(|k| ((k * 7919) % 101) as f64 / 100.0)
                .collect();
            let tf: Vec<f64> = (0..fine.n).map(|k| t[k / 4]).collect();
            let (vf, pf) = render_of(&px, z, fine, field, &tf, None).unwrap();
            let sys = system_matrix_of(&px, z, coarse, field, None).unwrap();
            assert_eq!(pf, sys.pixels);
            let m = &sys.matrix;
            for (r, &got) in vf.iter().enumerate() {
                let (cells, vals) = m.row(r);
                let want: f64 = cells
                    .iter()
                    .zip(vals)
                    .map(|(&c, &v)| v * t[c as usize])
                    .sum();
                assert!(close(got, want, 1e-10), "{src:?} {r}: {got} {want}");
            }
        }
    }

    /// Three rect channels: f-number matched ideal, a sensor layout with three lens types,
    /// an ideal layout with two (the Python tests' `MIX`); shares sum to 1.
    fn mix() -> Design {
        use crate::model::design::{Aperture, ChannelSpec, Grid as Lattice};
        let ch = |l, d, v, mu, kx, f: Option<Vec<f64>>, layout: &str, q, share| ChannelSpec {
            l,
            d,
            v,
            mu,
            kx,
            ky: 3,
            grid: Lattice::Rect,
            f,
            layout: layout.into(),
            q,
            mx: None,
            my: None,
            share,
        };
        let specs = [
            ch(60.0, 0.1, 0.6, 0.01, 21, None, "ideal", Some(9), 0.3),
            ch(
                66.0,
                0.12,
                0.5,
                0.008,
                17,
                Some(vec![0.45, 0.5, 0.55]),
                "sensor",
                None,
                0.3,
            ),
            ch(
                75.0,
                0.1,
                0.6,
                0.01,
                15,
                Some(vec![0.5, 0.62]),
                "ideal",
                Some(8),
                0.4,
            ),
        ];
        Design::new(50.0, 10.0, Aperture::Circle, &specs).unwrap()
    }

    #[test]
    fn design_rows_integrate_to_the_channel_light() {
        // Σ_k A[p, k] = share · area / (D μ_1) for a channel's light field pixel (area in
        // ray space referred to L_1); D μ_c L_1/L_c / (D μ_1) for its conventional camera.
        let d = mix();
        let mu1 = d.channels[0].mu;
        for z in [150.0, 300.0, 420.0, 1000.0] {
            for c in 1..=3i64 {
                for src in [DesignSource::Channel(c), DesignSource::Conventional(c)] {
                    let px = Pixels::of_design(&d, src).unwrap();
                    let line = &px.line;
                    let step = d.resolution_step(z) / 2.0;
                    let g = Grid::new(-1500.0 * step, step, 3000).unwrap();
                    let f = (g.edge(0), g.edge(g.n));
                    let sys = system_matrix_of(&px, z, g, f, Some(2)).unwrap();
                    assert!(sys.matrix.nrows() > 20, "{src:?} {z}");
                    let area = trace_line(line).unwrap().area;
                    let m = &sys.matrix;
                    for (r, &p) in sys.pixels.iter().enumerate() {
                        let s: f64 = m.row(r).1.iter().sum();
                        let want = if px.conventional {
                            d.aperture * line.mu * line.v_ref / line.l / (d.aperture * mu1)
                        } else {
                            line.share * area[p as usize] / (d.aperture * mu1)
                        };
                        assert!(close(s, want, 1e-9), "{src:?} z={z} px={p}: {s} vs {want}");
                    }
                }
            }
        }
    }

    #[test]
    fn design_sources_are_named_and_hex_is_refused() {
        let d = mix();
        assert_eq!(
            DesignSource::from_name(&d, "channel3").unwrap(),
            DesignSource::Channel(3)
        );
        assert_eq!(
            DesignSource::from_name(&d, "conventional2").unwrap(),
            DesignSource::Conventional(2)
        );
        for bad in [
            "channel0",
            "channel4",
            "channel01",
            "half1",
            "conventional",
            "channel+1",
        ] {
            let e = DesignSource::from_name(&d, bad).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("source"));
        }
        let hex = crate::model::presets::preset("raytrix-r12").unwrap();
        let e = Pixels::of_design(&hex, DesignSource::Channel(1)).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("channels[1].grid"));
    }

    #[test]
    fn deterministic_across_thread_counts() {
        let d = Camera::paper().design();
        let px = Pixels::of_design(&d, DesignSource::Channel(2)).unwrap();
        let g = grid_around(&d, 642.0, 200, 2);
        let f = (g.edge(0), g.edge(g.n));
        let a = system_matrix_of(&px, 642.0, g, f, Some(1)).unwrap();
        let b = system_matrix_of(&px, 642.0, g, f, Some(2)).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn rejects_bad_input() {
        let d = Camera::paper().design();
        let px = Pixels::of_design(&d, DesignSource::Channel(1)).unwrap();
        let g = Grid::new(-1.0, 0.01, 200).unwrap();
        assert!(DesignSource::from_name(&d, "half3").is_err());
        assert!(Grid::new(f64::NAN, 0.1, 3).is_err());
        assert!(Grid::new(0.0, 0.0, 3).is_err());
        assert!(Grid::new(0.0, 0.1, 0).is_err());
        assert!(matches!(
            system_matrix_of(&px, 50.0, g, (-1.0, 1.0), None),
            Err(Error::InvalidDepth { .. })
        ));
        assert!(system_matrix_of(&px, 500.0, g, (1.0, -1.0), None).is_err());
        assert!(system_matrix_of(&px, 500.0, g, (-1.0, 1.0), Some(0)).is_err());
        let bad_grid = Grid {
            origin: 0.0,
            step: -1.0,
            n: 3,
        };
        assert!(system_matrix_of(&px, 500.0, bad_grid, (-1.0, 1.0), None).is_err());
        assert!(render_of(&px, 500.0, g, (-1.0, 1.0), &[1.0; 199], None).is_err());
        let mut t = vec![1.0; 200];
        t[5] = -0.1;
        assert!(render_of(&px, 500.0, g, (-1.0, 1.0), &t, None).is_err());
        t[5] = f64::NAN;
        assert!(render_of(&px, 500.0, g, (-1.0, 1.0), &t, None).is_err());
        assert!(kernel_support_of(&px, f64::INFINITY, None).is_err());
    }
}
