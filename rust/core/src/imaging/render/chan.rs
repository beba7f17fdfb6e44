//! One channel as the renderer sees it ([`Chan`]: its lens types, cell, aperture and
//! norm) and a worker's buffers ([`Work`]), shared by the general route, the exact route
//! and record mode.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::hash::{BuildHasherDefault, Hasher};

use super::footprint;
use crate::imaging::scene::Surface;
use crate::imaging::texture::Scratch;
use crate::infra::polygon::Pt;
use crate::model::design::{Aperture, Channel, Design, Grid};

/// Fewest and most sides of the equal-area polygon that stands for a circular aperture.
pub const MIN_CIRCLE_SIDES: usize = 32;
pub const MAX_CIRCLE_SIDES: usize = 1024;

/// Sides of the equal-area polygon for a circular aperture at tolerance `tol`: the area
/// between a disc and its equal-area n-gon is about 2.5/n² of the disc (measured: 1.1e-3 at
/// n = 48, 1.5e-4 at 128, 3.9e-5 at 256), a bound on the error it makes in any pixel as a
/// fraction of white; n keeps it below tol/4, leaving the rest to the quadrature.
pub fn circle_sides(tol: f64) -> usize {
    let n = (2.5 / (0.25 * tol)).sqrt().ceil();
    (n as usize).clamp(MIN_CIRCLE_SIDES, MAX_CIRCLE_SIDES)
}
/// Relative accuracy assumed of one evaluation of the integrand on a slanted plane or a
/// depth map (its pieces' count changes with the node, so it is not smooth at that level):
/// the adaptive rule accepts a box when its two rules agree to tol plus this fraction of
/// the box's value, instead of chasing those steps to the deepest level.
const PIECE_NOISE: f64 = 2e-4;

/// One channel as the renderer sees it.
pub(crate) struct Chan<'a> {
    pub(crate) ch: &'a Channel,
    pub(crate) f_main: f64,
    /// Aperture half-width (square) or radius (circle).
    pub(crate) r_ap: f64,
    pub(crate) shape: Aperture,
    /// share (L_1/L)² / (μ_1² A).
    pub(crate) norm: f64,
    /// (α, κ = v/f) per lens type.
    pub(crate) types: Vec<(f64, f64)>,
    /// The lens cell around its centre (counter-clockwise).
    pub(crate) cell: Vec<Pt>,
    /// Half-extents of the cell's bounding box; the y of the hex's side vertices.
    pub(crate) hx: f64,
    pub(crate) hy: f64,
    pub(super) hy_side: f64,
    /// The unit circle as an equal-area polygon (circle apertures).
    pub(crate) ngon: Vec<Pt>,
    /// Lens image centre magnification 1 + v/L.
    pub(super) m: f64,
    /// v/L.
    pub(crate) vl: f64,
    /// The raw rows a render of the channel fills: all of them, or a band
    /// ([`super::render_band`]).
    pub(crate) rows: std::ops::Range<usize>,
}

impl<'a> Chan<'a> {
    pub(crate) fn new(design: &'a Design, ch: &'a Channel, tol: f64) -> Chan<'a> {
        let l1 = design.channels[0].l;
        let mu1 = design.channels[0].mu;
        let r_ap = design.aperture / 2.0;
        let area = match design.shape {
            Aperture::Square => design.aperture * design.aperture,
            Aperture::Circle => PI * r_ap * r_ap,
        };
        let norm = ch.share * (l1 / ch.l).powi(2) / (mu1 * mu1 * area);
        let types =
            ch.f.iter()
                .map(|&f| (1.0 + ch.v / ch.l - ch.v / f, ch.v / f))
                .collect();
        let d = ch.d;
        let (cell, hx, hy, hy_side) = match ch.grid {
            Grid::Rect => {
                let h = d / 2.0;
                (vec![[-h, -h], [h, -h], [h, h], [-h, h]], h, h, h)
            }
            Grid::Hex => {
                let (a, b) = (d / 2.0, d / 3f64.sqrt());
                let side = b / 2.0;
                (
                    vec![
                        [0.0, -b],
                        [a, -side],
                        [a, side],
                        [0.0, b],
                        [-a, side],
                        [-a, -side],
                    ],
                    a,
                    b,
                    side,
                )
            }
        };
        let sides = circle_sides(tol);
        let n = sides as f64;
        let scale = (2.0 * PI / (n * (2.0 * PI / n).sin())).sqrt();
        let ngon = (0..sides)
            .map(|i| {
                let t = 2.0 * PI * i as f64 / n;
                [scale * t.cos(), scale * t.sin()]
            })
            .collect();
        Chan {
            ch,
            f_main: design.f_main,
            r_ap,
            shape: design.shape,
            norm,
            types,
            cell,
            hx,
            hy,
            hy_side,
            ngon,
            m: ch.magnification(),
            vl: ch.v / ch.l,
            rows: 0..super::raw_shape(ch).0,
        }
    }

    /// The channel rendered on the raw rows `rows` alone (a band, checked by the caller).
    pub(crate) fn with_rows(mut self, rows: std::ops::Range<usize>) -> Chan<'a> {
        self.rows = rows;
        self
    }

    /// Largest reach of a lens's light from its image centre on the sensor, per axis.
    pub(crate) fn reach(&self) -> [f64; 2] {
        let amax = self.types.iter().map(|t| t.0.abs()).fold(0.0, f64::max);
        let ap = self.vl * self.r_ap;
        [amax * self.hx + ap, amax * self.hy + ap]
    }

    /// The lenses (rows k, columns j) whose light can reach the sensor point s (sensor
    /// layout): those around the nearest lens within `reach` (per axis) of their images.
    pub(crate) fn lens_window(
        &self,
        s: Pt,
        reach: [f64; 2],
    ) -> (std::ops::RangeInclusive<u32>, std::ops::RangeInclusive<u32>) {
        let ch = self.ch;
        let (j0, k0) = ch.nearest_lens(s);
        let p = ch.image_pitch();
        let row = match ch.grid {
            Grid::Rect => p,
            Grid::Hex => p * 3f64.sqrt() / 2.0,
        };
        let dj = (reach[0] / p).ceil() as i64 + 1;
        let dk = (reach[1] / row).ceil() as i64 + 1;
        let span = |c: u32, d: i64, n: u32| {
            let lo = (c as i64 - d).max(0) as u32;
            let hi = (c as i64 + d).min(n as i64 - 1).max(0) as u32;
            lo..=hi
        };
        (span(k0, dk, ch.ky), span(j0, dj, ch.kx))
    }

    /// The coordinates along `axis` of the cell's vertices (relative to its centre).
    pub(super) fn vertex_coords(&self, axis: usize) -> Vec<f64> {
        let mut v: Vec<f64> = self.cell.iter().map(|p| p[axis]).collect();
        v.sort_by(|a, b| a.total_cmp(b));
        v.dedup();
        v
    }

    /// The half-side of a box holding the main lens's aperture (a disc's: its polygon's).
    pub(crate) fn aperture_box(&self) -> f64 {
        match self.shape {
            Aperture::Square => self.r_ap,
            Aperture::Circle => self.r_ap * self.ngon[0][0],
        }
    }

    /// Does the type's α call for the outer-w rule (its cell's image narrower than a pixel)?
    pub(super) fn uses_outer_w(&self, alpha: f64) -> bool {
        alpha.abs() * 2.0 * self.hx < self.ch.mu
    }
}

/// A node's hits on a depth map by the bits of their cell point ([`Work::hits`]).
pub(super) type HitCache = HashMap<[u64; 2], Option<(f64, Pt)>, BuildHasherDefault<BitsHasher>>;

/// A multiplicative hash of a few machine words (FxHash's step): the keys are a point's
/// bits, looked up a few dozen times per node, where SipHash's cost showed in the
/// renders' times.
#[derive(Default)]
pub(super) struct BitsHasher(u64);

impl Hasher for BitsHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

/// Per-worker buffers.
#[derive(Default)]
pub(crate) struct Work {
    /// Relative accuracy of one evaluation of the integrand (0: exact; see `PIECE_NOISE`).
    pub(super) rel_floor: f64,
    /// When set, the integration records each grid cell's share of the pixel's rays
    /// instead of averaging the texture (the map of docs/model.md §11; see
    /// [`crate::imaging::recorder::Recorder`]), and the adaptive rule is a fixed one ([`super::adaptive::fixed_rule`]).
    pub(crate) rec: Option<Box<crate::imaging::recorder::Recorder>>,
    pub(super) tex: Scratch,
    pub(super) poly: Vec<Pt>,
    pub(super) tmp: Vec<Pt>,
    pub(super) piece: Vec<Pt>,
    pub(super) mapped: Vec<Pt>,
    pub(super) cuts_a: Vec<f64>,
    pub(super) cuts_b: Vec<f64>,
    pub(super) zs: Vec<f64>,
    /// On a depth map, the hits of one node's rays taken so far (by the bits of cell point
    /// ξ: its depth and scene point, None for a miss), `mean::scene_mean`'s: the pieces of
    /// a polygon share vertices with it and with each other, and a hit on a map is a walk
    /// over its patches.
    pub(super) hits: HitCache,
    /// Evaluations of the integrand by the adaptive rule so far (its work).
    pub(crate) evals: u64,
    /// Boxes integrated in closed form so far ([`super::interior`]).
    pub(crate) closed: u64,
    /// Boxes cut by the aperture's circle taken in closed form so far
    /// ([`super::sat::SatTable::disc_rect_polygon`]).
    pub(crate) disc_boxes: u64,
    /// The closed form's corners taken so far ([`super::sat::CornerMemo`]).
    pub(crate) corners: super::sat::CornerMemo,
    /// Record mode on a plane: [`footprint`]'s buffers.
    pub(super) fp: footprint::Scratch,
    /// Record mode on a depth map: every ray meets it at most once
    /// ([`crate::imaging::scene::DepthMap::seen_once`]), so [`footprint`] records it too.
    pub(super) map_once: bool,
}

impl Work {
    /// A worker that averages the texture (`fronto`: the surface is a fronto-parallel plane).
    pub(super) fn new(fronto: bool) -> Work {
        Work {
            rel_floor: if fronto { 0.0 } else { PIECE_NOISE },
            ..Work::default()
        }
    }

    /// A worker in record mode. On a plane, and on a depth map that every ray meets at
    /// most once (`map_once`: [`map_seen_once`]), the record is [`footprint`]'s, which has
    /// rules of its own; on another depth map (never fronto-parallel) it is the render's
    /// own integral's, which takes first hits.
    pub(crate) fn recording(rec: Box<crate::imaging::recorder::Recorder>, map_once: bool) -> Work {
        Work {
            rec: Some(rec),
            map_once,
            ..Work::new(false)
        }
    }
}

/// Is `surface` a depth map that every ray through the main lens of `chan` meets at most
/// once ([`crate::imaging::scene::DepthMap::seen_once`])? Checked once per map, not per worker.
pub(crate) fn map_seen_once(chan: &Chan, surface: &Surface) -> bool {
    matches!(surface, Surface::Map(m) if m.seen_once(chan.aperture_box()))
}
