//! The choice of λ and the estimate of the noise for a reconstruction
//! (docs/reconstruct.md, "The prior's weight and the noise, from the data"): on the
//! grid's central part, once for every tile, by [`choose`].

use crate::infra::csr::Csr;
use crate::infra::error::Result;
use crate::inverse::choose::{self, Rule};
use crate::inverse::plan::Estimate;
use crate::inverse::solve::{self, Block};
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
            parabola: false,
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
        let clock = std::time::Instant::now();
        let mut eq = self.equations(sub, progress, iters, main, None)?;
        let built = clock.elapsed().as_secs_f64();
        progress.note(format!(
            "reconstruct: choosing the prior's weight on {} rows over {} x {} cells (the \
             map in {built:.1} s)",
            eq.rows, eq.grid.nx, eq.grid.ny
        ));
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
        progress.note(format!(
            "reconstruct: the prior's weight chosen ({}): lambda {:.4e} after {} lambda, {} \
             iterations, {:.1} s",
            rule.name(),
            choice.lam,
            choice.trials.len(),
            choice.trials.iter().map(|t| t.iterations).sum::<usize>(),
            clock.elapsed().as_secs_f64() - built
        ));
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

impl Plan<'_> {
    /// The rows a solve keeps: every row for the image; for the choice of λ (`choice`),
    /// an explicit block's rows that see the central sub-grid `inner` (an entry in one of
    /// its cells). The padding is there to explain those rows; a row that sees only the
    /// padding tells nothing of the sub-grid's cells, and when a pixel's span is wide
    /// against the sub-grid such rows are most of the map and of each product's cost
    /// (docs/reconstruct.md, "The search"). A factored block keeps its rows.
    pub(super) fn kept(
        blocks: Vec<Block>,
        inner: &CellGrid,
        grid: &CellGrid,
        choice: bool,
    ) -> Result<Vec<Block>> {
        if !choice {
            return Ok(blocks);
        }
        let h = grid.step;
        let i0 = ((inner.x0 - grid.x0) / h).round().max(0.0) as usize;
        let j0 = ((grid.y1 - inner.y1) / h).round().max(0.0) as usize;
        let (i1, j1) = ((i0 + inner.nx).min(grid.nx), (j0 + inner.ny).min(grid.ny));
        let sees = |c: u32| {
            let (j, i) = (c as usize / grid.nx, c as usize % grid.nx);
            (i0..i1).contains(&i) && (j0..j1).contains(&j)
        };
        let mut out = Vec::with_capacity(blocks.len());
        for block in blocks {
            let Block::Rows { a, w, y } = block else {
                out.push(block);
                continue;
            };
            let mut b = Csr::empty(a.ncols);
            let (mut wk, mut yk) = (vec![], vec![]);
            for r in 0..a.nrows() {
                let (cells, values) = a.row(r);
                if cells.iter().any(|&c| sees(c)) {
                    b.indices.extend_from_slice(cells);
                    b.data.extend_from_slice(values);
                    b.end_row();
                    wk.push(w[r]);
                    yk.push(y[r]);
                }
            }
            out.push(Block::Rows { a: b, w: wk, y: yk });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 6 × 6 grid around a 2 × 2 sub-grid two cells in from the left and the top (its
    /// cells 14, 15, 20, 21): the choice keeps the rows with an entry there, with their
    /// weights and values, in order; the image keeps every row; a factored block is kept.
    #[test]
    fn the_choice_keeps_the_rows_that_see_the_sub_grid() {
        let inner = CellGrid::covering([0.0, 2.0, 0.0, 2.0], 1.0).unwrap();
        let grid = CellGrid::covering([-2.0, 4.0, -2.0, 4.0], 1.0).unwrap();
        let rows: Vec<Vec<(u32, f64)>> = vec![
            vec![(0, 1.0), (1, 2.0)],
            vec![(14, 3.0)],
            vec![(5, 4.0), (21, 5.0)],
            vec![(35, 6.0)],
            vec![(13, 7.0), (16, 8.0), (19, 9.0), (22, 1.5)],
            vec![(20, 2.5)],
        ];
        let a = Csr::from_rows("rows", &rows, 36).unwrap();
        let (w, y): (Vec<f64>, Vec<f64>) = (0..6).map(|r| (r as f64, 10.0 + r as f64)).unzip();
        let block = || Block::Rows {
            a: a.clone(),
            w: w.clone(),
            y: y.clone(),
        };
        let all = Plan::kept(vec![block()], &inner, &grid, false).unwrap();
        let Block::Rows { a: got, .. } = &all[0] else {
            panic!("a Rows block")
        };
        assert_eq!(got, &a);
        let kept = Plan::kept(vec![block()], &inner, &grid, true).unwrap();
        let Block::Rows {
            a: got,
            w: wk,
            y: yk,
        } = &kept[0]
        else {
            panic!("a Rows block")
        };
        let want = Csr::from_rows(
            "rows",
            &[rows[1].clone(), rows[2].clone(), rows[5].clone()],
            36,
        )
        .unwrap();
        assert_eq!(got, &want);
        assert_eq!(wk, &vec![1.0, 2.0, 5.0]);
        assert_eq!(yk, &vec![11.0, 12.0, 15.0]);
        let factored = Block::Factored {
            norm: 1.0,
            px: Csr::empty(6),
            py: Csr::empty(6),
            w: vec![],
            y: vec![],
        };
        let kept = Plan::kept(vec![factored], &inner, &grid, true).unwrap();
        assert!(matches!(kept[..], [Block::Factored { .. }]));
    }
}
