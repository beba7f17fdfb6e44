//! The prior's weight λ chosen from the data (docs/reconstruct.md, "The prior's weight"):
//! for the normal equations (AᵀWA + λDᵀD) t = AᵀWy of one grid, the λ that minimises a
//! predictive risk in the data, searched over log λ.
//!
//! Write N = AᵀWA, R = DᵀD, t_λ the solution, RSS(λ) = Σ_rows w (A t_λ − y)² and
//! df(λ) = trace((N + λR)⁻¹ N) the fit's degrees of freedom (the trace of the hat matrix
//! W^½ A (N + λR)⁻¹ Aᵀ W^½), m the rows:
//! - [`Rule::Upre`] (Mallows' C_p / the unbiased predictive risk estimate, SURE for a
//!   linear estimator) when W is the inverse noise variance (a noise given, carried by the
//!   raw, or the floor of a noise-free raw): U(λ) = RSS + 2ρ df − m;
//! - [`Rule::Gcv`] (generalised cross-validation) when the noise's scale is not known
//!   (W known up to a factor): V(λ) = m RSS / (m − ρ df)²; then RSS / (m − df) at the
//!   chosen λ estimates the factor (the rows' noise variance in W's units).
//!
//! ρ ([`Config::df_weight`]) is 1 for plain UPRE/GCV. A caller whose model is inexact
//! (rows built on an estimated depth surface, wrong where the estimate is wrong) passes
//! ρ > 1, "weighted GCV": plain GCV fits the model's error as if it were signal and its
//! score keeps falling to the bracket's bottom; charging each degree of freedom more
//! holds the choice where the image, not the model's error, is fitted
//! (docs/reconstruct.md, "The prior's weight").
//!
//! RSS comes from the solution without a forward product: tᵀNt − 2 tᵀAᵀWy + Σ w y².
//! df is a Hutchinson estimate: the mean of zᵀ (N + λR)⁻¹ N z over fixed Rademacher probes
//! z over the cells (the same probes at every λ, so the estimate's error changes smoothly
//! with λ and does not move the minimum about). Each λ costs one solve for t and one per
//! probe, each warm-started from the nearest λ already solved.
//!
//! The search: λ over decades down from [`START_DECADES`] below the top of the bracket,
//! stopped one decade past the least score (and up from the start when the start stays the
//! least), then a golden-section search in log λ over the two decades around the least.

use crate::infra::error::{Error, Result};
use crate::infra::parallel;

use super::solve::{self, Normal, Start, Stop};

/// The decades below the top of the bracket at which the search starts (module doc): the
/// largest λ converge slowest, the prior's smooth modes dominating (measured on a slanted
/// plane's wide-span pixels, half 2 in docs/make_fig2_slanted.py's 702 mm band: 2,500
/// iterations at the bracket's top, 2,453 a decade below, against 945–1,231 near the least
/// score, which lay 3.35 decades below the top; docs/reconstruct.md, "The search"). When
/// the least lies higher, the search walks up to it.
pub const START_DECADES: f64 = 3.0;

/// Which risk the search minimises (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    Upre,
    Gcv,
}

impl Rule {
    pub fn name(self) -> &'static str {
        match self {
            Rule::Upre => "upre",
            Rule::Gcv => "gcv",
        }
    }
}

/// How the search runs: the bracket of λ (both > 0), the golden-section steps, the
/// probes, the iterations the whole search may take (`budget`: no λ is tried once the
/// next one's solves, each at its cap, could exceed it), and each solve's stop (the data's: `data`, whose `noise` is τ for a W in
/// inverse-variance units and scaled by the running noise estimate under GCV; the probes':
/// `probe`, relative).
#[derive(Clone, Copy, Debug)]
pub struct Config {
    pub lo: f64,
    pub hi: f64,
    pub golden_steps: usize,
    pub probes: usize,
    pub budget: usize,
    pub data: Stop,
    pub probe: Stop,
    /// ρ ≥ 1: the weight on df in the score (module doc).
    pub df_weight: f64,
    /// After the decades, one λ at the vertex of the parabola through the least decade's
    /// score and its two neighbours' (in log λ, when the three are tried and the parabola
    /// opens upwards), instead of the golden sections (which run when it cannot be had).
    pub parabola: bool,
}

/// One λ tried: its score, RSS, df, and the solves' iterations.
#[derive(Clone, Copy, Debug)]
pub struct Trial {
    pub lam: f64,
    pub score: f64,
    pub rss: f64,
    pub df: f64,
    pub iterations: usize,
}

/// The Hutchinson standard errors of ρ df within which GCV's denominator m − ρ df may not
/// come to zero: a trial nearer than that (or within one row) is degenerate, its score
/// infinite (module doc).
pub const DEGENERATE_ERRORS: f64 = 3.0;

/// The least relative stop a warm start's is tightened to ([`warm_stop`]): a residual
/// double precision reaches (reconstruct's own stop is 10⁻¹⁰ of ‖b‖).
pub const WARM_RTOL_FLOOR: f64 = 1e-12;

/// `stop` for the solve of (N + λR) x = b (`rhs`) from `x0`: its relative stop taken
/// against the start's own residual r₀ = b − (N + λR) x₀ when that is the smaller
/// (rtol · min(‖b‖, ‖r₀‖), not below [`WARM_RTOL_FLOOR`] ‖b‖). A solve warm-started from
/// a neighbouring λ′ starts at r₀ = (λ′ − λ) R x₀, which at small λ lies below rtol ‖b‖:
/// stopped against ‖b‖ it takes no step, and its x (a probe's df, a data set's RSS) stays
/// λ′'s (docs/reconstruct.md, "The prior's weight"). Without `x0`, `stop` itself.
pub fn warm_stop(normal: &Normal, rhs: &[f64], x0: Option<&[f64]>, stop: Stop) -> Result<Stop> {
    let Some(x0) = x0 else { return Ok(stop) };
    let bn = dot(rhs, rhs).sqrt();
    if bn == 0.0 {
        return Ok(stop);
    }
    let mut work = normal.work()?;
    let mut r = vec![0.0; rhs.len()];
    normal.apply(x0, &mut work, &mut r);
    let rn = r
        .iter()
        .zip(rhs)
        .map(|(q, b)| (b - q) * (b - q))
        .sum::<f64>()
        .sqrt();
    let rtol = (stop.rtol * (rn / bn).min(1.0)).max(WARM_RTOL_FLOOR.min(stop.rtol));
    Ok(Stop { rtol, ..stop })
}

/// The mean of `v` and its standard error (0 for fewer than two values).
fn mean_and_error(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n.max(1.0);
    if v.len() < 2 {
        return (mean, 0.0);
    }
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// The search's result: the λ of the least score, the rows, the noise factor RSS/(m − df)
/// there, and every λ tried in order.
#[derive(Clone, Debug)]
pub struct Choice {
    pub lam: f64,
    pub rows: usize,
    pub scale: f64,
    pub trials: Vec<Trial>,
}

impl Choice {
    /// The solves the search made (one for the data and one per probe, per λ).
    pub fn solves(&self, probes: usize) -> usize {
        self.trials.len() * (1 + probes)
    }
}

/// out = DᵀD t over the nx × ny grid (the solve's own prior rows at λ = 1).
fn prior(t: &[f64], nx: usize, ny: usize, out: &mut [f64]) {
    for (j, o) in out.chunks_mut(nx).enumerate() {
        super::solve::prior_row(t, (nx, ny), j, 1.0, o);
    }
}

/// A Rademacher vector (±1) of n values from `seed`: the sign bit of a SplitMix64 stream.
fn rademacher(n: usize, seed: u64) -> Vec<f64> {
    let state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    crate::infra::random::splitmix64_stream(state)
        .take(n)
        .map(|z| if z >> 63 == 0 { 1.0 } else { -1.0 })
        .collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// One data vector y the search fits: AᵀWy (`rhs`), Σ w y² (`yy`) and the last solution
/// at it (a warm start; after the search, the solution at the last λ tried).
#[derive(Clone, Debug)]
pub struct DataSet {
    pub rhs: Vec<f64>,
    pub yy: f64,
    pub last: Option<Vec<f64>>,
}

/// The search's state: the equations, the data sets (the equations' own y, or several y
/// over the same rows: [`choose_sets`]; `own`: the equations' own), the rows, the probes
/// and N z for each, and the probes' last solutions (warm starts).
struct Search<'a> {
    normal: &'a mut Normal,
    rule: Rule,
    cfg: Config,
    threads: Option<usize>,
    done: &'a std::sync::atomic::AtomicUsize,
    sets: Vec<DataSet>,
    own: bool,
    rows: usize,
    probes: Vec<(Vec<f64>, Vec<f64>)>,
    u: Vec<Option<Vec<f64>>>,
    scale: Option<f64>,
    trials: Vec<Trial>,
    used: usize,
}

impl Search<'_> {
    /// Whether the next λ's solves, each at its cap, could exceed the budget.
    fn exhausted(&self) -> bool {
        let next =
            self.sets.len() * self.cfg.data.max_iter + self.cfg.probes * self.cfg.probe.max_iter;
        self.used + next > self.cfg.budget
    }

    /// N t = (N + λR) t − λ R t.
    fn data_product(&mut self, t: &[f64]) -> Result<Vec<f64>> {
        let ((nx, ny), lam) = (self.normal.shape(), self.normal.regularization());
        let mut work = self.normal.work()?;
        let mut out = vec![0.0; t.len()];
        self.normal.apply(t, &mut work, &mut out);
        let mut r = vec![0.0; t.len()];
        prior(t, nx, ny, &mut r);
        out.iter_mut().zip(&r).for_each(|(o, r)| *o -= lam * r);
        Ok(out)
    }

    /// The score at λ (and its trial kept).
    fn trial(&mut self, lam: f64) -> Result<f64> {
        self.normal.set_regularization(lam)?;
        let mut data = self.cfg.data;
        if self.rule == Rule::Gcv {
            // W is right up to the factor `scale`: the noise's norm scales with its root.
            match self.scale {
                Some(s) => data.noise *= s.sqrt(),
                None => data.noise = 0.0,
            }
        }
        // The data sets' and the probes' solves, side by side (one CG each), each warm
        // start's relative stop taken against its own residual ([`warm_stop`]).
        let mut jobs: Vec<(Start<'_>, Stop)> = Vec::with_capacity(self.sets.len() + self.u.len());
        for set in &self.sets {
            let start = Start {
                rhs: (!self.own).then_some(set.rhs.as_slice()),
                x0: set.last.as_deref(),
            };
            jobs.push((start, warm_stop(self.normal, &set.rhs, start.x0, data)?));
        }
        for ((_, nz), u) in self.probes.iter().zip(&self.u) {
            let start = Start {
                rhs: Some(nz.as_slice()),
                x0: u.as_deref(),
            };
            jobs.push((start, warm_stop(self.normal, nz, start.x0, self.cfg.probe)?));
        }
        let sols = solve::solve_each(self.normal, &jobs, self.threads, self.done)?;
        drop(jobs);
        let (mut rss, mut iterations) = (0.0, 0);
        let mut sols = sols.into_iter();
        for k in 0..self.sets.len() {
            let Some(sol) = sols.next() else { break };
            iterations += sol.iterations;
            let nt = self.data_product(&sol.cells)?;
            let set = &mut self.sets[k];
            rss += (dot(&sol.cells, &nt) - 2.0 * dot(&sol.cells, &set.rhs) + set.yy).max(0.0);
            set.last = Some(sol.cells);
        }
        // The sets' mean RSS (one set: its own).
        rss /= self.sets.len().max(1) as f64;
        let mut each = Vec::with_capacity(self.probes.len());
        for (k, s) in sols.enumerate() {
            iterations += s.iterations;
            each.push(dot(&self.probes[k].0, &s.cells));
            self.u[k] = Some(s.cells);
        }
        let (df, df_error) = mean_and_error(&each);
        self.used += iterations;
        let m = self.rows as f64;
        let rho = self.cfg.df_weight;
        // GCV's denominator: the rows' freedom the fit leaves. A fit that leaves none
        // within the estimate's error (df → m: it interpolates the data, RSS → 0) is
        // degenerate and never chosen (module doc).
        let free = m - rho * df;
        let score = match self.rule {
            Rule::Upre => rss + 2.0 * rho * df - m,
            Rule::Gcv if free <= (DEGENERATE_ERRORS * rho * df_error).max(1.0) => f64::INFINITY,
            Rule::Gcv => m * rss / (free * free),
        };
        if self.rule == Rule::Gcv && rss > 0.0 {
            self.scale = Some(rss / (m - df).max(1.0));
        }
        self.trials.push(Trial {
            lam,
            score,
            rss,
            df,
            iterations,
        });
        parallel::checkpoint()?;
        Ok(score)
    }
}

/// Choose λ for `normal` by `rule` (see the module doc); `normal` is left at the chosen
/// λ. `done` counts the solves' iterations.
pub fn choose(
    normal: &mut Normal,
    rule: Rule,
    cfg: Config,
    threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<Choice> {
    let n = normal.cells();
    let (_, yy) = normal.data_sums();
    let mut work = normal.work()?;
    let mut rhs = vec![0.0; n];
    normal.rhs(&mut work, &mut rhs);
    drop(work);
    let own = vec![DataSet {
        rhs,
        yy,
        last: None,
    }];
    Ok(search(normal, rule, cfg, (own, true), threads, done)?.0)
}

/// [`choose`] for several data vectors over the same rows (`sets`: each one's AᵀWy and
/// Σ w y², e.g. draws of an image and its noise), by the score of their mean RSS (the
/// mean of their scores, under UPRE and GCV alike: df is the rows' alone). Returns the
/// choice and the sets, each with its solution at the last λ tried.
pub fn choose_sets(
    normal: &mut Normal,
    rule: Rule,
    cfg: Config,
    sets: Vec<DataSet>,
    threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<(Choice, Vec<DataSet>)> {
    let n = normal.cells();
    if sets.is_empty() || sets.iter().any(|s| s.rhs.len() != n) {
        return Err(Error::param(
            "sets",
            sets.len(),
            format!("at least one data set of {n} values (one per cell)"),
        ));
    }
    search(normal, rule, cfg, (sets, false), threads, done)
}

/// The search of [`choose`] over the data sets (`own`: the equations' own data).
fn search(
    normal: &mut Normal,
    rule: Rule,
    cfg: Config,
    (sets, own): (Vec<DataSet>, bool),
    threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<(Choice, Vec<DataSet>)> {
    if !(cfg.df_weight >= 1.0 && cfg.df_weight.is_finite()) {
        return Err(Error::param(
            "df_weight",
            cfg.df_weight.to_string(),
            "finite and at least 1",
        ));
    }
    if !(cfg.lo > 0.0 && cfg.hi > cfg.lo && cfg.hi.is_finite()) {
        return Err(Error::param(
            "regularization",
            format!("a bracket [{}, {}]", cfg.lo, cfg.hi),
            "0 < lo < hi finite",
        ));
    }
    let n = normal.cells();
    let (rows, _) = normal.data_sums();
    let mut search = Search {
        normal,
        rule,
        cfg,
        threads,
        done,
        sets,
        own,
        rows,
        probes: vec![],
        u: vec![None; cfg.probes],
        scale: None,
        trials: vec![],
        used: 0,
    };
    for k in 0..cfg.probes {
        let z = rademacher(n, 0x5eed + k as u64);
        let nz = search.data_product(&z)?;
        search.probes.push((z, nz));
    }
    // Decades down from START_DECADES below the top of the bracket, stopped one past the
    // least score; then up from the start when it stays the least.
    let (l0, l1) = (cfg.lo.log10(), cfg.hi.log10());
    let start = (l1 - START_DECADES).max(l0);
    let down: Vec<f64> = (0..25)
        .map(|k| start - k as f64)
        .take_while(|&e| e >= l0 - 1e-9)
        .collect();
    let up: Vec<f64> = (1..25)
        .map(|k| start + k as f64)
        .take_while(|&e| e <= l1 + 1e-9)
        .collect();
    let mut scores: Vec<(f64, f64)> = vec![];
    walk(&mut search, &down, &mut scores)?;
    if scores.len() > 1 && least(&scores).0 == start {
        walk(&mut search, &up, &mut scores)?;
    }
    if scores.is_empty() {
        return Err(Error::param(
            "regularization",
            "no bracket",
            "a bracket of λ",
        ));
    }
    let best = least(&scores);
    if cfg.parabola && !search.exhausted() {
        if let Some(v) = vertex(&scores, best.0) {
            search.trial(10f64.powf(v))?;
            return finish(search, rows);
        }
    }
    // Golden section over the decades either side of the least (within the bracket).
    let (mut a, mut d) = ((best.0 - 1.0).max(l0), (best.0 + 1.0).min(l1));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c1 = d - g * (d - a);
    let mut c2 = a + g * (d - a);
    if cfg.golden_steps == 0 || search.exhausted() {
        return finish(search, rows);
    }
    let mut f1 = search.trial(10f64.powf(c1))?;
    if search.exhausted() {
        return finish(search, rows);
    }
    let mut f2 = search.trial(10f64.powf(c2))?;
    for _ in 0..cfg.golden_steps.saturating_sub(1) {
        if search.exhausted() {
            break;
        }
        if f1 <= f2 {
            (d, c2, f2) = (c2, c1, f1);
            c1 = d - g * (d - a);
            f1 = search.trial(10f64.powf(c1))?;
        } else {
            (a, c1, f1) = (c1, c2, f2);
            c2 = a + g * (d - a);
            f2 = search.trial(10f64.powf(c2))?;
        }
    }
    finish(search, rows)
}

/// The (log λ, score) of the least score (the first of equals).
fn least(scores: &[(f64, f64)]) -> (f64, f64) {
    scores
        .iter()
        .copied()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((f64::NAN, f64::INFINITY))
}

/// The vertex (log λ) of the parabola through the score at `at` and at the decades either
/// side, when both were tried, the parabola opens upwards and its vertex lies between them.
fn vertex(scores: &[(f64, f64)], at: f64) -> Option<f64> {
    let near = |e: f64| scores.iter().find(|s| (s.0 - e).abs() < 1e-9).map(|s| s.1);
    let (fa, fb, fc) = (near(at - 1.0)?, near(at)?, near(at + 1.0)?);
    let curve = fa - 2.0 * fb + fc;
    let v = at + 0.5 * (fa - fc) / curve;
    (curve > 0.0 && v.is_finite() && (at - 1.0..=at + 1.0).contains(&v)).then_some(v)
}

/// Try the decades `exps` (log λ) in order, each kept in `scores`, until one is tried
/// past the least score (the last tried is not the least) or the budget is spent.
fn walk(search: &mut Search<'_>, exps: &[f64], scores: &mut Vec<(f64, f64)>) -> Result<()> {
    for &e in exps {
        if !scores.is_empty() && search.exhausted() {
            break;
        }
        let s = search.trial(10f64.powf(e))?;
        scores.push((e, s));
        if least(scores).0 != e {
            break;
        }
    }
    Ok(())
}

/// The λ of the least score tried, the equations left at it.
fn finish(search: Search<'_>, rows: usize) -> Result<(Choice, Vec<DataSet>)> {
    let least = search
        .trials
        .iter()
        .min_by(|a, b| a.score.total_cmp(&b.score))
        .copied()
        .ok_or_else(|| Error::param("regularization", "no trial", "a bracket of λ"))?;
    let m = rows as f64;
    let scale = least.rss / (m - least.df).max(1.0);
    let Search {
        normal,
        trials,
        sets,
        ..
    } = search;
    normal.set_regularization(least.lam)?;
    let choice = Choice {
        lam: least.lam,
        rows,
        scale,
        trials,
    };
    Ok((choice, sets))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::solve::{self, Block, Csr};
    use std::sync::atomic::AtomicUsize;

    /// Dense helpers for the exact df and RSS of a small problem.
    fn solve_dense(mut h: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
        let n = b.len();
        for c in 0..n {
            for r in c + 1..n {
                let f = h[r][c] / h[c][c];
                let pivot = h[c].clone();
                for (q, p) in h[r][c..].iter_mut().zip(&pivot[c..]) {
                    *q -= f * p;
                }
                b[r] -= f * b[c];
            }
        }
        let mut x = vec![0.0; n];
        for c in (0..n).rev() {
            let s: f64 = (c + 1..n).map(|k| h[c][k] * x[k]).sum();
            x[c] = (b[c] - s) / h[c][c];
        }
        x
    }

    /// A random blur of a 6 × 5 grid seen by 80 noisy rows: the search's RSS and df at
    /// each λ against the dense hat matrix (df within 3 Hutchinson standard errors of 8
    /// probes, RSS to 10⁻⁸), and the chosen λ the least of a fine dense scan's score
    /// (with the df weight ρ) within a tenth of a decade of score.
    #[test]
    fn trials_are_the_dense_risk() {
        dense_risk(1.0, 1e3);
    }

    /// The same with the bracket's top at 10 (the search starts at 10⁻²): the least lies
    /// above the start, and the search walks up to it (a λ above the start is tried and
    /// the chosen λ is the dense scan's least within the bracket).
    #[test]
    fn the_search_walks_up_from_its_start() {
        let start = 10f64.powf(1.0 - START_DECADES);
        let c = dense_risk(1.0, 1e1);
        let up = c
            .trials
            .iter()
            .any(|t| (t.lam / (10.0 * start) - 1.0).abs() < 1e-9);
        assert!(up && c.lam > start, "{c:?}");
    }

    /// The same with ρ = 2: the least of the weighted score, at a larger λ than ρ = 1's.
    #[test]
    fn weighted_trials_are_the_dense_weighted_risk() {
        assert!(dense_risk(2.0, 1e3).lam > dense_risk(1.0, 1e3).lam);
    }

    /// GCV on 48 wide rows (12 cells each) over 64 cells, the probes solved loosely (10⁻³):
    /// the trials' df and RSS the dense ones', the choice the dense GCV score's least, and
    /// no trial whose fit leaves fewer than 3 Hutchinson errors of the rows' freedom is
    /// chosen (λ ≤ 1 here: df 47 of 48 rows, the old clamp's score m RSS ≈ 0).
    #[test]
    fn gcv_never_chooses_a_degenerate_fit() {
        let c = dense_case(Rule::Gcv, (1.0, 1e3, 1e-3), (8, 8, 48, 12));
        let degenerate = c.trials.iter().filter(|t| t.score.is_infinite()).count();
        assert!(degenerate > 0 && c.lam > 1.0, "{c:?}");
    }

    /// A solve warm-started from a neighbouring λ (10⁻³ away) starts within 10⁻⁶ of ‖b‖:
    /// stopped at 10⁻⁴ of ‖b‖ it took no step and kept the old λ's x. [`warm_stop`] stops it
    /// against its own residual: it steps, and lands within 10⁻³ of the change on the dense
    /// solution (issue 49; docs/reconstruct.md, "The prior's weight").
    #[test]
    fn a_warm_start_is_stopped_against_its_own_residual() {
        let (mut normal, nz, dense) = small_case();
        let tight = Stop::relative(1e-13, 10_000);
        let done = AtomicUsize::new(0);
        let start = |x0| Start {
            rhs: Some(nz.as_slice()),
            x0,
        };
        let old = solve::solve_from(&normal, start(None), tight, Some(1), &done).unwrap();
        normal.set_regularization(0.999).unwrap();
        let loose = Stop::relative(1e-4, 10_000);
        let stop = warm_stop(&normal, &nz, Some(&old.cells), loose).unwrap();
        assert!(
            stop.rtol < 1e-4 * loose.rtol && stop.rtol >= WARM_RTOL_FLOOR,
            "{stop:?}"
        );
        let new = solve::solve_from(&normal, start(Some(&old.cells)), stop, Some(1), &done);
        let new = new.unwrap();
        let exact = dense(0.999);
        let change: f64 = old
            .cells
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).powi(2))
            .sum();
        let err: f64 = new
            .cells
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).powi(2))
            .sum();
        assert!(
            new.iterations > 0 && err.sqrt() < 1e-3 * change.sqrt(),
            "{err} {change}"
        );
        // Against ‖b‖ alone: no step, the old λ's x.
        let stale = solve::solve_from(&normal, start(Some(&old.cells)), loose, Some(1), &done);
        assert_eq!(stale.unwrap().iterations, 0);
    }

    /// The 6 × 5 grid of `dense_case` at λ = 1 with a probe's right-hand side N z, and the
    /// dense solution of (N + λR) x = N z at λ.
    fn small_case() -> (Normal, Vec<f64>, impl Fn(f64) -> Vec<f64>) {
        let (nx, ny, m) = (6usize, 5usize, 80usize);
        let n = nx * ny;
        let u = rademacher(4 * m, 3);
        let mut dense = vec![vec![0.0; n]; m];
        let (mut indptr, mut indices, mut data) = (vec![0usize], vec![], vec![]);
        for (r, row) in dense.iter_mut().enumerate() {
            for k in 0..4 {
                let c = (r * 7 + k) % n;
                row[c] += 0.5 + 0.2 * u[r * 4 + k];
                indices.push(c as u32);
                data.push(row[c]);
            }
            indptr.push(data.len());
        }
        let a = Csr::new("rows", indptr, indices, data, n).unwrap();
        let block = Block::Rows {
            a,
            w: vec![400.0; m],
            y: vec![0.0; m],
        };
        let normal = Normal::new(nx, ny, 1.0, vec![block]).unwrap();
        let mut nmat = vec![vec![0.0; n]; n];
        for row in &dense {
            for i in 0..n {
                for j in 0..n {
                    nmat[i][j] += 400.0 * row[i] * row[j];
                }
            }
        }
        let z = rademacher(n, 0x5eed);
        let nz: Vec<f64> = nmat.iter().map(|row| dot(row, &z)).collect();
        let rhs = nz.clone();
        let exact = move |lam: f64| {
            let mut h = nmat.clone();
            let mut e = vec![0.0; n];
            let mut r = vec![0.0; n];
            for i in 0..n {
                e.fill(0.0);
                e[i] = 1.0;
                prior(&e, nx, ny, &mut r);
                for j in 0..n {
                    h[j][i] += lam * r[j];
                }
            }
            solve_dense(h, rhs.clone())
        };
        (normal, nz, exact)
    }

    /// `trials_are_the_dense_risk` at ρ over the bracket [10⁻³, hi]; the choice.
    fn dense_risk(df_weight: f64, hi: f64) -> Choice {
        dense_case(Rule::Upre, (df_weight, hi, 1e-13), (6, 5, 80, 4))
    }

    /// The dense RSS and df at λ of the rows `dense` (weights `w`, data `y`) over an
    /// nx × ny grid with the first-difference prior.
    fn dense_hat(
        dense: &[Vec<f64>],
        w: &[f64],
        y: &[f64],
        (nx, ny): (usize, usize),
        lam: f64,
    ) -> (f64, f64) {
        let (n, m) = (nx * ny, dense.len());
        let mut nmat = vec![vec![0.0; n]; n];
        for (row, &wr) in dense.iter().zip(w) {
            for i in 0..n {
                for j in 0..n {
                    nmat[i][j] += wr * row[i] * row[j];
                }
            }
        }
        let mut h = nmat.clone();
        let mut e = vec![0.0; n];
        for i in 0..n {
            e.fill(0.0);
            e[i] = 1.0;
            let mut r = vec![0.0; n];
            prior(&e, nx, ny, &mut r);
            for j in 0..n {
                h[j][i] += lam * r[j];
            }
        }
        let mut df = 0.0;
        for (i, row) in nmat.iter().enumerate() {
            // N is symmetric: its column i is its row i.
            df += solve_dense(h.clone(), row.clone())[i];
        }
        let rhs: Vec<f64> = (0..n)
            .map(|i| (0..m).map(|r| dense[r][i] * w[r] * y[r]).sum())
            .collect();
        let t = solve_dense(h, rhs);
        let rss: f64 = (0..m)
            .map(|r| w[r] * (dot(&dense[r], &t) - y[r]).powi(2))
            .sum();
        (rss, df)
    }

    /// The dense check of the trials and the choice by `rule` at ρ over [10⁻³, hi], the
    /// probes solved to `probe_rtol` (the data to 10⁻¹³).
    fn dense_case(
        rule: Rule,
        (df_weight, hi, probe_rtol): (f64, f64, f64),
        (nx, ny, m, width): (usize, usize, usize, usize),
    ) -> Choice {
        let n = nx * ny;
        let u = rademacher(width * m * n, 3);
        let mut dense = vec![vec![0.0; n]; m];
        let (mut indptr, mut indices, mut data) = (vec![0usize], vec![], vec![]);
        for (r, row) in dense.iter_mut().enumerate() {
            let c0 = (r * 7) % n;
            for k in 0..width {
                let c = (c0 + k) % n;
                row[c] += 0.5 + 0.2 * u[r * width + k];
            }
            for (c, &v) in row.iter().enumerate() {
                if v != 0.0 {
                    indices.push(c as u32);
                    data.push(v);
                }
            }
            indptr.push(data.len());
        }
        let truth: Vec<f64> = (0..n)
            .map(|c| 0.5 + 0.3 * ((c as f64) * 0.7).sin())
            .collect();
        let y: Vec<f64> = dense
            .iter()
            .enumerate()
            .map(|(r, row)| dot(row, &truth) + 0.05 * u[m * n + r])
            .collect();
        let w = vec![400.0; m];
        let a = Csr::new("rows", indptr, indices, data, n).unwrap();
        let block = Block::Rows {
            a,
            w: w.clone(),
            y: y.clone(),
        };
        let mut normal = Normal::new(nx, ny, 1.0, vec![block]).unwrap();
        let cfg = Config {
            lo: 1e-3,
            hi,
            golden_steps: 8,
            probes: 8,
            budget: 1_000_000,
            data: Stop::relative(1e-13, 10_000),
            probe: Stop::relative(probe_rtol, 10_000),
            df_weight,
            parabola: false,
        };
        let done = AtomicUsize::new(0);
        let c = choose(&mut normal, rule, cfg, Some(1), &done).unwrap();
        let hat = |lam: f64| dense_hat(&dense, &w, &y, (nx, ny), lam);
        for t in &c.trials {
            let (rss, df) = hat(t.lam);
            assert!((t.rss - rss).abs() <= 1e-8 * rss.max(1.0), "{t:?} {rss}");
            // Hutchinson's variance is at most 2 ‖M‖_F² ≤ 2 n per probe.
            let se = (2.0 * n as f64 / cfg.probes as f64).sqrt();
            assert!((t.df - df).abs() <= 3.0 * se, "{t:?} {df}");
        }
        // The dense score, and the slack of the chosen λ's against the scan's least.
        let mf = m as f64;
        let (score, slack) = match rule {
            Rule::Upre => (
                Box::new(move |rss: f64, df: f64| rss + 2.0 * df_weight * df - mf)
                    as Box<dyn Fn(f64, f64) -> f64>,
                1.5,
            ),
            Rule::Gcv => (
                Box::new(move |rss: f64, df: f64| mf * rss / (mf - df_weight * df).powi(2))
                    as Box<dyn Fn(f64, f64) -> f64>,
                // V ≈ U / m + 1 near the least (unit noise): twice UPRE's slack over m
                // (the wide rows' df, 40 of 48, moves V by 2 δdf / (m − df)).
                3.0 / mf,
            ),
        };
        let steps = ((hi.log10() + 3.0) / 0.05).round() as usize;
        let scan = (0..=steps)
            .map(|k| 10f64.powf(-3.0 + k as f64 * 0.05))
            .map(|l| {
                let (rss, df) = hat(l);
                (l, score(rss, df))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let (rss, df) = hat(c.lam);
        let chosen = score(rss, df);
        assert!(chosen <= scan.1 + slack, "{} ({chosen}) vs {scan:?}", c.lam);
        assert_eq!(normal.regularization(), c.lam);
        c
    }

    /// The parabola's vertex through three decades: a quadratic's own minimum; none
    /// when a neighbour is missing or the three lie on a line or open downwards.
    #[test]
    fn vertex_is_the_quadratics_minimum() {
        let q = |e: f64| 3.0 * (e - 1.37) * (e - 1.37) + 5.0;
        let scores: Vec<(f64, f64)> = [0.0, 1.0, 2.0, 3.0].iter().map(|&e| (e, q(e))).collect();
        let v = vertex(&scores, 1.0).unwrap();
        assert!((v - 1.37).abs() < 1e-12, "{v}");
        assert!(vertex(&scores[..2], 1.0).is_none());
        let line: Vec<(f64, f64)> = [0.0, 1.0, 2.0].iter().map(|&e| (e, 2.0 * e)).collect();
        assert!(vertex(&line, 1.0).is_none());
        let cap: Vec<(f64, f64)> = [0.0, 1.0, 2.0].iter().map(|&e| (e, -q(e))).collect();
        assert!(vertex(&cap, 1.0).is_none());
    }

    #[test]
    fn rademacher_is_balanced_and_fixed() {
        let z = rademacher(10_000, 1);
        assert!(z.iter().all(|&v| v == 1.0 || v == -1.0));
        assert!(z.iter().sum::<f64>().abs() < 300.0);
        assert_eq!(z, rademacher(10_000, 1));
        assert_ne!(z, rademacher(10_000, 2));
    }
}
