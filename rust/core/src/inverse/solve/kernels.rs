//! The arithmetic every pass of a product is made of, each in a fixed order of summation
//! (so that the result does not depend on the thread count or the CPU's vector width):
//! dot products of slices (plain and AVX2, the same bits), chunked dot products of whole
//! vectors, and axpy.

use rayon::prelude::*;

/// Σ a_k b_k over equal-length slices: sixteen interleaved partial sums (four vectors of
/// four, so that the adds of one vector do not wait on each other's), then four for what
/// is left in fours, then the rest in order. The order is fixed, so the result is too.
#[inline(always)]
pub(super) fn dot_slices(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 16];
    let (ca, cb) = (a.chunks_exact(16), b.chunks_exact(16));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..16 {
            acc[k] += x[k] * y[k];
        }
    }
    let (ca, cb) = (ra.chunks_exact(4), rb.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut lanes = [0.0f64; 4];
    for (k, l) in lanes.iter_mut().enumerate() {
        *l = (acc[k] + acc[4 + k]) + (acc[8 + k] + acc[12 + k]);
    }
    let mut s = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// [`dot_slices`] with AVX2 vectors, the same operations in the same order (so the same
/// bits): LLVM does not keep the sixteen partial sums in four vectors by itself.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn dot_slices_avx2(a: &[f64], b: &[f64]) -> f64 {
    use std::arch::x86_64::*;
    let n = a.len().min(b.len());
    let (pa, pb) = (a.as_ptr(), b.as_ptr());
    let mut acc = [_mm256_setzero_pd(); 4];
    let mut c = 0;
    // SAFETY: every load reads 4 values at c + 4k + 3 < n.
    while c + 16 <= n {
        for (k, acc) in acc.iter_mut().enumerate() {
            let x = _mm256_loadu_pd(pa.add(c + 4 * k));
            let y = _mm256_loadu_pd(pb.add(c + 4 * k));
            *acc = _mm256_add_pd(*acc, _mm256_mul_pd(x, y));
        }
        c += 16;
    }
    while c + 4 <= n {
        let x = _mm256_loadu_pd(pa.add(c));
        let y = _mm256_loadu_pd(pb.add(c));
        acc[0] = _mm256_add_pd(acc[0], _mm256_mul_pd(x, y));
        c += 4;
    }
    let v = _mm256_add_pd(_mm256_add_pd(acc[0], acc[1]), _mm256_add_pd(acc[2], acc[3]));
    let mut lanes = [0.0f64; 4];
    _mm256_storeu_pd(lanes.as_mut_ptr(), v);
    let mut s = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for k in c..n {
        s += a[k] * b[k];
    }
    s
}

/// o += v · s over equal-length slices.
#[inline(always)]
pub(super) fn axpy(o: &mut [f64], v: f64, s: &[f64]) {
    for (q, x) in o.iter_mut().zip(s) {
        *q += v * x;
    }
}

/// Entries summed per chunk of a dot product (fixed: thread-independent rounding).
const DOT_CHUNK: usize = 4096;

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let parts: Vec<f64> = a
        .par_chunks(DOT_CHUNK)
        .zip(b.par_chunks(DOT_CHUNK))
        .map(|(x, y)| dot_slices(x, y))
        .collect();
    parts.iter().sum()
}

pub(super) fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}
