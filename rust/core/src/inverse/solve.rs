//! The reconstruction's solve (docs/model.md §11, docs/reconstruct.md): regularised,
//! weighted least squares on the map a reconstruction inverts,
//!
//! ```text
//!     min_t  Σ_rows w (A t − y)²  +  λ |D t|²,
//! ```
//!
//! D the differences between horizontal and vertical neighbour cells, solved matrix-free by
//! conjugate gradients on the normal equations (Aᵀ W A + λ DᵀD) t = Aᵀ W y with a Jacobi
//! (diagonal) preconditioner: the iteration of SciPy's `cg` (same start, same stop:
//! ‖r‖ < rtol ‖b‖), so the two agree to rounding.
//!
//! The map comes in blocks of rows:
//! - [`Block::Factored`]: the pixels of one lens type of one channel on the exact route,
//!   rows `norm · (py row b ⊗ px row a)` over a window of raw rows b and columns a (the
//!   map's Kronecker factors, never multiplied out: a half-2 pixel at 1 m touches ~6,000
//!   cells, its factors 2 × 78);
//! - [`Block::Rows`]: explicit rows (the general and tilted routes).
//!
//! Every product runs in parallel over rows with a fixed order of summation inside each
//! row, and every dot product over fixed chunks added in order: the result does not depend
//! on the thread count.

use rayon::prelude::*;

use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel;
use crate::infra::simd;

/// A sparse matrix in compressed rows: row i's entries are `indices[indptr[i]..indptr[i+1]]`
/// (columns, < `ncols`) and the same range of `data`.
#[derive(Clone, Debug)]
pub struct Csr {
    pub indptr: Vec<usize>,
    pub indices: Vec<u32>,
    pub data: Vec<f64>,
    pub ncols: usize,
}

impl Csr {
    /// A checked CSR matrix: `indptr` starts at 0, never decreases and ends at the number of
    /// entries; every column index < `ncols`; every entry finite. `field` names it in errors.
    pub fn new(
        field: &'static str,
        indptr: Vec<usize>,
        indices: Vec<u32>,
        data: Vec<f64>,
        ncols: usize,
    ) -> Result<Csr> {
        let ok_ptr = indptr.first() == Some(&0)
            && indptr.windows(2).all(|w| w[0] <= w[1])
            && indptr.last() == Some(&indices.len())
            && indices.len() == data.len();
        if !ok_ptr {
            return Err(Error::param(
                field,
                format!(
                    "indptr of {} entries over {} indices",
                    indptr.len(),
                    indices.len()
                ),
                "a CSR matrix: indptr from 0, non-decreasing, ending at the number of entries",
            ));
        }
        if let Some(&c) = indices.iter().find(|&&c| c as usize >= ncols) {
            return Err(Error::param(field, c, format!("column indices < {ncols}")));
        }
        if let Some(&v) = data.iter().find(|v| !v.is_finite()) {
            return Err(Error::param(field, v, "finite entries"));
        }
        Ok(Csr {
            indptr,
            indices,
            data,
            ncols,
        })
    }

    pub fn nrows(&self) -> usize {
        self.indptr.len() - 1
    }

    fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let r = self.indptr[i]..self.indptr[i + 1];
        (&self.indices[r.clone()], &self.data[r])
    }

    /// The transpose, its rows' entries in increasing column order.
    pub fn transpose(&self) -> Result<Csr> {
        let nnz = self.indices.len();
        let mut count = memory::try_vec("a transposed factor", self.ncols + 1, 0usize)?;
        for &c in &self.indices {
            count[c as usize + 1] += 1;
        }
        for i in 0..self.ncols {
            count[i + 1] += count[i];
        }
        let indptr = count.clone();
        let mut next = count;
        let mut indices = memory::try_vec("a transposed factor", nnz, 0u32)?;
        let mut data = memory::try_vec("a transposed factor", nnz, 0.0f64)?;
        for i in 0..self.nrows() {
            let (cols, vals) = self.row(i);
            for (&c, &v) in cols.iter().zip(vals) {
                let k = &mut next[c as usize];
                indices[*k] = i as u32;
                data[*k] = v;
                *k += 1;
            }
        }
        Ok(Csr {
            indptr,
            indices,
            data,
            ncols: self.nrows(),
        })
    }
}

/// A matrix's rows as dense spans: row i covers columns `first[i] ..` with the values
/// `data[ptr[i]..ptr[i + 1]]` (zeros inside a span kept). The x factor's rows are one
/// pixel's contiguous run of cells, so its spans hold exactly its entries, and products
/// with them are slices the compiler vectorises.
struct Band {
    first: Vec<usize>,
    ptr: Vec<usize>,
    data: Vec<f64>,
}

impl Band {
    /// `m`'s rows as spans, every value squared when `squared` (for diag(Aᵀ W A)).
    fn new(m: &Csr, squared: bool) -> Result<Band> {
        let n = m.nrows();
        let spans = |i: usize| {
            let (cs, _) = m.row(i);
            match (cs.iter().min(), cs.iter().max()) {
                (Some(&lo), Some(&hi)) => (lo as usize, (hi - lo) as usize + 1),
                _ => (0, 0),
            }
        };
        let total: usize = (0..n).map(|i| spans(i).1).sum();
        let mut data = memory::try_vec("a factor's spans", total, 0.0)?;
        let mut first = memory::try_vec("a factor's spans", n, 0usize)?;
        let mut ptr = memory::try_vec("a factor's spans", n + 1, 0usize)?;
        for i in 0..n {
            let (lo, len) = spans(i);
            first[i] = lo;
            ptr[i + 1] = ptr[i] + len;
            let (cs, vs) = m.row(i);
            for (&c, &v) in cs.iter().zip(vs) {
                data[ptr[i] + c as usize - lo] += if squared { v * v } else { v };
            }
        }
        Ok(Band { first, ptr, data })
    }

    #[inline(always)]
    fn row(&self, i: usize) -> (usize, &[f64]) {
        (self.first[i], &self.data[self.ptr[i]..self.ptr[i + 1]])
    }
}

/// Entries of a factor's row within this share of the row's largest value of a line are
/// taken as on it (the profiles' own rounding is ~10⁻¹³ of it: an area is a difference of
/// cumulative areas over the grid).
const RUN_TOL: f64 = 1e-12;
/// The fewest entries an affine run replaces.
const MIN_RUN: usize = 4;

/// An affine run of a factor's row: the value α + β·i at column i of [lo, hi).
#[derive(Clone, Copy, Debug)]
struct Run {
    lo: u32,
    hi: u32,
    a: f64,
    b: f64,
}

/// A factor's rows for [`Normal::apply`], cut into dense spans (values kept) and affine
/// runs. A pixel's profile is the integral over cells of a piecewise-linear density (its
/// ray set's polygon seen along one axis), so it is affine between the few cells that hold
/// a kink: the seed's y profiles at 1 m (cells of δ) have 72 entries a row on half 2 and
/// 23 on half 1, and become 3.7 and 3.9 dense entries and 2.8 and 2.9 runs. A run's
/// product with a vector costs two prefix-sum differences instead of its length.
struct Pieces {
    /// Row r's dense spans are `dense[dptr[r]..dptr[r + 1]]`: (first column, offset in
    /// `data`, length).
    dptr: Vec<usize>,
    dense: Vec<(u32, u32, u32)>,
    data: Vec<f64>,
    /// Row r's runs are `runs[rptr[r]..rptr[r + 1]]`.
    rptr: Vec<usize>,
    runs: Vec<Run>,
}

/// The longest affine stretch from the start of `v` (a line through its first and last
/// entries, every entry within `tol`), at least two entries.
fn affine_len(v: &[f64], tol: f64) -> usize {
    let mut e = 2.min(v.len());
    while e < v.len() {
        let n = e; // try [0, e]
        let beta = (v[n] - v[0]) / n as f64;
        if !(0..=n).all(|k| (v[k] - (v[0] + beta * k as f64)).abs() <= tol) {
            break;
        }
        e += 1;
    }
    e
}

impl Pieces {
    fn new(m: &Csr) -> Result<Pieces> {
        let band = Band::new(m, false)?;
        let n = m.nrows();
        let mut p = Pieces {
            dptr: vec![0],
            dense: vec![],
            data: vec![],
            rptr: vec![0],
            runs: vec![],
        };
        for r in 0..n {
            let (lo, v) = band.row(r);
            let tol = RUN_TOL * v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let mut i = 0;
            while i < v.len() {
                let e = i + affine_len(&v[i..], tol);
                if e - i >= MIN_RUN {
                    let beta = (v[e - 1] - v[i]) / (e - 1 - i) as f64;
                    let c = (lo + i) as f64;
                    p.runs.push(Run {
                        lo: (lo + i) as u32,
                        hi: (lo + e) as u32,
                        a: v[i] - beta * c,
                        b: beta,
                    });
                    i = e;
                    continue;
                }
                // A dense entry, joined to the row's last span when adjacent.
                let col = (lo + i) as u32;
                let own = p.dense.len() > p.dptr[r];
                match p.dense.last_mut() {
                    Some(d) if own && d.0 + d.2 == col => d.2 += 1,
                    _ => p.dense.push((col, p.data.len() as u32, 1)),
                }
                p.data.push(v[i]);
                i += 1;
            }
            p.dptr.push(p.dense.len());
            p.rptr.push(p.runs.len());
        }
        if p.data.len() >= u32::MAX as usize {
            return Err(Error::param(
                "factors",
                p.data.len(),
                "fewer than 2^32 entries",
            ));
        }
        Ok(p)
    }

    #[inline(always)]
    fn dense(&self, r: usize) -> impl Iterator<Item = (usize, &[f64])> {
        self.dense[self.dptr[r]..self.dptr[r + 1]]
            .iter()
            .map(|&(c, o, l)| (c as usize, &self.data[o as usize..(o + l) as usize]))
    }

    #[inline(always)]
    fn runs(&self, r: usize) -> &[Run] {
        &self.runs[self.rptr[r]..self.rptr[r + 1]]
    }
}

/// Columns per chunk of the column-wise sweeps (prefix sums over grid rows): fixed, so
/// the sums' order does not depend on the thread count.
const CW: usize = 64;

/// The y factor's runs as events over grid rows: at row j, each (b, α, β) of
/// `ev[ptr[j]..ptr[j + 1]]` adds (α + β j) × raw row b's scratch from j on (a run's start;
/// its end adds the negatives).
struct Events {
    ptr: Vec<usize>,
    ev: Vec<(u32, f64, f64)>,
}

impl Events {
    fn new(y: &Pieces, ny: usize) -> Events {
        let mut at: Vec<Vec<(u32, f64, f64)>> = vec![vec![]; ny + 1];
        for b in 0..y.rptr.len() - 1 {
            for run in y.runs(b) {
                at[run.lo as usize].push((b as u32, run.a, run.b));
                at[run.hi as usize].push((b as u32, -run.a, -run.b));
            }
        }
        let mut ptr = vec![0];
        let mut ev = vec![];
        for list in at {
            ev.extend(list);
            ptr.push(ev.len());
        }
        Events { ptr, ev }
    }
}

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

/// Σ a_k b_k over equal-length slices: sixteen interleaved partial sums (four vectors of
/// four, so that the adds of one vector do not wait on each other's), then four for what
/// is left in fours, then the rest in order. The order is fixed, so the result is too.
#[inline(always)]
fn dot_slices(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 16];
    let (ca, cb) = (a.chunks_exact(16), b.chunks_exact(16));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..16 {
            acc[k] += x[k] * y[k];
        }
    }
    let (ca, cb) = (ra.chunks_exact(4), rb.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut lanes = [0.0f64; 4];
    for (k, l) in lanes.iter_mut().enumerate() {
        *l = (acc[k] + acc[4 + k]) + (acc[8 + k] + acc[12 + k]);
    }
    let mut s = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// [`dot_slices`] with AVX2 vectors, the same operations in the same order (so the same
/// bits): LLVM does not keep the sixteen partial sums in four vectors by itself.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn dot_slices_avx2(a: &[f64], b: &[f64]) -> f64 {
    use std::arch::x86_64::*;
    let n = a.len().min(b.len());
    let (pa, pb) = (a.as_ptr(), b.as_ptr());
    let mut acc = [_mm256_setzero_pd(); 4];
    let mut c = 0;
    // SAFETY: every load reads 4 values at c + 4k + 3 < n.
    while c + 16 <= n {
        for (k, acc) in acc.iter_mut().enumerate() {
            let x = _mm256_loadu_pd(pa.add(c + 4 * k));
            let y = _mm256_loadu_pd(pb.add(c + 4 * k));
            *acc = _mm256_add_pd(*acc, _mm256_mul_pd(x, y));
        }
        c += 16;
    }
    while c + 4 <= n {
        let x = _mm256_loadu_pd(pa.add(c));
        let y = _mm256_loadu_pd(pb.add(c));
        acc[0] = _mm256_add_pd(acc[0], _mm256_mul_pd(x, y));
        c += 4;
    }
    let v = _mm256_add_pd(_mm256_add_pd(acc[0], acc[1]), _mm256_add_pd(acc[2], acc[3]));
    let mut lanes = [0.0f64; 4];
    _mm256_storeu_pd(lanes.as_mut_ptr(), v);
    let mut s = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for k in c..n {
        s += a[k] * b[k];
    }
    s
}

/// o += v · s over equal-length slices.
#[inline(always)]
fn axpy(o: &mut [f64], v: f64, s: &[f64]) {
    for (q, x) in o.iter_mut().zip(s) {
        *q += v * x;
    }
}

/// A block of the map's rows, with each row's weight w (1/σ², 0 for a pixel that is not a
/// row) and raw value y.
#[derive(Clone, Debug)]
pub enum Block {
    /// Rows `norm · (py row b ⊗ px row a)` for the nr × nc raw window (b, a), `w` and `y`
    /// row-major over the window; `px` maps raw columns to grid columns, `py` raw rows to
    /// grid rows from the top.
    Factored {
        norm: f64,
        px: Csr,
        py: Csr,
        w: Vec<f64>,
        y: Vec<f64>,
    },
    /// Explicit rows over the grid's cells (row-major, row 0 at the top).
    Rows { a: Csr, w: Vec<f64>, y: Vec<f64> },
}

/// A block ready for products: its transposes (for the pass over output rows) and a
/// factored block's x factor as spans (plain and squared).
struct Prepared {
    block: Block,
    /// Factored: pyᵀ (grid rows → raw rows); Rows: Aᵀ (cells → rows).
    back: Csr,
    spans: Option<(Band, Band)>,
    /// A factored block's y factor in pieces (None for Rows blocks).
    fast: Option<Fast>,
}

impl Prepared {
    /// The y factor's pieces if a pass runs through them: a product (A t formed) of a
    /// factored block always does (its runs from T's prefix sums, its dense entries through
    /// `back_dense`, the runs back by [`Normal::sweep`]); the right-hand side and the
    /// diagonal use py whole. The one place this choice is made.
    fn pieces(&self, product: bool) -> Option<&Fast> {
        self.fast.as_ref().filter(|_| product)
    }
}

/// A factored block's y factor for [`Normal::apply`]: cut into pieces, its dense entries
/// transposed (grid rows → raw rows) and its runs as events over grid rows. (The x factor
/// stays dense: its rows are short slices the products vectorise, where pieces would cost
/// more per pixel than they save.)
struct Fast {
    y: Pieces,
    back_dense: Csr,
    events: Events,
}

impl Fast {
    fn new(py: &Csr) -> Result<Fast> {
        let y = Pieces::new(py)?;
        let mut indptr = vec![0];
        let (mut indices, mut data) = (vec![], vec![]);
        for b in 0..py.nrows() {
            for (c, v) in y.dense(b) {
                indices.extend((c..c + v.len()).map(|k| k as u32));
                data.extend_from_slice(v);
            }
            indptr.push(data.len());
        }
        let dense = Csr {
            indptr,
            indices,
            data,
            ncols: py.ncols,
        };
        let events = Events::new(&y, py.ncols);
        Ok(Fast {
            y,
            back_dense: dense.transpose()?,
            events,
        })
    }
}

/// The normal equations of one solve over an nx × ny grid of cells.
pub struct Normal {
    nx: usize,
    ny: usize,
    lam: f64,
    blocks: Vec<Prepared>,
    /// Whether a product has y runs to read and sweep (some block is factored): then the
    /// column-chunked prefix sums exist.
    runs: bool,
}

/// The solve's result: the cells (row-major, row 0 at the top), the iterations CG took and
/// the normal equations' relative residual ‖(AᵀWA + λDᵀD) t − AᵀWy‖ / ‖AᵀWy‖ at the end.
pub struct Solution {
    pub cells: Vec<f64>,
    pub iterations: usize,
    pub residual: f64,
}

/// The scratch of one product: per block, a Factored block's (nr × nx) back-projected rows
/// or a Rows block's weighted residuals; and two column-chunked (ny + 1) × nx arrays for
/// the factored blocks' runs (see [`Normal::prefix`] and [`Normal::sweep`]).
pub struct Work {
    scratch: Vec<Vec<f64>>,
    s0: Vec<f64>,
    s1: Vec<f64>,
}

/// Entries summed per chunk of a dot product (fixed: thread-independent rounding).
const DOT_CHUNK: usize = 4096;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    let parts: Vec<f64> = a
        .par_chunks(DOT_CHUNK)
        .zip(b.par_chunks(DOT_CHUNK))
        .map(|(x, y)| dot_slices(x, y))
        .collect();
    parts.iter().sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

fn check_weights(field: &'static str, v: &[f64], n: usize, nonneg: bool) -> Result<()> {
    if v.len() != n {
        return Err(Error::param(
            field,
            v.len(),
            format!("{n} values (one per row)"),
        ));
    }
    if let Some(&x) = v.iter().find(|x| !x.is_finite() || (nonneg && **x < 0.0)) {
        let allowed = if nonneg {
            "finite values ≥ 0"
        } else {
            "finite values"
        };
        return Err(Error::param(field, x, allowed));
    }
    Ok(())
}

impl Normal {
    /// The normal equations of `blocks` over the nx × ny grid with prior weight `lam`,
    /// every block checked against the grid.
    pub fn new(nx: usize, ny: usize, lam: f64, blocks: Vec<Block>) -> Result<Normal> {
        if nx == 0 || ny == 0 {
            return Err(Error::param(
                "grid",
                format!("{nx} x {ny}"),
                "at least 1 x 1 cells",
            ));
        }
        if !(lam.is_finite() && lam > 0.0) {
            return Err(Error::param("regularization", lam, "a finite value > 0"));
        }
        let cells = nx
            .checked_mul(ny)
            .filter(|&n| n < u32::MAX as usize)
            .ok_or_else(|| Error::param("grid", format!("{nx} x {ny}"), "fewer than 2^32 cells"))?;
        let mut prepared = Vec::with_capacity(blocks.len());
        for block in blocks {
            let back = match &block {
                Block::Factored { norm, px, py, w, y } => {
                    if !norm.is_finite() {
                        return Err(Error::param("norm", norm, "a finite value"));
                    }
                    if px.ncols != nx || py.ncols != ny {
                        return Err(Error::param(
                            "factors",
                            format!("{} x {} grid columns x rows", px.ncols, py.ncols),
                            format!("the grid's {nx} x {ny}"),
                        ));
                    }
                    let n = px.nrows() * py.nrows();
                    check_weights("weights", w, n, true)?;
                    check_weights("values", y, n, false)?;
                    let spans = Some((Band::new(px, false)?, Band::new(px, true)?));
                    (py.transpose()?, spans, Some(Fast::new(py)?))
                }
                Block::Rows { a, w, y } => {
                    if a.ncols != cells {
                        return Err(Error::param("rows", a.ncols, format!("{cells} columns")));
                    }
                    check_weights("weights", w, a.nrows(), true)?;
                    check_weights("values", y, a.nrows(), false)?;
                    (a.transpose()?, None, None)
                }
            };
            let (back, spans, fast) = back;
            prepared.push(Prepared {
                block,
                back,
                spans,
                fast,
            });
        }
        let runs = prepared.iter().any(|p| p.fast.is_some());
        Ok(Normal {
            nx,
            ny,
            lam,
            blocks: prepared,
            runs,
        })
    }

    pub fn cells(&self) -> usize {
        self.nx * self.ny
    }

    /// Bytes of one product's scratch (what [`Normal::apply`] holds besides its vectors).
    fn work_bytes(&self) -> u128 {
        (self
            .blocks
            .iter()
            .map(|p| self.scratch_len(p) as u128)
            .sum::<u128>()
            + 2 * self.chunked_len() as u128)
            * 8
    }

    /// Values of one column-chunked array (0 without factored blocks): chunk k holds
    /// columns k·CW .. (k + 1)·CW of grid rows 0..=ny, row-major.
    fn chunked_len(&self) -> usize {
        if self.runs {
            self.nx.div_ceil(CW) * CW * (self.ny + 1)
        } else {
            0
        }
    }

    /// Values of one block's scratch: a Factored block's nr × nx back-projected rows, a
    /// Rows block's one value a row.
    fn scratch_len(&self, p: &Prepared) -> usize {
        match &p.block {
            Block::Factored { py, .. } => py.nrows() * self.nx,
            Block::Rows { a, .. } => a.nrows(),
        }
    }

    fn work(&self) -> Result<Work> {
        let scratch = self
            .blocks
            .iter()
            .map(|p| memory::try_vec("the solve's work arrays", self.scratch_len(p), 0.0))
            .collect::<Result<_>>()?;
        let n = self.chunked_len();
        Ok(Work {
            scratch,
            s0: memory::try_vec("the solve's work arrays", n, 0.0)?,
            s1: memory::try_vec("the solve's work arrays", n, 0.0)?,
        })
    }

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
        match t {
            Some(t) => {
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
            None => o.fill(0.0),
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
    fn rhs(&self, work: &mut Work, out: &mut [f64]) {
        self.rows_into(None, work, false, |b, k, _| match b {
            Block::Factored { norm, w, y, .. } => w[k] * norm * y[k],
            Block::Rows { w, y, .. } => w[k] * y[k],
        });
        self.gather(work, false, None, out);
    }

    /// diag(Aᵀ W A + λ DᵀD) into `out`; returns trace(Aᵀ W A), the data part's sum
    /// (taken before the prior is added).
    fn diagonal(&self, work: &mut Work, out: &mut [f64]) -> f64 {
        self.rows_into(None, work, true, |b, k, _| match b {
            Block::Factored { norm, w, .. } => w[k] * norm * norm,
            Block::Rows { w, .. } => w[k],
        });
        self.gather(work, true, None, out);
        let trace = out.iter().sum::<f64>();
        let (nx, ny) = (self.nx, self.ny);
        for (c, d) in out.iter_mut().enumerate() {
            let (j, i) = (c / nx, c % nx);
            let n = (i > 0) as u8 + (i + 1 < nx) as u8 + (j > 0) as u8 + (j + 1 < ny) as u8;
            *d += self.lam * n as f64;
        }
        trace
    }
}

/// Wall time of one batch of iterations between two interrupt checks on the calling thread.
const BATCH: std::time::Duration = std::time::Duration::from_millis(40);

/// When [`solve`] stops: after `max_iter` steps, or once ‖r‖ < max(rtol ‖AᵀWy‖,
/// noise ν), where ν = √trace(AᵀWA) is the expected norm of the noise's part of AᵀWy when
/// W is the rows' inverse noise variance (E[AᵀW n nᵀ W A] = AᵀWA): `noise` = 0 for a
/// raw whose noise is not known.
#[derive(Clone, Copy, Debug)]
pub struct Stop {
    pub rtol: f64,
    pub noise: f64,
    pub max_iter: usize,
}

impl Stop {
    /// A stop on the relative residual alone.
    pub fn relative(rtol: f64, max_iter: usize) -> Stop {
        Stop {
            rtol,
            noise: 0.0,
            max_iter,
        }
    }
}

/// Solve the normal equations by Jacobi-preconditioned conjugate gradients, SciPy's `cg`
/// iteration: start from the normalised back-projection (AᵀWy / AᵀWA·1; cells no row sees
/// start at Σ AᵀWy / Σ AᵀWA·1), stop as `stop` says (with `stop.noise` = 0, SciPy's
/// ‖r‖ < rtol ‖AᵀWy‖). `done` counts iterations (progress); Ctrl-C is checked between
/// batches of about 40 ms.
pub fn solve(
    normal: &Normal,
    stop: Stop,
    n_threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<Solution> {
    let Stop {
        rtol,
        noise,
        max_iter,
    } = stop;
    if !(rtol.is_finite() && rtol > 0.0) {
        return Err(Error::param("rtol", rtol, "a finite value > 0"));
    }
    if !(noise.is_finite() && noise >= 0.0) {
        return Err(Error::param("noise_tol", noise, "a finite value >= 0"));
    }
    let n = normal.cells();
    memory::check(
        "the solve's vectors",
        memory::bytes_of::<f64>(7 * n as u128) + normal.work_bytes(),
    )?;
    let vec = |v: f64| memory::try_vec("the solve's vectors", n, v);
    let mut work = normal.work()?;
    let (mut b, mut diag, mut seen, mut x) = (vec(0.0)?, vec(0.0)?, vec(0.0)?, vec(0.0)?);
    let (mut r, mut p, mut q) = (vec(0.0)?, vec(0.0)?, vec(0.0)?);
    let (mut iterations, mut rho_prev) = (0usize, 0.0f64);
    let mut first = true;
    let (mut tol, mut bn) = (0.0, 0.0);
    parallel::repeat_until(n_threads, || {
        if first {
            first = false;
            normal.rhs(&mut work, &mut b);
            let trace = normal.diagonal(&mut work, &mut diag);
            // AᵀWA·1, with p (not needed before the first step) as the ones: the seven
            // vectors the memory check counts are all the solve holds.
            p.fill(1.0);
            normal.apply(&p, &mut work, &mut seen);
            let mean = b.iter().sum::<f64>() / seen.iter().sum::<f64>().max(1e-300);
            x.par_iter_mut()
                .zip(b.par_iter().zip(seen.par_iter()))
                .for_each(|(x, (&b, &s))| *x = if s > 0.0 { b / s } else { mean });
            bn = norm(&b);
            if bn == 0.0 {
                x.fill(0.0);
                return Ok(true);
            }
            tol = (rtol * bn).max(noise * trace.sqrt());
            normal.apply(&x, &mut work, &mut q);
            r.par_iter_mut()
                .zip(b.par_iter().zip(q.par_iter()))
                .for_each(|(r, (&b, &q))| *r = b - q);
            return Ok(false);
        }
        let start = std::time::Instant::now();
        loop {
            if iterations >= max_iter || norm(&r) < tol {
                return Ok(true);
            }
            // z = r / diag, kept in q until the product overwrites it.
            q.par_iter_mut()
                .zip(r.par_iter().zip(diag.par_iter()))
                .for_each(|(z, (&r, &d))| *z = r / if d > 0.0 { d } else { 1.0 });
            let rho = dot(&r, &q);
            if iterations == 0 {
                p.copy_from_slice(&q);
            } else {
                let beta = rho / rho_prev;
                p.par_iter_mut()
                    .zip(q.par_iter())
                    .for_each(|(p, &z)| *p = beta * *p + z);
            }
            normal.apply(&p, &mut work, &mut q);
            let alpha = rho / dot(&p, &q);
            x.par_iter_mut()
                .zip(p.par_iter())
                .for_each(|(x, &p)| *x += alpha * p);
            r.par_iter_mut()
                .zip(q.par_iter())
                .for_each(|(r, &q)| *r -= alpha * q);
            (iterations, rho_prev) = (iterations + 1, rho);
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            parallel::checkpoint()?;
            if start.elapsed() >= BATCH {
                return Ok(false);
            }
        }
    })?;
    // The true residual of the result (not the recurrence's).
    normal.apply(&x, &mut work, &mut q);
    q.iter_mut().zip(&b).for_each(|(q, b)| *q -= b);
    let residual = if bn > 0.0 { norm(&q) / bn } else { 0.0 };
    Ok(Solution {
        cells: x,
        iterations,
        residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    /// A small factored block: nr × nc raw window over an nx × ny grid, each pixel's x and
    /// y rows a contiguous run of 2–4 cells, some pixels not rows (weight 0).
    fn factored(nx: usize, ny: usize) -> (Block, Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
        let run = |n: usize, cols: usize, seed: usize| {
            let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
            for i in 0..n {
                let len = 2 + (i + seed) % 3;
                let first = (i * (cols - len)) / n.max(1);
                for k in 0..len {
                    indices.push((first + k) as u32);
                    data.push(0.3 + 0.1 * ((i * 7 + k * 3 + seed) % 5) as f64);
                }
                indptr.push(indices.len());
            }
            Csr::new("test", indptr, indices, data, cols).unwrap()
        };
        let (nc, nr) = (7, 6);
        let px = run(nc, nx, 1);
        let py = run(nr, ny, 2);
        let w: Vec<f64> = (0..nr * nc)
            .map(|k| {
                if k % 5 == 3 {
                    0.0
                } else {
                    1.0 + (k % 4) as f64
                }
            })
            .collect();
        let y: Vec<f64> = (0..nr * nc).map(|k| ((k * 13) % 7) as f64 / 7.0).collect();
        // The explicit rows: norm · (py row b) ⊗ (px row a), dense over the cells.
        let norm = 1.5;
        let mut dense = vec![];
        for b in 0..nr {
            for a in 0..nc {
                let mut row = vec![0.0; nx * ny];
                let (js, vy) = py.row(b);
                let (is, vx) = px.row(a);
                for (&j, &u) in js.iter().zip(vy) {
                    for (&i, &v) in is.iter().zip(vx) {
                        row[j as usize * nx + i as usize] += norm * u * v;
                    }
                }
                dense.push(row);
            }
        }
        let block = Block::Factored {
            norm,
            px,
            py,
            w: w.clone(),
            y: y.clone(),
        };
        (block, dense, w, y)
    }

    fn rows_of(dense: &[Vec<f64>], w: Vec<f64>, y: Vec<f64>) -> Block {
        let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
        for row in dense {
            for (c, &v) in row.iter().enumerate() {
                if v != 0.0 {
                    indices.push(c as u32);
                    data.push(v);
                }
            }
            indptr.push(indices.len());
        }
        let a = Csr::new("test", indptr, indices, data, dense[0].len()).unwrap();
        Block::Rows { a, w, y }
    }

    /// The direct solution of (AᵀWA + λDᵀD) t = AᵀWy by Gaussian elimination.
    fn direct(
        dense: &[Vec<f64>],
        w: &[f64],
        y: &[f64],
        nx: usize,
        ny: usize,
        lam: f64,
    ) -> Vec<f64> {
        let n = nx * ny;
        let mut h = vec![vec![0.0; n + 1]; n];
        for (k, row) in dense.iter().enumerate() {
            for c in 0..n {
                h[c][n] += row[c] * w[k] * y[k];
                for d in 0..n {
                    h[c][d] += row[c] * w[k] * row[d];
                }
            }
        }
        let mut pair = |p: usize, q: usize| {
            h[p][p] += lam;
            h[q][q] += lam;
            h[p][q] -= lam;
            h[q][p] -= lam;
        };
        for j in 0..ny {
            for i in 0..nx {
                if i + 1 < nx {
                    pair(j * nx + i, j * nx + i + 1);
                }
                if j + 1 < ny {
                    pair(j * nx + i, (j + 1) * nx + i);
                }
            }
        }
        for c in 0..n {
            let piv = (c..n)
                .max_by(|&a, &b| h[a][c].abs().total_cmp(&h[b][c].abs()))
                .unwrap();
            h.swap(c, piv);
            for r in 0..n {
                if r != c {
                    let f = h[r][c] / h[c][c];
                    let pivot = h[c].clone();
                    for (q, p) in h[r][c..].iter_mut().zip(&pivot[c..]) {
                        *q -= f * p;
                    }
                }
            }
        }
        (0..n).map(|c| h[c][n] / h[c][c]).collect()
    }

    #[test]
    fn cg_reaches_the_direct_solution_in_both_forms_at_any_thread_count() {
        let (nx, ny, lam) = (9, 8, 0.2);
        let (block, dense, w, y) = factored(nx, ny);
        let want = direct(&dense, &w, &y, nx, ny, lam);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let rows = rows_of(&dense, w, y);
        let mut results = vec![];
        for b in [block, rows] {
            let normal = Normal::new(nx, ny, lam, vec![b]).unwrap();
            for threads in [Some(1), Some(2)] {
                let done = AtomicUsize::new(0);
                let s = solve(&normal, Stop::relative(1e-14, 10_000), threads, &done).unwrap();
                assert!(s.iterations > 0 && s.iterations < 10_000);
                assert_eq!(
                    done.load(std::sync::atomic::Ordering::Relaxed),
                    s.iterations
                );
                assert!(s.residual < 1e-12, "{}", s.residual);
                let err = s
                    .cells
                    .iter()
                    .zip(&want)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(err <= 1e-10 * scale, "{err}");
                results.push(s.cells);
            }
        }
        // Thread-independent bit for bit within a form.
        assert_eq!(results[0], results[1]);
        assert_eq!(results[2], results[3]);
    }

    /// The noise stop is the relative stop at rtol = τ √trace(AᵀWA) / ‖AᵀWy‖, the trace
    /// (Σ_rows w ‖row‖²) and the right-hand side taken here from the dense rows: the same
    /// iterations and the same cells, in both forms, and fewer iterations than rtol alone.
    #[test]
    fn noise_stop_is_the_relative_stop_at_the_noise_norm() {
        let (nx, ny, lam, tau) = (9, 8, 0.2, 1e-3);
        let (block, dense, w, y) = factored(nx, ny);
        let trace: f64 = dense
            .iter()
            .zip(&w)
            .map(|(row, &w)| w * row.iter().map(|v| v * v).sum::<f64>())
            .sum();
        let rhs: Vec<f64> = (0..nx * ny)
            .map(|c| {
                dense
                    .iter()
                    .zip(&w)
                    .zip(&y)
                    .map(|((r, w), y)| r[c] * w * y)
                    .sum()
            })
            .collect();
        let bn = norm(&rhs);
        let rows = rows_of(&dense, w, y);
        for b in [block, rows] {
            let normal = Normal::new(nx, ny, lam, vec![b]).unwrap();
            let done = AtomicUsize::new(0);
            let stop = Stop {
                rtol: 1e-14,
                noise: tau,
                max_iter: 10_000,
            };
            let noisy = solve(&normal, stop, None, &done).unwrap();
            let rtol = tau * trace.sqrt() / bn;
            let relative = solve(&normal, Stop::relative(rtol, 10_000), None, &done).unwrap();
            let tight = solve(&normal, Stop::relative(1e-14, 10_000), None, &done).unwrap();
            assert!(rtol > 1e-9 && noisy.iterations > 0, "{rtol}");
            assert!(noisy.iterations < tight.iterations);
            assert_eq!(noisy.iterations, relative.iterations);
            assert_eq!(noisy.cells, relative.cells);
        }
        let normal = Normal::new(nx, ny, lam, vec![factored(nx, ny).0]).unwrap();
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let stop = Stop {
                rtol: 1e-10,
                noise: bad,
                max_iter: 10,
            };
            let Err(e) = solve(&normal, stop, None, &AtomicUsize::new(0)) else {
                panic!("noise_tol {bad} was taken");
            };
            assert!(e.to_string().contains("noise_tol"), "{e}");
        }
    }

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

    #[test]
    fn zero_data_gives_zero_cells() {
        let (nx, ny) = (9, 8);
        let (block, ..) = factored(nx, ny);
        let Block::Factored { norm, px, py, w, y } = block else {
            unreachable!()
        };
        let zero = Block::Factored {
            norm,
            px,
            py,
            w,
            y: vec![0.0; y.len()],
        };
        let normal = Normal::new(nx, ny, 1.0, vec![zero]).unwrap();
        let s = solve(
            &normal,
            Stop::relative(1e-10, 100),
            None,
            &AtomicUsize::new(0),
        )
        .unwrap();
        assert!(s.cells.iter().all(|&v| v == 0.0));
        assert_eq!((s.iterations, s.residual), (0, 0.0));
    }

    #[test]
    fn bad_input_names_its_field() {
        let field = |r: Result<Csr>| r.unwrap_err().parameter_name().unwrap();
        assert_eq!(
            field(Csr::new("px", vec![0, 2], vec![0], vec![1.0], 3)),
            "px"
        );
        assert_eq!(
            field(Csr::new("px", vec![0, 1], vec![3], vec![1.0], 3)),
            "px"
        );
        assert_eq!(
            field(Csr::new("py", vec![0, 1], vec![0], vec![f64::NAN], 3)),
            "py"
        );
        let (block, ..) = factored(9, 8);
        let e = |nx, lam, b: Block| {
            Normal::new(nx, 8, lam, vec![b])
                .err()
                .unwrap()
                .parameter_name()
                .unwrap()
        };
        assert_eq!(e(9, 0.0, block.clone()), "regularization");
        assert_eq!(e(10, 1.0, block.clone()), "factors");
        let Block::Factored { norm, px, py, w, y } = block else {
            unreachable!()
        };
        let short = Block::Factored {
            norm,
            px,
            py,
            w: w[1..].to_vec(),
            y,
        };
        assert_eq!(e(9, 1.0, short), "weights");
        let normal = Normal::new(1, 1, 1.0, vec![]).unwrap();
        let r = solve(
            &normal,
            Stop::relative(f64::NAN, 10),
            None,
            &AtomicUsize::new(0),
        );
        assert_eq!(r.err().unwrap().parameter_name().unwrap(), "rtol");
    }

    #[test]
    fn transpose_is_the_transpose() {
        let a = Csr::new("a", vec![0, 2, 2, 3], vec![1, 3, 0], vec![1.0, 2.0, 3.0], 4).unwrap();
        let t = a.transpose().unwrap();
        assert_eq!(t.indptr, vec![0, 1, 2, 2, 3]);
        assert_eq!(t.indices, vec![2, 0, 0]);
        assert_eq!(t.data, vec![3.0, 1.0, 2.0]);
        assert_eq!(t.ncols, 3);
    }
}
