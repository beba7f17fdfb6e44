//! Closed forms of the general route on a fronto-parallel plane (docs/render.md, "The
//! interior in closed form"): the integral of an image (or constant) texture over a
//! rectangle of translates of a fixed polygon, ∫_{Q ∈ R} ∫_{u ∈ U} T(Q + u) du dQ, from the
//! texture's summed-area function S by Green's theorem: a cost in the texture cells the
//! polygon's translated boundary crosses, not in those its footprint covers.

use crate::imaging::grid::{walk, Lines};
use crate::imaging::texture::{ImageTexture, Texture};
use crate::infra::error::Result;
use crate::infra::polygon::{signed_area, Pt};

/// T = mean + T', T' an image's deviation from its mean (zero beyond the array). `n` holds
/// S(X, Y) = ∫∫_{X' < X, Y' < Y} T' at the grid's nodes (bilinear between them, constant
/// beyond the array in Y and beyond its right edge in X, zero to its left and below);
/// `cum` holds S1(X, Y) = ∫_{X' < X} S(X', Y) dX' at the nodes (the trapezoid rule of S
/// along each node row, exact as S is linear there).
pub(crate) struct SatTable {
    mean: f64,
    x0: f64,
    y0: f64,
    hx: f64,
    hy: f64,
    cols: usize,
    rows: usize,
    n: Vec<f64>,
    cum: Vec<f64>,
}

/// 2-point Gauss–Legendre on [0, 1]: exact for the cubics S1 is along a segment in a cell.
const G2_LO: f64 = 0.211_324_865_405_187_1;
const G2_HI: f64 = 0.788_675_134_594_812_9;

impl SatTable {
    /// The table of a texture the closed form handles: an image or a constant.
    pub(crate) fn of(texture: &Texture) -> Result<Option<SatTable>> {
        Ok(match texture {
            Texture::Constant(c) => Some(SatTable::constant(*c)),
            Texture::Image(im) => Some(SatTable::image(im)?),
            _ => None,
        })
    }

    fn constant(c: f64) -> SatTable {
        SatTable {
            mean: c,
            x0: 0.0,
            y0: 0.0,
            hx: 1.0,
            hy: 1.0,
            cols: 0,
            rows: 0,
            n: Vec::new(),
            cum: Vec::new(),
        }
    }

    fn image(im: &ImageTexture) -> Result<SatTable> {
        let (x0, x1, y0, y1) = im.extent();
        let (rows, cols) = im.shape();
        let (hx, hy) = ((x1 - x0) / cols as f64, (y1 - y0) / rows as f64);
        let mean = im.mean_value();
        let len = (rows + 1) * (cols + 1);
        let mut n = crate::infra::memory::try_vec("the texture's summed areas", len, 0.0)?;
        let mut cum = crate::infra::memory::try_vec("the texture's summed areas", len, 0.0)?;
        let w = cols + 1;
        for b in 0..rows {
            let row = im.row_bottom_up(b);
            let mut acc = 0.0;
            for (i, &v) in row.iter().enumerate() {
                acc += (v - mean) * hx * hy;
                n[(b + 1) * w + i + 1] = n[b * w + i + 1] + acc;
            }
        }
        for j in 0..=rows {
            for i in 0..cols {
                cum[j * w + i + 1] = cum[j * w + i] + 0.5 * hx * (n[j * w + i] + n[j * w + i + 1]);
            }
        }
        Ok(SatTable {
            mean,
            x0,
            y0,
            hx,
            hy,
            cols,
            rows,
            n,
            cum,
        })
    }

    /// The smallest side of a texture cell (0 for a constant).
    pub(crate) fn cell(&self) -> f64 {
        if self.cols == 0 {
            0.0
        } else {
            self.hx.min(self.hy)
        }
    }

    /// S1 at (x, y) in grid units (x = (X − X0)/hx), in cell (c, r) of the walk (−1 and
    /// cols / rows beyond the array), whose cell it is up to rounding.
    fn s1(&self, c: i64, r: i64, x: f64, y: f64) -> f64 {
        let (cols, rows, w) = (self.cols as i64, self.rows as i64, self.cols + 1);
        if c < 0 {
            return 0.0;
        }
        // Beyond the array in Y, S and S1 are their values on its edge.
        let (r, ty) = if r < 0 {
            (0, 0.0)
        } else if r >= rows {
            (rows - 1, 1.0)
        } else {
            (r, (y - r as f64).clamp(0.0, 1.0))
        };
        let (j0, j1) = (r as usize * w, (r as usize + 1) * w);
        if c >= cols {
            let i = self.cols;
            let s = (1.0 - ty) * self.n[j0 + i] + ty * self.n[j1 + i];
            let s1 = (1.0 - ty) * self.cum[j0 + i] + ty * self.cum[j1 + i];
            return s1 + (x - cols as f64) * self.hx * s;
        }
        let i = c as usize;
        let tx = (x - c as f64).clamp(0.0, 1.0);
        let (a0, a1) = (self.n[j0 + i], self.n[j0 + i + 1]);
        let (b0, b1) = (self.n[j1 + i], self.n[j1 + i + 1]);
        let lo = self.cum[j0 + i] + self.hx * tx * (a0 + 0.5 * tx * (a1 - a0));
        let hi = self.cum[j1 + i] + self.hx * tx * (b0 + 0.5 * tx * (b1 - b0));
        (1.0 - ty) * lo + ty * hi
    }

    /// ∫ S1 dY along the segment a → b (scene coordinates), less `s1_ref` along it (a
    /// constant, whose closed integral is zero: it keeps the sum's terms small), cut at
    /// the grid's lines (the cells it crosses, by [`walk`] as `ImageTexture::edge`), each
    /// piece by the 2-point rule, exact for its cubic.
    fn edge(&self, a: Pt, b: Pt, s1_ref: f64) -> f64 {
        let (ax, ay) = ((a[0] - self.x0) / self.hx, (a[1] - self.y0) / self.hy);
        let (dx, dy) = ((b[0] - a[0]) / self.hx, (b[1] - a[1]) / self.hy);
        if dy == 0.0 {
            return 0.0;
        }
        let lines = |origin, step, cells| Lines {
            origin,
            step,
            cells,
        };
        let x = lines(self.x0, self.hx, self.cols);
        let y = lines(self.y0, self.hy, self.rows);
        let mut total = 0.0;
        walk(x, y, a, b, |c, r, t0, t1| {
            let h = t1 - t0;
            let (p, q) = (t0 + G2_LO * h, t0 + G2_HI * h);
            let f =
                self.s1(c, r, ax + p * dx, ay + p * dy) + self.s1(c, r, ax + q * dx, ay + q * dy);
            total += 0.5 * h * (f - 2.0 * s1_ref);
        });
        total * (b[1] - a[1])
    }

    /// ∫_U S(Q + u) du = ∮ S1 dY around the translate Q + U (counter-clockwise).
    fn over_polygon(&self, q: Pt, u: &[Pt]) -> f64 {
        let at = |k: usize| [q[0] + u[k][0], q[1] + u[k][1]];
        let p0 = at(0);
        let (c0, r0) = (
            ((p0[0] - self.x0) / self.hx).floor(),
            ((p0[1] - self.y0) / self.hy).floor(),
        );
        let clamp = |v: f64, n: usize| v.clamp(-1.0, n as f64) as i64;
        let s1_ref = self.s1(
            clamp(c0, self.cols),
            clamp(r0, self.rows),
            (p0[0] - self.x0) / self.hx,
            (p0[1] - self.y0) / self.hy,
        );
        (0..u.len())
            .map(|k| self.edge(at(k), at((k + 1) % u.len()), s1_ref))
            .sum()
    }

    /// ∫_{Q ∈ [X0, X1] × [Y0, Y1]} ∫_{u ∈ U} T(Q + u) du dQ for a counter-clockwise polygon
    /// U: the mean's part by area, T′'s from S at the rectangle's four corners.
    pub(crate) fn rect_polygon(&self, rect: [f64; 4], u: &[Pt]) -> f64 {
        let [x0, x1, y0, y1] = rect;
        let base = self.mean * (x1 - x0) * (y1 - y0) * signed_area(u);
        if self.cols == 0 {
            return base;
        }
        base + self.over_polygon([x1, y1], u)
            - self.over_polygon([x0, y1], u)
            - self.over_polygon([x1, y0], u)
            + self.over_polygon([x0, y0], u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against an independent sum: the midpoint rule over Q on a 240 × 240 grid of the
    /// texture's exact polygon integral ([`Texture::average`]) over Q + U, on a 3 × 4
    /// image with a hexagon straddling its edges; and a constant by area.
    #[test]
    fn rect_polygon_matches_a_fine_sum() {
        let vals: Vec<f64> = (0..12).map(|i| ((i * 7 % 5) as f64) * 0.2 + 0.1).collect();
        let im = ImageTexture::new(&vals, 3, 4, [-1.0, 3.0, -0.5, 1.0]).unwrap();
        let tex = Texture::Image(Box::new(im));
        let sat = SatTable::of(&tex).unwrap().unwrap();
        let hex: Vec<Pt> = (0..6)
            .map(|k| {
                let t = std::f64::consts::PI / 3.0 * k as f64 + 0.2;
                [0.9 * t.cos() + 0.1, 0.7 * t.sin()]
            })
            .collect();
        let rect = [-0.7, 2.9, -0.9, 0.8];
        let got = sat.rect_polygon(rect, &hex);
        let n = 240;
        let mut want = 0.0;
        let mut scratch = crate::imaging::texture::Scratch::default();
        let (dx, dy) = (
            (rect[1] - rect[0]) / n as f64,
            (rect[3] - rect[2]) / n as f64,
        );
        for i in 0..n {
            for j in 0..n {
                let q = [
                    rect[0] + (i as f64 + 0.5) * dx,
                    rect[2] + (j as f64 + 0.5) * dy,
                ];
                let p: Vec<Pt> = hex.iter().map(|v| [v[0] + q[0], v[1] + q[1]]).collect();
                want += tex.average(&p, &mut scratch) * signed_area(&p) * dx * dy;
            }
        }
        // The midpoint rule over Q of a piecewise-smooth function: error ~ (1/n)².
        assert!((got - want).abs() < 2e-4 * want.abs(), "{got} {want}");
        let c = SatTable::of(&Texture::Constant(0.3)).unwrap().unwrap();
        let area = signed_area(&hex) * 3.6 * 1.7;
        assert!((c.rect_polygon(rect, &hex) - 0.3 * area).abs() < 1e-14);
    }
}
