//! One channel seen along one axis: the 1-D view the ray-space engine ([`crate::sampling::rayspace`])
//! and the sample counts ([`crate::sampling::samples`]) run on (docs/model.md §3–§6, and §9 for
//! designs: "The 1-D analysis of §3–§6 runs along x on rect grids").
//!
//! A [`Line`] is a channel of a [`Design`] ([`Line::of_channel`], rect grids only); the
//! paper's half i is channel i of `Camera::design`. Every formula here is written in the
//! order docs/model.md gives it, so the seed's numbers are the paper's closed forms bit for
//! bit.
//!
//! - Lens j (j = 0 … K − 1) is centred at c_j = (j − (K − 1)/2) d; its type is j mod T
//!   (x axis; along y, k mod T: the column j = 0 of the rect pattern (j + k) mod T).
//! - Ideal layout: pixel i = j Q + q has the offset θ = μ (q − (Q − 1)/2).
//! - Sensor layout: pixel i = m of M sits at s = μ (m − (M − 1)/2); its lens is the one
//!   whose image centre is nearest ([`Channel::nearest_lens`], ties to the lower index),
//!   θ = s − c_j (1 + v/L), and it is lit only when its centre lies in that lens's image
//!   cell ([`Channel::in_cell`]).
//! - A pixel is lit when its chief ray, w = −(L/v) θ, passes the aperture: |w| < D/2. In one
//!   dimension the aperture is its section by the axis, so a square and a circle of width
//!   D are the same segment.
//! - Ray space is referred to plane v_ref = L_1 (channel 1's array; v' of the paper's camera).

use crate::infra::error::{Error, Result};
use crate::model::design::{Aperture, Channel, Design, Grid, Layout};

/// One lateral axis of the sensor (a rect microlens grid is separable).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    X,
    Y,
}

/// How the pixels of a line are laid out.
#[derive(Debug, Clone, PartialEq)]
pub enum LinePixels {
    /// Q pixels per lens centred on its image (pixel i = j Q + q).
    Ideal { q: u32 },
    /// M pixels of pitch μ centred on the axis; the channel decides each pixel's lens.
    Sensor { m: u32, channel: Box<Channel> },
}

/// One pixel of a line: its lens j, offset θ from that lens's image centre, lit flag.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinePixel {
    pub j: u32,
    pub theta: f64,
    pub lit: bool,
}

/// One channel along one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// The channel's index from 0 (half 1 is 0).
    pub index: usize,
    pub axis: Axis,
    /// F, main-lens focal length.
    pub f_main: f64,
    /// D, main-lens aperture width.
    pub aperture: f64,
    /// The reference plane of ray space (v' of the camera, L_1 of a design).
    pub v_ref: f64,
    /// L, main lens → this array.
    pub l: f64,
    pub d: f64,
    pub v: f64,
    pub mu: f64,
    /// Lenses along the axis.
    pub k: u32,
    /// Focal length of each lens type (lens j has type j mod T).
    pub focal: Vec<f64>,
    /// Fraction of the main lens's light that reaches the channel (½ per camera half).
    pub share: f64,
    pub pixels: LinePixels,
}

impl Line {
    /// Channel `number` (from 1) of `design` along `axis`. The 1-D analysis needs a rect
    /// grid: a hex channel is refused, naming `channels[i].grid`.
    pub fn of_channel(design: &Design, number: i64, axis: Axis) -> Result<Line> {
        let ch = design.channel(number)?;
        let index = number as usize - 1;
        if ch.grid != Grid::Rect {
            return Err(Error::param(
                "grid",
                "\"hex\"",
                "\"rect\": the 1-D analysis (docs/model.md §3–§6, trace, footprints, \
                 new_samples, coincidence_planes) runs along x on rect grids only; \
                 hexagonal arrays have the 2-D analysis (chief_samples, samples_2d, coverage)",
            )
            .in_channel(number as usize));
        }
        let (k, pixels) = match (ch.layout, axis) {
            (Layout::Ideal { q }, Axis::X) => (ch.kx, LinePixels::Ideal { q }),
            (Layout::Ideal { q }, Axis::Y) => (ch.ky, LinePixels::Ideal { q }),
            (Layout::Sensor { mx, .. }, Axis::X) => (
                ch.kx,
                LinePixels::Sensor {
                    m: mx,
                    channel: Box::new(ch.clone()),
                },
            ),
            (Layout::Sensor { my, .. }, Axis::Y) => (
                ch.ky,
                LinePixels::Sensor {
                    m: my,
                    channel: Box::new(ch.clone()),
                },
            ),
        };
        Ok(Line {
            index,
            axis,
            f_main: design.f_main,
            aperture: design.aperture,
            v_ref: design.channels[0].l,
            l: ch.l,
            d: ch.d,
            v: ch.v,
            mu: ch.mu,
            k,
            focal: ch.f.clone(),
            share: ch.share,
            pixels,
        })
    }

    /// Every channel of `design` along `axis` (each must be rect).
    pub fn of_design(design: &Design, axis: Axis) -> Result<Vec<Line>> {
        (1..=design.channels.len() as i64)
            .map(|i| Line::of_channel(design, i, axis))
            .collect()
    }

    /// Q of the ideal layout, None for the sensor layout.
    pub fn q(&self) -> Option<u32> {
        match self.pixels {
            LinePixels::Ideal { q } => Some(q),
            LinePixels::Sensor { .. } => None,
        }
    }

    /// Pixels along the line: K Q (ideal) or M (sensor).
    pub fn pixel_count(&self) -> u128 {
        match &self.pixels {
            LinePixels::Ideal { q } => self.k as u128 * *q as u128,
            LinePixels::Sensor { m, .. } => *m as u128,
        }
    }

    /// Number of lens types T.
    pub fn types(&self) -> usize {
        self.focal.len()
    }

    /// Type of lens j: j mod T.
    #[inline]
    pub fn lens_type(&self, j: u32) -> usize {
        j as usize % self.focal.len()
    }

    /// c_j = (j − (K−1)/2) d (docs/model.md §3; as the rect
    /// `Channel::lens_center` along this axis: the product is the same either way round).
    #[inline]
    pub fn lens_center(&self, j: u32) -> f64 {
        (j as f64 - (self.k as f64 - 1.0) / 2.0) * self.d
    }

    /// θ_q = μ (q − (Q−1)/2) of the ideal layout (docs/model.md §3).
    #[inline]
    pub fn ideal_offset(&self, q: u32, q_count: u32) -> f64 {
        self.mu * (q as f64 - (q_count as f64 - 1.0) / 2.0)
    }

    /// w = −(L/v) θ: main-lens height of the chief ray of a pixel at offset θ (any f).
    #[inline]
    pub fn chief_w(&self, theta: f64) -> f64 {
        -(self.l / self.v) * theta
    }

    /// Does the chief ray of height w pass the aperture (|w| < D/2)?
    #[inline]
    pub fn passes(&self, w: f64) -> bool {
        w.abs() < self.aperture / 2.0
    }

    /// Pixel i of the line (docs/model.md §3, §6; §9 "Pixel layouts").
    pub fn pixel(&self, i: u32) -> LinePixel {
        match &self.pixels {
            LinePixels::Ideal { q } => {
                let (j, qq) = (i / q, i % q);
                let theta = self.ideal_offset(qq, *q);
                LinePixel {
                    j,
                    theta,
                    lit: self.passes(self.chief_w(theta)),
                }
            }
            LinePixels::Sensor { m, channel } => {
                let s = self.mu * (i as f64 - (*m as f64 - 1.0) / 2.0);
                let mag = channel.magnification();
                // The other coordinate on the image centre of lens 0 of the other axis:
                // the rect nearest-lens rule is separable, so this picks the nearest lens
                // along this axis with ties to the lower index.
                let (j, theta, cell) = match self.axis {
                    Axis::X => {
                        let y = channel.lens_center(0, 0)[1] * mag;
                        let j = channel.nearest_lens([s, y]).0;
                        let t = s - channel.lens_center(j, 0)[0] * mag;
                        (j, t, [t, 0.0])
                    }
                    Axis::Y => {
                        let x = channel.lens_center(0, 0)[0] * mag;
                        let k = channel.nearest_lens([x, s]).1;
                        let t = s - channel.lens_center(0, k)[1] * mag;
                        (k, t, [0.0, t])
                    }
                };
                LinePixel {
                    j,
                    theta,
                    lit: channel.in_cell(cell) && self.passes(self.chief_w(theta)),
                }
            }
        }
    }

    /// Chief sample p' on plane v_ref of a pixel of lens centre c and chief height w on the
    /// plane with conjugate z' (docs/model.md §5): p' = (v_ref/L) [c + w (L − z')/z'].
    #[inline]
    pub fn chief_projection(&self, c: f64, w: f64, zc: f64) -> f64 {
        let l = self.l;
        (self.v_ref / l) * (c + w * (l - zc) / zc)
    }

    /// X = −p' z / v_ref (docs/model.md §5).
    #[inline]
    pub fn object_position(&self, p: f64, z: f64) -> f64 {
        let x = -p * z;
        if x.is_finite() {
            x / self.v_ref
        } else {
            -p * (z / self.v_ref)
        }
    }

    /// σ = (v_ref − z')/z': a point of the plane at depth z is the line u + σ w = p'.
    #[inline]
    pub fn slope(&self, zc: f64) -> f64 {
        (self.v_ref - zc) / zc
    }

    /// Rays through the aperture and one lens: D d v_ref / L, the area of the lens's
    /// parallelogram in (u, w) (docs/model.md §8), times the channel's share.
    pub fn lens_light(&self) -> f64 {
        self.aperture * self.d * self.v_ref / self.l * self.share
    }
}

/// Refuse what the coincidence planes of docs/model.md §6 cannot describe: a square
/// aperture (Eqs. 8–9 are products of one factor per axis) and, for channel `number`, the
/// ideal layout (every lens has the same pixel offsets). The grid is checked by
/// [`Line::of_channel`].
pub fn check_coincidence_channel(design: &Design, number: i64) -> Result<()> {
    let ch = design.channel(number)?;
    if design.shape != Aperture::Square {
        return Err(Error::param(
            "aperture",
            "\"circle\"",
            "\"square\": Eqs. 8–9 (docs/model.md §6) count the product of one lit set per \
             axis, which a circular aperture does not give",
        ));
    }
    if let Layout::Sensor { .. } = ch.layout {
        return Err(Error::param(
            "layout",
            "\"sensor\"",
            "\"ideal\": coincidence planes and Eqs. 8–9 (docs/model.md §6) need the ideal \
             layout, where every lens has the same pixel offsets",
        )
        .in_channel(number as usize));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The seed's lines follow the paper's closed forms bit for bit, each written in the
    /// order docs/model.md gives it: θ_q = μ (q − (Q−1)/2), c_j = (j − (K−1)/2) d,
    /// w_q = −(L/v) θ_q, lit iff |w_q| < D/2, p' = (v'/L) [c + w (L − z')/z'].
    #[test]
    fn seed_lines_follow_the_closed_forms() {
        let d = crate::model::camera::Camera::paper().design();
        for (h, ch) in d.channels.iter().enumerate() {
            let Layout::Ideal { q: qq } = ch.layout else {
                panic!("the seed has the ideal layout")
            };
            for (axis, k) in [(Axis::X, ch.kx), (Axis::Y, ch.ky)] {
                let a = Line::of_channel(&d, h as i64 + 1, axis).unwrap();
                for i in 0..a.pixel_count() as u32 {
                    let p = a.pixel(i);
                    let q = i % qq;
                    let theta = ch.mu * (q as f64 - (qq as f64 - 1.0) / 2.0);
                    assert_eq!(p.theta.to_bits(), theta.to_bits());
                    let w = -(ch.l / ch.v) * theta;
                    assert_eq!(p.lit, w.abs() < d.aperture / 2.0);
                    let c = (p.j as f64 - (k as f64 - 1.0) / 2.0) * ch.d;
                    assert_eq!(a.lens_center(p.j).to_bits(), c.to_bits());
                    assert_eq!(a.chief_w(p.theta).to_bits(), w.to_bits());
                    let zc = 123.4;
                    let v1 = d.channels[0].l;
                    let want = (v1 / ch.l) * (c + w * (ch.l - zc) / zc);
                    assert_eq!(a.chief_projection(c, w, zc).to_bits(), want.to_bits());
                }
            }
        }
    }
}
