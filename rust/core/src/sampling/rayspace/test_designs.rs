//! The seed with few lenses, its lines and a relative comparison, shared by the unit tests
//! of the folder.

use crate::model::camera::{Camera, CameraSpec};
use crate::model::design::Design;
use crate::sampling::line::{Axis, Line};

/// The seed with 6 x 4 lenses and the given microlens focal lengths, as its design.
pub(super) fn design(f1: Option<f64>, f2: Option<f64>) -> Design {
    Camera::new(&CameraSpec {
        kx: 6,
        ky: 4,
        f1,
        f2,
        ..CameraSpec::paper()
    })
    .unwrap()
    .design()
}

pub(super) fn line(d: &Design, channel: i64, axis: Axis) -> Line {
    Line::of_channel(d, channel, axis).unwrap()
}

pub(super) fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}
