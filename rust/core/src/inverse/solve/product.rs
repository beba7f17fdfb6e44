//! The passes of one product with the normal equations: (AᵀWA + λDᵀD) t ([`Normal::apply`]),
//! AᵀWy and diag(AᵀWA + λDᵀD) with the trace of AᵀWA: each block's rows formed and
//! back-projected into its scratch ([`RowJob`] for a factored block, row by row of the
//! raw), the y factors' runs through column-wise prefix sums and a sweep down the grid
//! rows, and the scratch gathered back onto the grid with the prior.

use rayon::prelude::*;

use crate::infra::simd;

use super::block::Block;
#[cfg(target_arch = "x86_64")]
use super::kernels::dot_slices_avx2;
use super::kernels::{axpy, dot_slices};
use super::normal::{Edges, Normal, Work, CW};
use super::pieces::{Band, Pieces};
use crate::infra::csr::Csr;

/// One raw row b of a factored block: u = (py row b) · T (for products on py's pieces: its
/// dense entries as rows of T, its runs from T's column-wise prefix sums), then for each pixel a of the row
/// that is a row of the map the value s = value(b·nc + a, (px row a) · u), back-projected
/// into the scratch row g = Σ_a s · (px row a).
struct RowJob<'a, F: Fn(usize, f64) -> f64 + Sync> {
    py: &'a Csr,
    /// For products: py's rows as pieces, and T's chunked prefix sums (s0, s1 of
    /// [`Normal::prefix`]) for their runs.
    pieces: Option<(&'a Pieces, &'a [f64], &'a [f64])>,
    ny: usize,
    band: &'a Band,
    w: &'a [f64],
    nc: usize,
    nx: usize,
    t: Option<&'a [f64]>,
    value: &'a F,
}

impl<F: Fn(usize, f64) -> f64 + Sync> RowJob<'_, F> {
    fn run(&self, b: usize, u: &mut [f64], g: &mut [f64]) {
        simd::dispatch(
            #[inline(always)]
            |avx2| {
                if avx2 {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: dispatch says the CPU has AVX2.
                    return self.run_with(b, u, g, |a, b| unsafe { dot_slices_avx2(a, b) });
                }
                self.run_with(b, u, g, dot_slices)
            },
        )
    }

    #[inline(always)]
    fn run_with(
        &self,
        b: usize,
        u: &mut [f64],
        g: &mut [f64],
        dot: impl Fn(&[f64], &[f64]) -> f64,
    ) {
        let (nx, nc) = (self.nx, self.nc);
        if let Some(t) = self.t {
            u.fill(0.0);
            match self.pieces {
                Some((y, s0, s1)) => {
                    for (c, v) in y.dense(b) {
                        for (j, &val) in (c..).zip(v) {
                            axpy(u, val, &t[j * nx..(j + 1) * nx]);
                        }
                    }
                    // A run's Σ_j (α + β j) T_j from the prefix sums at its ends.
                    let len = (self.ny + 1) * CW;
                    for run in y.runs(b) {
                        let (lo, hi) = (run.lo as usize, run.hi as usize);
                        for (k, u) in u.chunks_mut(CW).enumerate() {
                            let w = u.len();
                            let (oh, ol) = (k * len + hi * CW, k * len + lo * CW);
                            let (e0, b0) = (&s0[oh..oh + w], &s0[ol..ol + w]);
                            let (e1, b1) = (&s1[oh..oh + w], &s1[ol..ol + w]);
                            for i in 0..w {
                                u[i] += run.a * (e0[i] - b0[i]) + run.b * (e1[i] - b1[i]);
                            }
                        }
                    }
                }
                None => {
                    let (js, vs) = self.py.row(b);
                    for (&j, &v) in js.iter().zip(vs) {
                        axpy(u, v, &t[j as usize * nx..(j as usize + 1) * nx]);
                    }
                }
            }
        }
        g.fill(0.0);
        for a in 0..nc {
            if self.w[b * nc + a] == 0.0 {
                continue;
            }
            let (lo, vs) = self.band.row(a);
            let fwd = match self.t {
                Some(_) => dot(vs, &u[lo..lo + vs.len()]),
                None => 0.0,
            };
            let s = (self.value)(b * nc + a, fwd);
            if s != 0.0 {
                axpy(&mut g[lo..lo + vs.len()], s, vs);
            }
        }
    }
}

impl Normal {
    /// Column-wise prefix sums of t over grid rows, chunked: s0[j] = Σ_{j'<j} t_j' and
    /// s1[j] = Σ_{j'<j} j' t_j' for j in 0..=ny (the y factors' runs read them).
    fn prefix(&self, t: &[f64], work: &mut Work) {
        let (nx, ny) = (self.nx, self.ny);
        let len = (ny + 1) * CW;
        work.s0
            .par_chunks_mut(len)
            .zip(work.s1.par_chunks_mut(len))
            .enumerate()
            .for_each(|(k, (s0, s1))| {
                let (c0, wk) = (k * CW, CW.min(nx - k * CW));
                let (mut a0, mut a1) = ([0.0f64; CW], [0.0f64; CW]);
                for j in 0..=ny {
                    s0[j * CW..j * CW + wk].copy_from_slice(&a0[..wk]);
                    s1[j * CW..j * CW + wk].copy_from_slice(&a1[..wk]);
                    if j < ny {
                        let row = &t[j * nx + c0..j * nx + c0 + wk];
                        for i in 0..wk {
                            a0[i] += row[i];
                            a1[i] += j as f64 * row[i];
                        }
                    }
                }
            });
    }

    /// The factored blocks' y runs back to the grid, chunked into s0: row j of chunk k is
    /// Σ_blocks Σ_{runs of raw row b over j} (α + β j) × scratch row b (on the chunk's
    /// columns), as a sweep down the grid rows adding each run where it starts and taking
    /// it away where it ends.
    fn sweep(&self, work: &mut Work) {
        let len = (self.ny + 1) * CW;
        let scratch = &work.scratch;
        work.s0.par_chunks_mut(len).enumerate().for_each(|(k, v)| {
            simd::dispatch(
                #[inline(always)]
                |_| self.sweep_chunk(scratch, k, v),
            )
        });
    }

    /// Chunk k of [`Normal::sweep`].
    #[inline(always)]
    fn sweep_chunk(&self, scratch: &[Vec<f64>], k: usize, v: &mut [f64]) {
        let (nx, ny) = (self.nx, self.ny);
        let (c0, wk) = (k * CW, CW.min(nx - k * CW));
        v.fill(0.0);
        for (p, g) in self.blocks.iter().zip(scratch) {
            let Some(fast) = p.pieces(true) else { continue };
            let (mut r0, mut r1) = ([0.0f64; CW], [0.0f64; CW]);
            let ev = &fast.events;
            for j in 0..ny {
                for &(b, a, beta) in &ev.ev[ev.ptr[j]..ev.ptr[j + 1]] {
                    let row = &g[b as usize * nx + c0..b as usize * nx + c0 + wk];
                    for i in 0..wk {
                        r0[i] += a * row[i];
                        r1[i] += beta * row[i];
                    }
                }
                let o = &mut v[j * CW..j * CW + wk];
                let jf = j as f64;
                for i in 0..wk {
                    o[i] += r0[i] + jf * r1[i];
                }
            }
        }
    }

    /// Each block's rows' values s (a Factored block's back-projected as Σ_a s[b,a] px[a,:]
    /// into its scratch row b): `row_value(block, window index or row, A row · t)`.
    /// With `t` None the products are not formed (A row · t is 0).
    fn rows_into(
        &self,
        t: Option<&[f64]>,
        work: &mut Work,
        squared: bool,
        value: impl Fn(&Block, usize, f64) -> f64 + Sync,
    ) {
        let nx = self.nx;
        let (s0, s1) = (&work.s0, &work.s1);
        for (p, scratch) in self.blocks.iter().zip(work.scratch.iter_mut()) {
            match &p.block {
                Block::Factored { px, py, w, .. } => {
                    let Some((plain, sq)) = &p.spans else {
                        continue;
                    };
                    let band = if squared { sq } else { plain };
                    let nc = px.nrows();
                    let block = &p.block;
                    let pieces = p
                        .pieces(t.is_some())
                        .map(|fast| (&fast.y, s0.as_slice(), s1.as_slice()));
                    let job = RowJob {
                        py,
                        pieces,
                        ny: self.ny,
                        band,
                        w,
                        nc,
                        nx,
                        t,
                        value: &|k, fwd| value(block, k, fwd),
                    };
                    scratch.par_chunks_mut(nx).enumerate().for_each_init(
                        || vec![0.0; if t.is_some() { nx } else { 0 }],
                        |u, (b, g)| job.run(b, u, g),
                    );
                }
                Block::Rows { a, .. } => {
                    scratch.par_iter_mut().enumerate().for_each(|(k, r)| {
                        let fwd = match t {
                            Some(t) => {
                                let (cs, vs) = a.row(k);
                                cs.iter().zip(vs).map(|(&c, &v)| v * t[c as usize]).sum()
                            }
                            None => 0.0,
                        };
                        *r = value(&p.block, k, fwd);
                    });
                }
            }
        }
    }

    /// out = Σ_blocks (the blocks' scratch back through the remaining factor: pyᵀ or Aᵀ,
    /// squared for the diagonal) + λ DᵀD t (t None: no prior term).
    fn gather(&self, work: &Work, squared: bool, t: Option<&[f64]>, out: &mut [f64]) {
        let nx = self.nx;
        out.par_chunks_mut(nx).enumerate().for_each(|(j, o)| {
            simd::dispatch(
                #[inline(always)]
                |_| self.gather_row(work, squared, t, j, o),
            )
        });
    }

    /// Row j of [`Normal::gather`].
    #[inline(always)]
    fn gather_row(&self, work: &Work, squared: bool, t: Option<&[f64]>, j: usize, o: &mut [f64]) {
        let (nx, ny, lam) = (self.nx, self.ny, self.lam);
        match (t, &work.edges) {
            (Some(t), Some(e)) => self.weighted_prior_row(t, e, j, o),
            (Some(t), None) => prior_row(t, (nx, ny), j, lam, o),
            (None, _) => o.fill(0.0),
        }
        for (p, scratch) in self.blocks.iter().zip(&work.scratch) {
            match &p.block {
                Block::Factored { .. } => {
                    let back = p
                        .pieces(t.is_some())
                        .map_or(&p.back, |fast| &fast.back_dense);
                    let (bs, vs) = back.row(j);
                    for (&b, &v) in bs.iter().zip(vs) {
                        let v = if squared { v * v } else { v };
                        axpy(o, v, &scratch[b as usize * nx..(b as usize + 1) * nx]);
                    }
                }
                Block::Rows { .. } => {
                    // The cells of grid row j are back's rows j·nx .. (j+1)·nx.
                    for (i, q) in o.iter_mut().enumerate() {
                        let (ks, vs) = p.back.row(j * nx + i);
                        *q += ks
                            .iter()
                            .zip(vs)
                            .map(|(&k, &v)| (if squared { v * v } else { v }) * scratch[k as usize])
                            .sum::<f64>();
                    }
                }
            }
        }
        if t.is_some() && self.runs {
            // The y runs' part, swept into the chunked s0 by [`Normal::sweep`].
            let len = (ny + 1) * CW;
            for (k, o) in o.chunks_mut(CW).enumerate() {
                let v = &work.s0[k * len + j * CW..k * len + j * CW + o.len()];
                for (q, v) in o.iter_mut().zip(v) {
                    *q += v;
                }
            }
        }
    }

    /// Row j of λ Dᵀ diag(w) D t, the prior's part of a product under the weights `e`.
    #[inline(always)]
    fn weighted_prior_row(&self, t: &[f64], e: &Edges, j: usize, o: &mut [f64]) {
        let (nx, ny, lam) = (self.nx, self.ny, self.lam);
        let row = |r: usize| &t[r * nx..(r + 1) * nx];
        let here = row(j);
        let wx = &e.x[j * (nx - 1)..(j + 1) * (nx - 1)];
        for i in 0..nx {
            let mut g = 0.0;
            if i > 0 {
                g += wx[i - 1] * (here[i] - here[i - 1]);
            }
            if i + 1 < nx {
                g += wx[i] * (here[i] - here[i + 1]);
            }
            if j > 0 {
                g += e.y[(j - 1) * nx + i] * (here[i] - row(j - 1)[i]);
            }
            if j + 1 < ny {
                g += e.y[j * nx + i] * (here[i] - row(j + 1)[i]);
            }
            o[i] = lam * g;
        }
    }

    /// The prior's weights at the cells t ([`Prior::weight`] of each difference) into
    /// `work` (allocated on first use).
    pub(super) fn reweight(&self, t: &[f64], work: &mut Work) -> crate::infra::error::Result<()> {
        let (nx, ny) = (self.nx, self.ny);
        if work.edges.is_none() {
            let what = "the prior's weights";
            work.edges = Some(Edges {
                x: crate::infra::memory::try_vec(what, (nx - 1) * ny, 1.0)?,
                y: crate::infra::memory::try_vec(what, nx * (ny - 1), 1.0)?,
            });
        }
        let Some(e) = work.edges.as_mut() else {
            return Ok(());
        };
        let prior = self.prior;
        if nx > 1 {
            e.x.par_chunks_mut(nx - 1).enumerate().for_each(|(j, w)| {
                let r = &t[j * nx..(j + 1) * nx];
                for (i, w) in w.iter_mut().enumerate() {
                    *w = prior.weight(r[i + 1] - r[i]);
                }
            });
        }
        e.y.par_chunks_mut(nx).enumerate().for_each(|(j, w)| {
            let (a, b) = (&t[j * nx..(j + 1) * nx], &t[(j + 1) * nx..(j + 2) * nx]);
            for (i, w) in w.iter_mut().enumerate() {
                *w = prior.weight(b[i] - a[i]);
            }
        });
        Ok(())
    }

    /// out += diag(λ Dᵀ diag(w) D): λ times each cell's neighbours (all weights 1), or the
    /// sum of its differences' weights in `work`.
    pub(super) fn add_prior_diagonal(&self, work: &Work, out: &mut [f64]) {
        let (nx, ny) = (self.nx, self.ny);
        for (c, d) in out.iter_mut().enumerate() {
            let (j, i) = (c / nx, c % nx);
            match &work.edges {
                None => {
                    let n = (i > 0) as u8 + (i + 1 < nx) as u8 + (j > 0) as u8 + (j + 1 < ny) as u8;
                    *d += self.lam * n as f64;
                }
                Some(e) => {
                    let mut s = 0.0;
                    if i > 0 {
                        s += e.x[j * (nx - 1) + i - 1];
                    }
                    if i + 1 < nx {
                        s += e.x[j * (nx - 1) + i];
                    }
                    if j > 0 {
                        s += e.y[(j - 1) * nx + i];
                    }
                    if j + 1 < ny {
                        s += e.y[j * nx + i];
                    }
                    *d += self.lam * s;
                }
            }
        }
    }

    /// out = (Aᵀ W A + λ DᵀD) t.
    pub fn apply(&self, t: &[f64], work: &mut Work, out: &mut [f64]) {
        if self.runs {
            self.prefix(t, work);
        }
        self.rows_into(Some(t), work, false, |b, k, fwd| match b {
            Block::Factored { norm, w, .. } => w[k] * norm * norm * fwd,
            Block::Rows { w, .. } => w[k] * fwd,
        });
        if self.runs {
            self.sweep(work);
        }
        self.gather(work, false, Some(t), out);
    }

    /// Aᵀ W y.
    pub fn rhs(&self, work: &mut Work, out: &mut [f64]) {
        self.rows_into(None, work, false, |b, k, _| match b {
            Block::Factored { norm, w, y, .. } => w[k] * norm * y[k],
            Block::Rows { w, y, .. } => w[k] * y[k],
        });
        self.gather(work, false, None, out);
    }

    /// diag(Aᵀ W A) into `out` (the prior's part is [`Normal::add_prior_diagonal`]);
    /// returns trace(Aᵀ W A).
    pub fn diagonal(&self, work: &mut Work, out: &mut [f64]) -> f64 {
        self.rows_into(None, work, true, |b, k, _| match b {
            Block::Factored { norm, w, .. } => w[k] * norm * norm,
            Block::Rows { w, .. } => w[k],
        });
        self.gather(work, true, None, out);
        out.iter().sum::<f64>()
    }
}

/// Row j of λ DᵀD t over the nx × ny grid (first differences to the horizontal and
/// vertical neighbours): o = λ Σ_neighbours (t − t_neighbour).
#[inline(always)]
pub(crate) fn prior_row(t: &[f64], (nx, ny): (usize, usize), j: usize, lam: f64, o: &mut [f64]) {
    let row = |r: usize| &t[r * nx..(r + 1) * nx];
    let here = row(j);
    for i in 0..nx {
        let mut g = 0.0;
        if i > 0 {
            g += here[i] - here[i - 1];
        }
        if i + 1 < nx {
            g += here[i] - here[i + 1];
        }
        if j > 0 {
            g += here[i] - row(j - 1)[i];
        }
        if j + 1 < ny {
            g += here[i] - row(j + 1)[i];
        }
        o[i] = lam * g;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::solve::pieces::Fast;

    /// Rows shaped like defocused pixels' profiles: a kink cell, a ramp up, a flat top, a
    /// ramp down and a kink cell (lengths 4–40 over the grid, some rows plain random).
    fn trapezoids(n: usize, cols: usize, seed: u64) -> Csr {
        let mut state = seed;
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
        for _ in 0..n {
            let mut v = vec![0.1 + rnd()];
            if rnd() < 0.2 {
                v.extend((0..3).map(|_| rnd()));
            } else {
                let (up, flat, down) = (
                    (rnd() * 12.0) as usize,
                    (rnd() * 25.0) as usize,
                    (rnd() * 12.0) as usize,
                );
                let top = 1.0 + rnd();
                v.extend((1..=up).map(|k| top * k as f64 / (up + 1) as f64));
                v.extend((0..flat).map(|_| top));
                v.extend((1..=down).rev().map(|k| top * k as f64 / (down + 1) as f64));
                v.push(0.1 + rnd());
            }
            let first = (rnd() * (cols - v.len()) as f64) as usize;
            indices.extend((first..first + v.len()).map(|c| c as u32));
            data.extend(v);
            indptr.push(data.len());
        }
        Csr::new("t", indptr, indices, data, cols).unwrap()
    }

    #[test]
    fn apply_on_pieces_is_the_dense_product() {
        // Grids wider than one column chunk (CW) and not a multiple of it.
        let (nx, ny, lam) = (150, 137, 0.3);
        let (px, py) = (trapezoids(40, nx, 1), trapezoids(35, ny, 2));
        let fast = Fast::new(&py).unwrap();
        assert!(fast.y.runs.len() > 30 && !fast.y.dense.is_empty());
        let (nc, nr) = (px.nrows(), py.nrows());
        let w: Vec<f64> = (0..nr * nc).map(|k| ((k * 7) % 5) as f64 * 0.25).collect();
        let y = vec![0.0; nr * nc];
        let norm = 0.7;
        let t: Vec<f64> = (0..nx * ny)
            .map(|k| ((k * 37) % 101) as f64 / 101.0)
            .collect();
        // The dense product: Σ_rows w (row · t) row + λ DᵀD t.
        let dense = |m: &Csr, r: usize, n: usize| {
            let mut d = vec![0.0; n];
            let (cs, vs) = m.row(r);
            cs.iter().zip(vs).for_each(|(&c, &v)| d[c as usize] = v);
            d
        };
        let mut want = vec![0.0; nx * ny];
        for b in 0..nr {
            let yb = dense(&py, b, ny);
            let ty: Vec<f64> = (0..nx)
                .map(|i| (0..ny).map(|j| yb[j] * t[j * nx + i]).sum())
                .collect();
            for a in 0..nc {
                let xa = dense(&px, a, nx);
                let f: f64 = (0..nx).map(|i| xa[i] * ty[i]).sum::<f64>() * norm;
                let s = w[b * nc + a] * norm * f;
                for j in 0..ny {
                    for i in 0..nx {
                        want[j * nx + i] += s * yb[j] * xa[i];
                    }
                }
            }
        }
        for j in 0..ny {
            for i in 0..nx {
                let c = j * nx + i;
                let mut g = 0.0;
                for (ok, d) in [
                    (i > 0, c.wrapping_sub(1)),
                    (i + 1 < nx, c + 1),
                    (j > 0, c.wrapping_sub(nx)),
                    (j + 1 < ny, c + nx),
                ] {
                    if ok {
                        g += t[c] - t[d];
                    }
                }
                want[c] += lam * g;
            }
        }
        let block = Block::Factored { norm, px, py, w, y };
        let normal = Normal::new(nx, ny, lam, vec![block]).unwrap();
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut outs = vec![];
        for threads in [Some(1), Some(2)] {
            let mut work = normal.work().unwrap();
            let mut out = vec![0.0; nx * ny];
            crate::infra::parallel::with_threads(threads, || normal.apply(&t, &mut work, &mut out))
                .unwrap();
            let err = out
                .iter()
                .zip(&want)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(err <= 1e-12 * scale, "{err} of {scale}");
            outs.push(out);
        }
        assert_eq!(outs[0], outs[1]);
    }
}
