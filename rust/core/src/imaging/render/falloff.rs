//! Radiometric falloff (docs/model.md §10, "Radiometric falloff"; docs/render.md): each
//! ray's contribution weighted by cos⁴θ_m (its microlens-to-sensor segment s − x against
//! the distance v) and cos⁴θ_M (its main-lens-to-array segment x − w against L).
//!
//! At a node of the general route the rays form a polygon of cell points ξ; both
//! segments are affine in ξ (u = a ξ + b, a scalar), so the weight is a smooth function
//! over the polygon. The polygon is cut into pieces (on a grid over its box, each piece
//! at most [`piece_step`] of the weight's length scale k/|a| wide), and each piece's
//! integral is its exact mean albedo × ∫ W over the piece, ∫ W by the weight's second-order
//! Taylor expansion about the piece's centroid integrated exactly (the piece's area and
//! central second moments): exact for a weight quadratic over a piece, the error of
//! fourth order in the piece's size where the albedo is constant over it.

use super::chan::{Chan, Work};
use super::mean::scene_mean;
use crate::imaging::scene::Scene;
use crate::infra::error::{Error, Result};
use crate::infra::polygon::{bounds, clip_box, moments, Pt};

/// Which cos⁴ factors weight a ray (docs/model.md §10): none (the paper's paraxial
/// model), the microlens-to-sensor factor, the main-lens-to-array factor, or both.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Falloff {
    #[default]
    None,
    Microlens,
    Main,
    Both,
}

impl Falloff {
    /// The names the bindings accept, in order.
    pub const NAMES: [&'static str; 4] = ["none", "microlens", "main", "both"];

    /// The falloff of a name of [`Falloff::NAMES`] (an error naming `falloff` otherwise).
    pub fn from_name(name: &str) -> Result<Falloff> {
        match name {
            "none" => Ok(Falloff::None),
            "microlens" => Ok(Falloff::Microlens),
            "main" => Ok(Falloff::Main),
            "both" => Ok(Falloff::Both),
            _ => Err(Error::param(
                "falloff",
                format!("{name:?}"),
                "None, \"microlens\", \"main\" or \"both\"",
            )),
        }
    }

    /// Its name in [`Falloff::NAMES`].
    pub fn name(self) -> &'static str {
        Falloff::NAMES[self as usize]
    }

    /// Does it weight rays at all?
    pub fn is_on(self) -> bool {
        self != Falloff::None
    }

    fn microlens(self) -> bool {
        matches!(self, Falloff::Microlens | Falloff::Both)
    }

    fn main(self) -> bool {
        matches!(self, Falloff::Main | Falloff::Both)
    }
}

/// Most pieces per axis a node's polygon is cut into for the weight.
const MAX_PIECES: usize = 16;

/// The widest piece, in units of the weight's length scale k/|a|, at error target `tol`
/// (relative to a fully lit pixel under the scene's largest albedo), over a texture that
/// is constant (`constant`) or not (docs/render.md, "Radiometric falloff"):
/// - constant: 1/4 at 10⁻³, as the fourth root of `tol` (the Taylor rule's error on a
///   piece of constant albedo is of fourth order in its size: 2.6·10⁻⁴ of white on the
///   seed's white raw at 10⁻³, against an independent quadrature);
/// - otherwise 1.4 √tol (0.044 at 10⁻³): where the albedo varies over a piece the rule
///   takes the weight at the piece's centroid for the albedo's own centre, a first-order
///   error in the piece's size on the pieces an albedo edge crosses, a fraction of them
///   of first order too. Measured on the seed's half 1 (a random image on the plane at
///   1 m, 24 × 24 cells over 0.8 of the view) against 16 pieces a side, the error is
///   0.135 h² of white at a width h (6.5·10⁻³ at h = 0.22, 4.0·10⁻⁴ at 0.055): h =
///   1.4 √tol keeps it near tol/4.
pub(super) fn piece_step(tol: f64, constant: bool) -> f64 {
    let geometric = 0.25 * (tol / 1e-3).powf(0.25);
    if constant {
        geometric
    } else {
        geometric.min(TEXTURE_STEP * tol.sqrt())
    }
}

/// The widest piece over a varying texture is this × √tol ([`piece_step`]).
const TEXTURE_STEP: f64 = 1.4;

/// The weighting of one channel's rays at a render's error target.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Weighting {
    pub(crate) falloff: Falloff,
    /// [`piece_step`] of the render's relative target.
    pub(crate) step: f64,
}

/// The segments of the rays of one node's polygon as affine maps of the cell point ξ:
/// s − x = a_m ξ + b_m (against v) and x − w = a_main ξ + b_main (against L).
#[derive(Debug, Clone, Copy)]
pub(super) struct Segments {
    pub(super) a_m: f64,
    pub(super) b_m: Pt,
    pub(super) a_main: f64,
    pub(super) b_main: Pt,
}

/// cos⁴ of a segment u against the distance k, f = (1 + |u|²/k²)⁻², with its gradient
/// and Hessian [xx, xy, yy] in ξ for u = a ξ + b.
fn factor(a: f64, u: Pt, k: f64) -> (f64, Pt, [f64; 3]) {
    let k2 = k * k;
    let q = 1.0 / (1.0 + (u[0] * u[0] + u[1] * u[1]) / k2);
    let f = q * q;
    // ∇_u f = −4 u q³/k², H_u f = −4 q³/k² I + 24 q⁴ u uᵀ/k⁴; ∇_ξ = a ∇_u, H_ξ = a² H_u.
    let g = -4.0 * q * q * q / k2;
    let h = 24.0 * q * q * q * q / (k2 * k2);
    let grad = [a * g * u[0], a * g * u[1]];
    let a2 = a * a;
    let hess = [
        a2 * (g + h * u[0] * u[0]),
        a2 * h * u[0] * u[1],
        a2 * (g + h * u[1] * u[1]),
    ];
    (f, grad, hess)
}

impl Segments {
    /// The weight at ξ, its gradient and its Hessian.
    fn weight(&self, wt: &Weighting, chan: &Chan, xi: Pt) -> (f64, Pt, [f64; 3]) {
        let one = (1.0, [0.0, 0.0], [0.0; 3]);
        let at = |a: f64, b: Pt| [a * xi[0] + b[0], a * xi[1] + b[1]];
        let m = if wt.falloff.microlens() {
            factor(self.a_m, at(self.a_m, self.b_m), chan.ch.v)
        } else {
            one
        };
        let big = if wt.falloff.main() {
            factor(self.a_main, at(self.a_main, self.b_main), chan.ch.l)
        } else {
            one
        };
        let (f, g) = (
            m.0 * big.0,
            [
                m.0 * big.1[0] + big.0 * m.1[0],
                m.0 * big.1[1] + big.0 * m.1[1],
            ],
        );
        let h = [
            m.0 * big.2[0] + big.0 * m.2[0] + 2.0 * m.1[0] * big.1[0],
            m.0 * big.2[1] + big.0 * m.2[1] + m.1[0] * big.1[1] + m.1[1] * big.1[0],
            m.0 * big.2[2] + big.0 * m.2[2] + 2.0 * m.1[1] * big.1[1],
        ];
        (f, g, h)
    }

    /// The weight's length scale in ξ: the least k/|a| of the factors on.
    fn scale(&self, wt: &Weighting, chan: &Chan) -> f64 {
        let mut s = f64::INFINITY;
        if wt.falloff.microlens() && self.a_m != 0.0 {
            s = s.min(chan.ch.v / self.a_m.abs());
        }
        if wt.falloff.main() && self.a_main != 0.0 {
            s = s.min(chan.ch.l / self.a_main.abs());
        }
        s
    }
}

/// ∫ T W over the polygon `wk.poly` (cell coordinates ξ, x = c + ξ, each vertex's ray
/// through main-lens point `w_of(ξ)`): the weighted counterpart of area × [`scene_mean`].
pub(super) fn weighted_integral(
    (chan, scene, wt): (&Chan, &Scene, &Weighting),
    seg: &Segments,
    c: Pt,
    w_of: impl Fn(Pt) -> Pt,
    wk: &mut Work,
) -> f64 {
    let src = std::mem::take(&mut wk.poly);
    let (x0, x1, y0, y1) = bounds(&src);
    let h = wt.step * seg.scale(wt, chan);
    let count = |span: f64| ((span / h).ceil() as usize).clamp(1, MAX_PIECES);
    let (nx, ny) = (count(x1 - x0), count(y1 - y0));
    let mut acc = 0.0;
    for i in 0..nx {
        for j in 0..ny {
            wk.poly.clear();
            wk.poly.extend_from_slice(&src);
            if nx * ny > 1 {
                let a = |k: usize, n: usize, lo: f64, hi: f64| lo + (hi - lo) * k as f64 / n as f64;
                let (ax, bx) = (a(i, nx, x0, x1), a(i + 1, nx, x0, x1));
                let (ay, by) = (a(j, ny, y0, y1), a(j + 1, ny, y0, y1));
                clip_box(&mut wk.poly, &mut wk.tmp, ax, bx, ay, by);
            }
            let (area, cen, m) = moments(&wk.poly);
            if area <= 0.0 {
                continue;
            }
            let (f, _, hs) = seg.weight(wt, chan, cen);
            // ∫ W over the piece to second order about its centroid (the linear term
            // integrates to zero there).
            let w_int = f * area + 0.5 * (hs[0] * m[0] + 2.0 * hs[1] * m[1] + hs[2] * m[2]);
            acc += w_int * scene_mean(chan, scene, c, &w_of, wk);
        }
    }
    wk.poly = src;
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factor's gradient and Hessian against central differences.
    #[test]
    fn factor_derivatives_match_differences() {
        let (a, b, k) = (-0.7, [0.03, -0.05], 0.09);
        let f = |xi: Pt| factor(a, [a * xi[0] + b[0], a * xi[1] + b[1]], k);
        let xi = [0.02, 0.04];
        let e = 1e-5;
        let (_, g, h) = f(xi);
        let d = |i: usize| {
            let mut p = xi;
            let mut q = xi;
            p[i] += e;
            q[i] -= e;
            (f(p), f(q))
        };
        let (px, qx) = d(0);
        let (py, qy) = d(1);
        assert!((g[0] - (px.0 - qx.0) / (2.0 * e)).abs() < 1e-6);
        assert!((g[1] - (py.0 - qy.0) / (2.0 * e)).abs() < 1e-6);
        assert!((h[0] - (px.1[0] - qx.1[0]) / (2.0 * e)).abs() < 1e-4 * h[0].abs().max(1.0));
        assert!((h[1] - (py.1[0] - qy.1[0]) / (2.0 * e)).abs() < 1e-4 * h[1].abs().max(1.0));
        assert!((h[2] - (py.1[1] - qy.1[1]) / (2.0 * e)).abs() < 1e-4 * h[2].abs().max(1.0));
    }

    #[test]
    fn names_round_trip_and_bad_names_are_refused() {
        for n in Falloff::NAMES {
            assert_eq!(Falloff::from_name(n).unwrap().name(), n);
        }
        match Falloff::from_name("cos4").unwrap_err() {
            Error::InvalidParameter { name, .. } => assert_eq!(name, "falloff"),
            e => panic!("{e:?}"),
        }
    }
}
