//! Designs and depths at the edges of the floating-point range: every result stays finite
//! and consistent, or the input is refused with a named error.

use splitlf_core::model::camera::{Camera, CameraSpec};
use splitlf_core::model::lens::conjugate;
use splitlf_core::model::optics::{design_curves as curves, design_depth_of_field};
use splitlf_core::sampling::line::Line;
use splitlf_core::sampling::rayspace::{self, Sample, LIT_AREA_RTOL};
use splitlf_core::sampling::samples::design_new_samples as new_samples;
use splitlf_core::{Axis, Design, Error};

/// The seed with some of (F, D, v1, kappa, d, v, mu) changed, as its two-channel design.
fn seed_with(f: impl FnOnce(&mut [f64; 7])) -> Result<Design, Error> {
    let p = Camera::paper();
    let mut x = [p.f_main, p.aperture, p.v1, p.kappa, p.d, p.v, p.mu];
    f(&mut x);
    Camera::new(&CameraSpec {
        f_main: x[0],
        aperture: x[1],
        v1: x[2],
        kappa: x[3],
        d: x[4],
        v: x[5],
        mu: x[6],
        q: 15,
        kx: 266,
        ky: 88,
        f1: None,
        f2: None,
    })
    .map(|c| c.design())
}

fn seed() -> Design {
    Camera::paper().design()
}

fn line(d: &Design, channel: i64, axis: Axis) -> Line {
    Line::of_channel(d, channel, axis).unwrap()
}

#[test]
fn conjugate_of_huge_depths_is_finite_and_tends_to_f() {
    for z in [1e300, 1e307, 1.7e308, f64::MAX] {
        let zc = conjugate(80.0, z);
        assert!(
            zc.is_finite() && (80.0..80.0 + 1e-9).contains(&zc),
            "{z} -> {zc}"
        );
    }
    // Below the overflow threshold the product form of Eq. 1 is kept, bit for bit.
    for z in [80.5, 642.0, 1e6, 1e300] {
        assert_eq!(conjugate(80.0, z), 80.0 * z / (z - 80.0));
    }
}

#[test]
fn curves_at_huge_depths_equal_the_limit() {
    let cam = seed();
    let far = curves(&cam, &[1e307, f64::MAX], None).unwrap();
    let near_inf = curves(&cam, &[1e30], None).unwrap();
    for (k, v) in far.conjugate.iter().enumerate() {
        assert!((v - 80.0).abs() < 1e-12, "conjugate[{k}] = {v}");
    }
    for (a, b) in far.blur_px.iter().zip([
        near_inf.blur_px[0],
        near_inf.blur_px[0],
        near_inf.blur_px[1],
        near_inf.blur_px[1],
    ]) {
        assert!(a.is_finite() && (a - b).abs() < 1e-9, "{a} vs {b}");
    }
}

#[test]
fn samples_and_footprints_at_huge_depths() {
    let cam = seed();
    let z = [1e307, f64::MAX];
    for mode in [Sample::Chief, Sample::Centroid] {
        let s = new_samples(&cam, &z, 1e-6, mode, None).unwrap();
        let m = z.len();
        for (k, zk) in z.iter().enumerate() {
            let (h1, h2, u) = (s.distinct[k], s.distinct[m + k], s.distinct[2 * m + k]);
            assert!(u >= h1 && u >= h2, "{mode:?} z = {zk}: {h1} {h2} {u}");
            // At z' = F (far away) every half samples like at infinity.
            let far = new_samples(&cam, &[1e12], 1e-6, mode, None).unwrap();
            assert_eq!(s.distinct[k], far.distinct[0]);
            assert_eq!(s.distinct[m + k], far.distinct[1]);
            assert_eq!(s.distinct[2 * m + k], far.distinct[2]);
        }
    }
    for sample in [Sample::Chief, Sample::Centroid] {
        let fp =
            rayspace::footprints_line(&line(&cam, 1, Axis::X), &z, sample, false, None).unwrap();
        assert!(fp.lo.iter().chain(&fp.hi).all(|v| v.is_finite()));
        assert!(fp.position.iter().all(|v| v.is_finite()));
    }
    assert!(cam.resolution_step(f64::MAX).is_finite());
    assert!(line(&cam, 1, Axis::X)
        .object_position(20.0, f64::MAX)
        .is_finite());
}

#[test]
fn derived_lengths_are_validated_like_given_ones() {
    // v subnormal: 1/v overflows, Ng's f would be 0.
    let e = seed_with(|x| x[5] = 5e-324).unwrap_err();
    assert!(
        matches!(e, Error::InvalidParameter { name: "v", .. }),
        "{e}"
    );
    // Every length a normal float, but Ng's focal length underflows to a subnormal.
    let e = seed_with(|x| {
        x[5] = 1e-300;
        x[2] = 1e-10 + 80.0;
        x[4] = 1e-300;
    });
    if let Err(e) = e {
        assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
    }
    // Products that overflow: D L / 2 with D and v1 near the top of the range.
    let e = seed_with(|x| {
        x[1] = 1e200;
        x[2] = 1e200;
    })
    .unwrap_err();
    assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
    // Accepted designs give finite curves everywhere.
    for v in [1e-200, 1e-12, 1.0, 1e10] {
        if let Ok(cam) = seed_with(|x| x[5] = v) {
            let c = curves(&cam, &[80.001, 200.0, 642.0, 1e9], None).unwrap();
            assert!(c.blur_px.iter().all(|b| b.is_finite()), "v = {v}");
            assert!(c.microlens_blur.iter().all(|b| !b.is_nan()), "v = {v}");
        }
    }
}

#[test]
fn depth_of_field_never_returns_empty_intervals() {
    let cams = [
        seed_with(|x| x[2] = 1e300).unwrap(),
        // D = 0.1: with D = 20 the microlens images of this F overlap (refused).
        seed_with(|x| {
            x[0] = 1e-300;
            x[1] = 0.1;
            x[2] = 1.0;
        })
        .unwrap(),
        seed(),
    ];
    for cam in cams {
        for t in [1e-3, 0.5, 7.0, 1e6] {
            let dof = design_depth_of_field(&cam, t).unwrap();
            let all = dof
                .types
                .iter()
                .chain(&dof.channels)
                .chain(&dof.conventional)
                .chain([&dof.union]);
            for iv in all {
                for w in iv.windows(2) {
                    assert!(w[0].1 <= w[1].0, "{iv:?}");
                }
                for &(lo, hi) in iv {
                    assert!(lo < hi, "empty interval ({lo}, {hi}) at threshold {t}");
                }
            }
        }
    }
}

#[test]
fn boundary_contacts_are_not_light() {
    // A design whose half-2 polygons touch a strip boundary: exact area 0, computed area
    // ~5e-16 of a full pixel before the rule.
    let cam = Camera::new(&CameraSpec {
        f_main: 40.0,
        aperture: 10.0,
        v1: 45.0,
        kappa: 0.2,
        d: 0.1,
        v: 0.45,
        mu: 0.1 / 12.0,
        q: 12,
        kx: 8,
        ky: 4,
        f1: None,
        f2: None,
    })
    .unwrap()
    .design();
    for channel in [1, 2] {
        for axis in [Axis::X, Axis::Y] {
            let tr = rayspace::trace_line(&line(&cam, channel, axis)).unwrap();
            let max = tr.area.iter().copied().fold(0.0, f64::max);
            assert!(max > 0.0);
            for (i, &a) in tr.area.iter().enumerate() {
                assert!(
                    a == 0.0 || a >= LIT_AREA_RTOL * max,
                    "pixel {i}: area {a} of {max}"
                );
                assert_eq!(a == 0.0, tr.centroid[i][0].is_nan(), "pixel {i}");
            }
        }
    }
    // Centroid samples count only pixels with light: the same number as the sample grid's
    // non-NaN centroid samples along x.
    let s = new_samples(&cam, &[100.0], 1e-6, Sample::Centroid, None).unwrap();
    let (rows, cols) = (4 * 12, 8 * 12);
    for channel in [1, 2] {
        let (mut gx, mut gy) = (vec![0.0; rows * cols], vec![0.0; rows * cols]);
        rayspace::design_sample_grid_into(
            &cam,
            channel,
            100.0,
            Sample::Centroid,
            &mut gx,
            &mut gy,
            None,
        )
        .unwrap();
        // Rows are y pixels: a row whose y pixel collects light has every x sample.
        let with_light = gx
            .chunks(cols)
            .map(|row| row.iter().filter(|v| !v.is_nan()).count() as u64)
            .max()
            .unwrap();
        assert_eq!(with_light, s.sampled[channel as usize - 1]);
    }
}
