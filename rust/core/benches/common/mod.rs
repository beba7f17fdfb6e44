//! Shared inputs of the criterion benches (modest sizes of the workloads of
//! `benches/run.py`, which measures the full sizes against NumPy).

#![allow(dead_code)]

use criterion::{Criterion, Throughput};

/// n depths geometrically spaced over [lo, hi] mm.
pub fn geomspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let r = (hi / lo).ln();
    (0..n)
        .map(|i| lo * (r * i as f64 / (n.max(2) - 1) as f64).exp())
        .collect()
}

/// Thread counts to bench: 1 and all cores.
pub fn thread_counts() -> [Option<usize>; 2] {
    [Some(1), None]
}

/// Bench `f(n_threads)` as group `name`, once per [`thread_counts`], with `elements`
/// elements per iteration (and `samples` criterion samples when given).
pub fn per_thread_count(
    c: &mut Criterion,
    name: &str,
    elements: u64,
    samples: Option<usize>,
    mut f: impl FnMut(Option<usize>),
) {
    let mut g = c.benchmark_group(name);
    if let Some(n) = samples {
        g.sample_size(n);
    }
    g.throughput(Throughput::Elements(elements));
    for t in thread_counts() {
        g.bench_function(label(t), |b| b.iter(|| f(t)));
    }
    g.finish();
}

pub fn label(n: Option<usize>) -> String {
    match n {
        Some(n) => format!("{n}thr"),
        None => "all".into(),
    }
}

/// The `lytro-illum` preset with 1/4 of its lenses and pixels per axis: 135 x 108 lenses
/// on 1,932 x 1,342 pixels (W6's modest size).
pub fn lytro_quarter() -> splitlf_core::Design {
    splitlf_core::model::presets::lytro_illum_reduced(4).unwrap()
}
