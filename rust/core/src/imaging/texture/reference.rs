//! 929d86a's walk of [`ImageTexture`]'s Green's integral along an edge (rows found by
//! division, column knots collected, G evaluated at each), kept as the reference that
//! the cell walk ([`ImageTexture::edge`]) is tested against.

use super::ImageTexture;
use crate::infra::polygon::Pt;

impl ImageTexture {
    /// G_b(X) = ∫_{x0}^{X} T dX' on bottom-up row b (None: outside the rows, mean).
    fn g(&self, b: Option<usize>, x: f64) -> f64 {
        let g = &self.grid;
        let Some(b) = b else {
            return self.mean * (x - g.x0);
        };
        if x <= g.x0 {
            return self.mean * (x - g.x0);
        }
        let p = &self.prefix[b * (g.cols + 1)..(b + 1) * (g.cols + 1)];
        if x >= g.x1 {
            return p[g.cols] + self.mean * (x - g.x1);
        }
        let i = (((x - g.x0) / g.hx) as usize).min(g.cols - 1);
        p[i] + self.values[b * g.cols + i] * (x - (g.x0 + i as f64 * g.hx))
    }

    /// Column-edge knots of G strictly between xa and xb (either order), in order from xa.
    fn knots(&self, xa: f64, xb: f64, out: &mut Vec<f64>) {
        let g = &self.grid;
        out.clear();
        let (lo, hi) = if xa < xb { (xa, xb) } else { (xb, xa) };
        let lo_c = lo.max(g.x0);
        let hi_c = hi.min(g.x1);
        if hi_c < lo_c {
            return;
        }
        // Knots X0 + i hx for i in [i0, i1] with lo < knot < hi.
        let i0 = ((lo_c - g.x0) / g.hx).floor().max(0.0) as usize;
        let i1 = (((hi_c - g.x0) / g.hx).ceil() as usize).min(g.cols);
        for i in i0..=i1 {
            let k = g.x0 + i as f64 * g.hx;
            if k > lo && k < hi {
                out.push(k);
            }
        }
        if xa > xb {
            out.reverse();
        }
    }

    /// ∫ G dY along the segment a → b by 929d86a's walk (rows by division, column knots
    /// collected, G evaluated at each): the reference [`Self::edge`] is tested against.
    fn edge_reference(&self, a: Pt, b: Pt, knots: &mut Vec<f64>) -> f64 {
        let g = &self.grid;
        let dy = b[1] - a[1];
        if dy == 0.0 {
            return 0.0;
        }
        // Cut at the row edges y0 + k hy (and y0, y1) between a and b.
        let (ylo, yhi) = if dy > 0.0 { (a[1], b[1]) } else { (b[1], a[1]) };
        let mut total = 0.0;
        let mut cuts: [f64; 2] = [ylo, yhi];
        // Row index (bottom-up) of a y strictly inside the rows, else None.
        let row_of = |y: f64| -> Option<usize> {
            if y > g.y0 && y < g.y1 {
                Some((((y - g.y0) / g.hy) as usize).min(g.rows - 1))
            } else {
                None
            }
        };
        let x_at = |y: f64| a[0] + (b[0] - a[0]) * ((y - a[1]) / dy);
        // Walk the y-pieces from ylo up to yhi.
        let first = if ylo <= g.y0 {
            None
        } else {
            Some(((ylo - g.y0) / g.hy).floor() as i64)
        };
        let mut y = ylo;
        let mut k = first; // index of the row-edge cell containing y (None: below y0)
        while y < yhi {
            // Next cut above y.
            let next = match k {
                None => g.y0,
                Some(k) if k >= g.rows as i64 => f64::INFINITY,
                Some(k) => g.y0 + (k + 1) as f64 * g.hy,
            };
            let next = if next <= y {
                y + f64::MIN_POSITIVE
            } else {
                next
            };
            let ye = next.min(yhi);
            let row = row_of(0.5 * (y + ye));
            let (xs, xe) = (x_at(y), x_at(ye));
            // ∫ G_row(X(Y)) dY over [y, ye]: piecewise linear in Y, cut at column knots.
            self.knots(xs, xe, knots);
            let mut px = xs;
            let mut py = y;
            let mut gp = self.g(row, xs);
            let slope_y = if xe != xs { (ye - y) / (xe - xs) } else { 0.0 };
            for &kx in knots.iter() {
                let ky = y + (kx - xs) * slope_y;
                let gk = self.g(row, kx);
                total += 0.5 * (gp + gk) * (ky - py);
                px = kx;
                py = ky;
                gp = gk;
            }
            let _ = px;
            let ge = self.g(row, xe);
            total += 0.5 * (gp + ge) * (ye - py);
            y = ye;
            k = Some(match k {
                None => 0,
                Some(k) => k + 1,
            });
            cuts[0] = y;
        }
        let _ = cuts;
        if dy > 0.0 {
            total
        } else {
            -total
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cell walk of [`ImageTexture::edge`] against 929d86a's walk
    /// ([`ImageTexture::edge_reference`]) on segments of every kind: inside, crossing,
    /// beyond the grid on each side, vertical, horizontal, starting and ending on grid
    /// lines and corners, long ones crossing hundreds of cells.
    #[test]
    fn cell_walk_matches_the_reference_walk() {
        let (rows, cols) = (37usize, 53usize);
        let vals: Vec<f64> = (0..rows * cols)
            .map(|i| ((i * 7919) % 101) as f64 / 101.0)
            .collect();
        let t = ImageTexture::new(&vals, rows, cols, [-1.3, 2.7, -0.4, 1.8]).unwrap();
        let (hx, hy) = (4.0 / 53.0, 2.2 / 37.0);
        let mut rng = crate::infra::random::splitmix64_stream(11);
        let mut u = |lo: f64, hi: f64| {
            let r = (rng.next().unwrap() >> 11) as f64 / (1u64 << 53) as f64;
            lo + (hi - lo) * r
        };
        let mut knots = Vec::new();
        let mut pts: Vec<(Pt, Pt)> = vec![
            ([-1.3, -0.4], [2.7, 1.8]),                        // corner to corner
            ([-1.3 + 5.0 * hx, -3.0], [-1.3 + 5.0 * hx, 3.0]), // on a column line
            ([-2.0, -0.4 + 3.0 * hy], [3.0, -0.4 + 3.0 * hy]), // on a row line
            ([0.1, -5.0], [0.1, 5.0]),                         // vertical through everything
            ([-9.0, -9.0], [-8.0, 9.0]),                       // beyond, left
            ([5.0, 0.3], [9.0, 0.9]),                          // beyond, right
            ([0.3, 2.5], [0.9, 3.5]),                          // beyond, above
        ];
        for _ in 0..2000 {
            let a = [u(-2.0, 3.5), u(-1.0, 2.5)];
            let b = [u(-2.0, 3.5), u(-1.0, 2.5)];
            pts.push((a, b));
            // From a grid node, along a line, and short.
            let node = [
                -1.3 + (u(0.0, 53.0) as i64) as f64 * hx,
                -0.4 + (u(0.0, 37.0) as i64) as f64 * hy,
            ];
            pts.push((node, b));
            pts.push((a, [a[0] + u(-1e-3, 1e-3), a[1] + u(-1e-3, 1e-3)]));
        }
        for (a, b) in pts {
            let (got, want) = (t.edge(a, b), t.edge_reference(a, b, &mut knots));
            let scale = 1.0 + (b[1] - a[1]).abs() * (a[0].abs() + b[0].abs() + 4.0);
            assert!(
                (got - want).abs() <= 1e-13 * scale,
                "{a:?} {b:?}: {got} vs {want}"
            );
        }
    }
}
