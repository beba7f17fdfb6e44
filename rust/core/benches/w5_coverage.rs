//! W5 at a modest size: `coverage` of the `raytrix-r12` preset at 8 depths geometric over
//! [300, 10^4] mm (`benches/run.py` runs 100 depths against SciPy/qhull).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use splitlf_core::presets::preset;
use splitlf_core::samples2d::coverage;

mod common;

fn bench(c: &mut Criterion) {
    let d = preset("raytrix-r12").unwrap();
    let z = common::geomspace(300.0, 10_000.0, 8);
    let mut g = c.benchmark_group("w5_coverage");
    g.sample_size(10);
    g.throughput(Throughput::Elements(z.len() as u64));
    for t in common::thread_counts() {
        g.bench_function(common::label(t), |b| {
            b.iter(|| coverage(&d, &z, 1e-6, 16.0, t).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
