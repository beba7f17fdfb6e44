//! A coarse-grid correction for CG's preconditioner (an option of [`Normal`],
//! [`Normal::precondition_coarse`]): the Jacobi diagonal reaches each cell alone, so the
//! prior's smooth modes (the ones λDᵀD barely penalises and the data do not pin) converge
//! slowest, in about one iteration per cell of the grid's side. The two-level additive
//! preconditioner adds their exact Galerkin solve on aggregates of h × h cells:
//!
//! ```text
//!     z = r / diag  +  R₀ᵀ (R₀ (AᵀWA + λDᵀD) R₀ᵀ)⁻¹ R₀ r,
//! ```
//!
//! R₀ the sum over each aggregate (piecewise-constant prolongation R₀ᵀ). The coarse
//! matrix is formed exactly from the map's rows, never by products: each row's sums over
//! the aggregates (a factored row's are the Kronecker product of its two factors' sums),
//! Σ_rows w (R₀ a)(R₀ a)ᵀ, and the prior's from the fine differences that cross between
//! aggregates. It is factored by Cholesky at each λ (dense: at most [`COARSE_CELLS`]
//! aggregates, a few tens of milliseconds; hand-written, twenty lines a linear-algebra
//! crate would bring a large dependency for). Both terms are symmetric positive
//! (semi-)definite, so CG converges to the same solution; only the iterations change.
//! Every sum runs in a fixed order: the result does not depend on the thread count.

use rayon::prelude::*;

use super::block::Block;
use crate::infra::error::Result;
use crate::infra::memory;

/// The most aggregates (the coarse matrix's side); the aggregates' side h is the least
/// that keeps their count at most this.
pub const COARSE_CELLS: usize = 576;

/// The coarse system over the aggregates of an nx × ny grid.
pub struct Coarse {
    nx: usize,
    h: usize,
    cx: usize,
    cy: usize,
    /// R₀ AᵀWA R₀ᵀ and R₀ DᵀD R₀ᵀ, dense, row-major.
    data: Vec<f64>,
    prior: Vec<f64>,
    /// The Cholesky factor (lower, row-major) of data + λ prior at the last λ; empty when
    /// that matrix is not positive definite (then no correction is added).
    chol: Vec<f64>,
}

/// A row's sums over the aggregates of one axis: (aggregate, sum) in increasing order.
fn sums(cols: &[u32], vals: &[f64], h: usize, out: &mut Vec<(usize, f64)>) {
    out.clear();
    for (&c, &v) in cols.iter().zip(vals) {
        let g = c as usize / h;
        match out.last_mut() {
            Some(last) if last.0 == g => last.1 += v,
            _ => out.push((g, v)),
        }
    }
}

/// m += w e eᵀ over the sparse e.
fn outer(m: &mut [f64], n: usize, e: &[(usize, f64)], w: f64) {
    for &(p, a) in e {
        let row = &mut m[p * n..(p + 1) * n];
        let wa = w * a;
        for &(q, b) in e {
            row[q] += wa * b;
        }
    }
}

impl Coarse {
    /// The coarse system of `blocks` over the nx × ny grid (the quadratic prior's
    /// differences); None for grids too small to coarsen (fewer than 4 aggregates).
    pub fn build(blocks: &[&Block], nx: usize, ny: usize) -> Result<Option<Coarse>> {
        Coarse::build_with(blocks, nx, ny, COARSE_CELLS)
    }

    /// [`Coarse::build`] with at most `most` aggregates.
    fn build_with(blocks: &[&Block], nx: usize, ny: usize, most: usize) -> Result<Option<Coarse>> {
        let mut h = 1;
        while nx.div_ceil(h) * ny.div_ceil(h) > most {
            h += 1;
        }
        let (cx, cy) = (nx.div_ceil(h), ny.div_ceil(h));
        let n = cx * cy;
        if h < 2 || n < 4 {
            return Ok(None);
        }
        let mut data = memory::try_vec("the coarse system", n * n, 0.0)?;
        for block in blocks {
            match block {
                Block::Factored {
                    norm, px, py, w, ..
                } => {
                    let nc = px.nrows();
                    let mut tmp = vec![];
                    let xs: Vec<Vec<(usize, f64)>> = (0..nc)
                        .map(|a| {
                            let (c, v) = px.row(a);
                            sums(c, v, h, &mut tmp);
                            tmp.clone()
                        })
                        .collect();
                    // Raw rows in parallel, each into its own matrix, added in row order.
                    let part = (0..py.nrows())
                        .into_par_iter()
                        .fold_chunks(
                            64,
                            || (vec![0.0; n * n], vec![], vec![]),
                            |(mut m, mut ys, mut e), b| {
                                let (c, v) = py.row(b);
                                sums(c, v, h, &mut ys);
                                for (a, xa) in xs.iter().enumerate() {
                                    let wk = w[b * nc + a];
                                    if wk == 0.0 {
                                        continue;
                                    }
                                    e.clear();
                                    for &(gy, vy) in &ys {
                                        for &(gx, vx) in xa {
                                            e.push((gy * cx + gx, norm * vy * vx));
                                        }
                                    }
                                    outer(&mut m, n, &e, wk);
                                }
                                (m, ys, e)
                            },
                        )
                        .map(|(m, _, _)| m)
                        .collect::<Vec<_>>();
                    for m in part {
                        data.iter_mut().zip(&m).for_each(|(d, v)| *d += v);
                    }
                }
                Block::Rows { a, w, .. } => {
                    let mut e: Vec<(usize, f64)> = vec![];
                    for (k, &wk) in w.iter().enumerate() {
                        if wk == 0.0 {
                            continue;
                        }
                        e.clear();
                        let (cs, vs) = a.row(k);
                        for (&c, &v) in cs.iter().zip(vs) {
                            let (j, i) = (c as usize / nx, c as usize % nx);
                            let g = (j / h) * cx + i / h;
                            match e.iter_mut().find(|p| p.0 == g) {
                                Some(p) => p.1 += v,
                                None => e.push((g, v)),
                            }
                        }
                        outer(&mut data, n, &e, wk);
                    }
                }
            }
        }
        // The differences between neighbour cells in different aggregates.
        let mut prior = memory::try_vec("the coarse system", n * n, 0.0)?;
        let mut edge = |p: usize, q: usize| {
            prior[p * n + p] += 1.0;
            prior[q * n + q] += 1.0;
            prior[p * n + q] -= 1.0;
            prior[q * n + p] -= 1.0;
        };
        for j in 0..ny {
            for i in 0..nx {
                let g = (j / h) * cx + i / h;
                if i + 1 < nx && (i + 1) % h == 0 {
                    edge(g, g + 1);
                }
                if j + 1 < ny && (j + 1) % h == 0 {
                    edge(g, g + cx);
                }
            }
        }
        Ok(Some(Coarse {
            nx,
            h,
            cx,
            cy,
            data,
            prior,
            chol: vec![],
        }))
    }

    /// Factor data + λ prior (Cholesky); not positive definite: no correction.
    pub fn factor(&mut self, lam: f64) {
        let n = self.cx * self.cy;
        let mut l: Vec<f64> = self
            .data
            .iter()
            .zip(&self.prior)
            .map(|(d, p)| d + lam * p)
            .collect();
        for i in 0..n {
            for j in 0..=i {
                let s = l[i * n + j] - (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum::<f64>();
                if i == j {
                    if !(s > 0.0 && s.is_finite()) {
                        self.chol = vec![];
                        return;
                    }
                    l[i * n + i] = s.sqrt();
                } else {
                    l[i * n + j] = s / l[j * n + j];
                }
            }
        }
        // Zero the upper triangle (unused, kept tidy).
        for i in 0..n {
            l[i * n + i + 1..(i + 1) * n].fill(0.0);
        }
        self.chol = l;
    }

    /// z += R₀ᵀ C⁻¹ R₀ r.
    pub fn add_correction(&self, r: &[f64], z: &mut [f64]) {
        if self.chol.is_empty() {
            return;
        }
        let (nx, h, cx) = (self.nx, self.h, self.cx);
        let n = cx * self.cy;
        // R₀ r: each grid row's runs of h cells, summed in order.
        let mut v = vec![0.0; n];
        for (j, row) in r.chunks(nx).enumerate() {
            let base = (j / h) * cx;
            for (g, run) in row.chunks(h).enumerate() {
                v[base + g] += run.iter().sum::<f64>();
            }
        }
        // L y = v by rows, then Lᵀ x = y by L's rows from the last (x_i found, taken
        // from the entries before it): both read L row-contiguously.
        let l = &self.chol;
        for i in 0..n {
            let s: f64 = l[i * n..i * n + i]
                .iter()
                .zip(&v[..i])
                .map(|(a, b)| a * b)
                .sum();
            v[i] = (v[i] - s) / l[i * n + i];
        }
        for i in (0..n).rev() {
            let x = v[i] / l[i * n + i];
            v[i] = x;
            for (vk, lk) in v[..i].iter_mut().zip(&l[i * n..i * n + i]) {
                *vk -= lk * x;
            }
        }
        z.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let base = (j / h) * cx;
            for (g, run) in row.chunks_mut(h).enumerate() {
                let x = v[base + g];
                run.iter_mut().for_each(|z| *z += x);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{factored, rows_of};
    use super::super::{solve, Block, Csr, Normal, Stop};
    use super::*;
    use std::sync::atomic::AtomicUsize;

    /// A blur: one row per cell of the central half of the grid in each axis (the rim seen
    /// by no row, as a merit's padded patch is seen by fewer pixels), the mean of the
    /// w × w box around it (clipped at the rim), data from a smooth image, weights 1.
    fn blur(nx: usize, ny: usize, w: usize) -> Block {
        let r = (w / 2) as isize;
        let (mut rows, mut y) = (vec![], vec![]);
        for j in (ny / 4) as isize..(3 * ny / 4) as isize {
            for i in (nx / 4) as isize..(3 * nx / 4) as isize {
                let mut row = vec![];
                for dj in -r..=r {
                    for di in -r..=r {
                        let (a, b) = (i + di, j + dj);
                        if a >= 0 && b >= 0 && a < nx as isize && b < ny as isize {
                            row.push(((b as usize * nx + a as usize) as u32, 1.0));
                        }
                    }
                }
                let v = 1.0 / row.len() as f64;
                row.iter_mut().for_each(|e| e.1 = v);
                rows.push(row);
                y.push(0.5 + 0.3 * (0.3 * i as f64).sin() * (0.2 * j as f64).cos());
            }
        }
        let n = y.len();
        let a = Csr::from_rows("test", &rows, nx * ny).unwrap();
        Block::Rows {
            a,
            w: vec![1.0; n],
            y,
        }
    }

    /// The coarse matrix is R₀ (AᵀWA + λDᵀD) R₀ᵀ formed by products: for each aggregate
    /// J, the operator applied to its indicator, summed over each aggregate I (a factored
    /// block and the same rows given explicitly, with the prior).
    #[test]
    fn the_coarse_matrix_is_the_galerkin_product() {
        let (nx, ny, lam) = (9, 11, 0.7);
        let (block, dense, w, y) = factored(nx, ny);
        for b in [block, rows_of(&dense, w, y)] {
            let c = Coarse::build_with(&[&b], nx, ny, 16).unwrap().unwrap();
            let normal = Normal::new(nx, ny, lam, vec![b]).unwrap();
            let (h, cx, n) = (c.h, c.cx, c.cx * c.cy);
            assert!(h >= 2 && n >= 4);
            let agg = |cell: usize| (cell / nx / h) * cx + (cell % nx) / h;
            let mut work = normal.work().unwrap();
            for jj in 0..n {
                let ind: Vec<f64> = (0..nx * ny).map(|k| (agg(k) == jj) as u8 as f64).collect();
                let mut out = vec![0.0; nx * ny];
                normal.apply(&ind, &mut work, &mut out);
                let mut col = vec![0.0; n];
                for (k, v) in out.iter().enumerate() {
                    col[agg(k)] += v;
                }
                for (ii, got) in col.iter().enumerate() {
                    let m = c.data[ii * n + jj] + lam * c.prior[ii * n + jj];
                    assert!(
                        (m - got).abs() < 1e-12 * (1.0 + m.abs()),
                        "{ii} {jj}: {m} {got}"
                    );
                }
            }
        }
    }

    /// On a blur whose rim no row sees (the prior alone reaches it: slow, smooth modes) the
    /// coarse correction takes far fewer iterations than Jacobi alone, to the same solution
    /// (both solved to 1e-10), bit for bit the same at 1 and 2 threads.
    #[test]
    fn fewer_iterations_on_a_blur_and_the_same_solution() {
        let (nx, ny, lam) = (96, 80, 0.05);
        let done = AtomicUsize::new(0);
        let stop = Stop::relative(1e-10, 10_000);
        let jacobi = Normal::new(nx, ny, lam, vec![blur(nx, ny, 15)]).unwrap();
        let a = solve(&jacobi, stop, Some(1), &done).unwrap();
        let mut two = Normal::new(nx, ny, lam, vec![blur(nx, ny, 15)]).unwrap();
        two.precondition_coarse().unwrap();
        let b = solve(&two, stop, Some(1), &done).unwrap();
        let diff = a
            .cells
            .iter()
            .zip(&b.cells)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        println!(
            "jacobi {} two-level {} max diff {diff:e}",
            a.iterations, b.iterations
        );
        assert!(diff < 1e-7, "{diff}");
        // 313 against 52 when written.
        assert!(
            3 * b.iterations < a.iterations,
            "{} vs {}",
            b.iterations,
            a.iterations
        );
        let c = solve(&two, stop, Some(2), &done).unwrap();
        assert_eq!(b.cells, c.cells, "the thread count changed the solution");
    }
}
