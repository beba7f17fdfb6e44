//! A depth estimate made into a surface that `reconstruct` can take fast (docs/depth.md,
//! "The estimate's surface"): a map every ray through the main lens meets at most once
//! ([`DepthMap::seen_once`]), so that its map takes the footprint route
//! (docs/reconstruct.md step 6) instead of the render's own first-hit integral.
//!
//! The surface z minimises
//!
//!   Σ_cells a_i (z_i − d_i)² + λ Σ_cells (c_x (∂²_x z)² + c_y (∂²_y z)²)
//!                            + Σ_neighbours e_ij (z_i − z_j)²
//!
//! (d the estimate, a_i its confidence on confident cells and 0 elsewhere, λ = [`SMOOTH`],
//! ∂² the second differences along a row and a column): confident cells hold, the others
//! follow their neighbours (a plane, and any bilinear surface, is left as it is: the
//! cells of a plane with unconfident holes keep the plane, in the holes too). Two steps
//! shape the weights c and e:
//! - **Jumps the data show stay jumps**: an edge between two confident cells is cut (the
//!   second differences that span it get c = 0) when the three cells on either side along
//!   the axis are all confident, agree among themselves within a quarter of the step
//!   between the two sides' medians, and that step is more than [`JUMP`] of the nearer
//!   side's depth.
//! - **Slopes every ray meets once**: after each solve, every bilinear patch that fails
//!   [`DepthMap::patch_faces`] (the facing condition of `seen_once`, the aperture's box
//!   given) is stiffened and the map solved again, until every patch passes: first its
//!   curvature terms ([`STIFFEN`] times a round, up to [`CURVE_CAP`]), which smooths a
//!   bump or a jump into a ramp and keeps a plane's own slope; where those are at the cap
//!   and the patch still fails (a slope too steep in itself), its four edges (e from 0 to
//!   λ [`STIFFEN`], then [`STIFFEN`] times more a round), which flattens it. So the loop
//!   ends, and a jump becomes a ramp about as steep as the condition allows (it spreads
//!   over as many cells as that slope needs). After [`MAX_ROUNDS`] rounds the deviations from the confident
//!   cells' weighted mean are scaled down by the largest factor that makes every patch
//!   pass (each patch's lead term scales with the factor, its depths tend to the mean), a
//!   last resort that the tests report when it is taken.
//!
//! The solve is Jacobi-preconditioned conjugate gradients, warm-started from the previous
//! round's surface.

use crate::imaging::scene::DepthMap;
use crate::infra::error::{Error, Result};
use crate::infra::parallel::checkpoint;
use crate::model::design::Design;

/// λ, the neighbours' weight against a fully confident cell's (a confident cell holds
/// its depth against its four neighbours' pull at weight 1 each).
pub const SMOOTH: f64 = 1.0;
/// A step between two confident, self-consistent sides larger than this share of the
/// nearer side's depth is a jump the data show: its edge is cut.
pub const JUMP: f64 = 0.03;
/// A surface no cell of which is further than this share of the depth from its
/// confidence-weighted plane is taken as that plane (its depths replaced by the plane's):
/// [`JUMP`], the least step the surface keeps as an edge the data show, so a surface
/// within it of a plane shows no edge. Its rows are then the plane's (the tilted route,
/// docs/reconstruct.md step 6, "An estimate is taken as its surface").
pub const PLANE_FIT: f64 = JUMP;
/// The factor by which a failing patch's edges are stiffened each round.
pub const STIFFEN: f64 = 4.0;
/// Rounds of stiffening before the last resort (a global scale toward the mean).
pub const MAX_ROUNDS: usize = 200;
/// The largest curvature weight (4^8: the patch is a straight ramp between its
/// neighbours), beyond which a failing patch's edges are stiffened instead.
pub const CURVE_CAP: f64 = 65_536.0;
/// The largest edge weight (a stiffened edge stops there: 4^13).
const MAX_WEIGHT: f64 = 6.7e7;
/// Every cell's least data weight, a share of the largest (keeps the system definite).
const FLOOR: f64 = 1e-9;
/// CG's stop (relative residual) and iteration cap per solve.
const CG_RTOL: f64 = 1e-10;
const CG_MAX_ITER: usize = 20_000;

/// The estimate: depths (row-major, row 0 at the top, `rows` × `cols`, mm) over `extent`
/// (X0, X1, Y0, Y1), each cell's confidence (None: 1) and whether it is confident (None:
/// every cell), and the half-side `r` of a box holding the main lens's aperture.
#[derive(Clone, Copy, Debug)]
pub struct Input<'a> {
    pub depth: &'a [f64],
    pub confidence: Option<&'a [f64]>,
    pub confident: Option<&'a [bool]>,
    pub rows: usize,
    pub cols: usize,
    pub extent: [f64; 4],
    pub r: f64,
}

/// The surface (as the input's depths) and how it was made: the stiffening rounds, the
/// edges cut as jumps, and the last resort's scale (1: not taken).
#[derive(Clone, Debug)]
pub struct Surface {
    pub depth: Vec<f64>,
    pub rounds: usize,
    pub cuts: usize,
    pub scale: f64,
    /// The plane (z0, gx, gy) the surface was fitted into, if it was ([`PLANE_FIT`]).
    pub plane: Option<[f64; 3]>,
}

/// The half-side of a box holding the design's main-lens aperture (the box
/// [`DepthMap::seen_once`] is checked over when a map's route is chosen).
pub fn aperture_box(design: &Design) -> f64 {
    let ch = &design.channels[0];
    crate::imaging::render::Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL)
        .aperture_box()
}

/// The prior's weights: the curvature terms' `cx[r * cols + c]` on the second difference
/// centred at (r, c) along a row and `cy[r * cols + c]` along a column (1, or 0 where it
/// spans a cut), and the stiffening's `x[r * (cols - 1) + c]` between (r, c) and
/// (r, c + 1) and `y[r * cols + c]` between (r, c) and (r + 1, c) (0 until a patch
/// fails). Rows from the top.
struct Edges {
    rows: usize,
    cols: usize,
    cx: Vec<f64>,
    cy: Vec<f64>,
    x: Vec<f64>,
    y: Vec<f64>,
}

impl Edges {
    fn new(rows: usize, cols: usize) -> Edges {
        let n = rows * cols;
        let mut cx = vec![0.0; n];
        let mut cy = vec![0.0; n];
        for r in 0..rows {
            for c in 0..cols {
                if c > 0 && c + 1 < cols {
                    cx[r * cols + c] = 1.0;
                }
                if r > 0 && r + 1 < rows {
                    cy[r * cols + c] = 1.0;
                }
            }
        }
        Edges {
            rows,
            cols,
            cx,
            cy,
            x: vec![0.0; rows * cols.saturating_sub(1)],
            y: vec![0.0; rows.saturating_sub(1) * cols],
        }
    }

    /// Cut the edge between cells i and j = i + stride (stride 1: along a row; cols: along
    /// a column): the curvature terms centred on either end no longer span it.
    fn cut(&mut self, i: usize, along_row: bool) {
        let (c, j) = if along_row {
            (&mut self.cx, i + 1)
        } else {
            (&mut self.cy, i + self.cols)
        };
        c[i] = 0.0;
        c[j] = 0.0;
    }

    /// out = (diag(a) + P) z, P the prior's (curvature and stiffening) quadratic form.
    fn apply(&self, a: &[f64], z: &[f64], out: &mut [f64]) {
        let (rows, cols) = (self.rows, self.cols);
        for (o, (ai, zi)) in out.iter_mut().zip(a.iter().zip(z)) {
            *o = ai * zi;
        }
        for (stride, curv) in [(1, &self.cx), (cols, &self.cy)] {
            for (k, &w) in curv.iter().enumerate() {
                if w != 0.0 {
                    let q = SMOOTH * w * (z[k - stride] - 2.0 * z[k] + z[k + stride]);
                    out[k - stride] += q;
                    out[k] -= 2.0 * q;
                    out[k + stride] += q;
                }
            }
        }
        for r in 0..rows {
            for c in 0..cols.saturating_sub(1) {
                let (i, j) = (r * cols + c, r * cols + c + 1);
                let f = self.x[r * (cols - 1) + c] * (z[i] - z[j]);
                out[i] += f;
                out[j] -= f;
            }
        }
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols {
                let (i, j) = (r * cols + c, (r + 1) * cols + c);
                let f = self.y[r * cols + c] * (z[i] - z[j]);
                out[i] += f;
                out[j] -= f;
            }
        }
    }

    /// The diagonal of diag(a) + P.
    fn diagonal(&self, a: &[f64]) -> Vec<f64> {
        let (rows, cols) = (self.rows, self.cols);
        let mut d = a.to_vec();
        for (stride, curv) in [(1, &self.cx), (cols, &self.cy)] {
            for (k, &w) in curv.iter().enumerate() {
                if w != 0.0 {
                    d[k - stride] += SMOOTH * w;
                    d[k] += 4.0 * SMOOTH * w;
                    d[k + stride] += SMOOTH * w;
                }
            }
        }
        for r in 0..rows {
            for c in 0..cols.saturating_sub(1) {
                let e = self.x[r * (cols - 1) + c];
                d[r * cols + c] += e;
                d[r * cols + c + 1] += e;
            }
        }
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols {
                let e = self.y[r * cols + c];
                d[r * cols + c] += e;
                d[(r + 1) * cols + c] += e;
            }
        }
        d
    }
}

/// Cut the edges across jumps the data show (module doc); the count cut.
fn cut_jumps(edges: &mut Edges, d: &[f64], conf: &[bool]) -> usize {
    let (rows, cols) = (edges.rows, edges.cols);
    // The median and spread of three confident cells, None if any is not.
    let side = |cells: [usize; 3]| -> Option<(f64, f64)> {
        if !cells.iter().all(|&k| conf[k]) {
            return None;
        }
        let mut v = cells.map(|k| d[k]);
        v.sort_unstable_by(f64::total_cmp);
        Some((v[1], v[2] - v[0]))
    };
    let jump = |lo: Option<(f64, f64)>, hi: Option<(f64, f64)>| match (lo, hi) {
        (Some((m0, s0)), Some((m1, s1))) => {
            let step = (m1 - m0).abs();
            step > JUMP * m0.min(m1) && s0.max(s1) < 0.25 * step
        }
        _ => false,
    };
    // Three cells on either side of the edge after cell k along a line of n cells
    // (clamped at the line's ends), as indices along the line.
    let sides = |k: usize, n: usize| {
        let at = |v: isize| v.clamp(0, n as isize - 1) as usize;
        let k = k as isize;
        (
            [at(k - 2), at(k - 1), at(k)],
            [at(k + 1), at(k + 2), at(k + 3)],
        )
    };
    let mut cuts = 0;
    for r in 0..rows {
        for c in 0..cols.saturating_sub(1) {
            let (lo, hi) = sides(c, cols);
            if jump(
                side(lo.map(|k| r * cols + k)),
                side(hi.map(|k| r * cols + k)),
            ) {
                edges.cut(r * cols + c, true);
                cuts += 1;
            }
        }
    }
    for r in 0..rows.saturating_sub(1) {
        let (lo, hi) = sides(r, rows);
        for c in 0..cols {
            if jump(
                side(lo.map(|k| k * cols + c)),
                side(hi.map(|k| k * cols + c)),
            ) {
                edges.cut(r * cols + c, false);
                cuts += 1;
            }
        }
    }
    cuts
}

/// Solve (diag(a) + λ L_e) z = a ∘ d by Jacobi-preconditioned CG from `z`.
fn solve(edges: &Edges, a: &[f64], d: &[f64], z: &mut [f64]) -> Result<()> {
    let n = z.len();
    let b: Vec<f64> = a.iter().zip(d).map(|(ai, di)| ai * di).collect();
    let inv: Vec<f64> = edges.diagonal(a).iter().map(|v| 1.0 / v).collect();
    let norm_b = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut q = vec![0.0; n];
    edges.apply(a, z, &mut q);
    let mut r: Vec<f64> = b.iter().zip(&q).map(|(bi, qi)| bi - qi).collect();
    let mut s: Vec<f64> = r.iter().zip(&inv).map(|(ri, m)| ri * m).collect();
    let mut p = s.clone();
    let mut rho: f64 = r.iter().zip(&s).map(|(x, y)| x * y).sum();
    for it in 0..CG_MAX_ITER {
        if r.iter().map(|v| v * v).sum::<f64>().sqrt() <= CG_RTOL * norm_b {
            break;
        }
        if it % 256 == 0 {
            checkpoint()?;
        }
        edges.apply(a, &p, &mut q);
        let pq: f64 = p.iter().zip(&q).map(|(x, y)| x * y).sum();
        if pq.is_nan() || pq <= 0.0 {
            break;
        }
        let alpha = rho / pq;
        for k in 0..n {
            z[k] += alpha * p[k];
            r[k] -= alpha * q[k];
            s[k] = r[k] * inv[k];
        }
        let next: f64 = r.iter().zip(&s).map(|(x, y)| x * y).sum();
        let beta = next / rho;
        rho = next;
        for k in 0..n {
            p[k] = s[k] + beta * p[k];
        }
    }
    Ok(())
}

/// Stiffen every patch that fails the facing condition; how many failed. First its
/// curvature terms (the second differences centred on its corners, [`STIFFEN`] times
/// each round up to [`CURVE_CAP`]): that smooths a bump or a jump into a ramp and keeps a
/// plane's own slope; a patch whose curvature terms are at the cap and still fails (a
/// slope too steep in itself) has its four edges stiffened, which flattens it.
fn stiffen(edges: &mut Edges, map: &DepthMap, r: f64) -> usize {
    let (rows, cols) = (edges.rows, edges.cols);
    let mut failed = 0;
    let up = |w: &mut f64, cap: f64| *w = (w.max(SMOOTH) * STIFFEN).min(cap);
    for b in 0..rows.saturating_sub(1).max(1) {
        for i in 0..cols.saturating_sub(1).max(1) {
            if map.patch_faces(b, i, r) {
                continue;
            }
            failed += 1;
            // Rows from the top: the patch's rows (rb above ra) and columns.
            let (ra, rb) = (rows - 1 - b, rows - 1 - (b + 1).min(rows - 1));
            let i1 = (i + 1).min(cols - 1);
            let corners = [(ra, i), (ra, i1), (rb, i), (rb, i1)];
            let mut capped = true;
            for &(rr, cc) in &corners {
                let k = rr * cols + cc;
                for (c, inside) in [
                    (&mut edges.cx, cc > 0 && cc + 1 < cols),
                    (&mut edges.cy, rr > 0 && rr + 1 < rows),
                ] {
                    if inside && c[k] < CURVE_CAP {
                        up(&mut c[k], CURVE_CAP);
                        capped = false;
                    }
                }
            }
            if !capped {
                continue;
            }
            if i1 > i {
                up(&mut edges.x[ra * (cols - 1) + i], MAX_WEIGHT);
                up(&mut edges.x[rb * (cols - 1) + i], MAX_WEIGHT);
            }
            if ra > rb {
                up(&mut edges.y[rb * cols + i], MAX_WEIGHT);
                up(&mut edges.y[rb * cols + i1], MAX_WEIGHT);
            }
        }
    }
    failed
}

/// The largest factor s ≤ 1 such that the map scaled toward m by s passes every patch
/// (module doc), times 0.98: a patch's lead term scales with s and its least depth is
/// m + s (zmin − m), so it passes when s (lead − 0.99 (zmin − m)) < 0.99 m.
fn last_resort(map: &DepthMap, m: f64, r: f64, rows: usize, cols: usize) -> f64 {
    let mut s = 1.0f64;
    for b in 0..rows.saturating_sub(1).max(1) {
        for i in 0..cols.saturating_sub(1).max(1) {
            let (lead, zmin) = map.patch_lead(b, i, r);
            let k = lead - 0.99 * (zmin - m);
            if k > 0.0 {
                s = s.min(0.99 * m / k);
            }
        }
    }
    0.98 * s
}

/// The estimate's surface (module doc).
pub fn surface(inp: &Input<'_>) -> Result<Surface> {
    let (rows, cols) = (inp.rows, inp.cols);
    let n = rows * cols;
    if n == 0 || inp.depth.len() != n {
        return Err(Error::param(
            "depth",
            format!("{} values", inp.depth.len()),
            format!("{rows} x {cols} depths"),
        ));
    }
    if !(inp.r.is_finite() && inp.r >= 0.0) {
        return Err(Error::param(
            "aperture",
            inp.r,
            "a finite half-side >= 0 (mm)",
        ));
    }
    // The buffers (the weights, the CG's vectors, a map per round): about 16 of n.
    crate::infra::memory::check(
        "the depth surface's buffers",
        crate::infra::memory::bytes_of::<f64>(16 * n as u128),
    )?;
    // Checks the depths and the extent.
    DepthMap::new(inp.depth, rows, cols, inp.extent)?;
    let all = vec![true; n];
    let conf = inp.confident.unwrap_or(&all);
    let ones = vec![1.0; n];
    let c = inp.confidence.unwrap_or(&ones);
    if conf.len() != n || c.len() != n {
        return Err(Error::param(
            "confidence",
            format!("{} and {} values", c.len(), conf.len()),
            format!("{rows} x {cols} values, the depths' shape"),
        ));
    }
    let mut a: Vec<f64> = (0..n)
        .map(|k| {
            if conf[k] && c[k] > 0.0 {
                c[k].min(1.0)
            } else {
                0.0
            }
        })
        .collect();
    if a.iter().all(|&v| v == 0.0) {
        a.fill(1.0);
    }
    let floor = FLOOR * a.iter().copied().fold(0.0, f64::max);
    a.iter_mut().for_each(|v| *v = v.max(floor));
    let mut edges = Edges::new(rows, cols);
    let cuts = cut_jumps(&mut edges, inp.depth, conf);
    let mut z = inp.depth.to_vec();
    let mut rounds = 0;
    loop {
        solve(&edges, &a, inp.depth, &mut z)?;
        let map = DepthMap::new(&z, rows, cols, inp.extent)?;
        if rounds == MAX_ROUNDS || stiffen(&mut edges, &map, inp.r) == 0 {
            break;
        }
        rounds += 1;
    }
    let map = DepthMap::new(&z, rows, cols, inp.extent)?;
    let mut scale = 1.0;
    if !map.seen_once(inp.r) {
        let wsum: f64 = a.iter().sum();
        let m = a.iter().zip(&z).map(|(w, v)| w * v).sum::<f64>() / wsum;
        scale = last_resort(&map, m, inp.r, rows, cols);
        z.iter_mut().for_each(|v| *v = m + scale * (*v - m));
    }
    let plane = fit_into_plane(&mut z, &a, inp);
    Ok(Surface {
        depth: z,
        rounds,
        cuts,
        scale,
        plane,
    })
}

/// The plane Z = z0 + gx X + gy Y (cell centres, row 0 at the top) fitted to `z` by least
/// squares with the weights `a` (the confidence), as (z0, gx, gy); None when the weights
/// do not fix one (fewer than three non-collinear cells of weight).
fn fit_plane(z: &[f64], a: &[f64], rows: usize, cols: usize, ext: [f64; 4]) -> Option<[f64; 3]> {
    let (hx, hy) = (
        (ext[1] - ext[0]) / cols as f64,
        (ext[3] - ext[2]) / rows as f64,
    );
    // About the extent's centre, in cells, for the normal equations' conditioning.
    let (xc, yc) = (0.5 * (ext[0] + ext[1]), 0.5 * (ext[2] + ext[3]));
    let (mut m, mut v) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
    for r in 0..rows {
        for c in 0..cols {
            let k = r * cols + c;
            let u = [
                1.0,
                (ext[0] + (c as f64 + 0.5) * hx - xc) / hx,
                (ext[3] - (r as f64 + 0.5) * hy - yc) / hy,
            ];
            for i in 0..3 {
                v[i] += a[k] * u[i] * z[k];
                for j in 0..3 {
                    m[i][j] += a[k] * u[i] * u[j];
                }
            }
        }
    }
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    let scale = m[0][0] * m[1][1] * m[2][2];
    // (False for NaN too.)
    let fixed = d.abs() > 1e-12 * scale.abs();
    if !fixed {
        return None;
    }
    // Cramer's rule.
    let mut p = [0.0; 3];
    for (i, pi) in p.iter_mut().enumerate() {
        let mut mi = m;
        for (row, vr) in mi.iter_mut().zip(v) {
            row[i] = vr;
        }
        *pi = det(&mi) / d;
    }
    let (gx, gy) = (p[1] / hx, p[2] / hy);
    Some([p[0] - gx * xc - gy * yc, gx, gy])
}

/// Replace the surface `z` by its fitted plane ([`fit_plane`], weighted by the
/// confidence `a`) when no cell is more than [`PLANE_FIT`] of the plane's depth off it
/// and every ray meets the plane once over the map; the plane as (z0, gx, gy), or None
/// (z left as it is).
fn fit_into_plane(z: &mut [f64], a: &[f64], inp: &Input<'_>) -> Option<[f64; 3]> {
    let (rows, cols, ext) = (inp.rows, inp.cols, inp.extent);
    let p = fit_plane(z, a, rows, cols, ext)?;
    let (hx, hy) = (
        (ext[1] - ext[0]) / cols as f64,
        (ext[3] - ext[2]) / rows as f64,
    );
    let mut q = Vec::with_capacity(z.len());
    for r in 0..rows {
        for c in 0..cols {
            let x = ext[0] + (c as f64 + 0.5) * hx;
            let y = ext[3] - (r as f64 + 0.5) * hy;
            let zp = p[0] + p[1] * x + p[2] * y;
            if !(zp > 0.0 && (z[r * cols + c] - zp).abs() <= PLANE_FIT * zp) {
                return None;
            }
            q.push(zp);
        }
    }
    if !DepthMap::new(&q, rows, cols, ext).ok()?.seen_once(inp.r) {
        return None;
    }
    z.copy_from_slice(&q);
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Depths of `f` at the centres of rows × cols cells over `ext` (row 0 at the top).
    fn sampled(f: impl Fn(f64, f64) -> f64, rows: usize, cols: usize, ext: [f64; 4]) -> Vec<f64> {
        let (hx, hy) = (
            (ext[1] - ext[0]) / cols as f64,
            (ext[3] - ext[2]) / rows as f64,
        );
        let mut v = Vec::with_capacity(rows * cols);
        for r in 0..rows {
            for c in 0..cols {
                v.push(f(
                    ext[0] + (c as f64 + 0.5) * hx,
                    ext[3] - (r as f64 + 0.5) * hy,
                ));
            }
        }
        v
    }

    /// A SplitMix64 stream mapped to [-1, 1).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        crate::infra::random::splitmix64_stream(seed)
            .take(n)
            .map(|z| (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0)
            .collect()
    }

    /// The weighted plane fit against closed forms: a checkerboard on an even grid is
    /// orthogonal to 1, X and Y, so the plane under it is the fit; cells of weight 0 do
    /// not count, whatever they hold; weight on one column alone fixes no plane.
    #[test]
    fn fit_plane_is_the_plane_under_the_noise() {
        let (rows, cols, ext) = (20, 16, [-1.0, 3.0, -2.0, 3.0]);
        let plane = |x: f64, y: f64| 650.0 - 4.0 * x + 26.0 * y;
        let truth = sampled(plane, rows, cols, ext);
        // ±13 mm (2 % of the mean depth), alternating: its sums against 1, X and Y vanish
        // on an even number of rows and columns.
        let sign = |k: usize| {
            if (k / cols + k % cols) % 2 == 0 {
                1.0
            } else {
                -1.0
            }
        };
        let z: Vec<f64> = (0..rows * cols)
            .map(|k| truth[k] + 13.0 * sign(k))
            .collect();
        let ones = vec![1.0; rows * cols];
        let p = fit_plane(&z, &ones, rows, cols, ext).unwrap();
        assert!(
            (p[0] - 650.0).abs() < 1e-9 && (p[1] + 4.0).abs() < 1e-10,
            "{p:?}"
        );
        assert!((p[2] - 26.0).abs() < 1e-10, "{p:?}");
        let mut w = ones.clone();
        let mut z = truth.clone();
        let wild = noise(rows * cols, 3);
        for k in 0..rows * cols / 3 {
            z[k] = 400.0 + 300.0 * wild[k];
            w[k] = 0.0;
        }
        let p = fit_plane(&z, &w, rows, cols, ext).unwrap();
        assert!(
            (p[0] - 650.0).abs() < 1e-9 && (p[1] + 4.0).abs() < 1e-10,
            "{p:?}"
        );
        // One column of weight: no plane.
        let mut w = vec![0.0; rows * cols];
        (0..rows).for_each(|r| w[r * cols + 3] = 1.0);
        assert!(fit_plane(&truth, &w, rows, cols, ext).is_none());
    }

    /// A noisy estimate of a plane (±2 % a cell) becomes the plane fitted to its surface
    /// (within 0.3 % of the true plane everywhere; its samples a plane,
    /// `DepthMap::as_plane`); a bowl that leaves its plane by more than [`PLANE_FIT`] is
    /// left as a surface.
    #[test]
    fn a_surface_within_plane_fit_of_a_plane_is_the_plane() {
        let (rows, cols, ext) = (40, 30, [-1.5, 1.5, -2.0, 2.0]);
        let plane = |x: f64, y: f64| 650.0 + 2.0 * x + 26.0 * y;
        let truth = sampled(plane, rows, cols, ext);
        let wild = noise(rows * cols, 13);
        let run = |d: &[f64]| {
            surface(&Input {
                depth: d,
                confidence: None,
                confident: None,
                rows,
                cols,
                extent: ext,
                r: 10.0,
            })
            .unwrap()
        };
        let d: Vec<f64> = (0..rows * cols)
            .map(|k| truth[k] * (1.0 + 0.02 * wild[k]))
            .collect();
        let s = run(&d);
        let p = s.plane.expect("fitted into a plane");
        let map = DepthMap::new(&s.depth, rows, cols, ext).unwrap();
        let (z0, g, _) = map.as_plane().expect("the surface is a plane");
        assert!(
            (z0 - p[0]).abs() < 1e-9 && (g[0] - p[1]).abs() < 1e-9 && (g[1] - p[2]).abs() < 1e-9
        );
        let worst = (0..rows * cols)
            .map(|k| (s.depth[k] / truth[k] - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 3e-3, "{worst}");
        // The bowl is 3.6 % off its plane at the corners (6 (x² + y²) less its mean,
        // 12.5 mm, over about 700 mm); a step becomes a ramp (a_jump_the_data_show_stays_a_jump).
        let bowl = sampled(|x, y| plane(x, y) + 6.0 * (x * x + y * y), rows, cols, ext);
        assert!(run(&bowl).plane.is_none());
    }

    /// Unconfident cells follow their neighbours: a block of them holding nonsense inside
    /// a confident plane takes the plane (the harmonic interpolation of an affine function
    /// is that function), and the confident cells away from the map's border hold it.
    #[test]
    fn unconfident_cells_take_the_plane_around_them() {
        let (rows, cols, ext) = (30, 40, [-2.0, 2.0, -1.5, 1.5]);
        let plane = |x: f64, y: f64| 700.0 + 3.0 * x - 5.0 * y;
        let truth = sampled(plane, rows, cols, ext);
        let mut d = truth.clone();
        let mut conf = vec![true; rows * cols];
        let wild = noise(rows * cols, 7);
        for r in 10..20 {
            for c in 12..25 {
                d[r * cols + c] = 700.0 + 300.0 * wild[r * cols + c];
                conf[r * cols + c] = false;
            }
        }
        let s = surface(&Input {
            depth: &d,
            confidence: None,
            confident: Some(&conf),
            rows,
            cols,
            extent: ext,
            r: 10.0,
        })
        .unwrap();
        assert_eq!((s.rounds, s.cuts, s.scale), (0, 0, 1.0));
        for r in 4..rows - 4 {
            for c in 4..cols - 4 {
                let k = r * cols + c;
                let err = (s.depth[k] - truth[k]).abs() / truth[k];
                assert!(
                    err < 1e-7,
                    "({r}, {c}): {} against {}",
                    s.depth[k],
                    truth[k]
                );
            }
        }
        let map = DepthMap::new(&s.depth, rows, cols, ext).unwrap();
        assert!(map.seen_once(10.0));
    }

    /// A rough estimate of a steep plane (noise of 2 % a cell, local slopes of hundreds
    /// of mm per mm, as the issue measured) fails `seen_once`; its surface passes, and
    /// its RMS error against the plane is under half the estimate's (measured: 0.0201 ->
    /// 0.0041 of the depth after 2 rounds).
    #[test]
    fn rough_estimate_becomes_a_surface_seen_once() {
        let (rows, cols, ext) = (64, 24, [-1.5, 1.5, -5.0, 3.0]);
        let plane = |_x: f64, y: f64| 600.0 + 26.0 * y;
        let truth = sampled(plane, rows, cols, ext);
        let wild = noise(rows * cols, 11);
        let d: Vec<f64> = truth
            .iter()
            .zip(&wild)
            .map(|(t, n)| t * (1.0 + 0.035 * n))
            .collect();
        let r = 10.0;
        assert!(!DepthMap::new(&d, rows, cols, ext).unwrap().seen_once(r));
        let conf: Vec<f64> = noise(rows * cols, 5)
            .iter()
            .map(|v| 0.75 + 0.25 * v)
            .collect();
        let s = surface(&Input {
            depth: &d,
            confidence: Some(&conf),
            confident: None,
            rows,
            cols,
            extent: ext,
            r,
        })
        .unwrap();
        assert!(DepthMap::new(&s.depth, rows, cols, ext)
            .unwrap()
            .seen_once(r));
        assert_eq!(s.scale, 1.0, "the last resort was taken");
        let rms = |v: &[f64]| {
            (v.iter()
                .zip(&truth)
                .map(|(a, t)| ((a - t) / t).powi(2))
                .sum::<f64>()
                / v.len() as f64)
                .sqrt()
        };
        let (before, after) = (rms(&d), rms(&s.depth));
        eprintln!("rounds {}, RMS error {before:.4} -> {after:.4}", s.rounds);
        assert!(after < 0.5 * before, "{before} -> {after}");
    }

    /// A jump between confident sides stays a jump: a step of 100 mm between two fronto
    /// planes becomes a ramp no wider than 3 times the steepest the facing condition
    /// allows there (|g| (X + r) < 0.99 z at the ramp's far edge, solved for the width),
    /// and the cells beyond it hold their depths within 0.5 % (measured: 40 cells moved,
    /// the least ramp 36.8 cells).
    #[test]
    fn a_jump_the_data_show_stays_a_jump() {
        let (rows, cols, ext) = (6, 120, [-3.0, 3.0, -0.15, 0.15]);
        let (near, far) = (600.0, 700.0);
        let step = |x: f64, _y: f64| if x < 0.0 { far } else { near };
        let d = sampled(step, rows, cols, ext);
        let r = 10.0;
        let s = surface(&Input {
            depth: &d,
            confidence: None,
            confident: None,
            rows,
            cols,
            extent: ext,
            r,
        })
        .unwrap();
        assert!(s.cuts >= rows, "{}", s.cuts);
        // A ramp over 40 of 120 cells is no plane (PLANE_FIT).
        assert!(s.plane.is_none());
        assert!(DepthMap::new(&s.depth, rows, cols, ext)
            .unwrap()
            .seen_once(r));
        // The ramp descends toward +X (g < 0): g (X − w) is largest at w = −r, X at the
        // ramp's right end x1 ≈ w/2: |g| (x1 + r) < 0.99 z_near, |g| = 100 / w.
        let hx = (ext[1] - ext[0]) / cols as f64;
        let least: f64 = (far - near) * r / (0.99 * near - 0.5 * (far - near));
        let least_cells = least / hx;
        for row in 0..rows {
            let line = &s.depth[row * cols..(row + 1) * cols];
            let moved = line
                .iter()
                .zip(&d[row * cols..(row + 1) * cols])
                .filter(|(a, b)| (*a - *b).abs() > 0.005 * *b)
                .count();
            eprintln!(
                "row {row}: {moved} cells moved by > 0.5 %, least ramp {least_cells:.1} cells"
            );
            assert!(moved as f64 <= 3.0 * least_cells + 2.0, "{moved}");
        }
    }
}
