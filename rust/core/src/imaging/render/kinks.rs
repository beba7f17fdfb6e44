//! Where a lens's outer integrand kinks and how its box is cut: the texture's own lines
//! (image cells, bar edges) crossed by the polygon's moving vertex lines, and the sorted
//! cuts of the outer box (docs/render.md).

use super::chan::Work;
use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::Texture;

/// The lines along one axis (0: X, 1: Y) where a texture's albedo jumps, as (origin,
/// spacing, first, last index): an image's cell edges, a bar chart's bar edges; and a
/// sinusoid's quarter periods (its zeros and extrema), between which it is close to a
/// cubic, which the adaptive rule's 2- and 3-point rules see; over a box on which the
/// polygon moves several periods they can agree by chance and both be wrong (measured
/// against the exact route: 3.5e-2 of white, 3.1 cycles/mm on the seed's half 2 at 1 m).
fn texture_lines(t: &Texture, axis: usize) -> Option<(f64, f64, i64, i64)> {
    match t {
        Texture::Image(im) => {
            let (x0, x1, y0, y1) = im.extent();
            let (rows, cols) = im.shape();
            Some(if axis == 0 {
                (x0, (x1 - x0) / cols as f64, 0, cols as i64)
            } else {
                (y0, (y1 - y0) / rows as f64, 0, rows as i64)
            })
        }
        Texture::Bars { frequency, .. } if axis == 0 => {
            // (Bars wider than f64::MAX / 2, as in the texture's own integral: a finite
            // spacing keeps the edge at X = 0 a cut, where 0 × ∞ made it NaN.)
            let h = (0.5 / frequency).min(0.5 * f64::MAX);
            Some((0.0, h, i64::MIN / 4, i64::MAX / 4))
        }
        Texture::Sinusoid {
            frequency, phase, ..
        } if axis == 0 => {
            let h = (0.25 / frequency).min(0.5 * f64::MAX);
            // The zero of 2π f X + phase nearest X = 0 (the origin only sets the lines'
            // phase: any of them is one).
            let o = (-phase / (2.0 * std::f64::consts::PI * frequency)).rem_euclid(h);
            Some((
                if o.is_finite() { o } else { 0.0 },
                h,
                i64::MIN / 4,
                i64::MAX / 4,
            ))
        }
        _ => None,
    }
}

/// Largest scene image of a pixel's polygon, in texture cells, whose kinks count as
/// strong (cut at, up to [`MAX_KINKS`]).
const KINK_CELLS: f64 = 4.0;
/// Texture kinks always cut on one axis, however wide the polygon's scene image.
const FEW_KINKS: usize = 8;
/// Most texture kinks added to one axis's cuts.
const MAX_KINKS: usize = 40;
/// Beyond the kinks cut at, the interval is split uniformly so that no vertex of the
/// polygon's scene image moves over more than this many texture cells in one part ...
const MOTION_CELLS: f64 = 4.0;
/// ... in at most this many parts.
const MAX_SPLITS: usize = 16;
/// The same two when a map is recorded: each cell's weight (not only their sum, the
/// texture's average) must come out right, so the parts are shorter.
const RECORD_MOTION_CELLS: f64 = 1.0;
const RECORD_SPLITS: usize = 48;

/// A polygon's vertex lines along one axis as the outer variable t of a lens's quadrature
/// runs over `span`: each a line P = slope t + intercept on the scene (the polygon's edges
/// that move with t), `extent` the width of the polygon's scene image.
pub(super) struct Sweep<'a> {
    /// 0: X, 1: Y.
    pub axis: usize,
    pub extent: f64,
    /// (slope, intercept) per moving line.
    pub moving: &'a [(f64, f64)],
    /// (t0, t1).
    pub span: (f64, f64),
}

/// Add to `out` the values of the outer variable t in the sweep's span where one of its
/// moving lines crosses one of the texture's lines along its axis. When they are too many,
/// `out` gets uniform splits instead (shorter ones in `record` mode). True when the cuts
/// are every kink (or the texture has none).
pub(super) fn texture_kinks(
    texture: &Texture,
    sweep: &Sweep,
    separable: bool,
    record: bool,
    out: &mut Vec<f64>,
) -> bool {
    let Sweep {
        axis,
        extent,
        moving,
        span: (t0, t1),
    } = *sweep;
    let Some((o, h, first, last)) = texture_lines(texture, axis) else {
        return true;
    };
    // The integrand has a kink wherever a vertex line crosses a texture line, of slope
    // jump ~ contrast / (image width in cells). Kinks are cut at when they are few, or
    // when strong (images of a few cells) and not too many. Otherwise the integrand
    // varies on the scale of one cell of motion: the 2- and 3-point rules, comparing
    // each other on a box over which it moves many cells, can agree by chance and both
    // be wrong (measured against the exact route: 1.6e-2 of white on the seed's half 2 at
    // 800 mm, a 7-cell image moving 40 cells over the box; 3.8e-3 on half 1 at 1000 mm,
    // 12 cells moving 6). So the interval is split into parts of at most MOTION_CELLS
    // cells of motion (more for wide images) before the adaptive rule starts.
    // With a `separable` polygon (rect cell, square aperture: the polygon is a product of
    // intervals) every kink crossing is cut at up to MAX_KINKS: on a fronto-parallel plane
    // the integrand is then bilinear between cuts, and exact; hex cells and discs move
    // their vertices obliquely, so that cuts per axis cannot follow them anyway.
    let weak = extent > KINK_CELLS * h;
    let start = out.len();
    let mut count = 0usize;
    let mut motion = 0.0f64;
    for &(slope, icpt) in moving {
        if slope == 0.0 || !slope.is_finite() {
            continue;
        }
        let (pa, pb) = (slope * t0 + icpt, slope * t1 + icpt);
        let (lo, hi) = if pa < pb { (pa, pb) } else { (pb, pa) };
        let i0 = (((lo - o) / h).ceil() as i64).max(first);
        let i1 = (((hi - o) / h).floor() as i64).min(last);
        if i1 < i0 {
            continue;
        }
        // Motion over the texture's own lines only (outside it the albedo is constant).
        let (a, b) = (lo.max(o + first as f64 * h), hi.min(o + last as f64 * h));
        motion = motion.max((b - a) / h);
        count += (i1 - i0 + 1) as usize;
        if count <= MAX_KINKS {
            for i in i0..=i1 {
                out.push((o + i as f64 * h - icpt) / slope);
            }
        }
    }
    if count <= FEW_KINKS || ((!weak || separable) && count <= MAX_KINKS) {
        return true;
    }
    out.truncate(start);
    let (cells, most) = if record {
        (RECORD_MOTION_CELLS, RECORD_SPLITS)
    } else {
        (MOTION_CELLS, MAX_SPLITS)
    };
    let per_part = cells * (extent / h / KINK_CELLS).max(1.0).sqrt();
    let n = ((motion / per_part).ceil() as usize).clamp(1, most);
    for k in 1..n {
        out.push(t0 + (t1 - t0) * k as f64 / n as f64);
    }
    false
}

/// Add to `out` the values of the outer variable t in the sweep's span where one of its
/// moving lines crosses an edge of a depth map's extent along its axis: beyond the edge
/// there is no surface and the rays see the background, a kink of the integrand that the
/// adaptive rule's 2- and 3-point rules can both straddle unseen (measured: a flat map at
/// 700 mm on the seed cut to 2 × 2 lenses, pixels whose rays leave the extent over a
/// sliver of their outer box read 0.5 where the exact route gives 0.4958, 8.5·10⁻³ of
/// white off). The lines are the sweep's, at its reference depth: exact on a map flat
/// near its edge; elsewhere the cut is where the edge is crossed at that depth.
pub(super) fn extent_kinks(scene: &Scene, sweep: &Sweep, out: &mut Vec<f64>) {
    let Surface::Map(m) = &scene.surface else {
        return;
    };
    let e = m.extent();
    let edges = if sweep.axis == 0 {
        [e[0], e[1]]
    } else {
        [e[2], e[3]]
    };
    let (t0, t1) = sweep.span;
    for &(slope, icpt) in sweep.moving {
        if slope == 0.0 || !slope.is_finite() {
            continue;
        }
        for edge in edges {
            let t = (edge - icpt) / slope;
            if t > t0 && t < t1 {
                out.push(t);
            }
        }
    }
}

/// Is the outer integrand bilinear between the cuts? So it is when the polygon is a product
/// of intervals with linearly moving ends (`separable`), the cuts hold every texture kink
/// (`complete`), the plane is fronto-parallel (the map to the scene is affine) and the
/// texture is constant between its lines ([`texture_lines`]).
pub(super) fn bilinear(scene: &Scene, separable: bool, complete: bool) -> bool {
    separable
        && complete
        && scene.surface.fronto().is_some()
        && matches!(
            scene.texture,
            Texture::Image(_) | Texture::Bars { .. } | Texture::Constant(_)
        )
}

/// The cuts of a lens's outer box [x0, x1] × [y0, y1] from its candidate breakpoints per
/// axis (in `wk`'s buffers: hand them back with `wk.cuts_a = cx; wk.cuts_b = cy`).
pub(super) fn box_cuts(
    wk: &mut Work,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    kx: &[f64],
    ky: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let mut cx = std::mem::take(&mut wk.cuts_a);
    let mut cy = std::mem::take(&mut wk.cuts_b);
    intervals(x0, x1, kx, &mut cx);
    intervals(y0, y1, ky, &mut cy);
    (cx, cy)
}

/// Sorted unique cuts of [lo, hi] (including both ends) from candidate breakpoints.
pub(super) fn intervals(lo: f64, hi: f64, cands: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.push(lo);
    let tol = 1e-12 * (hi - lo).abs().max(f64::MIN_POSITIVE);
    let mut c: Vec<f64> = cands
        .iter()
        .copied()
        .filter(|&b| b > lo + tol && b < hi - tol)
        .collect();
    c.sort_by(|a, b| a.total_cmp(b));
    for b in c {
        if b > *out.last().unwrap_or(&lo) + tol {
            out.push(b);
        }
    }
    out.push(hi);
}
