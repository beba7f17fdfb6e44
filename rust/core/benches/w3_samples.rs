//! W3 at a modest size: `design_new_samples` of the seed (distinct per channel and union,
//! max gap) at 500 depths.

use criterion::{criterion_group, criterion_main, Criterion};
use splitlf_core::sampling::rayspace::Sample;
use splitlf_core::sampling::samples::design_new_samples;
use splitlf_core::Camera;

mod common;

fn bench(c: &mut Criterion) {
    let d = Camera::paper().design();
    let z = common::geomspace(150.0, 10_000.0, 500);
    common::per_thread_count(c, "w3_samples", z.len() as u64, None, |t| {
        std::hint::black_box(design_new_samples(&d, &z, 1e-6, Sample::Chief, t).unwrap());
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
