//! W4 at a modest size: `design_sample_grid_into` of one half (channel 1) of a 1/16-size version of the 40-MP
//! sensor of `benches/run.py` (Kx = 129, Ky = 43: 1,935 x 645 pixels), at one depth.

use criterion::{criterion_group, criterion_main, Criterion};
use splitlf_core::model::camera::CameraSpec;
use splitlf_core::sampling::rayspace::{design_sample_grid_into, Sample};
use splitlf_core::Camera;

mod common;

fn bench(c: &mut Criterion) {
    let p = Camera::paper();
    let (mu, q) = (0.0045, 15);
    let d = q as f64 * mu;
    let cam = Camera::new(&CameraSpec {
        f_main: p.f_main,
        aperture: p.aperture,
        v1: p.v1,
        kappa: p.kappa,
        d,
        v: d * p.v1 / p.aperture,
        mu,
        q,
        kx: 129,
        ky: 43,
        f1: None,
        f2: None,
    })
    .unwrap();
    let n = (cam.kx * cam.q) as usize * (cam.ky * cam.q) as usize;
    let d = cam.design();
    let (mut gx, mut gy) = (vec![0.0; n], vec![0.0; n]);
    common::per_thread_count(c, "w4_sample_grid", n as u64, None, |t| {
        design_sample_grid_into(&d, 1, 500.0, Sample::Chief, &mut gx, &mut gy, t).unwrap();
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
