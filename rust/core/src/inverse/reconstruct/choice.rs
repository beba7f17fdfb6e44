//! The choice of λ and the estimate of the noise for a reconstruction
//! (docs/reconstruct.md, "The prior's weight and the noise, from the data"): on the
//! grid's central part, once for every tile, by [`choose`].

use crate::infra::error::Result;
use crate::inverse::choose::{self, Rule};
use crate::inverse::plan::Estimate;
use crate::inverse::solve;
use crate::inverse::system::{self, CellGrid};

use super::{Noise, Plan, Progress, MAX_PHOTONS, MAX_PRIOR_SHARE};

impl Plan<'_> {
    /// The expected seconds of one solve over the grid at the iteration cap.
    pub(super) fn expected(&self, inner: &CellGrid) -> Result<f64> {
        let req = self.req;
        let padded = self.pad(inner)?;
        let (pad, grid) = (padded.most(), padded.grid);
        let exact =
            self.surface.fronto().is_some() && system::exact(req.design, &req.channels).is_ok();
        let threads = crate::infra::parallel::threads(req.n_threads);
        let zlo = self.depths(grid.extent()).0;
        let plan = Estimate::new(req.design, &req.channels, &grid, pad, zlo, exact, threads);
        Ok(plan.seconds(req.settings.max_iter))
    }

    /// The central part of the grid, at most `side` cells a side (the whole grid when it
    /// is no larger).
    pub(super) fn central(grid: &CellGrid, side: usize) -> Result<CellGrid> {
        if grid.nx <= side && grid.ny <= side {
            return Ok(*grid);
        }
        let (sx, sy) = (grid.nx.min(side), grid.ny.min(side));
        let (i0, j0) = ((grid.nx - sx) / 2, (grid.ny - sy) / 2);
        let h = grid.step;
        let sub = [
            grid.x0 + i0 as f64 * h,
            grid.x0 + (i0 + sx) as f64 * h,
            grid.y1 - (j0 + sy) as f64 * h,
            grid.y1 - j0 as f64 * h,
        ];
        CellGrid::covering(sub, h)
    }

    /// One search for λ on the grid's central part by `rule` at the plan's noise; the
    /// expected time of the search and of `main` seconds planned.
    pub(super) fn search(
        &self,
        sub: &CellGrid,
        rule: Rule,
        main: f64,
        progress: &Progress,
    ) -> Result<choose::Choice> {
        let c = self.req.settings.choose;
        let mut cfg = choose::Config {
            lo: c.lo,
            hi: c.hi,
            golden_steps: c.golden_steps,
            probes: c.probes,
            budget: c.budget,
            df_weight: c.df_weight,
            data: self.stop(c.max_iter),
            probe: solve::Stop::relative(c.probe_rtol, c.max_iter),
        };
        // The floor of a noise-free raw is the noise the risk is measured against.
        cfg.data.noise = self.req.settings.noise_tol;
        if self.noise == Noise::Unknown {
            // The search's weights are photon noise at N = 1: λ in them is λ / N, for the
            // photon counts the estimate can find.
            cfg.lo /= c.photons[1];
            cfg.hi /= c.photons[0];
        }
        let iters = c.budget;
        let mut eq = self.equations(sub, progress, iters, main, None)?;
        let mut work = eq.normal.work()?;
        let mut diag = vec![0.0; eq.normal.cells()];
        let mean = eq.normal.diagonal(&mut work, &mut diag) / eq.grid.cells().max(1) as f64;
        drop((work, diag));
        cfg.hi = cfg.hi.min(MAX_PRIOR_SHARE * mean);
        cfg.lo = cfg.lo.min(cfg.hi / 10.0);
        progress.start(2, iters);
        let choice = choose::choose(
            &mut eq.normal,
            rule,
            cfg,
            self.req.n_threads,
            &progress.done,
        )?;
        for t in &choice.trials {
            progress.note(format!(
                "reconstruct: choosing the prior's weight ({}): lambda {:.4e}: score {:.6e}, \
                 RSS {:.6e}, df {:.1} of {} rows, {} iterations",
                rule.name(),
                t.lam,
                t.score,
                t.rss,
                t.df,
                choice.rows,
                t.iterations
            ));
        }
        Ok(choice)
    }

    /// Choose λ (when not given) and estimate the noise (when not known) on the central
    /// part of the grid, once for every tile, by GCV: on the noise's weights when it is
    /// known; on the weights of photon noise at N = 1 when not, whose factor RSS/(m − df)
    /// is then 1/N̂. Then λ = N̂ λ₁; when N̂ puts more than 1 % of the raw's pixels under
    /// the floor (the weights are then no longer N̂ times the search's), λ is chosen again
    /// at N̂.
    /// Returns the rule and the λ tried.
    pub(super) fn choose(
        &mut self,
        grid: &CellGrid,
        progress: &Progress,
    ) -> Result<(&'static str, Vec<choose::Trial>)> {
        let s = self.req.settings;
        let sub = Self::central(grid, s.choose.side)?;
        let main = self.expected(grid)?;
        let known = self.noise != Noise::Unknown;
        // GCV also for a known noise: the stated noise leaves out the model's own error
        // (a texture no grid holds, a renderer's), which GCV's scale takes in (measured:
        // UPRE at the stated N = 2000 chose λ 5-30 times too small on Monte-Carlo raws).
        // A noise-free raw has no noise for GCV to measure (its residual is rounding): its
        // floor is taken as the noise, by UPRE.
        let rule = if self.noise == Noise::Free {
            Rule::Upre
        } else {
            Rule::Gcv
        };
        let first = self.search(&sub, rule, main, progress)?;
        let mut trials = first.trials.clone();
        if known {
            self.lam = first.lam;
            return Ok((rule.name(), trials));
        }
        let photons = if first.scale > 0.0 {
            1.0 / first.scale
        } else {
            f64::INFINITY
        };
        self.noise = if photons.is_finite() && photons <= MAX_PHOTONS {
            Noise::Photons([photons, 0.0])
        } else {
            Noise::Free
        };
        progress.note(format!(
            "reconstruct: noise estimated from the data (GCV at lambda {:.4e}): photons {photons:.6e}",
            first.lam
        ));
        if let Some(lam) = self.req.regularization {
            self.lam = lam;
            return Ok(("fixed", trials));
        }
        if self.noise == Noise::Photons([photons, 0.0]) && self.floored(photons) <= 0.01 {
            self.lam = first.lam * photons;
            return Ok((Rule::Gcv.name(), trials));
        }
        let again = self.search(&sub, Rule::Gcv, main, progress)?;
        trials.extend(again.trials);
        self.lam = again.lam;
        Ok((Rule::Gcv.name(), trials))
    }

    /// The share of the chosen channels' pixels whose photon noise at N would lie under
    /// the floor.
    pub(super) fn floored(&self, n: f64) -> f64 {
        let d = self.req.design;
        let (mut under, mut all) = (0usize, 0usize);
        for &c in &self.req.channels {
            let floor = self.req.settings.noise_floor * d.channels[c].share;
            let img = self.req.images[c];
            under += img
                .iter()
                .filter(|&&y| y.max(0.0) / n < floor * floor)
                .count();
            all += img.len();
        }
        under as f64 / all.max(1) as f64
    }
}
