//! The whole estimate from a raw (docs/depth.md): the reference depth, the grid's pitch
//! and region (defaults from the design), the whites, then the sweep.

use std::sync::atomic::AtomicUsize;

use super::{sweep, sweep_bytes, whites, Images, Plan, Sweep};
use crate::imaging::recorder::CellGrid;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::threads;
use crate::inverse::system::seen_region;
use crate::model::design::Design;

/// The default grid pitch, in δ(z) (docs/model.md §9) at the reference depth.
pub const DEFAULT_STEP: f64 = 3.0;

/// Bytes per cell the caller's copies of the outputs take (five f64 and an i64).
const CALLER_BYTES_PER_CELL: u128 = 48;

/// What to estimate: the chosen channels (indices into the design), the increasing
/// candidate depths, the region (X0, X1, Y0, Y1; None: what every chosen channel sees
/// through half its aperture at the reference depth, else what the first sees so), the
/// grid's pitch (None: [`DEFAULT_STEP`] δ at the reference depth), the window's radius,
/// the least share of a sensor-layout pixel's white that must come through its own lens,
/// whether to keep the whole cost volume, and whether to pool the window again along the
/// surface's local slope (docs/depth.md, step 7).
pub struct Request {
    pub channels: Vec<usize>,
    pub candidates: Vec<f64>,
    pub region: Option<[f64; 4]>,
    pub step: Option<f64>,
    pub radius: usize,
    pub min_own_share: f64,
    pub keep_volume: bool,
    pub tilt: bool,
}

/// The sweep's result on its grid.
pub struct Estimate {
    pub grid: CellGrid,
    pub sweep: Sweep,
}

/// The reference depth: the median candidate in 1/z (the mean of the two middle ones in
/// 1/z for an even count).
fn reference_depth(candidates: &[f64]) -> f64 {
    let n = candidates.len();
    let inv = |k: usize| 1.0 / candidates[k];
    let median = if n % 2 == 1 {
        inv(n / 2)
    } else {
        (inv(n / 2 - 1) + inv(n / 2)) / 2.0
    };
    1.0 / median
}

/// The grid: over the region asked for or the default one, at the pitch asked for or the
/// default one.
fn grid_of(design: &Design, req: &Request) -> Result<CellGrid> {
    let z_ref = reference_depth(&req.candidates);
    let step = match req.step {
        Some(s) => s,
        None => DEFAULT_STEP * design.resolution_step(z_ref),
    };
    let region = match req.region {
        Some(r) => r,
        // Far from its focus a channel may see no point through half its aperture: then
        // the first chosen channel's region.
        None => seen_region(design, &req.channels, z_ref)
            .or_else(|_| seen_region(design, &req.channels[..1], z_ref))?,
    };
    CellGrid::covering(region, step)
}

/// The depth of the scene from `raws` (one per chosen channel, row-major, the §10 layout)
/// as `req` asks: the grid, the whites (kept per design), the sweep. `done` counts
/// candidates. Before any work: the request is checked and the memory of the whole call
/// planned (the whites when not kept, the sweep, the caller's copies of the outputs).
pub fn estimate(
    design: &Design,
    raws: &[&[f64]],
    req: &Request,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Estimate> {
    crate::infra::parallel::check_threads(n_threads)?;
    super::check_candidates(design, &req.candidates)?;
    super::check_radius(req.radius)?;
    if req.channels.is_empty() || req.channels.iter().any(|&i| i >= design.channels.len()) {
        return Err(Error::param(
            "channels",
            format!(
                "{:?}",
                req.channels.iter().map(|i| i + 1).collect::<Vec<_>>()
            ),
            format!("channel numbers in 1..={}", design.channels.len()),
        ));
    }
    if !(0.0..=1.0).contains(&req.min_own_share) {
        return Err(Error::param(
            "min_own_share",
            req.min_own_share,
            "a share in [0, 1]",
        ));
    }
    let grid = grid_of(design, req)?;
    let plan = Plan {
        grid,
        candidates: &req.candidates,
        radius: req.radius,
        keep_volume: req.keep_volume,
        tilt: req.tilt,
    };
    let workers = threads(n_threads);
    let caller = grid.cells() as u128 * CALLER_BYTES_PER_CELL
        + if req.keep_volume {
            grid.cells() as u128 * (req.channels.len() * req.candidates.len()) as u128 * 8
        } else {
            0
        };
    let bytes =
        whites::whites_bytes(design) + sweep_bytes(design, &plan, &req.channels, workers, None);
    memory::check("the depth estimate", bytes + caller)?;
    let all = whites::sweep_whites(design, req.min_own_share, n_threads)?;
    let chosen: Vec<&[f64]> = req.channels.iter().map(|&i| all[i].as_slice()).collect();
    let images = Images {
        channels: &req.channels,
        raws,
        whites: &chosen,
    };
    let sweep = sweep(design, &images, &plan, n_threads, done)?;
    Ok(Estimate { grid, sweep })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_depth_is_the_median_in_inverse_depth() {
        // Odd: the middle candidate; even: 1 / mean of the two middle ones' 1/z
        // (1 / ((1/500 + 1/1000) / 2) = 666.67 mm).
        assert_eq!(reference_depth(&[250.0, 500.0, 4000.0]), 500.0);
        let even = reference_depth(&[250.0, 500.0, 1000.0, 4000.0]);
        assert!((even - 2000.0 / 3.0).abs() < 1e-9);
    }
}
