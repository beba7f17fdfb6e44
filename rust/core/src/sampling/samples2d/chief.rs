//! Chief samples of every pixel of one channel's layout (docs/model.md §9, "Chief samples
//! in 2-D"): the arrays of [`chief_samples_into`], filled row by row in parallel.

use rayon::prelude::*;

use super::tables::{tables_bytes, PixelTables, RowOut, Tables};
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_vec};
use crate::infra::parallel::{self, chunk_items, for_chunks};
use crate::model::design::Design;
use crate::model::optics::check_design_depths;

// ---- chief samples of every pixel -----------------------------------------------------

/// Output buffers of [`chief_samples_into`], row-major over the channel's pixel grid
/// (rows b, columns a; see [`Design::pixel_grid`]): `x`, `y`, `lit`, `types` one value per
/// pixel, `lens` two (j, k). Any initial content: every element is written once.
pub struct ChiefSamplesOut<'a> {
    pub x: &'a mut [f64],
    pub y: &'a mut [f64],
    pub lit: &'a mut [bool],
    pub lens: &'a mut [i64],
    pub types: &'a mut [i64],
}

/// Chief samples of every pixel of one channel (allocated by [`chief_samples`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ChiefSamples {
    /// Pixel rows (M_y, or K_y Q) and columns (M_x, or K_x Q).
    pub rows: usize,
    pub cols: usize,
    /// Sample X, Y [mm] on the plane (NaN where the pixel is unlit).
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub lit: Vec<bool>,
    /// (j, k) of each pixel's lens, interleaved.
    pub lens: Vec<i64>,
    /// Lens type t of each pixel's lens.
    pub types: Vec<i64>,
}

/// Bytes of the chief-sample outputs per pixel: X, Y, lit, (j, k), type.
pub const CHIEF_BYTES_PER_PIXEL: u128 = 8 + 8 + 1 + 16 + 8;

/// Validate a chief-samples call (threads, channel, depth) and check the memory of its
/// outputs and tables; returns the channel's index (from 0) and its (rows, columns).
pub fn check_chief_samples(
    design: &Design,
    channel: i64,
    z: f64,
    n_threads: Option<usize>,
) -> Result<(usize, usize, usize)> {
    let (index, _, rows, cols) = check_chief_rows(design, channel, z, n_threads, None)?;
    Ok((index, rows, cols))
}

/// [`check_chief_samples`] for the pixel rows `[start, stop)` of the window (every row for
/// `None`): validates the window too and checks the memory of the window's outputs only.
/// Returns the channel's index (from 0), the first row, and the (rows, columns) computed.
pub fn check_chief_rows(
    design: &Design,
    channel: i64,
    z: f64,
    n_threads: Option<usize>,
    window: Option<(i64, i64)>,
) -> Result<(usize, usize, usize, usize)> {
    parallel::check_threads(n_threads)?;
    let ch = design.channel(channel)?;
    check_design_depths(design.f_main, &[z])?;
    let (cols, rows) = design.pixel_grid(ch);
    let (first, rows) = match window {
        None => (0, rows as usize),
        Some(w) => {
            let (start, stop) = check_row_window(rows as usize, w)?;
            (start, stop - start)
        }
    };
    let n = rows as u128 * cols as u128;
    memory::check(
        "chief_samples",
        n.saturating_mul(CHIEF_BYTES_PER_PIXEL) + tables_bytes(ch),
    )?;
    Ok((channel as usize - 1, first, rows, cols as usize))
}

/// Every pixel's chief sample on the plane at depth z, its lens, type and lit flag,
/// written into `out` (rows in parallel, interruptible between chunks of rows).
pub fn chief_samples_into(
    design: &Design,
    channel: i64,
    z: f64,
    out: ChiefSamplesOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    chief_samples_rows_into(design, channel, z, None, out, n_threads)
}

/// Validate a window of pixel rows `[start, stop)` of a grid of `rows` rows: it must lie
/// in the grid and not be empty. Returns (start, stop).
pub fn check_row_window(rows: usize, window: (i64, i64)) -> Result<(usize, usize)> {
    let rows = rows as i64;
    let (start, stop) = window;
    if !(0 <= start && start < stop && stop <= rows) {
        return Err(Error::param(
            "rows",
            format!("({start}, {stop})"),
            format!("(start, stop) with 0 <= start < stop <= {rows} (the channel's pixel rows)"),
        ));
    }
    Ok((start as usize, stop as usize))
}

/// [`chief_samples_into`] for the pixel rows `[start, stop)` of the channel only (all
/// rows for `None`): the outputs hold (stop − start) × columns pixels, row `start` first.
/// Every value is that of the whole grid's call, bit for bit (the rows are independent).
pub fn chief_samples_rows_into(
    design: &Design,
    channel: i64,
    z: f64,
    window: Option<(i64, i64)>,
    out: ChiefSamplesOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    let (index, first, rows, cols) = check_chief_rows(design, channel, z, n_threads, window)?;
    let n = rows * cols;
    let lens = [
        out.x.len(),
        out.y.len(),
        out.lit.len(),
        out.lens.len() / 2,
        out.types.len(),
    ];
    if lens.iter().any(|&l| l != n) || out.lens.len() != 2 * n {
        return Err(Error::param(
            "output length",
            format!("{lens:?}"),
            format!("{n} pixels ({rows} rows x {cols} columns)"),
        ));
    }
    if n == 0 {
        return Ok(());
    }
    let ch = &design.channels[index];
    let t = Tables::new(design, ch)?;
    let zc = design.conjugate(z);
    let (g, s) = (z / ch.l, (ch.l - zc) / zc);
    let mut colx = Vec::new();
    if let PixelTables::Sensor(sen) = &t.px {
        t.columns_x(sen, g, s, &mut colx)?;
    }
    let colx = &colx[..];
    let step = chunk_items(n_threads, 12 * cols as u128).max(1);
    let ChiefSamplesOut {
        x,
        y,
        lit,
        lens,
        types,
    } = out;
    for_chunks(n_threads, rows, step, |r| {
        let (lo, hi) = (r.start * cols, r.end * cols);
        (
            x[lo..hi].par_chunks_mut(cols),
            y[lo..hi].par_chunks_mut(cols),
            lit[lo..hi].par_chunks_mut(cols),
            lens[2 * lo..2 * hi].par_chunks_mut(2 * cols),
            types[lo..hi].par_chunks_mut(cols),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(i, (x, y, lit, lens, types))| {
                let out = RowOut {
                    x,
                    y,
                    lit,
                    lens,
                    types,
                };
                t.fill_row(first + r.start + i, g, s, colx, out);
            });
        Ok(())
    })
}

/// [`chief_samples_into`] with its own (fallibly allocated) outputs.
pub fn chief_samples(
    design: &Design,
    channel: i64,
    z: f64,
    n_threads: Option<usize>,
) -> Result<ChiefSamples> {
    let (_, rows, cols) = check_chief_samples(design, channel, z, n_threads)?;
    let n = rows * cols;
    let what = "chief_samples";
    let mut r = ChiefSamples {
        rows,
        cols,
        x: try_vec(what, n, 0.0)?,
        y: try_vec(what, n, 0.0)?,
        lit: try_vec(what, n, false)?,
        lens: try_vec(what, 2 * n, 0)?,
        types: try_vec(what, n, 0)?,
    };
    let out = ChiefSamplesOut {
        x: &mut r.x,
        y: &mut r.y,
        lit: &mut r.lit,
        lens: &mut r.lens,
        types: &mut r.types,
    };
    chief_samples_into(design, channel, z, out, n_threads)?;
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::samples2d::test_designs::*;

    #[test]
    fn chief_samples_are_design_pixels_bit_for_bit() {
        // Both paths of the nearest-lens search run: columns settled once (`sel`) and
        // columns within rounding of a tie (`amb`, every pixel compares both candidates).
        let (mut settled, mut ambiguous) = (0, 0);
        for d in designs() {
            for ch in &d.channels {
                if let PixelTables::Sensor(sen) = &Tables::new(&d, ch).unwrap().px {
                    ambiguous += sen.cols.iter().filter(|c| c.amb).count();
                    settled += sen.cols.iter().filter(|c| !c.amb).count();
                }
            }
        }
        assert!(settled > 0 && ambiguous > 0, "{settled} {ambiguous}");
        for d in designs() {
            for (i, ch) in d.channels.iter().enumerate() {
                for z in [d.f_main * 1.3, 300.0, 2000.0] {
                    let r = chief_samples(&d, i as i64 + 1, z, Some(2)).unwrap();
                    let (cols, rows) = d.pixel_grid(ch);
                    assert_eq!((r.rows, r.cols), (rows as usize, cols as usize));
                    let zc = d.conjugate(z);
                    let mut lit = 0;
                    for b in 0..rows {
                        for a in 0..cols {
                            let px = d.pixel(ch, a, b);
                            let o = b as usize * cols as usize + a as usize;
                            assert_eq!(r.lit[o], px.lit, "{a} {b}");
                            assert_eq!(
                                (r.lens[2 * o], r.lens[2 * o + 1]),
                                (px.j as i64, px.k as i64)
                            );
                            assert_eq!(r.types[o], px.t as i64);
                            if px.lit {
                                lit += 1;
                                let c = ch.lens_center(px.j, px.k);
                                let xy = Design::chief_sample(ch, c, ch.chief_w(px.theta), z, zc);
                                assert_eq!(r.x[o].to_bits(), xy[0].to_bits());
                                assert_eq!(r.y[o].to_bits(), xy[1].to_bits());
                            } else {
                                assert!(r.x[o].is_nan() && r.y[o].is_nan());
                            }
                        }
                    }
                    assert!(lit > 0);
                }
            }
        }
    }
}
