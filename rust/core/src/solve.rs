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

use crate::error::{Error, Result};
use crate::memory;
use crate::parallel;

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

/// Whether the CPU has AVX2 (checked once): the products' kernels are compiled twice, for
/// the baseline and for AVX2, from the same code. Rust never fuses a multiply and an add,
/// so both give the same result bit for bit; AVX2 only does four at a time.
#[cfg(target_arch = "x86_64")]
fn avx2() -> bool {
    static HAS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *HAS.get_or_init(|| std::arch::is_x86_feature_detected!("avx2"))
}

/// One raw row b of a factored block: u = (py row b) · T, then for each pixel a of the row
/// that is a row of the map the value s = value(b·nc + a, (px row a) · u), back-projected
/// into the scratch row g = Σ_a s · (px row a).
struct RowJob<'a> {
    py: &'a Csr,
    band: &'a Band,
    w: &'a [f64],
    nc: usize,
    nx: usize,
    t: Option<&'a [f64]>,
    value: &'a (dyn Fn(usize, f64) -> f64 + Sync),
}

impl RowJob<'_> {
    fn run(&self, b: usize, u: &mut [f64], g: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if avx2() {
            // SAFETY: the CPU has AVX2 (checked at run time).
            return unsafe { self.run_avx2(b, u, g) };
        }
        self.run_plain(b, u, g)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(&self, b: usize, u: &mut [f64], g: &mut [f64]) {
        self.run_plain(b, u, g)
    }

    #[inline(always)]
    fn run_plain(&self, b: usize, u: &mut [f64], g: &mut [f64]) {
        let (nx, nc) = (self.nx, self.nc);
        if let Some(t) = self.t {
            u.fill(0.0);
            let (js, vs) = self.py.row(b);
            for (&j, &v) in js.iter().zip(vs) {
                axpy(u, v, &t[j as usize * nx..(j as usize + 1) * nx]);
            }
        }
        g.fill(0.0);
        for a in 0..nc {
            if self.w[b * nc + a] == 0.0 {
                continue;
            }
            let (lo, vs) = self.band.row(a);
            let fwd = match self.t {
                Some(_) => dot_slices(vs, &u[lo..lo + vs.len()]),
                None => 0.0,
            };
            let s = (self.value)(b * nc + a, fwd);
            if s != 0.0 {
                axpy(&mut g[lo..lo + vs.len()], s, vs);
            }
        }
    }
}

/// Σ a_k b_k over equal-length slices, in four interleaved partial sums (vectorised; the
/// order is fixed, so the result is too).
#[inline(always)]
fn dot_slices(a: &[f64], b: &[f64]) -> f64 {
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    let mut acc = [0.0f64; 4];
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
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
}

/// The normal equations of one solve over an nx × ny grid of cells.
pub struct Normal {
    nx: usize,
    ny: usize,
    lam: f64,
    blocks: Vec<Prepared>,
}

/// The solve's result: the cells (row-major, row 0 at the top), the iterations CG took and
/// the normal equations' relative residual ‖(AᵀWA + λDᵀD) t − AᵀWy‖ / ‖AᵀWy‖ at the end.
pub struct Solution {
    pub cells: Vec<f64>,
    pub iterations: usize,
    pub residual: f64,
}

/// Per-block scratch of one product: a Factored block's (nr × nx) back-projected rows, a
/// Rows block's weighted residuals.
type Work = Vec<Vec<f64>>;

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
                    (py.transpose()?, spans)
                }
                Block::Rows { a, w, y } => {
                    if a.ncols != cells {
                        return Err(Error::param("rows", a.ncols, format!("{cells} columns")));
                    }
                    check_weights("weights", w, a.nrows(), true)?;
                    check_weights("values", y, a.nrows(), false)?;
                    (a.transpose()?, None)
                }
            };
            let (back, spans) = back;
            prepared.push(Prepared { block, back, spans });
        }
        Ok(Normal {
            nx,
            ny,
            lam,
            blocks: prepared,
        })
    }

    pub fn cells(&self) -> usize {
        self.nx * self.ny
    }

    /// Bytes of one product's scratch (what [`Normal::apply`] holds besides its vectors).
    fn work_bytes(&self) -> u128 {
        self.blocks
            .iter()
            .map(|p| self.scratch_len(p) as u128)
            .sum::<u128>()
            * 8
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
        self.blocks
            .iter()
            .map(|p| memory::try_vec("the solve's work arrays", self.scratch_len(p), 0.0))
            .collect()
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
        for (p, scratch) in self.blocks.iter().zip(work.iter_mut()) {
            match &p.block {
                Block::Factored { px, py, w, .. } => {
                    let Some((plain, sq)) = &p.spans else {
                        continue;
                    };
                    let band = if squared { sq } else { plain };
                    let nc = px.nrows();
                    let block = &p.block;
                    let job = RowJob {
                        py,
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
            #[cfg(target_arch = "x86_64")]
            if avx2() {
                // SAFETY: the CPU has AVX2 (checked at run time).
                return unsafe { self.gather_row_avx2(work, squared, t, j, o) };
            }
            self.gather_row(work, squared, t, j, o)
        });
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn gather_row_avx2(
        &self,
        work: &Work,
        squared: bool,
        t: Option<&[f64]>,
        j: usize,
        o: &mut [f64],
    ) {
        self.gather_row(work, squared, t, j, o)
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
        for (p, scratch) in self.blocks.iter().zip(work) {
            match &p.block {
                Block::Factored { .. } => {
                    let (bs, vs) = p.back.row(j);
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
    }

    /// out = (Aᵀ W A + λ DᵀD) t.
    pub fn apply(&self, t: &[f64], work: &mut Work, out: &mut [f64]) {
        self.rows_into(Some(t), work, false, |b, k, fwd| match b {
            Block::Factored { norm, w, .. } => w[k] * norm * norm * fwd,
            Block::Rows { w, .. } => w[k] * fwd,
        });
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

    /// diag(Aᵀ W A + λ DᵀD).
    fn diagonal(&self, work: &mut Work, out: &mut [f64]) {
        self.rows_into(None, work, true, |b, k, _| match b {
            Block::Factored { norm, w, .. } => w[k] * norm * norm,
            Block::Rows { w, .. } => w[k],
        });
        self.gather(work, true, None, out);
        let (nx, ny) = (self.nx, self.ny);
        for (c, d) in out.iter_mut().enumerate() {
            let (j, i) = (c / nx, c % nx);
            let n = (i > 0) as u8 + (i + 1 < nx) as u8 + (j > 0) as u8 + (j + 1 < ny) as u8;
            *d += self.lam * n as f64;
        }
    }
}

/// Wall time of one batch of iterations between two interrupt checks on the calling thread.
const BATCH: std::time::Duration = std::time::Duration::from_millis(40);

/// Solve the normal equations by Jacobi-preconditioned conjugate gradients, SciPy's `cg`
/// iteration: start from the normalised back-projection (AᵀWy / AᵀWA·1; cells no row sees
/// start at Σ AᵀWy / Σ AᵀWA·1), stop when ‖r‖ < rtol ‖AᵀWy‖ or after `max_iter` steps.
/// `done` counts iterations (progress); Ctrl-C is checked between batches of about 40 ms.
pub fn solve(
    normal: &Normal,
    rtol: f64,
    max_iter: usize,
    n_threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<Solution> {
    if !(rtol.is_finite() && rtol > 0.0) {
        return Err(Error::param("rtol", rtol, "a finite value > 0"));
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
            normal.diagonal(&mut work, &mut diag);
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
            tol = rtol * bn;
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
                let s = solve(&normal, 1e-14, 10_000, threads, &done).unwrap();
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
        let s = solve(&normal, 1e-10, 100, None, &AtomicUsize::new(0)).unwrap();
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
        let r = solve(&normal, f64::NAN, 10, None, &AtomicUsize::new(0));
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
