//! A whole reconstruction in one call (docs/model.md §11, docs/reconstruct.md): the grid of
//! cells over the region (rounded out to whole cells, padded by a pixel's span), the map's
//! rows (per-axis factors on the exact route, explicit rows from [`system::build_surface`]
//! otherwise), each row's weight from the raw's noise, the solve ([`solve::solve`]) and
//! the crop; tiles when one solve would not fit. Its rules are stated here once: which
//! route a map takes ([`system::exact`]), the lens types kept, the surface deeper than F
//! over the padded region, the memory plan before any large buffer, the prior weight's
//! meaningful range and the expected work.
//!
//! Parts: [`blocks`] (the equations' blocks per route, the rows' weights and the prior
//! weight's range over them), [`choice`] (the data-chosen weight and noise estimate) and
//! [`padding`] (the grid's padding).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use crate::imaging::cfa::Pattern;
use crate::imaging::scene::Surface;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::inverse::choose;
use crate::inverse::plan::Estimate;

mod blocks;
use blocks::{block_rows, check_regularization, max_regularization};
mod choice;
mod padding;

use crate::inverse::solve::{self, Block};
use crate::inverse::system::{self, CellGrid};
use crate::model::design::Design;
pub use padding::PAD_NEAREST;

/// The numbers a reconstruction is configured with (the Python package's constants).
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// The noise floor, a share of a fully lit white pixel (1 sigma).
    pub noise_floor: f64,
    /// CG's stop on the normal equations' relative residual.
    pub rtol: f64,
    /// At most this many CG iterations.
    pub max_iter: usize,
    /// With a known noise: the stop at this share of the noise's expected norm.
    pub noise_tol: f64,
    /// Cells by which a tile's solve reaches into its neighbours.
    pub overlap: usize,
    /// The least tile side (cells).
    pub min_tile: usize,
    /// The expected time (s) beyond which a reconstruction is refused unless allowed.
    pub max_seconds: f64,
    /// How λ is chosen from the data when it is not given ([`choose`]).
    pub choose: ChooseSettings,
}

/// The choice of λ ([`choose`]): the bracket of λ for weights in inverse-variance units
/// (capped at [`MAX_PRIOR_SHARE`] times the data's mean weight per cell), the range of
/// photon counts an estimate of the noise can find (it widens the bracket when the noise
/// is not known), the golden-section steps, the trace probes, the central sub-grid's side
/// (cells) it is made on, each of its solves' iteration cap, the probes' stop and the
/// search's budget of iterations, and the weight on the fit's degrees of freedom.
#[derive(Clone, Copy, Debug)]
pub struct ChooseSettings {
    pub lo: f64,
    pub hi: f64,
    pub photons: [f64; 2],
    pub golden_steps: usize,
    pub probes: usize,
    pub side: usize,
    pub max_iter: usize,
    pub probe_rtol: f64,
    /// The iterations the whole search may take (the time plan counts them).
    pub budget: usize,
    /// The weight ρ ≥ 1 on the degrees of freedom in the risk ([`choose::Config`]).
    pub df_weight: f64,
}

/// The raw's noise as a reconstruction takes it: not known (estimated from the data),
/// noise-free (weighted as the floor), or photon noise N with read noise r (electrons).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Noise {
    Unknown,
    Free,
    Photons([f64; 2]),
}

/// The surface as the caller gives it: "plane" with (z0, gx, gy), or "depthmap" with its
/// extent and its depths (row-major, rows, columns).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSpec<'a> {
    pub kind: &'a str,
    pub params: &'a [f64],
    pub map: Option<(&'a [f64], usize, usize)>,
}

/// One reconstruction's inputs: the raw (every channel's image, row-major), the surface,
/// the channels and lens types (numbered from 0; lens types None: every type), the region
/// (None: what the channels see), the step (None: δ at the reference depth), λ (None:
/// chosen from the data, [`choose`]), the noise, the prior on the cells' differences
/// (quadratic, or edge-preserving, solved in passes by the solve), the tile side (None:
/// one solve, or the tiles that fit), whether a slow run is allowed, the threads and a
/// memory limit below what is available (tests). `colour` (a CFA's pattern and a colour,
/// 0 red, 1 green, 2 blue; None: every pixel) keeps only the pixels of that colour
/// (docs/model.md §12), each channel's raw indices taken by the pattern.
#[derive(Clone, Debug)]
pub struct Request<'a> {
    pub design: &'a Design,
    pub images: Vec<&'a [f64]>,
    pub surface: SurfaceSpec<'a>,
    pub channels: Vec<usize>,
    pub lens_types: Option<Vec<usize>>,
    pub colour: Option<(Pattern, usize)>,
    pub region: Option<[f64; 4]>,
    pub step: Option<f64>,
    pub regularization: Option<f64>,
    pub noise: Noise,
    pub prior: solve::Prior,
    pub tile: Option<usize>,
    pub allow_slow: bool,
    pub n_threads: Option<usize>,
    pub memory_limit: Option<u128>,
    pub settings: Settings,
}

/// The result: the cells (ny × nx, row-major from the top) over `extent`, the solve's
/// rows, iterations (the most of any tile, over every pass of the prior), residual (the
/// largest), the prior's passes (the most of any tile), the tiles, and the lens types
/// kept (None: every type).
#[derive(Clone, Debug)]
pub struct Outcome {
    pub image: Vec<f64>,
    pub nx: usize,
    pub ny: usize,
    pub extent: [f64; 4],
    pub step: f64,
    pub rows: usize,
    pub iterations: usize,
    pub residual: f64,
    pub passes: usize,
    pub tiles: usize,
    pub lens_types: Option<Vec<usize>>,
    /// The prior's weight used, and how it was set: "fixed" (given), "upre" or "gcv".
    pub regularization: f64,
    pub rule: &'static str,
    /// The noise used (Free or Photons) and whether it was estimated here.
    pub noise: Noise,
    pub estimated: bool,
    /// The λ the choice tried, in order (empty for a fixed λ with a known noise).
    pub trials: Vec<choose::Trial>,
}

/// What a running reconstruction reports: its phase (0 planning, 1 the map, 2 the solve),
/// the work done and the phase's total, and notes (the grid's size and expected work)
/// for the caller to show.
#[derive(Debug, Default)]
pub struct Progress {
    pub phase: AtomicUsize,
    pub done: AtomicUsize,
    pub total: AtomicUsize,
    pub notes: Mutex<Vec<String>>,
}

impl Progress {
    fn start(&self, phase: usize, total: usize) {
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        self.phase.store(phase, Ordering::Relaxed);
    }

    fn note(&self, text: String) {
        self.notes
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(text);
    }
}

/// The checked inputs shared by every tile, with λ and the noise as the solves take them
/// (chosen or estimated once, before the tiles).
struct Plan<'a> {
    req: &'a Request<'a>,
    surface: Surface,
    types: Option<Vec<usize>>,
    prior: solve::Prior,
    lam: f64,
    noise: Noise,
}

/// A grid's normal equations: the padding per side (cells: left, right, bottom, top), the
/// padded grid, the equations and the rows.
struct Equations {
    sides: [usize; 4],
    grid: CellGrid,
    normal: solve::Normal,
    rows: usize,
}

/// Reconstruct: the checks, the grid, then one solve or tiles (see the module doc).
pub fn reconstruct(req: &Request<'_>, progress: &Progress) -> Result<Outcome> {
    let d = req.design;
    if req.channels.is_empty() {
        return Err(Error::param("channels", "none", "at least one channel"));
    }
    for &c in &req.channels {
        if c >= d.channels.len() {
            return Err(Error::param(
                "channels",
                c + 1,
                format!("channel numbers in 1..={}", d.channels.len()),
            ));
        }
    }
    if req.images.len() != d.channels.len() {
        return Err(Error::param(
            "raw",
            format!("{} images", req.images.len()),
            format!("one image per channel ({})", d.channels.len()),
        ));
    }
    for (i, (img, ch)) in req.images.iter().zip(&d.channels).enumerate() {
        let (r, c) = crate::imaging::render::raw_shape(ch);
        if img.len() != r * c {
            return Err(Error::param(
                "raw",
                format!("channel {} of {} values", i + 1, img.len()),
                format!("the channel's {r} x {c} pixels"),
            ));
        }
    }
    if let Some(lam) = req.regularization {
        if !(lam.is_finite() && lam > 0.0) {
            return Err(Error::param("regularization", lam, "a finite value > 0"));
        }
    }
    if let Noise::Photons([n, r]) = req.noise {
        if !(n.is_finite() && n > 0.0 && r.is_finite() && r >= 0.0) {
            return Err(Error::param(
                "noise",
                format!("photons {n}, read noise {r}"),
                "photons finite > 0 and read noise finite >= 0",
            ));
        }
    }
    if let Some(t) = req.tile {
        if t < req.settings.min_tile {
            return Err(Error::param(
                "tile",
                t,
                format!("an integer >= {} (cells) or None", req.settings.min_tile),
            ));
        }
    }
    let prior = req.prior.checked()?;
    let s = req.surface;
    let surface = Surface::from_parts(s.kind, s.params, s.map)?;
    let types = lens_types(d, &req.channels, req.lens_types.as_deref())?;
    let mut plan = Plan {
        req,
        surface,
        types,
        prior,
        lam: req.regularization.unwrap_or(1.0),
        noise: req.noise,
    };
    let grid = plan.grid(req.region)?;
    let fixed = req.regularization.is_some() && req.noise != Noise::Unknown;
    let (rule, trials) = if fixed {
        ("fixed", vec![])
    } else {
        plan.choose(&grid, progress)?
    };
    let mut out = match req.tile {
        Some(t) if grid.nx > t || grid.ny > t => plan.tiled(&grid, t, progress),
        Some(_) => plan.hinted(&grid, progress, false),
        None => plan.hinted(&grid, progress, true),
    }?;
    out.rule = rule;
    out.trials = trials;
    out.estimated = req.noise == Noise::Unknown;
    Ok(out)
}

/// The lens types kept (from 0), checked against the channels' types; None for every
/// type (also when every type is listed).
fn lens_types(d: &Design, chans: &[usize], types: Option<&[usize]>) -> Result<Option<Vec<usize>>> {
    let Some(ts) = types else { return Ok(None) };
    let n = chans
        .iter()
        .map(|&i| d.channels[i].f.len())
        .max()
        .unwrap_or(1);
    if ts.is_empty() {
        return Err(Error::param("lens_types", "none", "at least one lens type"));
    }
    let mut out: Vec<usize> = Vec::with_capacity(ts.len());
    for &t in ts {
        if t >= n {
            return Err(Error::param(
                "lens_types",
                t + 1,
                format!("lens type numbers in 1..{n} (the chosen channels' lens types)"),
            ));
        }
        if out.contains(&t) {
            return Err(Error::param(
                "lens_types",
                t + 1,
                "each lens type at most once",
            ));
        }
        out.push(t);
    }
    out.sort_unstable();
    Ok((out.len() < n).then_some(out))
}

/// The median of the values (the mean of the two middle ones for an even count).
fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_unstable_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// A suggestion for a reconstruction too large for one solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hint {
    /// Tiles of at most this many cells per side.
    Tiles(usize),
    /// Tiles would not help (the padding alone does not fit): a step at least this coarse.
    Coarser(f64),
    /// Nothing to suggest.
    None,
}

/// The tile that would fit, from the need and the limit: the region's padded side scaled
/// by √(0.8 limit / need), less the padding; when that is below `min_tile`, a coarser
/// step (a row's entries scale as the inverse square of the step).
pub fn tiles_hint(
    bytes: u128,
    limit: u128,
    nx: usize,
    ny: usize,
    pad: usize,
    step: f64,
    min_tile: usize,
) -> Hint {
    if bytes == 0 || limit == 0 {
        return Hint::None;
    }
    let scale = (0.8 * limit as f64 / bytes as f64).sqrt();
    let padded = (((nx + 2 * pad) * (ny + 2 * pad)) as f64).sqrt();
    let side = ((padded * scale) as usize).saturating_sub(2 * pad).max(1);
    if side < min_tile {
        Hint::Coarser(step / scale)
    } else {
        Hint::Tiles(side)
    }
}

impl Hint {
    fn text(&self, nx: usize, ny: usize, pad: usize) -> String {
        let head = format!("the region is {nx} x {ny} cells (padded by {pad} per side)");
        match *self {
            Hint::Tiles(side) => {
                format!("{head}: reconstruct it in tiles of at most {side} x {side} cells (tile={side})")
            }
            Hint::Coarser(c) => {
                // Three significant digits.
                let digits = (2 - c.abs().log10().floor() as i64).max(0) as usize;
                format!(
                    "{head}: tiles would not help, the padding (a pixel's span on the \
                     surface, {pad} cells) needs the memory; use a coarser step (at least \
                     about {c:.digits$} mm, step={c:.digits$}), or fewer channels"
                )
            }
            Hint::None => head,
        }
    }
}

impl Plan<'_> {
    /// The depth range of the surface over the extent (a depth map's whole range).
    fn depths(&self, ext: [f64; 4]) -> (f64, f64) {
        match &self.surface {
            Surface::Plane { z0, g } => {
                let [x0, x1, y0, y1] = ext;
                let z = [[x0, y0], [x0, y1], [x1, y0], [x1, y1]]
                    .map(|p| z0 + g[0] * p[0] + g[1] * p[1]);
                (
                    z.iter().copied().fold(f64::INFINITY, f64::min),
                    z.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                )
            }
            Surface::Map(m) => (m.zmin, m.zmax),
        }
    }

    /// Refuse a surface not deeper than F at `zlo` (`where`: which depth it is).
    fn deeper_than_f(&self, zlo: f64, place: &str, hint: &str) -> Result<()> {
        let f = self.req.design.f_main;
        if zlo.is_nan() || zlo <= f {
            return Err(Error::param(
                "depth",
                format!("{zlo:.6} mm ({place})"),
                format!("depths > F = {f} mm everywhere in the region{hint}"),
            ));
        }
        Ok(())
    }

    /// The grid over the region (given, or what the channels see at the reference depth)
    /// at the step (given, or δ at the reference depth).
    fn grid(&self, region: Option<[f64; 4]>) -> Result<CellGrid> {
        let d = self.req.design;
        if let Some(r) = region {
            if !(r.iter().all(|v| v.is_finite()) && r[1] > r[0] && r[3] > r[2]) {
                return Err(Error::param(
                    "region",
                    format!("({}, {}, {}, {})", r[0], r[1], r[2], r[3]),
                    "finite (X0, X1, Y0, Y1) with X0 < X1 and Y0 < Y1 (mm)",
                ));
            }
        }
        let z_ref = match (&self.surface, region) {
            (Surface::Plane { z0, .. }, None) => *z0,
            (Surface::Plane { z0, g }, Some([x0, x1, y0, y1])) => {
                z0 + g[0] * (0.5 * (x0 + x1)) + g[1] * (0.5 * (y0 + y1))
            }
            (Surface::Map(_), _) => median(self.req.surface.map.map_or(&[][..], |m| m.0)),
        };
        if let Surface::Plane { g, .. } = &self.surface {
            if g != &[0.0, 0.0] {
                match region {
                    None => self.deeper_than_f(
                        z_ref,
                        "on the axis",
                        "; a plane nearer than F on the axis needs a region",
                    )?,
                    Some(r) => {
                        self.deeper_than_f(self.depths(r).0, "least depth over the region", "")?
                    }
                }
            }
        }
        let step = match self.req.step {
            Some(h) if h.is_finite() && h > 0.0 => h,
            Some(h) => return Err(Error::param("step", h, "a finite length > 0 (mm)")),
            None => {
                crate::model::optics::check_design_depths(d.f_main, &[z_ref])?;
                d.resolution_step(z_ref)
            }
        };
        let ext = match region {
            Some(r) => r,
            None => {
                let mut e = system::seen_region(d, &self.req.channels, z_ref)?;
                if let Surface::Map(m) = &self.surface {
                    let me = m.extent();
                    e = [
                        e[0].max(me[0]),
                        e[1].min(me[1]),
                        e[2].max(me[2]),
                        e[3].min(me[3]),
                    ];
                    if !(e[0] < e[1] && e[2] < e[3]) {
                        return Err(Error::param(
                            "region",
                            "none",
                            "a region: the depth map's extent lies outside what the \
                             channels see; give one",
                        ));
                    }
                }
                e
            }
        };
        CellGrid::covering(ext, step)
    }

    /// The grid solved in tiles of at most `tile` cells per side, each reaching `overlap`
    /// cells into its neighbours (cropped).
    fn tiled(&self, grid: &CellGrid, tile: usize, progress: &Progress) -> Result<Outcome> {
        let (nx, ny, h) = (grid.nx, grid.ny, grid.step);
        let ov = self.req.settings.overlap;
        let mut out = memory::try_vec("the reconstruction", nx * ny, 0.0)?;
        let (mut rows, mut iterations, mut tiles, mut resid) = (0, 0, 0, 0.0f64);
        let mut passes = 0;
        // A data-chosen λ held to a tile's cap (`equations`): the least any tile used.
        let mut lam_used = self.lam;
        for j0 in (0..ny).step_by(tile) {
            for i0 in (0..nx).step_by(tile) {
                let (j1, i1) = ((j0 + tile).min(ny), (i0 + tile).min(nx));
                let (e0, e1) = (i0.saturating_sub(ov), (i1 + ov).min(nx));
                let (f0, f1) = (j0.saturating_sub(ov), (j1 + ov).min(ny));
                let sub = [
                    grid.x0 + e0 as f64 * h,
                    grid.x0 + e1 as f64 * h,
                    grid.y1 - f1 as f64 * h,
                    grid.y1 - f0 as f64 * h,
                ];
                let g = CellGrid::covering(sub, h)?;
                if (g.ny, g.nx) != (f1 - f0, e1 - e0) {
                    return Err(Error::param(
                        "tile",
                        format!("a grid of {} x {}", g.ny, g.nx),
                        format!("its cells {} x {}", f1 - f0, e1 - e0),
                    ));
                }
                let r = self.hinted(&g, progress, false)?;
                for j in j0..j1 {
                    let src = &r.image[(j - f0) * r.nx + (i0 - e0)..(j - f0) * r.nx + (i1 - e0)];
                    out[j * nx + i0..j * nx + i1].copy_from_slice(src);
                }
                rows += r.rows;
                iterations = iterations.max(r.iterations);
                resid = resid.max(r.residual);
                passes = passes.max(r.passes);
                lam_used = lam_used.min(r.regularization);
                tiles += 1;
            }
        }
        Ok(Outcome {
            image: out,
            nx,
            ny,
            extent: grid.extent(),
            step: h,
            rows,
            iterations,
            residual: resid,
            passes,
            tiles,
            lens_types: self.types.clone(),
            regularization: lam_used,
            rule: "fixed",
            noise: self.noise,
            estimated: false,
            trials: vec![],
        })
    }

    /// [`Plan::one`] with a suggestion when it does not fit: tiles of the size that fits
    /// (taken when `retry`), or a coarser step when tiles would not help.
    fn hinted(&self, grid: &CellGrid, progress: &Progress, retry: bool) -> Result<Outcome> {
        match self.one(grid, progress) {
            Err(Error::TooLarge { what, bytes, limit }) => {
                let pad = self.pad(grid)?.most();
                let min = self.req.settings.min_tile;
                let hint = tiles_hint(bytes, limit, grid.nx, grid.ny, pad, grid.step, min);
                match hint {
                    Hint::Tiles(side) if retry => self.shrinking(grid, side, progress),
                    h => Err(Error::TooLarge {
                        what: format!("{what} ({})", h.text(grid.nx, grid.ny, pad)),
                        bytes,
                        limit,
                    }),
                }
            }
            other => other,
        }
    }

    /// Tiles of `side` cells, or smaller ones (by thirds, down to the least tile) while a
    /// tile's plan does not fit: the padding does not shrink with the tile, so the hint's
    /// side (the cells' share that fits) can be too large. A refusal comes from a tile's
    /// plan, before its work.
    fn shrinking(&self, grid: &CellGrid, side: usize, progress: &Progress) -> Result<Outcome> {
        let min = self.req.settings.min_tile;
        let mut side = side.max(min);
        loop {
            match self.tiled(grid, side, progress) {
                Err(Error::TooLarge { .. }) if side > min => side = (side * 2 / 3).max(min),
                other => return other,
            }
        }
    }

    /// The normal equations over the grid (padded here) at λ = `lam` (checked against
    /// the data; None: 1, unchecked, for the choice of λ), weighted by `self.noise`, after
    /// the plan's checks (memory; time for `iters` iterations and `extra` seconds of other
    /// solves, unless a slow run is allowed).
    fn equations(
        &self,
        inner: &CellGrid,
        progress: &Progress,
        iters: usize,
        extra: f64,
        lam: Option<f64>,
    ) -> Result<Equations> {
        let req = self.req;
        let padded = self.pad(inner)?;
        let (pad, sides, grid) = (padded.most(), padded.sides, padded.grid);
        let fronto = self.surface.fronto();
        let exact = fronto.is_some() && system::exact(req.design, &req.channels).is_ok();
        let limit = memory::available().min(req.memory_limit.unwrap_or(u128::MAX));
        let threads = crate::infra::parallel::threads(req.n_threads);
        let zlo = self.depths(grid.extent()).0;
        let plan = Estimate::new(req.design, &req.channels, &grid, pad, zlo, exact, threads);
        let s = req.settings;
        // The iteration cap: the image's over every pass of the prior; the choice's budget.
        let cap = match lam {
            Some(_) => iters.saturating_mul(self.prior.passes),
            None => iters,
        };
        progress.note(plan.describe(inner, pad, cap));
        let too_large = |bytes: u128| {
            (bytes > limit).then(|| Error::TooLarge {
                what: "the reconstruction's map and solve".into(),
                bytes,
                limit,
            })
        };
        if let Some(e) = too_large(plan.bytes()) {
            return Err(e);
        }
        if !req.allow_slow {
            plan.check_time_with(s.max_seconds, cap, extra)?;
        }
        progress.start(1, plan.raw_rows);
        let blocks = match fronto {
            Some(z) if exact => self.factored(z, &grid)?,
            _ => self.explicit(&grid, &progress.done)?,
        };
        let blocks = Self::kept(blocks, inner, &grid, lam.is_none())?;
        // The explicit map is known now: its transpose (the solve's copy) must fit too.
        let map: u128 = blocks
            .iter()
            .map(|b| match b {
                Block::Rows { a, .. } => {
                    2 * system::system_bytes(a.nrows() as u128, a.data.len() as u128)
                }
                Block::Factored { .. } => 0,
            })
            .sum();
        if let Some(e) = too_large(map + plan.bytes()) {
            return Err(e);
        }
        let rows: usize = blocks.iter().map(block_rows).sum();
        if rows == 0 {
            let [x0, x1, y0, y1] = inner.extent();
            return Err(Error::param(
                "region",
                format!("({x0:.6}, {x1:.6}, {y0:.6}, {y1:.6})"),
                format!(
                    "a region some pixel of the chosen channels{} sees",
                    if self.types.is_some() {
                        " and lens types"
                    } else {
                        ""
                    }
                ),
            ));
        }
        let lam = match lam {
            // A data-chosen λ was searched on the central sub-grid, whose cap differs from
            // this grid's: it is held to this grid's (the most smoothing the solve keeps).
            Some(l) if self.req.regularization.is_none() => {
                let most = max_regularization(&blocks, grid.cells());
                if l > most {
                    progress.note(format!(
                        "reconstruct: the chosen lambda {l:.4e} held to this grid's largest \
                         {most:.4e}"
                    ));
                }
                Some(l.min(most))
            }
            Some(l) => {
                check_regularization(l, &blocks, grid.cells())?;
                Some(l)
            }
            None => None,
        };
        // The choice of λ (lam None) solves with the quadratic prior; the image's solve
        // with the prior asked for.
        let normal = solve::Normal::new(grid.nx, grid.ny, lam.unwrap_or(1.0), blocks)?;
        let normal = match lam {
            Some(_) => normal.with_prior(self.prior)?,
            None => normal,
        };
        Ok(Equations {
            sides,
            grid,
            normal,
            rows,
        })
    }

    /// The solve's stop: the noise stop for a raw of photon noise (given or estimated),
    /// the relative stop alone for a noise-free one.
    fn stop(&self, max_iter: usize) -> solve::Stop {
        let s = self.req.settings;
        solve::Stop {
            rtol: s.rtol,
            noise: if matches!(self.noise, Noise::Photons(_)) {
                s.noise_tol
            } else {
                0.0
            },
            max_iter,
        }
    }

    /// One solve over the grid (padded here).
    fn one(&self, inner: &CellGrid, progress: &Progress) -> Result<Outcome> {
        let eq = self.equations(
            inner,
            progress,
            self.req.settings.max_iter,
            0.0,
            Some(self.lam),
        )?;
        let s = self.req.settings;
        // The iteration cap over every pass of the prior.
        let cap = s.max_iter.saturating_mul(self.prior.passes);
        progress.start(2, cap);
        let sol = solve::solve(
            &eq.normal,
            self.stop(s.max_iter),
            self.req.n_threads,
            &progress.done,
        )?;
        let ([left, _, _, top], grid) = (eq.sides, eq.grid);
        let mut image = Vec::with_capacity(inner.cells());
        for j in top..top + inner.ny {
            image.extend_from_slice(&sol.cells[j * grid.nx + left..j * grid.nx + left + inner.nx]);
        }
        Ok(Outcome {
            image,
            nx: inner.nx,
            ny: inner.ny,
            extent: inner.extent(),
            step: inner.step,
            rows: eq.rows,
            iterations: sol.iterations,
            residual: sol.residual,
            passes: sol.passes,
            tiles: 1,
            lens_types: self.types.clone(),
            regularization: eq.normal.regularization(),
            rule: "fixed",
            noise: self.noise,
            estimated: false,
            trials: vec![],
        })
    }
}

/// λ beyond this many times the data's mean weight per cell (trace(AᵀWA) / cells) drowns
/// the data: the normal equations' condition grows past what the solve resolves.
pub const MAX_PRIOR_SHARE: f64 = 1e6;

/// The largest photon count of the noise model (the Python package's `MAX_PHOTONS`): an
/// estimate beyond it is taken as noise-free.
pub const MAX_PHOTONS: f64 = 1e15;

#[cfg(test)]
mod tests {
    use super::*;

    /// The hint's tile: the padded side scaled by √(0.8 limit / need), less the padding
    /// (1020 √0.2 − 20 = 436 for a 1000² region padded by 10, needing four times the
    /// limit); a coarser step √(need / 0.8 limit) times the step when that is below 16.
    #[test]
    fn tiles_hint_is_the_share_that_fits() {
        let side = (1020.0 * (0.8f64 * 100.0 / 400.0).sqrt()) as usize - 20;
        assert_eq!(
            tiles_hint(400, 100, 1000, 1000, 10, 0.05, 16),
            Hint::Tiles(side)
        );
        let Hint::Coarser(c) = tiles_hint(12_163_760_088, 11_157_381_120, 64, 64, 1155, 0.0155, 16)
        else {
            panic!("tiles suggested")
        };
        let want = 0.0155 * (12_163_760_088f64 / (0.8 * 11_157_381_120f64)).sqrt();
        assert!((c - want).abs() < 1e-12 * want, "{c} {want}");
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
