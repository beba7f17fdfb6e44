//! Where a ray first meets a depth map, exactly: a walk over the bilinear patches its
//! lateral path crosses (docs/render.md, "What a pixel integrates").
//!
//! The ray P(z) = w − z a can meet the map only at depths z in [zmin, zmax] (the map's
//! range) and where P(z) is inside the extent (a convex box: one interval of z). Between
//! two consecutive lines of sample centres, or a centre line and the extent's edge, the
//! map is one bilinear patch (on the border strips constant along the clamped axis), so
//! along the ray, whose lateral point is linear in z, g(z) = z − h(P(z)) is a quadratic.
//! The walk visits the pieces of the z-interval between the lines' crossings in the
//! order of z, and on each piece takes the least root of its quadratic (from g at the
//! piece's ends and middle) where g reaches 0: the first hit (docs/model.md §10: the
//! first root of z = h(P(z)); a ray that enters the extent from its side behind the
//! surface, g > 0, has not met it, and meets it only where g comes back to 0), to
//! rounding, at a cost of the lines crossed (a march of fixed steps costs about 100
//! evaluations a ray and can step over a thin ridge).

use super::DepthMap;
use crate::infra::polygon::Pt;

/// The crossings of one axis's centre lines by the ray's lateral point, in the order of
/// increasing z: z_k = z0 + k·dz for k in [0, n).
struct Crossings {
    z0: f64,
    dz: f64,
    n: usize,
    k: usize,
}

impl Crossings {
    /// Lines c0 + i·h (i in [0, count)) crossed by X(z) = w − z a for z in [lo, hi] (a
    /// line through an end makes an empty piece, which the walk skips).
    fn new(w: f64, a: f64, (c0, h, count): (f64, f64, usize), (lo, hi): (f64, f64)) -> Self {
        // The line index t(X) = (X − c0)/h at the two ends; X(z) is monotone.
        let (ta, tb) = ((w - lo * a - c0) / h, (w - hi * a - c0) / h);
        let last = count as f64 - 1.0;
        // The first and last index crossed, in the order of increasing z.
        let (first, end, step) = if a > 0.0 {
            (ta.floor().min(last), tb.ceil().max(0.0), -1.0)
        } else {
            (ta.ceil().max(0.0), tb.floor().min(last), 1.0)
        };
        let n = (end - first) * step + 1.0;
        // (NaN counts as none.)
        if a == 0.0 || count == 0 || n.is_nan() || n < 1.0 {
            return Crossings {
                z0: 0.0,
                dz: 0.0,
                n: 0,
                k: 0,
            };
        }
        Crossings {
            z0: (w - (c0 + first * h)) / a,
            dz: -step * h / a,
            n: n as usize,
            k: 0,
        }
    }

    fn peek(&self) -> f64 {
        if self.k < self.n {
            self.z0 + self.k as f64 * self.dz
        } else {
            f64::INFINITY
        }
    }
}

/// The interval of z where w − z a lies in [lo, hi] (per axis), intersected with `z`.
fn slab(w: f64, a: f64, (lo, hi): (f64, f64), z: (f64, f64)) -> (f64, f64) {
    if a == 0.0 {
        return if w >= lo && w <= hi { z } else { (1.0, 0.0) };
    }
    let (za, zb) = ((w - hi) / a, (w - lo) / a);
    let (za, zb) = if za <= zb { (za, zb) } else { (zb, za) };
    (z.0.max(za), z.1.min(zb))
}

/// The least root in (0, 1] of the quadratic through (0, g0), (½, gm), (1, g1), g0 < 0
/// (the first where it reaches 0).
fn first_root(g0: f64, gm: f64, g1: f64) -> Option<f64> {
    let a = 2.0 * (g0 - 2.0 * gm + g1);
    let b = g1 - g0 - a;
    let c = g0;
    let scale = g0.abs().max(gm.abs()).max(g1.abs());
    let best = |u: f64| (u > 0.0 && u <= 1.0).then_some(u);
    if a.abs() <= 1e-14 * scale {
        // Linear (to rounding): a root only where g changes sign.
        return (g1 >= 0.0)
            .then(|| (-c / (g1 - g0)).clamp(0.0, 1.0))
            .filter(|&u| u > 0.0);
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        // No real root; a rounding error can leave g1 ≥ 0 with the vertex on the line.
        return (g1 >= 0.0).then_some(1.0);
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let (r1, r2) = (q / a, if q != 0.0 { c / q } else { f64::INFINITY });
    let (lo, hi) = if r1 <= r2 { (r1, r2) } else { (r2, r1) };
    best(lo)
        .or_else(|| best(hi))
        .or_else(|| (g1 >= 0.0).then_some(1.0))
}

impl DepthMap {
    /// The least z > 0 at which the ray P(z) = w − z a meets the map (None: never), to
    /// rounding; see the module's doc.
    pub fn first_hit(&self, w: Pt, a: Pt) -> Option<f64> {
        let g = &self.grid;
        let z = slab(w[0], a[0], (g.x0, g.x1), (self.zmin, self.zmax));
        let (lo, hi) = slab(w[1], a[1], (g.y0, g.y1), z);
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return None;
        }
        let f = |z: f64| z - self.depth_at([w[0] - z * a[0], w[1] - z * a[1]]);
        // A ray that enters the extent from its side behind the surface (g > 0 there) has
        // not met it: its first root is where g changes sign, from either side.
        let mut g0 = f(lo);
        if g0 == 0.0 {
            return Some(lo);
        }
        if hi == lo || g0.is_nan() {
            return None;
        }
        let mut xs = Crossings::new(w[0], a[0], self.creases(0), (lo, hi));
        let mut ys = Crossings::new(w[1], a[1], self.creases(1), (lo, hi));
        let mut s = lo;
        loop {
            let (zx, zy) = (xs.peek(), ys.peek());
            let t = zx.min(zy).min(hi);
            if t > s {
                let (g1, gm) = (f(t), f(0.5 * (s + t)));
                let root = if g0 < 0.0 {
                    first_root(g0, gm, g1)
                } else {
                    first_root(-g0, -gm, -g1)
                };
                if let Some(u) = root {
                    return Some((s + u * (t - s)).clamp(s, t));
                }
                g0 = g1;
                s = t;
            }
            if t >= hi {
                return None;
            }
            if zx <= zy {
                xs.k += 1;
            } else {
                ys.k += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::infra::random::splitmix64_stream;

    /// A map of random depths in [z0, z0 + relief] (rows × cols over `ext`).
    fn random_map(seed: u64, (rows, cols): (usize, usize), z0: f64, relief: f64) -> DepthMap {
        let ext = [-3.0, 2.0, -1.5, 2.5];
        let mut r = splitmix64_stream(seed);
        let v: Vec<f64> = (0..rows * cols)
            .map(|_| z0 + relief * (r.next().unwrap() >> 11) as f64 / (1u64 << 53) as f64)
            .collect();
        DepthMap::new(&v, rows, cols, ext).unwrap()
    }

    /// The ray's g(z) = z − h(P(z)) where P(z) is inside the extent, else None.
    fn g_of(m: &DepthMap, w: Pt, a: Pt, z: f64) -> Option<f64> {
        m.depth([w[0] - z * a[0], w[1] - z * a[1]]).map(|h| z - h)
    }

    /// The independent check of a hit: sample g densely over [zmin, zmax]; before the hit
    /// (less a rounding margin) g keeps one sign, never 0, wherever the ray is over the map
    /// (no root: a ray that enters the extent behind the surface has not met it), at the
    /// hit g = 0; with no hit g keeps one sign at every sample.
    fn check(m: &DepthMap, w: Pt, a: Pt, hit: Option<f64>) {
        let n = 20_000;
        let span = m.zmax - m.zmin;
        let eps = 1e-9 * m.zmax;
        let stop = hit.map_or(m.zmax, |z| z - eps);
        let mut sign = 0.0;
        for i in 0..=n {
            let z = m.zmin + span * i as f64 / n as f64;
            if z >= stop {
                break;
            }
            if let Some(v) = g_of(m, w, a, z) {
                if sign == 0.0 {
                    sign = v.signum();
                }
                assert!(
                    v * sign > 0.0,
                    "g({z}) = {v}: a root before the hit {hit:?}, w {w:?} a {a:?}"
                );
            }
        }
        if let Some(z) = hit {
            assert!(z >= m.zmin - eps && z <= m.zmax + eps);
            // Over the map (to rounding at the extent's edge).
            let p = [w[0] - z * a[0], w[1] - z * a[1]];
            let e = m.extent();
            assert!(
                p[0] > e[0] - eps && p[0] < e[1] + eps && p[1] > e[2] - eps && p[1] < e[3] + eps
            );
            let v = z - m.depth_grad(p).0;
            assert!(
                v.abs() <= 1e-10 * m.zmax,
                "g at the hit {z} = {v}, w {w:?} a {a:?}"
            );
        }
    }

    #[test]
    fn the_walk_finds_the_first_hit_on_random_maps() {
        let mut r = splitmix64_stream(7);
        let mut u = move || (r.next().unwrap() >> 11) as f64 / (1u64 << 53) as f64;
        let (mut hits, mut misses) = (0, 0);
        for (seed, shape, relief) in [
            (1, (12, 17), 30.0),
            (2, (1, 9), 80.0),
            (3, (7, 1), 80.0),
            (4, (1, 1), 0.0),
            (5, (40, 50), 300.0),
            (6, (3, 2), 5.0),
        ] {
            let m = random_map(seed, shape, 500.0, relief);
            for _ in 0..400 {
                // A ray from an aperture point within 20 mm through a point Q near the
                // map (its extent widened by a fifth, its depth range by 40 mm): slopes up
                // to ~0.05, crossing many of the map's lines on the steep relief; a tenth
                // of them parallel to an axis.
                let q = [
                    6.0 * u() - 3.5,
                    5.0 * u() - 2.0,
                    460.0 + (relief + 80.0) * u(),
                ];
                let w = [40.0 * u() - 20.0, 40.0 * u() - 20.0];
                let mut a = [(w[0] - q[0]) / q[2], (w[1] - q[1]) / q[2]];
                if u() < 0.1 {
                    let k = (u() * 2.0) as usize;
                    a[k] = 0.0;
                }
                let hit = m.first_hit(w, a);
                check(&m, w, a, hit);
                if hit.is_some() {
                    hits += 1;
                } else {
                    misses += 1;
                }
            }
        }
        // The cases exercise both outcomes.
        assert!(hits > 300 && misses > 300, "{hits} hits, {misses} misses");
    }

    #[test]
    fn a_ray_through_a_thin_ridge_is_caught() {
        // One column of samples 60 mm nearer than a 500 mm floor: a ridge two cells
        // wide (0.2 mm) in front of it.
        let (rows, cols) = (5, 61);
        let mut v = vec![500.0; rows * cols];
        for r in 0..rows {
            v[r * cols + 30] = 440.0;
        }
        let m = DepthMap::new(&v, rows, cols, [-3.05, 3.05, -1.0, 1.0]).unwrap();
        // X(z) = w − z a passes X = 0 (the ridge's crest) at z = 470, before the floor.
        let (w, a) = ([4.7, 0.0], [0.01, 0.0]);
        let z = m.first_hit(w, a).expect("the ridge");
        check(&m, w, a, Some(z));
        assert!(z > 440.0 && z < 470.0, "{z}");
    }

    #[test]
    fn a_ray_entering_the_extent_behind_the_surface_has_not_met_it() {
        // A floor at 500 mm with one sample at 550 mm far from the edge X1 = 2.
        let mut v = vec![500.0; 36];
        v[14] = 550.0;
        let m = DepthMap::new(&v, 6, 6, [-3.0, 2.0, -1.5, 2.5]).unwrap();
        // Over the map from X = 2 on, at z = 540 > h = 500 there: behind the floor, which
        // it passed beside the extent; it stays behind.
        let (w, a) = ([2.0 + 540.0 * 0.001, 0.3], [0.001, 0.0]);
        assert_eq!(m.first_hit(w, a), None);
        check(&m, w, a, None);
        // The same ray where a ridge (600 mm) rises behind it: it meets the ridge's back.
        let mut v = vec![500.0; 36];
        for r in 0..6 {
            v[r * 6 + 3] = 600.0;
        }
        let m = DepthMap::new(&v, 6, 6, [-3.0, 2.0, -1.5, 2.5]).unwrap();
        let (w, a) = ([2.0 + 510.0 * 0.03, 0.3], [0.03, 0.0]);
        let z = m.first_hit(w, a).expect("the ridge's back");
        check(&m, w, a, Some(z));
        assert!(z > 510.0 && z < 600.0, "{z}");
    }
}
