//! Sample positions of the full 2-D sensor of one channel on one plane, separable into
//! the per-axis samples of its two lines.

use rayon::prelude::*;

use super::footprints::rows_per_task;
use super::*;
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_with_capacity};
use crate::infra::parallel::{check_threads, chunk_items, for_chunks, with_threads};
use crate::model::design::{Aperture, Design};
use crate::model::lens::conjugate;
use crate::model::optics::check_design_depths;
use crate::sampling::line::Axis;
use crate::sampling::line::Line;

/// Per-axis sample positions of one line on the plane at depth z: object-space position
/// of every pixel along the axis (NaN where it yields no sample).
pub(crate) fn axis_samples(line: &Line, sample: Sample, z: f64) -> Result<Vec<f64>> {
    let zc = conjugate(line.f_main, z);
    let sigma = line.slope(zc);
    let n = line.pixel_count() as usize;
    let what = "sample_grid (per-axis samples)";
    let mut polygons = Vec::new();
    if sample == Sample::Centroid {
        let rays: Vec<Rays> = (0..line.types()).map(|t| Rays::new(line, t)).collect();
        polygons = try_with_capacity(what, n)?;
        polygons.extend((0..n as u32).map(|i| {
            let px = line.pixel(i);
            rays[line.lens_type(px.j)].polygon(line.lens_center(px.j), px.theta)
        }));
        drop_residue(&mut polygons);
    }
    let mut out = try_with_capacity(what, n)?;
    for i in 0..n as u32 {
        let px = line.pixel(i);
        let x = match sample {
            Sample::Chief if px.lit => {
                let w = line.chief_w(px.theta);
                let p = line.chief_projection(line.lens_center(px.j), w, zc);
                line.object_position(p, z)
            }
            Sample::Chief => f64::NAN,
            Sample::Centroid => {
                let [u, w] = polygons[i as usize].centroid();
                (u + sigma * w) * (-z / line.v_ref)
            }
        };
        out.push(x);
    }
    Ok(out)
}

/// A channel's sensor as [`grid_into`] separates it: its lines along x and y, and the
/// radius D/2 of a circular aperture (None for a square one, whose pixels are lit exactly
/// when both lines' are).
struct GridAxes<'a> {
    x: &'a Line,
    y: &'a Line,
    disc: Option<f64>,
}

/// The 2-D grid of a pair of lines: X from the column's line, Y from the row's, NaN where
/// either axis yields no sample; with `disc` = Some(D/2) (a circular aperture, chief
/// samples) also NaN where the chief ray's (w_x, w_y) is not strictly inside the disc.
fn grid_into(
    axes: &GridAxes<'_>,
    z: f64,
    sample: Sample,
    gx: &mut [f64],
    gy: &mut [f64],
    n_threads: Option<usize>,
) -> Result<()> {
    let &GridAxes { x: lx, y: ly, disc } = axes;
    let (rows, cols) = (ly.pixel_count() as usize, lx.pixel_count() as usize);
    let (xs, ys) = with_threads(n_threads, || -> Result<_> {
        Ok((axis_samples(lx, sample, z)?, axis_samples(ly, sample, z)?))
    })??;
    let chief_w = |line: &Line, n: usize| -> Result<Vec<f64>> {
        let mut w = try_with_capacity("sample_grid (chief heights)", n)?;
        if disc.is_some() {
            w.extend((0..n as u32).map(|i| line.chief_w(line.pixel(i).theta)));
        }
        Ok(w)
    };
    let (wx, wy) = (chief_w(lx, cols)?, chief_w(ly, rows)?);
    let per = rows_per_task(cols);
    let step = chunk_items(n_threads, 2 * cols as u128);
    for_chunks(n_threads, rows, step, |r| {
        let span = r.start * cols..r.end * cols;
        let first = r.start;
        gx[span.clone()]
            .par_chunks_mut(per * cols)
            .zip(gy[span].par_chunks_mut(per * cols))
            .zip(ys[r].par_chunks(per))
            .enumerate()
            .for_each(|(task, ((gx, gy), yr))| {
                for (r, &y) in yr.iter().enumerate() {
                    let rx = &mut gx[r * cols..(r + 1) * cols];
                    let ry = &mut gy[r * cols..(r + 1) * cols];
                    if y.is_nan() {
                        rx.fill(f64::NAN);
                        ry.fill(f64::NAN);
                    } else {
                        rx.copy_from_slice(&xs);
                        for (oy, &x) in ry.iter_mut().zip(&xs) {
                            // y + 0·x is y where x is a sample, NaN where it is not.
                            *oy = y + 0.0 * x;
                        }
                        if let Some(rad) = disc {
                            let w2 = wy[first + task * per + r];
                            for ((ox, oy), &w1) in rx.iter_mut().zip(ry.iter_mut()).zip(&wx) {
                                if w1 * w1 + w2 * w2 >= rad * rad {
                                    *ox = f64::NAN;
                                    *oy = f64::NAN;
                                }
                            }
                        }
                    }
                }
            });
        Ok(())
    })
}

/// Validate a design's sample_grid call before anything is allocated: threads, the depth,
/// a rect channel, the aperture (centroid samples need the square aperture: only then is a
/// pixel's 4-D region the product of its two 1-D polygons) and the memory. Returns the
/// channel's lines along x and y.
pub fn check_design_sample_grid(
    design: &Design,
    channel: i64,
    z: f64,
    sample: Sample,
    n_threads: Option<usize>,
) -> Result<(Line, Line)> {
    check_threads(n_threads)?;
    check_design_depths(design.f_main, &[z])?;
    let lx = Line::of_channel(design, channel, Axis::X)?;
    let ly = Line::of_channel(design, channel, Axis::Y)?;
    if sample == Sample::Centroid && design.shape == Aperture::Circle {
        return Err(Error::param(
            "aperture",
            "\"circle\"",
            "\"square\" for sample=\"centroid\" (behind a circular aperture a pixel's \
             region in 4-D ray space is not the product of its x and y polygons; use \
             sample=\"chief\")",
        ));
    }
    let (rows, cols) = (ly.pixel_count(), lx.pixel_count());
    let bytes = (2 * 8 * rows)
        .saturating_mul(cols)
        .saturating_add(16 * (rows + cols));
    memory::check("sample_grid (two outputs)", bytes)?;
    Ok((lx, ly))
}

/// The sample positions (X, Y) of every pixel of channel `channel` (from 1) of a design
/// (rect grids) on the plane at depth z, written into caller-provided buffers: rows the
/// channel's pixel rows along y, columns along x ((K_y Q, K_x Q) or (M_y, M_x)), NaN where
/// a pixel yields no sample. Separable: X depends on the column only, Y on the row only,
/// and under the square aperture a pixel yields a sample iff it does along both axes (the
/// 4-D integration region is the product of the two 2-D polygons, so its centroid is the
/// pair of centroids). In chunks of rows with an interrupt checkpoint between chunks.
pub fn design_sample_grid_into(
    design: &Design,
    channel: i64,
    z: f64,
    sample: Sample,
    gx: &mut [f64],
    gy: &mut [f64],
    n_threads: Option<usize>,
) -> Result<()> {
    let (lx, ly) = check_design_sample_grid(design, channel, z, sample, n_threads)?;
    let n = (ly.pixel_count() * lx.pixel_count()) as usize;
    if gx.len() != n || gy.len() != n {
        return Err(Error::param(
            "output length",
            format!("{:?}", (gx.len(), gy.len())),
            format!("{n}"),
        ));
    }
    let disc = (design.shape == Aperture::Circle).then_some(design.aperture / 2.0);
    let axes = GridAxes {
        x: &lx,
        y: &ly,
        disc,
    };
    grid_into(&axes, z, sample, gx, gy, n_threads)
}
