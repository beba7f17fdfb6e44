//! The blocks of a solve and the normal equations they make over the grid: each block
//! checked against the grid and prepared for products (transposes, spans, pieces), and
//! the scratch one product needs (sized before it is allocated).

use crate::infra::error::{Error, Result};
use crate::infra::memory;

use super::block::Block;
use super::coarse::Coarse;
use super::pieces::{Band, Fast};
use crate::infra::csr::Csr;

/// A block ready for products: its transposes (for the pass over output rows) and a
/// factored block's x factor as spans (plain and squared).
pub(super) struct Prepared {
    pub(super) block: Block,
    /// Factored: pyᵀ (grid rows → raw rows); Rows: Aᵀ (cells → rows).
    pub(super) back: Csr,
    pub(super) spans: Option<(Band, Band)>,
    /// A factored block's y factor in pieces (None for Rows blocks).
    pub(super) fast: Option<Fast>,
}

impl Prepared {
    /// The y factor's pieces if a pass runs through them: a product (A t formed) of a
    /// factored block always does (its runs from T's prefix sums, its dense entries through
    /// `back_dense`, the runs back by [`Normal::sweep`]); the right-hand side and the
    /// diagonal use py whole. The one place this choice is made.
    pub(super) fn pieces(&self, product: bool) -> Option<&Fast> {
        self.fast.as_ref().filter(|_| product)
    }
}

/// The penalty on each first difference r of neighbouring cells (docs/model.md §11): the
/// prior term is λ Σ_e ρ(r_e).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Penalty {
    /// ρ(r) = r² (the normal equations are linear: one solve).
    Quadratic,
    /// Huber's: ρ(r) = r² for |r| ≤ s, 2 s |r| − s² beyond (quadratic near 0, linear
    /// beyond the threshold s, so an edge costs in proportion to its height).
    Huber { threshold: f64 },
    /// Total variation, smoothed at ε: ρ(r) = r² / (2ε) for |r| ≤ ε, |r| − ε/2 beyond
    /// (Huber's with s = ε, divided by 2ε: |r| but for a rounded tip).
    Tv { smoothing: f64 },
}

/// The prior: its penalty and, for an edge-preserving one, the outer loop that solves it
/// by iteratively reweighted least squares (IRLS): at most `passes` conjugate-gradient
/// solves of the normal equations with per-difference weights w_e = ρ'(r_e) / (2 r_e)
/// from the previous pass's cells (the first pass is the quadratic prior's solve), each
/// warm-started from the previous cells, until the cells move by less than `tol` (RMS
/// over the cells) from one pass to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    pub penalty: Penalty,
    pub passes: usize,
    pub tol: f64,
}

impl Prior {
    /// The quadratic prior λ |D t|² (one solve).
    pub fn quadratic() -> Prior {
        Prior {
            penalty: Penalty::Quadratic,
            passes: 1,
            tol: 0.0,
        }
    }

    /// A prior by name ("quadratic", "huber", "tv") with its threshold (Huber's s, TV's
    /// smoothing ε; ignored by the quadratic prior) and the outer loop's passes and stop,
    /// each checked.
    pub fn from_parts(name: &str, threshold: f64, passes: usize, tol: f64) -> Result<Prior> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let penalty = match name {
            "quadratic" => Penalty::Quadratic,
            "huber" | "tv" if !positive(threshold) => {
                return Err(Error::param("threshold", threshold, "a finite value > 0"))
            }
            "huber" => Penalty::Huber { threshold },
            "tv" => Penalty::Tv {
                smoothing: threshold,
            },
            _ => {
                return Err(Error::param(
                    "prior",
                    name,
                    "one of \"quadratic\", \"huber\", \"tv\"",
                ))
            }
        };
        if passes == 0 {
            return Err(Error::param("prior_passes", passes, "an integer >= 1"));
        }
        if !(tol.is_finite() && tol >= 0.0) {
            return Err(Error::param("prior_tol", tol, "a finite value >= 0"));
        }
        let passes = if penalty == Penalty::Quadratic {
            1
        } else {
            passes
        };
        Ok(Prior {
            penalty,
            passes,
            tol,
        })
    }

    /// The prior checked as [`Prior::from_parts`] checks it (one pass if quadratic).
    pub fn checked(self) -> Result<Prior> {
        let (name, threshold) = match self.penalty {
            Penalty::Quadratic => ("quadratic", 1.0),
            Penalty::Huber { threshold } => ("huber", threshold),
            Penalty::Tv { smoothing } => ("tv", smoothing),
        };
        Prior::from_parts(name, threshold, self.passes, self.tol)
    }

    /// The IRLS weight w = ρ'(r) / (2 r) of a difference r (1 for the quadratic prior):
    /// the prior's quadratic majorant at r, so that each pass lowers the objective.
    #[inline]
    pub(super) fn weight(&self, r: f64) -> f64 {
        let a = r.abs();
        match self.penalty {
            Penalty::Quadratic => 1.0,
            Penalty::Huber { threshold } => {
                if a <= threshold {
                    1.0
                } else {
                    threshold / a
                }
            }
            Penalty::Tv { smoothing } => 0.5 / a.max(smoothing),
        }
    }
}

/// The normal equations of one solve over an nx × ny grid of cells.
pub struct Normal {
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) lam: f64,
    pub(super) prior: Prior,
    pub(super) blocks: Vec<Prepared>,
    /// Whether a product has y runs to read and sweep (some block is factored): then the
    /// column-chunked prefix sums exist.
    pub(super) runs: bool,
    /// The coarse-grid correction, when asked for ([`Normal::precondition_coarse`]).
    pub(super) coarse: Option<Coarse>,
}

/// The scratch of one product: per block, a Factored block's (nr × nx) back-projected rows
/// or a Rows block's weighted residuals; and two column-chunked (ny + 1) × nx arrays for
/// the factored blocks' runs (see [`Normal::prefix`] and [`Normal::sweep`]); and the
/// prior's per-difference weights when they are not all 1 (an IRLS pass after the first).
pub struct Work {
    pub(super) scratch: Vec<Vec<f64>>,
    pub(super) s0: Vec<f64>,
    pub(super) s1: Vec<f64>,
    pub(super) edges: Option<Edges>,
}

/// The weights of the differences: `x` along grid rows (cell (j, i) with (j, i + 1), at
/// j·(nx − 1) + i), `y` down the columns (cell (j, i) with (j + 1, i), at j·nx + i).
pub struct Edges {
    pub(super) x: Vec<f64>,
    pub(super) y: Vec<f64>,
}

/// Columns per chunk of the column-wise sweeps (prefix sums over grid rows): fixed, so
/// the sums' order does not depend on the thread count.
pub(super) const CW: usize = 64;

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
            prior: Prior::quadratic(),
            blocks: prepared,
            runs,
            coarse: None,
        })
    }

    /// The same normal equations under `prior` ([`Prior::checked`]).
    pub fn with_prior(mut self, prior: Prior) -> Result<Normal> {
        self.prior = prior.checked()?;
        Ok(self)
    }

    /// Precondition CG by the two-level preconditioner ([`super::coarse`]): the Jacobi
    /// diagonal plus an exact solve on aggregates of cells, rebuilt at each λ. The solution
    /// is the same; the iterations change. Grids too small to coarsen keep Jacobi.
    pub fn precondition_coarse(&mut self) -> Result<()> {
        let blocks: Vec<&Block> = self.blocks.iter().map(|p| &p.block).collect();
        self.coarse = Coarse::build(&blocks, self.nx, self.ny)?;
        if let Some(c) = &mut self.coarse {
            c.factor(self.lam);
        }
        Ok(())
    }

    pub fn prior(&self) -> Prior {
        self.prior
    }

    /// Values of the prior's weights (0 for the quadratic prior, whose weights are all 1).
    pub(super) fn edges_len(&self) -> usize {
        if self.prior.penalty == Penalty::Quadratic {
            0
        } else {
            (self.nx - 1) * self.ny + self.nx * (self.ny - 1)
        }
    }

    pub fn cells(&self) -> usize {
        self.nx * self.ny
    }

    /// The grid's columns and rows.
    pub fn shape(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// The prior's weight λ.
    pub fn regularization(&self) -> f64 {
        self.lam
    }

    /// The same equations at another prior weight (the blocks' preparation kept).
    pub fn set_regularization(&mut self, lam: f64) -> Result<()> {
        if !(lam.is_finite() && lam > 0.0) {
            return Err(Error::param("regularization", lam, "a finite value > 0"));
        }
        self.lam = lam;
        if let Some(c) = &mut self.coarse {
            c.factor(lam);
        }
        Ok(())
    }

    /// The rows (weight > 0) and Σ w y² over them.
    pub fn data_sums(&self) -> (usize, f64) {
        let (mut m, mut s) = (0usize, 0.0);
        for p in &self.blocks {
            let (Block::Factored { w, y, .. } | Block::Rows { w, y, .. }) = &p.block;
            for (&w, &y) in w.iter().zip(y) {
                if w > 0.0 {
                    m += 1;
                    s += w * y * y;
                }
            }
        }
        (m, s)
    }

    /// Bytes of one product's scratch (what [`Normal::apply`] holds besides its vectors).
    pub(super) fn work_bytes(&self) -> u128 {
        (self
            .blocks
            .iter()
            .map(|p| self.scratch_len(p) as u128)
            .sum::<u128>()
            + 2 * self.chunked_len() as u128
            + self.edges_len() as u128)
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

    pub fn work(&self) -> Result<Work> {
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
            edges: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::solve::testing::factored;

    #[test]
    fn bad_input_names_its_field() {
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
        let mut short = block;
        let Block::Factored { w, .. } = &mut short else {
            unreachable!()
        };
        w.remove(0);
        assert_eq!(e(9, 1.0, short), "weights");
    }
}
