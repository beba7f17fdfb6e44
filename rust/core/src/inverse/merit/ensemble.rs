//! The image ensemble of the merits: a stationary Gaussian random field on the cells with
//! a power-law spectrum, S(f) = a² |f|^−α (f in cycles per cell, S per cell², the
//! periodogram's units: E|DFT(x)|² / cells), about a mean albedo, optionally flat below a
//! floor frequency (S(f) = S(floor) for 0 < f < floor: no power law extrapolated below
//! the band it was fitted over), or a measured radial spectrum in its place (knots
//! (f, S), S interpolated linearly in log f – log S between them, flat beyond the first
//! and the last); and the Gaussian draws.
//!
//! Synthesis: on a periodic G × G grid (G the least power of two covering the cells),
//! x = m + Re u, u = (1/G) Σ_f H(f) Z_f e^{2πi f·j/G} with H = √S (0 at f = 0) and Z_f
//! independent standard complex normals (E|Z|² = 2), so that Re u has the covariance
//! C(d) = (1/G²) Σ_f S(f) cos(2π f·d/G); the cells are the field's top-left corner.

use crate::infra::error::{Error, Result};
use crate::infra::fft;
use crate::infra::random::splitmix64_stream;

/// An ensemble: the mean albedo `mean`, the amplitude a and the exponent α of the power
/// law, flat below `floor` cycles per cell (0: the power law down to the lowest
/// frequency); `spectrum`, when not empty, replaces the power law: knots (f, S), f in
/// cycles per cell strictly increasing in (0, 1], S > 0 (a and α then only describe it;
/// the floor still applies).
#[derive(Clone, Debug, PartialEq)]
pub struct Ensemble {
    pub mean: f64,
    pub amplitude: f64,
    pub exponent: f64,
    pub floor: f64,
    pub spectrum: Vec<[f64; 2]>,
}

/// The largest exponent taken (a spectrum steeper than f⁻⁴ is smoother than any image).
pub const MAX_EXPONENT: f64 = 4.0;

/// The most knots a measured spectrum may have.
pub const MAX_KNOTS: usize = 4096;

impl Ensemble {
    /// The ensemble checked: finite mean, amplitude ≥ 0, exponent in [0, 4].
    pub fn checked(&self) -> Result<&Ensemble> {
        if !self.mean.is_finite() {
            return Err(Error::param("mean", self.mean, "a finite albedo"));
        }
        if !(self.amplitude.is_finite() && self.amplitude >= 0.0) {
            return Err(Error::param(
                "amplitude",
                self.amplitude,
                "a finite value >= 0",
            ));
        }
        if !(self.exponent.is_finite() && (0.0..=MAX_EXPONENT).contains(&self.exponent)) {
            return Err(Error::param(
                "exponent",
                self.exponent,
                format!("a value in [0, {MAX_EXPONENT}]"),
            ));
        }
        if !(self.floor.is_finite() && (0.0..=0.5).contains(&self.floor)) {
            return Err(Error::param(
                "floor",
                self.floor,
                "a frequency in [0, 0.5] cycles per cell",
            ));
        }
        self.check_spectrum()?;
        Ok(self)
    }

    fn check_spectrum(&self) -> Result<()> {
        if self.spectrum.len() > MAX_KNOTS {
            return Err(Error::param(
                "spectrum",
                format!("{} knots", self.spectrum.len()),
                format!("at most {MAX_KNOTS} knots"),
            ));
        }
        let mut last = 0.0;
        for (i, &[f, s]) in self.spectrum.iter().enumerate() {
            if !(f.is_finite() && f > last && f <= 1.0) {
                return Err(Error::param(
                    "spectrum",
                    format!("knot {i} at f = {f}"),
                    "frequencies in (0, 1] cycles per cell, strictly increasing",
                ));
            }
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::param(
                    "spectrum",
                    format!("knot {i} with S = {s}"),
                    "a finite power > 0 at every knot",
                ));
            }
            last = f;
        }
        Ok(())
    }

    /// S at the radial frequency f > 0 (cycles per cell), the floor applied.
    pub fn power(&self, f: f64) -> f64 {
        let f = f.max(self.floor);
        let k = &self.spectrum;
        match k.len() {
            0 => self.amplitude * self.amplitude * f.powf(-self.exponent),
            _ if f <= k[0][0] => k[0][1],
            n if f >= k[n - 1][0] => k[n - 1][1],
            _ => {
                let j = k.partition_point(|p| p[0] <= f);
                let ([f0, s0], [f1, s1]) = (k[j - 1], k[j]);
                let t = (f / f0).ln() / (f1 / f0).ln();
                (s0.ln() + t * (s1 / s0).ln()).exp()
            }
        }
    }

    /// The synthesis period G for an nx × ny grid: the least power of two ≥ both.
    pub fn period(nx: usize, ny: usize) -> usize {
        nx.max(ny).max(1).next_power_of_two()
    }

    /// √S at the frequency (kx, ky) / G (each wrapped to [−G/2, G/2)); 0 at f = 0.
    pub fn gain(&self, kx: usize, ky: usize, g: usize) -> f64 {
        let wrap = |k: usize| {
            let k = k as f64;
            if k >= g as f64 / 2.0 {
                k - g as f64
            } else {
                k
            }
        };
        let f = (wrap(kx).hypot(wrap(ky))) / g as f64;
        if f == 0.0 {
            0.0
        } else if self.spectrum.is_empty() {
            // The power law's √S in this form, not `power(f).sqrt()`: the same draws, bit
            // for bit, as before measured spectra (the published merits).
            self.amplitude * f.max(self.floor).powf(-0.5 * self.exponent)
        } else {
            self.power(f).sqrt()
        }
    }

    /// One draw on the nx × ny cells (row-major from the top), from `seed`.
    pub fn draw(&self, nx: usize, ny: usize, seed: u64) -> Result<Vec<f64>> {
        let g = Self::period(nx, ny);
        let z = normals(2 * g * g, seed);
        let mut u: Vec<fft::Complex> = (0..g * g)
            .map(|i| {
                let h = self.gain(i % g, i / g, g);
                fft::Complex::new(h * z[2 * i], h * z[2 * i + 1])
            })
            .collect();
        fft::fft2(&mut u, g, true)?;
        let mut out = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            out.extend(
                u[j * g..j * g + nx]
                    .iter()
                    .map(|c| self.mean + c.re / g as f64),
            );
        }
        Ok(out)
    }
}

/// `n` independent standard normals from `seed` (Box–Muller on a SplitMix64 stream).
pub fn normals(n: usize, seed: u64) -> Vec<f64> {
    let state = seed.wrapping_mul(0xD6E8_FEB8_6659_FD93) ^ 0x2545_F491_4F6C_DD1D;
    let mut s = splitmix64_stream(state);
    let mut unit = move || ((s.next().unwrap_or(1) >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let mut out = Vec::with_capacity(n + 1);
    while out.len() < n {
        let (u1, u2) = (unit(), unit());
        let r = (-2.0 * u1.ln()).sqrt();
        let (s2, c2) = (2.0 * std::f64::consts::PI * u2).sin_cos();
        out.push(r * c2);
        out.push(r * s2);
    }
    out.truncate(n);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The draws' variance per cell is the spectrum's sum over the period, (1/G²) Σ S
    /// (here white, S = a²: a²), within the scatter of 64 x 64 x 40 values.
    #[test]
    fn white_draws_have_the_spectrum_s_variance() {
        let e = Ensemble {
            mean: 0.5,
            amplitude: 0.2,
            exponent: 0.0,
            floor: 0.0,
            spectrum: Vec::new(),
        };
        let (mut s, mut s2, mut n) = (0.0, 0.0, 0.0);
        for seed in 0..40 {
            for v in e.draw(64, 64, seed).unwrap() {
                s += v - 0.5;
                s2 += (v - 0.5) * (v - 0.5);
                n += 1.0;
            }
        }
        // One coefficient (f = 0) of 4096 is 0.
        let want = 0.04 * (1.0 - 1.0 / 4096.0);
        let var = s2 / n - (s / n) * (s / n);
        assert!((var - want).abs() < 0.02 * want, "{var} {want}");
    }

    /// Flat below the floor: √S there is the floor's, above it the power law's; the draws'
    /// variance per cell is (1/G²) Σ S of that spectrum (summed here term by term), within
    /// the scatter of 64 x 64 x 40 values; without the floor the same law's sum is larger
    /// (its slow modes) and a floor outside [0, 0.5] is refused.
    #[test]
    fn a_floor_flattens_the_spectrum_below_it() {
        let (g, floor) = (64usize, 4.0 / 64.0);
        let e = Ensemble {
            mean: 0.5,
            amplitude: 0.01,
            exponent: 3.0,
            floor,
            spectrum: Vec::new(),
        };
        let top = 0.01 * floor.powf(-1.5);
        assert_eq!(e.gain(1, 0, g), top);
        assert_eq!(e.gain(2, 3, g), top); // |f| = √13 / 64 < 4 / 64
        assert_eq!(e.gain(0, 0, g), 0.0);
        let above = 0.01 * (5.0f64 / 64.0).powf(-1.5);
        assert!((e.gain(5, 0, g) - above).abs() <= 1e-15 * above);
        let sum = |e: &Ensemble| -> f64 {
            (0..g * g)
                .map(|i| e.gain(i % g, i / g, g).powi(2))
                .sum::<f64>()
                / (g * g) as f64
        };
        let want = sum(&e);
        let bare = Ensemble {
            floor: 0.0,
            ..e.clone()
        };
        assert!(sum(&bare) > 1.5 * want, "{} {want}", sum(&bare));
        let (mut s2, mut n) = (0.0, 0.0);
        for seed in 0..40 {
            for v in e.draw(g, g, seed).unwrap() {
                s2 += (v - 0.5) * (v - 0.5);
                n += 1.0;
            }
        }
        let var = s2 / n;
        assert!((var - want).abs() < 0.05 * want, "{var} {want}");
        for bad in [-0.1, 0.6, f64::NAN] {
            assert!(
                Ensemble {
                    floor: bad,
                    ..e.clone()
                }
                .checked()
                .is_err(),
                "{bad}"
            );
        }
    }

    /// A measured spectrum: S interpolated linearly in log f – log S between the knots
    /// (at the geometric mean of two knots' frequencies, the geometric mean of their
    /// powers), flat beyond both ends, the floor applied; the draws' variance is (1/G²) Σ S
    /// of it; knots out of order, outside (0, 1] or without power are refused.
    #[test]
    fn a_measured_spectrum_is_interpolated_in_log_log() {
        let e = Ensemble {
            mean: 0.5,
            amplitude: 1.0,
            exponent: 2.0,
            floor: 0.0,
            spectrum: vec![[0.05, 4e-3], [0.1, 1e-3], [0.4, 6.25e-5]],
        };
        assert!(e.checked().is_ok());
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b;
        assert_eq!(e.power(0.01), 4e-3);
        assert_eq!(e.power(0.05), 4e-3);
        assert!(close(e.power((0.05f64 * 0.1).sqrt()), 2e-3));
        assert!(close(e.power(0.2), 2.5e-4));
        assert_eq!(e.power(0.6), 6.25e-5);
        let floored = Ensemble {
            floor: 0.1,
            ..e.clone()
        };
        assert!(close(floored.power(0.01), 1e-3));
        let g = 64usize;
        assert!(close(e.gain(0, 13, g), e.power(13.0 / 64.0).sqrt()));
        assert_eq!(e.gain(0, 0, g), 0.0);
        let want = (0..g * g)
            .map(|i| e.gain(i % g, i / g, g).powi(2))
            .sum::<f64>()
            / (g * g) as f64;
        let (mut s2, mut n) = (0.0, 0.0);
        for seed in 0..40 {
            for v in e.draw(g, g, seed).unwrap() {
                s2 += (v - 0.5) * (v - 0.5);
                n += 1.0;
            }
        }
        assert!((s2 / n - want).abs() < 0.05 * want, "{} {want}", s2 / n);
        for bad in [
            vec![[0.1, 1.0], [0.05, 1.0]],
            vec![[0.1, 1.0], [0.1, 1.0]],
            vec![[0.0, 1.0]],
            vec![[1.5, 1.0]],
            vec![[0.1, 0.0]],
            vec![[0.1, f64::NAN]],
            vec![[0.1, 1.0]; MAX_KNOTS + 1],
        ] {
            let e = Ensemble {
                spectrum: bad.clone(),
                ..e.clone()
            };
            assert!(e.checked().is_err(), "{bad:?}");
        }
    }

    #[test]
    fn normals_are_standard() {
        let z = normals(100_001, 7);
        assert_eq!(z.len(), 100_001);
        let m = z.iter().sum::<f64>() / z.len() as f64;
        let v = z.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / z.len() as f64;
        assert!(m.abs() < 0.01 && (v - 1.0).abs() < 0.01, "{m} {v}");
    }
}
