//! Validation and entry points: [`samples_2d`] at one depth, [`coverage`] over many in
//! parallel.

use rayon::prelude::*;

use super::rows::{depth_rows, Ctx, RowResult, Work};
use super::tables::{tables_bytes, Tables};
use super::*;
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_vec};
use crate::infra::parallel::{self, chunk_items, for_chunks, threads};
use crate::model::design::Design;
use crate::model::optics::check_design_depths;
use crate::sampling::samples::check_tol;

// ---- validation ------------------------------------------------------------------------

/// Validate the merge tolerance of the 2-D distinct samples: [`check_tol`] (finite,
/// ≥ 0), then > 0 (the relation is strict: with 0 nothing merges, not even coincident
/// samples) and at most [`MAX_TOL_2D`].
pub fn check_tol_2d(tol: f64) -> Result<f64> {
    let tol = check_tol(tol)?;
    if tol > 0.0 && tol <= MAX_TOL_2D {
        Ok(tol)
    } else {
        Err(Error::param(
            "tol",
            tol,
            format!(
                "a number in (0, {MAX_TOL_2D}] (a multiple of delta(z); two samples merge when \
                 both coordinates differ by less than tol * delta(z))"
            ),
        ))
    }
}

/// Validate the window (width of the 2-D central field in lens pitches of channel 1).
pub fn check_window(window: f64) -> Result<f64> {
    if window.is_finite() && window > 0.0 {
        Ok(window)
    } else {
        Err(Error::param(
            "window",
            window,
            "a finite number > 0 (the central field's width in lens pitches of channel 1)",
        ))
    }
}

/// The hash grid's cell indices |X| / (tol δ) must stay below [`MAX_CELL_INDEX`] for every
/// sample at every depth, and tol δ must be a normal number.
fn check_cells(design: &Design, z: &[f64], tol: f64) -> Result<()> {
    let mut worst = 0.0f64;
    for &zi in z {
        let zc = design.conjugate(zi);
        let delta = design.resolution_step(zi);
        let eps = tol * delta;
        if !(eps.is_normal() && eps > 0.0) {
            return Err(Error::param(
                "tol",
                tol,
                format!("a tolerance whose tol * delta(z) is a normal number (delta({zi}) = {delta} mm)"),
            ));
        }
        for ch in &design.channels {
            let cmax = {
                let a = ch.lens_center(0, 0);
                let b = ch.lens_center(ch.kx - 1, ch.ky - 1);
                let c = ch.lens_center(ch.kx - 1, ch.ky.min(2) - 1);
                let d = ch.lens_center(0, ch.ky.min(2) - 1);
                [a, b, c, d]
                    .iter()
                    .map(|p| p[0].abs().max(p[1].abs()))
                    .fold(0.0, f64::max)
            };
            let (g, s) = (zi / ch.l, (ch.l - zc) / zc);
            let extent = g * (cmax + design.aperture / 2.0 * s.abs());
            worst = worst.max(extent / eps);
        }
    }
    if worst * (1.0 + 1e-6) > MAX_CELL_INDEX {
        let need = tol * worst / MAX_CELL_INDEX * 1.01;
        return Err(Error::param(
            "tol",
            tol,
            format!(
                "at least {} for this design at these depths (its samples reach {} tol*delta(z) \
                 from the axis; at most 2^42 hash-grid cells are allowed)",
                crate::infra::error::short_number(need),
                crate::infra::error::short_number(worst)
            ),
        ));
    }
    Ok(())
}

/// Pixels of every channel.
fn all_pixels(design: &Design) -> u128 {
    design.channels.iter().map(|c| c.pixel_count()).sum()
}

/// Validate a coverage (or samples_2d) call before any work: threads, tolerance, window,
/// depths, the hash grid's range, the work limit and the memory of the first pass of
/// every depth on `threads` workers. Returns (tol, window).
fn check_coverage(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    n_threads: Option<usize>,
    what: &str,
) -> Result<(f64, f64)> {
    parallel::check_threads(n_threads)?;
    let tol = check_tol_2d(tol)?;
    let window = check_window(window)?;
    check_design_depths(design.f_main, z)?;
    check_cells(design, z, tol)?;
    let work = all_pixels(design).saturating_mul(z.len() as u128);
    if work > MAX_COVERAGE_WORK {
        return Err(Error::TooMuchWork {
            what: format!(
                "{what} over {} pixels of {} channels at {} depths",
                all_pixels(design),
                design.channels.len(),
                z.len()
            ),
            amount: work,
            limit: MAX_COVERAGE_WORK,
            unit: "pixel-depths",
        });
    }
    Ok((tol, window))
}

/// Bytes of the tables of every channel.
fn all_tables_bytes(design: &Design) -> u128 {
    design.channels.iter().map(tables_bytes).sum()
}

pub(super) fn context<'a>(design: &'a Design, tol: f64, window: f64) -> Result<Ctx<'a>> {
    let tables = design
        .channels
        .iter()
        .map(|ch| Tables::new(design, ch))
        .collect::<Result<Vec<_>>>()?;
    Ok(Ctx {
        design,
        tables,
        tol,
        window,
        separable: true,
        union_is_channel: true,
        trial: true,
    })
}

// ---- entry points ----------------------------------------------------------------------

/// The distinct samples of one depth: per row (channels, then the union) the
/// representatives inside the central field sorted by X then Y ([X, Y] in mm), their
/// number and the covering radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples2d {
    pub samples: Vec<Vec<[f64; 2]>>,
    pub distinct: Vec<u64>,
    /// ρ in δ(z) units and in mm (+∞ when the field holds no sample).
    pub covering_radius: Vec<f64>,
    pub covering_radius_mm: Vec<f64>,
}

/// Distinct samples and covering radius at one depth (validated first; on the calling
/// thread, interruptible between passes).
pub fn samples_2d(design: &Design, z: f64, tol: f64, window: f64) -> Result<Samples2d> {
    let (tol, window) = check_coverage(design, &[z], tol, window, Some(1), "samples_2d")?;
    let ctx = context(design, tol, window)?;
    let geom = ctx.geom(z);
    let first = ctx.pass_samples(&geom, geom.first);
    memory::check(
        "samples_2d",
        all_tables_bytes(design) + first.saturating_mul(SAMPLE_BYTES),
    )?;
    let mut w = Work::default();
    let mut keep = vec![Vec::new(); design.channels.len() + 1];
    let rows = depth_rows(&ctx, z, &mut w, Some(&mut keep), true)?;
    Ok(Samples2d {
        samples: keep,
        distinct: rows.iter().map(|r| r.distinct).collect(),
        covering_radius: rows.iter().map(|r| r.rho).collect(),
        covering_radius_mm: rows.iter().map(|r| r.rho_mm).collect(),
    })
}

/// Distinct counts and covering radii at m depths: row-major (n_channels + 1, m) arrays,
/// rows the channels then the union. Owned (what [`coverage`] returns) or the caller's
/// buffers ([`CoverageOut`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage<U = Vec<u64>, F = Vec<f64>> {
    pub distinct: U,
    pub covering_radius: F,
    pub covering_radius_mm: F,
}

/// Output buffers of [`coverage_into`]. Any initial content: every element is written
/// once.
pub type CoverageOut<'a> = Coverage<&'a mut [u64], &'a mut [f64]>;

/// Bytes a coverage call at the depths `z` holds at its peak when every depth is settled by
/// its first pass: the outputs (24 bytes per row and depth), one chunk of per-depth
/// results, every channel's tables, and per worker the samples of the largest first pass
/// ([`SAMPLE_BYTES`] each). A depth that needs a wider pass checks that pass's memory
/// before it starts.
fn coverage_bytes(ctx: &Ctx<'_>, z: &[f64], workers: usize) -> u128 {
    let rows = ctx.tables.len() as u128 + 1;
    let m = z.len() as u128;
    let outputs = 24 * rows * m;
    let chunk = (24 * rows + 24) * m.min(1 << 20);
    let first = z
        .iter()
        .map(|&zi| {
            let g = ctx.geom(zi);
            ctx.pass_samples(&g, g.first)
        })
        .max()
        .unwrap_or(0);
    let per_worker = first.saturating_mul(SAMPLE_BYTES);
    outputs + chunk + all_tables_bytes(ctx.design) + (workers as u128).saturating_mul(per_worker)
}

/// Depths per parallel task of [`coverage_into`].
const CHUNK: usize = 1;

/// [`coverage`] written into caller-provided buffers. Validates everything first
/// (see [`check_coverage`] and [`coverage_bytes`]).
pub fn coverage_into(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    out: CoverageOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    let (tol, window) = check_coverage(design, z, tol, window, n_threads, "coverage")?;
    let rows = design.channels.len() + 1;
    let m = z.len();
    let lens = [
        out.distinct.len(),
        out.covering_radius.len(),
        out.covering_radius_mm.len(),
    ];
    if lens.iter().any(|&l| l != rows * m) {
        return Err(Error::param(
            "output length",
            format!("{lens:?}"),
            format!("{} ({rows} rows x m = {m} depths)", rows * m),
        ));
    }
    memory::check("coverage (channel tables)", all_tables_bytes(design))?;
    let ctx = context(design, tol, window)?;
    let workers = threads(n_threads).min(m.max(1));
    memory::check("coverage", coverage_bytes(&ctx, z, workers))?;
    // Elementary steps per depth: about the samples of a first pass.
    let cost = z
        .iter()
        .take(16)
        .map(|&zi| {
            let g = ctx.geom(zi);
            ctx.pass_samples(&g, g.first)
        })
        .max()
        .unwrap_or(1)
        .saturating_mul(64);
    let step = chunk_items(n_threads, cost).min(1 << 20);
    let mut res = try_vec(
        "coverage (per-depth results)",
        step.min(m),
        Vec::<RowResult>::new(),
    )?;
    for_chunks(n_threads, m, step, |r| {
        let res = &mut res[..r.len()];
        res.par_chunks_mut(CHUNK)
            .zip(z[r.clone()].par_chunks(CHUNK))
            .try_for_each_init(Work::default, |w, (rs, zs)| -> Result<()> {
                for (ri, &zi) in rs.iter_mut().zip(zs) {
                    *ri = depth_rows(&ctx, zi, w, None, false)?;
                }
                Ok(())
            })?;
        for (k, d) in r.zip(res.iter()) {
            for (row, v) in d.iter().enumerate() {
                out.distinct[row * m + k] = v.distinct;
                out.covering_radius[row * m + k] = v.rho;
                out.covering_radius_mm[row * m + k] = v.rho_mm;
            }
        }
        Ok(())
    })
}

/// Distinct 2-D samples inside the central field and the covering radius of each channel
/// and of the union at every depth (validated first), parallel over depths.
pub fn coverage(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    n_threads: Option<usize>,
) -> Result<Coverage> {
    let n = (design.channels.len() + 1) * z.len();
    let what = "coverage";
    let mut distinct = try_vec(what, n, 0)?;
    let mut radius = try_vec(what, n, 0.0)?;
    let mut radius_mm = try_vec(what, n, 0.0)?;
    let out = Coverage {
        distinct: &mut distinct[..],
        covering_radius: &mut radius[..],
        covering_radius_mm: &mut radius_mm[..],
    };
    coverage_into(design, z, tol, window, out, n_threads)?;
    Ok(Coverage {
        distinct,
        covering_radius: radius,
        covering_radius_mm: radius_mm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera::Camera;
    use crate::sampling::samples2d::components::before;
    use crate::sampling::samples2d::test_designs::*;

    #[test]
    fn union_is_at_least_each_channel_and_threads_agree() {
        let d = Camera::paper().design();
        let z: Vec<f64> = (0..12)
            .map(|i| 150.0 * (8000.0f64 / 150.0).powf(i as f64 / 11.0))
            .collect();
        let a = coverage(&d, &z, 1e-6, 16.0, Some(1)).unwrap();
        let b = coverage(&d, &z, 1e-6, 16.0, Some(2)).unwrap();
        assert_eq!(a, b);
        let m = z.len();
        for k in 0..m {
            let u = a.distinct[2 * m + k];
            assert!(u >= a.distinct[k] && u >= a.distinct[m + k]);
            assert!(u <= a.distinct[k] + a.distinct[m + k]);
            assert!(
                a.covering_radius[2 * m + k]
                    <= a.covering_radius[k].min(a.covering_radius[m + k]) + 1e-12
            );
        }
        // Channel 1 on its out-of-focus plane: one sample per lens.
        let z1 = crate::model::lens::depth_of_conjugate(d.f_main, d.channels[0].l);
        let s = samples_2d(&d, z1, 1e-6, 16.0).unwrap();
        assert_eq!(s.distinct[0], 16 * 16);
        assert_eq!(s.samples[0].len(), 256);
        // The lens pitch on the plane is Q delta: cell centres are Q / sqrt 2 away.
        assert!(
            (s.covering_radius[0] - 15.0 / 2f64.sqrt()).abs() < 1e-9,
            "{}",
            s.covering_radius[0]
        );
        assert!(s
            .samples
            .iter()
            .all(|v| v.windows(2).all(|p| before(p[0], p[1]))));
    }

    #[test]
    fn bad_input_is_refused() {
        let d = designs().remove(0);
        let z = [300.0];
        for tol in [0.0, -1.0, f64::NAN, 1.5, f64::INFINITY] {
            let e = coverage(&d, &z, tol, 16.0, None).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("tol"), "{tol}");
        }
        let e = coverage(&d, &z, 1e-15, 16.0, None).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("tol"));
        for window in [0.0, -2.0, f64::NAN, f64::INFINITY] {
            let e = samples_2d(&d, 300.0, 1e-6, window).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("window"));
        }
        for zi in [50.0, 10.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                coverage(&d, &[300.0, zi], 1e-6, 16.0, None),
                Err(Error::InvalidDepth { index: 1, .. })
            ));
            assert!(matches!(
                chief_samples(&d, 1, zi, None),
                Err(Error::InvalidDepth { .. })
            ));
        }
        for ch in [0, 3, -1] {
            let e = chief_samples(&d, ch, 300.0, None).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("channel"));
        }
        assert!(chief_samples(&d, 1, 300.0, Some(0)).is_err());
        let many: Vec<f64> = vec![300.0; 1 << 24];
        assert!(matches!(
            coverage(&Camera::paper().design(), &many, 1e-6, 16.0, None),
            Err(Error::TooMuchWork { .. })
        ));
        // Empty depth arrays are fine.
        let c = coverage(&d, &[], 1e-6, 16.0, None).unwrap();
        assert!(c.distinct.is_empty());
    }
}
