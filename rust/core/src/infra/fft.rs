//! The discrete Fourier transform of power-of-two lengths (iterative radix-2
//! Cooley–Tukey), one axis and two: what a stationary random field's synthesis needs
//! (`inverse::merit`). Knows no optics.

use super::error::{Error, Result};

/// A complex number as (re, im).
pub type Complex = (f64, f64);

/// The transform of `v` in place, of power-of-two length: X_k = Σ_j v_j e^{∓2πi jk/n}
/// (− forward, + `inverse`), unnormalised.
pub fn fft(v: &mut [Complex], inverse: bool) -> Result<()> {
    let n = v.len();
    if !n.is_power_of_two() {
        return Err(Error::param("length", n, "a power of two"));
    }
    let bits = n.trailing_zeros();
    if bits == 0 {
        return Ok(());
    }
    for i in 0..n {
        let j = i.reverse_bits() >> (usize::BITS - bits);
        if j > i {
            v.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let ang = sign * 2.0 * std::f64::consts::PI / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (s, c) = (ang * k as f64).sin_cos();
                let (a, b) = (v[start + k], v[start + k + len / 2]);
                let t = (b.0 * c - b.1 * s, b.0 * s + b.1 * c);
                v[start + k] = (a.0 + t.0, a.1 + t.1);
                v[start + k + len / 2] = (a.0 - t.0, a.1 - t.1);
            }
        }
        len *= 2;
    }
    Ok(())
}

/// The 2-D transform in place of an n × n array (row-major), n a power of two.
pub fn fft2(v: &mut [Complex], n: usize, inverse: bool) -> Result<()> {
    if v.len() != n * n {
        return Err(Error::param("array", v.len(), format!("{n} x {n} values")));
    }
    for row in v.chunks_mut(n) {
        fft(row, inverse)?;
    }
    let mut col = vec![(0.0, 0.0); n];
    for i in 0..n {
        for (j, c) in col.iter_mut().enumerate() {
            *c = v[j * n + i];
        }
        fft(&mut col, inverse)?;
        for (j, c) in col.iter().enumerate() {
            v[j * n + i] = *c;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the DFT's definition, summed directly, at n = 8 (both directions).
    #[test]
    fn matches_the_direct_sum() {
        let v: Vec<Complex> = (0..8)
            .map(|j| ((j as f64).sin(), (j * j) as f64 * 0.1))
            .collect();
        for inverse in [false, true] {
            let mut got = v.clone();
            fft(&mut got, inverse).unwrap();
            let sign = if inverse { 1.0 } else { -1.0 };
            for (k, g) in got.iter().enumerate() {
                let (mut re, mut im) = (0.0, 0.0);
                for (j, x) in v.iter().enumerate() {
                    let a = sign * 2.0 * std::f64::consts::PI * (j * k) as f64 / 8.0;
                    re += x.0 * a.cos() - x.1 * a.sin();
                    im += x.0 * a.sin() + x.1 * a.cos();
                }
                assert!((g.0 - re).abs() < 1e-12 && (g.1 - im).abs() < 1e-12);
            }
        }
        assert!(fft(&mut [(0.0, 0.0); 6], false).is_err());
    }
}
