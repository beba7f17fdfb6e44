//! A Lambertian scene of the 2-D forward model (docs/model.md §10, "Scene"): a surface
//! Z = h(X, Y) carrying a texture, and where a ray (u, w) first meets it.
//!
//! In object space the ray with main-lens point w and array-plane point x (plane L) is the
//! line P(z) = w − z a, a = w/F + (x − w)/L (the thin main lens deflects it by −w/F).

use crate::imaging::grid::SampleGrid;
use crate::imaging::texture::{count_params, Texture};
use crate::infra::error::{Error, Result};
use crate::infra::polygon::Pt;

mod hit;

/// Most depth-map samples.
pub const MAX_DEPTH_SAMPLES: usize = 1 << 28;
/// How far (a share of its depth) a sample may be off the plane through the corner
/// samples for [`DepthMap::as_plane`] to take the map as that plane: rounding, not
/// geometry (a plane's samples computed in floating point are within ~1e-15 of it).
pub const PLANAR: f64 = 1e-9;

/// A depth map: depths at the centres of uniform cells over [x0, x1] × [y0, y1] (row 0
/// at the top), bilinear between centres, constant beyond the outer centres up to the
/// extent's edge; no surface outside the extent.
#[derive(Debug, Clone)]
pub struct DepthMap {
    grid: SampleGrid,
    /// Bottom-up rows.
    z: Vec<f64>,
    pub zmin: f64,
    pub zmax: f64,
}

impl DepthMap {
    pub fn new(values: &[f64], rows: usize, cols: usize, extent: [f64; 4]) -> Result<DepthMap> {
        let grid = SampleGrid::new(
            "depth_map",
            (rows, cols),
            extent,
            (MAX_DEPTH_SAMPLES, "depths"),
        )?;
        let mut z = crate::infra::memory::try_vec("the depth map", rows * cols, 0.0)?;
        let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for r in 0..rows {
            for c in 0..cols {
                let v = values[r * cols + c];
                if !(v.is_finite() && v > 0.0) {
                    return Err(Error::param("depth_map", v, "finite depths > 0 (mm)"));
                }
                zmin = zmin.min(v);
                zmax = zmax.max(v);
                z[(rows - 1 - r) * cols + c] = v;
            }
        }
        Ok(DepthMap {
            grid,
            z,
            zmin,
            zmax,
        })
    }

    /// The extent (X0, X1, Y0, Y1).
    pub fn extent(&self) -> [f64; 4] {
        self.grid.extent()
    }

    /// Cell size (hx, hy).
    pub fn cell(&self) -> [f64; 2] {
        [self.grid.hx, self.grid.hy]
    }

    /// h(X, Y), None outside the extent.
    pub fn depth(&self, p: Pt) -> Option<f64> {
        let g = &self.grid;
        (p[0] >= g.x0 && p[0] <= g.x1 && p[1] >= g.y0 && p[1] <= g.y1).then(|| self.depth_grad(p).0)
    }

    /// h(X, Y) and its gradient at any point: inside the extent the surface's own (the
    /// gradient of the bilinear patch holding p, the patch on the larger-coordinate side
    /// on a line between patches); beyond it, the surface continued as it is at the
    /// extent's edge (p clamped to the extent; there is no surface there, and the
    /// continuation only tells where the rays that miss the surface go).
    pub fn depth_grad(&self, p: Pt) -> (f64, Pt) {
        let g = &self.grid;
        let x = p[0].clamp(g.x0, g.x1);
        let y = p[1].clamp(g.y0, g.y1);
        // (lower sample, upper sample, fraction, d fraction / d coordinate).
        let axis = |t: f64, n: usize, h: f64| -> (usize, usize, f64, f64) {
            if n == 1 || t < 0.0 {
                return (0, 0, 0.0, 0.0);
            }
            let m = (n - 1) as f64;
            if t >= m {
                return (n - 1, n - 1, 0.0, 0.0);
            }
            let i = t.floor() as usize;
            (i, i + 1, t - i as f64, 1.0 / h)
        };
        let (i0, i1, fx, dx) = axis((x - g.x0) / g.hx - 0.5, g.cols, g.hx);
        let (b0, b1, fy, dy) = axis((y - g.y0) / g.hy - 0.5, g.rows, g.hy);
        let v = |b: usize, i: usize| self.z[b * g.cols + i];
        let lo = v(b0, i0) * (1.0 - fx) + v(b0, i1) * fx;
        let hi = v(b1, i0) * (1.0 - fx) + v(b1, i1) * fx;
        let gx = ((v(b0, i1) - v(b0, i0)) * (1.0 - fy) + (v(b1, i1) - v(b1, i0)) * fy) * dx;
        let gy = (hi - lo) * dy;
        (lo * (1.0 - fy) + hi * fy, [gx, gy])
    }

    /// [`DepthMap::depth_grad`]'s depth alone, the same value bit for bit (`t as usize` is
    /// the floor of a t ≥ 0, NaN to 0 as the floor's cast): the hit's walk evaluates it a
    /// few times a ray, and the gradient and libm's floor cost a tenth of a depth map's
    /// render.
    #[inline]
    pub fn depth_at(&self, p: Pt) -> f64 {
        let g = &self.grid;
        let x = p[0].clamp(g.x0, g.x1);
        let y = p[1].clamp(g.y0, g.y1);
        let axis = |t: f64, n: usize| -> (usize, usize, f64) {
            if n == 1 || t < 0.0 {
                return (0, 0, 0.0);
            }
            if t >= (n - 1) as f64 {
                return (n - 1, n - 1, 0.0);
            }
            let i = t as usize;
            (i, i + 1, t - i as f64)
        };
        let (i0, i1, fx) = axis((x - g.x0) / g.hx - 0.5, g.cols);
        let (b0, b1, fy) = axis((y - g.y0) / g.hy - 0.5, g.rows);
        let v = |b: usize, i: usize| self.z[b * g.cols + i];
        let lo = v(b0, i0) * (1.0 - fx) + v(b0, i1) * fx;
        let hi = v(b1, i0) * (1.0 - fx) + v(b1, i1) * fx;
        lo * (1.0 - fy) + hi * fy
    }

    /// The plane Z = z0 + g · (X, Y) that this map is over the box between its outer
    /// sample centres (returned as that box, [X0, X1, Y0, Y1]), when every sample lies on
    /// one plane within `PLANAR` of its depth: bilinear interpolation of a plane's samples
    /// is the plane there (beyond the outer centres the map is constant, not the plane).
    /// None for a map of one row or column, or one that is not planar.
    pub fn as_plane(&self) -> Option<(f64, Pt, [f64; 4])> {
        let g = &self.grid;
        if g.rows < 2 || g.cols < 2 {
            return None;
        }
        let v = |b: usize, i: usize| self.z[b * g.cols + i];
        // The plane through three corner samples (rows bottom-up), checked at every sample.
        let gx = (v(0, g.cols - 1) - v(0, 0)) / ((g.cols - 1) as f64 * g.hx);
        let gy = (v(g.rows - 1, 0) - v(0, 0)) / ((g.rows - 1) as f64 * g.hy);
        let (cx, cy) = (g.x0 + 0.5 * g.hx, g.y0 + 0.5 * g.hy);
        let z0 = v(0, 0) - gx * cx - gy * cy;
        let on = (0..g.rows).all(|b| {
            (0..g.cols).all(|i| {
                let p = z0 + gx * (cx + i as f64 * g.hx) + gy * (cy + b as f64 * g.hy);
                (v(b, i) - p).abs() <= PLANAR * v(b, i)
            })
        });
        on.then_some((z0, [gx, gy], [cx, g.x1 - 0.5 * g.hx, cy, g.y1 - 0.5 * g.hy]))
    }

    /// Bounds (least, greatest) on h over the box [X0, X1, Y0, Y1] (clamped to the
    /// extent, as `depth_grad` continues it): the samples of every patch that meets it.
    pub fn range_over(&self, b: [f64; 4]) -> (f64, f64) {
        let g = &self.grid;
        let idx = |lo: f64, hi: f64, o: f64, h: f64, n: usize| -> (usize, usize) {
            let m = (n - 1) as f64;
            let a = ((lo - o) / h - 0.5).floor().clamp(0.0, m);
            let b = ((hi - o) / h - 0.5).ceil().clamp(0.0, m);
            (a as usize, b as usize)
        };
        let (i0, i1) = idx(b[0], b[1], g.x0, g.hx, g.cols);
        let (r0, r1) = idx(b[2], b[3], g.y0, g.hy, g.rows);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for r in r0..=r1 {
            for &v in &self.z[r * g.cols + i0..=r * g.cols + i1] {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }

    /// The sample-centre lines along one axis (0: X, 1: Y), where the surface's gradient
    /// may jump: (first line, spacing, count).
    pub fn creases(&self, axis: usize) -> (f64, f64, usize) {
        let g = &self.grid;
        if axis == 0 {
            (g.x0 + 0.5 * g.hx, g.hx, g.cols)
        } else {
            (g.y0 + 0.5 * g.hy, g.hy, g.rows)
        }
    }

    /// Does every ray from a main-lens point w with |w_x|, |w_y| ≤ `r` meet the surface at
    /// most once? So it does when the surface faces every such w everywhere: g · (P − w)
    /// < h(P), g the gradient at P (along the line from w through P's foot, t / h(P(t))
    /// then grows strictly, so no two points of the surface lie on one ray; the extent is
    /// convex). Checked per bilinear patch with interval bounds (the gradient's range over
    /// the patch times P − w's), with a margin of 1 % of the patch's least depth.
    pub fn seen_once(&self, r: f64) -> bool {
        // Patches between centres (b, i)..(b + 1, i + 1); one row or column: its own.
        (0..self.grid.rows.saturating_sub(1).max(1)).all(|b| {
            (0..self.grid.cols.saturating_sub(1).max(1)).all(|i| self.patch_faces(b, i, r))
        })
    }

    /// [`DepthMap::seen_once`]'s condition on one bilinear patch, between the sample
    /// rows b and b + 1 (counted from the bottom) and the columns i and i + 1 (a map of
    /// one row or column: the patch is that row or column).
    pub fn patch_faces(&self, b: usize, i: usize, r: f64) -> bool {
        let (lead, zmin) = self.patch_lead(b, i, r);
        // (NaN fails too.)
        lead.partial_cmp(&(0.99 * zmin)) == Some(std::cmp::Ordering::Less)
    }

    /// The two sides of [`DepthMap::patch_faces`]'s condition on the patch (b, i): the
    /// bound on g · (P − w) over the patch and |w| ≤ r (the gradient's range times
    /// P − w's), and the patch's least depth; it faces every such w when the first is
    /// below 0.99 times the second.
    pub fn patch_lead(&self, b: usize, i: usize, r: f64) -> (f64, f64) {
        let grid = &self.grid;
        let (cols, rows) = (grid.cols, grid.rows);
        let v = |b: usize, i: usize| self.z[b * cols + i];
        let span = |a: [f64; 2], b: [f64; 2]| {
            let q = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]];
            q.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        };
        let (b1, i1) = ((b + 1).min(rows - 1), (i + 1).min(cols - 1));
        // The range of a difference quotient between two pairs of samples.
        let slope = |a: (f64, f64), b: (f64, f64), h: f64| {
            let (p, q) = ((a.1 - a.0) / h, (b.1 - b.0) / h);
            [p.min(q), p.max(q)]
        };
        let gx = if i1 > i {
            slope((v(b, i), v(b, i1)), (v(b1, i), v(b1, i1)), grid.hx)
        } else {
            [0.0, 0.0]
        };
        let gy = if b1 > b {
            slope((v(b, i), v(b1, i)), (v(b, i1), v(b1, i1)), grid.hy)
        } else {
            [0.0, 0.0]
        };
        // The patch's X and Y ranges (the border strips' gradient is 0).
        let xa = grid.x0 + (i as f64 + 0.5) * grid.hx;
        let xb = grid.x0 + (i1 as f64 + 0.5) * grid.hx;
        let ya = grid.y0 + (b as f64 + 0.5) * grid.hy;
        let yb = grid.y0 + (b1 as f64 + 0.5) * grid.hy;
        let zmin = v(b, i).min(v(b, i1)).min(v(b1, i)).min(v(b1, i1));
        let lead = span(gx, [xa - r, xb + r]) + span(gy, [ya - r, yb + r]);
        (lead, zmin)
    }
}

/// The surface of a scene.
#[derive(Debug, Clone)]
pub enum Surface {
    /// Z = z0 + g · (X, Y).
    Plane {
        z0: f64,
        g: [f64; 2],
    },
    Map(DepthMap),
}

impl Surface {
    pub fn from_parts(
        kind: &str,
        params: &[f64],
        map: Option<(&[f64], usize, usize)>,
    ) -> Result<Surface> {
        let need = |n: usize| count_params("surface_params", kind, params, n);
        match (kind, map) {
            ("plane", None) => {
                need(3)?;
                let [z0, gx, gy] = [params[0], params[1], params[2]];
                if !(z0.is_finite() && z0 > 0.0) {
                    return Err(Error::param("z0", z0, "a finite depth > 0 (mm)"));
                }
                for (n, g) in [("gx", gx), ("gy", gy)] {
                    if !g.is_finite() || g.abs() > 1e6 {
                        return Err(Error::param(n, g, "a finite slope in [-1e6, 1e6]"));
                    }
                }
                Ok(Surface::Plane { z0, g: [gx, gy] })
            }
            ("depthmap", Some((v, rows, cols))) => {
                need(4)?;
                let ext = [params[0], params[1], params[2], params[3]];
                Ok(Surface::Map(DepthMap::new(v, rows, cols, ext)?))
            }
            ("depthmap", None) => Err(Error::param(
                "depth_map",
                "None",
                "a 2-D array of depths for a \"depthmap\" surface",
            )),
            ("plane", Some(_)) => Err(Error::param(
                "depth_map",
                "an array",
                "None for a \"plane\" surface",
            )),
            _ => Err(Error::param(
                "surface",
                format!("{kind:?}"),
                "\"plane\" or \"depthmap\"",
            )),
        }
    }

    /// The fronto-parallel depth, if the surface is one.
    pub fn fronto(&self) -> Option<f64> {
        match self {
            Surface::Plane { z0, g } if g[0] == 0.0 && g[1] == 0.0 => Some(*z0),
            _ => None,
        }
    }

    /// Depth of the surface at the lateral point p (None: no surface there).
    pub fn depth_at(&self, p: Pt) -> Option<f64> {
        match self {
            Surface::Plane { z0, g } => Some(z0 + g[0] * p[0] + g[1] * p[1]),
            Surface::Map(m) => m.depth(p),
        }
    }

    /// Where the ray P(z) = w − z a first meets the surface (z, P), z > 0; None: never.
    pub fn hit(&self, w: Pt, a: Pt) -> Option<(f64, Pt)> {
        let at = |z: f64| [w[0] - z * a[0], w[1] - z * a[1]];
        match self {
            Surface::Plane { z0, g } => {
                let den = 1.0 + g[0] * a[0] + g[1] * a[1];
                let z = (z0 + g[0] * w[0] + g[1] * w[1]) / den;
                (den > 0.0 && z > 0.0 && z.is_finite()).then(|| (z, at(z)))
            }
            Surface::Map(m) => m.first_hit(w, a).map(|z| (z, at(z))),
        }
    }
}

/// A scene: a surface, its texture, and the albedo of rays that meet no surface.
#[derive(Debug, Clone)]
pub struct Scene {
    pub texture: Texture,
    pub surface: Surface,
    pub background: f64,
}

impl Scene {
    pub fn new(texture: Texture, surface: Surface, background: f64) -> Result<Scene> {
        if !(background.is_finite() && background >= 0.0) {
            return Err(Error::param(
                "background",
                background,
                "a finite albedo >= 0",
            ));
        }
        Ok(Scene {
            texture,
            surface,
            background,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map of `f` sampled at the centres of rows × cols cells over `ext` (row 0 at the
    /// top).
    fn sampled(f: impl Fn(f64, f64) -> f64, rows: usize, cols: usize, ext: [f64; 4]) -> DepthMap {
        let (hx, hy) = (
            (ext[1] - ext[0]) / cols as f64,
            (ext[3] - ext[2]) / rows as f64,
        );
        let mut v = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                v.push(f(
                    ext[0] + (c as f64 + 0.5) * hx,
                    ext[3] - (r as f64 + 0.5) * hy,
                ));
            }
        }
        DepthMap::new(&v, rows, cols, ext).unwrap()
    }

    /// A plane's samples are that plane (its coefficients to rounding, over the box of
    /// the outer sample centres: hand-computed here); one sample 1e-6 of its depth off,
    /// a curved map and a map of one row are not.
    #[test]
    fn a_planes_samples_are_the_plane() {
        let ext = [-2.0, 2.5, -1.0, 2.0];
        let plane = |x: f64, y: f64| 700.0 + 3.0 * x - 26.0 * y;
        let m = sampled(plane, 6, 9, ext);
        let (z0, g, bx) = m.as_plane().expect("a plane");
        assert!(
            (z0 - 700.0).abs() < 1e-9 && (g[0] - 3.0).abs() < 1e-11,
            "{z0} {g:?}"
        );
        assert!((g[1] + 26.0).abs() < 1e-11, "{g:?}");
        // Cells of 0.5 by 0.5 mm: the outer centres a quarter mm in from the edges.
        let want = [-1.75, 2.25, -0.75, 1.75];
        assert!(
            bx.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
            "{bx:?}"
        );
        let mut v: Vec<f64> = (0..6 * 9).map(|k| m.z[k]).collect();
        v[4 * 9 + 5] *= 1.0 + 1e-6;
        assert!(DepthMap::new(&v, 6, 9, ext).unwrap().as_plane().is_none());
        let bowl = sampled(|x, y| plane(x, y) + 0.01 * x * x, 6, 9, ext);
        assert!(bowl.as_plane().is_none());
        assert!(sampled(plane, 1, 9, ext).as_plane().is_none());
    }

    #[test]
    fn depth_at_is_depth_grads_depth_bit_for_bit() {
        let m = sampled(
            |x, y| 500.0 + 3.0 * x * x - 2.0 * x * y + 7.0 * y,
            7,
            9,
            [-2.0, 2.5, -1.0, 2.0],
        );
        let one = sampled(|_, _| 640.0, 1, 1, [-1.0, 1.0, -1.0, 1.0]);
        let mut r = crate::infra::random::splitmix64_stream(3);
        let mut u = move || (r.next().unwrap() >> 11) as f64 / (1u64 << 53) as f64;
        for _ in 0..2000 {
            // Inside, beyond the extent and on the lines of sample centres (hx = 0.5).
            let p = [7.0 * u() - 3.2, 5.0 * u() - 2.0];
            for q in [p, [-1.75 + 0.5 * (u() * 9.0).floor(), p[1]]] {
                assert_eq!(m.depth_at(q).to_bits(), m.depth_grad(q).0.to_bits());
                assert_eq!(one.depth_at(q).to_bits(), one.depth_grad(q).0.to_bits());
            }
        }
        assert!(m.depth_at([f64::NAN, 0.0]).is_nan() && m.depth_grad([f64::NAN, 0.0]).0.is_nan());
    }

    #[test]
    fn depth_grad_is_the_bilinear_surface_and_its_slope() {
        let m = sampled(
            |x, y| 500.0 + 3.0 * x * x - 2.0 * x * y + 7.0 * y,
            7,
            9,
            [-2.0, 2.5, -1.0, 2.0],
        );
        let h = 1e-6;
        for &(x, y) in &[
            (0.1, 0.2),
            (-1.7, 1.8),
            (2.1, -0.7),
            (0.33, 0.41),
            (-0.6, -0.05),
        ] {
            let (z, g) = m.depth_grad([x, y]);
            assert_eq!(Some(z), m.depth([x, y]));
            for (i, d) in [[h, 0.0], [0.0, h]].iter().enumerate() {
                let fd = (m.depth([x + d[0], y + d[1]]).unwrap()
                    - m.depth([x - d[0], y - d[1]]).unwrap())
                    / (2.0 * h);
                assert!(
                    (g[i] - fd).abs() < 1e-6,
                    "({x}, {y}) axis {i}: {} vs {fd}",
                    g[i]
                );
            }
        }
        // Beyond the extent: the edge's depth, flat across it.
        let (z, g) = m.depth_grad([3.5, 0.2]);
        assert_eq!(Some(z), m.depth([2.5, 0.2]));
        assert_eq!(g[0], 0.0);
        // On a plane the bilinear map is the plane inside the outer centres.
        let p = sampled(
            |x, y| 800.0 + 0.3 * x + 2.0 * y,
            5,
            5,
            [-1.0, 1.0, -1.0, 1.0],
        );
        let (z, g) = p.depth_grad([0.31, -0.47]);
        assert!((z - (800.0 + 0.3 * 0.31 - 2.0 * 0.47)).abs() < 1e-9);
        assert!((g[0] - 0.3).abs() < 1e-12 && (g[1] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn range_over_bounds_the_surface_on_a_box() {
        let m = sampled(
            |x, y| 600.0 + 40.0 * (x * 1.3).sin() * (y * 0.7).cos(),
            20,
            30,
            [-3.0, 3.0, -2.0, 2.0],
        );
        for b in [
            [-0.4, 0.9, -1.1, 0.3],
            [2.0, 5.0, 1.5, 4.0],
            [-9.0, -8.0, -0.1, 0.1],
            [-1.0, 1.0, -1.0, 1.0],
        ] {
            let (lo, hi) = m.range_over(b);
            let (mut a, mut z) = (f64::INFINITY, f64::NEG_INFINITY);
            for i in 0..=40 {
                for j in 0..=40 {
                    let p = [
                        b[0] + (b[1] - b[0]) * i as f64 / 40.0,
                        b[2] + (b[3] - b[2]) * j as f64 / 40.0,
                    ];
                    let v = m.depth_grad(p).0;
                    a = a.min(v);
                    z = z.max(v);
                }
            }
            assert!(lo <= a && z <= hi, "{b:?}: [{lo}, {hi}] against [{a}, {z}]");
            // Not the whole map's range for a small box.
            if b[1] - b[0] < 2.0 {
                assert!(hi - lo < m.zmax - m.zmin, "{b:?}");
            }
        }
    }

    #[test]
    fn seen_once_is_the_facing_condition() {
        // A ramp in X over [0, 2] × [0, 1] (centres at X = 0.5, 1.5): gradient g, depth
        // z0 at X = 0.5. With |w| <= r = 1 the worst case is g (1.5 + r) against 0.99 z0:
        // g < 39.6 for z0 = 100.
        let ramp = |g: f64| {
            DepthMap::new(
                &[100.0, 100.0 + g, 100.0, 100.0 + g],
                2,
                2,
                [0.0, 2.0, 0.0, 1.0],
            )
            .unwrap()
        };
        assert!(ramp(39.0).seen_once(1.0));
        assert!(!ramp(40.0).seen_once(1.0));
        // A descent: g (X − w) is largest at X = 0.5, w = 1 (g = −20: 10 against 0.99 ×
        // 80, the patch's least depth). Its mirror image over [−2, 0] climbs towards the
        // axis: 40 (1.5 + r) against 99.
        assert!(ramp(-20.0).seen_once(1.0));
        let mirror = DepthMap::new(
            &[100.0 + 40.0, 100.0, 100.0 + 40.0, 100.0],
            2,
            2,
            [-2.0, 0.0, 0.0, 1.0],
        )
        .unwrap();
        assert!(!mirror.seen_once(1.0));
        assert!(mirror.seen_once(0.5)); // 40 (1.5 + 0.5) = 80 < 99
                                        // A single sample: flat, always seen once.
        assert!(DepthMap::new(&[50.0], 1, 1, [0.0, 1.0, 0.0, 1.0])
            .unwrap()
            .seen_once(100.0));
    }
}
