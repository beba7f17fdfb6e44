//! The inner integral of the general route: the mean albedo over the scene image of one
//! node's polygon of rays, exact on a fronto-parallel plane ([`Texture::average`]), on
//! slanted planes and depth maps through strips or pieces small enough that the map to
//! the scene is affine within each to the error budget (docs/render.md).

use super::chan::{Chan, HitCache, Work};
use crate::imaging::scene::{Scene, Surface};
#[cfg(doc)]
use crate::imaging::texture::Texture;
use crate::infra::polygon::{area_moments, bounds, clip_box, clip_into, signed_area, Pt};

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
/// On a plane, with the texture's first moments ([`Texture::moments`]): the relative span
/// of D = Z − Z_Q (Z_Q the depth of the apex of the node's pencil of rays) over one strip,
/// where the ray map's density, exactly ∝ D⁻³, is taken linear: an error of about
/// 6 (half the span)² ≈ 10⁻⁴ × the albedo's range within the strip (docs/render.md,
/// "Slanted planes").
const LINEAR_STRIP_RTOL: f64 = 8e-3;

/// The mean albedo over the scene image of the polygon `wk.poly` (local cell coordinates
/// ξ, x = c + ξ), each vertex's ray having main-lens point `w_of(ξ)`.
pub(super) fn scene_mean(
    chan: &Chan,
    scene: &Scene,
    c: Pt,
    w_of: impl Fn(Pt) -> Pt,
    wk: &mut Work,
) -> f64 {
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
    let rays = Rays { scene, w_of, a_of };
    let hits = vertex_hits(&rays, wk);
    if hits.misses == wk.poly.len() {
        // Check the centroid before declaring the whole polygon background.
        if rays
            .hit(crate::infra::polygon::centroid(&wk.poly))
            .is_none()
        {
            if let Some(r) = wk.rec.as_deref_mut() {
                r.add_background(signed_area(&wk.poly));
                return 0.0;
            }
            return scene.background;
        }
    }
    let total_area = signed_area(&wk.poly);
    let src = std::mem::take(&mut wk.poly);
    let acc = if matches!(scene.surface, Surface::Plane { .. })
        && hits.misses == 0
        && hits.zmax > hits.zmin
    {
        match linear_strips(&rays, &src, &hits, wk) {
            Some(v) => v,
            None => strips_integral(&rays, &src, &hits, wk),
        }
    } else {
        pieces_integral(&rays, &src, &hits, wk)
    };
    wk.poly = src;
    acc / total_area
}

/// The rays of one node's polygon: cell point ξ's ray leaves main-lens point `w_of(ξ)` with
/// slope `a_of(ξ, w)` toward the scene.
struct Rays<'a, W, A> {
    scene: &'a Scene,
    w_of: W,
    a_of: A,
}

impl<W: Fn(Pt) -> Pt, A: Fn(Pt, Pt) -> Pt> Rays<'_, W, A> {
    /// Where the ray of cell point ξ meets the surface: its depth and scene point.
    fn hit(&self, xi: Pt) -> Option<(f64, Pt)> {
        let w = (self.w_of)(xi);
        self.scene.surface.hit(w, (self.a_of)(xi, w))
    }

    /// [`Rays::hit`], on a depth map through this node's hits so far (`hits`: a point
    /// taken before, bit for bit, is not taken again; the result is the same either way).
    /// On a plane a hit is a closed form, cheaper than the look-up.
    fn hit_known(&self, xi: Pt, hits: &mut HitCache) -> Option<(f64, Pt)> {
        if !matches!(self.scene.surface, Surface::Map(_)) {
            return self.hit(xi);
        }
        *hits
            .entry([xi[0].to_bits(), xi[1].to_bits()])
            .or_insert_with(|| self.hit(xi))
    }
}

/// Where the rays of the vertices of `wk.poly` meet the surface: their depths (also in
/// `wk.zs`; the scene points of those that hit in `wk.mapped`), the box of their scene
/// points, and how many miss it.
struct Hits {
    zmin: f64,
    zmax: f64,
    misses: usize,
    pmin: Pt,
    pmax: Pt,
}

fn vertex_hits(rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>, wk: &mut Work) -> Hits {
    let mut zmin = f64::INFINITY;
    let mut zmax = f64::NEG_INFINITY;
    let mut misses = 0;
    let mut pmin = [f64::INFINITY; 2];
    let mut pmax = [f64::NEG_INFINITY; 2];
    wk.zs.clear();
    wk.mapped.clear();
    wk.hits.clear();
    for &xi in &wk.poly {
        match rays.hit_known(xi, &mut wk.hits) {
            Some((z, p)) => {
                wk.zs.push(z);
                wk.mapped.push(p);
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
    Hits {
        zmin,
        zmax,
        misses,
        pmin,
        pmax,
    }
}

/// ∫ T over the polygon `src` on a plane that all its vertices' rays meet: the depth's
/// level lines over the polygon are (nearly: exactly for a fixed main-lens point)
/// parallel, and the ray map's density varies across them only. Strips along them, each
/// of relative depth span [`STRIP_DEPTH_RTOL`] at most.
fn strips_integral(
    rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>,
    src: &[Pt],
    hits: &Hits,
    wk: &mut Work,
) -> f64 {
    let (zmin, zmax) = (hits.zmin, hits.zmax);
    let n = ((zmax - zmin) / zmin / STRIP_DEPTH_RTOL).ceil() as usize;
    let n = n.clamp(1, MAX_STRIPS);
    let strips = Strips::new(src, &wk.zs, n);
    let mut acc = 0.0;
    for k in 0..n {
        if n > 1 {
            strips.cut(src, k, wk);
        } else {
            wk.piece.clear();
            wk.piece.extend_from_slice(src);
        }
        acc += piece_value(rays, wk);
    }
    acc
}

/// A polygon cut into `n` strips of equal width along its depth's level lines (across the
/// least-squares gradient of its vertices' depths, [`depth_gradient`]).
struct Strips {
    g: Pt,
    t0: f64,
    t1: f64,
    n: usize,
}

impl Strips {
    fn new(src: &[Pt], zs: &[f64], n: usize) -> Strips {
        let g = depth_gradient(src, zs);
        let (t0, t1) = src
            .iter()
            .map(|p| g[0] * p[0] + g[1] * p[1])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
        Strips { g, t0, t1, n }
    }

    /// Strip k of `src` into `wk.piece`.
    fn cut(&self, src: &[Pt], k: usize, wk: &mut Work) {
        let (g, t0, t1, n) = (self.g, self.t0, self.t1, self.n as f64);
        let proj = |p: Pt| g[0] * p[0] + g[1] * p[1];
        let lo = t0 + (t1 - t0) * k as f64 / n;
        let hi = t0 + (t1 - t0) * (k + 1) as f64 / n;
        clip_into(src, &mut wk.tmp, |p| proj(p) - lo);
        clip_into(&wk.tmp, &mut wk.piece, |p| hi - proj(p));
    }
}

/// The depth of the apex of a node's pencil of rays: X(z) = w(ξ) − z a(ξ) with w and a
/// affine in ξ, the same along both axes, so every ray passes through the point where
/// ∂X/∂ξ = 0 (z = ∂w/∂ξ / ∂a/∂ξ: 0 on the outer-w rule, where w is fixed); infinity for
/// parallel rays; None if the axes disagree.
fn apex_depth(rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>) -> Option<f64> {
    let w0 = (rays.w_of)([0.0, 0.0]);
    let a0 = (rays.a_of)([0.0, 0.0], w0);
    let mut z = [0.0; 2];
    for k in 0..2 {
        let mut e = [0.0; 2];
        e[k] = 1.0;
        let w1 = (rays.w_of)(e);
        let a1 = (rays.a_of)(e, w1);
        let (dw, da) = (w1[k] - w0[k], a1[k] - a0[k]);
        z[k] = if da.abs() <= 1e-12 * a0[k].abs().max(a1[k].abs()) {
            f64::INFINITY
        } else {
            dw / da
        };
    }
    let same = (z[0].is_infinite() && z[1].is_infinite())
        || (z[0] - z[1]).abs() <= 1e-9 * (z[0].abs() + z[1].abs() + 1.0);
    same.then_some(z[0])
}

/// ∫ T over the polygon `src` on a plane that all its vertices' rays meet, with the
/// texture's first moments: for a fixed pencil of rays (apex depth Z_Q, [`apex_depth`]) a
/// piece's image on the plane is exactly the polygon of its vertices' hits, and the ray
/// map's density there is exactly ∝ D(P)⁻³, D = Z(P) − Z_Q; taken linear about the image's
/// centroid P̄, ∫ T ρ = (area in ξ / image area) (∬ T − 3 g · (∬ T P − P̄ ∬ T) / D(P̄)).
/// Strips along the depth's level lines of relative D span [`LINEAR_STRIP_RTOL`] (one, on
/// most polygons). None (the constant-density strips instead) for a texture without
/// moments, in record mode, or when the apex lies among the plane's depths.
fn linear_strips(
    rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>,
    src: &[Pt],
    hits: &Hits,
    wk: &mut Work,
) -> Option<f64> {
    let scene = rays.scene;
    let Surface::Plane { z0, g } = scene.surface else {
        return None;
    };
    if !scene.texture.has_moments() || wk.rec.is_some() {
        return None;
    }
    let zq = apex_depth(rays)?;
    let n = if zq.is_finite() {
        let (d0, d1) = (hits.zmin - zq, hits.zmax - zq);
        if !(d0 > 0.0 || d1 < 0.0) {
            return None;
        }
        let parts = (d1 - d0) / d0.abs().min(d1.abs()) / LINEAR_STRIP_RTOL;
        if parts.is_nan() || parts > MAX_STRIPS as f64 {
            return None;
        }
        (parts.ceil() as usize).max(1)
    } else {
        1
    };
    let plane = Linear { z0, g, zq };
    if n == 1 {
        // The vertices' hits (`vertex_hits`) are the piece's.
        return plane.piece(scene, signed_area(src), &wk.mapped);
    }
    let strips = Strips::new(src, &wk.zs, n);
    let mut acc = 0.0;
    for k in 0..n {
        strips.cut(src, k, wk);
        let area = signed_area(&wk.piece);
        if area <= 0.0 {
            continue;
        }
        wk.mapped.clear();
        for &xi in &wk.piece {
            wk.mapped.push(rays.hit(xi)?.1);
        }
        acc += plane.piece(scene, area, &wk.mapped)?;
    }
    Some(acc)
}

/// A plane Z = z0 + g · P seen by a pencil of rays with apex depth `zq` ([`linear_strips`]).
struct Linear {
    z0: f64,
    g: Pt,
    zq: f64,
}

impl Linear {
    /// ∫ T over a piece of `area` in ξ whose image on the plane is `mapped`.
    fn piece(&self, scene: &Scene, area: f64, mapped: &[Pt]) -> Option<f64> {
        let (ap, m) = area_moments(mapped);
        let (x0, x1, y0, y1) = bounds(mapped);
        let scale = (x1 - x0).max(y1 - y0);
        if ap.abs() <= 1e-12 * scale * scale || !ap.is_finite() {
            // A degenerate image (as `Texture::average` takes it): T at its centroid.
            return Some(area * scene.texture.at(crate::infra::polygon::centroid(mapped)));
        }
        let t = scene.texture.moments(mapped)?;
        let pc = [m[0] / ap, m[1] / ap];
        let g = self.g;
        let corr = if self.zq.is_finite() {
            let d = self.z0 + g[0] * pc[0] + g[1] * pc[1] - self.zq;
            -3.0 * (g[0] * (t[1] - pc[0] * t[0]) + g[1] * (t[2] - pc[1] * t[0])) / d
        } else {
            0.0
        };
        Some(area * ((t[0] + corr) / ap).max(0.0))
    }
}

/// ∫ T over the polygon `src` on a slanted plane some rays miss, or a depth map: cut into
/// n × n pieces, n set by the relative depth span ([`PIECE_DEPTH_RTOL`]), the map's cells
/// the image spans, and misses (at most [`MAX_PIECES`]).
fn pieces_integral(
    rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>,
    src: &[Pt],
    hits: &Hits,
    wk: &mut Work,
) -> f64 {
    let Hits {
        zmin,
        zmax,
        misses,
        pmin,
        pmax,
    } = *hits;
    let mut n = if zmin.is_finite() {
        ((zmax - zmin) / zmin / PIECE_DEPTH_RTOL).sqrt().ceil() as usize
    } else {
        1
    };
    if let Surface::Map(m) = &rays.scene.surface {
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
    let (x0, x1, y0, y1) = bounds(src);
    let mut acc = 0.0;
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
            wk.piece.extend_from_slice(src);
            if n > 1 {
                clip_box(&mut wk.piece, &mut wk.tmp, px0, px1, py0, py1);
            }
            acc += piece_value(rays, wk);
        }
    }
    acc
}

/// ∫ T over the ray set `wk.piece` (cell coordinates ξ) of one node, the piece's image
/// treated as the polygon of its vertices' hits (in record mode: recorded, 0 returned).
fn piece_value(rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>, wk: &mut Work) -> f64 {
    let area = signed_area(&wk.piece);
    if area <= 0.0 {
        return 0.0;
    }
    wk.mapped.clear();
    // On a depth map a piece that some rays miss needs every vertex's hit (`edge_piece`);
    // elsewhere the first miss settles it (the centroid's ray stands for the piece).
    let map = match &rays.scene.surface {
        Surface::Map(m) => Some(m),
        Surface::Plane { .. } => None,
    };
    let (mut misses, mut zsum) = (0usize, 0.0);
    for &xi in &wk.piece {
        match rays.hit_known(xi, &mut wk.hits) {
            Some((z, p)) => {
                wk.mapped.push(p);
                zsum += z;
            }
            None => {
                misses += 1;
                if map.is_none() {
                    break;
                }
                wk.mapped.push([f64::NAN; 2]);
            }
        }
    }
    let n = wk.piece.len();
    if let Some(m) = map {
        if misses > 0 && misses < n {
            return edge_piece(rays, m.extent(), area, zsum / (n - misses) as f64, wk);
        }
    }
    let miss = misses > 0;
    if let Some(r) = wk.rec.as_deref_mut() {
        if !miss {
            r.add(&wk.mapped, area);
        } else {
            match rays.hit(crate::infra::polygon::centroid(&wk.piece)) {
                Some((_, p)) => r.add_point(p, area),
                None => r.add_background(area),
            }
        }
        return 0.0;
    }
    let scene = rays.scene;
    let v = if miss {
        match rays.hit(crate::infra::polygon::centroid(&wk.piece)) {
            Some((_, p)) => scene.texture.at(p),
            None => scene.background,
        }
    } else {
        scene.texture.average(&wk.mapped, &mut wk.tex)
    };
    area * v
}

/// A piece of a depth map's node some of whose rays miss the map (`wk.mapped`: the hits,
/// NaN where a ray misses) and the others hit it at mean depth `z`: where the map's
/// extent ends (beyond it there is no surface, the background). The missing vertices are
/// carried to depth z too, the piece's image clipped by the extent, and the piece's rays
/// shared in proportion to the image's areas inside (the texture) and outside (the
/// background): exact on a map flat near its edge (the map from rays to the scene is
/// affine there), where the centroid's ray standing for the whole piece was 1.3·10⁻⁴ of
/// white off on the seed at 700 mm (docs/render.md, "Occlusion edges").
fn edge_piece(
    rays: &Rays<impl Fn(Pt) -> Pt, impl Fn(Pt, Pt) -> Pt>,
    extent: [f64; 4],
    area: f64,
    z: f64,
    wk: &mut Work,
) -> f64 {
    for (p, &xi) in wk.mapped.iter_mut().zip(&wk.piece) {
        if p[0].is_nan() {
            let w = (rays.w_of)(xi);
            let a = (rays.a_of)(xi, w);
            *p = [w[0] - z * a[0], w[1] - z * a[1]];
        }
    }
    let whole = signed_area(&wk.mapped).abs();
    clip_box(
        &mut wk.mapped,
        &mut wk.tmp,
        extent[0],
        extent[1],
        extent[2],
        extent[3],
    );
    let inside = signed_area(&wk.mapped).abs();
    let frac = if whole > 0.0 {
        (inside / whole).min(1.0)
    } else {
        0.0
    };
    if let Some(r) = wk.rec.as_deref_mut() {
        if frac > 0.0 {
            r.add(&wk.mapped, area * frac);
        }
        r.add_background(area * (1.0 - frac));
        return 0.0;
    }
    let scene = rays.scene;
    let tex = if frac > 0.0 {
        scene.texture.average(&wk.mapped, &mut wk.tex)
    } else {
        0.0
    };
    area * (frac * tex + (1.0 - frac) * scene.background)
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
