//! The split-sensor light field camera (docs/model.md §1, §3, §7).
//!
//! Unfolded along the optical axis the device is two light field cameras sharing one main
//! lens; half i has its microlens array at `L_i` (L_1 = v', L_2 = v'(1+κ)) with microlens
//! focal length `f_i`, and its sensor a distance `v` behind the array. All lengths in mm.

use crate::infra::error::{Error, Result};
use crate::model::design::{Aperture, Channel, ChannelSpec, Design, Grid, Layout};
use crate::model::lens::ng_focal_length;

/// Which half of the split sensor: half 1 is the conventional ("original") LF camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Half {
    One,
    Two,
}

impl Half {
    pub const BOTH: [Half; 2] = [Half::One, Half::Two];

    /// 0 for half 1, 1 for half 2 (the row of the two-row outputs).
    pub fn index(self) -> usize {
        match self {
            Half::One => 0,
            Half::Two => 1,
        }
    }

    /// Half from its paper number (1 or 2).
    pub fn from_number(n: i64) -> Result<Half> {
        match n {
            1 => Ok(Half::One),
            2 => Ok(Half::Two),
            _ => Err(Error::param("half", n, "1 or 2")),
        }
    }
}

/// A validated camera. Construct with [`Camera::new`]; fields are the docs/model.md symbols.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// F, main lens focal length.
    pub f_main: f64,
    /// D, main lens (square) aperture width.
    pub aperture: f64,
    /// v', main lens to the microlens array of half 1.
    pub v1: f64,
    /// κ = ρ / v', relative extra optical path of half 2.
    pub kappa: f64,
    /// d, microlens pitch (= diameter), both halves.
    pub d: f64,
    /// v, microlens array to sensor, both halves.
    pub v: f64,
    /// μ, pixel width.
    pub mu: f64,
    /// Q, pixels per microlens along one axis.
    pub q: u32,
    /// K_x, microlenses per half along x.
    pub kx: u32,
    /// K_y, microlenses per half along y.
    pub ky: u32,
    /// f_1, microlens focal length of half 1.
    pub f1: f64,
    /// f_2, microlens focal length of half 2.
    pub f2: f64,
}

/// The paper's rule for the second half: it lies behind the first, κ ≥ 0, and
/// L_2 = v'(1 + κ) is finite. Returns L_2. (Every other rule is the design's.)
fn check_kappa(v1: f64, kappa: f64) -> Result<f64> {
    if !(kappa.is_finite() && kappa >= 0.0) {
        return Err(Error::param("kappa", kappa, "a finite number >= 0"));
    }
    let l2 = v1 * (1.0 + kappa);
    // Only a valid v1 can make kappa the culprit; an invalid v1 is channel 1's L, which the
    // design checks (and names v1) before channel 2's.
    if v1.is_finite() && v1 > 0.0 && !l2.is_finite() {
        return Err(Error::param(
            "kappa",
            kappa,
            "small enough that v1 (1 + kappa) is finite",
        ));
    }
    Ok(l2)
}

/// A design's error said of the camera's own fields: channel i's L is v1 (i = 1) or
/// kappa (i = 2), its f is f1 or f2, every other field (D, d, v, mu, Q, Kx, Ky and the
/// derived lengths) keeps its name; the value and the rule are the design's.
fn camera_error(e: Error) -> Error {
    match e {
        Error::InvalidParameter {
            name,
            value,
            allowed,
            channel,
        } => {
            let name = match (channel, name) {
                (Some(1), "L") => "v1",
                (Some(2), "L") => "kappa",
                (Some(1), "f") => "f1",
                (Some(2), "f") => "f2",
                (_, other) => other,
            };
            Error::InvalidParameter {
                name,
                value,
                allowed,
                channel: None,
            }
        }
        other => other,
    }
}

/// A camera's fields before validation ([`Camera::new`]): the docs/model.md symbols of
/// [`Camera`], Q and K as given (any integer) and f_1/f_2 `None` for Ng's setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSpec {
    pub f_main: f64,
    pub aperture: f64,
    pub v1: f64,
    pub kappa: f64,
    pub d: f64,
    pub v: f64,
    pub mu: f64,
    pub q: i64,
    pub kx: i64,
    pub ky: i64,
    pub f1: Option<f64>,
    pub f2: Option<f64>,
}

impl CameraSpec {
    /// The fields of the seed design ([`Camera::paper`]), in Ng's setting.
    pub fn paper() -> CameraSpec {
        let f_main = 80.0;
        let aperture = 20.0;
        let v1 = f_main * 642.0 / (642.0 - f_main);
        let l2 = f_main * 217.0 / (217.0 - f_main);
        let d = 0.135;
        CameraSpec {
            f_main,
            aperture,
            v1,
            kappa: l2 / v1 - 1.0,
            d,
            v: d * v1 / aperture,
            mu: 0.009,
            q: 15,
            kx: 266,
            ky: 88,
            f1: None,
            f2: None,
        }
    }
}

impl Camera {
    /// Validate every field; `f1`/`f2` default to Ng's setting when `None`. The camera is
    /// the two-channel design of [`Camera::design`] and is valid exactly when that design
    /// is ([`Design::new`]: overlapping microlens images are refused too), with κ ≥ 0 as
    /// the parametrisation's own rule; an error names the camera's field.
    pub fn new(spec: &CameraSpec) -> Result<Camera> {
        let s = spec;
        let l2 = check_kappa(s.v1, s.kappa)?;
        let channel = |l: f64, f: Option<f64>| ChannelSpec {
            l,
            d: s.d,
            v: s.v,
            mu: s.mu,
            kx: s.kx,
            ky: s.ky,
            grid: Grid::Rect,
            f: f.map(|f| vec![f]),
            layout: "ideal".into(),
            q: Some(s.q),
            mx: None,
            my: None,
            share: 0.5,
        };
        let specs = [channel(s.v1, s.f1), channel(l2, s.f2)];
        let design =
            Design::new(s.f_main, s.aperture, Aperture::Square, &specs).map_err(camera_error)?;
        let [c1, c2] = [&design.channels[0], &design.channels[1]];
        Ok(Camera {
            f_main: design.f_main,
            aperture: design.aperture,
            v1: c1.l,
            kappa: s.kappa,
            d: c1.d,
            v: c1.v,
            mu: c1.mu,
            // Q passed the design's check: an integer in [1, MAX_Q].
            q: s.q as u32,
            kx: c1.kx,
            ky: c1.ky,
            f1: c1.f[0],
            f2: c2.f[0],
        })
    }

    /// The camera as its two-channel design: channel i is half i (L_1 = v', L_2 = v'(1 + κ)),
    /// rect grids, the ideal layout with Q, shares ½, a square aperture, f_i as the camera
    /// has them (Ng's setting when they equal it).
    pub fn design(&self) -> Design {
        let channel = |half: Half| {
            let l = self.array_plane(half);
            let f = self.microlens_focal(half);
            Channel {
                l,
                d: self.d,
                v: self.v,
                mu: self.mu,
                kx: self.kx,
                ky: self.ky,
                grid: Grid::Rect,
                f: vec![f],
                ng: f == ng_focal_length(l, self.v),
                layout: Layout::Ideal { q: self.q },
                share: 0.5,
            }
        };
        Design {
            f_main: self.f_main,
            aperture: self.aperture,
            shape: Aperture::Square,
            channels: vec![channel(Half::One), channel(Half::Two)],
        }
    }

    /// The seed design (docs/model.md §7), a reconstruction from the paper's two out-of-focus
    /// planes (642 mm and 217 mm): F = 80, D = 20, d = 0.135, μ = 0.009, Q = 15,
    /// v = d v'/D (f-number matched on half 1), Ng's setting, K = 266 × 88 per half.
    pub fn paper() -> Camera {
        Camera::new(&CameraSpec::paper()).expect("the seed design is valid")
    }

    /// L_i, the array plane of half i: L_1 = v', L_2 = v'(1+κ).
    pub fn array_plane(&self, half: Half) -> f64 {
        match half {
            Half::One => self.v1,
            Half::Two => self.v1 * (1.0 + self.kappa),
        }
    }

    /// f_i, the microlens focal length of half i.
    pub fn microlens_focal(&self, half: Half) -> f64 {
        match half {
            Half::One => self.f1,
            Half::Two => self.f2,
        }
    }

    /// Lit pixels under one lens along x of half i (docs/model.md §3): the q whose chief
    /// ray w = −(L_i/v) θ_q, θ_q = μ (q − (Q − 1)/2), passes the aperture, |w| < D/2.
    pub fn lit_pixels(&self, half: Half) -> u32 {
        let l = self.array_plane(half);
        let lit = |q: u32| {
            let theta = self.mu * (q as f64 - (self.q as f64 - 1.0) / 2.0);
            (-(l / self.v) * theta).abs() < self.aperture / 2.0
        };
        (0..self.q).filter(|&q| lit(q)).count() as u32
    }

    /// ρ = κ v', the extra optical path of half 2 (one prism side).
    pub fn rho(&self) -> f64 {
        self.kappa * self.v1
    }

    /// F-number of the main lens, F / D.
    pub fn f_number(&self) -> f64 {
        self.f_main / self.aperture
    }

    /// δ(z) = d z / (Q v'): object-space size of one sensor-resolution step (docs/model.md §6).
    pub fn resolution_step(&self, z: f64) -> f64 {
        let dz = self.d * z;
        if dz.is_finite() {
            dz / (self.q as f64 * self.v1)
        } else {
            self.d * (z / (self.q as f64 * self.v1))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::lens::depth_of_conjugate;
    use crate::sampling::line::{Axis, Line};

    /// Lit pixels of channel `number` along x under one lens.
    fn lit_pixels(d: &Design, number: i64) -> usize {
        let line = Line::of_channel(d, number, Axis::X).unwrap();
        (0..line.q().unwrap())
            .filter(|&i| line.pixel(i).lit)
            .count()
    }

    #[test]
    fn paper_out_of_focus_planes() {
        let cam = Camera::paper();
        let d = cam.design();
        for (ch, z) in d.channels.iter().zip([642.0, 217.0]) {
            assert!((depth_of_conjugate(cam.f_main, ch.l) - z).abs() < 1e-9);
        }
        assert!((cam.kappa - 0.3866).abs() < 1e-4);
        assert!((cam.rho() - 35.3).abs() < 0.05);
    }

    #[test]
    fn paper_lit_pixels() {
        // Half 1 is f-number matched: all 15 lit. Half 2: |q − 7| < 7.5 / (1 + κ) = 5.41.
        let cam = Camera::paper();
        let d = cam.design();
        assert_eq!(lit_pixels(&d, 1), 15);
        assert_eq!(lit_pixels(&d, 2), 11);
        assert_eq!(
            [cam.lit_pixels(Half::One), cam.lit_pixels(Half::Two)],
            [15, 11]
        );
    }

    #[test]
    fn lit_pixels_are_the_lines_lit_pixels() {
        // The camera's count against the 1-D line's pixels (sampling::line), over apertures
        // from vignetted to f-number matched, odd and even Q (Q μ = d).
        for (aperture, q, mu) in [
            (20.0, 15, 0.009),
            (14.0, 15, 0.009),
            (9.0, 15, 0.009),
            (14.0, 10, 0.0135),
            (7.0, 10, 0.0135),
        ] {
            let cam = Camera::new(&CameraSpec {
                aperture,
                mu,
                q,
                kx: 6,
                ky: 4,
                ..CameraSpec::paper()
            })
            .unwrap();
            let d = cam.design();
            for (n, half) in [(1, Half::One), (2, Half::Two)] {
                assert_eq!(
                    cam.lit_pixels(half) as usize,
                    lit_pixels(&d, n),
                    "{aperture} {q}"
                );
            }
        }
    }

    #[test]
    fn rejects_bad_fields() {
        let ok = Camera::paper();
        let mk = |v1: f64, kappa: f64, q: i64| {
            Camera::new(&CameraSpec {
                f_main: 80.0,
                aperture: 20.0,
                v1,
                kappa,
                d: 0.135,
                v: ok.v,
                mu: 0.009,
                q,
                kx: 10,
                ky: 10,
                f1: None,
                f2: None,
            })
        };
        assert!(matches!(
            mk(80.0, 0.1, 15),
            Err(Error::InvalidParameter { name: "v1", .. })
        ));
        assert!(matches!(
            mk(90.0, -0.1, 15),
            Err(Error::InvalidParameter { name: "kappa", .. })
        ));
        assert!(matches!(
            mk(90.0, 0.1, 0),
            Err(Error::InvalidParameter { name: "Q", .. })
        ));
        assert!(matches!(
            mk(f64::NAN, 0.1, 15),
            Err(Error::InvalidParameter { name: "v1", .. })
        ));
    }

    /// The camera refuses what its design refuses, naming its own field: the seed with
    /// v = 0.7 or D = 40 has overlapping microlens images.
    #[test]
    fn validates_as_its_design() {
        let p = Camera::paper();
        let with = |aperture: f64, v: f64, f1: Option<f64>| {
            Camera::new(&CameraSpec {
                f_main: p.f_main,
                aperture,
                v1: p.v1,
                kappa: p.kappa,
                d: p.d,
                v,
                mu: p.mu,
                q: 15,
                kx: 266,
                ky: 88,
                f1,
                f2: None,
            })
        };
        for (aperture, v) in [(20.0, 0.7), (40.0, p.v)] {
            let e = with(aperture, v, None).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("D"), "{e}");
            assert!(e.to_string().contains("overlap"), "{e}");
        }
        let e = with(20.0, p.v, Some(-1.0)).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("f1"));
        let e = Camera::new(&CameraSpec {
            f2: Some(0.0),
            ..CameraSpec::paper()
        })
        .unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("f2"));
        let e = with(20.0, 0.0, None).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("v"));
    }

    /// `Camera::design` is the design `Camera::new` validated.
    #[test]
    fn seed_design_matches_camera() {
        let cam = Camera::paper();
        let d = cam.design();
        let spec = |l: f64| ChannelSpec {
            l,
            d: cam.d,
            v: cam.v,
            mu: cam.mu,
            kx: 266,
            ky: 88,
            grid: Grid::Rect,
            f: None,
            layout: "ideal".into(),
            q: Some(15),
            mx: None,
            my: None,
            share: 0.5,
        };
        let specs = [spec(cam.v1), spec(cam.array_plane(Half::Two))];
        assert_eq!(
            d,
            Design::new(cam.f_main, cam.aperture, Aperture::Square, &specs).unwrap()
        );
        assert_eq!(d.channels.len(), 2);
        assert_eq!(d.channels[1].l, cam.array_plane(Half::Two));
        assert!(d.channels.iter().all(|c| c.ng));
        // Lit pixels along x of half 2 (2-D pixels of the centre row) equal the 1-D rule's.
        let ch = &d.channels[1];
        let lit = (0..cam.q)
            .filter(|&a| d.pixel(ch, a, cam.q / 2).lit)
            .count();
        assert_eq!(lit, lit_pixels(&d, 2));
    }
}
