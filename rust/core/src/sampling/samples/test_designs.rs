//! The seed's design and small variants of it, and a distinct-sample count, shared by the
//! unit tests of the folder.

use super::designs::design_step;
use super::sorted::{line_samples, scan, LineSamples, Scratch};
use crate::model::camera::{Camera, CameraSpec};
use crate::model::design::Design;
use crate::model::lens::conjugate;
use crate::sampling::line::{Axis, Line};

/// The seed's design, or a variant of it with F = 80 (as the paper's camera).
pub(super) fn small(kappa: f64, aperture: f64, q: i64, kx: i64, ky: i64) -> Design {
    Camera::new(&CameraSpec {
        aperture,
        kappa,
        q,
        kx,
        ky,
        ..CameraSpec::paper()
    })
    .unwrap()
    .design()
}

pub(super) fn seed() -> Design {
    Camera::paper().design()
}

/// Distinct chief samples of channel `c` along `axis` at depth z (merge tolerance
/// `tol` δ(z)).
pub(super) fn count(d: &Design, c: i64, axis: Axis, z: f64, tol: f64) -> u64 {
    let ls = LineSamples::new(&Line::of_channel(d, c, axis).unwrap());
    let mut s = Scratch::default();
    line_samples(&ls, conjugate(d.f_main, z), &mut s.pos[0], &mut s.work);
    scan(&s.pos[0], tol * design_step(d), f64::INFINITY).0
}
