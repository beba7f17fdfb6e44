//! W5 at a modest size: `coverage` of the `raytrix-r12` preset at 8 depths geometric over
//! [300, 10^4] mm (`benches/run.py` runs 100 depths against SciPy/qhull).

use criterion::{criterion_group, criterion_main, Criterion};
use splitlf_core::model::presets::preset;
use splitlf_core::sampling::samples2d::coverage;

mod common;

fn bench(c: &mut Criterion) {
    let d = preset("raytrix-r12").unwrap();
    let z = common::geomspace(300.0, 10_000.0, 8);
    common::per_thread_count(c, "w5_coverage", z.len() as u64, Some(10), |t| {
        std::hint::black_box(coverage(&d, &z, 1e-6, 16.0, t).unwrap());
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
