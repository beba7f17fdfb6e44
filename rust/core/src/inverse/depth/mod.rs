//! Depth from the raw (docs/model.md §11, docs/depth.md): a plane sweep over candidate
//! depths that compares the lenses' micro-images.
//!
//! Each pixel's value divided by its white (its value under a white albedo: vignetting and
//! the channel's share removed) is a sample of the albedo near the point where the pixel's
//! mean ray meets the surface. Under a square aperture on a rect lattice that is the
//! centroid ray of its 4-D ray set (the product of its x and y polygons, §4: the
//! `centroid` sample of `rayspace`); elsewhere (hexagonal lattices, circular apertures)
//! the chief ray, X(z) = B(z) w − (z/L) c, B(z) = 1 − z/F + z/L (c: the lens centre, w:
//! the chief ray's main-lens height). Either is affine in z, X(z) = p + z q, and within
//! one lens X depends on the pixel's column alone and Y on its row alone.
//!
//! **One lens, one value per cell.** At a candidate z each lens's micro-image is
//! resampled at the centres of a grid of cells: per axis a tent t of half-width
//! H = max(h, s) in object space around each of the lens's column (row) positions (h the
//! cell pitch, s the lens's mean column spacing at z). Where the lens's pixels are sparser
//! than the cells (s ≥ h) that is linear interpolation between its pixels; where they are
//! denser, the average of those within about a cell. The lens's value in the cell is the
//! mean m = Σ t ω v / Σ t ω over its own valid pixels (ω the pixel's white relative to a
//! fully lit pixel, its photon-noise weight) with weight Ω = (Σ t ω)² / Σ t² ω (the weight
//! of a pixel of m's variance), times the coverage c = min(1, Σ t) over its valid pixels:
//! beyond the lens's last pixel the tents are an extrapolation, and the weight falls to 0
//! with them (without c a cell that one edge pixel barely reaches would count in full,
//! and the cost would jump wherever a pixel's tent enters or leaves a cell as z varies).
//! Cells where c Ω < [`MIN_WHITE`] take nothing from the lens.
//!
//! **Cost.** At the true depth the lenses that see a cell agree (up to noise and
//! interpolation); at a wrong depth they saw different patches. Per channel and cell the
//! spread of the lenses' values is pooled over a (2r + 1)² window,
//!
//!   C(z) = Σ_window Σ_lens Ω (m − m̄)² / Σ_window (S0 − Σ Ω² / S0) / V(z),
//!
//! (S0 = Σ Ω per cell, m̄ the Ω-weighted mean; Ω = (Σ t ω)² / Σ t² ω, the weight of a
//! pixel of the value's variance): the denominator is the cells' degrees of freedom, so a
//! lone lens tells nothing, and V(z), the same spread of all the channel's lens values over
//! the grid at z, is the scale of a mismatch at that depth (resampled micro-images are
//! smoother where the pixels lie far apart). A channel's cost is missing where its window
//! holds less than [`MIN_WEIGHT`] degrees of freedom. Comparing lens with lens, never
//! pixel with pixel, keeps the pairs compared the same at every candidate: pooling single
//! pixels that happen to fall into one cell compared, at some candidates, mostly pixels
//! that see nearly the same ray, whose agreement says nothing of the depth, and the cost
//! curves dipped there.
//!
//! **Thinning.** Far from a channel's focus hundreds of its lenses see each cell. Where
//! more than [`M_CAP`] do on average (the summed areas of their footprints over the grid's
//! area), each lens is kept with probability M_CAP / M(z), by a fixed pseudo-random number
//! per lens, so the kept sets are nested as z varies.
//!
//! Each channel's estimate per cell is the candidate of least cost, refined by the vertex
//! of the symmetric V through it and its two neighbours ([`vertex`]), and its confidence
//! ([`confidence`]) the least of the contrast 1 − min / m', m' the least of the curve's
//! mean, of its least local minimum more than n/16 candidates away and of its least cost
//! beyond a ridge twice that cost's height ([`RIDGE`]) however near, and of its cost at the
//! mirror of the least cost's depth about the channel's out-of-focus plane, read after the
//! sweep ([`mirror`]) (a second dip of the same depth makes a cell ambiguous; a
//! textureless patch costs the same, its noise, at every depth), and of the resolution: how narrow the dip is in relative depth against
//! the least cost, measured over a fixed span of relative depth ([`RESOLUTION_SPAN`]; a
//! shallow dip is not trusted); 0 where the least cost is at an end of the candidates. Each cell takes the estimate of its most confident channel: the channels'
//! blurs differ, so their values of one patch are never compared, and a channel that sees
//! no texture at some depth has a shallow, sloping curve that would add rival minima to a
//! sum.
//!
//! The candidates are swept in parallel, each layer of costs folded in candidate order
//! into running minima, so the cost volume is never held whole (unless asked for).
//!
//! The parts: [`micro`] (the lenses' micro-images), [`layer`] (one candidate's costs),
//! [`fold`] (the running minima), [`mirror`] (the mirror rival), [`whites`] (the whites
//! under a white albedo) and [`estimate`] (the whole estimate from a raw: region, grid,
//! whites, sweep).

mod estimate;
mod fold;
mod layer;
mod micro;
mod mirror;
pub mod surface;
mod tilt;
mod whites;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use rayon::prelude::*;

use crate::imaging::recorder::CellGrid;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel::{checkpoint, for_chunks, threads};
use crate::model::design::Design;

pub use estimate::{estimate, Estimate, Request, DEFAULT_STEP};
pub use whites::{sweep_whites, whites_bytes, Whites};

use fold::Fold;
use layer::Layer;
use micro::Micro;

/// Least degrees of freedom (in fully lit lenses) a channel's window must hold for its cost
/// to count.
pub const MIN_WEIGHT: f64 = 2.0;
/// Pixels whose white is below this fraction of a fully lit pixel's are left out (their
/// values are mostly noise); a lens's value in a cell needs this much weight.
pub const MIN_WHITE: f64 = 0.05;
/// Lenses of a channel that see a cell, on average, beyond which the sweep thins them.
pub const M_CAP: f64 = 48.0;
/// Local minima kept per cell (for the confidence's rival minimum).
const KEEP_MINIMA: usize = 4;
/// A rival minimum lies more than n / RIVAL_SEPARATION (at least 2) candidates from the
/// least cost, or beyond a ridge ([`RIDGE`]).
const RIVAL_SEPARATION: u32 = 16;
/// A cost is a rival dip, however near the least cost, where the curve between the two
/// rises to RIDGE times it: a dip of its own by the contrast's standard at the default
/// `min_confidence` (½). Measured (docs/depth.md step 6): 1.2 to 3 give the same
/// confident cells within 1.5 points of share on every case there.
pub(super) const RIDGE: f64 = 2.0;
/// The relative depth width of a cost curve's dip (see [`confidence`]) at which its
/// resolution is ½: measured on Monte-Carlo and `render` raws with photon noise
/// (docs/depth.md), the widest at which the cells called confident keep a 90th percentile
/// relative error within 5 %.
pub const WIDTH_AT_HALF: f64 = 0.045;
/// The relative depth, ½ ln(z_{k+K} / z_{k−K}), over which the resolution measures a dip
/// (its costs K candidates either side of the least, [`fold::spans`]): at least the
/// candidates' own step, so that more candidates do not narrow a V-shaped dip's measured
/// width (docs/depth.md step 6). 5 %: about the default 64 candidates' step at 1 m
/// (250 mm to 4 m), where [`WIDTH_AT_HALF`] was measured.
pub const RESOLUTION_SPAN: f64 = 0.05;
/// Largest window radius, in cells.
pub const MAX_RADIUS: usize = 64;
/// Most candidate depths of a sweep (each is a pass over every lens: 4096 take minutes on
/// a full design already).
pub const MAX_CANDIDATES: usize = 4096;
/// Bytes held per pixel of a lens's box (its ω and ω v).
const BYTES_PER_PIXEL: u128 = 16;
/// Bytes per cell of a sweep's outputs ([`Sweep`] without its volume: five f64 and a u8).
const OUTPUT_BYTES_PER_CELL: u128 = 41;

/// The chosen channels' images: per chosen channel (its index in the design, in
/// `channels`) its raw and its white, row-major in the §10 layout.
pub struct Images<'a> {
    pub channels: &'a [usize],
    pub raws: &'a [&'a [f64]],
    pub whites: &'a [&'a [f64]],
}

/// What a sweep covers: the grid, the increasing candidate depths, the window's radius
/// (cells: (2 radius + 1)² cells pooled), whether the whole cost volume is kept, and
/// whether the window is pooled again along the surface's local slope ([`tilt`]).
pub struct Plan<'a> {
    pub grid: CellGrid,
    pub candidates: &'a [f64],
    pub radius: usize,
    pub keep_volume: bool,
    pub tilt: bool,
}

/// The result of a sweep, row-major over the grid (row 0 at the top, Y1).
pub struct Sweep {
    /// The refined depth (mm); NaN where no candidate had a cost.
    pub depth: Vec<f64>,
    /// The refined candidate index (fractional); NaN where no candidate had a cost.
    pub index: Vec<f64>,
    /// The least of the cost curve's contrast and resolution ([`confidence`]), in [0, 1];
    /// 0 where no candidate had a cost or the least cost is at an end of the candidates.
    pub confidence: Vec<f64>,
    /// The least cost; NaN where no candidate had a cost.
    pub min_cost: Vec<f64>,
    /// The mean cost over the candidates that had one; NaN where none had.
    pub mean_cost: Vec<f64>,
    /// The channel whose curve gave the estimate, as its index among the chosen channels.
    pub channel: Vec<u8>,
    /// Valid pixels of the lenses whose footprints can meet the grid.
    pub samples: usize,
    /// The whole cost volume (candidate, then chosen channel, then cell), when asked for;
    /// NaN where missing.
    pub volume: Option<Vec<f64>>,
}

/// Check the candidates: 3 to [`MAX_CANDIDATES`], finite, > F, strictly increasing.
pub fn check_candidates(design: &Design, candidates: &[f64]) -> Result<()> {
    if !(3..=MAX_CANDIDATES).contains(&candidates.len()) {
        return Err(Error::param(
            "depths",
            format!("{} candidates", candidates.len()),
            format!("3 to {MAX_CANDIDATES} candidate depths"),
        ));
    }
    let f = design.f_main;
    for (i, &z) in candidates.iter().enumerate() {
        if !(z.is_finite() && z > f) {
            return Err(Error::param(
                "depths",
                format!("{z} (candidate {i})"),
                format!("finite depths > F = {f} mm"),
            ));
        }
        if i > 0 && z <= candidates[i - 1] {
            return Err(Error::param(
                "depths",
                format!("{z} after {} (candidate {i})", candidates[i - 1]),
                "strictly increasing candidate depths",
            ));
        }
    }
    Ok(())
}

/// Check the window's radius: at most [`MAX_RADIUS`] cells.
fn check_radius(radius: usize) -> Result<()> {
    if radius > MAX_RADIUS {
        return Err(Error::param(
            "window",
            radius,
            format!("a window radius in [0, {MAX_RADIUS}] cells"),
        ));
    }
    Ok(())
}

/// Check a sweep's inputs: threads, candidates, channels (1 to 255, in the design), the
/// window's radius, one raw and one white per chosen channel of the channel's raw shape,
/// all finite.
fn check_sweep(
    design: &Design,
    images: &Images,
    plan: &Plan,
    n_threads: Option<usize>,
) -> Result<()> {
    crate::infra::parallel::check_threads(n_threads)?;
    check_candidates(design, plan.candidates)?;
    let channels = images.channels;
    if channels.is_empty() || channels.len() > u8::MAX as usize {
        return Err(Error::param(
            "channels",
            channels.len(),
            "1 to 255 channels",
        ));
    }
    check_radius(plan.radius)?;
    if images.raws.len() != channels.len() || images.whites.len() != channels.len() {
        return Err(Error::param(
            "raw",
            format!("{} images", images.raws.len()),
            format!("one image per chosen channel ({})", channels.len()),
        ));
    }
    for (n, &i) in channels.iter().enumerate() {
        if i >= design.channels.len() {
            return Err(Error::param(
                "channels",
                i + 1,
                format!("channel numbers in 1..={}", design.channels.len()),
            ));
        }
        let (rows, cols) = crate::imaging::render::raw_shape(&design.channels[i]);
        for (name, img) in [("raw", images.raws[n]), ("white", images.whites[n])] {
            if img.len() != rows * cols {
                return Err(Error::param(
                    name,
                    format!("{} values for channel {}", img.len(), i + 1),
                    format!("{rows} x {cols} = {} values", rows * cols),
                ));
            }
            if let Some(k) = img.iter().position(|v| !v.is_finite()) {
                return Err(Error::param(
                    name,
                    format!("{} at channel {} pixel {k}", img[k], i + 1),
                    "finite values",
                ));
            }
        }
    }
    Ok(())
}

/// Layers a worker may compute beyond the next one to fold, per worker: bounds the
/// layers waiting to be folded.
const AHEAD_PER_WORKER: usize = 1;

/// The sweep's bytes at its peak, from what it allocates: the micro-images (`mi`, once
/// collected: their boxes, 16 bytes a pixel, their rays and their records), per worker a
/// [`Layer`] (its planes over the widened grid, the lenses' extents and one lens's scratch)
/// and the layers of costs in flight (one computed per worker and at most
/// [`AHEAD_PER_WORKER`] per worker waiting, 8 bytes an entry), the fold, the outputs and
/// the cost volume when kept.
/// Before the micro-images are collected their boxes are known on the ideal layout alone
/// (Q × Q).
fn sweep_bytes(
    design: &Design,
    plan: &Plan,
    chosen: &[usize],
    workers: usize,
    mi: Option<&Micro>,
) -> u128 {
    let grid = &plan.grid;
    let channels = chosen.len();
    let ex = (grid.nx + 2 * plan.radius, grid.ny + 2 * plan.radius);
    let entries = grid.cells() as u128 * channels as u128;
    let (micro, lenses, boxes) = match mi {
        Some(m) => (m.bytes, m.lenses.len() as u128, m.box_max),
        None => (0, 0, micro::ideal_boxes(design, chosen)),
    };
    let boxes = (boxes.0 as u128, boxes.1 as u128);
    let volume = if plan.keep_volume {
        entries * plan.candidates.len() as u128 * 8
    } else {
        0
    };
    let mut layers = (1 + AHEAD_PER_WORKER as u128) * entries * 8;
    // The tilted pooling's cells' own costs: a pair of f32 per widened cell, channel and
    // candidate, and each layer's in flight.
    let cells = ex.0 as u128 * ex.1 as u128 * channels as u128 * 8;
    let tilt = if plan.tilt {
        layers += (1 + AHEAD_PER_WORKER as u128) * cells;
        cells * plan.candidates.len() as u128
    } else {
        0
    };
    micro
        + tilt
        + workers as u128 * (Layer::bytes(ex, channels, lenses, boxes) + layers)
        + entries * Fold::bytes_per_entry(plan.candidates)
        + entries * mirror::BYTES_PER_ENTRY
        + grid.cells() as u128 * OUTPUT_BYTES_PER_CELL
        + volume
}

/// The plane sweep of the chosen channels' `images` over `plan` (the candidates, the
/// grid, the window). `done` counts candidates. See the module's doc.
pub fn sweep(
    design: &Design,
    images: &Images,
    plan: &Plan,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Sweep> {
    check_sweep(design, images, plan, n_threads)?;
    let nch = images.channels.len();
    let workers = threads(n_threads);
    // The memory without the micro-images first, then with them once collected.
    let chosen = images.channels;
    let bytes = sweep_bytes(design, plan, chosen, workers, None);
    memory::check("the depth sweep", bytes)?;
    let candidates = plan.candidates;
    let zs = (candidates[0], candidates[candidates.len() - 1]);
    let mi = micro::collect(design, images, &plan.grid, plan.radius, zs, n_threads)?;
    let bytes = sweep_bytes(design, plan, chosen, workers, Some(&mi));
    memory::check("the depth sweep", bytes)?;
    let (mut fold, volume, cells) = run(&mi, plan, workers, n_threads, done)?;
    fold.end(candidates.len() as u32);
    checkpoint()?;
    let mirrors = mirror::rivals(design, &mi, plan, chosen, &fold, workers, n_threads)?;
    let mut s = finish(fold, &mirrors, nch, candidates, mi.pixels, volume);
    if let Some(values) = cells {
        checkpoint()?;
        let costs = tilt::CellCosts {
            values: &values,
            channels: nch,
            n: candidates.len(),
        };
        tilt::refine(
            &mut s,
            &costs,
            &plan.grid,
            plan.radius,
            candidates,
            n_threads,
        )?;
    }
    Ok(s)
}

/// The layers computed and not yet folded, the fold and the volume.
struct Folding {
    fold: Fold,
    volume: Option<Vec<f64>>,
    /// The cells' own costs of every candidate folded (the tilted pooling's).
    cells: Option<Vec<f32>>,
    pending: BTreeMap<usize, (Vec<f64>, Option<Vec<f32>>)>,
    /// The next candidate to fold.
    next: usize,
    /// A worker stopped (with an error): the others stop waiting.
    failed: bool,
}

impl Folding {
    /// Fold every pending layer that is next in order.
    fn fold_ready(&mut self) {
        while let Some((l, c)) = self.pending.remove(&self.next) {
            self.fold.add(self.next as u32, &l);
            if let Some(v) = self.volume.as_mut() {
                v.extend_from_slice(&l);
            }
            if let (Some(v), Some(c)) = (self.cells.as_mut(), c) {
                v.extend_from_slice(&c);
            }
            self.next += 1;
        }
    }
}

/// What [`run`] returns: the fold, the cost volume when kept, and the cells' own costs
/// when the window is tilted.
type Swept = (Fold, Option<Vec<f64>>, Option<Vec<f32>>);

/// Sweep the candidates in parallel: each worker takes the next candidate in turn (once
/// it is at most [`AHEAD_PER_WORKER`] × workers beyond the next to fold) and folds, under
/// the lock, every layer that is next in order (the others keep computing meanwhile).
fn run(
    mi: &Micro,
    plan: &Plan,
    workers: usize,
    n_threads: Option<usize>,
    done: &AtomicUsize,
) -> Result<Swept> {
    let (grid, n) = (&plan.grid, plan.candidates.len());
    let entries = grid.cells() * mi.channels;
    let ex = (grid.nx + 2 * plan.radius, grid.ny + 2 * plan.radius);
    let per_layer = ex.0 * ex.1 * mi.channels * 2;
    // The cells' costs for the tilted pooling and the cost volume, each only when asked.
    let cells = plan
        .tilt
        .then(|| memory::try_with_capacity("the depth sweep's cells' costs", per_layer * n))
        .transpose()?;
    let volume = plan
        .keep_volume
        .then(|| memory::try_with_capacity("the depth sweep's cost volume", entries * n))
        .transpose()?;
    let state = Mutex::new(Folding {
        fold: Fold::new(entries, plan.candidates)?,
        volume,
        cells,
        pending: BTreeMap::new(),
        next: 0,
        failed: false,
    });
    let folded = Condvar::new();
    let ahead = AHEAD_PER_WORKER * workers.max(1);
    let next = AtomicUsize::new(0);
    let poisoned = || Error::param("n_threads", 1, "a worker that does not panic");
    let work = || -> Result<()> {
        let mut buf = Layer::new(ex, mi.channels);
        loop {
            let k = next.fetch_add(1, Ordering::Relaxed);
            if k >= n {
                return Ok(());
            }
            // Wait (checking for Ctrl-C) while k is too far ahead of the fold; the layer
            // next in order is always being computed, by a worker that does not wait.
            loop {
                let st = state.lock().map_err(|_| poisoned())?;
                if st.failed {
                    return Ok(());
                }
                if k < st.next + ahead {
                    break;
                }
                let wait = folded.wait_timeout(st, Duration::from_millis(20));
                drop(wait.map_err(|_| poisoned())?);
                checkpoint()?;
            }
            checkpoint()?;
            let mut out = vec![0.0; entries];
            let mut own = plan.tilt.then(|| vec![0.0f32; per_layer]);
            layer::layer(
                mi,
                grid,
                plan.radius,
                plan.candidates[k],
                &mut buf,
                &mut out,
                own.as_deref_mut(),
            )?;
            done.fetch_add(1, Ordering::Relaxed);
            let mut st = state.lock().map_err(|_| poisoned())?;
            st.pending.insert(k, (out, own));
            st.fold_ready();
            folded.notify_all();
        }
    };
    for_chunks(n_threads, workers, workers, |range| {
        range.into_par_iter().try_for_each(|_| {
            work().inspect_err(|_| {
                if let Ok(mut st) = state.lock() {
                    st.failed = true;
                }
                folded.notify_all();
            })
        })
    })?;
    let st = state.into_inner().map_err(|_| poisoned())?;
    Ok((st.fold, st.volume, st.cells))
}

/// Refine each channel's minimum in each cell, derive its depth and confidence, and keep
/// per cell the channel of highest confidence (the first on a tie).
fn finish(
    fold: Fold,
    mirrors: &[f64],
    channels: usize,
    candidates: &[f64],
    samples: usize,
    volume: Option<Vec<f64>>,
) -> Sweep {
    let cells = fold.min.len() / channels;
    let n = candidates.len();
    let mut s = Sweep {
        depth: vec![f64::NAN; cells],
        index: vec![f64::NAN; cells],
        confidence: vec![0.0; cells],
        min_cost: vec![f64::NAN; cells],
        mean_cost: vec![f64::NAN; cells],
        channel: vec![0; cells],
        samples,
        volume,
    };
    let sep = (n as u32 / RIVAL_SEPARATION).max(2);
    for cell in 0..cells {
        let mut best: Option<(f64, usize)> = None;
        for ch in 0..channels {
            let e = ch * cells + cell;
            if fold.arg[e] == u32::MAX {
                continue;
            }
            let conf = confidence(&fold, e, sep, candidates, mirrors[e]);
            if best.map_or(true, |(c, _)| conf > c) {
                best = Some((conf, ch));
            }
        }
        let Some((conf, ch)) = best else {
            continue;
        };
        let e = ch * cells + cell;
        let (k, m, l, r) = (fold.arg[e], fold.min[e], fold.left[e], fold.right[e]);
        let off = if l.is_finite() && r.is_finite() {
            vertex(l, m, r)
        } else {
            0.0
        };
        let kf = k as f64 + off;
        s.index[cell] = kf;
        s.depth[cell] = depth_at(candidates, kf, n);
        s.min_cost[cell] = m;
        s.mean_cost[cell] = fold.sum[e] / fold.count[e] as f64;
        s.confidence[cell] = conf;
        s.channel[cell] = ch as u8;
    }
    s
}

/// The confidence of entry e's curve (docs/depth.md, step 6): the least of its contrast and
/// its resolution, 0 where its least cost is at the first or last candidate (a minimum
/// the candidates do not bracket: the truth may lie beyond them) or has no neighbour.
/// - The contrast 1 − min / min(mean, rival), the rival the least of the local minima more
///   than `sep` candidates away, of the costs beyond a ridge of [`RIDGE`] times their
///   own ([`fold::Ridge`]) and of the `mirror` reading ([`mirror::rivals`]; +∞: none): a
///   textureless window costs its noise at every depth (near 0), a curve with two dips of
///   one depth is ambiguous, however near they are (measured: the R12 near its array's
///   conjugate, a dip each side of it three candidates apart) and however narrow the
///   other (the seed's half 1 either side of its out-of-focus plane).
/// - The resolution 1 / (1 + (w / [`WIDTH_AT_HALF`])²), w = Δ ln z · √(min / a) the
///   relative depth over which the parabola through the least cost and the costs l_K, r_K
///   K candidates either side (curvature a = (l_K + r_K − 2 min) / 2 per (K candidates)²,
///   Δ ln z = ½ ln(z_{k+K} / z_{k−K}), K from [`fold::spans`]: a span of about
///   [`RESOLUTION_SPAN`] in relative depth, or the candidates' step where that is coarser)
///   rises by the least cost itself, the cost's own scale of noise and mismatch: a shallow
///   dip (a smooth texture, a far depth where the disparity per candidate is small) is not
///   trusted, however far it lies below the curve's mean. Over the immediate neighbours a
///   V-shaped dip's w shrank as √step with more candidates (the seed's photograph at 1 m:
///   29.5 % confident with p90 0.77 % at 64 candidates, 52.7 % with p90 72 % at 256);
///   over a fixed span it does not.
/// - 0 where a neighbour of the least cost is above the curve's mean: a step in the curve
///   (measured: a cost 4× the mean beside a false dip at the grid's edge), not a dip.
fn confidence(fold: &Fold, e: usize, sep: u32, candidates: &[f64], mirror: f64) -> f64 {
    let (k, m, l, r) = (
        fold.arg[e] as usize,
        fold.min[e],
        fold.left[e],
        fold.right[e],
    );
    let n = candidates.len();
    if k == 0 || k + 1 >= n || !(l.is_finite() && r.is_finite()) {
        return 0.0;
    }
    let mean = fold.sum[e] / fold.count[e] as f64;
    let against = mean.min(fold.rival(e, sep)).min(fold.ridged(e)).min(mirror);
    if !(against > 0.0 && against.is_finite()) {
        return 0.0;
    }
    // A neighbour above the curve's mean: a step in the curve, not a dip.
    if l.max(r) > mean {
        return 0.0;
    }
    let contrast = (1.0 - m / against).clamp(0.0, 1.0);
    // The parabola through the least cost and the curve's costs a span either side.
    let Some(reach) = fold.reach[k] else {
        return 0.0;
    };
    let (hl, hr) = (reach.left.h, reach.right.h);
    let (cl, cr) = (
        reach.left.cost(fold.before[e]),
        reach.right.cost(fold.after[e]),
    );
    let b = ((cl - m) / hl + (cr - m) / hr) / (hl + hr);
    let resolution = if b > 0.0 {
        let w = (m.max(0.0) / b).sqrt() / WIDTH_AT_HALF;
        1.0 / (1.0 + w * w)
    } else {
        0.0
    };
    contrast.min(resolution)
}

/// The offset in (−½, ½) of a cost curve's minimum from the candidate of least cost m,
/// from its neighbours' costs l and r: the vertex of the symmetric V through the three
/// (equiangular fit: the cost rises linearly with the misregistration near its minimum,
/// as a sum of squared differences of a sharp texture does, more than quadratically).
fn vertex(l: f64, m: f64, r: f64) -> f64 {
    let rise = l.max(r) - m;
    if rise > 0.0 {
        (0.5 * (l - r) / rise).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// The depth at fractional candidate index kf: linear in 1/z between the two candidates
/// around it (the default candidates are uniform in 1/z).
fn depth_at(candidates: &[f64], kf: f64, n: usize) -> f64 {
    let k0 = (kf.floor() as usize).min(n - 2);
    let t = kf - k0 as f64;
    let inv = (1.0 - t) / candidates[k0] + t / candidates[k0 + 1];
    1.0 / inv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_of_a_symmetric_v() {
        // |x − 0.3| sampled at −1, 0, 1: l = 1.3, m = 0.3, r = 0.7.
        assert!((vertex(1.3, 0.3, 0.7) - 0.3).abs() < 1e-12);
        assert!((vertex(0.7, 0.3, 1.3) + 0.3).abs() < 1e-12);
        assert_eq!(vertex(1.0, 1.0, 1.0), 0.0);
    }

    #[test]
    fn depth_at_interpolates_in_inverse_depth() {
        let c = [500.0, 1000.0, 2000.0];
        assert!((depth_at(&c, 1.0, 3) - 1000.0).abs() < 1e-9);
        assert!((depth_at(&c, 0.5, 3) - 1.0 / (0.5 / 500.0 + 0.5 / 1000.0)).abs() < 1e-9);
        assert!((depth_at(&c, 2.0, 3) - 2000.0).abs() < 1e-9);
    }
}
