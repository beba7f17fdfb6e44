//! The 2-D forward model (docs/model.md §10, docs/render.md): what each channel's sensor
//! records for a textured Lambertian scene.
//!
//! A pixel's value is share / (μ_1² A) · ∫∫ T(P_hit(u, w)) du dw over the rays it collects,
//! with du dw = (L_1/L)² dx dw (x the ray's point on the channel's array plane). Per lens
//! that can send light to the pixel, the 4-D integral is done as a 2-D Gauss–Legendre
//! quadrature over one pair of variables and an exact integral over the other:
//! - **outer w** (the main-lens point; used when the lens's image of its own cell, |α| d,
//!   is narrower than a pixel, α = 1 + v/L − v/f: microlenses focused near the main lens,
//!   Ng's setting α = 0): for each w the rays form a convex polygon of x (the lens cell
//!   clipped by the pixel's preimage, a square of side μ/|α|);
//! - **outer s** (the sensor point in the pixel; used otherwise): for each s the rays form
//!   the polygon of x inside the cell whose main-lens point w(x) = (L/v)(α x + (v/f) c − s)
//!   lies in the aperture (a square, or a disc as an equal-area polygon of `circle_sides(tol)` sides).
//!
//! The polygon is mapped to the scene through each vertex's ray hit, and T is averaged
//! over the image polygon exactly ([`Texture::average`]). On a fronto-parallel plane the
//! map is affine and this is exact; on slanted planes and depth maps the polygon is cut
//! into pieces small enough that the map's non-linearity is below the error budget.
//! The quadrature intervals are cut where the integrand's kinks are known (where the pixel
//! square or the aperture edges cross the cell's edges), so that for a constant texture
//! the rule is exact on rect cells with a square aperture.
//!
//! **Exact route**: a fronto-parallel plane, rect cells, a square aperture, the ideal
//! layout and an image (or constant) texture: a pixel's ray set is the product of its x
//! and y polygons of §4, and its value is Σ_cells T · I_x · I_y with I the areas of the
//! 1-D polygons between the cell's edges — no quadrature error. A sinusoid or bars (T of
//! X only) take it too: the value is (∫ T over the x polygon) · (the y polygon's area),
//! the first by the texture's closed form over the polygon's affine image in (X, w).
//!
//! Parts: [`chan`] (a channel as the renderer sees it, a worker's buffers), [`general`]
//! (the general route: outer w / outer s per pixel and lens), [`adaptive`] (its
//! quadrature), [`kinks`] (where its boxes are cut), [`mean`] (the inner integral over a
//! node's polygon of rays), [`falloff`] (the rays' radiometric falloff, a weight inside
//! that integral), [`exact`] (the exact route and its 1-D profiles) and [`footprint`]
//! (record mode on a plane). This file holds the entry points, the options
//! and the checks of a scene against a design, and [`render_band`]: a band of raw rows of
//! one channel, the unit of a render split over processes or machines.

use std::ops::Range;
use std::sync::atomic::AtomicUsize;

use rayon::prelude::*;

use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::Texture;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::model::design::{Aperture, Channel, Design, Grid, Layout};

mod adaptive;
mod chan;
pub(crate) mod exact;
mod falloff;
/// Record mode on a plane: the footprint density integrated over the grid's cells.
pub(crate) mod footprint;
mod general;
mod interior;
mod kinks;
mod mean;
mod sat;

pub use chan::{circle_sides, MAX_CIRCLE_SIDES, MIN_CIRCLE_SIDES};
pub(crate) use chan::{map_seen_once, Chan, Work};
pub use falloff::Falloff;
pub(crate) use general::{pixel_value, Pixels};

/// Default error target of a pixel, relative to a fully lit pixel under the scene's largest
/// albedo ([`Texture::max_albedo`]).
pub const DEFAULT_TOL: f64 = 1e-3;
/// Smallest error target accepted (the quadrature's own limit is far below).
pub const MIN_TOL: f64 = 1e-10;

/// Deepest surface point accepted (mm; 1,000 km): beyond, scene coordinates and the
/// areas of ray polygons on the scene (~ depth²) leave the range where the integrals are
/// exact in floating point (at 1e200 mm they overflowed to NaN).
pub const MAX_SCENE_DEPTH: f64 = 1e9;

/// Options of a render.
#[derive(Debug, Clone, Copy)]
pub struct RenderOptions {
    /// Error target of the general route's adaptive quadrature per pixel and lens,
    /// relative to a fully lit pixel under the scene's largest albedo.
    pub tol: f64,
    /// Each pixel takes the light of its own lens alone (the lens [`Design::pixel`]
    /// assigns it), not what its neighbours' lenses send it on a sensor layout: the depth
    /// sweep's test of which pixels sample one footprint (docs/depth.md). On the ideal
    /// layout a pixel sees its own lens only either way.
    pub own_lens: bool,
    /// An error target per pixel relative to the noise the render adds (replacing `tol`
    /// on the general route): [`NoiseTarget`].
    pub noise: Option<NoiseTarget>,
    /// Radiometric falloff: each ray weighted by the cos⁴ law on its microlens-to-sensor
    /// and/or main-lens-to-array segment (docs/model.md §10). Off by default (the paper's
    /// paraxial model); on, every channel takes the general route.
    pub falloff: Falloff,
    /// The general route takes a lens's boxes whose polygon of rays is one polygon moving
    /// by translation in closed form on a fronto-parallel plane (docs/render.md, "The
    /// interior in closed form"); off, every box by the quadrature (the reference of the
    /// closed form's tests).
    pub closed_form: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            tol: DEFAULT_TOL,
            own_lens: false,
            noise: None,
            falloff: Falloff::None,
            closed_form: true,
        }
    }
}

/// Most photons of a fully lit pixel a noise target accepts (as `simulate`'s noise).
pub const MAX_PHOTONS: f64 = 1e15;

/// A pixel's error target as a fraction of the standard deviation of the noise the render
/// adds at the pixel's own value v (raw units: counts Poisson(N v) plus Gaussian read noise
/// of r electrons, divided by N): `fraction` × √(max(v, 1/N)/N + (r/N)²), a value under
/// one photon counted as one (docs/render.md, "A target relative to the noise").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseTarget {
    /// N: photons of a pixel of value 1.
    pub photons: f64,
    /// r: read noise, electrons rms.
    pub read_noise: f64,
    /// The fraction of the noise's standard deviation, in (0, 1].
    pub fraction: f64,
}

impl NoiseTarget {
    /// The error target (raw units) at pixel value `v`.
    pub fn at(&self, v: f64) -> f64 {
        let n = self.photons;
        let rn = self.read_noise / n;
        self.fraction * (v.max(1.0 / n) / n + rn * rn).sqrt()
    }

    fn check(&self) -> Result<()> {
        if !(self.photons.is_finite() && self.photons > 0.0 && self.photons <= MAX_PHOTONS) {
            return Err(Error::param(
                "photons",
                self.photons,
                format!("a finite value in (0, {MAX_PHOTONS:e}] for a noise target"),
            ));
        }
        if !(self.read_noise.is_finite() && self.read_noise >= 0.0) {
            return Err(Error::param(
                "read_noise",
                self.read_noise,
                "a finite value >= 0",
            ));
        }
        if !(self.fraction.is_finite() && self.fraction > 0.0 && self.fraction <= 1.0) {
            return Err(Error::param(
                "noise_tol",
                self.fraction,
                "a fraction of the noise's standard deviation in (0, 1]",
            ));
        }
        Ok(())
    }
}

/// The raw shape (rows, cols) of a channel.
pub fn raw_shape(ch: &Channel) -> (usize, usize) {
    match ch.layout {
        Layout::Ideal { q } => ((ch.ky * q) as usize, (ch.kx * q) as usize),
        Layout::Sensor { mx, my } => (my as usize, mx as usize),
    }
}

/// The object-space rectangle (X0, X1, Y0, Y1) on the fronto-parallel plane at depth z
/// that holds every point a ray of any channel can reach (rays through any point of the
/// aperture and any point of the array's cells).
pub fn view_extent(design: &Design, z: f64) -> Result<[f64; 4]> {
    crate::model::optics::check_design_depths(design.f_main, &[z])?;
    let r = design.aperture / 2.0;
    let mut ext = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for ch in &design.channels {
        let (w, h) = ch.array_extent();
        // P = w (1 − z/F + z/L) − (z/L) x, extreme over |x| ≤ extent/2 and |w| ≤ r.
        let b = (1.0 - z / design.f_main + z / ch.l).abs() * r;
        let gx = z / ch.l * w / 2.0 + b;
        let gy = z / ch.l * h / 2.0 + b;
        ext = [
            ext[0].min(-gx),
            ext[1].max(gx),
            ext[2].min(-gy),
            ext[3].max(gy),
        ];
    }
    Ok(ext)
}

/// Check that the surface is in front of the main lens's focal plane wherever the design
/// looks (z > F at every point of the view over the surface's depth range).
pub(crate) fn check_surface(design: &Design, surface: &Surface) -> Result<()> {
    let f = design.f_main;
    match surface {
        Surface::Plane { z0, g } => {
            if *z0 > MAX_SCENE_DEPTH {
                return Err(Error::param(
                    "z0",
                    *z0,
                    format!("a depth in (F, {MAX_SCENE_DEPTH:e}] mm, F = {f} mm"),
                ));
            }
            if g[0] == 0.0 && g[1] == 0.0 {
                if *z0 <= f {
                    return Err(Error::param("z0", *z0, format!("a depth > F = {f} mm")));
                }
                return Ok(());
            }
            // A ray P(z) = w − z a (w on the main lens, a = w/F + (x − w)/L for x on a
            // channel's array) meets the plane at z = N/D, N = z0 + g·w, D = 1 + g·a (a hit
            // when N, D > 0). N and D are affine in (w, x): over the box of w (|w| ≤ r, a
            // circle inside it) and x (the array's box) the least hit depth is at a vertex,
            // or 0 where N changes sign on an edge with D > 0 (the plane passes through
            // the lens's own plane inside the ray bundle).
            if *z0 <= f {
                return Err(Error::param("z0", *z0, format!("a depth > F = {f} mm")));
            }
            let r = design.aperture / 2.0;
            let mut least = f64::INFINITY;
            for ch in &design.channels {
                let (w, h) = ch.array_extent();
                let half = [[r, r], [w / 2.0, h / 2.0]];
                let nd = |v: [f64; 4]| {
                    let (wv, xv) = ([v[0], v[1]], [v[2], v[3]]);
                    let a = [
                        wv[0] / f + (xv[0] - wv[0]) / ch.l,
                        wv[1] / f + (xv[1] - wv[1]) / ch.l,
                    ];
                    (
                        z0 + g[0] * wv[0] + g[1] * wv[1],
                        1.0 + g[0] * a[0] + g[1] * a[1],
                    )
                };
                let vertex = |k: usize| -> [f64; 4] {
                    let mut v = [0.0; 4];
                    for (i, vi) in v.iter_mut().enumerate() {
                        let s = if k >> i & 1 == 1 { 1.0 } else { -1.0 };
                        *vi = s * half[i / 2][i % 2];
                    }
                    v
                };
                for k in 0..16usize {
                    let (n, d) = nd(vertex(k));
                    if n > 0.0 && d > 0.0 {
                        least = least.min(n / d);
                    }
                    for i in 0..4 {
                        let k2 = k | 1 << i;
                        if k2 == k {
                            continue;
                        }
                        let (n2, d2) = nd(vertex(k2));
                        if (n > 0.0) != (n2 > 0.0) {
                            let t = n / (n - n2);
                            if d + t * (d2 - d) > 0.0 {
                                least = 0.0;
                            }
                        }
                    }
                }
            }
            if least <= f {
                return Err(Error::param(
                    "plane",
                    format!("Z = {z0} + {} X + {} Y", g[0], g[1]),
                    format!(
                        "a plane deeper than F = {f} mm wherever a ray of the design meets it \
                         (some ray meets it at {least:.1} mm)"
                    ),
                ));
            }
            Ok(())
        }
        Surface::Map(m) => {
            if m.zmax > MAX_SCENE_DEPTH {
                return Err(Error::param(
                    "depth_map",
                    m.zmax,
                    format!("depths in (F, {MAX_SCENE_DEPTH:e}] mm, F = {f} mm"),
                ));
            }
            if m.zmin <= f {
                return Err(Error::param(
                    "depth_map",
                    m.zmin,
                    format!("depths > F = {f} mm (the surface must lie in front of the main lens's focal plane)"),
                ));
            }
            Ok(())
        }
    }
}

/// Whether a channel takes the exact route.
pub(crate) fn exact_route(design: &Design, ch: &Channel, scene: &Scene) -> bool {
    scene.surface.fronto().is_some()
        && ch.grid == Grid::Rect
        && design.shape == Aperture::Square
        && matches!(ch.layout, Layout::Ideal { .. })
        && matches!(
            scene.texture,
            Texture::Image(_)
                | Texture::Constant(_)
                | Texture::Sinusoid { .. }
                | Texture::Bars { .. }
        )
}

/// Bytes a render holds at its peak: the raws, plus the exact route's per-type tables.
pub fn render_bytes(design: &Design) -> u128 {
    design
        .channels
        .iter()
        .map(|ch| {
            let (r, c) = raw_shape(ch);
            (r as u128) * (c as u128) * 8
        })
        .sum()
}

/// Render every channel's raw (row-major, §10 layout) into new buffers. `done` counts
/// finished raw rows over all channels (for progress).
pub fn render(
    design: &Design,
    scene: &Scene,
    opts: RenderOptions,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Vec<Vec<f64>>> {
    memory::check("the rendered raw images", render_bytes(design) + (1 << 20))?;
    let mut raws = Vec::with_capacity(design.channels.len());
    for ch in &design.channels {
        let (rows, cols) = raw_shape(ch);
        raws.push(memory::try_vec("a rendered raw image", rows * cols, 0.0)?);
    }
    let outs: Vec<&mut [f64]> = raws.iter_mut().map(|r| r.as_mut_slice()).collect();
    render_into(design, scene, opts, n_threads, done, outs)?;
    Ok(raws)
}

/// Check a render's options and scene against the design before any work.
pub fn check_render(design: &Design, scene: &Scene, opts: RenderOptions) -> Result<()> {
    if !(opts.tol.is_finite() && (MIN_TOL..=0.1).contains(&opts.tol)) {
        return Err(Error::param(
            "tol",
            opts.tol,
            format!("a value in [{MIN_TOL:e}, 0.1]"),
        ));
    }
    if let Some(nt) = &opts.noise {
        nt.check()?;
    }
    check_surface(design, &scene.surface)
}

/// [`render`] into the caller's buffers, one per channel of [`raw_shape`] (row-major).
pub fn render_into(
    design: &Design,
    scene: &Scene,
    opts: RenderOptions,
    n_threads: Option<usize>,
    done: &AtomicUsize,
    outs: Vec<&mut [f64]>,
) -> Result<()> {
    check_render(design, scene, opts)?;
    if outs.len() != design.channels.len() {
        return Err(Error::param(
            "outputs",
            outs.len(),
            "one buffer per channel",
        ));
    }
    for (ch, raw) in design.channels.iter().zip(outs) {
        let (rows, cols) = raw_shape(ch);
        if raw.len() != rows * cols {
            return Err(Error::param(
                "outputs",
                raw.len(),
                format!("{} values", rows * cols),
            ));
        }
        let chan = Chan::new(design, ch, opts.tol);
        let chan = noise_chan(chan, design, ch, scene, opts);
        fill_channel(design, &chan, scene, opts, raw, (n_threads, done))?;
    }
    Ok(())
}

/// The channel as a render with `opts` sees it: under a noise target the disc's polygon is
/// drawn for the brightest pixel's relative target (its area error is a fixed fraction of
/// a pixel's light, within a quarter of the target at every value since the target over v
/// grows as v falls).
fn noise_chan<'a>(
    chan: Chan<'a>,
    design: &'a Design,
    ch: &'a Channel,
    scene: &Scene,
    opts: RenderOptions,
) -> Chan<'a> {
    match opts.noise {
        Some(nt) => {
            let top = general::top_value(&chan, scene);
            Chan::new(design, ch, (nt.at(top) / top).clamp(MIN_TOL, 0.1))
        }
        None => chan,
    }
}

/// Render the rows `chan.rows` of one channel into `raw` (those rows, row-major) by the
/// channel's route.
fn fill_channel(
    design: &Design,
    chan: &Chan,
    scene: &Scene,
    opts: RenderOptions,
    raw: &mut [f64],
    (n_threads, done): (Option<usize>, &AtomicUsize),
) -> Result<()> {
    // The exact route's separable sums hold no weight: with falloff, the general route.
    if !opts.falloff.is_on() && exact_route(design, chan.ch, scene) {
        exact::render_channel(design, chan, scene, raw, n_threads, done)
    } else {
        general::general_channel(design, chan, scene, opts, raw, n_threads, done)
    }
}

/// A band of raw rows of one channel: rows `rows` (r0..r1) of channel `channel` (from 0).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Band {
    pub channel: usize,
    pub rows: Range<usize>,
}

/// Check a band against the design: a channel of the design and 0 <= r0 < r1 <= its raw's
/// rows ([`Error::param`] naming `channel` or `rows`). Returns the channel's raw shape.
pub fn check_band(design: &Design, band: &Band) -> Result<(usize, usize)> {
    let n = design.channels.len();
    let Some(ch) = design.channels.get(band.channel) else {
        return Err(Error::param(
            "channel",
            band.channel,
            format!("a channel index in [0, {}]", n - 1),
        ));
    };
    let (rows, cols) = raw_shape(ch);
    let Range { start, end } = band.rows;
    if !(start < end && end <= rows) {
        return Err(Error::param(
            "rows",
            format!("[{start}, {end})"),
            format!(
                "rows [r0, r1) with 0 <= r0 < r1 <= {rows} (channel {}'s raw rows)",
                band.channel
            ),
        ));
    }
    Ok((rows, cols))
}

/// The rows of one band of one channel's raw (row-major, r1 − r0 rows of [`raw_shape`]'s
/// columns), bit for bit the same rows of [`render`]'s raw: each raw row is computed on
/// its own by either route (the exact route's tables are per column and per row, the
/// general route's pixels are independent), so a band is a natural cut of a render over
/// tasks. `done` counts the band's finished rows.
pub fn render_band(
    design: &Design,
    scene: &Scene,
    opts: RenderOptions,
    band: &Band,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Vec<f64>> {
    check_render(design, scene, opts)?;
    let (_, cols) = check_band(design, band)?;
    let n = band.rows.len() * cols;
    memory::check("a band of a rendered raw", (n as u128) * 8 + (1 << 20))?;
    let mut out = memory::try_vec("a band of a rendered raw", n, 0.0)?;
    render_band_into(design, scene, opts, band, (n_threads, done), &mut out)?;
    Ok(out)
}

/// [`render_band`] into the caller's buffer of (r1 − r0) × cols values.
pub fn render_band_into(
    design: &Design,
    scene: &Scene,
    opts: RenderOptions,
    band: &Band,
    (n_threads, done): (Option<usize>, &AtomicUsize),
    out: &mut [f64],
) -> Result<()> {
    check_render(design, scene, opts)?;
    let (_, cols) = check_band(design, band)?;
    if out.len() != band.rows.len() * cols {
        return Err(Error::param(
            "output",
            out.len(),
            format!("{} values", band.rows.len() * cols),
        ));
    }
    let ch = &design.channels[band.channel];
    let chan = Chan::new(design, ch, opts.tol);
    let chan = noise_chan(chan, design, ch, scene, opts).with_rows(band.rows.clone());
    fill_channel(design, &chan, scene, opts, out, (n_threads, done))
}

#[derive(Clone, Copy)]
struct SendPtr(*mut f64);
// SAFETY: used only to hand disjoint row ranges of one buffer to the chunks of one call.
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}
impl SendPtr {
    fn get(self) -> *mut f64 {
        self.0
    }
}

/// Fill `raw`, the raw rows `rows` (r0..r1) of `cols` values each, on the pool of
/// `n_threads` in chunks of `step` rows (a checkpoint between chunks), the rows of a chunk
/// in parallel: `row(state, b, values)` writes raw row b (r0 <= b < r1) into `raw`'s row
/// b − r0, each worker holding its own `init()` state.
pub(super) fn fill_rows<T>(
    raw: &mut [f64],
    (rows, cols): (Range<usize>, usize),
    (n_threads, step): (Option<usize>, usize),
    init: impl Fn() -> T + Sync + Send,
    row: impl Fn(&mut T, usize, &mut [f64]) -> Result<()> + Sync + Send,
) -> Result<()> {
    debug_assert_eq!(raw.len(), rows.len() * cols);
    let first = rows.start;
    let raw_ptr = SendPtr(raw.as_mut_ptr());
    crate::infra::parallel::for_chunks(n_threads, rows.len(), step, |range| {
        let start = range.start;
        // SAFETY: each chunk writes its own disjoint rows of `raw`.
        let chunk = unsafe {
            std::slice::from_raw_parts_mut(raw_ptr.get().add(start * cols), range.len() * cols)
        };
        chunk
            .par_chunks_mut(cols)
            .enumerate()
            .try_for_each_init(&init, |state, (i, values)| {
                row(state, first + start + i, values)
            })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imaging::texture::Texture;

    /// The seed with 3 x 2 lenses per channel.
    fn seed_small() -> Design {
        let mut d = crate::model::presets::preset("seed").unwrap();
        for ch in d.channels.iter_mut() {
            ch.kx = 3;
            ch.ky = 2;
        }
        d
    }

    /// Bands of rows, stacked, are the whole render bit for bit: on the exact route (an
    /// image, and bars, on a fronto-parallel plane) and on the general route (a sinusoid on a tilted
    /// plane), with bands that start and end inside a lens's rows, one row alone, and on
    /// one thread and two.
    #[test]
    fn bands_are_the_whole_render_bit_for_bit() {
        let d = seed_small();
        let values: Vec<f64> = (0..40 * 50)
            .map(|i| ((i * 7919) % 101) as f64 / 100.0)
            .collect();
        let image =
            crate::imaging::texture::ImageTexture::new(&values, 40, 50, [-5.0, 5.0, -4.0, 4.0]);
        let image = Texture::Image(Box::new(image.unwrap()));
        let sinusoid = Texture::Sinusoid {
            frequency: 0.7,
            mean: 0.5,
            amplitude: 0.4,
            phase: 0.3,
        };
        let bars = Texture::Bars {
            frequency: 1.3,
            low: 0.2,
            high: 0.9,
        };
        let scenes = [
            (
                bars,
                Surface::Plane {
                    z0: 700.0,
                    g: [0.0, 0.0],
                },
                true,
            ),
            (
                image,
                Surface::Plane {
                    z0: 900.0,
                    g: [0.0, 0.0],
                },
                true,
            ),
            (
                sinusoid,
                Surface::Plane {
                    z0: 900.0,
                    g: [0.05, -0.02],
                },
                false,
            ),
        ];
        let opts = RenderOptions {
            tol: 1e-2,
            ..RenderOptions::default()
        };
        for (tex, surf, exact) in scenes {
            let scene = Scene::new(tex, surf, 0.5).unwrap();
            assert_eq!(exact_route(&d, &d.channels[0], &scene), exact);
            let whole = render(&d, &scene, opts, Some(2), &AtomicUsize::new(0)).unwrap();
            for (c, ch) in d.channels.iter().enumerate() {
                let (rows, cols) = raw_shape(ch);
                let cuts = [0, 1, 2, rows / 3, rows / 2 + 1, rows - 1, rows];
                let mut stacked = Vec::new();
                for (k, w) in cuts.windows(2).enumerate() {
                    let band = Band {
                        channel: c,
                        rows: w[0]..w[1],
                    };
                    let done = AtomicUsize::new(0);
                    let threads = Some(1 + k % 2);
                    let part = render_band(&d, &scene, opts, &band, threads, &done).unwrap();
                    assert_eq!(part.len(), (w[1] - w[0]) * cols);
                    assert_eq!(done.load(std::sync::atomic::Ordering::Relaxed), w[1] - w[0]);
                    stacked.extend(part);
                }
                let same = stacked
                    .iter()
                    .zip(&whole[c])
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same && stacked.len() == whole[c].len(), "channel {c}");
                assert!(whole[c].iter().any(|&v| v > 0.0));
            }
        }
    }

    /// A band outside the design is refused naming `channel` or `rows`, never a panic.
    #[test]
    fn bad_bands_name_their_parameter() {
        let d = seed_small();
        let scene = Scene::new(
            Texture::Constant(0.5),
            Surface::Plane {
                z0: 900.0,
                g: [0.0, 0.0],
            },
            0.5,
        )
        .unwrap();
        let rows = raw_shape(&d.channels[1]).0;
        let cases = [
            (
                Band {
                    channel: 2,
                    rows: 0..1,
                },
                "channel",
            ),
            (
                Band {
                    channel: 1,
                    rows: 3..3,
                },
                "rows",
            ),
            (
                Band {
                    channel: 1,
                    rows: 0..rows + 1,
                },
                "rows",
            ),
            (
                Band {
                    channel: 0,
                    rows: rows..rows + 2,
                },
                "rows",
            ),
        ];
        for (band, name) in cases {
            let err = render_band(
                &d,
                &scene,
                RenderOptions::default(),
                &band,
                None,
                &AtomicUsize::new(0),
            )
            .unwrap_err();
            match err {
                Error::InvalidParameter { name: n, .. } => assert_eq!(n, name, "{band:?}"),
                e => panic!("{band:?}: {e:?}"),
            }
        }
        let mut short = vec![0.0; 3];
        let band = Band {
            channel: 0,
            rows: 0..1,
        };
        let err = render_band_into(
            &d,
            &scene,
            RenderOptions::default(),
            &band,
            (None, &AtomicUsize::new(0)),
            &mut short,
        );
        assert!(err.is_err());
    }
}
