//! The general route's 2-D adaptive quadrature: Gauss–Legendre 2 × 2 against 3 × 3 on
//! boxes, halved where they disagree or where a texture discontinuity sweeps through, and
//! the fixed rule of record mode (docs/render.md).

use super::chan::Work;

/// A box [x0, x1] × [y0, y1] of a lens's outer variables.
#[derive(Debug, Clone, Copy)]
pub(super) struct QBox {
    pub x0: f64,
    pub x1: f64,
    pub y0: f64,
    pub y1: f64,
}

impl QBox {
    pub(super) fn new(x0: f64, x1: f64, y0: f64, y1: f64) -> QBox {
        QBox { x0, x1, y0, y1 }
    }
}

/// 2-D adaptive quadrature on the box [x0, x1] × [y0, y1]: the 3 × 3 Gauss–Legendre rule,
/// accepted when it differs from the 2 × 2 rule by at most `tol`; otherwise the box is cut
/// in four (at most [`MAX_DEPTH`] times), each quarter with a quarter of the tolerance. Both
/// rules are exact for bicubic integrands, so on boxes between the known kinks of a
/// constant or piecewise constant texture the first test already passes. A box whose
/// integral `closed` knows exactly (the interior of a lens on a fronto-parallel plane:
/// docs/render.md) takes it, at any level.
pub(super) fn adaptive(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    (rough, closed): (
        &impl Fn(f64, f64, f64, f64, &mut Work) -> bool,
        &impl Closed,
    ),
    bx: QBox,
    tol: f64,
    depth: u32,
    wk: &mut Work,
) -> f64 {
    let QBox { x0, x1, y0, y1 } = bx;
    let (xm, xh, ym, yh) = (
        0.5 * (x0 + x1),
        0.5 * (x1 - x0),
        0.5 * (y0 + y1),
        0.5 * (y1 - y0),
    );
    if wk.rec.is_some() {
        fixed_rule(f, x0, x1, y0, y1, wk);
        return 0.0;
    }
    if let Some(v) = closed(bx, wk) {
        return v;
    }
    let area = 4.0 * xh * yh;
    let t = 0.25 * tol;
    if depth < ROUGH_DEPTH && rough(x0, x1, y0, y1, wk) {
        // A texture discontinuity sweeps through the box: the rules cannot see it.
        return quartered(f, (rough, closed), bx, t, depth, wk);
    }
    // 2 × 2 and 3 × 3 Gauss–Legendre: the difference bounds the 2-point rule's error
    // and, far more pessimistically, the 3-point rule's, which is returned.
    let g1 = area * gauss(G2, f, xm, xh, ym, yh, wk);
    let g2 = area * gauss(G3, f, xm, xh, ym, yh, wk);
    if (g2 - g1).abs() <= tol + wk.rel_floor * g2.abs() || depth >= MAX_DEPTH {
        return g2;
    }
    quartered(f, (rough, closed), bx, t, depth, wk)
}

/// [`adaptive`] over the box's four quarters (at `depth` + 1, each with `tol`), summed in
/// the order lower left, lower right, upper left, upper right.
fn quartered(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    hooks: (
        &impl Fn(f64, f64, f64, f64, &mut Work) -> bool,
        &impl Closed,
    ),
    bx: QBox,
    tol: f64,
    depth: u32,
    wk: &mut Work,
) -> f64 {
    let QBox { x0, x1, y0, y1 } = bx;
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let quarters = [
        QBox::new(x0, xm, y0, ym),
        QBox::new(xm, x1, y0, ym),
        QBox::new(x0, xm, ym, y1),
        QBox::new(xm, x1, ym, y1),
    ];
    let mut sum = adaptive(f, hooks, quarters[0], tol, depth + 1, wk);
    for q in &quarters[1..] {
        sum += adaptive(f, hooks, *q, tol, depth + 1, wk);
    }
    sum
}

/// A Gauss–Legendre rule on [-1, 1]: nodes and weights (the weights sum to 1, the mean).
type Rule = (&'static [f64], &'static [f64]);
/// 2-point Gauss–Legendre (exact for cubics).
const G2: Rule = (
    &[-0.577_350_269_189_625_8, 0.577_350_269_189_625_8],
    &[0.5, 0.5],
);
/// 3-point Gauss–Legendre (exact for quintics).
const G3: Rule = (
    &[-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4],
    &[5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0],
);

/// The mean of `f` over the box centred on (xm, ym) with half-sides (xh, yh) by `rule`
/// along both axes.
fn gauss(
    rule: Rule,
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    xm: f64,
    xh: f64,
    ym: f64,
    yh: f64,
    wk: &mut Work,
) -> f64 {
    let mut sum = 0.0;
    wk.evals += (rule.0.len() * rule.0.len()) as u64;
    for (&sx, &wx) in rule.0.iter().zip(rule.1) {
        for (&sy, &wy) in rule.0.iter().zip(rule.1) {
            sum += wx * wy * f(xm + sx * xh, ym + sy * yh, wk);
        }
    }
    sum
}

/// The record-mode rule on a box (its decisions cannot depend on one texture's values):
/// 3 × 3 Gauss–Legendre. Each node's weight is handed to the recorder before the integrand
/// runs. (Record mode reaches it on depth maps only: on a plane the record is
/// [`super::footprint`]'s.)
pub(super) fn fixed_rule(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    wk: &mut Work,
) {
    let (nodes, weights) = G3;
    let (hx, hy) = (0.5 * (x1 - x0), 0.5 * (y1 - y0));
    let (xm, ym) = (x0 + hx, y0 + hy);
    let area = 4.0 * hx * hy;
    for (&sx, &wx) in nodes.iter().zip(weights) {
        for (&sy, &wy) in nodes.iter().zip(weights) {
            if let Some(r) = wk.rec.as_deref_mut() {
                r.node = area * wx * wy;
            }
            f(xm + sx * hx, ym + sy * hy, wk);
        }
    }
}

/// A box's exact integral when known (else `None`): [`adaptive`]'s and [`over_boxes`]' hook.
pub(super) trait Closed: Fn(QBox, &mut Work) -> Option<f64> {}
impl<F: Fn(QBox, &mut Work) -> Option<f64>> Closed for F {}

/// The hook of a quadrature that knows no box's integral.
pub(super) fn never(_: QBox, _: &mut Work) -> Option<f64> {
    None
}

/// Halvings forced on a box that a texture discontinuity sweeps (a feature the 2- and
/// 3-point rules could both miss is then at most 1/64 of the box).
const ROUGH_DEPTH: u32 = 3;
/// Most halvings of a box by [`adaptive`].
const MAX_DEPTH: u32 = 6;

/// Adaptive quadrature over the boxes between consecutive cuts, the tolerance shared in
/// proportion to their areas; with `bilinear` (the integrand is known to be bilinear
/// on each box) the midpoint rule alone; a box whose integral `closed` knows takes it.
pub(super) fn over_boxes(
    f: &mut impl FnMut(f64, f64, &mut Work) -> f64,
    (rough, closed): (
        &impl Fn(f64, f64, f64, f64, &mut Work) -> bool,
        &impl Closed,
    ),
    (cx, cy): (&[f64], &[f64]),
    tol: f64,
    bilinear: bool,
    wk: &mut Work,
) -> f64 {
    let total = (cx[cx.len() - 1] - cx[0]) * (cy[cy.len() - 1] - cy[0]);
    let mut s = 0.0;
    for i in 1..cx.len() {
        for j in 1..cy.len() {
            let a = (cx[i] - cx[i - 1]) * (cy[j] - cy[j - 1]);
            let bx = QBox::new(cx[i - 1], cx[i], cy[j - 1], cy[j]);
            if wk.rec.is_none() {
                if let Some(v) = closed(bx, wk) {
                    s += v;
                    continue;
                }
            }
            if bilinear {
                // Bilinear between the cuts (a fronto-parallel plane, never in record mode):
                // the midpoint rule is exact.
                let (xm, ym) = (0.5 * (cx[i - 1] + cx[i]), 0.5 * (cy[j - 1] + cy[j]));
                wk.evals += 1;
                s += a * f(xm, ym, wk);
                continue;
            }
            s += adaptive(f, (rough, closed), bx, tol * a / total, 0, wk);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn adaptive_is_exact_on_bilinear_and_converges_on_a_disc() {
        let mut wk = Work::default();
        let mut f = |x: f64, y: f64, _: &mut Work| 1.0 + 2.0 * x - y + 3.0 * x * y;
        let smooth0 = |_: f64, _: f64, _: f64, _: f64, _: &mut Work| false;
        let v = adaptive(
            &mut f,
            (&smooth0, &never),
            QBox::new(0.0, 2.0, -1.0, 1.0),
            1e-12,
            0,
            &mut wk,
        );
        assert!((v - 12.0).abs() < 1e-12, "{v}");
        let mut disc = |x: f64, y: f64, _: &mut Work| if x * x + y * y < 1.0 { 1.0 } else { 0.0 };
        let smooth = |_: f64, _: f64, _: f64, _: f64, _: &mut Work| false;
        let v = adaptive(
            &mut disc,
            (&smooth, &never),
            QBox::new(-1.0, 1.0, -1.0, 1.0),
            1e-3,
            0,
            &mut wk,
        );
        assert!((v - PI).abs() < 0.05, "{v}");
    }
}
