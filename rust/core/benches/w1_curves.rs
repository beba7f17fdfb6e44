//! W1 at a modest size: every closed-form curve (`curves_into`) for 10^5 depths.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use splitlf_core::optics::{curves_into, CurvesOut};
use splitlf_core::Camera;

mod common;

fn bench(c: &mut Criterion) {
    let cam = Camera::paper();
    let n = 100_000;
    let z = common::geomspace(cam.f_main * 1.001, 1e5, n);
    let mut bufs: [Vec<f64>; 6] =
        std::array::from_fn(|k| vec![0.0; if k == 0 { n } else { 2 * n }]);
    let mut g = c.benchmark_group("w1_curves");
    g.throughput(Throughput::Elements(n as u64));
    for t in common::thread_counts() {
        g.bench_function(common::label(t), |b| {
            b.iter(|| {
                let [zc, h, r, mb, p, cv] = &mut bufs;
                let out = CurvesOut {
                    conjugate: zc,
                    main_blur: h,
                    repetitions: r,
                    microlens_blur: mb,
                    blur_px: p,
                    conventional_px: cv,
                };
                curves_into(&cam, &z, out, t).unwrap();
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
