//! The discrete Fourier transform, one axis and two: what a stationary random field's
//! synthesis needs (`inverse::merit`), by the `rustfft` crate (a well-kept library: mixed
//! radices, SIMD, planned once per length). Knows no optics.

use rustfft::{FftDirection, FftPlanner};

use super::error::{Error, Result};

/// A complex number.
pub type Complex = rustfft::num_complex::Complex64;

fn direction(inverse: bool) -> FftDirection {
    if inverse {
        FftDirection::Inverse
    } else {
        FftDirection::Forward
    }
}

/// The transform of `v` in place: X_k = Σ_j v_j e^{∓2πi jk/n} (− forward, + `inverse`),
/// unnormalised.
pub fn fft(v: &mut [Complex], inverse: bool) -> Result<()> {
    if v.len() > 1 {
        FftPlanner::new()
            .plan_fft(v.len(), direction(inverse))
            .process(v);
    }
    Ok(())
}

/// The 2-D transform in place of an n × n array (row-major): the rows, then the columns
/// (through a transpose and back).
pub fn fft2(v: &mut [Complex], n: usize, inverse: bool) -> Result<()> {
    if v.len() != n * n {
        return Err(Error::param("array", v.len(), format!("{n} x {n} values")));
    }
    if n <= 1 {
        return Ok(());
    }
    let plan = FftPlanner::new().plan_fft(n, direction(inverse));
    plan.process(v);
    let mut t = vec![Complex::new(0.0, 0.0); n * n];
    transpose(v, &mut t, n);
    plan.process(&mut t);
    transpose(&t, v, n);
    Ok(())
}

/// `out` = the transpose of the n × n `v`.
fn transpose(v: &[Complex], out: &mut [Complex], n: usize) {
    for (j, row) in v.chunks(n).enumerate() {
        for (i, &x) in row.iter().enumerate() {
            out[i * n + j] = x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The direct sum X_k = Σ_j v_j e^{∓2πi jk/n}.
    fn direct(v: &[Complex], inverse: bool) -> Vec<Complex> {
        let n = v.len();
        let sign = if inverse { 1.0 } else { -1.0 };
        (0..n)
            .map(|k| {
                v.iter()
                    .enumerate()
                    .map(|(j, x)| {
                        let a = sign * 2.0 * std::f64::consts::PI * (j * k) as f64 / n as f64;
                        x * Complex::new(a.cos(), a.sin())
                    })
                    .sum()
            })
            .collect()
    }

    /// Against the DFT's definition, summed directly, at n = 8 and 6 (both directions).
    #[test]
    fn matches_the_direct_sum() {
        for n in [8usize, 6] {
            let v: Vec<Complex> = (0..n)
                .map(|j| Complex::new((j as f64).sin(), (j * j) as f64 * 0.1))
                .collect();
            for inverse in [false, true] {
                let mut got = v.clone();
                fft(&mut got, inverse).unwrap();
                for (g, w) in got.iter().zip(direct(&v, inverse)) {
                    assert!((g - w).norm() < 1e-12, "{g} {w}");
                }
            }
        }
    }

    /// The 2-D transform against the direct sums over rows then columns, at 4 × 4.
    #[test]
    fn fft2_is_the_rows_then_the_columns() {
        let n = 4;
        let v: Vec<Complex> = (0..n * n)
            .map(|j| Complex::new((j as f64 * 0.7).cos(), (j as f64 * 0.3).sin()))
            .collect();
        let mut got = v.clone();
        fft2(&mut got, n, true).unwrap();
        let rows: Vec<Complex> = v.chunks(n).flat_map(|r| direct(r, true)).collect();
        for i in 0..n {
            let col: Vec<Complex> = (0..n).map(|j| rows[j * n + i]).collect();
            for (j, w) in direct(&col, true).into_iter().enumerate() {
                assert!((got[j * n + i] - w).norm() < 1e-12);
            }
        }
        assert!(fft2(&mut got, 3, false).is_err());
    }
}
