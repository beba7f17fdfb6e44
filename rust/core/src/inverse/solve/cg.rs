//! The conjugate gradients on the normal equations ([`solve`]) and when they stop
//! ([`Stop`]: the relative residual, or the noise's expected norm, or the iteration cap).

use rayon::prelude::*;

use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::parallel;

use super::kernels::{dot, norm};
use super::normal::Normal;

/// The solve's result: the cells (row-major, row 0 at the top), the iterations CG took and
/// the normal equations' relative residual ‖(AᵀWA + λDᵀD) t − AᵀWy‖ / ‖AᵀWy‖ at the end.
pub struct Solution {
    pub cells: Vec<f64>,
    pub iterations: usize,
    pub residual: f64,
}

/// Wall time of one batch of iterations between two interrupt checks on the calling thread.
const BATCH: std::time::Duration = std::time::Duration::from_millis(40);

/// When [`solve`] stops: after `max_iter` steps, or once ‖r‖ < max(rtol ‖AᵀWy‖,
/// noise ν), where ν = √trace(AᵀWA) is the expected norm of the noise's part of AᵀWy when
/// W is the rows' inverse noise variance (E[AᵀW n nᵀ W A] = AᵀWA): `noise` = 0 for a
/// raw whose noise is not known.
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

/// Solve the normal equations by Jacobi-preconditioned conjugate gradients, SciPy's `cg`
/// iteration: start from the normalised back-projection (AᵀWy / AᵀWA·1; cells no row sees
/// start at Σ AᵀWy / Σ AᵀWA·1), stop as `stop` says (with `stop.noise` = 0, SciPy's
/// ‖r‖ < rtol ‖AᵀWy‖). `done` counts iterations (progress); Ctrl-C is checked between
/// batches of about 40 ms.
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
        memory::bytes_of::<f64>(7 * n as u128) + normal.work_bytes(),
    )?;
    let vec = |v: f64| memory::try_vec("the solve's vectors", n, v);
    let mut work = normal.work()?;
    let (mut b, mut diag, mut seen, mut x) = (vec(0.0)?, vec(0.0)?, vec(0.0)?, vec(0.0)?);
    let (mut r, mut p, mut q) = (vec(0.0)?, vec(0.0)?, vec(0.0)?);
    let (mut iterations, mut rho_prev) = (0usize, 0.0f64);
    let mut first = true;
    let (mut tol, mut bn) = (0.0, 0.0);
    parallel::repeat_until(n_threads, || {
        if first {
            first = false;
            match start.rhs {
                Some(v) => b.copy_from_slice(v),
                None => normal.rhs(&mut work, &mut b),
            }
            let trace = normal.diagonal(&mut work, &mut diag);
            if let Some(v) = start.x0 {
                x.copy_from_slice(v);
            } else {
                // AᵀWA·1, with p (not needed before the first step) as the ones: the seven
                // vectors the memory check counts are all the solve holds.
                p.fill(1.0);
                normal.apply(&p, &mut work, &mut seen);
                let mean = b.iter().sum::<f64>() / seen.iter().sum::<f64>().max(1e-300);
                x.par_iter_mut()
                    .zip(b.par_iter().zip(seen.par_iter()))
                    .for_each(|(x, (&b, &s))| *x = if s > 0.0 { b / s } else { mean });
            }
            bn = norm(&b);
            if bn == 0.0 {
                x.fill(0.0);
                return Ok(true);
            }
            tol = (rtol * bn).max(noise * trace.sqrt());
            normal.apply(&x, &mut work, &mut q);
            r.par_iter_mut()
                .zip(b.par_iter().zip(q.par_iter()))
                .for_each(|(r, (&b, &q))| *r = b - q);
            return Ok(false);
        }
        let start = std::time::Instant::now();
        loop {
            if iterations >= max_iter || norm(&r) < tol {
                return Ok(true);
            }
            // z = r / diag, kept in q until the product overwrites it.
            q.par_iter_mut()
                .zip(r.par_iter().zip(diag.par_iter()))
                .for_each(|(z, (&r, &d))| *z = r / if d > 0.0 { d } else { 1.0 });
            let rho = dot(&r, &q);
            if iterations == 0 {
                p.copy_from_slice(&q);
            } else {
                let beta = rho / rho_prev;
                p.par_iter_mut()
                    .zip(q.par_iter())
                    .for_each(|(p, &z)| *p = beta * *p + z);
            }
            normal.apply(&p, &mut work, &mut q);
            let alpha = rho / dot(&p, &q);
            x.par_iter_mut()
                .zip(p.par_iter())
                .for_each(|(x, &p)| *x += alpha * p);
            r.par_iter_mut()
                .zip(q.par_iter())
                .for_each(|(r, &q)| *r -= alpha * q);
            (iterations, rho_prev) = (iterations + 1, rho);
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            parallel::checkpoint()?;
            if start.elapsed() >= BATCH {
                return Ok(false);
            }
        }
    })?;
    // The true residual of the result (not the recurrence's).
    normal.apply(&x, &mut work, &mut q);
    q.iter_mut().zip(&b).for_each(|(q, b)| *q -= b);
    let residual = if bn > 0.0 { norm(&q) / bn } else { 0.0 };
    Ok(Solution {
        cells: x,
        iterations,
        residual,
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

    #[test]
    fn zero_data_gives_zero_cells() {
        let (nx, ny) = (9, 8);
        let (block, ..) = factored(nx, ny);
        let Block::Factored { norm, px, py, w, y } = block else {
            unreachable!()
        };
        let zero = Block::Factored {
            norm,
            px,
            py,
            w,
            y: vec![0.0; y.len()],
        };
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
