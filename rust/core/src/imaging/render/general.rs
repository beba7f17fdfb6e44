//! The general route (module doc of [`super`]): any surface, cell grid, aperture, layout
//! and texture. Per pixel and lens, a 2-D adaptive quadrature ([`super::adaptive`]) over
//! the main-lens point w (outer w) or the sensor point s (outer s), cut where the
//! integrand's kinks are known ([`super::kinks`]); at each node the exact mean of the
//! texture over the node's polygon of rays ([`super::mean`]).

use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::adaptive::{adaptive, never, over_boxes, QBox};
use super::chan::{Chan, Work};
use super::falloff::{piece_step, weighted_integral, Segments, Weighting};
use super::footprint;
use super::interior::{self, Lens};
use super::kinks::{bilinear, box_cuts, extent_kinks, texture_kinks, Sweep};
use super::mean::scene_mean;
use super::sat::{MemoShelf, SatTable};
use super::{fill_rows, raw_shape, NoiseTarget, RenderOptions};
use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::Texture;
use crate::infra::error::Result;
use crate::infra::parallel::checkpoint;
use crate::infra::polygon::{angular_span, bounds, clip_box, clip_into, signed_area, Pt};
use crate::model::design::{Aperture, Design, Grid, Layout};

/// One channel's pixels under a scene: what [`pixel_value`] integrates. `tol` is the
/// adaptive rule's absolute target per lens (before the channel's norm).
#[derive(Clone, Copy)]
pub(crate) struct Pixels<'a> {
    pub(crate) design: &'a Design,
    pub(crate) chan: &'a Chan<'a>,
    pub(crate) scene: &'a Scene,
    pub(crate) tol: f64,
    /// The rays' radiometric falloff, when on (docs/model.md §10).
    pub(crate) weighting: Option<Weighting>,
    /// The texture's summed areas, when the boxes inside a lens take the closed form
    /// ([`interior`]: a fronto-parallel plane, an image or constant texture, no falloff).
    pub(crate) sat: Option<&'a SatTable>,
}

/// One lens as one pixel sees it: its centre c, its type's α and κ = v/f, and
/// e = (1 + v/L) c − s, its image centre's offset from the pixel's sensor point s.
#[derive(Debug, Clone, Copy)]
struct LensView {
    c: Pt,
    alpha: f64,
    kappa: f64,
    e: Pt,
    /// Per axis, e's range over the pixel, [e − μ/2, e + μ/2], from the pixel's edges
    /// ([`PixelAt`]): a pixel's edge is its neighbour's bit for bit, so the boxes of
    /// neighbouring pixels share their corners exactly ([`interior`]'s memo).
    span: [[f64; 2]; 2],
}

/// A pixel on the sensor: its centre s and its square's low and high edges, each edge
/// computed from its own index (so two neighbours' shared edge is one value, bit for bit).
#[derive(Clone, Copy)]
struct PixelAt {
    s: Pt,
    lo: Pt,
    hi: Pt,
}

impl PixelAt {
    /// Pixel (a, b) of a grid of mx × my pixels of pitch μ centred on the axis.
    fn on_grid(mu: f64, (a, b): (u32, u32), (mx, my): (u32, u32)) -> PixelAt {
        let edge = |i: u32, n: u32| mu * (i as f64 - n as f64 / 2.0);
        let centre = |i: u32, n: u32| mu * (i as f64 - (n as f64 - 1.0) / 2.0);
        PixelAt {
            s: [centre(a, mx), centre(b, my)],
            lo: [edge(a, mx), edge(b, my)],
            hi: [edge(a + 1, mx), edge(b + 1, my)],
        }
    }
}

/// The fewest raw rows a chunk of the general route gives each thread.
const ROWS_PER_THREAD: usize = 16;

/// A worker's buffers, holding its pool thread's corner memo ([`MemoShelf`]) while it lives.
struct Held<'a> {
    wk: Work,
    shelf: &'a MemoShelf,
}

impl Drop for Held<'_> {
    fn drop(&mut self) {
        self.shelf.put(std::mem::take(&mut self.wk.corners));
    }
}

/// The general route over one channel's raw, parallel over rows.
pub(super) fn general_channel(
    design: &Design,
    chan: &Chan,
    scene: &Scene,
    opts: RenderOptions,
    raw: &mut [f64],
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<()> {
    let (tol, own) = (opts.tol, opts.own_lens);
    let ch = chan.ch;
    let cols = raw_shape(ch).1;
    let per_row = (cols as u128) * 2000;
    let top = top_value(chan, scene);
    let rel = match opts.noise {
        Some(nt) => (nt.at(top) / top).clamp(super::MIN_TOL, 0.1),
        None => tol,
    };
    let table = match scene.surface.fronto() {
        Some(_) if opts.closed_form && !opts.falloff.is_on() => SatTable::of(&scene.texture)?,
        _ => None,
    };
    let px = Pixels {
        design,
        chan,
        scene,
        tol: lens_tol(chan, scene, tol),
        weighting: opts.falloff.is_on().then(|| Weighting {
            falloff: opts.falloff,
            step: piece_step(rel, uniform(scene)),
        }),
        sat: table.as_ref(),
    };
    // Rows differ in cost (the lenses' edges take the quadrature, their interiors the
    // closed form): a chunk of a few rows a thread leaves a thread idle at its end, so a
    // chunk holds at least ROWS_PER_THREAD rows a thread (a pixel checks for Ctrl-C itself).
    let threads = crate::infra::parallel::threads(n_threads);
    let step =
        crate::infra::parallel::chunk_items(n_threads, per_row).max(ROWS_PER_THREAD * threads);
    let shelf = MemoShelf::new(threads);
    fill_rows(
        raw,
        (chan.rows.clone(), cols),
        (n_threads, step),
        || {
            let mut wk = Work::new(scene.surface.fronto().is_some());
            wk.corners = shelf.take();
            Held { wk, shelf: &shelf }
        },
        |held, b, row| {
            let wk = &mut held.wk;
            checkpoint()?;
            let b = b as u32;
            for (a, out) in row.iter_mut().enumerate() {
                // A pixel can take milliseconds (depth maps): check for Ctrl-C per pixel.
                checkpoint()?;
                let value = |px: &Pixels, wk: &mut Work| {
                    if own {
                        own_lens_value(px, a as u32, b, wk)
                    } else {
                        pixel_value(px, a as u32, b, wk)
                    }
                };
                *out = match opts.noise {
                    None => value(&px, wk),
                    Some(nt) => noise_target_value(&px, (nt, top), |p| value(p, wk)),
                };
            }
            done.fetch_add(1, Ordering::Relaxed);
            Ok(())
        },
    )
}

/// Is every ray's albedo the same: a constant texture on a fronto-parallel plane (every
/// ray meets it), or over a background of the same albedo?
fn uniform(scene: &Scene) -> bool {
    match scene.texture {
        Texture::Constant(c) => scene.surface.fronto().is_some() || c == scene.background,
        _ => false,
    }
}

/// A pixel's value to the noise target `nt` (docs/render.md, "A target relative to the
/// noise"): first to the target of the brightest value a pixel can take (the loosest),
/// then, when the value v₁ found, less that target ε₁, allows a tighter one, again to
/// nt.at(v₁ − ε₁) — the target at the least value the pixel can have, so at most the
/// target at its true value. The targets are held in the range `tol` accepts.
/// `top` is [`top_value`] of the channel and scene.
fn noise_target_value(
    px: &Pixels,
    (nt, top): (NoiseTarget, f64),
    mut value: impl FnMut(&Pixels) -> f64,
) -> f64 {
    // The adaptive rule's estimate is not a bound: it is given half the target (at tight
    // targets its error came within 16 % over the whole one on the seed's half 2).
    let lens = |eps: f64| {
        let rel = (NOISE_TARGET_SHARE * eps / top).clamp(super::MIN_TOL, 0.1);
        Pixels {
            tol: rel * top / px.chan.norm,
            ..*px
        }
    };
    let eps1 = nt.at(top);
    let v1 = value(&lens(eps1));
    let eps2 = nt.at((v1 - eps1).max(0.0));
    if eps2 >= eps1 {
        return v1;
    }
    value(&lens(eps2))
}

/// The share of a noise target the adaptive rule is asked for ([`noise_target_value`]).
const NOISE_TARGET_SHARE: f64 = 0.5;

/// The value of a fully lit pixel under the scene's largest albedo (of the texture or the
/// background; 1 for a black scene): the scale `tol` is relative to.
pub(super) fn top_value(chan: &Chan, scene: &Scene) -> f64 {
    chan.norm * lens_tol(chan, scene, 1.0)
}

/// The adaptive rule's absolute target per lens (before the channel's norm) for an error
/// target `tol` relative to a fully lit pixel under the scene's largest albedo: tol × the
/// ray measure of a fully lit pixel, cell area × (μ L / v)², × that albedo (of the texture
/// or the background; 1 for a black scene). Relative to the scene, not to white: scaling
/// the albedo scales the raw and leaves the work unchanged (docs/render.md).
pub(super) fn lens_tol(chan: &Chan, scene: &Scene, tol: f64) -> f64 {
    let full = signed_area(&chan.cell) * (chan.ch.mu / chan.vl).powi(2);
    let scale = scene.texture.max_albedo().max(scene.background);
    let scale = if scale > 0.0 { scale } else { 1.0 };
    tol * full * scale
}

/// One pixel (column a, row b of the channel's raw).
pub(crate) fn pixel_value(px: &Pixels, a: u32, b: u32, wk: &mut Work) -> f64 {
    let chan = px.chan;
    let ch = chan.ch;
    match ch.layout {
        // The pixel sees its own lens alone.
        Layout::Ideal { .. } => own_lens_value(px, a, b, wk),
        Layout::Sensor { mx, my } => {
            let reach = chan.reach();
            let mu = ch.mu;
            let at = PixelAt::on_grid(mu, (a, b), (mx, my));
            let s = at.s;
            let (ks, js) = chan.lens_window(s, reach);
            let mut v = 0.0;
            for k in ks {
                for j in js.clone() {
                    let c = ch.lens_center(j, k);
                    let img = [chan.m * c[0], chan.m * c[1]];
                    if (s[0] - img[0]).abs() > reach[0] + mu
                        || (s[1] - img[1]).abs() > reach[1] + mu
                    {
                        continue;
                    }
                    v += lens_contribution(px, c, ch.lens_type(j, k), at, wk);
                }
            }
            chan.norm * v
        }
    }
}

/// One pixel's value through its own lens alone (the lens [`Design::pixel`] assigns it;
/// on the ideal layout that is the pixel's whole value, [`pixel_value`]).
fn own_lens_value(px: &Pixels, a: u32, b: u32, wk: &mut Work) -> f64 {
    let chan = px.chan;
    let ch = chan.ch;
    let p = px.design.pixel(ch, a, b);
    let c = ch.lens_center(p.j, p.k);
    // The pixel's sensor point: its lens image's centre plus its offset θ (both layouts).
    let at = match ch.layout {
        Layout::Sensor { mx, my } => PixelAt::on_grid(ch.mu, (a, b), (mx, my)),
        Layout::Ideal { q } => {
            // θ on the lens's q × q grid, shifted to the lens image's centre.
            let img = [chan.m * c[0], chan.m * c[1]];
            let on = PixelAt::on_grid(ch.mu, (a % q, b % q), (q, q));
            let at = |t: Pt| [img[0] + t[0], img[1] + t[1]];
            PixelAt {
                s: at(on.s),
                lo: at(on.lo),
                hi: at(on.hi),
            }
        }
    };
    chan.norm * lens_contribution(px, c, p.t, at, wk)
}

/// The contribution of one lens (centre c, type t) to the pixel at sensor point s_pix
/// (before the channel's norm).
fn lens_contribution(px: &Pixels, c: Pt, t: usize, at: PixelAt, wk: &mut Work) -> f64 {
    let chan = px.chan;
    let (alpha, kappa) = chan.types[t];
    let img = [chan.m * c[0], chan.m * c[1]];
    let e = [img[0] - at.s[0], img[1] - at.s[1]];
    let span = [
        [img[0] - at.hi[0], img[0] - at.lo[0]],
        [img[1] - at.hi[1], img[1] - at.lo[1]],
    ];
    if let Some(rec) = wk.rec.as_deref_mut() {
        // Record mode on a plane, or on a depth map every ray meets at most once: the
        // footprint density over the grid's cells.
        let surf = match &px.scene.surface {
            Surface::Plane { z0, g } => Some(footprint::Surf::Plane { z0: *z0, g: *g }),
            Surface::Map(m) if wk.map_once => Some(footprint::Surf::Map(m)),
            Surface::Map(_) => None,
        };
        if let Some(surf) = surf {
            footprint::record(chan, c, alpha, e, surf, rec, &mut wk.fp);
            return 0.0;
        }
    }
    let lens = LensView {
        c,
        alpha,
        kappa,
        e,
        span,
    };
    if chan.uses_outer_w(alpha) {
        outer_w(px, lens, wk)
    } else {
        outer_s(px, lens, wk)
    }
}

/// The lens as the closed form of its interior boxes sees it ([`interior`]), when it
/// applies: a summed-area table, a fronto-parallel plane, no weight, not recording.
fn closed_lens<'a>(px: &Pixels<'a>, lens: LensView, wk: &Work) -> Option<Lens<'a>> {
    let (sat, z) = (px.sat?, px.scene.surface.fronto()?);
    if px.weighting.is_some() || wk.rec.is_some() {
        return None;
    }
    let chan = px.chan;
    Some(Lens {
        chan,
        sat,
        c: lens.c,
        alpha: lens.alpha,
        e: lens.e,
        bb: 1.0 - z / chan.f_main + z / chan.ch.l,
        g: z / chan.ch.l,
    })
}

/// The cuts of a lens's outer box and what the quadrature needs to know of them: whether
/// the integrand is bilinear between them, and the reference plane's B = 1 − z/F + z/L
/// and g = z/L (P = B w − g (c + ξ) on it).
struct Cuts {
    cx: Vec<f64>,
    cy: Vec<f64>,
    bilinear: bool,
    bb: f64,
    g: f64,
}

/// Outer-w rule: ∫ over w of (area of the x-polygon × mean T over its scene image).
fn outer_w(px: &Pixels, lens: LensView, wk: &mut Work) -> f64 {
    let (chan, scene) = (px.chan, px.scene);
    let LensView { c, alpha, .. } = lens;
    let lv = 1.0 / chan.vl;
    let aa = alpha.abs();
    if let Some(r) = wk.rec.as_deref_mut() {
        r.outer = 1.0;
        r.jac = 1.0;
    }
    // w-range per axis.
    let range =
        |e: [f64; 2], h: f64| -> (f64, f64) { (lv * (e[0] - aa * h), lv * (e[1] + aa * h)) };
    let r = chan.r_ap;
    let (x0, x1) = range(lens.span[0], chan.hx);
    let (y0, y1) = range(lens.span[1], chan.hy);
    let (x0, x1, y0, y1) = (x0.max(-r), x1.min(r), y0.max(-r), y1.min(r));
    if !(x1 > x0 && y1 > y0) {
        return 0.0;
    }
    let bx = QBox::new(x0, x1, y0, y1);
    let closed_l = closed_lens(px, lens, wk);
    if let Some(cl) = &closed_l {
        let in_disc = chan.shape != Aperture::Circle
            || [x0, x1]
                .iter()
                .all(|&a| [y0, y1].iter().all(|&b| a * a + b * b <= r * r));
        // A box the aperture's circle cuts: its part inside the disc, the arcs by a 1-D rule.
        let disc = (!in_disc).then_some((r, px.tol));
        if let Some(v) = interior::outer_w_box(cl, bx, disc, wk) {
            return v;
        }
    }
    let Cuts {
        cx,
        cy,
        bilinear,
        bb,
        g,
    } = outer_w_cuts(px, lens, bx, wk);
    // A box is rough when a vertex of the polygon's scene image, moving over the box,
    // meets a discontinuity of the texture that no cut follows (a line through the
    // polygon's interior throughout leaves the integrand smooth).
    let slope = if alpha != 0.0 {
        bb.abs().max((bb - g * chan.vl / alpha).abs())
    } else {
        bb.abs()
    };
    let rough = |a0: f64, a1: f64, b0: f64, b1: f64, wk: &mut Work| {
        let w = [0.5 * (a0 + a1), 0.5 * (b0 + b1)];
        let m = [slope * 0.5 * (a1 - a0), slope * 0.5 * (b1 - b0)];
        poly_w(chan, lens, w, wk);
        vertex_meets_jump(scene, c, bb, g, m, |_| w, wk)
    };
    let total = if chan.shape != Aperture::Circle {
        let mut f = |wx: f64, wy: f64, wk: &mut Work| node_w(px, lens, [wx, wy], wk);
        let bilinear = bilinear && px.weighting.is_none();
        let closed = |b: QBox, wk: &mut Work| {
            closed_l
                .as_ref()
                .and_then(|l| interior::outer_w_box(l, b, None, wk))
        };
        over_boxes(&mut f, (&rough, &closed), (&cx, &cy), px.tol, bilinear, wk)
    } else {
        outer_w_disc(px, (lens, closed_l.as_ref()), bx, (&cx, &cy), &rough, wk)
    };
    wk.cuts_a = cx;
    wk.cuts_b = cy;
    total
}

/// The cuts of the outer-w box `bx`: where the pixel square or the aperture's edges
/// cross the cell's edges, and the texture's kinks (where the polygon's vertex lines cross
/// the texture's lines), at the reference depth of the box's centre.
fn outer_w_cuts(px: &Pixels, lens: LensView, bx: QBox, wk: &mut Work) -> Cuts {
    let (chan, scene, mu) = (px.chan, px.scene, px.chan.ch.mu);
    let LensView { c, alpha, e, .. } = lens;
    let QBox { x0, x1, y0, y1 } = bx;
    let lv = 1.0 / chan.vl;
    let aa = alpha.abs();
    let r = chan.r_ap;
    // The kinks of the integrand inside the w-range (in w units).
    let kinks = |e: f64, hs: &[f64]| -> Vec<f64> {
        let mut k = Vec::with_capacity(4 * hs.len());
        for &h in hs {
            for s1 in [-1.0, 1.0] {
                for s2 in [-1.0, 1.0] {
                    k.push(lv * (e + s1 * aa * h + s2 * mu / 2.0));
                }
            }
        }
        k
    };
    let mut kx = kinks(e[0], &[chan.hx]);
    let mut ky = kinks(e[1], &[chan.hy, chan.hy_side]);
    let circle = chan.shape == Aperture::Circle;
    if circle {
        for b in [y0, y1] {
            if b.abs() < r {
                let q = (r * r - b * b).sqrt();
                kx.extend([-q, q]);
            }
        }
    }
    // The texture's kinks: where the polygon's vertex lines cross the texture's lines.
    let z = reference_depth(chan, scene, c, [0.5 * (x0 + x1), 0.5 * (y0 + y1)]);
    let (l, bb) = (chan.ch.l, 1.0 - z / chan.f_main + z / chan.ch.l);
    let separable = chan.ch.grid == Grid::Rect;
    let mut complete = true;
    for (axis, (t0, t1)) in [(0, (x0, x1)), (1, (y0, y1))] {
        let mut moving: Vec<(f64, f64)> = chan
            .vertex_coords(axis)
            .iter()
            .map(|&xi| (bb, -z / l * (c[axis] + xi)))
            .collect();
        if alpha != 0.0 {
            let slope = bb - z / l * chan.vl / alpha;
            for sgn in [-1.0, 1.0] {
                moving.push((
                    slope,
                    -z / l * (c[axis] - e[axis] / alpha + sgn * mu / (2.0 * aa)),
                ));
            }
        }
        let half = if axis == 0 { chan.hx } else { chan.hy };
        let size = if alpha != 0.0 {
            (2.0 * half).min(mu / aa)
        } else {
            2.0 * half
        };
        let target = if axis == 0 { &mut kx } else { &mut ky };
        let sweep = Sweep {
            axis,
            extent: z / l * size,
            moving: &moving,
            span: (t0, t1),
        };
        complete &= texture_kinks(&scene.texture, &sweep, separable, wk.rec.is_some(), target);
        extent_kinks(scene, &sweep, target);
    }
    let (cx, cy) = box_cuts(wk, (x0, x1), (y0, y1), &kx, &ky);
    // The rect cell clipped by the pixel's square preimage: a product of intervals (a
    // circle's outer domain is parametrised by φ instead).
    let bilinear = bilinear(scene, separable && !circle, complete);
    Cuts {
        cx,
        cy,
        bilinear,
        bb,
        g: z / l,
    }
}

/// The outer-w rule on a circular aperture: w_x = r sin φ; per interval of w_x the
/// y-range is either the box's (then its cuts apply) or clipped by the circle (then w_y
/// runs over [ylo, yhi] as u ∈ [0, 1]). A box of the first kind maps to a rectangle of
/// w, which the closed form takes when the lens's `closed` view knows it.
fn outer_w_disc(
    px: &Pixels,
    (lens, closed_l): (LensView, Option<&Lens>),
    bx: QBox,
    (cx, cy): (&[f64], &[f64]),
    rough: &impl Fn(f64, f64, f64, f64, &mut Work) -> bool,
    wk: &mut Work,
) -> f64 {
    let (r, tol) = (px.chan.r_ap, px.tol);
    let QBox { x0, x1, y0, y1 } = bx;
    let width = x1 - x0;
    let mut sum = 0.0;
    for i in 1..cx.len() {
        let (a, b) = (cx[i - 1], cx[i]);
        let t = tol * (b - a) / width;
        let (pa, pb) = (
            (a / r).clamp(-1.0, 1.0).asin(),
            (b / r).clamp(-1.0, 1.0).asin(),
        );
        // Whether the circle cuts the strip's y-range anywhere in it: at its end farther from
        // the axis (its lowest height). The middle's height missed a cap at the circle's top
        // or bottom whose strip is centred on the axis: there q = r exactly, the box's edge
        // clipped to r, and the strip was taken as a full rectangle (1.5 × the cap).
        let far = a.abs().max(b.abs());
        let q = (r * r - far * far).max(0.0).sqrt();
        let clipped = -q > y0 || q < y1;
        if !clipped {
            let mut f = |p: f64, wy: f64, wk: &mut Work| {
                if let Some(rec) = wk.rec.as_deref_mut() {
                    rec.jac = r * p.cos();
                }
                r * p.cos() * node_w(px, lens, [r * p.sin(), wy], wk)
            };
            let rough_p = |p0: f64, p1: f64, b0: f64, b1: f64, wk: &mut Work| {
                let (a0, a1) = (r * p0.sin(), r * p1.sin());
                rough(a0.min(a1), a0.max(a1), b0, b1, wk)
            };
            let closed = |b: QBox, wk: &mut Work| {
                let w = QBox::new(r * b.x0.sin(), r * b.x1.sin(), b.y0, b.y1);
                closed_l.and_then(|l| interior::outer_w_box(l, w, None, wk))
            };
            sum += over_boxes(&mut f, (&rough_p, &closed), (&[pa, pb], cy), t, false, wk);
        } else {
            let mut f = |p: f64, u: f64, wk: &mut Work| {
                let wx = r * p.sin();
                let q = (r * r - wx * wx).max(0.0).sqrt();
                let (lo, hi) = (y0.max(-q), y1.min(q));
                if hi <= lo {
                    return 0.0;
                }
                let wy = lo + u * (hi - lo);
                if let Some(rec) = wk.rec.as_deref_mut() {
                    rec.jac = r * p.cos() * (hi - lo);
                }
                r * p.cos() * (hi - lo) * node_w(px, lens, [wx, wy], wk)
            };
            let rough_p = |p0: f64, p1: f64, _: f64, _: f64, wk: &mut Work| {
                let (a0, a1) = (r * p0.sin(), r * p1.sin());
                rough(a0.min(a1), a0.max(a1), y0, y1, wk)
            };
            let bx = QBox::new(pa, pb, 0.0, 1.0);
            sum += adaptive(&mut f, (&rough_p, &never), bx, t, 0, wk);
        }
    }
    sum
}

/// Whether a vertex ξ of the polygon `wk.poly`, its ray through main-lens point `w_of(ξ)`
/// meeting the reference plane at P = B w − g (c + ξ), can meet a discontinuity of the
/// texture while moving by at most `m` (per axis) over a quadrature box: a "rough" box.
fn vertex_meets_jump(
    scene: &Scene,
    c: Pt,
    bb: f64,
    g: f64,
    m: Pt,
    w_of: impl Fn(Pt) -> Pt,
    wk: &Work,
) -> bool {
    wk.poly.iter().any(|&xi| {
        let w = w_of(xi);
        let p = [
            bb * w[0] - g * (c[0] + xi[0]),
            bb * w[1] - g * (c[1] + xi[1]),
        ];
        scene
            .texture
            .jumps_in(p[0] - m[0], p[0] + m[0], p[1] - m[1], p[1] + m[1])
    })
}

/// The outer-w polygon at main-lens point w into `wk.poly` (cell coordinates ξ); its area.
fn poly_w(chan: &Chan, lens: LensView, w: Pt, wk: &mut Work) -> f64 {
    let (alpha, e, mu) = (lens.alpha, lens.e, chan.ch.mu);
    wk.poly.clear();
    wk.poly.extend_from_slice(&chan.cell);
    if alpha != 0.0 {
        // ξ ∈ ((v/L) w − e)/α ± μ/(2|α|).
        let g = [
            (chan.vl * w[0] - e[0]) / alpha,
            (chan.vl * w[1] - e[1]) / alpha,
        ];
        let h = mu / (2.0 * alpha.abs());
        clip_box(
            &mut wk.poly,
            &mut wk.tmp,
            g[0] - h,
            g[0] + h,
            g[1] - h,
            g[1] + h,
        );
    }
    signed_area(&wk.poly)
}

/// The outer-w integrand at main-lens point w.
fn node_w(px: &Pixels, lens: LensView, w: Pt, wk: &mut Work) -> f64 {
    let area = poly_w(px.chan, lens, w, wk);
    if area <= 0.0 {
        return 0.0;
    }
    if let Some(wt) = &px.weighting {
        // s − x = (α − 1)(c + ξ) − (v/L) w + κ c, x − w = c + ξ − w.
        let (c, am) = (lens.c, lens.alpha - 1.0);
        let seg = Segments {
            a_m: am,
            b_m: [
                (am + lens.kappa) * c[0] - px.chan.vl * w[0],
                (am + lens.kappa) * c[1] - px.chan.vl * w[1],
            ],
            a_main: 1.0,
            b_main: [c[0] - w[0], c[1] - w[1]],
        };
        return weighted_integral((px.chan, px.scene, wt), &seg, c, |_| w, wk);
    }
    area * scene_mean(px.chan, px.scene, lens.c, |_| w, wk)
}

/// Outer-s rule: ∫ over the sensor point s in the pixel (and in the lens's reach).
fn outer_s(px: &Pixels, lens: LensView, wk: &mut Work) -> f64 {
    let (chan, scene, tol) = (px.chan, px.scene, px.tol);
    let LensView { c, alpha, .. } = lens;
    // Offsets σ = s − img (img = (1 + v/L) c): the pixel is σ ∈ −e ± μ/2; the lens's
    // light reaches |σ| ≤ |α| h + (v/L) r_ap per axis.
    let aa = alpha.abs();
    if let Some(r) = wk.rec.as_deref_mut() {
        r.outer = (1.0 / chan.vl).powi(2);
        r.jac = 1.0;
    }
    let rho = chan.vl * chan.r_ap; // (v/L) r_ap; the preimage radius is rho / |α|
    let reach = [aa * chan.hx + rho, aa * chan.hy + rho];
    let span = lens.span;
    let (x0, x1) = ((-span[0][1]).max(-reach[0]), (-span[0][0]).min(reach[0]));
    let (y0, y1) = ((-span[1][1]).max(-reach[1]), (-span[1][0]).min(reach[1]));
    if !(x1 > x0 && y1 > y0) {
        return 0.0;
    }
    let lv = 1.0 / chan.vl;
    let closed_l = closed_lens(px, lens, wk);
    if let Some(cl) = &closed_l {
        if let Some(v) = interior::outer_s_box(cl, QBox::new(x0, x1, y0, y1), wk) {
            return v * lv * lv;
        }
    }
    let kinks = |hs: &[f64]| -> Vec<f64> {
        let mut k = Vec::new();
        if chan.shape == Aperture::Square {
            for &h in hs {
                for s1 in [-1.0, 1.0] {
                    for s2 in [-1.0, 1.0] {
                        k.push(s1 * (aa * h + s2 * rho));
                    }
                }
            }
        }
        k
    };
    let mut kx = kinks(&[chan.hx]);
    let mut ky = kinks(&[chan.hy, chan.hy_side]);
    // The texture's kinks (see outer_w), in σ = s − img.
    let z = reference_depth(chan, scene, c, [0.0, 0.0]);
    let (l, bb) = (chan.ch.l, 1.0 - z / chan.f_main + z / chan.ch.l);
    let lvb = bb / chan.vl;
    let separable = chan.ch.grid == Grid::Rect && chan.shape == Aperture::Square;
    let mut complete = true;
    for (axis, (t0, t1)) in [(0, (x0, x1)), (1, (y0, y1))] {
        let mut moving: Vec<(f64, f64)> = chan
            .vertex_coords(axis)
            .iter()
            .map(|&xi| (-lvb, lvb * alpha * xi - z / l * (c[axis] + xi)))
            .collect();
        for sgn in [-1.0, 1.0] {
            let icpt = sgn * (bb * chan.r_ap * alpha.signum() - z / l * rho / aa) - z / l * c[axis];
            moving.push((-z / l / alpha, icpt));
        }
        let half = if axis == 0 { chan.hx } else { chan.hy };
        let size = (lvb * alpha - z / l).abs() * 2.0 * half;
        let target = if axis == 0 { &mut kx } else { &mut ky };
        let sweep = Sweep {
            axis,
            extent: size,
            moving: &moving,
            span: (t0, t1),
        };
        complete &= texture_kinks(&scene.texture, &sweep, separable, wk.rec.is_some(), target);
        extent_kinks(scene, &sweep, target);
    }
    let (cx, cy) = box_cuts(wk, (x0, x1), (y0, y1), &kx, &ky);
    // The rect cell clipped by the square aperture's preimage: a product of intervals.
    // (A weight makes the integrand smooth, not bilinear.)
    let bilinear = bilinear(scene, separable, complete) && px.weighting.is_none();
    let mut f = |sx: f64, sy: f64, wk: &mut Work| node_s(px, lens, [sx, sy], wk);
    // Rough boxes (see outer_w): P = B w(ξ) − (z/L)(c + ξ), w(ξ) = (L/v)(α ξ − σ); a vertex
    // of the cell moves by −B (L/v) per unit σ, one of the aperture's preimage by −(z/L)/α.
    let g = z / l;
    let slope = lvb.abs().max(g / aa);
    let rough = |a0: f64, a1: f64, b0: f64, b1: f64, wk: &mut Work| {
        let sg = [0.5 * (a0 + a1), 0.5 * (b0 + b1)];
        let m = [slope * 0.5 * (a1 - a0), slope * 0.5 * (b1 - b0)];
        poly_s(chan, alpha, sg, wk);
        let w_of = |xi: Pt| [lv * (alpha * xi[0] - sg[0]), lv * (alpha * xi[1] - sg[1])];
        vertex_meets_jump(scene, c, bb, g, m, w_of, wk)
    };
    let closed = |b: QBox, wk: &mut Work| {
        closed_l
            .as_ref()
            .and_then(|l| interior::outer_s_box(l, b, wk))
    };
    let hooks = (&rough, &closed);
    let total = over_boxes(&mut f, hooks, (&cx, &cy), tol / (lv * lv), bilinear, wk);
    wk.cuts_a = cx;
    wk.cuts_b = cy;
    total * lv * lv
}

/// The outer-s polygon at sensor offset σ into `wk.poly` (cell coordinates ξ): the cell
/// clipped by the aperture's preimage ξ ∈ σ/α + (ρ/|α|) · unit aperture; its area.
fn poly_s(chan: &Chan, alpha: f64, sigma: Pt, wk: &mut Work) -> f64 {
    let rho = chan.vl * chan.r_ap;
    let g = [sigma[0] / alpha, sigma[1] / alpha];
    let rad = rho / alpha.abs();
    wk.poly.clear();
    wk.poly.extend_from_slice(&chan.cell);
    match chan.shape {
        Aperture::Square => clip_box(
            &mut wk.poly,
            &mut wk.tmp,
            g[0] - rad,
            g[0] + rad,
            g[1] - rad,
            g[1] + rad,
        ),
        Aperture::Circle => clip_disc(&chan.ngon, g, rad, wk),
    }
    signed_area(&wk.poly)
}

/// The outer-s integrand at sensor offset σ = s − img.
fn node_s(px: &Pixels, lens: LensView, sigma: Pt, wk: &mut Work) -> f64 {
    let (chan, alpha) = (px.chan, lens.alpha);
    let lv = 1.0 / chan.vl;
    let area = poly_s(chan, alpha, sigma, wk);
    if area <= 0.0 {
        return 0.0;
    }
    // w(ξ) = (L/v)(α ξ − σ) (from s = α x − (v/L) w + κ c, x = c + ξ).
    let wfun = |xi: Pt| {
        [
            lv * (alpha * xi[0] - sigma[0]),
            lv * (alpha * xi[1] - sigma[1]),
        ]
    };
    if let Some(wt) = &px.weighting {
        // s − x = (v/L) c + σ − ξ, x − w = (1 − (L/v) α) ξ + c + (L/v) σ.
        let c = lens.c;
        let seg = Segments {
            a_m: -1.0,
            b_m: [chan.vl * c[0] + sigma[0], chan.vl * c[1] + sigma[1]],
            a_main: 1.0 - lv * alpha,
            b_main: [c[0] + lv * sigma[0], c[1] + lv * sigma[1]],
        };
        return weighted_integral((chan, px.scene, wt), &seg, c, wfun, wk);
    }
    area * scene_mean(chan, px.scene, lens.c, wfun, wk)
}

/// The depth that the kinks of a lens's quadrature are placed for: the plane's depth, or
/// where the ray through the lens centre and main-lens point `w` meets the surface (the
/// surface's mean depth when it misses).
fn reference_depth(chan: &Chan, scene: &Scene, c: Pt, w: Pt) -> f64 {
    if let Some(z) = scene.surface.fronto() {
        return z;
    }
    let (f, l) = (chan.f_main, chan.ch.l);
    let a = [w[0] / f + (c[0] - w[0]) / l, w[1] / f + (c[1] - w[1]) / l];
    match scene.surface.hit(w, a) {
        Some((z, _)) => z,
        None => match &scene.surface {
            Surface::Plane { z0, .. } => *z0,
            Surface::Map(m) => 0.5 * (m.zmin + m.zmax),
        },
    }
}

/// Clip `wk.poly` by the disc (centre g, radius rad) as the equal-area polygon `ngon`.
fn clip_disc(ngon: &[Pt], g: Pt, rad: f64, wk: &mut Work) {
    // Quick accept: every vertex inside the inscribed circle of the polygon.
    let inscribed = rad * ngon[0][0] * (PI / ngon.len() as f64).cos();
    let inside = wk.poly.iter().all(|p| {
        let (dx, dy) = (p[0] - g[0], p[1] - g[1]);
        dx * dx + dy * dy <= inscribed * inscribed
    });
    if inside {
        return;
    }
    let n = ngon.len();
    let step = 2.0 * PI / n as f64;
    // The n-gon edges that can cut the polygon: those facing its vertices' directions.
    let (bx0, bx1, by0, by1) = bounds(&wk.poly);
    let centre_inside = g[0] >= bx0 && g[0] <= bx1 && g[1] >= by0 && g[1] <= by1;
    let (i0, i1) = if centre_inside {
        (0i64, n as i64 - 1)
    } else {
        let (lo, hi) = angular_span(&wk.poly, g);
        (
            (lo / step).floor() as i64 - 1,
            (hi / step).ceil() as i64 + 1,
        )
    };
    for k in i0..=i1 {
        let i = k.rem_euclid(n as i64) as usize;
        let (a, b) = (ngon[i], ngon[(i + 1) % n]);
        let (ax, ay) = (g[0] + rad * a[0], g[1] + rad * a[1]);
        let (ex, ey) = (rad * (b[0] - a[0]), rad * (b[1] - a[1]));
        clip_into(&wk.poly, &mut wk.tmp, |p| {
            ex * (p[1] - ay) - ey * (p[0] - ax)
        });
        std::mem::swap(&mut wk.poly, &mut wk.tmp);
        if wk.poly.is_empty() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The general route's target is relative to the scene's largest albedo: a sinusoid
    /// on a tilted plane scaled by 50 renders 50 × the raw (to 50 × tol of its white) with
    /// the same number of integrand evaluations (before: relative to white, the scaled
    /// scene's target was 50 × tighter and its work grew).
    #[test]
    fn scaling_the_albedo_scales_the_raw_not_the_work() {
        let design = crate::model::presets::preset("seed").unwrap();
        let ch = &design.channels[0];
        let chan = Chan::new(&design, ch, 1e-3);
        let scene = |k: f64| {
            let tex = Texture::Sinusoid {
                frequency: 0.8,
                mean: 0.5 * k,
                amplitude: 0.4 * k,
                phase: 0.3,
            };
            let surf = Surface::Plane {
                z0: 1000.0,
                g: [0.2, -0.1],
            };
            Scene::new(tex, surf, 0.5 * k).unwrap()
        };
        let (s1, s50) = (scene(1.0), scene(50.0));
        let run = |sc: &Scene| {
            let px = Pixels {
                design: &design,
                chan: &chan,
                scene: sc,
                tol: lens_tol(&chan, sc, 1e-3),
                weighting: None,
                sat: None,
            };
            let mut wk = Work::new(false);
            let v: Vec<f64> = (0..40u32)
                .map(|i| pixel_value(&px, 300 + 7 * i, 200 + 3 * i, &mut wk))
                .collect();
            (v, wk.evals)
        };
        let ((v1, n1), (v50, n50)) = (run(&s1), run(&s50));
        assert!(n1 > 0);
        assert_eq!(n1, n50, "work units");
        // White is 1/2 on the seed's fully lit pixels; tol 1e-3 of the scene's max (0.9 k).
        for (a, b) in v1.iter().zip(&v50) {
            assert!((b - 50.0 * a).abs() <= 50.0 * 1e-3 * 0.9 * 0.5, "{a} {b}");
        }
    }
}
