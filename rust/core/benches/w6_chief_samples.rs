//! W6 at a modest size: `chief_samples` of a 1/4-per-axis Lytro Illum (the `lytro-illum`
//! preset with 135 x 108 lenses on 1,932 x 1,342 pixels) at z = 1000 mm, into buffers
//! allocated once (the compute alone; `benches/run.py` measures the whole sensor against
//! the alloc-and-fill floor of fresh outputs).

use criterion::{criterion_group, criterion_main, Criterion};
use splitlf_core::sampling::samples2d::{chief_samples_into, ChiefSamplesOut};

mod common;

fn bench(c: &mut Criterion) {
    let d = common::lytro_quarter();
    let n = 1932 * 1342;
    let (mut x, mut y, mut lit) = (vec![0.0; n], vec![0.0; n], vec![false; n]);
    let (mut lens, mut types) = (vec![0i64; 2 * n], vec![0i64; n]);
    common::per_thread_count(c, "w6_chief_samples", n as u64, None, |t| {
        let out = ChiefSamplesOut {
            x: &mut x,
            y: &mut y,
            lit: &mut lit,
            lens: &mut lens,
            types: &mut types,
        };
        chief_samples_into(&d, 1, 1000.0, out, t).unwrap();
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
