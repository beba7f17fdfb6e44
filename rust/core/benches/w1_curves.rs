//! W1 at a modest size: every closed-form curve (`design_curves_into`) of the seed's
//! two-channel design for 10^5 depths.

use criterion::{criterion_group, criterion_main, Criterion};
use splitlf_core::model::optics::{design_curves_into, DesignCurvesOut};
use splitlf_core::Camera;

mod common;

fn bench(c: &mut Criterion) {
    let d = Camera::paper().design();
    let n = 100_000;
    let z = common::geomspace(d.f_main * 1.001, 1e5, n);
    // conjugate and union (n), per channel and per lens type (2 n each: two channels of one
    // type).
    let mut bufs: [Vec<f64>; 8] =
        std::array::from_fn(|k| vec![0.0; if k == 0 || k == 7 { n } else { 2 * n }]);
    common::per_thread_count(c, "w1_curves", n as u64, None, |t| {
        let [zc, h, r, cv, mb, p, cp, u] = &mut bufs;
        let out = DesignCurvesOut {
            conjugate: zc,
            main_blur: h,
            repetitions: r,
            conventional_px: cv,
            microlens_blur: mb,
            blur_px: p,
            channel_blur_px: cp,
            union_blur_px: u,
        };
        design_curves_into(&d, &z, out, t).unwrap();
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
