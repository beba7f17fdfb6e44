//! The exact route (module doc of [`super`]): a fronto-parallel plane, rect cells, a
//! square aperture, the ideal layout and an image (or constant) texture, or one of X
//! only (a sinusoid, bars: [`x_integral`]). A pixel's ray set
//! is the product of its x and y polygons, so its value is Σ_cells T · I_x · I_y with I the
//! areas of the 1-D ray sets between the cell's edges ([`Profile`]). The profiles (also
//! on a tilted plane, [`tilted_profile`]) serve the reconstruction's maps too.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::chan::Chan;
use super::{fill_rows, raw_shape};
use crate::imaging::scene::Scene;
use crate::imaging::texture::{ImageTexture, Scratch, Texture};
use crate::infra::error::{Error, Result};
use crate::infra::parallel::checkpoint;
use crate::infra::polygon::{clip_into, signed_area, Pt};
use crate::model::design::{Design, Layout};

/// Areas of one pixel's 1-D ray set (x, w) between consecutive cell edges of one axis:
/// `first` the index of the first cell, then the areas; plus the areas before the
/// first edge and after the last (outside the texture) and the total.
pub(crate) struct Profile {
    pub first: usize,
    pub areas: Vec<f64>,
    pub total: f64,
}

/// The offset θ of raw column (or row) i from its lens image's centre, on the ideal
/// layout with q pixels a lens.
pub(crate) fn pixel_offset(mu: f64, q: u32, i: u32) -> f64 {
    mu * ((i % q) as f64 - (q as f64 - 1.0) / 2.0)
}

/// The area of a pixel's 1-D ray set (the [`polygon`] below): its profile's total.
pub(crate) fn ray_set_area(chan: &Chan, alpha: f64, theta: f64) -> f64 {
    signed_area(&polygon(chan, alpha, theta)).max(0.0)
}

/// The mean ray of a pixel's 1-D ray set (lens centre c, offset θ, type α): its scene
/// coordinate on the fronto-parallel plane at depth z is w̄ − z ā (the coordinate is
/// affine in the ray, so its mean is the centroid's), returned as (w̄, ā); None for an
/// empty set.
pub(crate) fn mean_ray(chan: &Chan, alpha: f64, c: f64, theta: f64) -> Option<(f64, f64)> {
    mean_ray_of(chan, c, &polygon(chan, alpha, theta))
}

/// The slope a = w/F + (c + ξ − w)/L of the ray q = (ξ, w) behind the lens centred at
/// c: the ray is P(Z) = w − Z a.
fn slope(chan: &Chan, c: f64, q: Pt) -> f64 {
    q[1] / chan.f_main + (c + q[0] - q[1]) / chan.ch.l
}

/// [`mean_ray`] of any polygon of rays in (ξ, w) behind the lens centred at c.
pub(crate) fn mean_ray_of(chan: &Chan, c: f64, poly: &[Pt]) -> Option<(f64, f64)> {
    if signed_area(poly) <= 0.0 {
        return None;
    }
    let q = crate::infra::polygon::centroid(poly);
    Some((q[1], slope(chan, c, q)))
}

/// The scene coordinates [lo, hi] over which a polygon of rays in (ξ, w) behind the lens
/// centred at c meets the fronto-parallel plane at depth z: the extremes of an affine
/// function over the polygon, at its vertices; None for an empty polygon.
pub(crate) fn footprint_of(chan: &Chan, c: f64, poly: &[Pt], z: f64) -> Option<(f64, f64)> {
    if signed_area(poly) <= 0.0 {
        return None;
    }
    let xs = |q: &Pt| q[1] - z * slope(chan, c, *q);
    let lo = poly.iter().map(xs).fold(f64::INFINITY, f64::min);
    let hi = poly.iter().map(xs).fold(f64::NEG_INFINITY, f64::max);
    Some((lo, hi))
}

/// The 1-D ray-set polygon in (ξ, w) (ξ = x − c) of a pixel at offset θ from its lens
/// image centre: |ξ| ≤ d/2, |w| ≤ D/2, |α ξ − (v/L) w − θ| ≤ μ/2.
pub(crate) fn polygon(chan: &Chan, alpha: f64, theta: f64) -> Vec<Pt> {
    let (h, r, mu, vl) = (chan.hx, chan.r_ap, chan.ch.mu, chan.vl);
    let mut p = vec![[-h, -r], [h, -r], [h, r], [-h, r]];
    let mut t = Vec::new();
    clip_into(&p, &mut t, |q| {
        mu / 2.0 - (alpha * q[0] - vl * q[1] - theta)
    });
    clip_into(&t, &mut p, |q| {
        mu / 2.0 + (alpha * q[0] - vl * q[1] - theta)
    });
    p
}

/// The profile of a pixel (lens centre c, offset θ, type α) against cell edges
/// `edge(i)` for i = 0..=n (ascending), on the plane at depth z: the scene coordinate is
/// X = B w − (z/L)(c + ξ), B = 1 − z/F + z/L.
pub(crate) fn profile(
    chan: &Chan,
    alpha: f64,
    c: f64,
    theta: f64,
    z: f64,
    n: usize,
    edge: impl Fn(usize) -> f64,
) -> Profile {
    tilted_profile(chan, alpha, c, theta, Tilt { z0: z, g: 0.0 }, n, edge)
        .expect("a fronto-parallel plane at z > 0 is met by every ray")
}

/// The plane Z = z0 + g Y of one axis's profiles (g = 0: fronto-parallel at z0), Y the
/// scene coordinate along the axis the edges cut.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tilt {
    pub z0: f64,
    pub g: f64,
}

/// The profile against the edges of the axis along which the plane Z = z0 + g Y tilts
/// (g = 0: the fronto-parallel plane at z0). A ray of this axis, P(Z) = w − Z a with
/// a = w/F + (c + ξ − w)/L, meets the plane at Y = (w − z0 a) / (1 + g a) when
/// 1 + g a > 0, and there Y ≤ e exactly when w − Z_e a ≤ e, Z_e = z0 + g e: the
/// fronto-parallel condition at the edge's own depth, a straight cut of the polygon. So
/// the areas between edges stay exact. None when some ray of the pixel runs parallel
/// to the plane or meets it behind the main lens (1 + g a ≤ 0 or Z ≤ 0 somewhere).
pub(crate) fn tilted_profile(
    chan: &Chan,
    alpha: f64,
    c: f64,
    theta: f64,
    plane: Tilt,
    n: usize,
    edge: impl Fn(usize) -> f64,
) -> Option<Profile> {
    tilted_profile_of(chan, c, &polygon(chan, alpha, theta), plane, n, edge)
}

/// [`tilted_profile`] of any polygon of rays in (ξ, w) behind the lens centred at c (a
/// part of a pixel's ray set).
pub(crate) fn tilted_profile_of(
    chan: &Chan,
    c: f64,
    poly: &[Pt],
    plane: Tilt,
    n: usize,
    edge: impl Fn(usize) -> f64,
) -> Option<Profile> {
    let Tilt { z0, g } = plane;
    let total = signed_area(poly);
    if total <= 0.0 {
        return Some(Profile {
            first: 0,
            areas: Vec::new(),
            total: 0.0,
        });
    }
    let a_of = |q: Pt| slope(chan, c, q);
    // The scene coordinate of the fronto-parallel plane at depth z.
    let xs = |q: Pt, z: f64| q[1] - z * a_of(q);
    // Y is a linear-fractional function of (ξ, w): extreme at the polygon's vertices.
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &q in poly {
        let den = 1.0 + g * a_of(q);
        let y = (q[1] - z0 * a_of(q)) / den;
        if !(den > 0.0 && z0 + g * y > 0.0 && y.is_finite()) {
            return None;
        }
        lo = lo.min(y);
        hi = hi.max(y);
    }
    let mut tmp = Vec::new();
    // A(e): the area of the polygon whose rays meet the plane at Y ≤ e.
    let below = |e: f64, tmp: &mut Vec<Pt>| -> f64 {
        if e <= lo {
            return 0.0;
        }
        if e >= hi {
            return total;
        }
        let z = z0 + g * e;
        clip_into(poly, tmp, |q| e - xs(q, z));
        signed_area(tmp)
    };
    // Cells i whose [edge(i), edge(i+1)] meets [lo, hi].
    let (e0, en) = (edge(0), edge(n));
    let step = (en - e0) / n as f64;
    let i0 = (((lo - e0) / step).floor().max(0.0) as usize).min(n);
    let i1 = (((hi - e0) / step).ceil().max(0.0) as usize).min(n);
    let mut areas = Vec::with_capacity(i1.saturating_sub(i0));
    let mut prev = below(edge(i0), &mut tmp);
    for i in i0..i1 {
        let a = below(edge(i + 1), &mut tmp);
        areas.push(a - prev);
        prev = a;
    }
    Some(Profile {
        first: i0,
        areas,
        total,
    })
}

/// Per lens type, the profiles of the raw columns (`axis` 0) or rows (1) `pixels` against
/// the `n` texture cells of width `h` from `e0` along that axis, on the plane at depth z.
/// Built on the pool of `n_threads`, never rayon's global pool: its threads do not survive
/// a fork(), and a forked process-pool worker would wait on them forever.
fn axis_profiles(
    chan: &Chan,
    (q, axis): (u32, usize),
    pixels: std::ops::Range<u32>,
    z: f64,
    (n, e0, h): (usize, f64, f64),
    n_threads: Option<usize>,
) -> Result<Vec<Vec<Profile>>> {
    let ch = chan.ch;
    crate::infra::parallel::with_threads(n_threads, || {
        (0..chan.types.len())
            .map(|t| {
                pixels
                    .clone()
                    .into_par_iter()
                    .map(|i| {
                        let lens = if axis == 0 { (i / q, 0) } else { (0, i / q) };
                        let c = ch.lens_center(lens.0, lens.1)[axis];
                        let theta = pixel_offset(ch.mu, q, i);
                        profile(chan, chan.types[t].0, c, theta, z, n, |k| e0 + k as f64 * h)
                    })
                    .collect()
            })
            .collect()
    })
}

/// The exact route over one channel's raw, parallel over rows.
pub(super) fn render_channel(
    _design: &Design,
    chan: &Chan,
    scene: &Scene,
    raw: &mut [f64],
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<()> {
    let ch = chan.ch;
    let z = scene.surface.fronto().unwrap_or(f64::NAN);
    let Layout::Ideal { q } = ch.layout else {
        return Err(Error::param(
            "layout",
            "sensor",
            "the ideal layout (exact route)",
        ));
    };
    if matches!(
        scene.texture,
        Texture::Sinusoid { .. } | Texture::Bars { .. }
    ) {
        return x_channel(chan, &scene.texture, (z, q), raw, n_threads, done);
    }
    let constant;
    let tex: &ImageTexture = match &scene.texture {
        Texture::Image(im) => im,
        Texture::Constant(v) => {
            constant = ImageTexture::new(&[*v], 1, 1, [-1.0, 1.0, -1.0, 1.0])?;
            &constant
        }
        _ => {
            return Err(Error::param(
                "texture",
                "analytic",
                "an image texture (exact route)",
            ))
        }
    };
    let cols = raw_shape(ch).1;
    let (tx0, tx1, ty0, ty1) = tex.extent();
    let (tr, tc) = tex.shape();
    let hx = (tx1 - tx0) / tc as f64;
    let hy = (ty1 - ty0) / tr as f64;
    // X profiles per type and column a; Y profiles (top-down texture rows: edge i at
    // Y1 − i hy, so flip: bottom-up row index) per type and row b of the band this call
    // fills (every row for a whole render).
    let nt = chan.types.len();
    let band = chan.rows.clone();
    let px = axis_profiles(chan, (q, 0), 0..cols as u32, z, (tc, tx0, hx), n_threads)?;
    let py = axis_profiles(
        chan,
        (q, 1),
        band.start as u32..band.end as u32,
        z,
        (tr, ty0, hy),
        n_threads,
    )?;
    let mean = tex.mean_value();
    let norm = chan.norm;
    let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 64);
    fill_rows(
        raw,
        (band.clone(), cols),
        (n_threads, step),
        || vec![vec![0.0; tc]; nt],
        |tmps, b, row| {
            checkpoint()?;
            let k = b as u32 / q;
            // Per type: tmp[i] = Σ_rows Iy[row] T[row][i] (bottom-up rows) and
            // the y-area inside the texture.
            let mut ay_in = vec![0.0; nt];
            for t in 0..nt {
                let yp = &py[t][b - band.start];
                let tmp = &mut tmps[t];
                tmp.iter_mut().for_each(|v| *v = 0.0);
                for (r, &ay) in yp.areas.iter().enumerate() {
                    let bu = yp.first + r;
                    if ay == 0.0 {
                        continue;
                    }
                    ay_in[t] += ay;
                    for (tv, &v) in tmp.iter_mut().zip(tex.row_bottom_up(bu)) {
                        *tv += ay * v;
                    }
                }
            }
            for (a, out) in row.iter_mut().enumerate() {
                let t = ch.lens_type(a as u32 / q, k);
                let (xp, yp) = (&px[t][a], &py[t][b - band.start]);
                let tmp = &tmps[t];
                let mut inside = 0.0;
                let mut ax_in = 0.0;
                for (m, &ax) in xp.areas.iter().enumerate() {
                    inside += tmp[xp.first + m] * ax;
                    ax_in += ax;
                }
                let out_area = xp.total * yp.total - ax_in * ay_in[t];
                *out = norm * (inside + mean * out_area);
            }
            done.fetch_add(1, Ordering::Relaxed);
            Ok(())
        },
    )
}

/// ∫ T dξ dw over a pixel's 1-D x ray set (lens centre c, offset θ, type α) for a texture
/// that varies along X only (a sinusoid, bars) on the fronto-parallel plane at depth z.
/// The scene coordinate X = w − z a(ξ, w) is affine with ∂X/∂ξ = −z/L, so the polygon's
/// image in (X, w) has area z/L times its own, dξ dw = (L/z) dX dw, and the texture's own
/// closed form over a polygon ([`Texture::integral`], Green's theorem) applies there, w
/// standing in for the Y on which T does not depend.
pub(crate) fn x_integral(
    chan: &Chan,
    tex: &Texture,
    (alpha, c, theta): (f64, f64, f64),
    z: f64,
    scratch: &mut Scratch,
) -> f64 {
    let poly = polygon(chan, alpha, theta);
    if signed_area(&poly) <= 0.0 {
        return 0.0;
    }
    let mut img: Vec<Pt> = poly
        .iter()
        .map(|&q| [q[1] - z * slope(chan, c, q), q[1]])
        .collect();
    let mut area = signed_area(&img);
    if area < 0.0 {
        img.reverse();
        area = -area;
    }
    let (x0, x1, _, _) = crate::infra::polygon::bounds(&img);
    tex.integral(&img, area, x1 - x0, scratch) * chan.ch.l / z
}

/// The exact route for a texture that varies along X only: a pixel's value is
/// norm · (∫ T over its x ray set) · (its y ray set's area), each axis's factor once per
/// type and raw column (row).
fn x_channel(
    chan: &Chan,
    tex: &Texture,
    (z, q): (f64, u32),
    raw: &mut [f64],
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<()> {
    let ch = chan.ch;
    let cols = raw_shape(ch).1;
    let ix: Vec<Vec<f64>> = crate::infra::parallel::with_threads(n_threads, || {
        chan.types
            .iter()
            .map(|&(alpha, _)| {
                (0..cols as u32)
                    .into_par_iter()
                    .map_init(Scratch::default, |s, a| {
                        let c = ch.lens_center(a / q, 0)[0];
                        x_integral(chan, tex, (alpha, c, pixel_offset(ch.mu, q, a)), z, s)
                    })
                    .collect()
            })
            .collect()
    })?;
    let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 8);
    fill_rows(
        raw,
        (chan.rows.clone(), cols),
        (n_threads, step),
        || (),
        |_, b, row| {
            checkpoint()?;
            let k = b as u32 / q;
            let theta = pixel_offset(ch.mu, q, b as u32);
            let ay: Vec<f64> = chan
                .types
                .iter()
                .map(|&(alpha, _)| ray_set_area(chan, alpha, theta))
                .collect();
            for (a, out) in row.iter_mut().enumerate() {
                let t = ch.lens_type(a as u32 / q, k);
                *out = chan.norm * ix[t][a] * ay[t];
            }
            done.fetch_add(1, Ordering::Relaxed);
            Ok(())
        },
    )
}
