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
//! 1-D polygons between the cell's edges — no quadrature error.

use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::{Scratch, Texture};
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::{checkpoint, for_chunks};
use crate::infra::polygon::{angular_span, bounds, clip_box, clip_into, signed_area, Pt};
use crate::model::design::{Aperture, Channel, Design, Grid, Layout};

/// Record mode on a plane: the footprint density integrated over the grid's cells.
pub(crate) mod footprint;

/// Fewest and most sides of the equal-area polygon that stands for a circular aperture.
pub const MIN_CIRCLE_SIDES: usize = 32;
pub const MAX_CIRCLE_SIDES: usize = 1024;

/// Sides of the equal-area polygon for a circular aperture at tolerance `tol`: the area
/// between a disc and its equal-area n-gon is about 2.5/n² of the disc (measured: 1.1e-3 at
/// n = 48, 1.5e-4 at 128, 3.9e-5 at 256), a bound on the error it makes in any pixel as a
/// fraction of white; n keeps it below tol/4, leaving the rest to the quadrature.
pub fn circle_sides(tol: f64) -> usize {
    let n = (2.5 / (0.25 * tol)).sqrt().ceil();
    (n as usize).clamp(MIN_CIRCLE_SIDES, MAX_CIRCLE_SIDES)
}
/// Default error target of a pixel, relative to a fully lit pixel under a white albedo.
pub const DEFAULT_TOL: f64 = 1e-3;
/// Smallest error target accepted (the quadrature's own limit is far below).
pub const MIN_TOL: f64 = 1e-10;
/// Relative depth variation across one mapped piece of a polygon on a curved or slanted
/// surface (the map to the scene is treated as affine within a piece).
const PIECE_DEPTH_RTOL: f64 = 2e-4;
/// Most pieces per axis a polygon is cut into.
const MAX_PIECES: usize = 24;
/// On a plane: the relative depth span of one strip of a polygon (along the depth's level
/// lines), where the ray map's density is treated as constant (it varies as the cube of
/// depth: an error of at most about 1.5 × this × the albedo's range within the strip).
const STRIP_DEPTH_RTOL: f64 = 5e-4;
/// Most strips a polygon is cut into.
const MAX_STRIPS: usize = 64;
/// Relative accuracy assumed of one evaluation of the integrand on a slanted plane or a
/// depth map (its pieces' count changes with the node, so it is not smooth at that level):
/// the adaptive rule accepts a box when its two rules agree to tol plus this fraction of
/// the box's value, instead of chasing those steps to the deepest level.
const PIECE_NOISE: f64 = 2e-4;

/// Options of a render.
#[derive(Debug, Clone, Copy)]
pub struct RenderOptions {
    /// Error target of the general route's adaptive quadrature per pixel and lens,
    /// relative to a fully lit pixel under a white albedo.
    pub tol: f64,
    /// Each pixel takes the light of its own lens alone (the lens [`Design::pixel`]
    /// assigns it), not what its neighbours' lenses send it on a sensor layout: the depth
    /// sweep's test of which pixels sample one footprint (docs/depth.md). On the ideal
    /// layout a pixel sees its own lens only either way.
    pub own_lens: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            tol: DEFAULT_TOL,
            own_lens: false,
        }
    }
}

/// One channel as the renderer sees it.
pub(crate) struct Chan<'a> {
    pub(crate) ch: &'a Channel,
    pub(crate) f_main: f64,
    /// Aperture half-width (square) or radius (circle).
    pub(crate) r_ap: f64,
    pub(crate) shape: Aperture,
    /// share (L_1/L)² / (μ_1² A).
    pub(crate) norm: f64,
    /// (α, κ = v/f) per lens type.
    pub(crate) types: Vec<(f64, f64)>,
    /// The lens cell around its centre (counter-clockwise).
    pub(crate) cell: Vec<Pt>,
    /// Half-extents of the cell's bounding box; the y of the hex's side vertices.
    pub(crate) hx: f64,
    pub(crate) hy: f64,
    hy_side: f64,
    /// The unit circle as an equal-area polygon (circle apertures).
    pub(crate) ngon: Vec<Pt>,
    /// Lens image centre magnification 1 + v/L.
    m: f64,
    /// v/L.
    pub(crate) vl: f64,
}

impl<'a> Chan<'a> {
    pub(crate) fn new(design: &'a Design, ch: &'a Channel, tol: f64) -> Chan<'a> {
        let l1 = design.channels[0].l;
        let mu1 = design.channels[0].mu;
        let r_ap = design.aperture / 2.0;
        let area = match design.shape {
            Aperture::Square => design.aperture * design.aperture,
            Aperture::Circle => PI * r_ap * r_ap,
        };
        let norm = ch.share * (l1 / ch.l).powi(2) / (mu1 * mu1 * area);
        let types =
            ch.f.iter()
                .map(|&f| (1.0 + ch.v / ch.l - ch.v / f, ch.v / f))
                .collect();
        let d = ch.d;
        let (cell, hx, hy, hy_side) = match ch.grid {
            Grid::Rect => {
                let h = d / 2.0;
                (vec![[-h, -h], [h, -h], [h, h], [-h, h]], h, h, h)
            }
            Grid::Hex => {
                let (a, b) = (d / 2.0, d / 3f64.sqrt());
                let side = b / 2.0;
                (
                    vec![
                        [0.0, -b],
                        [a, -side],
                        [a, side],
                        [0.0, b],
                        [-a, side],
                        [-a, -side],
                    ],
                    a,
                    b,
                    side,
                )
            }
        };
        let sides = circle_sides(tol);
        let n = sides as f64;
        let scale = (2.0 * PI / (n * (2.0 * PI / n).sin())).sqrt();
        let ngon = (0..sides)
            .map(|i| {
                let t = 2.0 * PI * i as f64 / n;
                [scale * t.cos(), scale * t.sin()]
            })
            .collect();
        Chan {
            ch,
            f_main: design.f_main,
            r_ap,
            shape: design.shape,
            norm,
            types,
            cell,
            hx,
            hy,
            hy_side,
            ngon,
            m: ch.magnification(),
            vl: ch.v / ch.l,
        }
    }

    /// Largest reach of a lens's light from its image centre on the sensor, per axis.
    pub(crate) fn reach(&self) -> [f64; 2] {
        let amax = self.types.iter().map(|t| t.0.abs()).fold(0.0, f64::max);
        let ap = self.vl * self.r_ap;
        [amax * self.hx + ap, amax * self.hy + ap]
    }

    /// The lenses (rows k, columns j) whose light can reach the sensor point s (sensor
    /// layout): those around the nearest lens within `reach` (per axis) of their images.
    pub(crate) fn lens_window(
        &self,
        s: Pt,
        reach: [f64; 2],
    ) -> (std::ops::RangeInclusive<u32>, std::ops::RangeInclusive<u32>) {
        let ch = self.ch;
        let (j0, k0) = ch.nearest_lens(s);
        let p = ch.image_pitch();
        let row = match ch.grid {
            Grid::Rect => p,
            Grid::Hex => p * 3f64.sqrt() / 2.0,
        };
        let dj = (reach[0] / p).ceil() as i64 + 1;
        let dk = (reach[1] / row).ceil() as i64 + 1;
        let span = |c: u32, d: i64, n: u32| {
            let lo = (c as i64 - d).max(0) as u32;
            let hi = (c as i64 + d).min(n as i64 - 1).max(0) as u32;
            lo..=hi
        };
        (span(k0, dk, ch.ky), span(j0, dj, ch.kx))
    }

    /// The coordinates along `axis` of the cell's vertices (relative to its centre).
    fn vertex_coords(&self, axis: usize) -> Vec<f64> {
        let mut v: Vec<f64> = self.cell.iter().map(|p| p[axis]).collect();
        v.sort_by(|a, b| a.total_cmp(b));
        v.dedup();
        v
    }

    /// The half-side of a box holding the main lens's aperture (a disc's: its polygon's).
    pub(crate) fn aperture_box(&self) -> f64 {
        match self.shape {
            Aperture::Square => self.r_ap,
            Aperture::Circle => self.r_ap * self.ngon[0][0],
        }
    }

    /// Does the type's α call for the outer-w rule (its cell's image narrower than a pixel)?
    fn outer_w(&self, alpha: f64) -> bool {
        alpha.abs() * 2.0 * self.hx < self.ch.mu
    }
}

/// Per-worker buffers.
#[derive(Default)]
pub(crate) struct Work {
    /// Relative accuracy of one evaluation of the integrand (0: exact; see `PIECE_NOISE`).
    rel_floor: f64,
    /// When set, the integration records each grid cell's share of the pixel's rays
    /// instead of averaging the texture (the map of docs/model.md §11; see
    /// [`crate::imaging::recorder::Recorder`]), and the adaptive rule is a fixed one ([`fixed_rule`]).
    pub(crate) rec: Option<Box<crate::imaging::recorder::Recorder>>,
    tex: Scratch,
    poly: Vec<Pt>,
    tmp: Vec<Pt>,
    piece: Vec<Pt>,
    mapped: Vec<Pt>,
    cuts_a: Vec<f64>,
    cuts_b: Vec<f64>,
    zs: Vec<f64>,
    /// Record mode on a plane: [`footprint`]'s buffers.
    fp: footprint::Scratch,
    /// Record mode on a depth map: every ray meets it at most once
    /// ([`crate::imaging::scene::DepthMap::seen_once`]), so [`footprint`] records it too.
    map_once: bool,
}

impl Work {
    /// A worker that averages the texture (`fronto`: the surface is a fronto-parallel plane).
    fn new(fronto: bool) -> Work {
        Work {
            rel_floor: if fronto { 0.0 } else { PIECE_NOISE },
            ..Work::default()
        }
    }

    /// A worker in record mode. On a plane, and on a depth map that every ray meets at
    /// most once (`map_once`: [`map_seen_once`]), the record is [`footprint`]'s, which has
    /// rules of its own; on another depth map (never fronto-parallel) it is the render's
    /// own integral's, which takes first hits.
    pub(crate) fn recording(rec: Box<crate::imaging::recorder::Recorder>, map_once: bool) -> Work {
        Work {
            rec: Some(rec),
            map_once,
            ..Work::new(false)
        }
    }
}

/// Is `surface` a depth map that every ray through the main lens of `chan` meets at most
/// once ([`crate::imaging::scene::DepthMap::seen_once`])? Checked once per map, not per worker.
pub(crate) fn map_seen_once(chan: &Chan, surface: &Surface) -> bool {
    matches!(surface, Surface::Map(m) if m.seen_once(chan.aperture_box()))
}

/// The lines along one axis (0: X, 1: Y) where a texture's albedo jumps, as (origin,
/// spacing, first, last index): an image's cell edges, a bar chart's bar edges.
fn texture_lines(t: &Texture, axis: usize) -> Option<(f64, f64, i64, i64)> {
    match t {
        Texture::Image(im) => {
            let (x0, x1, y0, y1) = im.extent();
            let (rows, cols) = im.shape();
            Some(if axis == 0 {
                (x0, (x1 - x0) / cols as f64, 0, cols as i64)
            } else {
                (y0, (y1 - y0) / rows as f64, 0, rows as i64)
            })
        }
        Texture::Bars { frequency, .. } if axis == 0 => {
            Some((0.0, 0.5 / frequency, i64::MIN / 4, i64::MAX / 4))
        }
        _ => None,
    }
}

/// Largest scene image of a pixel's polygon, in texture cells, whose kinks count as
/// strong (cut at, up to [`MAX_KINKS`]).
const KINK_CELLS: f64 = 4.0;
/// Texture kinks always cut on one axis, however wide the polygon's scene image.
const FEW_KINKS: usize = 8;
/// Most texture kinks added to one axis's cuts.
const MAX_KINKS: usize = 40;
/// Beyond the kinks cut at, the interval is split uniformly so that no vertex of the
/// polygon's scene image moves over more than this many texture cells in one part ...
const MOTION_CELLS: f64 = 4.0;
/// ... in at most this many parts.
const MAX_SPLITS: usize = 16;
/// The same two when a map is recorded: each cell's weight (not only their sum, the
/// texture's average) must come out right, so the parts are shorter.
const RECORD_MOTION_CELLS: f64 = 1.0;
const RECORD_SPLITS: usize = 48;

/// Add to `out` the values of the outer variable t in [t0, t1] where a moving line
/// P = slope t + intercept of the polygon crosses one of the texture's lines along `axis`
/// (`extent`: the width of the polygon's scene image). When they are too many, `out` gets
/// uniform splits instead. True when the cuts are every kink (or the texture has none).
#[allow(clippy::too_many_arguments)]
fn texture_kinks(
    texture: &Texture,
    axis: usize,
    extent: f64,
    moving: &[(f64, f64)],
    (t0, t1): (f64, f64),
    separable: bool,
    record: bool,
    out: &mut Vec<f64>,
) -> bool {
    let Some((o, h, first, last)) = texture_lines(texture, axis) else {
        return true;
    };
    // The integrand has a kink wherever a vertex line crosses a texture line, of slope
    // jump ~ contrast / (image width in cells). Kinks are cut at when they are few, or
    // when strong (images of a few cells) and not too many. Otherwise the integrand
    // varies on the scale of one cell of motion: the 2- and 3-point rules, comparing
    // each other on a box over which it moves many cells, can agree by chance and both
    // be wrong (measured against the exact route: 1.6e-2 of white on the seed's half 2 at
    // 800 mm, a 7-cell image moving 40 cells over the box; 3.8e-3 on half 1 at 1000 mm,
    // 12 cells moving 6). So the interval is split into parts of at most MOTION_CELLS
    // cells of motion (more for wide images) before the adaptive rule starts.
    // With a `separable` polygon (rect cell, square aperture: the polygon is a product of
    // intervals) every kink crossing is cut at up to MAX_KINKS: on a fronto-parallel plane
    // the integrand is then bilinear between cuts, and exact; hex cells and discs move
    // their vertices obliquely, so that cuts per axis cannot follow them anyway.
    let weak = extent > KINK_CELLS * h;
    let start = out.len();
    let mut count = 0usize;
    let mut motion = 0.0f64;
    for &(slope, icpt) in moving {
        if slope == 0.0 || !slope.is_finite() {
            continue;
        }
        let (pa, pb) = (slope * t0 + icpt, slope * t1 + icpt);
        let (lo, hi) = if pa < pb { (pa, pb) } else { (pb, pa) };
        let i0 = (((lo - o) / h).ceil() as i64).max(first);
        let i1 = (((hi - o) / h).floor() as i64).min(last);
        if i1 < i0 {
            continue;
        }
        // Motion over the texture's own lines only (outside it the albedo is constant).
        let (a, b) = (lo.max(o + first as f64 * h), hi.min(o + last as f64 * h));
        motion = motion.max((b - a) / h);
        count += (i1 - i0 + 1) as usize;
        if count <= MAX_KINKS {
            for i in i0..=i1 {
                out.push((o + i as f64 * h - icpt) / slope);
            }
        }
    }
    if count <= FEW_KINKS || ((!weak || separable) && count <= MAX_KINKS) {
        return true;
    }
    out.truncate(start);
    let (cells, most) = if record {
        (RECORD_MOTION_CELLS, RECORD_SPLITS)
    } else {
        (MOTION_CELLS, MAX_SPLITS)
    };
    let per_part = cells * (extent / h / KINK_CELLS).max(1.0).sqrt();
    let n = ((motion / per_part).ceil() as usize).clamp(1, most);
    for k in 1..n {
        out.push(t0 + (t1 - t0) * k as f64 / n as f64);
    }
    false
}

/// Is the outer integrand bilinear between the cuts? So it is when the polygon is a product
/// of intervals with linearly moving ends (`separable`), the cuts hold every texture kink
/// (`complete`), the plane is fronto-parallel (the map to the scene is affine) and the
/// texture is constant between its lines ([`texture_lines`]).
fn bilinear(scene: &Scene, separable: bool, complete: bool) -> bool {
    separable
        && complete
        && scene.surface.fronto().is_some()
        && matches!(
            scene.texture,
            Texture::Image(_) | Texture::Bars { .. } | Texture::Constant(_)
        )
}

/// The cuts of a lens's outer box [x0, x1] × [y0, y1] from its candidate breakpoints per
/// axis (in `wk`'s buffers: hand them back with `wk.cuts_a = cx; wk.cuts_b = cy`).
fn box_cuts(
    wk: &mut Work,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    kx: &[f64],
    ky: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let mut cx = std::mem::take(&mut wk.cuts_a);
    let mut cy = std::mem::take(&mut wk.cuts_b);
    intervals(x0, x1, kx, &mut cx);
    intervals(y0, y1, ky, &mut cy);
    (cx, cy)
}

/// Sorted unique cuts of [lo, hi] (including both ends) from candidate breakpoints.
fn intervals(lo: f64, hi: f64, cands: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.push(lo);
    let tol = 1e-12 * (hi - lo).abs().max(f64::MIN_POSITIVE);
    let mut c: Vec<f64> = cands
        .iter()
        .copied()
        .filter(|&b| b > lo + tol && b < hi - tol)
        .collect();
    c.sort_by(|a, b| a.total_cmp(b));
    for b in c {
        if b > *out.last().unwrap_or(&lo) + tol {
            out.push(b);
        }
    }
    out.push(hi);
}

/// The contribution of one lens (centre c, type t) to the pixel at sensor point s_pix
/// (before the channel's norm).
fn lens_contribution(
    chan: &Chan,
    scene: &Scene,
    tol: f64,
    c: Pt,
    t: usize,
    s_pix: Pt,
    wk: &mut Work,
) -> f64 {
    let (alpha, _) = chan.types[t];
    let mu = chan.ch.mu;
    let e = [chan.m * c[0] - s_pix[0], chan.m * c[1] - s_pix[1]];
    if let Some(rec) = wk.rec.as_deref_mut() {
        // Record mode on a plane, or on a depth map every ray meets at most once: the
        // footprint density over the grid's cells.
        let surf = match &scene.surface {
            Surface::Plane { z0, g } => Some(footprint::Surf::Plane { z0: *z0, g: *g }),
            Surface::Map(m) if wk.map_once => Some(footprint::Surf::Map(m)),
            Surface::Map(_) => None,
        };
        if let Some(surf) = surf {
            footprint::record(chan, c, alpha, e, surf, rec, &mut wk.fp);
            return 0.0;
        }
    }
    if chan.outer_w(alpha) {
        outer_w(chan, scene, tol, c, alpha, e, mu, wk)
    } else {
        outer_s(chan, scene, tol, c, alpha, e, mu, wk)
    }
}

/// 2-D adaptive quadrature on the box [x0, x1] × [y0, y1]: the 3 × 3 Gauss–Legendre rule,
/// accepted when it differs from the 2 × 2 rule by at most `tol`; otherwise the box is cut
/// in four (at most [`MAX_DEPTH`] times), each quarter with a quarter of the tolerance. Both
/// rules are exact for bicubic integrands, so on boxes between the known kinks of a
/// constant or piecewise constant texture the first test already passes.
#[allow(clippy::too_many_arguments)]
fn adaptive(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    rough: &impl Fn(f64, f64, f64, f64, &mut Work) -> bool,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    tol: f64,
    depth: u32,
    wk: &mut Work,
) -> f64 {
    let (xm, xh, ym, yh) = (
        0.5 * (x0 + x1),
        0.5 * (x1 - x0),
        0.5 * (y0 + y1),
        0.5 * (y1 - y0),
    );
    if wk.rec.is_some() {
        fixed_rule(f, x0, x1, y0, y1, wk);
        return 0.0;
    }
    let area = 4.0 * xh * yh;
    let t = 0.25 * tol;
    if depth < ROUGH_DEPTH && rough(x0, x1, y0, y1, wk) {
        // A texture discontinuity sweeps through the box: the rules cannot see it.
        return adaptive(f, rough, x0, xm, y0, ym, t, depth + 1, wk)
            + adaptive(f, rough, xm, x1, y0, ym, t, depth + 1, wk)
            + adaptive(f, rough, x0, xm, ym, y1, t, depth + 1, wk)
            + adaptive(f, rough, xm, x1, ym, y1, t, depth + 1, wk);
    }
    // 2 × 2 and 3 × 3 Gauss–Legendre: the difference bounds the 2-point rule's error
    // and, far more pessimistically, the 3-point rule's, which is returned.
    let g1 = area * gauss(G2, f, xm, xh, ym, yh, wk);
    let g2 = area * gauss(G3, f, xm, xh, ym, yh, wk);
    if (g2 - g1).abs() <= tol + wk.rel_floor * g2.abs() || depth >= MAX_DEPTH {
        return g2;
    }
    adaptive(f, rough, x0, xm, y0, ym, t, depth + 1, wk)
        + adaptive(f, rough, xm, x1, y0, ym, t, depth + 1, wk)
        + adaptive(f, rough, x0, xm, ym, y1, t, depth + 1, wk)
        + adaptive(f, rough, xm, x1, ym, y1, t, depth + 1, wk)
}

/// A Gauss–Legendre rule on [-1, 1]: nodes and weights (the weights sum to 1, the mean).
type Rule = (&'static [f64], &'static [f64]);
/// 2-point Gauss–Legendre (exact for cubics).
const G2: Rule = (
    &[-0.577_350_269_189_625_8, 0.577_350_269_189_625_8],
    &[0.5, 0.5],
);
/// 3-point Gauss–Legendre (exact for quintics).
const G3: Rule = (
    &[-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4],
    &[5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0],
);

/// The mean of `f` over the box centred on (xm, ym) with half-sides (xh, yh) by `rule`
/// along both axes.
fn gauss(
    rule: Rule,
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    xm: f64,
    xh: f64,
    ym: f64,
    yh: f64,
    wk: &mut Work,
) -> f64 {
    let mut sum = 0.0;
    for (&sx, &wx) in rule.0.iter().zip(rule.1) {
        for (&sy, &wy) in rule.0.iter().zip(rule.1) {
            sum += wx * wy * f(xm + sx * xh, ym + sy * yh, wk);
        }
    }
    sum
}

/// The record-mode rule on a box (its decisions cannot depend on one texture's values):
/// 3 × 3 Gauss–Legendre. Each node's weight is handed to the recorder before the integrand
/// runs. (Record mode reaches it on depth maps only: on a plane the record is
/// [`footprint`]'s.)
fn fixed_rule(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    wk: &mut Work,
) {
    let (nodes, weights) = G3;
    let (hx, hy) = (0.5 * (x1 - x0), 0.5 * (y1 - y0));
    let (xm, ym) = (x0 + hx, y0 + hy);
    let area = 4.0 * hx * hy;
    for (&sx, &wx) in nodes.iter().zip(weights) {
        for (&sy, &wy) in nodes.iter().zip(weights) {
            if let Some(r) = wk.rec.as_deref_mut() {
                r.node = area * wx * wy;
            }
            f(xm + sx * hx, ym + sy * hy, wk);
        }
    }
}

/// Halvings forced on a box that a texture discontinuity sweeps (a feature the 2- and
/// 3-point rules could both miss is then at most 1/64 of the box).
const ROUGH_DEPTH: u32 = 3;
/// Most halvings of a box by [`adaptive`].
const MAX_DEPTH: u32 = 6;

/// Adaptive quadrature over the boxes between consecutive cuts, the tolerance shared in
/// proportion to their areas; with `bilinear` (the integrand is known to be bilinear
/// on each box) the midpoint rule alone.
#[allow(clippy::too_many_arguments)]
fn over_boxes(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    rough: &impl Fn(f64, f64, f64, f64, &mut Work) -> bool,
    cx: &[f64],
    cy: &[f64],
    tol: f64,
    bilinear: bool,
    wk: &mut Work,
) -> f64 {
    let total = (cx[cx.len() - 1] - cx[0]) * (cy[cy.len() - 1] - cy[0]);
    let mut s = 0.0;
    for i in 1..cx.len() {
        for j in 1..cy.len() {
            let a = (cx[i] - cx[i - 1]) * (cy[j] - cy[j - 1]);
            if bilinear {
                // Bilinear between the cuts (a fronto-parallel plane, never in record mode):
                // the midpoint rule is exact.
                let (xm, ym) = (0.5 * (cx[i - 1] + cx[i]), 0.5 * (cy[j - 1] + cy[j]));
                s += a * f(xm, ym, wk);
                continue;
            }
            s += adaptive(
                f,
                rough,
                cx[i - 1],
                cx[i],
                cy[j - 1],
                cy[j],
                tol * a / total,
                0,
                wk,
            );
        }
    }
    s
}

/// Outer-w rule: ∫ over w of (area of the x-polygon × mean T over its scene image).
#[allow(clippy::too_many_arguments)]
fn outer_w(
    chan: &Chan,
    scene: &Scene,
    tol: f64,
    c: Pt,
    alpha: f64,
    e: Pt,
    mu: f64,
    wk: &mut Work,
) -> f64 {
    let lv = 1.0 / chan.vl;
    let aa = alpha.abs();
    if let Some(r) = wk.rec.as_deref_mut() {
        r.outer = 1.0;
        r.jac = 1.0;
    }
    // w-range per axis and the kinks of the integrand inside it (in w units).
    let range = |e: f64, h: f64| -> (f64, f64) {
        (lv * (e - aa * h - mu / 2.0), lv * (e + aa * h + mu / 2.0))
    };
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
    let r = chan.r_ap;
    let (x0, x1) = range(e[0], chan.hx);
    let (y0, y1) = range(e[1], chan.hy);
    let (x0, x1, y0, y1) = (x0.max(-r), x1.min(r), y0.max(-r), y1.min(r));
    if !(x1 > x0 && y1 > y0) {
        return 0.0;
    }
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
        complete &= texture_kinks(
            &scene.texture,
            axis,
            z / l * size,
            &moving,
            (t0, t1),
            separable,
            wk.rec.is_some(),
            target,
        );
    }
    let (cx, cy) = box_cuts(wk, (x0, x1), (y0, y1), &kx, &ky);
    // The rect cell clipped by the pixel's square preimage: a product of intervals (a
    // circle's outer domain is parametrised by φ instead).
    let bilinear = bilinear(scene, separable && !circle, complete);
    // A box is rough when a vertex of the polygon's scene image, moving over the box,
    // meets a discontinuity of the texture that no cut follows (a line through the
    // polygon's interior throughout leaves the integrand smooth).
    let g = z / l;
    let slope = if alpha != 0.0 {
        bb.abs().max((bb - g * chan.vl / alpha).abs())
    } else {
        bb.abs()
    };
    let rough = |a0: f64, a1: f64, b0: f64, b1: f64, wk: &mut Work| {
        let w = [0.5 * (a0 + a1), 0.5 * (b0 + b1)];
        let m = [slope * 0.5 * (a1 - a0), slope * 0.5 * (b1 - b0)];
        poly_w(chan, alpha, e, mu, w, wk);
        vertex_meets_jump(scene, c, bb, g, m, |_| w, wk)
    };
    let total = if !circle {
        let mut f =
            |wx: f64, wy: f64, wk: &mut Work| node_w(chan, scene, c, alpha, e, mu, [wx, wy], wk);
        over_boxes(&mut f, &rough, &cx, &cy, tol, bilinear, wk)
    } else {
        // w_x = r sin φ; per interval of w_x the y-range is either the box's (then its
        // cuts apply) or clipped by the circle (then w_y runs over [ylo, yhi] as u ∈ [0, 1]).
        let width = x1 - x0;
        let mut sum = 0.0;
        for i in 1..cx.len() {
            let (a, b) = (cx[i - 1], cx[i]);
            let t = tol * (b - a) / width;
            let (pa, pb) = (
                (a / r).clamp(-1.0, 1.0).asin(),
                (b / r).clamp(-1.0, 1.0).asin(),
            );
            let mid = 0.5 * (a + b);
            let q = (r * r - mid * mid).max(0.0).sqrt();
            let clipped = -q > y0 || q < y1;
            if !clipped {
                let mut f = |p: f64, wy: f64, wk: &mut Work| {
                    if let Some(rec) = wk.rec.as_deref_mut() {
                        rec.jac = r * p.cos();
                    }
                    r * p.cos() * node_w(chan, scene, c, alpha, e, mu, [r * p.sin(), wy], wk)
                };
                let rough_p = |p0: f64, p1: f64, b0: f64, b1: f64, wk: &mut Work| {
                    let (a0, a1) = (r * p0.sin(), r * p1.sin());
                    rough(a0.min(a1), a0.max(a1), b0, b1, wk)
                };
                sum += over_boxes(&mut f, &rough_p, &[pa, pb], &cy, t, false, wk);
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
                    r * p.cos() * (hi - lo) * node_w(chan, scene, c, alpha, e, mu, [wx, wy], wk)
                };
                let rough_p = |p0: f64, p1: f64, _: f64, _: f64, wk: &mut Work| {
                    let (a0, a1) = (r * p0.sin(), r * p1.sin());
                    rough(a0.min(a1), a0.max(a1), y0, y1, wk)
                };
                sum += adaptive(&mut f, &rough_p, pa, pb, 0.0, 1.0, t, 0, wk);
            }
        }
        sum
    };
    wk.cuts_a = cx;
    wk.cuts_b = cy;
    total
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
fn poly_w(chan: &Chan, alpha: f64, e: Pt, mu: f64, w: Pt, wk: &mut Work) -> f64 {
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
#[allow(clippy::too_many_arguments)]
fn node_w(
    chan: &Chan,
    scene: &Scene,
    c: Pt,
    alpha: f64,
    e: Pt,
    mu: f64,
    w: Pt,
    wk: &mut Work,
) -> f64 {
    let area = poly_w(chan, alpha, e, mu, w, wk);
    if area <= 0.0 {
        return 0.0;
    }
    area * scene_mean(chan, scene, c, |_| w, wk)
}

/// Outer-s rule: ∫ over the sensor point s in the pixel (and in the lens's reach).
#[allow(clippy::too_many_arguments)]
fn outer_s(
    chan: &Chan,
    scene: &Scene,
    tol: f64,
    c: Pt,
    alpha: f64,
    e: Pt,
    mu: f64,
    wk: &mut Work,
) -> f64 {
    // Offsets σ = s − img (img = (1 + v/L) c): the pixel is σ ∈ −e ± μ/2; the lens's
    // light reaches |σ| ≤ |α| h + (v/L) r_ap per axis.
    let aa = alpha.abs();
    if let Some(r) = wk.rec.as_deref_mut() {
        r.outer = (1.0 / chan.vl).powi(2);
        r.jac = 1.0;
    }
    let rho = chan.vl * chan.r_ap; // (v/L) r_ap; the preimage radius is rho / |α|
    let reach = [aa * chan.hx + rho, aa * chan.hy + rho];
    let (x0, x1) = (
        (-e[0] - mu / 2.0).max(-reach[0]),
        (-e[0] + mu / 2.0).min(reach[0]),
    );
    let (y0, y1) = (
        (-e[1] - mu / 2.0).max(-reach[1]),
        (-e[1] + mu / 2.0).min(reach[1]),
    );
    if !(x1 > x0 && y1 > y0) {
        return 0.0;
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
        complete &= texture_kinks(
            &scene.texture,
            axis,
            size,
            &moving,
            (t0, t1),
            separable,
            wk.rec.is_some(),
            target,
        );
    }
    let (cx, cy) = box_cuts(wk, (x0, x1), (y0, y1), &kx, &ky);
    // The rect cell clipped by the square aperture's preimage: a product of intervals.
    let bilinear = bilinear(scene, separable, complete);
    let lv = 1.0 / chan.vl;
    let mut f = |sx: f64, sy: f64, wk: &mut Work| node_s(chan, scene, c, alpha, [sx, sy], wk);
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
    let total = over_boxes(&mut f, &rough, &cx, &cy, tol / (lv * lv), bilinear, wk);
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
fn node_s(chan: &Chan, scene: &Scene, c: Pt, alpha: f64, sigma: Pt, wk: &mut Work) -> f64 {
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
    area * scene_mean(chan, scene, c, wfun, wk)
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

/// The mean albedo over the scene image of the polygon `wk.poly` (local cell coordinates
/// ξ, x = c + ξ), each vertex's ray having main-lens point `w_of(ξ)`.
fn scene_mean(chan: &Chan, scene: &Scene, c: Pt, w_of: impl Fn(Pt) -> Pt, wk: &mut Work) -> f64 {
    let l = chan.ch.l;
    let f = chan.f_main;
    let a_of = |xi: Pt, w: Pt| {
        [
            w[0] / f + (c[0] + xi[0] - w[0]) / l,
            w[1] / f + (c[1] + xi[1] - w[1]) / l,
        ]
    };
    if let Some(z) = scene.surface.fronto() {
        wk.mapped.clear();
        for &xi in &wk.poly {
            let w = w_of(xi);
            let a = a_of(xi, w);
            wk.mapped.push([w[0] - z * a[0], w[1] - z * a[1]]);
        }
        // (Never in record mode: on a plane the record is `footprint`'s.)
        return scene.texture.average(&wk.mapped, &mut wk.tex);
    }
    // Slanted or curved: hits at the vertices decide how finely to cut.
    let mut zmin = f64::INFINITY;
    let mut zmax = f64::NEG_INFINITY;
    let mut misses = 0;
    let mut pmin = [f64::INFINITY; 2];
    let mut pmax = [f64::NEG_INFINITY; 2];
    wk.zs.clear();
    for &xi in &wk.poly {
        let w = w_of(xi);
        match scene.surface.hit(w, a_of(xi, w)) {
            Some((z, p)) => {
                wk.zs.push(z);
                zmin = zmin.min(z);
                zmax = zmax.max(z);
                for k in 0..2 {
                    pmin[k] = pmin[k].min(p[k]);
                    pmax[k] = pmax[k].max(p[k]);
                }
            }
            None => misses += 1,
        }
    }
    if misses == wk.poly.len() {
        // Check the centroid before declaring the whole polygon background.
        let ctr = crate::infra::polygon::centroid(&wk.poly);
        let w = w_of(ctr);
        if scene.surface.hit(w, a_of(ctr, w)).is_none() {
            if let Some(r) = wk.rec.as_deref_mut() {
                r.add_background(signed_area(&wk.poly));
                return 0.0;
            }
            return scene.background;
        }
    }
    let total_area = signed_area(&wk.poly);
    let src = std::mem::take(&mut wk.poly);
    let mut acc = 0.0;
    if matches!(scene.surface, Surface::Plane { .. }) && misses == 0 && zmax > zmin {
        // A plane: the depth's level lines over the polygon are (nearly: exactly for a
        // fixed main-lens point) parallel, and the ray map's density varies across them
        // only. Strips along them, each of relative depth span STRIP_DEPTH_RTOL at most.
        let n = ((zmax - zmin) / zmin / STRIP_DEPTH_RTOL).ceil() as usize;
        let n = n.clamp(1, MAX_STRIPS);
        let g = depth_gradient(&src, &wk.zs);
        let proj = |p: Pt| g[0] * p[0] + g[1] * p[1];
        let (t0, t1) = src
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &p| {
                (a.min(proj(p)), b.max(proj(p)))
            });
        for k in 0..n {
            let lo = t0 + (t1 - t0) * k as f64 / n as f64;
            let hi = t0 + (t1 - t0) * (k + 1) as f64 / n as f64;
            if n > 1 {
                clip_into(&src, &mut wk.tmp, |p| proj(p) - lo);
                clip_into(&wk.tmp, &mut wk.piece, |p| hi - proj(p));
            } else {
                wk.piece.clear();
                wk.piece.extend_from_slice(&src);
            }
            acc += piece_value(scene, &w_of, &a_of, wk);
        }
        wk.poly = src;
        return acc / total_area;
    }
    let mut n = if zmin.is_finite() {
        ((zmax - zmin) / zmin / PIECE_DEPTH_RTOL).sqrt().ceil() as usize
    } else {
        1
    };
    if let Surface::Map(m) = &scene.surface {
        let cell = m.cell();
        let span = ((pmax[0] - pmin[0]) / cell[0]).max((pmax[1] - pmin[1]) / cell[1]);
        if span.is_finite() {
            n = n.max(span.ceil() as usize);
        }
    }
    if misses > 0 {
        n = n.max(4);
    }
    let n = n.clamp(1, MAX_PIECES);
    let (x0, x1, y0, y1) = bounds(&src);
    for i in 0..n {
        for j in 0..n {
            let (px0, px1) = (
                x0 + (x1 - x0) * i as f64 / n as f64,
                x0 + (x1 - x0) * (i + 1) as f64 / n as f64,
            );
            let (py0, py1) = (
                y0 + (y1 - y0) * j as f64 / n as f64,
                y0 + (y1 - y0) * (j + 1) as f64 / n as f64,
            );
            wk.piece.clear();
            wk.piece.extend_from_slice(&src);
            if n > 1 {
                clip_box(&mut wk.piece, &mut wk.tmp, px0, px1, py0, py1);
            }
            acc += piece_value(scene, &w_of, &a_of, wk);
        }
    }
    wk.poly = src;
    acc / total_area
}

/// ∫ T over the ray set `wk.piece` (cell coordinates ξ) of one node, the piece's image
/// treated as the polygon of its vertices' hits (in record mode: recorded, 0 returned).
fn piece_value(
    scene: &Scene,
    w_of: &impl Fn(Pt) -> Pt,
    a_of: &impl Fn(Pt, Pt) -> Pt,
    wk: &mut Work,
) -> f64 {
    let area = signed_area(&wk.piece);
    if area <= 0.0 {
        return 0.0;
    }
    wk.mapped.clear();
    let mut miss = false;
    for &xi in &wk.piece {
        let w = w_of(xi);
        match scene.surface.hit(w, a_of(xi, w)) {
            Some((_, p)) => wk.mapped.push(p),
            None => {
                miss = true;
                break;
            }
        }
    }
    if let Some(r) = wk.rec.as_deref_mut() {
        if !miss {
            r.add(&wk.mapped, area);
        } else {
            let ctr = crate::infra::polygon::centroid(&wk.piece);
            let w = w_of(ctr);
            match scene.surface.hit(w, a_of(ctr, w)) {
                Some((_, p)) => r.add_point(p, area),
                None => r.add_background(area),
            }
        }
        return 0.0;
    }
    let v = if miss {
        let ctr = crate::infra::polygon::centroid(&wk.piece);
        let w = w_of(ctr);
        match scene.surface.hit(w, a_of(ctr, w)) {
            Some((_, p)) => scene.texture.at(p),
            None => scene.background,
        }
    } else {
        scene.texture.average(&wk.mapped, &mut wk.tex)
    };
    area * v
}

/// The direction of steepest depth increase over a polygon (least squares through its
/// vertices' hit depths `zs`); any unit vector when they are flat.
fn depth_gradient(poly: &[Pt], zs: &[f64]) -> Pt {
    let n = poly.len() as f64;
    let m = poly
        .iter()
        .fold([0.0, 0.0], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n]);
    let zm = zs.iter().sum::<f64>() / n;
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (p, &z) in poly.iter().zip(zs) {
        let (dx, dy, dz) = (p[0] - m[0], p[1] - m[1], z - zm);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
        sxz += dx * dz;
        syz += dy * dz;
    }
    let det = sxx * syy - sxy * sxy;
    let g = if det.abs() > 1e-300 {
        [(syy * sxz - sxy * syz) / det, (sxx * syz - sxy * sxz) / det]
    } else {
        [sxz, syz]
    };
    let norm = (g[0] * g[0] + g[1] * g[1]).sqrt();
    if norm > 0.0 && norm.is_finite() {
        [g[0] / norm, g[1] / norm]
    } else {
        [1.0, 0.0]
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
fn exact_route(design: &Design, ch: &Channel, scene: &Scene) -> bool {
    scene.surface.fronto().is_some()
        && ch.grid == Grid::Rect
        && design.shape == Aperture::Square
        && matches!(ch.layout, Layout::Ideal { .. })
        && matches!(scene.texture, Texture::Image(_) | Texture::Constant(_))
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
        if exact_route(design, ch, scene) {
            exact::render_channel(design, &chan, scene, raw, n_threads, done)?;
        } else {
            general_channel(design, &chan, scene, opts, raw, n_threads, done)?;
        }
    }
    Ok(())
}

/// The general route over one channel's raw, parallel over rows.
fn general_channel(
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
    let (rows, cols) = raw_shape(ch);
    let per_row = (cols as u128) * 2000;
    // The adaptive rule's absolute target per lens (before the channel's norm): tol × the
    // ray measure of a fully lit pixel, cell area × (μ L / v)².
    let full = signed_area(&chan.cell) * (ch.mu / chan.vl).powi(2);
    let tol = tol * full;
    let step = crate::infra::parallel::chunk_items(n_threads, per_row);
    let reach = chan.reach();
    let raw_ptr = SendPtr(raw.as_mut_ptr());
    for_chunks(n_threads, rows, step, |range| {
        let start = range.start;
        // SAFETY: each chunk writes its own disjoint rows of `raw`.
        let chunk = unsafe {
            std::slice::from_raw_parts_mut(raw_ptr.get().add(start * cols), range.len() * cols)
        };
        chunk.par_chunks_mut(cols).enumerate().try_for_each_init(
            || Work::new(scene.surface.fronto().is_some()),
            |wk, (i, row)| -> Result<()> {
                checkpoint()?;
                let b = (start + i) as u32;
                for (a, out) in row.iter_mut().enumerate() {
                    // A pixel can take milliseconds (depth maps): check for Ctrl-C per pixel.
                    checkpoint()?;
                    *out = if own {
                        own_lens_value(design, chan, scene, tol, a as u32, b, wk)
                    } else {
                        pixel_value(design, chan, scene, tol, a as u32, b, reach, wk)
                    };
                }
                done.fetch_add(1, Ordering::Relaxed);
                Ok(())
            },
        )
    })
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

/// One pixel (column a, row b of the channel's raw).
#[allow(clippy::too_many_arguments)]
pub(crate) fn pixel_value(
    design: &Design,
    chan: &Chan,
    scene: &Scene,
    tol: f64,
    a: u32,
    b: u32,
    reach: [f64; 2],
    wk: &mut Work,
) -> f64 {
    let ch = chan.ch;
    match ch.layout {
        // The pixel sees its own lens alone.
        Layout::Ideal { .. } => own_lens_value(design, chan, scene, tol, a, b, wk),
        Layout::Sensor { mx, my } => {
            let mu = ch.mu;
            let s = [
                mu * (a as f64 - (mx as f64 - 1.0) / 2.0),
                mu * (b as f64 - (my as f64 - 1.0) / 2.0),
            ];
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
                    v += lens_contribution(chan, scene, tol, c, ch.lens_type(j, k), s, wk);
                }
            }
            chan.norm * v
        }
    }
}

/// One pixel's value through its own lens alone (the lens [`Design::pixel`] assigns it;
/// on the ideal layout that is the pixel's whole value, [`pixel_value`]).
fn own_lens_value(
    design: &Design,
    chan: &Chan,
    scene: &Scene,
    tol: f64,
    a: u32,
    b: u32,
    wk: &mut Work,
) -> f64 {
    let ch = chan.ch;
    let px = design.pixel(ch, a, b);
    let c = ch.lens_center(px.j, px.k);
    // The pixel's sensor point: its lens image's centre plus its offset θ (both layouts).
    let s = [chan.m * c[0] + px.theta[0], chan.m * c[1] + px.theta[1]];
    chan.norm * lens_contribution(chan, scene, tol, c, px.t, s, wk)
}

/// The exact route (module doc): separable 1-D ray-set areas per texture column and row.
pub(crate) mod exact {
    use super::*;
    use crate::imaging::texture::ImageTexture;

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
        tilted_profile(chan, alpha, c, theta, z, 0.0, n, edge)
            .expect("a fronto-parallel plane at z > 0 is met by every ray")
    }

    /// The profile against the edges of the axis along which the plane Z = z0 + g Y tilts
    /// (g = 0: the fronto-parallel plane at z0). A ray of this axis, P(Z) = w − Z a with
    /// a = w/F + (c + ξ − w)/L, meets the plane at Y = (w − z0 a) / (1 + g a) when
    /// 1 + g a > 0, and there Y ≤ e exactly when w − Z_e a ≤ e, Z_e = z0 + g e: the
    /// fronto-parallel condition at the edge's own depth, a straight cut of the polygon. So
    /// the areas between edges stay exact. None when some ray of the pixel runs parallel
    /// to the plane or meets it behind the main lens (1 + g a ≤ 0 or Z ≤ 0 somewhere).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn tilted_profile(
        chan: &Chan,
        alpha: f64,
        c: f64,
        theta: f64,
        z0: f64,
        g: f64,
        n: usize,
        edge: impl Fn(usize) -> f64,
    ) -> Option<Profile> {
        tilted_profile_of(chan, c, &polygon(chan, alpha, theta), z0, g, n, edge)
    }

    /// [`tilted_profile`] of any polygon of rays in (ξ, w) behind the lens centred at c (a
    /// part of a pixel's ray set).
    pub(crate) fn tilted_profile_of(
        chan: &Chan,
        c: f64,
        poly: &[Pt],
        z0: f64,
        g: f64,
        n: usize,
        edge: impl Fn(usize) -> f64,
    ) -> Option<Profile> {
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
        let (rows, cols) = raw_shape(ch);
        let (tx0, tx1, ty0, ty1) = tex.extent();
        let (tr, tc) = tex.shape();
        let hx = (tx1 - tx0) / tc as f64;
        let hy = (ty1 - ty0) / tr as f64;
        let theta = |i: u32| pixel_offset(ch.mu, q, i);
        // X profiles per type and column a; Y profiles (top-down texture rows: edge i at
        // Y1 − i hy, so flip: bottom-up row index) per type and row b.
        let nt = chan.types.len();
        let px: Vec<Vec<Profile>> = (0..nt)
            .map(|t| {
                (0..cols as u32)
                    .into_par_iter()
                    .map(|a| {
                        let c = ch.lens_center(a / q, 0)[0];
                        profile(chan, chan.types[t].0, c, theta(a), z, tc, |i| {
                            tx0 + i as f64 * hx
                        })
                    })
                    .collect()
            })
            .collect();
        let py: Vec<Vec<Profile>> = (0..nt)
            .map(|t| {
                (0..rows as u32)
                    .into_par_iter()
                    .map(|b| {
                        let c = ch.lens_center(0, b / q)[1];
                        profile(chan, chan.types[t].0, c, theta(b), z, tr, |i| {
                            ty0 + i as f64 * hy
                        })
                    })
                    .collect()
            })
            .collect();
        let mean = tex.mean_value();
        let norm = chan.norm;
        let step = crate::infra::parallel::chunk_items(n_threads, (cols as u128) * 64);
        let raw_ptr = SendPtr(raw.as_mut_ptr());
        for_chunks(n_threads, rows, step, |range| {
            let start = range.start;
            // SAFETY: each chunk writes its own disjoint rows of `raw`.
            let chunk = unsafe {
                std::slice::from_raw_parts_mut(raw_ptr.get().add(start * cols), range.len() * cols)
            };
            chunk.par_chunks_mut(cols).enumerate().try_for_each_init(
                || vec![vec![0.0; tc]; nt],
                |tmps, (i, row)| -> Result<()> {
                    checkpoint()?;
                    let b = start + i;
                    let k = b as u32 / q;
                    // Per type: tmp[i] = Σ_rows Iy[row] T[row][i] (bottom-up rows) and
                    // the y-area inside the texture.
                    let mut ay_in = vec![0.0; nt];
                    for t in 0..nt {
                        let yp = &py[t][b];
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
                        let (xp, yp) = (&px[t][a], &py[t][b]);
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
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adaptive_is_exact_on_bilinear_and_converges_on_a_disc() {
        let mut wk = Work::default();
        let mut f = |x: f64, y: f64, _: &mut Work| 1.0 + 2.0 * x - y + 3.0 * x * y;
        let smooth0 = |_: f64, _: f64, _: f64, _: f64, _: &mut Work| false;
        let v = adaptive(&mut f, &smooth0, 0.0, 2.0, -1.0, 1.0, 1e-12, 0, &mut wk);
        assert!((v - 12.0).abs() < 1e-12, "{v}");
        let mut disc = |x: f64, y: f64, _: &mut Work| if x * x + y * y < 1.0 { 1.0 } else { 0.0 };
        let smooth = |_: f64, _: f64, _: f64, _: f64, _: &mut Work| false;
        let v = adaptive(&mut disc, &smooth, -1.0, 1.0, -1.0, 1.0, 1e-3, 0, &mut wk);
        assert!((v - PI).abs() < 0.05, "{v}");
    }
}
