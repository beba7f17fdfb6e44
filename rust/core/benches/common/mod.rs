//! Shared inputs of the criterion benches (modest sizes of the workloads of
//! `benches/run.py`, which measures the full sizes against NumPy).

#![allow(dead_code)]

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

pub fn label(n: Option<usize>) -> String {
    match n {
        Some(n) => format!("{n}thr"),
        None => "all".into(),
    }
}
