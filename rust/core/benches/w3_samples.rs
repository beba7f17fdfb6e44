//! W3 at a modest size: `design_new_samples` of the seed (distinct per channel and union,
//! max gap) at 500 depths.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use splitlf_core::rayspace::Sample;
use splitlf_core::samples::design_new_samples;
use splitlf_core::Camera;

mod common;

fn bench(c: &mut Criterion) {
    let d = Camera::paper().design();
    let z = common::geomspace(150.0, 10_000.0, 500);
    let mut g = c.benchmark_group("w3_samples");
    g.throughput(Throughput::Elements(z.len() as u64));
    for t in common::thread_counts() {
        g.bench_function(common::label(t), |b| {
            b.iter(|| design_new_samples(&d, &z, 1e-6, Sample::Chief, t).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
