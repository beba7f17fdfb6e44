//! Convex polygons in the plane: area, centroid, clipping by half-planes (Sutherland–
//! Hodgman), the building blocks of the 2-D forward model (docs/render.md).

/// A point (x, y).
pub type Pt = [f64; 2];

/// The angles (radians) of the points `pts` seen from `c`, as the range [lo, hi] they span
/// unwrapped around the first point's angle: lo ≤ that angle ≤ hi, hi − lo < 2π. For points
/// of a convex set that does not contain `c`, the set's whole angular extent.
pub fn angular_span(pts: &[Pt], c: Pt) -> (f64, f64) {
    use std::f64::consts::PI;
    let Some(first) = pts.first() else {
        return (0.0, 0.0);
    };
    let a0 = (first[1] - c[1]).atan2(first[0] - c[0]);
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for p in &pts[1..] {
        let mut d = (p[1] - c[1]).atan2(p[0] - c[0]) - a0;
        while d > PI {
            d -= 2.0 * PI;
        }
        while d < -PI {
            d += 2.0 * PI;
        }
        lo = lo.min(d);
        hi = hi.max(d);
    }
    (a0 + lo, a0 + hi)
}

/// Signed area (positive for counter-clockwise vertices; shoelace formula).
pub fn signed_area(p: &[Pt]) -> f64 {
    let n = p.len();
    if n < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for i in 0..n {
        let a = p[i];
        let b = p[(i + 1) % n];
        s += a[0] * b[1] - a[1] * b[0];
    }
    0.5 * s
}

/// Signed area taken about the first vertex (a fan of triangles from it): the same value
/// as [`signed_area`] up to rounding, more precise far from the origin.
pub fn signed_area_about_first(p: &[Pt]) -> f64 {
    if p.len() < 3 {
        return 0.0;
    }
    let o = p[0];
    let mut a2 = 0.0;
    for i in 1..p.len() - 1 {
        a2 += (p[i][0] - o[0]) * (p[i + 1][1] - o[1]) - (p[i + 1][0] - o[0]) * (p[i][1] - o[1]);
    }
    0.5 * a2
}

/// Every edge of the closed polygon `p` (n ≥ 1) relative to its first vertex (for precision
/// far from the origin), with the edge's cross product x0 y1 − x1 y0: the shoelace sums'
/// common loop (`centroid`, `moments`).
#[inline]
fn shoelace(p: &[Pt], mut f: impl FnMut(Pt, Pt, f64)) {
    let (n, o) = (p.len(), p[0]);
    for i in 0..n {
        let (x0, y0) = (p[i][0] - o[0], p[i][1] - o[1]);
        let q = p[(i + 1) % n];
        let (x1, y1) = (q[0] - o[0], q[1] - o[1]);
        f([x0, y0], [x1, y1], x0 * y1 - x1 * y0);
    }
}

/// Centroid of a polygon of non-zero area (the vertex mean when the area vanishes).
pub fn centroid(p: &[Pt]) -> Pt {
    let n = p.len();
    if n == 0 {
        return [0.0, 0.0];
    }
    let o = p[0];
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    shoelace(p, |[x0, y0], [x1, y1], c| {
        a += c;
        cx += (x0 + x1) * c;
        cy += (y0 + y1) * c;
    });
    if a.abs() > 0.0 {
        [o[0] + cx / (3.0 * a), o[1] + cy / (3.0 * a)]
    } else {
        let m = p.iter().fold([0.0, 0.0], |s, v| [s[0] + v[0], s[1] + v[1]]);
        [m[0] / n as f64, m[1] / n as f64]
    }
}

/// The signed area and first moments [∬ X, ∬ Y] of a polygon (zero for fewer than three
/// vertices; the shoelace sums about its first vertex, for precision far from the origin).
pub fn area_moments(p: &[Pt]) -> (f64, [f64; 2]) {
    if p.len() < 3 {
        return (0.0, [0.0; 2]);
    }
    let o = p[0];
    let (mut a, mut sx, mut sy) = (0.0, 0.0, 0.0);
    shoelace(p, |[x0, y0], [x1, y1], c| {
        a += c;
        sx += (x0 + x1) * c;
        sy += (y0 + y1) * c;
    });
    let area = 0.5 * a;
    (area, [sx / 6.0 + area * o[0], sy / 6.0 + area * o[1]])
}

/// Area, centroid and central second moments [∫(x − cx)², ∫(x − cx)(y − cy), ∫(y − cy)²]
/// of a counter-clockwise polygon (zero area: the vertex mean and zero moments).
pub fn moments(p: &[Pt]) -> (f64, Pt, [f64; 3]) {
    let n = p.len();
    if n < 3 {
        return (0.0, centroid(p), [0.0; 3]);
    }
    let o = p[0];
    let (mut a, mut sx, mut sy, mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    shoelace(p, |[x0, y0], [x1, y1], c| {
        a += c;
        sx += (x0 + x1) * c;
        sy += (y0 + y1) * c;
        sxx += (x0 * x0 + x0 * x1 + x1 * x1) * c;
        syy += (y0 * y0 + y0 * y1 + y1 * y1) * c;
        sxy += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * c;
    });
    let area = 0.5 * a;
    if area.abs() <= 0.0 {
        return (0.0, centroid(p), [0.0; 3]);
    }
    let (mx, my) = (sx / (3.0 * a), sy / (3.0 * a));
    let m = [
        sxx / 12.0 - area * mx * mx,
        sxy / 24.0 - area * mx * my,
        syy / 12.0 - area * my * my,
    ];
    (area, [o[0] + mx, o[1] + my], m)
}

/// Keep the part of `src` where `f(point) >= 0`, `f` affine (a half-plane), into `out`.
pub fn clip_into(src: &[Pt], out: &mut Vec<Pt>, f: impl Fn(Pt) -> f64) {
    out.clear();
    let n = src.len();
    if n == 0 {
        return;
    }
    let mut prev = src[n - 1];
    let mut fp = f(prev);
    for &cur in src {
        let fc = f(cur);
        if fc >= 0.0 {
            if fp < 0.0 {
                out.push(cut(prev, cur, fp, fc));
            }
            out.push(cur);
        } else if fp >= 0.0 {
            out.push(cut(prev, cur, fp, fc));
        }
        prev = cur;
        fp = fc;
    }
}

/// Keep the part of the convex polygon `src` where `f(point) >= 0`, `f` affine, into the
/// fixed buffer `out`; returns the number of vertices written (at most `out.len()`, the rest
/// dropped). Unlike [`clip_into`] the output starts at `src[0]` when it is kept, and a
/// vertex on the line is kept once and makes no extra intersection.
pub fn clip_keep(src: &[Pt], out: &mut [Pt], f: impl Fn(Pt) -> f64) -> usize {
    let (cap, m) = (out.len(), src.len());
    let mut k = 0;
    for i in 0..m {
        let (a, b) = (src[i], src[(i + 1) % m]);
        let (fa, fb) = (f(a), f(b));
        if fa >= 0.0 && k < cap {
            out[k] = a;
            k += 1;
        }
        if ((fa > 0.0 && fb < 0.0) || (fa < 0.0 && fb > 0.0)) && k < cap {
            out[k] = cut(a, b, fa, fb);
            k += 1;
        }
    }
    k
}

#[inline]
fn cut(a: Pt, b: Pt, fa: f64, fb: f64) -> Pt {
    let t = fa / (fa - fb);
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// Signed area of the part of `p` at or above the line y = c: the polygon clipped to that
/// half-plane as [`clip_into`] does, its shoelace sum taken on the fly about (ox, c) (a
/// point near the polygon, for precision), without building the clipped polygon.
pub fn area_above(p: &[Pt], c: f64, ox: f64) -> f64 {
    let n = p.len();
    if n < 3 {
        return 0.0;
    }
    let (mut s, mut first, mut last) = (0.0, None::<Pt>, [0.0, 0.0]);
    let mut emit = |q: Pt| {
        let q = [q[0] - ox, q[1] - c];
        match first {
            None => first = Some(q),
            Some(_) => s += last[0] * q[1] - last[1] * q[0],
        }
        last = q;
    };
    let mut prev = p[n - 1];
    let mut fp = prev[1] - c;
    for &cur in p {
        let fc = cur[1] - c;
        if fc >= 0.0 {
            if fp < 0.0 {
                emit(cut(prev, cur, fp, fc));
            }
            emit(cur);
        } else if fp >= 0.0 {
            emit(cut(prev, cur, fp, fc));
        }
        prev = cur;
        fp = fc;
    }
    if let Some(f) = first {
        s += last[0] * f[1] - last[1] * f[0];
    }
    0.5 * s
}

/// Clip `poly` in place to the axis-aligned box [x0, x1] × [y0, y1] (`tmp` is scratch).
pub fn clip_box(poly: &mut Vec<Pt>, tmp: &mut Vec<Pt>, x0: f64, x1: f64, y0: f64, y1: f64) {
    clip_into(poly, tmp, |p| p[0] - x0);
    clip_into(tmp, poly, |p| x1 - p[0]);
    clip_into(poly, tmp, |p| p[1] - y0);
    clip_into(tmp, poly, |p| y1 - p[1]);
}

/// Bounding box (x0, x1, y0, y1) of a non-empty point set.
pub fn bounds(p: &[Pt]) -> (f64, f64, f64, f64) {
    p.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), v| (a.min(v[0]), b.max(v[0]), c.min(v[1]), d.max(v[1])),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moments_of_a_rectangle_and_a_triangle() {
        // A 2 x 4 rectangle centred at (5, -3): area 8, central moments w^3 h/12, 0, w h^3/12.
        let r = [[4.0, -5.0], [6.0, -5.0], [6.0, -1.0], [4.0, -1.0]];
        let (a, c, m) = moments(&r);
        assert!(
            (a - 8.0).abs() < 1e-12 && (c[0] - 5.0).abs() < 1e-12 && (c[1] + 3.0).abs() < 1e-12
        );
        assert!(
            (m[0] - 8.0 / 3.0).abs() < 1e-12
                && m[1].abs() < 1e-12
                && (m[2] - 32.0 / 3.0).abs() < 1e-12
        );
        // The triangle (0,0), (1,0), (0,1): area 1/2, centroid (1/3, 1/3), ∫x² = 1/12,
        // ∫xy = 1/24 (so central 1/36 and −1/72).
        let (a, c, m) = moments(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        assert!((a - 0.5).abs() < 1e-15 && (c[0] - 1.0 / 3.0).abs() < 1e-15);
        assert!((m[0] - 1.0 / 36.0).abs() < 1e-15 && (m[1] + 1.0 / 72.0).abs() < 1e-15);
        assert!((m[2] - 1.0 / 36.0).abs() < 1e-15);
        // First moments: area × centroid, for the rectangle (8 × (5, −3)) and clockwise
        // (negative area, the same centroid).
        let (a, f) = area_moments(&r);
        assert!((a - 8.0).abs() < 1e-12 && (f[0] - 40.0).abs() < 1e-12);
        assert!((f[1] + 24.0).abs() < 1e-12);
        let cw: Vec<Pt> = r.iter().rev().copied().collect();
        let (a, f) = area_moments(&cw);
        assert!((a + 8.0).abs() < 1e-12 && (f[0] + 40.0).abs() < 1e-12);
        assert!((f[1] - 24.0).abs() < 1e-12);
        assert_eq!(area_moments(&r[..2]), (0.0, [0.0; 2]));
    }

    #[test]
    fn area_above_is_the_clipped_area() {
        // A pentagon (either orientation) against lines through, above and below it.
        let p = vec![
            [0.3, -1.0],
            [2.1, -0.4],
            [2.6, 1.2],
            [1.0, 2.2],
            [-0.7, 0.5],
        ];
        let q: Vec<Pt> = p.iter().rev().copied().collect();
        for poly in [&p, &q] {
            for c in [-2.0, -1.0, -0.7, 0.0, 0.5, 1.9, 2.2, 3.0] {
                let mut clipped = Vec::new();
                clip_into(poly, &mut clipped, |v| v[1] - c);
                let want = signed_area(&clipped);
                let got = area_above(poly, c, 0.37);
                assert!((got - want).abs() < 1e-14, "{c}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn clip_keep_keeps_vertices_on_the_line_once() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        let mut out = [[0.0; 2]; 8];
        // x ≤ 1: two cuts, starting at the first vertex.
        let n = clip_keep(&sq, &mut out, |q| 1.0 - q[0]);
        assert_eq!(&out[..n], &[[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 2.0]]);
        // x + y ≤ 2 passes through two corners: kept once each, no cut points.
        let n = clip_keep(&sq, &mut out, |q| 2.0 - q[0] - q[1]);
        assert_eq!(&out[..n], &[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
        assert_eq!(signed_area_about_first(&out[..n]), 2.0);
        assert_eq!(signed_area_about_first(&sq), signed_area(&sq));
        // A full buffer drops the rest.
        let mut small = [[0.0; 2]; 2];
        assert_eq!(clip_keep(&sq, &mut small, |_| 1.0), 2);
    }

    #[test]
    fn square_area_centroid_and_clip() {
        let sq = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(signed_area(&sq), 4.0);
        assert_eq!(centroid(&sq), [1.0, 1.0]);
        let mut p = sq.clone();
        let mut t = Vec::new();
        clip_box(&mut p, &mut t, 0.5, 1.5, -1.0, 1.0);
        assert!((signed_area(&p) - 1.0).abs() < 1e-15);
        let mut out = Vec::new();
        clip_into(&sq, &mut out, |q| q[0] + q[1] - 2.0); // upper-right triangle
        assert!((signed_area(&out) - 2.0).abs() < 1e-15);
    }
}
