//! Named designs (docs/architectures.md, "Presets"): the seed's split sensor, the seed's
//! half 1 alone on the whole sensor, a three-way split, and two commercial plenoptic
//! cameras (a Raytrix R12 and a Lytro Illum) rebuilt in the thin-lens model of
//! docs/model.md §9 from public numbers. Every number a preset does not take from a source
//! is computed here from the formula that defines it, and docs/architectures.md lists
//! them; the tests recompute them independently. All lengths in mm.

use crate::infra::error::{Error, Result};
use crate::model::camera::{Camera, Half};
use crate::model::design::{Aperture, ChannelSpec, Design, Grid};

/// The names [`preset`] accepts, in the order the docs list them.
pub const PRESETS: [&str; 5] = ["seed", "seed-plain", "split3", "raytrix-r12", "lytro-illum"];

/// The height of the seed's sensor (36 × 24 mm, docs/model.md §7): the split sensor's
/// halves are stacked along y, so a channel of a k-way split gets 24/k mm of it.
pub const SEED_SENSOR_HEIGHT: f64 = 24.0;

/// The design called `name` (one of [`PRESETS`]).
pub fn preset(name: &str) -> Result<Design> {
    match name {
        "seed" => Ok(Camera::paper().design()),
        "seed-plain" => seed_plain(),
        "split3" => split3(),
        "raytrix-r12" => raytrix_r12(),
        "lytro-illum" => lytro_illum(),
        _ => Err(Error::param(
            "preset",
            format!("{name:?}"),
            format!("one of {}", PRESETS.map(|p| format!("{p:?}")).join(", ")),
        )),
    }
}

/// A rect channel with the seed's d, v, μ, Q, K_x, Ng's setting, at array plane `l`.
fn seed_channel(cam: &Camera, l: f64, ky: i64, share: f64) -> ChannelSpec {
    ChannelSpec {
        l,
        d: cam.d,
        v: cam.v,
        mu: cam.mu,
        kx: cam.kx as i64,
        ky,
        grid: Grid::Rect,
        f: None,
        layout: "ideal".into(),
        q: Some(cam.q as i64),
        mx: None,
        my: None,
        share,
    }
}

/// Lenses of pitch d that fit in a band of `height` mm: ⌊height / d⌋.
fn rows_in(height: f64, d: f64) -> i64 {
    (height / d).floor() as i64
}

/// Half 1 of the seed alone, as a plain light field camera with the whole sensor: the
/// array at v' (out-of-focus plane 642 mm), the seed's d, v, μ, Q and K_x, share 1, and
/// K_y = 2 · 88 = 176: the lenses (and pixels) of both halves together, 23.76 mm of the
/// 24 mm sensor, so that it is compared with the split sensor on the same pixel count.
fn seed_plain() -> Result<Design> {
    let cam = Camera::paper();
    let ky = 2 * cam.ky as i64;
    let ch = seed_channel(&cam, cam.array_plane(Half::One), ky, 1.0);
    Design::new(cam.f_main, cam.aperture, Aperture::Square, &[ch])
}

/// A three-way split of the seed: the prism of the seed split in two equal steps, so the
/// arrays sit at v', v'(1 + κ/2) and v'(1 + κ). The outer two are the seed's (out-of-focus
/// planes 642 and 217 mm); the middle one's out-of-focus plane (300.3 mm) falls between
/// them, and each channel's out-of-focus plane lies where both other channels are sharp.
/// The 24 mm sensor height is split in three: K_y = ⌊8 / d⌋ = 59 per channel; shares 1/3.
fn split3() -> Result<Design> {
    let cam = Camera::paper();
    let ky = rows_in(SEED_SENSOR_HEIGHT / 3.0, cam.d);
    let planes = [
        cam.array_plane(Half::One),
        cam.v1 * (1.0 + cam.kappa / 2.0),
        cam.array_plane(Half::Two),
    ];
    let specs = planes.map(|l| seed_channel(&cam, l, ky, 1.0 / 3.0));
    Design::new(cam.f_main, cam.aperture, Aperture::Square, &specs)
}

/// Raytrix R12 (a multi-focus plenoptic camera in the Galilean configuration: the main lens
/// images the scene behind the array, and the three lens types relay that virtual image to
/// the sensor). Public numbers (github.com/comsee-research/plenoptic-datasets and the
/// calibration shipped with github.com/comsee-research/compote, focus configuration R12-A,
/// h = 450 mm): a 4080 × 3068 sensor of 5.5 µm pixels behind 176 × 152 hexagonal,
/// row-aligned microlenses of three types, a 50 mm main lens. From the calibration (to 5
/// significant digits): F = 49.885, L = 56.860, v = 0.33713, d = 0.12744,
/// f = (0.58267, 0.52402, 0.56057). Derived: D = d L / v (f-number matched: the aperture's
/// image behind a lens, D v / L, equals the pitch d and fills its cell of pitch
/// d (1 + v / L) to 99.4 %), a circular aperture.
fn raytrix_r12() -> Result<Design> {
    let (f_main, l, v, d) = (49.885, 56.860, 0.33713, 0.12744);
    let ch = ChannelSpec {
        l,
        d,
        v,
        mu: 0.0055,
        kx: 176,
        ky: 152,
        grid: Grid::Hex,
        f: Some(vec![0.58267, 0.52402, 0.56057]),
        layout: "sensor".into(),
        q: None,
        mx: Some(4080),
        my: Some(3068),
        share: 1.0,
    };
    Design::new(f_main, d * l / v, Aperture::Circle, &[ch])
}

/// Lytro Illum (an unfocused plenoptic camera: one hexagonal array of identical lenses).
/// Public numbers: a 7728 × 5368 sensor of 1.4 µm pixels, a hexagonal array of 20 µm pitch
/// (the Illum's own metadata, github.com/imageio/imageio tests/test_lytro.py), 541 × 434
/// lenses and, near the wide end of the zoom, F = 9.9845 mm at f/2 (the Illum intrinsics of Bok
/// et al. 2017 quoted by github.com/comsee-research/plenoptic-datasets). Derived:
/// D = F / N with N = 2; focused at the hyperfocal distance H = F² / (N d) + F (circle of
/// confusion one lens, d), whose conjugate is L = F H / (H − F) = F + N d; v = d L / D
/// (f-number matched: microlens images of diameter d); Ng's setting 1/f = 1/L + 1/v.
fn lytro_illum() -> Result<Design> {
    lytro_illum_reduced(1)
}

/// The `lytro-illum` preset with 1/`per_axis` of its lenses and pixels per axis (integer
/// division; the criterion benches' modest size is `per_axis` = 4: 135 × 108 lenses on
/// 1932 × 1342 pixels); 1 gives the preset itself. `per_axis` must be ≥ 1.
pub fn lytro_illum_reduced(per_axis: u32) -> Result<Design> {
    if per_axis == 0 {
        return Err(Error::param("per_axis", per_axis, "an integer >= 1"));
    }
    let k = i64::from(per_axis);
    let (f_main, n, d) = (9.9845, 2.0, 0.020);
    let aperture = f_main / n;
    let l = f_main + n * d;
    let ch = ChannelSpec {
        l,
        d,
        v: d * l / aperture,
        mu: 0.0014,
        kx: 541 / k,
        ky: 434 / k,
        grid: Grid::Hex,
        f: None,
        layout: "sensor".into(),
        q: None,
        mx: Some(7728 / k),
        my: Some(5368 / k),
        share: 1.0,
    };
    Design::new(f_main, aperture, Aperture::Circle, &[ch])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::optics::{design_depth_of_field, LensOptics};

    #[test]
    fn every_preset_is_valid_and_named() {
        for name in PRESETS {
            let d = preset(name).unwrap();
            let total: f64 = d.channels.iter().map(|c| c.share).sum();
            assert!(total <= 1.0 + 1e-12, "{name}");
        }
        let e = preset("nope").unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("preset"));
    }

    #[test]
    fn lytro_illum_reduced_divides_the_counts() {
        let full = preset("lytro-illum").unwrap();
        let quarter = lytro_illum_reduced(4).unwrap();
        let (a, b) = (&full.channels[0], &quarter.channels[0]);
        assert_eq!((b.kx, b.ky), (a.kx / 4, a.ky / 4));
        assert_eq!((b.kx, b.ky), (135, 108));
        assert_eq!((b.l, b.d, b.v, b.mu), (a.l, a.d, a.v, a.mu));
        let e = lytro_illum_reduced(0).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("per_axis"));
    }

    #[test]
    fn split3_out_of_focus_planes_interleave() {
        let d = preset("split3").unwrap();
        let dof = design_depth_of_field(&d, 0.5).unwrap();
        let inside = |iv: &[(f64, f64)], z: f64| iv.iter().any(|&(a, b)| a < z && z < b);
        for (i, ch) in d.channels.iter().enumerate() {
            let z = LensOptics::of_channel(&d, ch, 0).out_of_focus_depth();
            assert!(!inside(&dof.channels[i], z));
            for (j, iv) in dof.channels.iter().enumerate() {
                if j != i {
                    assert!(inside(iv, z), "channel {j} at channel {i}'s plane {z}");
                }
            }
        }
        assert_eq!(dof.union, vec![(d.f_main, f64::INFINITY)]);
    }
}
