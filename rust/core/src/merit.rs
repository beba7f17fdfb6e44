//! Figures of merit of one design over a set of depths (the quantities a design sweep
//! compares): sharp fractions from the closed-form depth of field, and the worst and
//! median resolution (max gap, docs/model.md §6) of each half and of the split sensor.

use crate::camera::{Camera, Half};
use crate::error::Result;
use crate::optics::{check_depths, sharp_fractions};
use crate::rayspace::Sample;
use crate::samples::new_samples;

/// Number of figures of merit, in the order of [`figures_of_merit`].
pub const N_MERITS: usize = 9;

/// Median as NumPy computes it: the middle value, or the mean of the two middle values.
fn median(values: &mut [f64]) -> f64 {
    let n = values.len();
    values.sort_unstable_by(|a, b| a.total_cmp(b));
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// Figures of merit of `cam` over the depths `z` (at least one, each > F):
/// [sharp fraction half 1, sharp fraction split (log depth over [min z, max z]),
///  worst max gap half 1, half 2, union, median max gap half 1, half 2, union (units of
///  δ(z)), lit-pixel fraction of half 2].
pub fn figures_of_merit(
    cam: &Camera,
    z: &[f64],
    threshold_px: f64,
    tol: f64,
    n_threads: Option<usize>,
) -> Result<[f64; N_MERITS]> {
    check_depths(cam, z)?;
    let lo = z.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let sharp = sharp_fractions(cam, threshold_px, lo, hi)?;
    let ns = new_samples(cam, z, tol, Sample::Chief, n_threads)?;
    let m = z.len();
    let mut out = [0.0; N_MERITS];
    out[0] = sharp[0];
    out[1] = sharp[2];
    for row in 0..3 {
        let gaps = &ns.max_gap[row * m..(row + 1) * m];
        out[2 + row] = gaps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        out[5 + row] = median(&mut gaps.to_vec());
    }
    out[8] = cam.lit_pixels(Half::Two) as f64 / cam.q as f64;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_like_numpy() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&mut [1.0, f64::INFINITY]), f64::INFINITY);
    }

    #[test]
    fn seed_design_merits() {
        let cam = Camera::paper();
        let z: Vec<f64> = (0..50)
            .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 49.0))
            .collect();
        let f = figures_of_merit(&cam, &z, 0.5, 1e-6, Some(1)).unwrap();
        assert_eq!(f[1], 1.0); // the split sensor is sharp everywhere
        assert!(f[0] < 1.0);
        assert!(f[4] <= f[2] && f[4] <= f[3]); // the union resolves at least as well
        assert_eq!(f[8], 11.0 / 15.0);
        assert!(figures_of_merit(&cam, &[50.0], 0.5, 1e-6, None).is_err());
    }
}
