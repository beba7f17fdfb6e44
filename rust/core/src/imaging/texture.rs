//! Albedo textures on object space (docs/model.md §10, "Textures") and their exact
//! integrals over convex polygons, the inner integral of the 2-D forward model
//! (docs/render.md).
//!
//! Every kind integrates exactly over a polygon:
//! - image (piecewise constant on cells, its mean outside): Green's theorem,
//!   ∬ T dX dY = ∮ G dY with G(X, Y) = ∫_{X0}^{X} T dX', piecewise linear in X on each row
//!   of cells; each edge is cut where it crosses a row or a column, and on each piece G is
//!   linear, so the trapezoid rule is exact. Cost: the rows and columns an edge crosses.
//! - sinusoid along X: the same with G in closed form (a sinc on each edge).
//! - bar chart: G piecewise linear, edges cut at the bar edges.
//! - slanted edge: low × area + (high − low) × area of the polygon clipped by the edge's
//!   half-plane; Siemens star: the same with each bright wedge (two half-planes).

use std::f64::consts::PI;

use crate::imaging::grid::{walk, SampleGrid};
use crate::infra::error::{Error, Result};
use crate::infra::polygon::{angular_span, centroid, clip_into, signed_area, Pt};

mod moments;
#[cfg(test)]
mod reference;

/// Largest number of texture cells (far beyond any image; guards typos).
pub const MAX_TEXTURE_CELLS: usize = 1 << 31;
/// Most spokes of a Siemens star.
pub const MAX_SPOKES: u32 = 100_000;

/// An image texture: `rows` × `cols` albedos on uniform cells over [x0, x1] × [y0, y1],
/// row 0 at the top (y1); the array's mean outside. Stored bottom-up with row prefix sums.
#[derive(Debug, Clone)]
pub struct ImageTexture {
    grid: SampleGrid,
    mean: f64,
    /// The largest value.
    max: f64,
    /// Bottom-up row b (b = rows − 1 − r): `prefix[b * (cols + 1) + i]` = Σ_{i' < i} T hx.
    prefix: Vec<f64>,
    /// Values bottom-up, `values[b * cols + i]`.
    values: Vec<f64>,
    /// The first-moment row sums, built on first use (`moments.rs`); None when they could
    /// not be allocated.
    prefix_u: std::sync::OnceLock<Option<Vec<f64>>>,
}

/// A texture T(X, Y) ≥ 0 (docs/model.md §10).
#[derive(Debug, Clone)]
pub enum Texture {
    Constant(f64),
    Image(Box<ImageTexture>),
    /// mean + amplitude sin(2π f X + phase).
    Sinusoid {
        frequency: f64,
        mean: f64,
        amplitude: f64,
        phase: f64,
    },
    /// `high` on [k/f, (k + ½)/f), `low` on the rest.
    Bars {
        frequency: f64,
        low: f64,
        high: f64,
    },
    /// `high` where (X − X0) cos a − (Y − Y0) sin a ≥ 0.
    Edge {
        normal: [f64; 2],
        center: [f64; 2],
        low: f64,
        high: f64,
    },
    /// `high` where ⌊θ spokes / π⌋ is even, θ = atan2(Y − Y0, X − X0) ∈ [0, 2π).
    Star {
        spokes: u32,
        center: [f64; 2],
        low: f64,
        high: f64,
    },
}

/// Largest albedo accepted: far beyond any physical one, small enough that a pixel's
/// integral (albedo × ray measure × norm) and an image's sum cannot overflow.
pub const MAX_ALBEDO: f64 = 1e100;

pub(crate) fn albedo(name: &'static str, x: f64) -> Result<f64> {
    if x.is_finite() && (0.0..=MAX_ALBEDO).contains(&x) {
        Ok(x)
    } else {
        Err(Error::param(
            name,
            x,
            format!("a finite albedo in [0, {MAX_ALBEDO:e}]"),
        ))
    }
}

fn finite(name: &'static str, x: f64) -> Result<f64> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(Error::param(name, x, "a finite number"))
    }
}

fn positive(name: &'static str, x: f64) -> Result<f64> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(Error::param(name, x, "a finite value > 0"))
    }
}

/// `n` parameters for a `kind` of texture or surface, else an error on `name`
/// ("texture_params", "surface_params").
pub(crate) fn count_params(name: &'static str, kind: &str, params: &[f64], n: usize) -> Result<()> {
    if params.len() == n {
        Ok(())
    } else {
        let noun = name.trim_end_matches("_params");
        Err(Error::param(
            name,
            format!("{} values", params.len()),
            format!("{n} values for a {kind:?} {noun}"),
        ))
    }
}

impl ImageTexture {
    /// `values` row-major [row][col], row 0 at the top.
    pub fn new(values: &[f64], rows: usize, cols: usize, extent: [f64; 4]) -> Result<Self> {
        let grid = SampleGrid::new(
            "texture_image",
            (rows, cols),
            extent,
            (MAX_TEXTURE_CELLS, "cells"),
        )?;
        let mut sum = 0.0;
        let mut max = 0.0f64;
        for &v in values {
            albedo("texture_image", v)?;
            sum += v;
            max = max.max(v);
        }
        let mean = sum / values.len() as f64;
        let hx = grid.hx;
        let mut flipped = crate::infra::memory::try_vec("the texture", rows * cols, 0.0)?;
        let mut prefix =
            crate::infra::memory::try_vec("the texture's row sums", rows * (cols + 1), 0.0)?;
        for b in 0..rows {
            let r = rows - 1 - b;
            let src = &values[r * cols..(r + 1) * cols];
            flipped[b * cols..(b + 1) * cols].copy_from_slice(src);
            let p = &mut prefix[b * (cols + 1)..(b + 1) * (cols + 1)];
            let mut acc = 0.0;
            for (i, &v) in src.iter().enumerate() {
                p[i] = acc;
                acc += v * hx;
            }
            p[cols] = acc;
        }
        Ok(ImageTexture {
            grid,
            mean,
            max,
            prefix,
            values: flipped,
            prefix_u: std::sync::OnceLock::new(),
        })
    }

    /// (X0, X1, Y0, Y1).
    pub fn extent(&self) -> (f64, f64, f64, f64) {
        let [x0, x1, y0, y1] = self.grid.extent();
        (x0, x1, y0, y1)
    }

    /// (rows, cols).
    pub fn shape(&self) -> (usize, usize) {
        (self.grid.rows, self.grid.cols)
    }

    /// The mean albedo (used outside the extent).
    pub fn mean_value(&self) -> f64 {
        self.mean
    }

    /// Bottom-up row b (b = rows − 1 − r) of the values.
    pub fn row_bottom_up(&self, b: usize) -> &[f64] {
        &self.values[b * self.grid.cols..(b + 1) * self.grid.cols]
    }

    fn at(&self, p: Pt) -> f64 {
        let g = &self.grid;
        let (x, y) = (p[0], p[1]);
        if !(x >= g.x0 && x < g.x1 && y >= g.y0 && y < g.y1) {
            return self.mean;
        }
        let i = (((x - g.x0) / g.hx) as usize).min(g.cols - 1);
        let b = (((y - g.y0) / g.hy) as usize).min(g.rows - 1);
        self.values[b * g.cols + i]
    }

    /// ∫ G dY along the segment a → b, walking the cells it crosses (a digital
    /// differential analyser over the grid's lines, the region beyond the grid as one
    /// more column or row on each side): within a cell G is linear in X, and X is linear
    /// in Y along the segment, so each piece is its length in Y times G at its midpoint.
    /// One G evaluation per cell crossed, no division in the loop.
    fn edge(&self, a: Pt, b: Pt) -> f64 {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        if dy == 0.0 {
            return 0.0;
        }
        let (x, y) = self.grid.lines();
        let mut total = 0.0;
        walk(x, y, a, b, |c, r, t0, t1| {
            let x = a[0] + 0.5 * (t0 + t1) * dx;
            total += (t1 - t0) * self.g_cell(r, c, x);
        });
        total * dy
    }

    /// G on bottom-up row `r` at X = x in column `c` (−1 / rows, −1 / cols: beyond the
    /// grid, where T is the mean).
    #[inline]
    fn g_cell(&self, r: i64, c: i64, x: f64) -> f64 {
        let g = &self.grid;
        if r < 0 || r >= g.rows as i64 || c < 0 {
            return self.mean * (x - g.x0);
        }
        let (r, cols) = (r as usize, g.cols);
        let p = &self.prefix[r * (cols + 1)..(r + 1) * (cols + 1)];
        if c as usize >= cols {
            return p[cols] + self.mean * (x - g.x1);
        }
        let i = c as usize;
        p[i] + self.values[r * cols + i] * (x - (g.x0 + i as f64 * g.hx))
    }
}

impl Texture {
    /// A texture from the seam's description (kind, params, optional image): see
    /// docs/render.md. Errors name the parameter.
    pub fn from_parts(
        kind: &str,
        params: &[f64],
        image: Option<(&[f64], usize, usize)>,
    ) -> Result<Texture> {
        if kind != "image" && image.is_some() {
            return Err(Error::param(
                "texture_image",
                "an array",
                format!("None for a {kind:?} texture"),
            ));
        }
        match kind {
            "constant" => {
                count_params("texture_params", kind, params, 1)?;
                Ok(Texture::Constant(albedo("albedo", params[0])?))
            }
            "image" => {
                count_params("texture_params", kind, params, 4)?;
                let Some((v, rows, cols)) = image else {
                    return Err(Error::param(
                        "texture_image",
                        "None",
                        "a 2-D array of albedos for an \"image\" texture",
                    ));
                };
                let ext = [params[0], params[1], params[2], params[3]];
                Ok(Texture::Image(Box::new(ImageTexture::new(
                    v, rows, cols, ext,
                )?)))
            }
            "sinusoid" => {
                count_params("texture_params", kind, params, 4)?;
                let frequency = positive("frequency", params[0])?;
                let mean = albedo("mean", params[1])?;
                let amplitude = albedo("amplitude", params[2])?;
                let phase = finite("phase", params[3])?;
                if amplitude > mean {
                    return Err(Error::param(
                        "amplitude",
                        amplitude,
                        format!("<= mean = {mean} (albedo >= 0)"),
                    ));
                }
                Ok(Texture::Sinusoid {
                    frequency,
                    mean,
                    amplitude,
                    phase,
                })
            }
            "bars" => {
                count_params("texture_params", kind, params, 3)?;
                Ok(Texture::Bars {
                    frequency: positive("frequency", params[0])?,
                    low: albedo("low", params[1])?,
                    high: albedo("high", params[2])?,
                })
            }
            "edge" => {
                count_params("texture_params", kind, params, 5)?;
                let a = finite("angle", params[0])?.to_radians();
                Ok(Texture::Edge {
                    normal: [a.cos(), -a.sin()],
                    low: albedo("low", params[1])?,
                    high: albedo("high", params[2])?,
                    center: [finite("center", params[3])?, finite("center", params[4])?],
                })
            }
            "star" => {
                count_params("texture_params", kind, params, 5)?;
                let s = params[0];
                if !(s.fract() == 0.0 && s >= 1.0 && s <= MAX_SPOKES as f64) {
                    return Err(Error::param(
                        "spokes",
                        s,
                        format!("an integer in [1, {MAX_SPOKES}]"),
                    ));
                }
                Ok(Texture::Star {
                    spokes: s as u32,
                    low: albedo("low", params[1])?,
                    high: albedo("high", params[2])?,
                    center: [finite("center", params[3])?, finite("center", params[4])?],
                })
            }
            _ => Err(Error::param(
                "texture",
                format!("{kind:?}"),
                "one of \"constant\", \"image\", \"sinusoid\", \"bars\", \"edge\", \"star\"",
            )),
        }
    }

    /// The mean albedo (of the array, of a period, or (low + high)/2).
    pub fn mean(&self) -> f64 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image(im) => im.mean,
            Texture::Sinusoid { mean, .. } => *mean,
            Texture::Bars { low, high, .. }
            | Texture::Edge { low, high, .. }
            | Texture::Star { low, high, .. } => 0.5 * (low + high),
        }
    }

    /// The largest albedo anywhere (an image's largest value, mean + amplitude, or the
    /// larger of low and high): the scale of the general route's error target.
    pub fn max_albedo(&self) -> f64 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image(im) => im.max,
            Texture::Sinusoid {
                mean, amplitude, ..
            } => mean + amplitude,
            Texture::Bars { low, high, .. }
            | Texture::Edge { low, high, .. }
            | Texture::Star { low, high, .. } => low.max(*high),
        }
    }

    /// Does the albedo jump inside the box [x0, x1] × [y0, y1] along a line that the
    /// renderer's cuts do not follow (a slanted edge, a star's spokes or centre), or, for
    /// a sinusoid, does the box span more than half its period (a point moving across it
    /// passes an extremum, where the quadrature rules' comparison can agree by chance)?
    /// Image cells and bar edges are axis-aligned: the renderer cuts at them.
    pub fn jumps_in(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> bool {
        let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        match self {
            Texture::Edge { normal, center, .. } => {
                let (lo, hi) = corners
                    .iter()
                    .map(|&p| edge_side(normal, center, p))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(v), b.max(v))
                    });
                lo <= 0.0 && hi >= 0.0
            }
            Texture::Star { spokes, center, .. } => {
                if center[0] >= x0 && center[0] <= x1 && center[1] >= y0 && center[1] <= y1 {
                    return true;
                }
                let width = PI / *spokes as f64;
                let (lo, hi) = angular_span(&corners, *center);
                // A few spoke edges: localised kinks the rules may miss; many: weak kinks
                // spread over the box, which the rules' comparison sees.
                let crossings = (hi / width).floor() - (lo / width).floor();
                (1.0..=8.0).contains(&crossings)
            }
            Texture::Sinusoid { frequency, .. } => (x1 - x0) * frequency > 0.5,
            _ => false,
        }
    }

    /// The image texture, if this is one.
    pub fn image(&self) -> Option<&ImageTexture> {
        match self {
            Texture::Image(im) => Some(im),
            _ => None,
        }
    }

    /// T at a point.
    pub fn at(&self, p: Pt) -> f64 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image(im) => im.at(p),
            Texture::Sinusoid {
                frequency,
                mean,
                amplitude,
                phase,
            } => mean + amplitude * (2.0 * PI * frequency * p[0] + phase).sin(),
            Texture::Bars {
                frequency,
                low,
                high,
            } => {
                let s = frequency * p[0];
                if s - s.floor() < 0.5 {
                    *high
                } else {
                    *low
                }
            }
            Texture::Edge {
                normal,
                center,
                low,
                high,
            } => {
                if edge_side(normal, center, p) >= 0.0 {
                    *high
                } else {
                    *low
                }
            }
            Texture::Star {
                spokes,
                center,
                low,
                high,
            } => {
                let mut t = (p[1] - center[1]).atan2(p[0] - center[0]);
                if t < 0.0 {
                    t += 2.0 * PI;
                }
                if ((t * *spokes as f64 / PI).floor() as i64) % 2 == 0 {
                    *high
                } else {
                    *low
                }
            }
        }
    }

    /// The mean of T over a convex polygon (T at its centroid when its area vanishes).
    pub fn average(&self, poly: &[Pt], scratch: &mut Scratch) -> f64 {
        let area = signed_area(poly);
        let (x0, x1, y0, y1) = crate::infra::polygon::bounds(poly);
        let scale = (x1 - x0).max(y1 - y0);
        if area.abs() <= 1e-12 * scale * scale || !area.is_finite() {
            return self.at(centroid(poly));
        }
        let v = self.integral(poly, area, x1 - x0, scratch) / area;
        v.max(0.0)
    }

    /// ∫ T over a polygon of signed area `area` (same orientation sign as `area`) and
    /// extent `x_span` along X.
    pub(crate) fn integral(&self, poly: &[Pt], area: f64, x_span: f64, s: &mut Scratch) -> f64 {
        let n = poly.len();
        match self {
            Texture::Constant(c) => c * area,
            Texture::Image(im) => {
                let mut t = 0.0;
                for i in 0..n {
                    t += im.edge(poly[i], poly[(i + 1) % n]);
                }
                t
            }
            Texture::Sinusoid {
                frequency,
                mean,
                amplitude,
                phase,
            } => {
                let wave = Wave {
                    w: 2.0 * PI * frequency,
                    mean: *mean,
                    amplitude: *amplitude,
                    phase: *phase,
                };
                sinusoid_integral(poly, x_span, &wave)
            }
            Texture::Bars {
                frequency,
                low,
                high,
            } => {
                // G(X) = mean X + (high − low) tri(X), tri(X) = ½ dist(X, P ℤ) (P = 1/f),
                // so ∫ G dY along an edge = dy (mean xm + (high − low) · tri's mean over
                // the edge's X range): no loop over the bars, any frequency.
                let period = (1.0 / frequency).min(f64::MAX);
                let mean = 0.5 * (low + high);
                edge_integral(poly, |a, b| {
                    let xm = 0.5 * (a[0] + b[0]);
                    mean * xm + (high - low) * tri_mean(period, a[0], b[0])
                })
            }
            Texture::Edge {
                normal,
                center,
                low,
                high,
            } => {
                clip_into(poly, &mut s.a, |p| edge_side(normal, center, p));
                low * area + (high - low) * signed_area(&s.a)
            }
            Texture::Star {
                spokes,
                center,
                low,
                high,
            } => low * area + (high - low) * star_bright_area(poly, *spokes, *center, s),
        }
    }
}

/// An edge's side of point p: its offset from the edge's line along the unit normal
/// (≥ 0 on the `high` side).
fn edge_side(normal: &Pt, center: &Pt, p: Pt) -> f64 {
    normal[0] * (p[0] - center[0]) + normal[1] * (p[1] - center[1])
}

/// ∮ G dY around a polygon from G's mean along each edge, `mean_g(a, b)` (an edge with
/// dy = 0 adds nothing): the textures whose antiderivative G(X) along X is closed form.
fn edge_integral(poly: &[Pt], mean_g: impl Fn(Pt, Pt) -> f64) -> f64 {
    let n = poly.len();
    let mut t = 0.0;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        let dy = b[1] - a[1];
        if dy != 0.0 {
            t += dy * mean_g(a, b);
        }
    }
    t
}

/// The least w × (the polygon's X extent) at which [`sinusoid_integral`] takes the direct
/// form: its rounding error, ~n ε amplitude |dY| / w over n edges, is then below
/// n ε / `SINUSOID_DIRECT_MIN` ≈ 1.3e-13 (n = 6) of amplitude × the polygon's bounding box.
const SINUSOID_DIRECT_MIN: f64 = 1e-2;

/// A sinusoid mean + amplitude sin(w X + φ), w = 2π frequency.
struct Wave {
    w: f64,
    mean: f64,
    amplitude: f64,
    phase: f64,
}

/// ∮ G dY for the sinusoid `wave` over a polygon spanning `x_span` along X.
///
/// Where the polygon spans at least [`SINUSOID_DIRECT_MIN`] / w along X: the direct form,
/// G(X) = mean X − amplitude cos(w X + φ)/w, whose mean along an edge (X = xm + t dx/2,
/// t ∈ [−1, 1], h = w dx/2) is mean xm − amplitude cos(w xm + φ) sinc(h) / w — one sine,
/// one cosine and one division an edge (929d86a's arithmetic, bit for bit).
/// Narrower (w tiny): the direct form's terms ~ amplitude / w cancel (a frequency of
/// 1e-20 read black), so G(X) = mean X + amplitude (cos φ − cos(w X + φ))/w, with the
/// constant cos φ / w, which drops out of ∮ G dY, folded in without cancellation: with
/// u = w xm, its mean along an edge is
///   cos φ (xm sin(u/2) sinc(u/2) + cos u (dx/2) c1(h)) + sin φ xm sinc u sinc h,
/// c1(h) = (1 − sinc h)/h: the same two transcendental calls an edge, but four divisions
/// instead of one and more products (sinusoid renders ran ~1.7× slower on it).
fn sinusoid_integral(poly: &[Pt], x_span: f64, wave: &Wave) -> f64 {
    let Wave {
        w,
        mean,
        amplitude,
        phase,
    } = *wave;
    if w * x_span >= SINUSOID_DIRECT_MIN {
        return edge_integral(poly, |a, b| {
            let xm = 0.5 * (a[0] + b[0]);
            let h = 0.5 * w * (b[0] - a[0]);
            let sinc = if h.abs() < 1e-8 {
                1.0 - h * h / 6.0
            } else {
                h.sin() / h
            };
            mean * xm - amplitude / w * (w * xm + phase).cos() * sinc
        });
    }
    let (cp, sp) = (phase.cos(), phase.sin());
    edge_integral(poly, |a, b| {
        let xm = 0.5 * (a[0] + b[0]);
        let half = 0.5 * (b[0] - a[0]);
        let (u, h) = (w * xm, w * half);
        // Two transcendental calls an edge: sin and cos of u/2 give sin u and cos u, sin h
        // gives sinc h and c1(h).
        let (s2, c2) = (0.5 * u).sin_cos();
        let (sin_u, cos_u) = (2.0 * s2 * c2, 1.0 - 2.0 * s2 * s2);
        let sin_h = h.sin();
        let wave = cp * (xm * s2 * sinc_of(0.5 * u, s2) + cos_u * half * c1_of(h, sin_h))
            + sp * xm * sinc_of(u, sin_u) * sinc_of(h, sin_h);
        mean * xm + amplitude * wave
    })
}

/// sin x / x (`sin_x` = sin x).
fn sinc_of(x: f64, sin_x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 - x * x / 6.0
    } else {
        sin_x / x
    }
}

/// (1 − sinc h)/h, without cancellation for small h (`sin_h` = sin h).
fn c1_of(h: f64, sin_h: f64) -> f64 {
    if h.abs() < 1e-3 {
        h / 6.0 - h * h * h / 120.0
    } else {
        (1.0 - sin_h / h) / h
    }
}

/// ½ the distance from X to the nearest multiple of `period` (a triangle wave of height
/// period/4, kinked at the bar edges k period/2).
fn tri(period: f64, x: f64) -> f64 {
    let k = (x / period).floor();
    let (lo, hi) = (x - k * period, (k + 1.0) * period - x);
    0.5 * lo.min(hi).clamp(0.0, 0.5 * period)
}

/// The mean of [`tri`] over X between xa and xb (its value at xa when they coincide).
fn tri_mean(period: f64, xa: f64, xb: f64) -> f64 {
    let (lo, hi) = if xa < xb { (xa, xb) } else { (xb, xa) };
    let half = 0.5 * period;
    let (m0, m1) = ((lo / half).floor(), (hi / half).ceil());
    if hi <= lo || hi.is_nan() || lo.is_nan() {
        return tri(period, lo);
    }
    if m1 - m0 <= 64.0 {
        // Linear between the kinks: the trapezoid rule piece by piece is exact.
        let mut acc = 0.0;
        let (mut x, mut v) = (lo, tri(period, lo));
        for j in 1..(m1 - m0) as i64 {
            let k = (m0 + j as f64) * half;
            if k > x && k < hi {
                let vk = tri(period, k);
                acc += 0.5 * (v + vk) * (k - x);
                (x, v) = (k, vk);
            }
        }
        let vh = tri(period, hi);
        acc += 0.5 * (v + vh) * (hi - x);
        return acc / (hi - lo);
    }
    // Many periods: the antiderivative in units of the period, P² T(X/P) with
    // T(u) = ⌊u⌋/8 + q(u − ⌊u⌋), q(s) = s²/4 (s < ½), 1/8 − (1 − s)²/4 (s ≥ ½).
    let big_t = |u: f64| {
        let k = u.floor();
        let s = u - k;
        let q = if s < 0.5 {
            0.25 * s * s
        } else {
            0.125 - 0.25 * (1.0 - s) * (1.0 - s)
        };
        0.125 * k + q
    };
    let (ua, ub) = (lo / period, hi / period);
    period * (big_t(ub) - big_t(ua)) / (ub - ua)
}

/// Signed area of the polygon's part in the bright wedges of a Siemens star.
fn star_bright_area(poly: &[Pt], spokes: u32, c: Pt, s: &mut Scratch) -> f64 {
    let width = PI / spokes as f64;
    // The wedges the polygon can touch: all when the centre is inside or on it, else the
    // angular range of its vertices (a convex polygon not containing c spans < π).
    let inside = {
        let n = poly.len();
        let sgn = signed_area(poly).signum();
        (0..n).all(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            sgn * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) >= 0.0
        })
    };
    let wedges = 2 * spokes as i64;
    let (k0, k1) = if inside {
        (0, wedges - 1)
    } else {
        let (lo, hi) = angular_span(poly, c);
        (
            (lo / width).floor() as i64 - 1,
            (hi / width).floor() as i64 + 1,
        )
    };
    // Each wedge once: with few spokes the margins can wrap round to the same wedge (one
    // spoke: wedges 0 and 2 are both the bright half-plane, counted twice before).
    let (k0, k1) = if k1 - k0 + 1 >= wedges {
        (0, wedges - 1)
    } else {
        (k0, k1)
    };
    let mut total = 0.0;
    for k in k0..=k1 {
        if k.rem_euclid(2) != 0 {
            continue;
        }
        let (t0, t1) = (k as f64 * width, (k + 1) as f64 * width);
        let (e0, e1) = ([t0.cos(), t0.sin()], [t1.cos(), t1.sin()]);
        clip_into(poly, &mut s.a, |p| {
            e0[0] * (p[1] - c[1]) - e0[1] * (p[0] - c[0])
        });
        if spokes == 1 {
            total += signed_area(&s.a);
            continue;
        }
        clip_into(&s.a, &mut s.b, |p| {
            e1[1] * (p[0] - c[0]) - e1[0] * (p[1] - c[1])
        });
        total += signed_area(&s.b);
    }
    total
}

/// Reusable buffers of one worker.
#[derive(Debug, Default)]
pub struct Scratch {
    pub knots: Vec<f64>,
    pub a: Vec<Pt>,
    pub b: Vec<Pt>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Vec<Pt> {
        vec![[0.13, -0.4], [2.71, 0.35], [0.9, 1.93]]
    }

    /// Brute-force mean over the polygon by a fine midpoint grid.
    fn brute(t: &Texture, p: &[Pt], n: usize) -> f64 {
        let (x0, x1, y0, y1) = crate::infra::polygon::bounds(p);
        let (hx, hy) = ((x1 - x0) / n as f64, (y1 - y0) / n as f64);
        let mut s = 0.0;
        let mut c = 0usize;
        let inside = |q: Pt| {
            (0..p.len()).all(|i| {
                let (a, b) = (p[i], p[(i + 1) % p.len()]);
                (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]) >= 0.0
            })
        };
        for i in 0..n {
            for j in 0..n {
                let q = [x0 + (i as f64 + 0.5) * hx, y0 + (j as f64 + 0.5) * hy];
                if inside(q) {
                    s += t.at(q);
                    c += 1;
                }
            }
        }
        s / c as f64
    }

    #[test]
    fn every_kind_matches_a_fine_grid() {
        let vals: Vec<f64> = (0..35).map(|i| ((i * 7919) % 13) as f64 / 13.0).collect();
        let kinds = [
            Texture::from_parts("image", &[-0.5, 2.0, -0.2, 1.5], Some((&vals, 5, 7))).unwrap(),
            Texture::from_parts("sinusoid", &[1.3, 0.5, 0.4, 0.3], None).unwrap(),
            Texture::from_parts("bars", &[1.7, 0.1, 0.9], None).unwrap(),
            Texture::from_parts("edge", &[20.0, 0.1, 0.9, 1.0, 0.5], None).unwrap(),
            Texture::from_parts("star", &[5.0, 0.1, 0.9, 1.1, 0.6], None).unwrap(),
            Texture::from_parts("star", &[1.0, 0.1, 0.9, 1.1, 0.6], None).unwrap(),
            Texture::from_parts("constant", &[0.7], None).unwrap(),
        ];
        let mut s = Scratch::default();
        for t in &kinds {
            for poly in [tri(), tri().into_iter().rev().collect::<Vec<_>>()] {
                let exact = t.average(&poly, &mut s);
                let b = brute(t, &tri(), 1500);
                assert!((exact - b).abs() < 3e-3, "{t:?}: {exact} vs {b}");
            }
        }
    }

    /// A 1-spoke star is the half-plane Y ≥ Y0 bright: a triangle right of the centre
    /// and across Y0 (no vertex at the centre) reads low + (high − low) × its share above
    /// Y0, by hand; before, the wedge list wrapped round and counted that half twice.
    #[test]
    fn one_spoke_star_is_a_half_plane() {
        let t = Texture::from_parts("star", &[1.0, 0.0, 1.0, 0.0, 0.0], None).unwrap();
        // Triangle (1, −1), (3, −1), (1, 3): area 4; above Y = 0 the triangle (1, 0),
        // (2.5, 0), (1, 3) of area 2.25.
        let p = [[1.0, -1.0], [3.0, -1.0], [1.0, 3.0]];
        let v = t.average(&p, &mut Scratch::default());
        assert!((v - 2.25 / 4.0).abs() < 1e-12, "{v}");
    }

    /// A sinusoid of tiny frequency is its value at the origin, mean + amplitude sin φ,
    /// over a small polygon anywhere near it (before: 1e-20 read black, 1e-15 off 0.5 %).
    #[test]
    fn slow_sinusoid_is_its_value_at_the_origin() {
        let p = tri();
        for f in [1e-300, 1e-20, 1e-15, 1e-9] {
            let t = Texture::from_parts("sinusoid", &[f, 0.5, 0.4, 0.3], None).unwrap();
            let v = t.average(&p, &mut Scratch::default());
            let want = 0.5 + 0.4 * 0.3f64.sin();
            assert!((v - want).abs() < 1e-6, "{f}: {v} vs {want}");
        }
    }

    /// Both forms of the sinusoid's integral against the closed form over a rectangle
    /// [x0, x1] × [y0, y1], by hand: (y1 − y0) (mean (x1 − x0) + 2 amplitude/w ·
    /// sin(w xm + φ) sin(w (x1 − x0)/2)), xm the centre (cos a − cos b as a product: no
    /// cancellation at tiny w); frequencies on both sides of the switch and at it.
    #[test]
    fn sinusoid_forms_match_the_rectangle_closed_form() {
        let (x0, x1, y0, y1) = (0.7, 1.9, -0.4, 0.8);
        let rect = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        let (mean, amp, phase) = (0.5, 0.4, 0.3);
        let switch = SINUSOID_DIRECT_MIN / (2.0 * PI * (x1 - x0));
        let mut s = Scratch::default();
        for f in [
            1e-15,
            1e-6,
            0.5 * switch,
            switch * (1.0 - 1e-12),
            switch,
            2.0 * switch,
            0.3,
            1.3,
            40.0,
        ] {
            let w = 2.0 * PI * f;
            let xm = 0.5 * (x0 + x1);
            let want = (y1 - y0)
                * (mean * (x1 - x0)
                    + 2.0 * amp / w * (w * xm + phase).sin() * (0.5 * w * (x1 - x0)).sin());
            let t = Texture::from_parts("sinusoid", &[f, mean, amp, phase], None).unwrap();
            let area = (x1 - x0) * (y1 - y0);
            for poly in [
                rect.to_vec(),
                rect.iter().rev().copied().collect::<Vec<_>>(),
            ] {
                let got = t.integral(&poly, signed_area(&poly), x1 - x0, &mut s);
                let sign = signed_area(&poly).signum();
                assert!(
                    (got - sign * want).abs() < 1e-13 * area,
                    "{f}: {got} vs {want}"
                );
            }
        }
    }

    /// Bars of extreme frequencies: far finer than the polygon, the mean (low + high)/2
    /// (before: a panic, capacity overflow, from 1e18 on); far wider, the bar the polygon
    /// lies in (X ≥ 0: high; before: 1.45 × high at 5e-324).
    #[test]
    fn bars_of_extreme_frequencies() {
        let p = tri(); // X in [0.13, 2.71]
        let mut s = Scratch::default();
        for f in [1e18, 1e30, 1e300] {
            let t = Texture::from_parts("bars", &[f, 0.1, 0.9], None).unwrap();
            let v = t.average(&p, &mut s);
            assert!((v - 0.5).abs() < 1e-9, "{f}: {v}");
        }
        for f in [5e-324, 1e-300, 1e-20] {
            let t = Texture::from_parts("bars", &[f, 0.1, 0.9], None).unwrap();
            let v = t.average(&p, &mut s);
            assert!((v - 0.9).abs() < 1e-9, "{f}: {v}");
            let left: Vec<Pt> = p.iter().map(|q| [-q[0], q[1]]).rev().collect();
            let v = t.average(&left, &mut s);
            assert!((v - 0.1).abs() < 1e-9, "{f} left: {v}");
        }
    }

    #[test]
    fn image_cells_exact() {
        // A polygon equal to one cell averages to that cell's value exactly.
        let vals = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // 2 rows x 3 cols, row 0 top
        let t = Texture::from_parts("image", &[0.0, 3.0, 0.0, 2.0], Some((&vals, 2, 3))).unwrap();
        let mut s = Scratch::default();
        let cell = [[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [1.0, 2.0]]; // top row, middle col
        assert!((t.average(&cell, &mut s) - 2.0).abs() < 1e-14);
        let low = [[2.0, 0.0], [3.0, 0.0], [3.0, 1.0], [2.0, 1.0]];
        assert!((t.average(&low, &mut s) - 6.0).abs() < 1e-14);
        let out = [[5.0, 5.0], [6.0, 5.0], [6.0, 6.0], [5.0, 6.0]];
        assert!((t.average(&out, &mut s) - 3.5).abs() < 1e-14);
    }
}
