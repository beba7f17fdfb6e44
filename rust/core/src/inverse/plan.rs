//! A reconstruction's plan before any large buffer (docs/reconstruct.md): the bytes it
//! holds at its peak and the work it does, from the padded grid, the raw pixels that can
//! see it and a pixel's span in cells.
//!
//! Bytes counted on the exact route (per channel and lens type, upper bounds): the axis
//! profiles and their compressed copies, the pixel-type map, the factored block (its two
//! factors restricted, the weights and values over its raw window), the solve's copies of
//! the factors (spans plain and squared, the y factor's transpose, pieces and events),
//! the block's scratch (raw rows × grid columns); then the solve's seven vectors and two
//! column-chunked prefix arrays. On the explicit routes the map's entries are counted as
//! they are made ([`crate::inverse::system::build_surface`]); before it the recorders,
//! the grid texture, the vectors and the prefix arrays, and after it the map's transpose
//! (checked before the solve copies it).

use crate::infra::error::{Error, Result};
use crate::inverse::system::CellGrid;
use crate::model::design::Design;

/// Work units (proportional to the products' multiply-adds) per second and thread, on
/// one core of the 2-core machine measured: the seed (24 x 16 and 40 x 60 lenses) at 700 mm, 2,000
/// iterations of a 225 x 76-cell region in 7 s (estimated 1.2 to 1.6 times the measured).
const RATE: f64 = 1e10;
/// Work units of a general-route entry of the map (record mode integrates its polygon).
const MAP_ENTRY: f64 = 200.0;
/// Work units per cell and iteration (the vectors, the prior, the prefix sums).
const PER_CELL: f64 = 30.0;

/// The plan of one solve (see the module doc).
#[derive(Clone, Debug)]
pub struct Estimate {
    /// Raw rows of the chosen channels (the map's progress unit).
    pub raw_rows: usize,
    /// Raw pixels that may see the padded grid, per channel and lens type summed.
    pub pixels: f64,
    /// Raw rows and columns that may see it (summed over channels and types).
    pub lines: f64,
    /// Cells of a pixel's span, per axis.
    pub span: f64,
    pub exact: bool,
    pub grid: CellGrid,
    pub threads: usize,
    /// Lens types x raw rows that may see the grid (scratch rows of the factored blocks).
    pub scratch_rows: f64,
}

impl Estimate {
    /// The plan for the padded grid `grid` (padded by `pad` cells) at depth z.
    pub fn new(
        design: &Design,
        channels: &[usize],
        grid: &CellGrid,
        pad: usize,
        z: f64,
        exact: bool,
        threads: usize,
    ) -> Estimate {
        let span = pad as f64 + 2.0;
        let (mut pixels, mut lines, mut raw_rows, mut scratch_rows) = (0.0, 0.0, 0usize, 0.0);
        let [gx0, gx1, gy0, gy1] = grid.extent();
        for &i in channels {
            let ch = &design.channels[i];
            let (rows, cols) = crate::imaging::render::raw_shape(ch);
            raw_rows += rows;
            // The share of the raw's columns (rows) whose pixels can see the grid: the
            // grid's width plus a span against the channel's field at z.
            let (w, h) = ch.array_extent();
            let field = |a: f64| (z / ch.l * a).max(1e-300);
            let share = |g: f64, a: f64| ((g + pad as f64 * grid.step) / field(a)).min(1.0);
            let (fc, fr) = (
                (cols as f64 * share(gx1 - gx0, w)).ceil(),
                (rows as f64 * share(gy1 - gy0, h)).ceil(),
            );
            let nt = ch.f.len() as f64;
            pixels += fc * fr;
            lines += nt * (fc + fr);
            scratch_rows += nt * fr;
        }
        Estimate {
            raw_rows,
            pixels,
            lines,
            span,
            exact,
            grid: *grid,
            threads,
            scratch_rows,
        }
    }

    /// The bytes held at the peak (the module doc's list).
    pub fn bytes(&self) -> u128 {
        let cells = self.grid.cells() as f64;
        let chunked =
            2.0 * 8.0 * (self.grid.nx.div_ceil(64) * 64) as f64 * (self.grid.ny + 1) as f64;
        let solve = 7.0 * 8.0 * cells + chunked;
        let b = if self.exact {
            // Profiles (8 a value + 48 a row), their CSR copy (12 + 24), the block's
            // factors (12 + 8) and the solve's spans, transposes and pieces (~56 + 40).
            let per_line = self.lines * (self.span * (8.0 + 12.0 + 12.0 + 56.0) + 160.0);
            let window = self.pixels * (1.0 + 16.0);
            let scratch = self.scratch_rows * self.grid.nx as f64 * 8.0;
            per_line + window + scratch + solve
        } else {
            let recorders = cells * 9.0 * (self.threads + 1) as f64 + 8.0 * cells;
            recorders + solve
        };
        b.min(u128::MAX as f64 / 2.0) as u128
    }

    /// The expected seconds at most (`max_iter` iterations): the map (general route: each
    /// pixel's entries integrated) and the solve's products.
    pub fn seconds(&self, max_iter: usize) -> f64 {
        let cells = self.grid.cells() as f64;
        let (map, per_iter) = if self.exact {
            let scratch = self.scratch_rows * self.grid.nx as f64;
            (
                0.0,
                4.0 * (scratch + self.pixels * self.span) + PER_CELL * cells,
            )
        } else {
            let nnz = self.pixels * self.span * self.span;
            (MAP_ENTRY * nnz, 4.0 * nnz + PER_CELL * cells)
        };
        (map + per_iter * max_iter as f64) / (RATE * self.threads.max(1) as f64)
    }

    /// One line for the caller: the grid, the padding, the bytes and the expected time.
    pub fn describe(&self, inner: &CellGrid, pad: usize, max_iter: usize) -> String {
        format!(
            "reconstruct: {} x {} cells of {:.4} mm (padded by {pad} per side to {} x {}), \
             ~{:.0} raw pixels, {} route; plan {:.2} GB, expected at most ~{:.0} s \
             ({max_iter} iterations, {} threads)",
            inner.nx,
            inner.ny,
            inner.step,
            self.grid.nx,
            self.grid.ny,
            self.pixels,
            if self.exact {
                "exact (factored)"
            } else {
                "explicit-row"
            },
            self.bytes() as f64 / 1e9,
            self.seconds(max_iter),
            self.threads,
        )
    }

    /// Refuse a run expected to take more than `max_seconds`.
    pub fn check_time(&self, max_seconds: f64, max_iter: usize) -> Result<()> {
        self.check_time_with(max_seconds, max_iter, 0.0)
    }

    /// Refuse a run expected to take more than `max_seconds` with `extra` seconds of
    /// other work (the choice of λ's solves on a sub-grid, the main solve after it).
    pub fn check_time_with(&self, max_seconds: f64, max_iter: usize, extra: f64) -> Result<()> {
        let s = self.seconds(max_iter) + extra;
        if s > max_seconds {
            return Err(Error::TooMuchWork {
                what: format!(
                    "the reconstruction's expected time ({} x {} cells padded, ~{:.0} raw \
                     pixels, up to {max_iter} iterations; give a smaller region, a coarser \
                     step, or allow_slow=True to run it anyway)",
                    self.grid.nx, self.grid.ny, self.pixels
                ),
                amount: s.ceil() as u128,
                limit: max_seconds as u128,
                unit: "s",
            });
        }
        Ok(())
    }
}
