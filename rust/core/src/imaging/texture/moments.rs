//! First moments of a texture over a convex polygon, [∬ T, ∬ T X, ∬ T Y], exact: with
//! them a density linear over the polygon is integrated exactly, which is how the general
//! route takes a slanted plane's ray map (docs/render.md, "Slanted planes").
//!
//! Image (piecewise constant on cells, its mean outside): Green's theorem as for
//! [`Texture::integral`], ∬ T X = ∮ G₁ dY and ∬ T Y = ∮ Y G dY, with G(X) = ∫ T dX' and
//! G₁(X) = ∫ T X' dX' from the grid's left edge along a row. On a piece of an edge inside
//! one cell (value v, X and Y linear in the edge's parameter) G is linear and G₁ quadratic
//! in it, so the piece's means are closed forms: G₁(X_m) + v ΔX²/24 and
//! Y_m G(X_m) + v ΔX ΔY / 12 (ΔX, ΔY the piece's extent).

use super::{ImageTexture, Texture};
use crate::imaging::grid::walk;
use crate::infra::polygon::{area_moments, Pt};

impl Texture {
    /// Whether [`Texture::moments`] has this texture's moments.
    pub(crate) fn has_moments(&self) -> bool {
        matches!(self, Texture::Constant(_) | Texture::Image(_))
    }

    /// [∬ T, ∬ T X, ∬ T Y] over a polygon (signed by its orientation); None for the
    /// textures without them here ([`Texture::has_moments`]), or when an image's second
    /// row sums cannot be allocated.
    pub(crate) fn moments(&self, poly: &[Pt]) -> Option<[f64; 3]> {
        match self {
            Texture::Constant(c) => {
                let (a, m) = area_moments(poly);
                Some([c * a, c * m[0], c * m[1]])
            }
            Texture::Image(im) => im.moments(poly),
            _ => None,
        }
    }
}

impl ImageTexture {
    /// Bottom-up row b: `[b * (cols + 1) + i]` = Σ_{i' < i} T ∫ u du over column i', u = X − X0
    /// (built on first use: only slanted planes need it).
    fn second_sums(&self) -> Option<&[f64]> {
        self.prefix_u
            .get_or_init(|| {
                let g = &self.grid;
                let (rows, cols, hx) = (g.rows, g.cols, g.hx);
                let mut q = crate::infra::memory::try_vec(
                    "the texture's moment sums",
                    rows * (cols + 1),
                    0.0,
                )
                .ok()?;
                for b in 0..rows {
                    let (src, p) = (
                        &self.values[b * cols..(b + 1) * cols],
                        &mut q[b * (cols + 1)..(b + 1) * (cols + 1)],
                    );
                    let mut acc = 0.0;
                    for (i, &v) in src.iter().enumerate() {
                        p[i] = acc;
                        let (u0, u1) = (i as f64 * hx, (i + 1) as f64 * hx);
                        acc += v * 0.5 * (u1 * u1 - u0 * u0);
                    }
                    p[cols] = acc;
                }
                Some(q)
            })
            .as_deref()
    }

    /// [∬ T, ∬ T X, ∬ T Y] over a polygon: the module's doc.
    fn moments(&self, poly: &[Pt]) -> Option<[f64; 3]> {
        let q = self.second_sums()?;
        let g = &self.grid;
        let (x, y) = g.lines();
        let cols = g.cols;
        // On bottom-up row r at u = X − X0 in column c: (the cell's value, G, G₁ in u).
        let cell = |r: i64, c: i64, u: f64| -> (f64, f64, f64) {
            let m = self.mean;
            if r < 0 || r >= g.rows as i64 || c < 0 {
                return (m, m * u, 0.5 * m * u * u);
            }
            let r = r as usize;
            let (p, s) = (
                &self.prefix[r * (cols + 1)..(r + 1) * (cols + 1)],
                &q[r * (cols + 1)..(r + 1) * (cols + 1)],
            );
            let (i, v) = if c as usize >= cols {
                (cols, m)
            } else {
                (c as usize, self.values[r * cols + c as usize])
            };
            let ui = i as f64 * g.hx;
            (v, p[i] + v * (u - ui), s[i] + 0.5 * v * (u * u - ui * ui))
        };
        let n = poly.len();
        let (mut m0, mut mu, mut my) = (0.0, 0.0, 0.0);
        for k in 0..n {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            if dy == 0.0 {
                continue;
            }
            let (mut e0, mut eu, mut ey) = (0.0, 0.0, 0.0);
            walk(x, y, a, b, |c, r, t0, t1| {
                let (tm, dt) = (0.5 * (t0 + t1), t1 - t0);
                let um = a[0] + tm * dx - g.x0;
                let ym = a[1] + tm * dy;
                let (v, gm, g1m) = cell(r, c, um);
                let du = dt * dx;
                e0 += dt * gm;
                eu += dt * (g1m + v * du * du / 24.0);
                ey += dt * (ym * gm + v * du * (dt * dy) / 12.0);
            });
            m0 += e0 * dy;
            mu += eu * dy;
            my += ey * dy;
        }
        // ∬ T X = ∬ T u + X0 ∬ T.
        Some([m0, mu + g.x0 * m0, my])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::infra::polygon::clip_box;
    use crate::infra::random::splitmix64_stream;

    /// The independent route: the polygon clipped to every cell of the image (and to the
    /// four regions beyond it, where T is the mean), each part's area and centroid by the
    /// shoelace sums, weighted by its value.
    fn by_cells(im: &ImageTexture, poly: &[Pt]) -> [f64; 3] {
        let g = &im.grid;
        let big = 1e9;
        let mut acc = [0.0; 3];
        let mut add = |v: f64, x0: f64, x1: f64, y0: f64, y1: f64| {
            let (mut p, mut tmp) = (poly.to_vec(), Vec::new());
            clip_box(&mut p, &mut tmp, x0, x1, y0, y1);
            let (a, m) = area_moments(&p);
            acc[0] += v * a;
            acc[1] += v * m[0];
            acc[2] += v * m[1];
        };
        for b in 0..g.rows {
            for i in 0..g.cols {
                let (x0, y0) = (g.x0 + i as f64 * g.hx, g.y0 + b as f64 * g.hy);
                add(im.values[b * g.cols + i], x0, x0 + g.hx, y0, y0 + g.hy);
            }
        }
        let m = im.mean;
        add(m, -big, g.x0, -big, big);
        add(m, g.x1, big, -big, big);
        add(m, g.x0, g.x1, -big, g.y0);
        add(m, g.x0, g.x1, g.y1, big);
        acc
    }

    #[test]
    fn image_moments_are_the_sum_over_its_cells() {
        let mut r = splitmix64_stream(11);
        let mut u = move || (r.next().unwrap() >> 11) as f64 / (1u64 << 53) as f64;
        let (rows, cols) = (7, 9);
        let v: Vec<f64> = (0..rows * cols).map(|_| u()).collect();
        let ext = [101.0, 104.6, -3.0, -0.2];
        let im = ImageTexture::new(&v, rows, cols, ext).unwrap();
        let tex = Texture::Image(Box::new(im.clone()));
        for trial in 0..200 {
            // A random convex polygon (points on an ellipse, counter-clockwise) inside,
            // across or outside the image.
            let c = [100.0 + 6.0 * u(), -4.5 + 6.0 * u()];
            let (ra, rb) = (0.05 + 2.0 * u(), 0.05 + 2.0 * u());
            let k = 3 + (u() * 6.0) as usize;
            let mut th: Vec<f64> = (0..k).map(|_| u() * std::f64::consts::TAU).collect();
            th.sort_by(f64::total_cmp);
            let poly: Vec<Pt> = th
                .iter()
                .map(|t| [c[0] + ra * t.cos(), c[1] + rb * t.sin()])
                .collect();
            let got = tex.moments(&poly).unwrap();
            let want = by_cells(&im, &poly);
            let (a, _) = area_moments(&poly);
            for j in 0..3 {
                let scale = a.abs() * (1.0 + [1.0, c[0].abs(), c[1].abs()][j]);
                assert!(
                    (got[j] - want[j]).abs() <= 1e-12 * scale,
                    "trial {trial} moment {j}: {} against {}",
                    got[j],
                    want[j]
                );
            }
            // ∬ T agrees with the texture's own integral.
            let whole = tex.integral(&poly, a, 1.0, &mut Default::default());
            assert!((got[0] - whole).abs() <= 1e-12 * a.abs());
            // Reversed orientation: every moment changes sign.
            let rev: Vec<Pt> = poly.iter().rev().copied().collect();
            let back = tex.moments(&rev).unwrap();
            for j in 0..3 {
                assert!((back[j] + got[j]).abs() <= 1e-12 * a.abs() * (1.0 + c[0].abs()));
            }
        }
    }

    #[test]
    fn constant_moments_are_the_polygons_and_others_have_none() {
        let tri = [[1.0, 0.0], [4.0, 0.0], [1.0, 3.0]];
        let m = Texture::Constant(0.5).moments(&tri).unwrap();
        // Area 4.5, centroid (2, 1).
        assert!((m[0] - 2.25).abs() < 1e-14);
        assert!((m[1] - 4.5).abs() < 1e-14);
        assert!((m[2] - 2.25).abs() < 1e-14);
        let s = Texture::Sinusoid {
            frequency: 1.0,
            mean: 0.5,
            amplitude: 0.2,
            phase: 0.0,
        };
        assert!(!s.has_moments() && s.moments(&tri).is_none());
    }
}
