//! The general route's boxes in closed form (docs/render.md, "The interior in closed
//! form"): on a fronto-parallel plane, over a box of the outer variable on which a lens's
//! polygon of rays is one fixed polygon moving by translation (the whole cell, inside the
//! aperture's or the pixel's preimage throughout; or a square preimage inside the cell
//! throughout), the scene point is P = a η + m t + P0 (η in the fixed polygon V, t the
//! outer variable, a and m scalars), and the box's integral is
//! ∫_t ∫_V T = [`SatTable::rect_polygon`](m · box + P0, a · V) / (a m)².

use super::adaptive::QBox;
use super::chan::{Chan, Work};
use super::sat::SatTable;
use crate::infra::polygon::Pt;
use crate::model::design::Aperture;

/// A fixed polygon moving by translation over a box: P = a η + m t + p0. `half` is 0 when
/// `v` is the channel's cell, else the half-side of the square `v` is: with `a` it keys
/// the polygon a·v in the corners' memo ([`super::sat::CornerMemo`]).
struct Moving<'v> {
    v: &'v [Pt],
    half: f64,
    a: f64,
    m: f64,
    p0: Pt,
}

/// A rectangle of scene translates narrower than this many texture cells is left to the
/// quadrature (the four-corner difference of S would lose its digits; the integrand is
/// nearly constant over such a box, and the quadrature's first test passes).
const MIN_RECT_CELLS: f64 = 1e-6;

/// ∫ over the box of ∫_V T(a η + m t + p0) dη dt, or `None` when the map is degenerate;
/// with `disc` = (r, tol), over the box's part inside the disc |t| ≤ r (its arcs to the
/// absolute accuracy tol of this integral).
fn integrate(
    sat: &SatTable,
    mv: &Moving,
    bx: QBox,
    disc: Option<(f64, f64)>,
    wk: &mut Work,
) -> Option<f64> {
    let Moving { v, half, a, m, p0 } = *mv;
    let (xa, xb) = (m * bx.x0 + p0[0], m * bx.x1 + p0[0]);
    let (ya, yb) = (m * bx.y0 + p0[1], m * bx.y1 + p0[1]);
    let rect = [xa.min(xb), xa.max(xb), ya.min(yb), ya.max(yb)];
    let narrow = MIN_RECT_CELLS * sat.cell();
    if a == 0.0 || !(rect[1] - rect[0] > narrow && rect[3] - rect[2] > narrow) {
        return None;
    }
    wk.mapped.clear();
    wk.mapped.extend(v.iter().map(|p| [a * p[0], a * p[1]]));
    wk.closed += 1;
    let (u, memo, boxes) = (&wk.mapped, &mut wk.corners, &mut wk.disc_boxes);
    let poly = [a.to_bits(), half.to_bits()];
    let corner = |q| memo.get(q, poly, || sat.over_polygon(q, u));
    let jac = (a * m).powi(2);
    let total = match disc {
        Some((r, tol))
            if !corners(bx)
                .iter()
                .all(|w| w[0] * w[0] + w[1] * w[1] <= r * r) =>
        {
            *boxes += 1;
            sat.disc_rect_polygon(rect, (p0, m.abs() * r), u, tol * jac, corner)
        }
        _ => sat.rect_polygon_by(rect, u, corner),
    };
    Some(total / jac)
}

/// The box's corners.
fn corners(bx: QBox) -> [Pt; 4] {
    [
        [bx.x0, bx.y0],
        [bx.x1, bx.y0],
        [bx.x0, bx.y1],
        [bx.x1, bx.y1],
    ]
}

/// Is the cell inside the aperture's preimage (centre `g`, radius or half-side `rad`)?
fn cell_inside(chan: &Chan, shape: Aperture, g: Pt, rad: f64) -> bool {
    chan.cell.iter().all(|p| {
        let (dx, dy) = (p[0] - g[0], p[1] - g[1]);
        match shape {
            Aperture::Circle => dx * dx + dy * dy <= rad * rad,
            Aperture::Square => dx.abs() <= rad && dy.abs() <= rad,
        }
    })
}

/// Is the square of centre `g` and half-side `h` inside the (convex) cell?
fn square_inside(chan: &Chan, g: Pt, h: f64) -> bool {
    let cell = &chan.cell;
    let n = cell.len();
    [[-h, -h], [h, -h], [h, h], [-h, h]].iter().all(|d| {
        let p = [g[0] + d[0], g[1] + d[1]];
        (0..n).all(|k| {
            let (a, b) = (cell[k], cell[(k + 1) % n]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0
        })
    })
}

/// The square [−h, h]² counter-clockwise, into `out`.
fn square(h: f64, out: &mut [Pt; 4]) -> &[Pt] {
    *out = [[-h, -h], [h, -h], [h, h], [-h, h]];
    &out[..]
}

/// What the closed form needs of a lens on a fronto-parallel plane at depth z: the lens
/// centre c, its type's α, its image's offset e, B = 1 − z/F + z/L and g = z/L.
#[derive(Clone, Copy)]
pub(super) struct Lens<'a> {
    pub chan: &'a Chan<'a>,
    pub sat: &'a SatTable,
    pub c: Pt,
    pub alpha: f64,
    pub e: Pt,
    pub bb: f64,
    pub g: f64,
}

/// Outer-s box (σ = s − img): the polygon is the cell ∩ the aperture's preimage centred
/// σ/α of radius ρ/|α|. P = a ξ − B (L/v) σ − g c with a = B (L/v) α − g.
pub(super) fn outer_s_box(lens: &Lens, bx: QBox, wk: &mut Work) -> Option<f64> {
    let Lens {
        chan,
        sat,
        c,
        alpha,
        bb,
        g,
        ..
    } = *lens;
    let lv = 1.0 / chan.vl;
    // A disc is drawn as its equal-area polygon (`Chan::ngon`) by the quadrature: the
    // cell is inside it when inside its inscribed circle.
    let rad = chan.vl * chan.r_ap / alpha.abs();
    let inner = match chan.shape {
        Aperture::Circle => {
            let n = chan.ngon.len() as f64;
            rad * chan.ngon[0][0] * (std::f64::consts::PI / n).cos()
        }
        Aperture::Square => rad,
    };
    let centre = |s: Pt| [s[0] / alpha, s[1] / alpha];
    let p0 = [-g * c[0], -g * c[1]];
    let pts = corners(bx);
    if pts
        .iter()
        .all(|&s| cell_inside(chan, chan.shape, centre(s), inner))
    {
        let mv = Moving {
            v: &chan.cell,
            half: 0.0,
            a: bb * lv * alpha - g,
            m: -bb * lv,
            p0,
        };
        return integrate(sat, &mv, bx, None, wk);
    }
    if chan.shape == Aperture::Square && pts.iter().all(|&s| square_inside(chan, centre(s), rad)) {
        // ξ = σ/α + η: P = a η + (a/α − B L/v) σ − g c = a η − (g/α) σ − g c.
        let mut buf = [[0.0; 2]; 4];
        let mv = Moving {
            v: square(rad, &mut buf),
            half: rad,
            a: bb * lv * alpha - g,
            m: -g / alpha,
            p0,
        };
        return integrate(sat, &mv, bx, None, wk);
    }
    None
}

/// Outer-w box (main-lens points w, a rectangle inside the aperture): the polygon is the
/// cell ∩ the pixel's preimage, the square of centre ((v/L) w − e)/α and half-side
/// μ/(2|α|) (the whole cell when α = 0). P = B w − g (c + ξ).
pub(super) fn outer_w_box(
    lens: &Lens,
    bx: QBox,
    disc: Option<(f64, f64)>,
    wk: &mut Work,
) -> Option<f64> {
    let Lens {
        chan,
        sat,
        c,
        alpha,
        e,
        bb,
        g,
    } = *lens;
    let p0 = [-g * c[0], -g * c[1]];
    let whole = Moving {
        v: &chan.cell,
        half: 0.0,
        a: -g,
        m: bb,
        p0,
    };
    if alpha == 0.0 {
        return integrate(sat, &whole, bx, disc, wk);
    }
    let h = chan.ch.mu / (2.0 * alpha.abs());
    let centre = |w: Pt| {
        [
            (chan.vl * w[0] - e[0]) / alpha,
            (chan.vl * w[1] - e[1]) / alpha,
        ]
    };
    let pts = corners(bx);
    if pts
        .iter()
        .all(|&w| cell_inside(chan, Aperture::Square, centre(w), h))
    {
        return integrate(sat, &whole, bx, disc, wk);
    }
    if pts.iter().all(|&w| square_inside(chan, centre(w), h)) {
        // ξ = centre(w) + η: P = B w − g c − g ((v/L) w − e)/α − g η.
        let mut buf = [[0.0; 2]; 4];
        let mv = Moving {
            v: square(h, &mut buf),
            half: h,
            a: -g,
            m: bb - g * chan.vl / alpha,
            p0: [p0[0] + g * e[0] / alpha, p0[1] + g * e[1] / alpha],
        };
        return integrate(sat, &mv, bx, disc, wk);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::super::chan::{Chan, Work};
    use super::super::general::{lens_tol, pixel_value, top_value, Pixels};
    use super::super::sat::SatTable;
    use crate::imaging::scene::{Scene, Surface};
    use crate::imaging::texture::{ImageTexture, Texture};
    use crate::model::design::{Channel, Design};

    /// A fronto-parallel plane at depth `z` under `tex` (background 0.2).
    fn fronto(tex: Texture, z: f64) -> Scene {
        Scene::new(tex, Surface::Plane { z0: z, g: [0.0; 2] }, 0.2).unwrap()
    }

    /// The value of pixel (a, b) of channel `ch` at `tol`, the interior in closed form on
    /// `sat` (None: the quadrature alone), with `wk`'s memo and counters.
    fn value(
        (design, ch, scene): (&Design, &Channel, &Scene),
        (tol, sat): (f64, Option<&SatTable>),
        (a, b): (u32, u32),
        wk: &mut Work,
    ) -> f64 {
        let chan = Chan::new(design, ch, tol);
        let px = Pixels {
            design,
            chan: &chan,
            scene,
            tol: lens_tol(&chan, scene, tol),
            weighting: None,
            sat,
        };
        pixel_value(&px, a, b, wk)
    }

    /// A random n × n image over [−w, w]² (a fixed linear congruential stream).
    fn image(n: usize, w: f64) -> Texture {
        let mut x = 12345u64;
        let v: Vec<f64> = (0..n * n)
            .map(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 11) as f64 / (1u64 << 53) as f64
            })
            .collect();
        Texture::Image(Box::new(
            ImageTexture::new(&v, n, n, [-w, w, -w, w]).unwrap(),
        ))
    }

    /// Pixels of `preset` around its sensor's centre, by the closed form and by the
    /// quadrature alone, at `tol`: within `within` of white, and the closed form taken.
    /// (On an image the quadrature's own error is the bound: its boxes keep kinks it does
    /// not cut, where hex vertices cross the texture's lines; the closed form is checked
    /// against an independent sum in `sat`'s tests.)
    fn agree(preset: &str, z: f64, tex: Texture, (tol, within): (f64, f64)) {
        let design = crate::model::presets::preset(preset).unwrap();
        let scene = fronto(tex, z);
        let sat = SatTable::of(&scene.texture).unwrap().unwrap();
        for ch in &design.channels {
            let (rows, cols) = super::super::raw_shape(ch);
            let white =
                top_value(&Chan::new(&design, ch, tol), &scene) / scene.texture.max_albedo();
            let run = |sat: Option<&SatTable>| {
                let mut wk = Work::new(true);
                // A block of 3 × 2 pixels 5 apart, near the R12's lens images' centres.
                let v: Vec<f64> = (0..6u32)
                    .map(|i| {
                        let a = cols as u32 / 2 + 5 * (i % 3);
                        let b = rows as u32 / 2 + 5 * (i / 3);
                        value((&design, ch, &scene), (tol, sat), (a, b), &mut wk)
                    })
                    .collect();
                (v, wk.closed, wk.evals)
            };
            let (new, closed, e_new) = run(Some(&sat));
            let (old, none, e_old) = run(None);
            assert!(closed > 0 && none == 0, "{preset}: {closed} closed boxes");
            assert!(
                e_new < e_old,
                "{preset}: {e_new} evaluations against {e_old}"
            );
            let worst = new
                .iter()
                .zip(&old)
                .map(|(a, b)| (a - b).abs() / white)
                .fold(0.0, f64::max);
            assert!(worst <= within, "{preset}: {worst:e} of white");
        }
    }

    /// The corners' memo changes nothing and is used: a block of 6 × 6 neighbouring pixels
    /// of lytro-illum (α = 0: a pixel's whole box in closed form) taken in order by one
    /// worker, whose memo hits, and each by a fresh worker, which cannot hit, agree bit for
    /// bit; and more than half the first worker's corners came from its memo (6 × 6 pixels
    /// have 7 × 7 corners for 144 look-ups where the boxes are whole).
    #[test]
    fn corner_memo_is_bit_for_bit_and_hits() {
        let design = crate::model::presets::preset("lytro-illum").unwrap();
        let scene = fronto(image(64, 40.0), 1000.0);
        let sat = SatTable::of(&scene.texture).unwrap().unwrap();
        let ch = &design.channels[0];
        let (rows, cols) = super::super::raw_shape(ch);
        let mut wk = Work::new(true);
        for b in (rows / 2) as u32..(rows / 2 + 6) as u32 {
            for a in (cols / 2) as u32..(cols / 2 + 6) as u32 {
                let at =
                    |wk: &mut Work| value((&design, ch, &scene), (1e-3, Some(&sat)), (a, b), wk);
                let shared = at(&mut wk);
                let mut fresh = Work::new(true);
                let alone = at(&mut fresh);
                assert_eq!(shared.to_bits(), alone.to_bits(), "pixel ({a}, {b})");
                assert_eq!(fresh.corners.hits, 0);
            }
        }
        let m = &wk.corners;
        assert!(
            m.looks >= 4 * 36 && 2 * m.hits > m.looks,
            "{} of {}",
            m.hits,
            m.looks
        );
    }

    /// Boxes the aperture's circle cuts ([`SatTable::disc_rect_polygon`]): 20 × 20 pixels
    /// of lytro-illum at its sensor's centre (α = 0, a circular aperture: every lens
    /// image's rim), a random 512² image over 500 mm at 1 m, by the closed form at tol
    /// 10⁻⁶ and by the quadrature alone at 10⁻⁹, within 2 × tol: the quadrature's own
    /// residual on this texture is about 4·10⁻⁷ of white (measured on 90 × 90 pixels at
    /// 10⁻⁸ / 10⁻¹⁰, on pixels with no box cut by the circle, where the two routes are
    /// the rectangle's closed form and the quadrature; on those cut by it the closed form
    /// agrees with an independent fine sum of the region). Measured here: 1.5·10⁻⁷; with
    /// the arcs not cut at K's kinks, 2.3·10⁻³ (a kink near an arc's end, between the
    /// Gauss nodes); with a box's edge tangent to the circle taken as two crossings,
    /// 1.6·10⁻⁵ (on 90 × 90 pixels).
    #[test]
    fn disc_boxes_are_the_quadrature() {
        let design = crate::model::presets::preset("lytro-illum").unwrap();
        let scene = fronto(image(512, 250.0), 1000.0);
        let sat = SatTable::of(&scene.texture).unwrap().unwrap();
        let ch = &design.channels[0];
        let (rows, cols) = super::super::raw_shape(ch);
        let white = top_value(&Chan::new(&design, ch, 1e-6), &scene) / scene.texture.max_albedo();
        let on = (&design, ch, &scene);
        let (mut worst, mut wk) = (0.0f64, Work::new(true));
        for b in (rows / 2) as u32..(rows / 2 + 20) as u32 {
            for a in (cols / 2) as u32..(cols / 2 + 20) as u32 {
                let new = value(on, (1e-6, Some(&sat)), (a, b), &mut wk);
                let old = value(on, (1e-9, None), (a, b), &mut Work::new(true));
                worst = worst.max((new - old).abs() / white);
            }
        }
        let boxes = wk.disc_boxes;
        assert!(boxes > 50, "{boxes} boxes cut by the circle");
        assert!(worst < 2e-6, "{worst:e} of white");
    }

    /// raytrix-r12 (hex cells, a circular aperture, the sensor layout, outer s: the cell
    /// inside the aperture's preimage), lytro-illum (α = 0, outer w: the whole cell) and
    /// the seed (rect cells, a square aperture, both rules), on a 6 × 6 image (few texture
    /// lines) and on a constant. Measured: the R12's constant 2e-16 of white, its image
    /// 6.8e-9 (the quadrature's residual at 1e-8; the same at 1e-10 on 24 pixels); the
    /// Illum's image 3.0e-10 at tol 1e-9 (3.1e-12 before its rim boxes, those the
    /// aperture's circle cuts, took the closed form too: their arcs are a 1-D rule to tol),
    /// the seed's 6e-15 and 1.8e-14 (its two halves).
    #[test]
    fn closed_form_is_the_quadrature_at_a_tight_tolerance() {
        agree("raytrix-r12", 1000.0, Texture::Constant(0.7), (1e-8, 1e-9));
        agree("raytrix-r12", 1000.0, image(6, 40.0), (1e-8, 2e-8));
        agree("lytro-illum", 500.0, image(6, 40.0), (1e-9, 1e-9));
        agree("seed", 900.0, image(6, 6.0), (1e-10, 1e-12));
    }
}
