//! A Lambertian scene of the 2-D forward model (docs/model.md §10, "Scene"): a surface
//! Z = h(X, Y) carrying a texture, and where a ray (u, w) first meets it.
//!
//! In object space the ray with main-lens point w and array-plane point x (plane L) is the
//! line P(z) = w − z a, a = w/F + (x − w)/L (the thin main lens deflects it by −w/F).

use crate::error::{Error, Result};
use crate::polygon::Pt;
use crate::texture::Texture;

/// Most depth-map samples.
pub const MAX_DEPTH_SAMPLES: usize = 1 << 28;
/// Steps of the march along a ray before bisection (depth maps).
const MARCH_STEPS: usize = 96;
/// Most refinement steps after the march (Illinois false position, bisection where the map is undefined).
const BISECTIONS: usize = 80;

/// A depth map: depths at the centres of uniform cells over [x0, x1] × [y0, y1] (row 0
/// at the top), bilinear between centres, constant beyond the outer centres up to the
/// extent's edge; no surface outside the extent.
#[derive(Debug, Clone)]
pub struct DepthMap {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    rows: usize,
    cols: usize,
    hx: f64,
    hy: f64,
    /// Bottom-up rows.
    z: Vec<f64>,
    pub zmin: f64,
    pub zmax: f64,
}

impl DepthMap {
    pub fn new(values: &[f64], rows: usize, cols: usize, extent: [f64; 4]) -> Result<DepthMap> {
        if rows == 0 || cols == 0 || rows.saturating_mul(cols) > MAX_DEPTH_SAMPLES {
            return Err(Error::param(
                "depth_map",
                format!("{rows} x {cols}"),
                format!("a non-empty 2-D array of at most {MAX_DEPTH_SAMPLES} depths"),
            ));
        }
        let [x0, x1, y0, y1] = extent;
        if !(extent.iter().all(|v| v.is_finite())
            && x1 > x0
            && y1 > y0
            && (x1 - x0).is_finite()
            && (y1 - y0).is_finite())
        {
            return Err(Error::param(
                "extent",
                format!("({x0}, {x1}, {y0}, {y1})"),
                "finite X0 < X1 and Y0 < Y1 (mm)",
            ));
        }
        let mut z = crate::memory::try_vec("the depth map", rows * cols, 0.0)?;
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
            x0,
            x1,
            y0,
            y1,
            rows,
            cols,
            hx: (x1 - x0) / cols as f64,
            hy: (y1 - y0) / rows as f64,
            z,
            zmin,
            zmax,
        })
    }

    /// The extent (X0, X1, Y0, Y1).
    pub fn extent(&self) -> [f64; 4] {
        [self.x0, self.x1, self.y0, self.y1]
    }

    /// Cell size (hx, hy).
    pub fn cell(&self) -> [f64; 2] {
        [self.hx, self.hy]
    }

    /// h(X, Y), None outside the extent.
    pub fn depth(&self, p: Pt) -> Option<f64> {
        if !(p[0] >= self.x0 && p[0] <= self.x1 && p[1] >= self.y0 && p[1] <= self.y1) {
            return None;
        }
        let axis = |t: f64, n: usize| -> (usize, usize, f64) {
            // t in cell-centre units: centre i at t = i.
            if n == 1 || t <= 0.0 {
                return (0, 0, 0.0);
            }
            let m = (n - 1) as f64;
            if t >= m {
                return (n - 1, n - 1, 0.0);
            }
            let i = t.floor() as usize;
            (i, (i + 1).min(n - 1), t - i as f64)
        };
        let (i0, i1, fx) = axis((p[0] - self.x0) / self.hx - 0.5, self.cols);
        let (b0, b1, fy) = axis((p[1] - self.y0) / self.hy - 0.5, self.rows);
        let v = |b: usize, i: usize| self.z[b * self.cols + i];
        let lo = v(b0, i0) * (1.0 - fx) + v(b0, i1) * fx;
        let hi = v(b1, i0) * (1.0 - fx) + v(b1, i1) * fx;
        Some(lo * (1.0 - fy) + hi * fy)
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
        let need = |n: usize| -> Result<()> {
            if params.len() == n {
                Ok(())
            } else {
                Err(Error::param(
                    "surface_params",
                    format!("{} values", params.len()),
                    format!("{n} values for a {kind:?} surface"),
                ))
            }
        };
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
            Surface::Map(m) => {
                // f(z) = z − h(P(z)) < 0 in front of the surface; the first z in
                // [zmin, zmax] where f ≥ 0 (where h is defined), by a march then bisection.
                let f = |z: f64| m.depth(at(z)).map(|h| z - h);
                if m.zmax <= m.zmin {
                    let z = m.zmin;
                    return f(z).map(|_| (z, at(z)));
                }
                let step = (m.zmax - m.zmin) / MARCH_STEPS as f64;
                let mut prev = m.zmin;
                if let Some(v) = f(prev) {
                    if v >= 0.0 {
                        return Some((prev, at(prev)));
                    }
                }
                for i in 1..=MARCH_STEPS {
                    let z = m.zmin + step * i as f64;
                    if let Some(v) = f(z) {
                        if v >= 0.0 {
                            // Illinois false position on the bracket (f(lo) < 0 ≤ f(hi)),
                            // a bisection step where f is undefined; to 1e-13 relative.
                            let (mut lo, mut hi) = (prev, z);
                            let (mut flo, mut fhi) = (f(lo).unwrap_or(f64::NAN), v);
                            let (mut side, eps) = (0i32, 1e-13 * hi.abs().max(1.0));
                            for _ in 0..BISECTIONS {
                                if hi - lo <= eps {
                                    break;
                                }
                                let mut mid = if flo.is_finite() && fhi > flo {
                                    lo - flo * (hi - lo) / (fhi - flo)
                                } else {
                                    0.5 * (lo + hi)
                                };
                                if !(mid > lo && mid < hi) {
                                    mid = 0.5 * (lo + hi);
                                }
                                match f(mid) {
                                    Some(fm) if fm >= 0.0 => {
                                        hi = mid;
                                        fhi = fm;
                                        if side == 1 {
                                            flo *= 0.5;
                                        }
                                        side = 1;
                                    }
                                    Some(fm) => {
                                        lo = mid;
                                        flo = fm;
                                        if side == -1 {
                                            fhi *= 0.5;
                                        }
                                        side = -1;
                                    }
                                    None => {
                                        lo = mid;
                                        flo = f64::NAN;
                                        side = 0;
                                    }
                                }
                            }
                            return Some((hi, at(hi)));
                        }
                    }
                    prev = z;
                }
                None
            }
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
