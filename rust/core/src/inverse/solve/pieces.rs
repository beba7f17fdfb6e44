//! A factor's rows cut for fast products: as dense spans ([`Band`], the x factor), as
//! dense entries and affine runs ([`Pieces`], the y factor), the y runs as events over grid
//! rows ([`Events`]), and a factored block's y factor ready for the passes ([`Fast`]).

use crate::infra::error::{Error, Result};
use crate::infra::memory;

use crate::infra::csr::Csr;

/// A matrix's rows as dense spans: row i covers columns `first[i] ..` with the values
/// `data[ptr[i]..ptr[i + 1]]` (zeros inside a span kept). The x factor's rows are one
/// pixel's contiguous run of cells, so its spans hold exactly its entries, and products
/// with them are slices the compiler vectorises.
pub(super) struct Band {
    first: Vec<usize>,
    ptr: Vec<usize>,
    data: Vec<f64>,
}

impl Band {
    /// `m`'s rows as spans, every value squared when `squared` (for diag(Aᵀ W A)).
    pub(super) fn new(m: &Csr, squared: bool) -> Result<Band> {
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
    pub(super) fn row(&self, i: usize) -> (usize, &[f64]) {
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
pub(super) struct Run {
    pub(super) lo: u32,
    pub(super) hi: u32,
    pub(super) a: f64,
    pub(super) b: f64,
}

/// A factor's rows for [`Normal::apply`](super::Normal::apply), cut into dense spans (values kept) and affine
/// runs. A pixel's profile is the integral over cells of a piecewise-linear density (its
/// ray set's polygon seen along one axis), so it is affine between the few cells that hold
/// a kink: the seed's y profiles at 1 m (cells of δ) have 72 entries a row on half 2 and
/// 23 on half 1, and become 3.7 and 3.9 dense entries and 2.8 and 2.9 runs. A run's
/// product with a vector costs two prefix-sum differences instead of its length.
pub(super) struct Pieces {
    /// Row r's dense spans are `dense[dptr[r]..dptr[r + 1]]`: (first column, offset in
    /// `data`, length).
    dptr: Vec<usize>,
    pub(super) dense: Vec<(u32, u32, u32)>,
    data: Vec<f64>,
    /// Row r's runs are `runs[rptr[r]..rptr[r + 1]]`.
    rptr: Vec<usize>,
    pub(super) runs: Vec<Run>,
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
    pub(super) fn new(m: &Csr) -> Result<Pieces> {
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
    pub(super) fn dense(&self, r: usize) -> impl Iterator<Item = (usize, &[f64])> {
        self.dense[self.dptr[r]..self.dptr[r + 1]]
            .iter()
            .map(|&(c, o, l)| (c as usize, &self.data[o as usize..(o + l) as usize]))
    }

    #[inline(always)]
    pub(super) fn runs(&self, r: usize) -> &[Run] {
        &self.runs[self.rptr[r]..self.rptr[r + 1]]
    }
}

/// The y factor's runs as events over grid rows: at row j, each (b, α, β) of
/// `ev[ptr[j]..ptr[j + 1]]` adds (α + β j) × raw row b's scratch from j on (a run's start;
/// its end adds the negatives).
pub(super) struct Events {
    pub(super) ptr: Vec<usize>,
    pub(super) ev: Vec<(u32, f64, f64)>,
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

/// A factored block's y factor for [`Normal::apply`](super::Normal::apply): cut into pieces, its dense entries
/// transposed (grid rows → raw rows) and its runs as events over grid rows. (The x factor
/// stays dense: its rows are short slices the products vectorise, where pieces would cost
/// more per pixel than they save.)
pub(super) struct Fast {
    pub(super) y: Pieces,
    pub(super) back_dense: Csr,
    pub(super) events: Events,
}

impl Fast {
    pub(super) fn new(py: &Csr) -> Result<Fast> {
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
