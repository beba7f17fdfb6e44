//! Small designs of every kind and a random source, shared by the unit tests of the
//! folder.

use crate::model::camera::{Camera, CameraSpec};
use crate::model::design::{Aperture, ChannelSpec, Design, Grid};

/// A rect channel of share ½ without a layout's numbers: L, d, v, μ and (K_x, K_y).
fn spec(l: f64, d: f64, v: f64, mu: f64, k: (i64, i64)) -> ChannelSpec {
    ChannelSpec {
        l,
        d,
        v,
        mu,
        kx: k.0,
        ky: k.1,
        grid: Grid::Rect,
        f: None,
        layout: "ideal".into(),
        q: None,
        mx: None,
        my: None,
        share: 0.5,
    }
}

/// `s` in the ideal layout with Q pixels per lens.
pub(super) fn ideal(q: i64, s: ChannelSpec) -> ChannelSpec {
    ChannelSpec { q: Some(q), ..s }
}

/// `s` on `grid` in the sensor layout of M_x × M_y pixels (None: the covering grid).
pub(super) fn sensor(grid: Grid, m: Option<(i64, i64)>, s: ChannelSpec) -> ChannelSpec {
    ChannelSpec {
        grid,
        layout: "sensor".into(),
        mx: m.map(|m| m.0),
        my: m.map(|m| m.1),
        ..s
    }
}

/// One channel of 40 x 36 lenses of pitch `d` with Q = 1 pixel per lens (pixel pitch
/// 0.01), behind a square main lens of aperture `aperture` (F = 50, L = 60, v = 0.3).
pub(super) fn one_pixel_lenses(aperture: f64, d: f64) -> Design {
    let channel = ideal(1, spec(60.0, d, 0.3, 0.01, (40, 36)));
    Design::new(50.0, aperture, Aperture::Square, &[channel]).unwrap()
}

/// Small designs of every kind: rect/hex, ideal/sensor, square/circle, several types,
/// sensors wider than the array (pixels beyond its edge).
pub(super) fn designs() -> Vec<Design> {
    let hex3 = Some(vec![0.3, 0.31, 0.32]);
    let design = |f_main: f64, aperture: f64, shape: Aperture, specs: &[ChannelSpec]| {
        Design::new(f_main, aperture, shape, specs).unwrap()
    };
    let multi_type = ChannelSpec {
        f: hex3.clone(),
        ..sensor(Grid::Hex, None, spec(60.0, 0.1, 0.3, 0.011, (9, 8)))
    };
    let wide = sensor(
        Grid::Hex,
        Some((80, 70)),
        spec(75.0, 0.1, 0.3, 0.013, (7, 6)),
    );
    let two_types = ChannelSpec {
        f: Some(vec![0.35, 0.37]),
        ..ideal(8, spec(70.0, 0.1, 0.4, 0.0125, (6, 5)))
    };
    let rect_sensor = ChannelSpec {
        f: hex3,
        ..sensor(
            Grid::Rect,
            Some((61, 40)),
            spec(65.0, 0.12, 0.5, 0.017, (7, 4)),
        )
    };
    let one_row = sensor(Grid::Hex, None, spec(55.0, 0.15, 0.5, 0.01, (5, 1)));
    // Pixel pitch a tenth of the image pitch (0.1 (1 + 0.3/60) / 10) and odd pixel
    // counts: pixel centres fall (within rounding) midway between two lens images, the
    // nearest-lens search's ties.
    let ties = sensor(
        Grid::Rect,
        Some((81, 61)),
        spec(60.0, 0.1, 0.3, 0.01005, (8, 6)),
    );
    vec![
        design(50.0, 10.0, Aperture::Circle, &[multi_type, wide]),
        design(
            50.0,
            8.0,
            Aperture::Square,
            &[ideal(5, spec(60.0, 0.1, 0.4, 0.02, (6, 5))), two_types],
        ),
        design(50.0, 9.0, Aperture::Square, &[rect_sensor]),
        design(40.0, 12.0, Aperture::Circle, &[one_row]),
        design(50.0, 10.0, Aperture::Square, &[ties]),
        small_camera().design(),
    ]
}

fn small_camera() -> Camera {
    Camera::new(&CameraSpec {
        kappa: 0.3866,
        kx: 12,
        ky: 9,
        ..CameraSpec::paper()
    })
    .unwrap()
}

/// A xorshift source of uniform numbers in [0, 1).
pub(super) struct Rng(pub(super) u64);

impl Rng {
    pub(super) fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}
