//! The crate's one compressed-row matrix ([`Csr`]): a solve's blocks are given in it (the
//! map's factors, its explicit rows), and the 1-D simulation's system matrix is one.

use crate::infra::error::{Error, Result};
use crate::infra::memory;

/// A sparse matrix in compressed rows: row i's entries are `indices[indptr[i]..indptr[i+1]]`
/// (columns, < `ncols`) and the same range of `data`.
#[derive(Clone, Debug, PartialEq)]
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

    /// A matrix of no rows over `ncols` columns, to be built row by row: a row's entries
    /// pushed on `indices` and `data`, then [`Csr::end_row`]. Such rows are the builder's
    /// own and unchecked: columns < `ncols`, values finite.
    pub fn empty(ncols: usize) -> Csr {
        Csr {
            indptr: vec![0],
            indices: Vec::new(),
            data: Vec::new(),
            ncols,
        }
    }

    /// Close the row being written (the entries pushed since the last row).
    pub fn end_row(&mut self) {
        self.indptr.push(self.data.len());
    }

    /// Append the rows of `other` (over the same columns) below this matrix's.
    pub fn append(&mut self, other: &Csr) {
        let base = self.data.len();
        self.indptr
            .extend(other.indptr[1..].iter().map(|&p| base + p));
        self.indices.extend_from_slice(&other.indices);
        self.data.extend_from_slice(&other.data);
    }

    /// The matrix of `rows`, each row's (column, value) entries in order, over `ncols`
    /// columns, its arrays allocated fallibly (`what` names it in errors); unchecked, as
    /// the rows of [`Csr::empty`].
    pub fn from_rows(what: &'static str, rows: &[Vec<(u32, f64)>], ncols: usize) -> Result<Csr> {
        let nnz: usize = rows.iter().map(Vec::len).sum();
        let mut m = Csr {
            indptr: memory::try_with_capacity(what, rows.len() + 1)?,
            indices: memory::try_with_capacity(what, nnz)?,
            data: memory::try_with_capacity(what, nnz)?,
            ncols,
        };
        m.indptr.push(0);
        for r in rows {
            for &(c, v) in r {
                m.indices.push(c);
                m.data.push(v);
            }
            m.end_row();
        }
        Ok(m)
    }

    pub fn nrows(&self) -> usize {
        self.indptr.len() - 1
    }

    /// Each row's sum of values.
    pub fn row_sums(&self) -> Vec<f64> {
        (0..self.nrows())
            .map(|r| self.row(r).1.iter().sum())
            .collect()
    }

    /// Row i's columns and values.
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
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

#[cfg(test)]
mod tests {
    use super::*;

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
    }

    #[test]
    fn from_rows_is_the_checked_matrix_of_its_rows() {
        let rows = vec![vec![(1, 1.0), (3, 2.0)], vec![], vec![(0, 3.0)]];
        let a = Csr::from_rows("a", &rows, 4).unwrap();
        let want = Csr::new("a", vec![0, 2, 2, 3], vec![1, 3, 0], vec![1.0, 2.0, 3.0], 4);
        assert_eq!(a, want.unwrap());
        assert_eq!(a.nrows(), 3);
        assert_eq!(a.row(0), (&[1u32, 3][..], &[1.0, 2.0][..]));
        assert_eq!(a.row(1), (&[][..], &[][..]));
        let empty = Csr::from_rows("a", &[], 4).unwrap();
        assert_eq!(empty, Csr::empty(4));
        assert_eq!((empty.nrows(), empty.indptr), (0, vec![0]));
    }

    /// Rows built one by one and appended in two parts are the matrix of all the rows.
    #[test]
    fn rows_built_and_appended_are_the_matrix() {
        let mut top = Csr::empty(4);
        top.indices.extend([1, 3]);
        top.data.extend([1.0, 2.0]);
        top.end_row();
        top.end_row();
        let mut bottom = Csr::empty(4);
        bottom.indices.push(0);
        bottom.data.push(3.0);
        bottom.end_row();
        top.append(&bottom);
        let want = Csr::new("a", vec![0, 2, 2, 3], vec![1, 3, 0], vec![1.0, 2.0, 3.0], 4);
        assert_eq!(top, want.unwrap());
        top.append(&Csr::empty(4));
        assert_eq!(top.nrows(), 3);
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
