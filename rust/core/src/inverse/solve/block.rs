//! The blocks a solve's map comes in (one type, on its own so that every part of the
//! solve can name it without naming the normal equations it makes).

use crate::infra::csr::Csr;

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
