//! The tilted route (module doc of [`super`]): the map for a plane that is not
//! fronto-parallel on the exact route's designs (rect grid, square aperture, ideal layout),
//! per axis exact cuts of the pixels' ray polygons at the plane's depth ([`build_tilted`]).

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

use super::slabs::{profiles, Line, Profiles, Slabs};
use super::{append_rows, row_done, Job, System, OUTSIDE_SHARE};
use crate::imaging::render::exact::{
    footprint_of, mean_ray_of, polygon, tilted_profile, tilted_profile_of, Tilt,
};
use crate::infra::error::Result;
use crate::infra::parallel::checkpoint;
use crate::infra::polygon::Pt;

/// The most parts per axis of (ξ, w) a pixel's o ray set is cut into on the tilted route
/// (m × m boxes).
const MAX_SIDE: usize = 16;
/// The share of its depth by which a row's plane may change across a pixel's footprint
/// along the smaller tilt's axis: g_o W / 2 over the depth where the pixel's mean ray meets
/// the plane, W the widest footprint along o over the slabs the pixel reaches. A pixel
/// within [`CUT_EPS`] is cut whole. A wider one is cut into m × m parts, m = ⌈share /
/// CUT_EPS⌉ (2 to [`MAX_SIDE`]), each part about that much narrower. When a part of the
/// finest cut is still past TILT_EPS, the plane is left to the general route.
const TILT_EPS: f64 = 1e-3;
/// The share past which a pixel is cut into parts (see [`TILT_EPS`]). Whole pixels' A t
/// stays within about 0.5 to 0.7 times their share of white (measured against the general
/// route on the seed: 2.2e-4 at a share of 4.4e-4, 4.6e-4 at 8.8e-4, when pixels were
/// cut whole up to 1e-3). With this cut every plane measured is within 0.7 to 2.4e-4 of
/// render's own raw, as the general route is (docs/reconstruct.md step 5).
const CUT_EPS: f64 = 2.5e-4;

/// What became of a pixel: not a row, a row (its entries gathered), or the plane is too
/// steep for the tilted route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pixel {
    Skip,
    Row,
    Steep,
}

/// A channel's rows on the tilted route: the geometry, the channel, its profiles and the
/// lens types kept.
struct Rows<'a> {
    sl: &'a Slabs,
    ln: &'a Line<'a>,
    pr: &'a Profiles,
    keeps: &'a (dyn Fn(usize) -> bool + Sync),
}

impl Rows<'_> {
    /// Raw row b: its kept pixels' rows. Stops at the first pixel too steep (`steep` is
    /// then set, and the row is not counted).
    fn row(
        &self,
        b: usize,
        steep: &AtomicBool,
        bytes: &AtomicU64,
        done: &AtomicUsize,
    ) -> Result<System> {
        checkpoint()?;
        let mut s = System::new(self.sl.nx * self.sl.ny);
        if steep.load(Ordering::Relaxed) {
            return Ok(s);
        }
        let norm = self.ln.chan.norm;
        let mut entries: Vec<(u32, f64)> = Vec::new();
        for a in 0..self.ln.cols {
            match self.pixel(a, b, &mut entries) {
                Pixel::Skip => continue,
                Pixel::Steep => {
                    steep.store(true, Ordering::Relaxed);
                    return Ok(s);
                }
                Pixel::Row => {}
            }
            entries.sort_unstable_by_key(|e| e.0);
            let mut last = u32::MAX;
            for &(idx, v) in entries.iter() {
                if idx == last {
                    *s.rows.data.last_mut().expect("an entry was pushed") += norm * v;
                } else {
                    s.rows.indices.push(idx);
                    s.rows.data.push(norm * v);
                    last = idx;
                }
            }
            s.end_row(self.ln.i, b * self.ln.cols + a);
        }
        row_done(&s, bytes, done)?;
        Ok(s)
    }

    /// Pixel (column a, row b): its entries into `entries` when it is a row.
    fn pixel(&self, a: usize, b: usize, entries: &mut Vec<(u32, f64)>) -> Pixel {
        let (sl, ln, pr) = (self.sl, self.ln, self.pr);
        let t = ln.typ(a, b);
        if !(self.keeps)(t) {
            return Pixel::Skip;
        }
        let (it, io) = if sl.axis == 0 { (a, b) } else { (b, a) };
        // The pixel's profile along t: its line's, or on the plane along t that its mean o
        // ray sees (`along_t`).
        let own;
        let mut zp_mean = f64::NAN;
        let mut ray_t = (f64::NAN, f64::NAN);
        let tp = if sl.go == 0.0 {
            match &pr.pt[t][0][it] {
                Some(p) => p,
                None => return Pixel::Skip,
            }
        } else {
            let (Some(rt), Some((wo, ao))) = (pr.rt[t][it], pr.ro[t][io]) else {
                return Pixel::Skip;
            };
            let Some(z) = sl.hit(rt, (wo, ao)) else {
                return Pixel::Skip;
            };
            zp_mean = z;
            ray_t = rt;
            let Some((zp, gp)) = sl.along_t(wo, ao) else {
                return Pixel::Skip;
            };
            let c = ln.center(it as u32, sl.axis);
            match tilted_profile(
                &ln.chan,
                ln.chan.types[t].0,
                c,
                ln.theta(it as u32),
                Tilt { z0: zp, g: gp },
                sl.ns,
                |k| sl.edge_t(k),
            ) {
                Some(p) => {
                    own = p;
                    &own
                }
                None => return Pixel::Skip,
            }
        };
        let total = tp.total * pr.ototal[t][io];
        if total <= 0.0 {
            return Pixel::Skip;
        }
        entries.clear();
        let mut inside = 0.0;
        // The pixel's widest footprint along o over the slabs it reaches, in cells.
        let mut widest = 0;
        for (m, &a_t) in tp.areas.iter().enumerate() {
            if a_t == 0.0 {
                continue;
            }
            let k = tp.first + m;
            let Some(os) = pr.po[t][k].as_ref() else {
                continue;
            };
            let Some(op) = &os[io] else {
                return Pixel::Skip;
            };
            widest = widest.max(sl.add(k, op, a_t, entries, &mut inside));
        }
        if !(inside > 0.0 && total - inside <= OUTSIDE_SHARE * total) {
            return Pixel::Skip;
        }
        // A row whose depth changes across its footprint along o by more than CUT_EPS:
        // cut into parts ([`Rows::cut`]).
        let eps = sl.go.abs() * widest as f64 * sl.h / (2.0 * zp_mean);
        if sl.go != 0.0 && eps > CUT_EPS {
            let m = ((eps / CUT_EPS).ceil() as usize).clamp(2, MAX_SIDE);
            return self.cut(t, (it, io), m, ray_t, total, entries);
        }
        Pixel::Row
    }

    /// The pixel of type t on lines (it, io) cut into parts: its o ray set is cut into
    /// m × m boxes in (ξ, w), each part with its own plane along t and its own o areas per
    /// slab (a box's rays meet any plane close together). The parts tile the o polygon,
    /// so the areas still add up to the whole (`total`). `ray_t` is the pixel's mean ray
    /// along t.
    fn cut(
        &self,
        t: usize,
        (it, io): (usize, usize),
        m: usize,
        ray_t: (f64, f64),
        total: f64,
        entries: &mut Vec<(u32, f64)>,
    ) -> Pixel {
        let ln = self.ln;
        let alpha = ln.chan.types[t].0;
        let tho = ln.theta(io as u32);
        let poly = polygon(&ln.chan, alpha, tho);
        let (bx0, bx1, by0, by1) = crate::infra::polygon::bounds(&poly);
        let split = |lo: f64, hi: f64, k: usize| {
            if k == m {
                hi
            } else {
                lo + (hi - lo) * k as f64 / m as f64
            }
        };
        let (mut part, mut tmp) = (Vec::new(), Vec::new());
        entries.clear();
        let mut inside = 0.0;
        for (jx, jy) in (0..m).flat_map(|jx| (0..m).map(move |jy| (jx, jy))) {
            part.clone_from(&poly);
            crate::infra::polygon::clip_box(
                &mut part,
                &mut tmp,
                split(bx0, bx1, jx),
                split(bx0, bx1, jx + 1),
                split(by0, by1, jy),
                split(by0, by1, jy + 1),
            );
            match self.part(alpha, (it, io), &part, ray_t, entries, &mut inside) {
                Pixel::Row => {}
                other => return other,
            }
        }
        if !(inside > 0.0 && total - inside <= OUTSIDE_SHARE * total) {
            return Pixel::Skip;
        }
        Pixel::Row
    }

    /// One part of a pixel's o polygon (lens type's α `alpha`, lines (it, io)): its
    /// entries and light on the grid added. Skip when some of its rays miss the plane,
    /// Steep when the part is still too wide for [`TILT_EPS`] (the plane is too steep for
    /// this route), Row otherwise (a part with no rays adds nothing).
    fn part(
        &self,
        alpha: f64,
        (it, io): (usize, usize),
        part: &[Pt],
        ray_t: (f64, f64),
        entries: &mut Vec<(u32, f64)>,
        inside: &mut f64,
    ) -> Pixel {
        let (sl, ln) = (self.sl, self.ln);
        let co = ln.center(io as u32, 1 - sl.axis);
        let (ct, tht) = (ln.center(it as u32, sl.axis), ln.theta(it as u32));
        let Some((wo, ao)) = mean_ray_of(&ln.chan, co, part) else {
            return Pixel::Row;
        };
        let Some(z) = sl.hit(ray_t, (wo, ao)) else {
            return Pixel::Skip;
        };
        let Some((zp, gp)) = sl.along_t(wo, ao) else {
            return Pixel::Skip;
        };
        let Some(tj) = tilted_profile(
            &ln.chan,
            alpha,
            ct,
            tht,
            Tilt { z0: zp, g: gp },
            sl.ns,
            |k| sl.edge_t(k),
        ) else {
            return Pixel::Skip;
        };
        // The part's widest footprint along o over the slabs it reaches (at its own depth
        // in each slab).
        let mut width = 0.0f64;
        for (n, &a_t) in tj.areas.iter().enumerate() {
            if a_t == 0.0 {
                continue;
            }
            let k = tj.first + n;
            let zk = zp + gp * (sl.t0 + (k as f64 + 0.5) * sl.hs);
            if let Some((lo, hi)) = footprint_of(&ln.chan, co, part, zk) {
                width = width.max(hi - lo);
            }
            let Some(op) = tilted_profile_of(
                &ln.chan,
                co,
                part,
                Tilt {
                    z0: sl.slab_z(k),
                    g: sl.go,
                },
                sl.nco,
                |n| sl.edge_o(n),
            ) else {
                return Pixel::Skip;
            };
            sl.add(k, &op, a_t, entries, inside);
        }
        // A part still too wide: the plane is too steep for this route.
        if sl.go.abs() * width / (2.0 * z) > TILT_EPS {
            return Pixel::Steep;
        }
        Pixel::Row
    }
}

/// The map for the plane Z = z0 + gx X + gy Y (not fronto-parallel) on the exact route's
/// designs (rect grid, square aperture, ideal layout), or None (the caller then takes the
/// general route): before any row is built when the plane is not in front of the lens over
/// the grid, and at the first row that finds it tilted along both axes too steeply even
/// for parts (the rows counted in `done` so far are then taken back). Pixels with rays
/// that miss the plane are not rows.
///
/// A pixel's ray set is the product of its x and y polygons. Call t the axis of the larger
/// tilt (Y on a tie) and o the other. Along t the polygon's areas between the grid's edges
/// are exact when the depth depends on U_t alone ([`tilted_profile`]: the cut at an edge
/// is the fronto-parallel cut at the edge's depth), and each grid row (column) is cut into
/// slabs of at most [`super::slabs::SLAB_DEPTH`] relative depth. Along o, each slab's areas are those of
/// the line of the plane through the slab's middle, Z = z_k + g_o U_o, cut the same exact
/// way; and a slab's t area times its o areas. With a tilt along o as well, the depth
/// along t's cuts depends on U_o too: each pixel's t areas are taken on the plane along t
/// that its mean o ray sees (U_o = w_o − Z a_o: Z = (z0 + g_o w_o) / (1 + g_o a_o) +
/// g_t U_t / (1 + g_o a_o), exact for that o ray with every t ray), so the error grows
/// with g_o times the pixel's footprint along o, not with the grid's. Where that footprint
/// is too wide for [`CUT_EPS`], the pixel's o polygon is cut into m × m boxes in (ξ, w)
/// (a box's rays are close in position and slope, so they meet the plane close together
/// at any depth), and each box takes the same two steps with its own mean o ray and its own
/// o areas per slab. Either way every pixel's areas add up to its whole ray set (the o
/// areas of each slab and box and the t areas do, and the boxes tile the polygon). The
/// two axes' geometry is the same per axis (a rect grid's lens centres, the ideal
/// layout's pixel offsets, a square aperture), so one code serves both. The job's `done`
/// counts the raw rows handled.
pub(super) fn build_tilted(
    job: &Job,
    z0: f64,
    g: [f64; 2],
    keeps: &(dyn Fn(usize) -> bool + Sync),
) -> Result<Option<System>> {
    let Some(sl) = Slabs::new(z0, g, job.grid) else {
        return Ok(None);
    };
    // Set by the first row too steep for this route (with a tilt along o); the rows
    // handled so far are then uncounted and the plane handed back.
    let steep = AtomicBool::new(false);
    let done_before = job.done.load(Ordering::Relaxed);
    let mut out = System::new(job.grid.cells());
    for &i in job.channels {
        let ln = Line::open(job.design, i, sl.axis);
        let pr = profiles(&sl, &ln, keeps)?;
        let rows = Rows {
            sl: &sl,
            ln: &ln,
            pr: &pr,
            keeps,
        };
        let step = crate::infra::parallel::chunk_items(job.n_threads, (ln.cols as u128) * 256);
        let bytes = AtomicU64::new((out.rows.data.len() * 12) as u64);
        let chunks = (job.n_threads, ln.rows, step);
        append_rows(
            &mut out,
            chunks,
            || (),
            |_, b| rows.row(b, &steep, &bytes, job.done),
        )?;
        if steep.load(Ordering::Relaxed) {
            job.done.store(done_before, Ordering::Relaxed);
            return Ok(None);
        }
    }
    Ok(Some(out))
}
