//! The split-sensor light field camera (docs/model.md §1, §3, §7).
//!
//! Unfolded along the optical axis the device is two light field cameras sharing one main
//! lens; half i has its microlens array at `L_i` (L_1 = v', L_2 = v'(1+κ)) with microlens
//! focal length `f_i`, and its sensor a distance `v` behind the array. All lengths in mm.

use crate::error::{Error, Result};

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

/// One lateral axis of the sensor (the microlens grid is separable).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    X,
    Y,
}

/// Largest pixel count per microlens along one axis the core accepts.
pub const MAX_Q: u64 = 65_535;
/// Largest microlens count per half along one axis the core accepts.
pub const MAX_K: u64 = 10_000_000;

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

/// Lengths must be normal floats (not subnormal): the formulas divide by them, and the
/// reciprocal of a subnormal length overflows.
pub(crate) fn positive(name: &'static str, x: f64) -> Result<f64> {
    if x.is_normal() && x > 0.0 {
        Ok(x)
    } else {
        Err(Error::param(
            name,
            x,
            "a finite length > 0 mm (a normal float, >= 2.2250738585072014e-308)",
        ))
    }
}

/// A value derived from the given fields must pass the same rule as a given one: a
/// positive, finite, normal float whose reciprocal is finite.
pub(crate) fn derived(name: &'static str, x: f64, from: &str) -> Result<()> {
    if x.is_normal() && x > 0.0 && (1.0 / x).is_finite() {
        Ok(())
    } else {
        Err(Error::param(
            name,
            x,
            format!("a finite length > 0 mm (a normal float); it is derived from {from}, so choose them so that it is"),
        ))
    }
}

pub(crate) fn count(name: &'static str, n: i64, max: u64) -> Result<u32> {
    if n >= 1 && (n as u64) <= max {
        Ok(n as u32)
    } else {
        Err(Error::param(name, n, format!("an integer in [1, {max}]")))
    }
}

/// The array planes: v' behind the focal plane, κ ≥ 0 and L_2 = v'(1 + κ) finite.
/// Returns L_2.
fn check_planes(f_main: f64, v1: f64, kappa: f64) -> Result<f64> {
    if !(v1.is_finite() && v1 > f_main) {
        return Err(Error::param(
            "v1",
            v1,
            format!(
                "a finite length > F = {f_main} mm (the array must lie behind the focal plane)"
            ),
        ));
    }
    if !(kappa.is_finite() && kappa >= 0.0) {
        return Err(Error::param("kappa", kappa, "a finite number >= 0"));
    }
    let l2 = v1 * (1.0 + kappa);
    if !l2.is_finite() {
        return Err(Error::param(
            "kappa",
            kappa,
            "small enough that v1 (1 + kappa) is finite",
        ));
    }
    Ok(l2)
}

/// Ng's setting: microlenses focused on the main lens, 1/f = 1/L + 1/v.
pub fn ng_focal_length(l: f64, v: f64) -> f64 {
    1.0 / (1.0 / l + 1.0 / v)
}

impl Camera {
    /// Validate every field; `f1`/`f2` default to Ng's setting when `None`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        f_main: f64,
        aperture: f64,
        v1: f64,
        kappa: f64,
        d: f64,
        v: f64,
        mu: f64,
        q: i64,
        kx: i64,
        ky: i64,
        f1: Option<f64>,
        f2: Option<f64>,
    ) -> Result<Camera> {
        let f_main = positive("F", f_main)?;
        let aperture = positive("D", aperture)?;
        let l2 = check_planes(f_main, v1, kappa)?;
        let d = positive("d", d)?;
        let v = positive("v", v)?;
        let mu = positive("mu", mu)?;
        let q = count("Q", q, MAX_Q)?;
        let kx = count("Kx", kx, MAX_K)?;
        let ky = count("Ky", ky, MAX_K)?;
        let f1 = match f1 {
            Some(f) => positive("f1", f)?,
            None => ng_focal_length(v1, v),
        };
        let f2 = match f2 {
            Some(f) => positive("f2", f)?,
            None => ng_focal_length(l2, v),
        };
        let cam = Camera {
            f_main,
            aperture,
            v1,
            kappa,
            d,
            v,
            mu,
            q,
            kx,
            ky,
            f1,
            f2,
        };
        cam.check_derived()?;
        Ok(cam)
    }

    /// Every derived quantity the formulas use must be as valid as a given field: the
    /// microlens focal lengths (Ng's setting 1/f = 1/L + 1/v when not given), the image
    /// radius R_i = D v / (2 L_i), the blur scale d v / 2, the aperture image D L_i / 2
    /// and the chief-ray height of the outermost pixel (L_i / v) μ (Q − 1)/2.
    fn check_derived(&self) -> Result<()> {
        let ng = "Ng's setting 1/f = 1/L + 1/v (L = v1 or v1 (1 + kappa))";
        derived("f1", self.f1, ng)?;
        derived("f2", self.f2, ng)?;
        derived("d v / 2", self.d * self.v / 2.0, "d and v")?;
        for h in Half::BOTH {
            let l = self.array_plane(h);
            derived(
                "R (microlens image radius D v / (2 L))",
                self.image_radius(h),
                "D, v, v1 and kappa",
            )?;
            derived("D L / 2", self.aperture * l / 2.0, "D, v1 and kappa")?;
            derived("L / v", l / self.v, "v1, kappa and v")?;
            let edge = self.chief_w(h, 0).abs();
            if !edge.is_finite() {
                return Err(Error::param(
                    "mu",
                    self.mu,
                    "small enough that the outermost pixel's chief ray height (L / v) mu (Q - 1) / 2 is finite",
                ));
            }
        }
        Ok(())
    }

    /// The seed design (docs/model.md §7), a reconstruction from the paper's two out-of-focus
    /// planes (642 mm and 217 mm): F = 80, D = 20, d = 0.135, μ = 0.009, Q = 15,
    /// v = d v'/D (f-number matched on half 1), Ng's setting, K = 266 × 88 per half.
    pub fn paper() -> Camera {
        let f_main = 80.0;
        let aperture = 20.0;
        let v1 = f_main * 642.0 / (642.0 - f_main);
        let l2 = f_main * 217.0 / (217.0 - f_main);
        let d = 0.135;
        Camera::new(
            f_main,
            aperture,
            v1,
            l2 / v1 - 1.0,
            d,
            d * v1 / aperture,
            0.009,
            15,
            266,
            88,
            None,
            None,
        )
        .expect("the seed design is valid")
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

    /// ρ = κ v', the extra optical path of half 2 (one prism side).
    pub fn rho(&self) -> f64 {
        self.kappa * self.v1
    }

    /// F-number of the main lens, F / D.
    pub fn f_number(&self) -> f64 {
        self.f_main / self.aperture
    }

    /// Out-of-focus plane of half i: the depth whose conjugate lies on array i,
    /// z_i = F L_i / (L_i − F) (Eq. 1 inverted).
    pub fn out_of_focus_depth(&self, half: Half) -> f64 {
        let l = self.array_plane(half);
        self.f_main * l / (l - self.f_main)
    }

    /// R_i = D v / (2 L_i): radius of one microlens image on the sensor (bound of the LF blur).
    pub fn image_radius(&self, half: Half) -> f64 {
        self.aperture * self.v / (2.0 * self.array_plane(half))
    }

    /// K along an axis.
    pub fn lenses(&self, axis: Axis) -> u32 {
        match axis {
            Axis::X => self.kx,
            Axis::Y => self.ky,
        }
    }

    /// c_j = (j − (K−1)/2) d, centre of microlens j of K (docs/model.md §3).
    pub fn lens_center(&self, j: u32, k: u32) -> f64 {
        (j as f64 - (k as f64 - 1.0) / 2.0) * self.d
    }

    /// θ_q = μ (q − (Q−1)/2), angular offset of pixel q from its microlens image centre.
    pub fn pixel_offset(&self, q: u32) -> f64 {
        self.mu * (q as f64 - (self.q as f64 - 1.0) / 2.0)
    }

    /// Sensor position of pixel q under microlens centre c: s = c (1 + v/L_i) + θ_q.
    pub fn pixel_center(&self, half: Half, c: f64, q: u32) -> f64 {
        c * (1.0 + self.v / self.array_plane(half)) + self.pixel_offset(q)
    }

    /// w_q = −(L_i / v) θ_q: main-lens height of the chief ray of pixel q (independent of f).
    pub fn chief_w(&self, half: Half, q: u32) -> f64 {
        -(self.array_plane(half) / self.v) * self.pixel_offset(q)
    }

    /// A pixel is lit when its chief ray passes the main-lens aperture, |w_q| < D/2 (docs/model.md §6).
    pub fn is_lit(&self, half: Half, q: u32) -> bool {
        self.chief_w(half, q).abs() < self.aperture / 2.0
    }

    /// Q_lit: lit pixels per microlens along one axis for half i.
    pub fn lit_pixels(&self, half: Half) -> u32 {
        (0..self.q).filter(|&q| self.is_lit(half, q)).count() as u32
    }

    /// Chief sample of pixel q under microlens centre c on the plane with conjugate z'
    /// (docs/model.md §5): p' = (v'/L_i) [c + w_q (L_i − z')/z'], its projection through the
    /// main-lens centre onto plane v'.
    pub fn chief_projection(&self, half: Half, c: f64, q: u32, zc: f64) -> f64 {
        let l = self.array_plane(half);
        (self.v1 / l) * (c + self.chief_w(half, q) * (l - zc) / zc)
    }

    /// Object-space lateral position on the plane at depth z of a point projecting to p'
    /// on plane v': X = −p' z / v' (docs/model.md §5).
    pub fn object_position(&self, p: f64, z: f64) -> f64 {
        let x = -p * z;
        if x.is_finite() {
            x / self.v1
        } else {
            // p' z overflows only for astronomically far planes; the quotient does not.
            -p * (z / self.v1)
        }
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

    #[test]
    fn paper_out_of_focus_planes() {
        let cam = Camera::paper();
        assert!((cam.out_of_focus_depth(Half::One) - 642.0).abs() < 1e-9);
        assert!((cam.out_of_focus_depth(Half::Two) - 217.0).abs() < 1e-9);
        assert!((cam.kappa - 0.3866).abs() < 1e-4);
        assert!((cam.rho() - 35.3).abs() < 0.05);
    }

    #[test]
    fn paper_lit_pixels() {
        // Half 1 is f-number matched: all 15 lit. Half 2: |q − 7| < 7.5 / (1 + κ) = 5.41.
        let cam = Camera::paper();
        assert_eq!(cam.lit_pixels(Half::One), 15);
        assert_eq!(cam.lit_pixels(Half::Two), 11);
    }

    #[test]
    fn rejects_bad_fields() {
        let ok = Camera::paper();
        let mk = |v1: f64, kappa: f64, q: i64| {
            Camera::new(
                80.0, 20.0, v1, kappa, 0.135, ok.v, 0.009, q, 10, 10, None, None,
            )
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
}
