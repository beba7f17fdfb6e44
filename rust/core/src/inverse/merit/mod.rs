//! Image merits (docs/merits.md): the image quality a design's reconstruction reaches at a
//! depth, from the linear estimator's expected error rather than from a rendered raw.
//!
//! On a patch of cells at the field's centre (padded by a pixel's span, as a
//! reconstruction pads its region), the map's rows A are built by the reconstruction's own
//! routes (the exact factored route on a fronto-parallel plane where the design allows,
//! the general route otherwise), each row weighted as a reconstruction weights it,
//! w = 1/σ², σ² = v/N (photon noise at N photo-electrons for white) floored, with v the
//! row's value on a flat scene at the ensemble's mean albedo. The estimator is the
//! reconstruction's: x̂ = (AᵀWA + λDᵀD)⁻¹ AᵀW y.
//!
//! Its expected squared error over the patch's central cells, for images x from a
//! power-law Gaussian ensemble ([`Ensemble`]) and Gaussian noise n of covariance W⁻¹,
//! is estimated by Monte Carlo with a few draws (x_k, n_k): each is one solve (CG, as
//! the reconstruction's, with the two-level preconditioner when `Settings::coarse`) of
//! (AᵀWA + λDᵀD) x̂_k = AᵀW (A x_k + n_k), and the merit is the mean of ‖x̂_k − x_k‖²
//! over the cells and draws, with the draws' standard error. The same draws serve every
//! λ (common random numbers: the estimate's error changes smoothly with λ). λ
//! ([`Lambda`]) is given; or chosen from the data as a reconstruction chooses it (`Gcv`,
//! the default: generalised cross-validation, `inverse::choose`, on the draws' data y_k
//! = A x_k + n_k, the λ of the least mean score m RSS / (m − df)², df by the
//! same Hutchinson probes); or the one of least expected error (`Oracle`, which a
//! reconstruction cannot know): decades down from the bracket's top, stopped a decade past
//! the least, then golden sections in log λ.
//!
//! The modulation transfer: at that λ, the estimator's mean response to a slanted edge
//! (the edge's cell averages x_e, x̂_e = (AᵀWA + λDᵀD)⁻¹ AᵀWA x_e, noise-free: the
//! expectation of the reconstruction of the edge), returned over the patch for the
//! caller's MTF50 (ISO 12233's edge method, `splitlf.measure`).

mod ensemble;
mod patch;

use std::sync::atomic::AtomicUsize;

use crate::imaging::texture::Texture;
use crate::infra::error::{Error, Result};
use crate::inverse::choose::{self, DataSet, Rule};
use crate::inverse::reconstruct::MAX_PRIOR_SHARE;
use crate::inverse::solve::{self, Normal, Start, Stop};
use crate::model::design::Design;

pub use ensemble::{normals, Ensemble, MAX_EXPONENT};
pub use patch::Patch;

/// The numbers the merits are computed with: the noise floor (a share of white, 1 σ),
/// CG's relative stop and iteration cap, the draws, the λ bracket (inverse-variance
/// units) and the golden-section steps, and the draws' seed.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub noise_floor: f64,
    pub rtol: f64,
    pub max_iter: usize,
    pub samples: usize,
    pub lo: f64,
    pub hi: f64,
    pub golden_steps: usize,
    pub seed: u64,
    /// The padding, in pixel spans beyond the patch (a reconstruction pads by one; the
    /// patch's padded cells are seen by fewer pixels than a region's, so more are taken).
    pub margin: f64,
    /// The Hutchinson probes of GCV's df and their solves' relative stop.
    pub probes: usize,
    pub probe_rtol: f64,
    /// GCV's refinement after the decades: one λ at the parabola's vertex (else golden
    /// sections, `golden_steps` of them).
    pub parabola: bool,
    /// CG preconditioned by the two-level preconditioner (`Normal::precondition_coarse`:
    /// Jacobi plus a coarse-grid solve) rather than by Jacobi alone: the same solutions,
    /// fewer iterations.
    pub coarse: bool,
}

/// How λ is had: given; chosen by GCV on the draws' data (a reconstruction's rule), the
/// fit's degrees of freedom charged ρ ≥ 1 times (1: plain GCV; a reconstruction on a known
/// surface charges 1.25, weighted GCV); or the least expected error (the oracle's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lambda {
    Given(f64),
    Gcv(f64),
    Oracle,
}

/// One merit's inputs: the design and depth (a fronto-parallel plane), the channels and
/// lens types (from 0; None: every type), the photons N for white, the ensemble, the edge
/// for the transfer (None: none), the patch's side (cells), the step (None: δ(z)), how λ
/// is had, the settings and the threads.
#[derive(Clone, Debug)]
pub struct Request<'a> {
    pub design: &'a Design,
    pub depth: f64,
    pub channels: Vec<usize>,
    pub lens_types: Option<Vec<usize>>,
    pub photons: f64,
    pub ensemble: Ensemble,
    pub edge: Option<&'a Texture>,
    pub patch: usize,
    pub step: Option<f64>,
    pub lambda: Lambda,
    pub settings: Settings,
    pub n_threads: Option<usize>,
}

/// One λ tried: the mean squared error per cell and its standard error over the draws.
#[derive(Clone, Copy, Debug)]
pub struct Trial {
    pub lam: f64,
    pub mse: f64,
    pub error: f64,
}

/// The merits: λ used, the expected squared error per cell (mean over draws) with its
/// standard error and each draw's, every λ whose expected error was found, the edge's expected image over the patch
/// (ny × nx, row-major from the top), the patch's grid (extent, step, nx, ny), the padded
/// grid's size, the rows and the solves' iterations.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub lam: f64,
    pub mse: f64,
    pub error: f64,
    pub draws: Vec<f64>,
    pub trials: Vec<Trial>,
    /// GCV's trials (score, RSS, df per λ; empty unless λ was chosen by GCV).
    pub gcv: Vec<choose::Trial>,
    pub edge: Option<Vec<f64>>,
    pub extent: [f64; 4],
    pub step: f64,
    pub nx: usize,
    pub ny: usize,
    pub padded: [usize; 2],
    pub rows: usize,
    pub iterations: usize,
}

fn check(req: &Request<'_>) -> Result<()> {
    let s = req.settings;
    if !(req.photons.is_finite() && req.photons > 0.0) {
        return Err(Error::param("photons", req.photons, "a finite value > 0"));
    }
    if req.patch < 8 {
        return Err(Error::param("patch", req.patch, "an integer >= 8 (cells)"));
    }
    if !(s.margin.is_finite() && (1.0..=8.0).contains(&s.margin)) {
        return Err(Error::param(
            "margin",
            s.margin,
            "a value in [1, 8] (pixel spans)",
        ));
    }
    if s.samples < 2 {
        return Err(Error::param("samples", s.samples, "an integer >= 2"));
    }
    if !(s.lo > 0.0 && s.hi > s.lo && s.hi.is_finite()) {
        return Err(Error::param(
            "bracket",
            format!("({}, {})", s.lo, s.hi),
            "0 < lo < hi, finite",
        ));
    }
    if let Lambda::Given(l) = req.lambda {
        if !(l.is_finite() && l > 0.0) {
            return Err(Error::param("regularization", l, "a finite value > 0"));
        }
    }
    if let Lambda::Gcv(rho) = req.lambda {
        if !(1..=64).contains(&s.probes) {
            return Err(Error::param("probes", s.probes, "an integer in [1, 64]"));
        }
        if !(rho.is_finite() && (1.0..=4.0).contains(&rho)) {
            return Err(Error::param("df_weight", rho, "a weight in [1, 4]"));
        }
    }
    req.ensemble.checked()?;
    Ok(())
}

/// The draws' fixed parts: each image x_k, its right-hand side AᵀW (A x_k + n_k) and
/// Σ w y², and the last solution at each (warm starts).
struct Draws {
    x: Vec<Vec<f64>>,
    rhs: Vec<Vec<f64>>,
    yy: Vec<f64>,
    last: Vec<Option<Vec<f64>>>,
}

/// The search's state over one patch.
struct Search<'a> {
    patch: &'a Patch,
    normal: Normal,
    draws: Draws,
    stop: Stop,
    threads: Option<usize>,
    done: &'a AtomicUsize,
    trials: Vec<Trial>,
    per_draw: Vec<Vec<f64>>,
    gcv: Vec<choose::Trial>,
    iterations: usize,
}

impl Search<'_> {
    /// The expected error per cell at λ (mean and standard error over the draws).
    fn trial(&mut self, lam: f64) -> Result<f64> {
        self.normal.set_regularization(lam)?;
        // Each warm start stopped against its own residual (`choose::warm_stop`).
        let mut jobs: Vec<(Start<'_>, Stop)> = Vec::with_capacity(self.draws.rhs.len());
        for (rhs, last) in self.draws.rhs.iter().zip(&self.draws.last) {
            let start = Start {
                rhs: Some(rhs),
                x0: last.as_deref(),
            };
            let stop = choose::warm_stop(&self.normal, rhs, start.x0, self.stop)?;
            jobs.push((start, stop));
        }
        let sols = solve::solve_each(&self.normal, &jobs, self.threads, self.done)?;
        drop(jobs);
        let mut errs = Vec::with_capacity(self.draws.x.len());
        for (k, sol) in sols.into_iter().enumerate() {
            self.iterations += sol.iterations;
            errs.push(self.patch.inner_mse(&sol.cells, &self.draws.x[k]));
            self.draws.last[k] = Some(sol.cells);
        }
        let n = errs.len() as f64;
        let mse = errs.iter().sum::<f64>() / n;
        let var = errs.iter().map(|e| (e - mse) * (e - mse)).sum::<f64>() / (n - 1.0);
        self.trials.push(Trial {
            lam,
            mse,
            error: (var / n).sqrt(),
        });
        self.per_draw.push(errs);
        Ok(mse)
    }

    /// λ of least expected error: decades from `hi` down (stopped one decade past the
    /// least, or at `lo`), then golden sections in log λ over the decades around it.
    fn least(&mut self, lo: f64, hi: f64, steps: usize) -> Result<f64> {
        let (mut best, mut best_lam) = (f64::INFINITY, hi);
        let mut lam = hi;
        while lam >= lo * (1.0 - 1e-12) {
            let e = self.trial(lam)?;
            if e < best {
                (best, best_lam) = (e, lam);
            } else if lam < best_lam / 5.0 {
                break;
            }
            lam /= 10.0;
        }
        let (mut a, mut b) = (
            (best_lam / 10.0).max(lo).ln(),
            (best_lam * 10.0).min(hi).ln(),
        );
        let phi = 0.5 * (5f64.sqrt() - 1.0);
        let (mut c, mut d) = (b - phi * (b - a), a + phi * (b - a));
        let (mut fc, mut fd) = (self.trial(c.exp())?, self.trial(d.exp())?);
        for _ in 0..steps {
            if fc < fd {
                (b, d, fd) = (d, c, fc);
                c = b - phi * (b - a);
                fc = self.trial(c.exp())?;
            } else {
                (a, c, fc) = (c, d, fd);
                d = a + phi * (b - a);
                fd = self.trial(d.exp())?;
            }
        }
        let i = (0..self.trials.len())
            .min_by(|&i, &j| self.trials[i].mse.total_cmp(&self.trials[j].mse))
            .unwrap_or(0);
        Ok(self.trials[i].lam)
    }

    /// λ by GCV on the draws' data, df charged `rho` times (`inverse::choose`, with a
    /// reconstruction's bracket cap at MAX_PRIOR_SHARE times the data's mean weight per
    /// cell), then its trial (the expected error there, warm-started from the choice's last
    /// solutions).
    fn gcv(&mut self, s: Settings, rho: f64) -> Result<f64> {
        let mut work = self.normal.work()?;
        let mut diag = vec![0.0; self.normal.cells()];
        let mean = self.normal.diagonal(&mut work, &mut diag) / diag.len().max(1) as f64;
        drop((work, diag));
        let hi = s.hi.min(MAX_PRIOR_SHARE * mean);
        let cfg = choose::Config {
            lo: s.lo.min(hi / 10.0),
            hi,
            golden_steps: s.golden_steps,
            probes: s.probes,
            budget: usize::MAX / 4,
            data: self.stop,
            probe: Stop::relative(s.probe_rtol, s.max_iter),
            df_weight: rho,
            parabola: s.parabola,
        };
        let sets = (0..self.draws.x.len())
            .map(|k| DataSet {
                rhs: self.draws.rhs[k].clone(),
                yy: self.draws.yy[k],
                last: None,
            })
            .collect();
        let (choice, sets) = choose::choose_sets(
            &mut self.normal,
            Rule::Gcv,
            cfg,
            sets,
            self.threads,
            self.done,
        )?;
        self.iterations += choice.trials.iter().map(|t| t.iterations).sum::<usize>();
        for (last, set) in self.draws.last.iter_mut().zip(sets) {
            *last = set.last;
        }
        self.gcv = choice.trials;
        self.trial(choice.lam)?;
        Ok(choice.lam)
    }
}

/// The merits of one design at one depth (module doc); `done` counts CG iterations.
pub fn image_merits(req: &Request<'_>, done: &AtomicUsize) -> Result<Outcome> {
    check(req)?;
    let s = req.settings;
    let patch = Patch::build(req, done)?;
    let (nx, ny) = (patch.grid.nx, patch.grid.ny);
    let mut draws = Draws {
        x: vec![],
        rhs: vec![],
        yy: vec![],
        last: vec![None; s.samples],
    };
    for k in 0..s.samples {
        let seed = s.seed.wrapping_mul(1_000_003).wrapping_add(k as u64);
        let x = req.ensemble.draw(nx, ny, 2 * seed)?;
        let xi = normals(patch.rows, 2 * seed + 1);
        let (rhs, yy) = patch.data(&x, Some(&xi));
        draws.rhs.push(rhs);
        draws.yy.push(yy);
        draws.x.push(x);
        crate::infra::parallel::checkpoint()?;
    }
    let mut normal = Normal::new(nx, ny, s.hi, patch.blocks())?;
    if s.coarse {
        normal.precondition_coarse()?;
    }
    let mut search = Search {
        patch: &patch,
        normal,
        draws,
        stop: Stop::relative(s.rtol, s.max_iter),
        threads: req.n_threads,
        done,
        trials: vec![],
        per_draw: vec![],
        gcv: vec![],
        iterations: 0,
    };
    let lam = match req.lambda {
        Lambda::Given(l) => {
            search.trial(l)?;
            l
        }
        Lambda::Gcv(rho) => search.gcv(s, rho)?,
        Lambda::Oracle => search.least(s.lo, s.hi, s.golden_steps)?,
    };
    let i = search
        .trials
        .iter()
        .rposition(|t| t.lam == lam)
        .unwrap_or(0);
    let t = search.trials[i];
    let edge = match req.edge {
        Some(tex) => {
            search.normal.set_regularization(lam)?;
            let xe = crate::inverse::system::cell_averages(tex, &patch.grid);
            let (rhs, _) = patch.data(&xe, None);
            let start = Start {
                rhs: Some(&rhs),
                x0: Some(&xe),
            };
            // Started at the edge itself: stopped against its own residual, as a warm
            // start (`choose::warm_stop`; against ‖b‖ alone it stopped near x_e, sharp).
            let stop = choose::warm_stop(&search.normal, &rhs, start.x0, search.stop)?;
            let sol = solve::solve_from(&search.normal, start, stop, req.n_threads, done)?;
            search.iterations += sol.iterations;
            Some(patch.crop(&sol.cells))
        }
        None => None,
    };
    Ok(Outcome {
        lam,
        mse: t.mse,
        error: t.error,
        draws: search.per_draw[i].clone(),
        trials: search.trials.clone(),
        gcv: search.gcv.clone(),
        edge,
        extent: patch.inner.extent(),
        step: patch.inner.step,
        nx: patch.inner.nx,
        ny: patch.inner.ny,
        padded: [nx, ny],
        rows: patch.rows,
        iterations: search.iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    /// The draws' solves one after the other (each CG's products split over the threads)
    /// against side by side (`solve::solve_each`), alternating, medians: the seed's half 2
    /// at 642 mm, 8 right-hand sides (4 draws and 4 probes' worth), the natural ensemble's
    /// numbers, 2 threads, and one thread for the reference. A timing, not a check: run it by name,
    /// `cargo test --release -p splitlf-core -- --ignored side_by_side --nocapture`.
    #[test]
    #[ignore]
    fn side_by_side_timing() {
        let d = crate::model::presets::preset("seed").unwrap();
        let settings = Settings {
            noise_floor: 1e-3,
            rtol: 1e-4,
            max_iter: 500,
            samples: 4,
            lo: 1e-3,
            hi: 1e5,
            golden_steps: 2,
            seed: 0,
            margin: 2.0,
            probes: 4,
            probe_rtol: 1e-4,
            parabola: false,
            coarse: true,
        };
        let ensemble = Ensemble {
            mean: 0.505,
            amplitude: 0.027,
            exponent: 2.0,
            floor: 0.0,
            spectrum: Vec::new(),
        };
        let req = Request {
            design: &d,
            depth: 642.0,
            channels: vec![1],
            lens_types: None,
            photons: 2000.0,
            ensemble: ensemble.clone(),
            edge: None,
            patch: 48,
            step: None,
            lambda: Lambda::Given(30.0),
            settings,
            n_threads: Some(2),
        };
        let done = AtomicUsize::new(0);
        let patch = Patch::build(&req, &done).unwrap();
        let (nx, ny) = (patch.grid.nx, patch.grid.ny);
        let rhs: Vec<Vec<f64>> = (0..8u64)
            .map(|k| {
                let x = ensemble.draw(nx, ny, 2 * k).unwrap();
                patch.data(&x, Some(&normals(patch.rows, 2 * k + 1))).0
            })
            .collect();
        let normal = Normal::new(nx, ny, 30.0, patch.blocks()).unwrap();
        let stop = Stop::relative(1e-4, 500);
        let jobs: Vec<(Start<'_>, Stop)> = rhs
            .iter()
            .map(|b| {
                let start = Start {
                    rhs: Some(b),
                    x0: None,
                };
                (start, stop)
            })
            .collect();
        let one_by_one = |threads| {
            let t = Instant::now();
            for &(s, st) in &jobs {
                solve::solve_from(&normal, s, st, threads, &done).unwrap();
            }
            t.elapsed().as_secs_f64()
        };
        let (mut seq1, mut seq, mut par) = (vec![], vec![], vec![]);
        for _ in 0..5 {
            seq1.push(one_by_one(Some(1)));
            seq.push(one_by_one(Some(2)));
            let t = Instant::now();
            solve::solve_each(&normal, &jobs, Some(2), &done).unwrap();
            par.push(t.elapsed().as_secs_f64());
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (a, b, c) = (median(&mut seq1), median(&mut seq), median(&mut par));
        println!(
            "grid {nx} x {ny}, 8 solves: one by one 1 thread {a:.3} s, 2 threads {b:.3} s, \
             side by side 2 threads {c:.3} s ({:.2}x one by one)",
            b / c
        );
    }
}
