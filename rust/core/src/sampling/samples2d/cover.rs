//! The covering radius of the central field by the representatives (Delaunay
//! triangulation by `spade`), and the 1-D chains and covers of the exact separable form
//! that `rows` takes for channels whose samples are products of two 1-D sets
//! (docs/model.md §9, "Covering radius").

use spade::{DelaunayTriangulation, HierarchyHintGenerator, Point2, Triangulation};

use super::*;
use crate::infra::error::{Error, Result};
use crate::infra::memory::try_reserve;
use crate::infra::parallel::{self};

// ---- covering radius -------------------------------------------------------------------

/// Items of a long serial loop between two interrupt checkpoints.
const CHECK_ITEMS: usize = 1 << 16;

type Tri = DelaunayTriangulation<Point2<f64>, (), (), (), HierarchyHintGenerator<f64>>;

#[inline]
fn dist(p: [f64; 2], q: Point2<f64>) -> f64 {
    ((p[0] - q.x).powi(2) + (p[1] - q.y).powi(2)).sqrt()
}

#[inline]
fn flush(x: f64) -> f64 {
    if x.abs() < FLUSH {
        0.0
    } else {
        x
    }
}

/// The covering radius of the box |x| ≤ field[0], |y| ≤ field[1] by `points`: the largest
/// distance from a point of the box to its nearest point of the set (+∞ for an empty set).
///
/// The distance function's maximum over the box lies at a Voronoi vertex inside it, where
/// a Voronoi edge crosses its boundary, or at a corner. The candidates are: the Delaunay
/// circumcentres inside the box (clamped in when they lie within rounding of its edge),
/// the crossings of each Delaunay edge's perpendicular bisector with the four sides, kept
/// where they lie on the edge's Voronoi segment (between the circumcentres of its two
/// faces, or the ray / line of a hull edge; widened by a relative 1e-6 against rounding),
/// and the four corners. Every candidate is a point of the box, and the distance to the
/// nearest point is evaluated there exactly (spade's nearest-neighbour walk), so extra
/// candidates never change the result. They are visited in decreasing order of an upper
/// bound (the distance to a point of the set that defines them), stopping when no bound
/// exceeds the best found by more than [`PRUNE_RTOL`].
///
/// No triangles (one point, two, or all collinear) needs no special case: the bisectors
/// of the hull's edges are whole lines then, and the corners are always candidates.
pub fn covering_radius(points: &[[f64; 2]], field: [f64; 2]) -> Result<f64> {
    if points.is_empty() {
        return Ok(f64::INFINITY);
    }
    let what = "covering radius (triangulation)";
    let mut verts = Vec::new();
    try_reserve(&mut verts, what, points.len())?;
    verts.extend(points.iter().map(|p| Point2::new(flush(p[0]), flush(p[1]))));
    // Seconds for millions of points, in spade, with no checkpoint: then on a thread of its
    // own (the call can stop meanwhile).
    let tri = if verts.len() >= CHECK_ITEMS {
        parallel::detached(move || Tri::bulk_load(verts))?
    } else {
        Tri::bulk_load(verts)
    };
    let tri = tri.map_err(|e| {
        Error::param(
            "samples",
            format!("a set spade cannot triangulate ({e:?})"),
            "finite sample coordinates",
        )
    })?;
    let nearest = |p: [f64; 2]| -> f64 {
        tri.nearest_neighbor(Point2::new(p[0], p[1]))
            .map_or(f64::INFINITY, |v| dist(p, v.position()))
    };
    let [hx, hy] = field;
    let mut best = [[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]]
        .into_iter()
        .map(nearest)
        .fold(0.0, f64::max);
    // Circumcentres, indexed by face (index 0 is the outer face).
    let mut centres: Vec<[f64; 2]> = Vec::new();
    try_reserve(&mut centres, what, tri.num_all_faces())?;
    centres.resize(tri.num_all_faces(), [f64::NAN; 2]);
    let mut cand: Vec<(f64, [f64; 2])> = Vec::new();
    try_reserve(&mut cand, what, tri.num_inner_faces() + 4)?;
    let near_box = |c: f64, h: f64| c.abs() <= h + 1e-12 * (h + c.abs());
    for (i, f) in tri.inner_faces().enumerate() {
        if i % CHECK_ITEMS == 0 {
            parallel::checkpoint()?;
        }
        let c = f.circumcenter();
        let c = [c.x, c.y];
        centres[f.fix().index()] = c;
        if near_box(c[0], hx) && near_box(c[1], hy) {
            let p = [c[0].clamp(-hx, hx), c[1].clamp(-hy, hy)];
            let u = f
                .vertices()
                .iter()
                .map(|v| dist(p, v.position()))
                .fold(f64::INFINITY, f64::min);
            cand.push((u, p));
        }
    }
    const T_SLACK: f64 = 1e-6;
    for (i, e) in tri.undirected_edges().enumerate() {
        if i % CHECK_ITEMS == 0 {
            parallel::checkpoint()?;
        }
        let d = e.as_directed();
        let (a, b) = (d.from().position(), d.to().position());
        let mid = [(a.x + b.x) / 2.0, (a.y + b.y) / 2.0];
        // The bisector mid + t·dir, dir the left normal of a → b (spade's face() is the
        // face to the left of a directed edge).
        let dir = [-(b.y - a.y), b.x - a.x];
        let len2 = dir[0] * dir[0] + dir[1] * dir[1];
        let t_of = |c: [f64; 2]| ((c[0] - mid[0]) * dir[0] + (c[1] - mid[1]) * dir[1]) / len2;
        let left = d.face().as_inner().map(|f| t_of(centres[f.fix().index()]));
        let right = d
            .rev()
            .face()
            .as_inner()
            .map(|f| t_of(centres[f.fix().index()]));
        // The Voronoi segment; a hull edge's runs away from its inner face to infinity.
        let (lo, hi) = match (left, right) {
            (Some(l), Some(r)) => (l.min(r), l.max(r)),
            (Some(l), None) => (f64::NEG_INFINITY, l),
            (None, Some(r)) => (r, f64::INFINITY),
            (None, None) => (f64::NEG_INFINITY, f64::INFINITY),
        };
        let (lo, hi) = (
            lo - T_SLACK * (1.0 + lo.abs()),
            hi + T_SLACK * (1.0 + hi.abs()),
        );
        for (axis, side) in [(0, -hx), (0, hx), (1, -hy), (1, hy)] {
            let other = 1 - axis;
            if dir[axis] == 0.0 {
                continue;
            }
            let t = (side - mid[axis]) / dir[axis];
            if !(t >= lo && t <= hi) {
                continue;
            }
            let v = mid[other] + t * dir[other];
            if !near_box(v, field[other]) {
                continue;
            }
            let mut p = [0.0; 2];
            p[axis] = side;
            p[other] = v.clamp(-field[other], field[other]);
            cand.push((dist(p, a), p));
        }
    }
    // Evaluate the candidate of largest bound, keep only those that can still beat the
    // best, then visit them in decreasing order of bound.
    if let Some(&(_, p)) = cand.iter().max_by(|x, y| x.0.total_cmp(&y.0)) {
        best = best.max(nearest(p));
    }
    cand.retain(|c| c.0 > best * (1.0 + PRUNE_RTOL));
    cand.sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
    for (i, &(u, p)) in cand.iter().enumerate() {
        if u <= best * (1.0 + PRUNE_RTOL) {
            break;
        }
        if i % CHECK_ITEMS == 0 {
            parallel::checkpoint()?;
        }
        best = best.max(nearest(p));
    }
    Ok(best)
}

// ---- separable channels ----------------------------------------------------------------

/// The representatives of values linked when they differ by less than eps (chains of
/// sorted values): each chain's least value. Sorts `v` and leaves the representatives.
pub(super) fn reps_1d(v: &mut Vec<f64>, eps: f64) {
    v.sort_unstable_by(f64::total_cmp);
    let mut out = 0;
    for i in 0..v.len() {
        if i == 0 || v[i] - v[i - 1] >= eps {
            v[out] = v[i];
            out += 1;
        }
    }
    v.truncate(out);
}

/// The covering radius of [−h, h] by the sorted values `r`: the distance to the nearest
/// value is largest at an end of the interval or halfway between two consecutive values.
pub(super) fn cover_1d(r: &[f64], h: f64) -> f64 {
    if r.is_empty() {
        return f64::INFINITY;
    }
    let at = |x: f64| {
        let i = r.partition_point(|&v| v < x);
        let hi = r.get(i).map_or(f64::INFINITY, |&v| v - x);
        let lo = if i > 0 { x - r[i - 1] } else { f64::INFINITY };
        hi.min(lo)
    };
    let mut best = at(-h).max(at(h));
    for p in r.windows(2) {
        let mid = p[0] + (p[1] - p[0]) / 2.0;
        if mid >= -h && mid <= h {
            best = best.max((mid - p[0]).min(p[1] - mid));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::samples2d::test_designs::*;

    /// Brute-force covering radius: the largest nearest distance over a dense grid of the
    /// field (a lower bound, within half a grid diagonal of the truth).
    fn grid_search(pts: &[[f64; 2]], field: [f64; 2], n: usize) -> f64 {
        let mut worst = 0.0f64;
        for i in 0..=n {
            for k in 0..=n {
                let p = [
                    -field[0] + 2.0 * field[0] * i as f64 / n as f64,
                    -field[1] + 2.0 * field[1] * k as f64 / n as f64,
                ];
                let d = pts
                    .iter()
                    .map(|q| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d);
            }
        }
        worst
    }

    #[test]
    fn covering_radius_of_degenerate_sets() {
        let f = [1.0, 2.0];
        assert_eq!(covering_radius(&[], f).unwrap(), f64::INFINITY);
        // One point: the farthest corner.
        assert_eq!(covering_radius(&[[0.0, 0.0]], f).unwrap(), 5f64.sqrt());
        let r = covering_radius(&[[0.5, -3.0]], f).unwrap();
        assert!((r - (1.5f64.powi(2) + 25.0).sqrt()).abs() < 1e-12);
        // Two points, duplicates, collinear rows (no triangle): bisector crossings count.
        let two = [[-0.5, 0.0], [0.5, 0.0], [0.5, 0.0]];
        let r = covering_radius(&two, f).unwrap();
        assert!((r - (0.25f64 + 4.0).sqrt()).abs() < 1e-12, "{r}");
        let line: Vec<[f64; 2]> = (-10..=10).map(|i| [i as f64 * 0.3, 0.7]).collect();
        let r = covering_radius(&line, f).unwrap();
        assert!(
            (r - (0.15f64.powi(2) + 2.7f64.powi(2)).sqrt()).abs() < 1e-12,
            "{r}"
        );
        let diag: Vec<[f64; 2]> = (-10..=10)
            .map(|i| [i as f64 * 0.3, i as f64 * 0.3])
            .collect();
        let r = covering_radius(&diag, f).unwrap();
        let g = grid_search(&diag, f, 400);
        assert!(r >= g - 1e-12 && r <= g + 0.01, "{r} {g}");
        // Far outside the field, all on one side.
        let far = [[10.0, 0.0], [10.0, 1.0], [11.0, 0.5]];
        let r = covering_radius(&far, f).unwrap();
        let g = grid_search(&far, f, 400);
        assert!(r >= g - 1e-12 && r <= g + 0.01, "{r} {g}");
    }

    #[test]
    fn square_grid_covers_at_one_over_root_two() {
        let pts: Vec<[f64; 2]> = (-12..=12)
            .flat_map(|i| (-12..=12).map(move |k| [i as f64, k as f64]))
            .collect();
        for field in [[8.0, 8.0], [7.5, 7.5], [8.3, 5.1], [0.25, 0.25]] {
            let r = covering_radius(&pts, field).unwrap();
            let want = if field == [0.25, 0.25] {
                (2.0 * 0.25f64.powi(2)).sqrt()
            } else {
                0.5f64.sqrt()
            };
            assert!((r - want).abs() < 1e-12, "{field:?} {r}");
        }
        // Through the whole pipeline: one channel of Q = 1 pixel per lens and d = mu, so
        // the samples are the lens centres' image, a square grid of pitch delta(z).
        let d = one_pixel_lenses(2.0, 0.01);
        let z = [120.0, 500.0, 3000.0];
        let c = coverage(&d, &z, 1e-6, 16.0, Some(2)).unwrap();
        for (k, &zk) in z.iter().enumerate() {
            for row in 0..2 {
                assert_eq!(c.distinct[row * 3 + k], 256);
                let r = c.covering_radius[row * 3 + k];
                assert!((r - 0.5f64.sqrt()).abs() < 1e-9, "{r}");
                let mm = c.covering_radius_mm[row * 3 + k];
                assert!((mm - r * d.resolution_step(zk)).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn covering_radius_equals_grid_search_on_random_sets() {
        let mut rng = Rng(12345);
        for case in 0..40 {
            let n = 3 + (rng.next() * 40.0) as usize;
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|_| {
                    let p = [rng.next() * 6.0 - 3.0, rng.next() * 6.0 - 3.0];
                    if case % 2 == 0 {
                        [(p[0] * 2.0).round() / 2.0, (p[1] * 2.0).round() / 2.0]
                    } else {
                        p
                    }
                })
                .collect();
            let field = [1.0 + rng.next(), 0.5 + rng.next()];
            let r = covering_radius(&pts, field).unwrap();
            let g = grid_search(&pts, field, 300);
            let cell = 2.0 * field[0].max(field[1]) / 300.0;
            assert!(r >= g - 1e-12 && r <= g + cell, "case {case}: {r} vs {g}");
        }
    }
}
