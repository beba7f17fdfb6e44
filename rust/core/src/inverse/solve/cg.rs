//! The conjugate gradients on the normal equations ([`solve`]) and when they stop
//! ([`Stop`]: the relative residual, or the noise's expected norm, or the iteration cap).

use rayon::prelude::*;

use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel;

use super::kernels::{dot, norm};
use super::normal::{Normal, Work};

/// The solve's result: the cells (row-major, row 0 at the top), the iterations CG took (over
/// every pass), the normal equations' relative residual ‖(AᵀWA + λDᵀD) t − AᵀWy‖ / ‖AᵀWy‖
/// at the end (of the last pass's weighted equations), the prior's passes (1 for the
/// quadratic prior) and the RMS change of the cells over the last pass (0 after one).
pub struct Solution {
    pub cells: Vec<f64>,
    pub iterations: usize,
    pub residual: f64,
    pub passes: usize,
    pub change: f64,
}

/// Wall time of one batch of iterations between two interrupt checks on the calling thread.
const BATCH: std::time::Duration = std::time::Duration::from_millis(40);

/// When [`solve`] stops: after `max_iter` steps, or once ‖r‖ < max(rtol ‖AᵀWy‖,
/// noise ν), where ν = √trace(AᵀWA) is the expected norm of the noise's part of AᵀWy when
/// W is the rows' inverse noise variance (E[AᵀW n nᵀ W A] = AᵀWA): `noise` = 0 for a
/// raw whose noise is not known. Under an edge-preserving prior, each pass stops so.
#[derive(Clone, Copy, Debug)]
pub struct Stop {
    pub rtol: f64,
    pub noise: f64,
    pub max_iter: usize,
}

impl Stop {
    /// A stop on the relative residual alone.
    pub fn relative(rtol: f64, max_iter: usize) -> Stop {
        Stop {
            rtol,
            noise: 0.0,
            max_iter,
        }
    }
}

/// The vectors of a solve: the right-hand side b, the Jacobi diagonal, the data's part of
/// it (kept for the passes after the first; empty with one pass), the previous pass's
/// cells (and AᵀWA·1 at the start), the cells x, the residual r, the direction p and the
/// product q; this pass's iterations, the last ρ, the stop's threshold and ‖b‖.
struct State {
    b: Vec<f64>,
    diag: Vec<f64>,
    data: Vec<f64>,
    prev: Vec<f64>,
    x: Vec<f64>,
    r: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    it: usize,
    rho_prev: f64,
    tol: f64,
    bn: f64,
}

impl State {
    fn new(n: usize, passes: bool) -> Result<State> {
        let vec = |v: f64| memory::try_vec("the solve's vectors", n, v);
        Ok(State {
            b: vec(0.0)?,
            diag: vec(0.0)?,
            data: if passes { vec(0.0)? } else { vec![] },
            prev: vec(0.0)?,
            x: vec(0.0)?,
            r: vec(0.0)?,
            p: vec(0.0)?,
            q: vec(0.0)?,
            it: 0,
            rho_prev: 0.0,
            tol: 0.0,
            bn: 0.0,
        })
    }

    /// The right-hand side, the diagonal, the start and its residual; false when b = 0
    /// (then x = 0 and there is nothing to do).
    fn start(&mut self, normal: &Normal, work: &mut Work, from: Start, tols: (f64, f64)) -> bool {
        let (rtol, noise) = tols;
        match from.rhs {
            Some(v) => self.b.copy_from_slice(v),
            None => normal.rhs(work, &mut self.b),
        }
        let trace = normal.diagonal(work, &mut self.diag);
        if !self.data.is_empty() {
            self.data.copy_from_slice(&self.diag);
        }
        normal.add_prior_diagonal(work, &mut self.diag);
        if let Some(v) = from.x0 {
            self.x.copy_from_slice(v);
        } else {
            // AᵀWA·1 into prev, with p (not needed before the first step) as the ones.
            let seen = &mut self.prev;
            self.p.fill(1.0);
            normal.apply(&self.p, work, seen);
            let mean = self.b.iter().sum::<f64>() / seen.iter().sum::<f64>().max(1e-300);
            self.x
                .par_iter_mut()
                .zip(self.b.par_iter().zip(seen.par_iter()))
                .for_each(|(x, (&b, &s))| *x = if s > 0.0 { b / s } else { mean });
        }
        self.bn = norm(&self.b);
        if self.bn == 0.0 {
            self.x.fill(0.0);
            return false;
        }
        self.tol = (rtol * self.bn).max(noise * trace.sqrt());
        self.residual(normal, work);
        true
    }

    /// r = b − (the normal matrix) x, and CG restarted (the next step is a steepest one).
    fn residual(&mut self, normal: &Normal, work: &mut Work) {
        normal.apply(&self.x, work, &mut self.q);
        self.r
            .par_iter_mut()
            .zip(self.b.par_iter().zip(self.q.par_iter()))
            .for_each(|(r, (&b, &q))| *r = b - q);
        self.it = 0;
    }

    /// One CG step.
    fn step(&mut self, normal: &Normal, work: &mut Work) {
        // z = r / diag, kept in q until the product overwrites it.
        self.q
            .par_iter_mut()
            .zip(self.r.par_iter().zip(self.diag.par_iter()))
            .for_each(|(z, (&r, &d))| *z = r / if d > 0.0 { d } else { 1.0 });
        if let Some(c) = &normal.coarse {
            c.add_correction(&self.r, &mut self.q);
        }
        let rho = dot(&self.r, &self.q);
        if self.it == 0 {
            self.p.copy_from_slice(&self.q);
        } else {
            let beta = rho / self.rho_prev;
            self.p
                .par_iter_mut()
                .zip(self.q.par_iter())
                .for_each(|(p, &z)| *p = beta * *p + z);
        }
        normal.apply(&self.p, work, &mut self.q);
        let alpha = rho / dot(&self.p, &self.q);
        self.x
            .par_iter_mut()
            .zip(self.p.par_iter())
            .for_each(|(x, &p)| *x += alpha * p);
        self.r
            .par_iter_mut()
            .zip(self.q.par_iter())
            .for_each(|(r, &q)| *r -= alpha * q);
        (self.it, self.rho_prev) = (self.it + 1, rho);
    }

    /// The next IRLS pass: the cells kept as the previous ones, the prior's weights from
    /// them, the diagonal and the residual of the reweighted equations (warm start).
    fn next_pass(&mut self, normal: &Normal, work: &mut Work) -> Result<()> {
        self.prev.copy_from_slice(&self.x);
        normal.reweight(&self.x, work)?;
        self.diag.copy_from_slice(&self.data);
        normal.add_prior_diagonal(work, &mut self.diag);
        self.residual(normal, work);
        Ok(())
    }

    /// RMS of x − prev.
    fn change(&self) -> f64 {
        let s: f64 = self
            .x
            .iter()
            .zip(&self.prev)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        (s / self.x.len().max(1) as f64).sqrt()
    }
}

/// Solve the normal equations by Jacobi-preconditioned conjugate gradients, SciPy's `cg`
/// iteration: start from the normalised back-projection (AᵀWy / AᵀWA·1; cells no row sees
/// start at Σ AᵀWy / Σ AᵀWA·1), stop as `stop` says (with `stop.noise` = 0, SciPy's
/// ‖r‖ < rtol ‖AᵀWy‖). Under an edge-preserving prior ([`super::Prior`]) this is the
/// first pass, and each further pass solves the reweighted equations from the last cells
/// until the cells move by less than the prior's `tol` or its passes are spent. `done`
/// counts iterations (progress, over every pass); Ctrl-C is checked between batches of
/// about 40 ms and between passes.
pub fn solve(
    normal: &Normal,
    stop: Stop,
    n_threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<Solution> {
    solve_from(normal, Start::default(), stop, n_threads, done)
}

/// Where [`solve_from`] starts: the right-hand side (None: AᵀWy) and the first iterate
/// (None: the normalised back-projection of the right-hand side). A warm start (the
/// solution at a nearby λ) and other right-hand sides (a trace estimate's probe) serve
/// the choice of λ (`inverse::choose`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Start<'a> {
    pub rhs: Option<&'a [f64]>,
    pub x0: Option<&'a [f64]>,
}

/// [`solve`] from `start`.
pub fn solve_from(
    normal: &Normal,
    start: Start<'_>,
    stop: Stop,
    n_threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<Solution> {
    parallel::check_threads(n_threads)?;
    solve_driven(normal, start, stop, done, |step| {
        parallel::repeat_until(n_threads, step)
    })
}

/// Several solves of the same equations (each `(start, stop)`: a right-hand side and its
/// stop), run side by side in the pool of `n_threads`, one CG per right-hand side (each
/// one's products split further when a thread is free): the solutions in the order of
/// `jobs`, each the one [`solve_from`] gives (the same numbers: every product's order of
/// summation is fixed). Ctrl-C is checked inside every solve.
pub fn solve_each(
    normal: &Normal,
    jobs: &[(Start<'_>, Stop)],
    n_threads: Option<usize>,
    done: &std::sync::atomic::AtomicUsize,
) -> Result<Vec<Solution>> {
    let mut out = Ok(vec![]);
    parallel::for_chunks(n_threads, 1, 1, |_| {
        out = jobs
            .par_iter()
            .map(|&(start, stop)| solve_driven(normal, start, stop, done, parallel::repeat_here))
            .collect();
        Ok(())
    })?;
    out
}

/// The CG of [`solve_from`], its batches of iterations run by `drive` (in a pool of its
/// own, or on the pool the caller runs on).
fn solve_driven(
    normal: &Normal,
    start: Start<'_>,
    stop: Stop,
    done: &std::sync::atomic::AtomicUsize,
    drive: impl FnOnce(&mut (dyn FnMut() -> Result<bool> + Send)) -> Result<()>,
) -> Result<Solution> {
    let Stop {
        rtol,
        noise,
        max_iter,
    } = stop;
    if !(rtol.is_finite() && rtol > 0.0) {
        return Err(Error::param("rtol", rtol, "a finite value > 0"));
    }
    if !(noise.is_finite() && noise >= 0.0) {
        return Err(Error::param("noise_tol", noise, "a finite value >= 0"));
    }
    let n = normal.cells();
    let prior = normal.prior();
    let vectors = if prior.passes > 1 { 8 } else { 7 };
    for (field, v) in [("rhs", start.rhs), ("x0", start.x0)] {
        if v.is_some_and(|v| v.len() != n) {
            return Err(Error::param(
                field,
                "a vector",
                format!("{n} values (one per cell)"),
            ));
        }
    }
    memory::check(
        "the solve's vectors",
        memory::bytes_of::<f64>(vectors * n as u128) + normal.work_bytes(),
    )?;
    let mut work = normal.work()?;
    let mut s = State::new(n, prior.passes > 1)?;
    let (mut first, mut iterations, mut passes, mut change) = (true, 0usize, 0usize, 0.0);
    drive(&mut || {
        if first {
            first = false;
            let go = s.start(normal, &mut work, start, (rtol, noise));
            passes = 1;
            return Ok(!go);
        }
        let start = std::time::Instant::now();
        loop {
            if s.it >= max_iter || norm(&s.r) < s.tol {
                if passes >= prior.passes {
                    return Ok(true);
                }
                if passes > 1 {
                    change = s.change();
                    if change <= prior.tol {
                        return Ok(true);
                    }
                }
                s.next_pass(normal, &mut work)?;
                passes += 1;
                return Ok(false);
            }
            s.step(normal, &mut work);
            iterations += 1;
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            parallel::checkpoint()?;
            if start.elapsed() >= BATCH {
                return Ok(false);
            }
        }
    })?;
    // The true residual of the result (not the recurrence's).
    let State {
        x, b, mut q, bn, ..
    } = s;
    normal.apply(&x, &mut work, &mut q);
    q.iter_mut().zip(&b).for_each(|(q, b)| *q -= b);
    let residual = if bn > 0.0 { norm(&q) / bn } else { 0.0 };
    Ok(Solution {
        cells: x,
        iterations,
        residual,
        passes,
        change,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::solve::testing::{factored, rows_of};
    use crate::inverse::solve::Block;
    use std::sync::atomic::AtomicUsize;

    /// The direct solution of (AᵀWA + λDᵀD) t = AᵀWy by Gaussian elimination.
    fn direct(
        dense: &[Vec<f64>],
        w: &[f64],
        y: &[f64],
        nx: usize,
        ny: usize,
        lam: f64,
    ) -> Vec<f64> {
        let n = nx * ny;
        let mut h = vec![vec![0.0; n + 1]; n];
        for (k, row) in dense.iter().enumerate() {
            for c in 0..n {
                h[c][n] += row[c] * w[k] * y[k];
                for d in 0..n {
                    h[c][d] += row[c] * w[k] * row[d];
                }
            }
        }
        let mut pair = |p: usize, q: usize| {
            h[p][p] += lam;
            h[q][q] += lam;
            h[p][q] -= lam;
            h[q][p] -= lam;
        };
        for j in 0..ny {
            for i in 0..nx {
                if i + 1 < nx {
                    pair(j * nx + i, j * nx + i + 1);
                }
                if j + 1 < ny {
                    pair(j * nx + i, (j + 1) * nx + i);
                }
            }
        }
        for c in 0..n {
            let piv = (c..n)
                .max_by(|&a, &b| h[a][c].abs().total_cmp(&h[b][c].abs()))
                .unwrap();
            h.swap(c, piv);
            for r in 0..n {
                if r != c {
                    let f = h[r][c] / h[c][c];
                    let pivot = h[c].clone();
                    for (q, p) in h[r][c..].iter_mut().zip(&pivot[c..]) {
                        *q -= f * p;
                    }
                }
            }
        }
        (0..n).map(|c| h[c][n] / h[c][c]).collect()
    }

    #[test]
    fn cg_reaches_the_direct_solution_in_both_forms_at_any_thread_count() {
        let (nx, ny, lam) = (9, 8, 0.2);
        let (block, dense, w, y) = factored(nx, ny);
        let want = direct(&dense, &w, &y, nx, ny, lam);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let rows = rows_of(&dense, w, y);
        let mut results = vec![];
        for b in [block, rows] {
            let normal = Normal::new(nx, ny, lam, vec![b]).unwrap();
            for threads in [Some(1), Some(2)] {
                let done = AtomicUsize::new(0);
                let s = solve(&normal, Stop::relative(1e-14, 10_000), threads, &done).unwrap();
                assert!(s.iterations > 0 && s.iterations < 10_000);
                assert_eq!(
                    done.load(std::sync::atomic::Ordering::Relaxed),
                    s.iterations
                );
                assert!(s.residual < 1e-12, "{}", s.residual);
                let err = s
                    .cells
                    .iter()
                    .zip(&want)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(err <= 1e-10 * scale, "{err}");
                results.push(s.cells);
            }
        }
        // Thread-independent bit for bit within a form.
        assert_eq!(results[0], results[1]);
        assert_eq!(results[2], results[3]);
    }

    /// Several solves side by side: each the one `solve_from` gives alone, bit for bit
    /// (its own right-hand side, start and stop), at 1 and 2 threads, the iterations all
    /// counted; the one on the equations' own data the direct solution.
    #[test]
    fn solves_side_by_side_are_the_solves_alone() {
        let (nx, ny, lam) = (9, 8, 0.2);
        let (block, dense, w, y) = factored(nx, ny);
        let want = direct(&dense, &w, &y, nx, ny, lam);
        let normal = Normal::new(nx, ny, lam, vec![block]).unwrap();
        let n = nx * ny;
        let b1: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
        let x1: Vec<f64> = (0..n).map(|i| 0.1 * (i % 3) as f64).collect();
        let b2: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let (tight, loose) = (Stop::relative(1e-14, 10_000), Stop::relative(1e-3, 10_000));
        let jobs = [
            (Start::default(), tight),
            (
                Start {
                    rhs: Some(&b1),
                    x0: Some(&x1),
                },
                tight,
            ),
            (
                Start {
                    rhs: Some(&b2),
                    x0: None,
                },
                loose,
            ),
        ];
        for threads in [Some(1), Some(2)] {
            let done = AtomicUsize::new(0);
            let all = solve_each(&normal, &jobs, threads, &done).unwrap();
            assert_eq!(all.len(), 3);
            let mut total = 0;
            for (s, &(start, stop)) in all.iter().zip(&jobs) {
                let alone =
                    solve_from(&normal, start, stop, Some(1), &AtomicUsize::new(0)).unwrap();
                assert_eq!(s.cells, alone.cells);
                assert_eq!(s.iterations, alone.iterations);
                total += s.iterations;
            }
            assert_eq!(done.load(std::sync::atomic::Ordering::Relaxed), total);
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = all[0]
                .cells
                .iter()
                .zip(&want)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(err <= 1e-10 * scale, "{err}");
        }
        assert!(solve_each(&normal, &jobs, Some(0), &AtomicUsize::new(0)).is_err());
    }

    /// The noise stop is the relative stop at rtol = τ √trace(AᵀWA) / ‖AᵀWy‖, the trace
    /// (Σ_rows w ‖row‖²) and the right-hand side taken here from the dense rows: the same
    /// iterations and the same cells, in both forms, and fewer iterations than rtol alone.
    #[test]
    fn noise_stop_is_the_relative_stop_at_the_noise_norm() {
        let (nx, ny, lam, tau) = (9, 8, 0.2, 1e-3);
        let (block, dense, w, y) = factored(nx, ny);
        let trace: f64 = dense
            .iter()
            .zip(&w)
            .map(|(row, &w)| w * row.iter().map(|v| v * v).sum::<f64>())
            .sum();
        let rhs: Vec<f64> = (0..nx * ny)
            .map(|c| {
                dense
                    .iter()
                    .zip(&w)
                    .zip(&y)
                    .map(|((r, w), y)| r[c] * w * y)
                    .sum()
            })
            .collect();
        let bn = norm(&rhs);
        let rows = rows_of(&dense, w, y);
        for b in [block, rows] {
            let normal = Normal::new(nx, ny, lam, vec![b]).unwrap();
            let done = AtomicUsize::new(0);
            let stop = Stop {
                rtol: 1e-14,
                noise: tau,
                max_iter: 10_000,
            };
            let noisy = solve(&normal, stop, None, &done).unwrap();
            let rtol = tau * trace.sqrt() / bn;
            let relative = solve(&normal, Stop::relative(rtol, 10_000), None, &done).unwrap();
            let tight = solve(&normal, Stop::relative(1e-14, 10_000), None, &done).unwrap();
            assert!(rtol > 1e-9 && noisy.iterations > 0, "{rtol}");
            assert!(noisy.iterations < tight.iterations);
            assert_eq!(noisy.iterations, relative.iterations);
            assert_eq!(noisy.cells, relative.cells);
        }
        let normal = Normal::new(nx, ny, lam, vec![factored(nx, ny).0]).unwrap();
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let stop = Stop {
                rtol: 1e-10,
                noise: bad,
                max_iter: 10,
            };
            let Err(e) = solve(&normal, stop, None, &AtomicUsize::new(0)) else {
                panic!("noise_tol {bad} was taken");
            };
            assert!(e.to_string().contains("noise_tol"), "{e}");
        }
    }

    /// The gradient of the objective Σ w (row · t − y)² + λ Σ_e ρ(r_e) at t, from the dense
    /// rows and ρ' written out here (Huber's: 2r, or 2 s sign r beyond s; TV's: r/ε, or
    /// sign r beyond ε).
    fn gradient(
        dense: &[Vec<f64>],
        w: &[f64],
        y: &[f64],
        (nx, ny, lam): (usize, usize, f64),
        penalty: crate::inverse::solve::Penalty,
        t: &[f64],
    ) -> Vec<f64> {
        use crate::inverse::solve::Penalty;
        let mut g = vec![0.0; nx * ny];
        for ((row, &w), &y) in dense.iter().zip(w).zip(y) {
            let res: f64 = row.iter().zip(t).map(|(a, b)| a * b).sum::<f64>() - y;
            for (g, a) in g.iter_mut().zip(row) {
                *g += 2.0 * w * res * a;
            }
        }
        let d = |r: f64| match penalty {
            Penalty::Quadratic => 2.0 * r,
            Penalty::Huber { threshold: s } => 2.0 * r.clamp(-s, s),
            Penalty::Tv { smoothing: e } => (r / e).clamp(-1.0, 1.0),
        };
        for j in 0..ny {
            for i in 0..nx {
                let c = j * nx + i;
                for (ok, o) in [(i + 1 < nx, c + 1), (j + 1 < ny, c + nx)] {
                    if ok {
                        let r = t[o] - t[c];
                        g[o] += lam * d(r);
                        g[c] -= lam * d(r);
                    }
                }
            }
        }
        g
    }

    /// IRLS reaches the edge-preserving objective's minimum: its gradient (written out
    /// independently above) vanishes at the cells, in both forms of the map, for Huber and
    /// TV with thresholds that some differences exceed; and each pass's objective is no
    /// higher than the last's (the weights make a quadratic majorant).
    #[test]
    fn irls_reaches_the_edge_preserving_optimum() {
        use crate::inverse::solve::{Penalty, Prior};
        let (nx, ny, lam) = (9, 8, 0.02);
        let (block, dense, w, y) = factored(nx, ny);
        let rows = rows_of(&dense, w.clone(), y.clone());
        for penalty in [
            Penalty::Huber { threshold: 0.05 },
            Penalty::Tv { smoothing: 0.02 },
        ] {
            for b in [block.clone(), rows.clone()] {
                let prior = Prior {
                    penalty,
                    passes: 500,
                    tol: 1e-13,
                };
                let normal = Normal::new(nx, ny, lam, vec![b])
                    .unwrap()
                    .with_prior(prior)
                    .unwrap();
                let done = AtomicUsize::new(0);
                let s = solve(&normal, Stop::relative(1e-14, 10_000), None, &done).unwrap();
                assert!(s.passes > 3 && s.passes < 500, "{} passes", s.passes);
                assert!(s.change <= 1e-13);
                assert_eq!(
                    done.load(std::sync::atomic::Ordering::Relaxed),
                    s.iterations
                );
                let g = gradient(&dense, &w, &y, (nx, ny, lam), penalty, &s.cells);
                let gmax = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                // Some differences are beyond the threshold: the prior is not quadratic here.
                let beyond = (0..nx * ny - 1)
                    .filter(|&c| (s.cells[c + 1] - s.cells[c]).abs() > 0.05)
                    .count();
                assert!(beyond > 5, "{beyond}");
                assert!(gmax < 1e-9, "{penalty:?}: gradient {gmax}");
            }
        }
    }

    /// The quadratic prior is the solve it was: `with_prior(quadratic)` gives the same bits
    /// as no prior given, and the weighted difference operator with every weight 1 is the
    /// unweighted one bit for bit.
    #[test]
    fn quadratic_prior_is_the_plain_solve() {
        use crate::inverse::solve::{Penalty, Prior};
        let (nx, ny, lam) = (9, 8, 0.2);
        let (block, ..) = factored(nx, ny);
        let plain = Normal::new(nx, ny, lam, vec![block.clone()]).unwrap();
        let quad = Normal::new(nx, ny, lam, vec![block.clone()])
            .unwrap()
            .with_prior(Prior::quadratic())
            .unwrap();
        let run = |n: &Normal| {
            solve(n, Stop::relative(1e-12, 10_000), None, &AtomicUsize::new(0))
                .unwrap()
                .cells
        };
        assert_eq!(run(&plain), run(&quad));
        // Weights all 1 (Huber with a threshold no difference reaches).
        let huge = Prior {
            penalty: Penalty::Huber { threshold: 1e9 },
            passes: 2,
            tol: 0.0,
        };
        let huber = Normal::new(nx, ny, lam, vec![block])
            .unwrap()
            .with_prior(huge)
            .unwrap();
        let t: Vec<f64> = (0..nx * ny)
            .map(|k| ((k * 29) % 13) as f64 / 13.0)
            .collect();
        let (mut a, mut b) = (vec![0.0; nx * ny], vec![0.0; nx * ny]);
        let mut work = plain.work().unwrap();
        plain.apply(&t, &mut work, &mut a);
        let mut work = huber.work().unwrap();
        huber.reweight(&t, &mut work).unwrap();
        assert!(work.edges.is_some());
        huber.apply(&t, &mut work, &mut b);
        assert_eq!(a, b);
        let (mut da, mut db) = (vec![0.5; nx * ny], vec![0.5; nx * ny]);
        plain.add_prior_diagonal(&plain.work().unwrap(), &mut da);
        huber.add_prior_diagonal(&work, &mut db);
        assert_eq!(da, db);
    }

    #[test]
    fn bad_priors_name_their_field() {
        use crate::inverse::solve::Prior;
        let name = |r: Result<Prior>| r.err().unwrap().parameter_name().unwrap();
        assert_eq!(name(Prior::from_parts("l1", 0.1, 10, 1e-3)), "prior");
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(name(Prior::from_parts("huber", bad, 10, 1e-3)), "threshold");
            assert_eq!(name(Prior::from_parts("tv", bad, 10, 1e-3)), "threshold");
        }
        assert_eq!(
            name(Prior::from_parts("huber", 0.1, 0, 1e-3)),
            "prior_passes"
        );
        assert_eq!(name(Prior::from_parts("tv", 0.1, 5, f64::NAN)), "prior_tol");
        // The quadratic prior takes no threshold and runs one pass.
        let q = Prior::from_parts("quadratic", f64::NAN, 7, 0.0).unwrap();
        assert_eq!(q, Prior::quadratic());
    }

    #[test]
    fn zero_data_gives_zero_cells() {
        let (nx, ny) = (9, 8);
        let (mut zero, ..) = factored(nx, ny);
        let Block::Factored { y, .. } = &mut zero else {
            unreachable!()
        };
        y.fill(0.0);
        let normal = Normal::new(nx, ny, 1.0, vec![zero]).unwrap();
        let s = solve(
            &normal,
            Stop::relative(1e-10, 100),
            None,
            &AtomicUsize::new(0),
        )
        .unwrap();
        assert!(s.cells.iter().all(|&v| v == 0.0));
        assert_eq!((s.iterations, s.residual), (0, 0.0));
    }

    #[test]
    fn bad_rtol_names_its_field() {
        let normal = Normal::new(1, 1, 1.0, vec![]).unwrap();
        let r = solve(
            &normal,
            Stop::relative(f64::NAN, 10),
            None,
            &AtomicUsize::new(0),
        );
        assert_eq!(r.err().unwrap().parameter_name().unwrap(), "rtol");
    }
}
