//! W2 at a modest size: centroid footprints (position, extent; no kernels) of every pixel
//! of half 2 along x (3,990 pixels) at 200 depths.

use criterion::{criterion_group, criterion_main, Criterion};
use splitlf_core::sampling::line::Line;
use splitlf_core::sampling::rayspace::{footprints_line_into, FootprintsOut, Sample};
use splitlf_core::{Axis, Camera};

mod common;

fn bench(c: &mut Criterion) {
    let line = Line::of_channel(&Camera::paper().design(), 2, Axis::X).unwrap();
    let z = common::geomspace(150.0, 10_000.0, 200);
    let n = line.pixel_count() as usize * z.len();
    let (mut pos, mut lo, mut hi) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    common::per_thread_count(c, "w2_footprints", n as u64, None, |t| {
        let out = FootprintsOut {
            position: &mut pos,
            lo: &mut lo,
            hi: &mut hi,
            kernel: None,
        };
        footprints_line_into(&line, &z, Sample::Centroid, out, t).unwrap();
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
