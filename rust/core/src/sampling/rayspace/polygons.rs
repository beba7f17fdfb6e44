//! Integration polygons in (u, w): the three strips of a pixel (aperture, microlens,
//! pixel), the parallelogram they clip (through `infra::polygon`) and the residue rule.

use super::*;
use crate::infra::polygon;
use crate::sampling::line::Line;

/// A convex polygon in (u, w), counter-clockwise; `n == 0` for an empty one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polygon {
    pub n: usize,
    pub v: [[f64; 2]; MAX_VERTICES],
}

impl Polygon {
    pub const EMPTY: Polygon = Polygon {
        n: 0,
        v: [[f64::NAN; 2]; MAX_VERTICES],
    };

    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.v[..self.n]
    }

    /// Shoelace area (relative to the first vertex, for accuracy); 0 when empty.
    pub fn area(&self) -> f64 {
        polygon::signed_area_about_first(self.vertices())
    }

    /// Centroid (u, w); NaN when empty (no positive area).
    pub fn centroid(&self) -> [f64; 2] {
        let p = self.vertices();
        if p.len() < 3 || self.area() <= 0.0 {
            return [f64::NAN; 2];
        }
        polygon::centroid(p)
    }
}

/// A strip lo ≤ n·(u, w) ≤ hi in ray space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strip {
    pub n: [f64; 2],
    pub lo: f64,
    pub hi: f64,
}

/// Largest working polygon during clipping (4 + 1 per clipping line, with slack).
const WORK: usize = 10;

/// Keep the part of `p` (convex, ccw) with n·x ≤ h (Sutherland–Hodgman, one line; a vertex
/// on the line is kept once and produces no extra intersection).
fn clip_half_plane(p: &[[f64; 2]], n: [f64; 2], h: f64, out: &mut [[f64; 2]; WORK]) -> usize {
    polygon::clip_keep(p, out, |x| h - (n[0] * x[0] + n[1] * x[1]))
}

/// Polygon from a clipped vertex list: drop repeated vertices, reduce to ≤ 6 vertices
/// (only reachable through rounding: drop the vertex whose removal changes the area
/// least), and call it empty when its area is not positive.
fn finish(buf: &[[f64; 2]]) -> Polygon {
    let mut v = [[0.0; 2]; WORK];
    let mut n = 0;
    for &p in buf {
        if n == 0 || v[n - 1] != p {
            v[n] = p;
            n += 1;
        }
    }
    while n > 1 && v[n - 1] == v[0] {
        n -= 1;
    }
    while n > MAX_VERTICES {
        let mut best = (f64::INFINITY, 0);
        for i in 0..n {
            let (a, b, c) = (v[(i + n - 1) % n], v[i], v[(i + 1) % n]);
            let t = ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs();
            if t < best.0 {
                best = (t, i);
            }
        }
        v.copy_within(best.1 + 1..n, best.1);
        n -= 1;
    }
    if n < 3 || polygon::signed_area_about_first(&v[..n]) <= 0.0 {
        return Polygon::EMPTY;
    }
    let mut out = Polygon::EMPTY;
    out.n = n;
    out.v[..n].copy_from_slice(&v[..n]);
    out
}

/// The ray-space geometry of one lens type of a line: x = a u + b w on the array plane
/// (a = L/v_ref, b = 1 − L/v_ref) and the pixel strip's normal (α a, α b − v/L),
/// α = 1 + v/L − v/f (docs/model.md §4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rays {
    pub a: f64,
    pub b: f64,
    pub alpha: f64,
    pub half_aperture: f64,
    /// Lens pitch d, pixel pitch μ and v/L.
    pub d: f64,
    pub mu: f64,
    pub v_l: f64,
}

impl Rays {
    /// Lens type `t` of `line`.
    pub fn new(line: &Line, t: usize) -> Rays {
        let l = line.l;
        Rays {
            a: l / line.v_ref,
            b: 1.0 - l / line.v_ref,
            alpha: 1.0 + line.v / l - line.v / line.focal[t],
            half_aperture: line.aperture / 2.0,
            d: line.d,
            mu: line.mu,
            v_l: line.v / l,
        }
    }

    /// The three strips of a pixel at offset θ from the image centre of the lens centred
    /// at c: aperture, microlens, pixel. The pixel strip |s' − s| ≤ μ/2 with
    /// s' = α x − (v/L) w + (v/f) c and s = c (1 + v/L) + θ reads
    /// α a u + (α b − v/L) w ∈ α c + θ ± μ/2, since s − (v/f) c = c (1 + v/L − v/f) + θ
    /// (the exact form, no cancellation).
    pub fn strips(&self, c: f64, theta: f64) -> [Strip; 3] {
        let h = self.half_aperture;
        let mid = self.alpha * c + theta;
        [
            Strip {
                n: [0.0, 1.0],
                lo: -h,
                hi: h,
            },
            Strip {
                n: [self.a, self.b],
                lo: c - self.d / 2.0,
                hi: c + self.d / 2.0,
            },
            Strip {
                n: [self.alpha * self.a, self.alpha * self.b - self.v_l],
                lo: mid - self.mu / 2.0,
                hi: mid + self.mu / 2.0,
            },
        ]
    }

    /// Integration polygon of the pixel at offset θ under the lens centred at c: the
    /// parallelogram aperture strip × microlens strip, clipped by the pixel strip.
    pub fn polygon(&self, c: f64, theta: f64) -> Polygon {
        let [_, lens, pixel] = self.strips(c, theta);
        let h = self.half_aperture;
        // u = (x − b w)/a at w = ∓D/2, x = c ∓ d/2: bottom-left, bottom-right, top-right,
        // top-left (a > 0, so counter-clockwise).
        let u = |x: f64, w: f64| (x - self.b * w) / self.a;
        let quad = [
            [u(lens.lo, -h), -h],
            [u(lens.hi, -h), -h],
            [u(lens.hi, h), h],
            [u(lens.lo, h), h],
        ];
        let mut b1 = [[0.0; 2]; WORK];
        let mut b2 = [[0.0; 2]; WORK];
        let n1 = clip_half_plane(&quad, pixel.n, pixel.hi, &mut b1);
        let neg = [-pixel.n[0], -pixel.n[1]];
        let n2 = clip_half_plane(&b1[..n1], neg, -pixel.lo, &mut b2);
        finish(&b2[..n2])
    }

    /// Chief ray (u, w) through the lens centre (x = c) at main-lens height w.
    pub fn chief(&self, c: f64, w: f64) -> [f64; 2] {
        [(c - self.b * w) / self.a, w]
    }
}

/// A polygon whose area is below this fraction of the largest polygon area of its half is
/// unlit (docs/model.md §9, "Lit by area"): such an area is the rounding residue of a
/// boundary contact (exact area 0), not light.
pub const LIT_AREA_RTOL: f64 = 1e-9;

/// Empty every polygon whose area is below [`LIT_AREA_RTOL`] of the largest in `polygons`.
pub fn drop_residue(polygons: &mut [Polygon]) {
    let floor = LIT_AREA_RTOL * polygons.iter().map(Polygon::area).fold(0.0, f64::max);
    for p in polygons.iter_mut() {
        if p.n > 0 && p.area() < floor {
            *p = Polygon::EMPTY;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera::Camera;
    use crate::sampling::rayspace::test_designs::*;

    #[test]
    fn strip_offset_matches_pixel_center() {
        // α c + θ_q is s − (v/f) c with s = c (1 + v/L) + θ_q, the pixel's sensor position.
        let d = design(Some(0.5), Some(0.9));
        for channel in [1, 2] {
            let ln = line(&d, channel, Axis::X);
            let rays = Rays::new(&ln, 0);
            for q in [0, 7, 14] {
                let c = ln.lens_center(5);
                let theta = ln.ideal_offset(q, 15);
                let s = rays.strips(c, theta)[2];
                let want = c * (1.0 + ln.v / ln.l) + theta - ln.v / ln.focal[0] * c;
                assert!(((s.lo + s.hi) / 2.0 - want).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn half1_ng_rectangles() {
        // docs/model.md §8: width d, height μ v'/v, axis-aligned, in Ng's setting.
        let d = Camera::paper().design();
        let ch = &d.channels[0];
        let tr = trace_line(&line(&d, 1, Axis::X)).unwrap();
        let h = ch.mu * ch.l / ch.v;
        for (i, p) in tr.polygons.iter().enumerate() {
            assert!(tr.lit[i]);
            assert_eq!(p.n, 4);
            let us: Vec<f64> = p.vertices().iter().map(|v| v[0]).collect();
            let ws: Vec<f64> = p.vertices().iter().map(|v| v[1]).collect();
            let umin = us.iter().cloned().fold(f64::INFINITY, f64::min);
            let umax = us.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let wmin = ws.iter().cloned().fold(f64::INFINITY, f64::min);
            let wmax = ws.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            assert!(close(umax - umin, ch.d, 1e-12));
            assert!(close(wmax - wmin, h, 1e-9));
            assert!(close(p.area(), ch.d * h, 1e-9));
        }
    }

    #[test]
    fn light_is_conserved_under_each_microlens() {
        // docs/model.md §8: Σ areas = D d v'/L_i when the microlens image fits in its Q pixels.
        let d = Camera::paper().design();
        for channel in [1, 2] {
            let ln = line(&d, channel, Axis::Y);
            let tr = trace_line(&ln).unwrap();
            let full = d.aperture * ln.d * ln.v_ref / ln.l;
            for lens in tr.area.chunks(15) {
                let s: f64 = lens.iter().sum();
                assert!(close(s, full, 1e-12), "{s} vs {full}");
            }
        }
    }

    #[test]
    fn chief_ray_lies_inside_lit_polygons() {
        let d = design(Some(0.7), None);
        for channel in [1, 2] {
            let tr = trace_line(&line(&d, channel, Axis::X)).unwrap();
            for i in 0..tr.polygons.len() {
                if tr.lit[i] {
                    assert!(tr.area[i] > 0.0);
                }
            }
        }
    }
}
