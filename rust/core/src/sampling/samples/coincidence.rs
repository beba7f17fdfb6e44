//! Coincidence planes (N, T) of a channel on both sides of its out-of-focus plane, with
//! Eqs. 8–9 and the brute-force count of distinct chief samples (docs/model.md §6).

use rayon::prelude::*;

use super::designs::check_line_size;
use super::sorted::{line_samples, scan, LineSamples, LitPixels, Scratch};
use super::*;
use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_reserve};
use crate::infra::parallel::{chunk_items, for_chunks, threads};
use crate::model::design::Design;
use crate::model::lens::depth_of_conjugate;
use crate::model::optics::LensOptics;
use crate::sampling::line::Axis;
use crate::sampling::line::{check_coincidence_channel, Line};

/// Side of a coincidence plane relative to the half's out-of-focus plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Beyond the out-of-focus plane: z' = L_i / (1 + r) < L_i.
    Far,
    /// In front of it: z' = L_i / (1 − r) > L_i (needs r < 1).
    Near,
}

impl Side {
    pub fn name(self) -> &'static str {
        match self {
            Side::Far => "far",
            Side::Near => "near",
        }
    }
}

/// One coincidence plane of a half (docs/model.md §6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoincidencePlane {
    pub n: u32,
    pub t: u32,
    pub side: Side,
    /// z' of the plane [mm].
    pub conjugate: f64,
    /// z [mm].
    pub z: f64,
    /// rep_i = 2 H_i / d at z' (Eqs. 4–5).
    pub repetitions: f64,
    /// One factor of Eq. 8/9 with K_x (and Q_lit).
    pub new_samples_x: u64,
    /// One factor of Eq. 8/9 with K_y (and Q_lit).
    pub new_samples_y: u64,
    /// Their product (Eq. 8 for half 1, Eq. 9 for half 2).
    pub new_samples: u64,
    /// Brute-force count of distinct chief samples over every lit pixel of the 2D half.
    pub counted: u64,
}

/// Tolerance (in δ(z)) of the brute-force count of `coincidence_planes`.
pub const COINCIDENCE_TOL: f64 = 1e-6;

/// Every coincidence plane (docs/model.md §6) of channel `channel` (from 1) of a design, with
/// coprime N ≤ max_n, T ≤ max_t (default Q), on both sides of the out-of-focus plane where
/// it exists (1 − r > 0, z' > F), sorted by depth z, each with the closed form of
/// Eqs. 8–9 and the brute-force count. The channel must have a rect grid, the
/// ideal layout and a square aperture, where docs/model.md §6 holds (anything else is
/// refused with the parameter named). The merge tolerance is [`COINCIDENCE_TOL`] δ(z),
/// δ(z) = μ_1 z / L_1 (docs/model.md §9). Chief samples do not depend on the lens types.
pub fn design_coincidence_planes(
    design: &Design,
    channel: i64,
    max_n: i64,
    max_t: Option<i64>,
    n_threads: Option<usize>,
) -> Result<Vec<CoincidencePlane>> {
    let lx = Line::of_channel(design, channel, Axis::X)?;
    check_coincidence_channel(design, channel)?;
    let ly = Line::of_channel(design, channel, Axis::Y)?;
    let q = lx.q().unwrap_or(1);
    let (max_n, max_t) = check_pairs(q, max_n, max_t)?;
    check_line_size(&[&lx, &ly])?;
    let ch = design.channel(channel)?;
    let pl = PlaneLines {
        x: LineSamples::new(&lx),
        y: LineSamples::new(&ly),
        kx: ch.kx,
        ky: ch.ky,
        q,
        eps: COINCIDENCE_TOL * design_step(design),
        optics: LensOptics::of_channel(design, ch, 0),
    };
    planes_of(&pl, max_n, max_t, n_threads)
}

/// What the coincidence planes of one half or channel need: its two lines, K_x, K_y, Q,
/// the merge tolerance in p' and its closed forms.
struct PlaneLines {
    pub(super) x: LineSamples,
    pub(super) y: LineSamples,
    pub(super) kx: u32,
    pub(super) ky: u32,
    pub(super) q: u32,
    pub(super) eps: f64,
    pub(super) optics: LensOptics,
}

impl PlaneLines {
    pub(super) fn q_lit(&self) -> u64 {
        match &self.x.pixels {
            LitPixels::Same(w) => w.len() as u64,
            LitPixels::Each(_) => 0,
        }
    }
}

fn planes_of(
    pl: &PlaneLines,
    max_n: u32,
    max_t: u32,
    n_threads: Option<usize>,
) -> Result<Vec<CoincidencePlane>> {
    let mut planes = enumerate_planes(pl, max_n, max_t)?;
    check_coincidence_work(pl, planes.len(), max_n, max_t)?;
    count_planes(pl, &mut planes, n_threads)?;
    Ok(planes)
}

/// Validate max_n and max_t (None: Q) and their product against [`MAX_PAIRS`].
fn check_pairs(q: u32, max_n: i64, max_t: Option<i64>) -> Result<(u32, u32)> {
    if !(1..=MAX_PAIRS as i64).contains(&max_n) {
        return Err(Error::param(
            "max_n",
            max_n,
            format!("an integer in [1, {MAX_PAIRS}]"),
        ));
    }
    let max_t = max_t.unwrap_or(q as i64);
    if !(1..=MAX_PAIRS as i64).contains(&max_t) {
        return Err(Error::param(
            "max_t",
            max_t,
            format!("an integer in [1, {MAX_PAIRS}] or None for Q"),
        ));
    }
    if (max_n as u64) * (max_t as u64) > MAX_PAIRS {
        return Err(Error::param(
            "max_n * max_t",
            max_n * max_t,
            format!("at most {MAX_PAIRS} (N, T) pairs"),
        ));
    }
    Ok((max_n as u32, max_t as u32))
}

/// The planes of docs/model.md §6 with r = N d v / (T μ L_i), z' = L_i / (1 ± r), sorted by
/// depth, with Eqs. 8–9 (Q_lit for Q) and `counted` still 0.
fn enumerate_planes(pl: &PlaneLines, max_n: u32, max_t: u32) -> Result<Vec<CoincidencePlane>> {
    let o = &pl.optics;
    let l = o.l;
    let q_lit = pl.q_lit();
    let mut planes = Vec::new();
    try_reserve(
        &mut planes,
        "coincidence_planes",
        2 * max_n as usize * max_t as usize,
    )?;
    for n in 1..=max_n {
        for t in (1..=max_t).filter(|&t| gcd(n as u64, t as u64) == 1) {
            let r = n as f64 * o.d * o.v / (t as f64 * o.mu * l);
            let sides = [(Side::Far, l / (1.0 + r)), (Side::Near, l / (1.0 - r))];
            for (side, zc) in sides {
                let valid = match side {
                    Side::Far => zc > o.f_main,
                    Side::Near => 1.0 - r > 0.0 && zc > o.f_main && zc.is_finite(),
                };
                // The object plane too must lie beyond F: with 1 − r a rounding error
                // above 0 the conjugate is ~1e16 L away and its depth rounds to F.
                let z = depth_of_conjugate(o.f_main, zc);
                if !(valid && z > o.f_main && z.is_finite()) {
                    continue;
                }
                let nx = closed_form_new_samples(pl.kx as u64, q_lit, n as u64, t as u64);
                let ny = closed_form_new_samples(pl.ky as u64, q_lit, n as u64, t as u64);
                planes.push(CoincidencePlane {
                    n,
                    t,
                    side,
                    conjugate: zc,
                    z,
                    repetitions: o.repetitions(o.main_blur(zc)),
                    new_samples_x: nx,
                    new_samples_y: ny,
                    new_samples: nx * ny,
                    counted: 0,
                });
            }
        }
    }
    planes.sort_by(|a, b| a.z.total_cmp(&b.z));
    Ok(planes)
}

/// Sample positions the brute force generates, sorts and scans per plane: (K_x + K_y) Q_lit.
fn positions_per_plane(pl: &PlaneLines) -> u128 {
    (pl.kx as u128 + pl.ky as u128) * pl.q_lit() as u128
}

/// Refuse a brute-force count above [`MAX_COINCIDENCE_WORK`] before it starts.
fn check_coincidence_work(pl: &PlaneLines, n_planes: usize, max_n: u32, max_t: u32) -> Result<()> {
    let per_plane = positions_per_plane(pl);
    let work = n_planes as u128 * per_plane;
    if work > MAX_COINCIDENCE_WORK as u128 {
        return Err(Error::TooMuchWork {
            what: format!(
                "coincidence_planes with max_n = {max_n}, max_t = {max_t}: {n_planes} planes x \
                 {per_plane} lit pixels (lower max_n or max_t)"
            ),
            amount: work,
            limit: MAX_COINCIDENCE_WORK as u128,
            unit: "sample positions",
        });
    }
    Ok(())
}

/// The brute-force count of every plane: distinct chief samples along x times along y,
/// at the plane's own conjugate z' (not re-derived from z), in interruptible chunks.
fn count_planes(
    pl: &PlaneLines,
    planes: &mut [CoincidencePlane],
    n_threads: Option<usize>,
) -> Result<()> {
    let eps = pl.eps;
    let k = pl.kx.max(pl.ky) as usize;
    let n = k * pl.q_lit() as usize;
    let (inner, q) = (k.max(pl.q as usize), pl.q as usize);
    memory::check(
        "coincidence_planes",
        memory::bytes_of::<CoincidencePlane>(planes.len() as u128)
            + threads(n_threads) as u128 * Scratch::bytes([n, 0], inner, q),
    )?;
    let step = chunk_items(n_threads, 4 * positions_per_plane(pl));
    for_chunks(n_threads, planes.len(), step, |r| {
        planes[r].par_iter_mut().try_for_each_init(
            || Scratch::reserved([n, 0], inner, q),
            |s, p| -> Result<()> {
                let s = s.as_mut().map_err(|e| e.clone())?;
                let mut count = 1;
                for ls in [&pl.x, &pl.y] {
                    line_samples(ls, p.conjugate, &mut s.pos[0], &mut s.work);
                    count *= scan(&s.pos[0], eps, f64::INFINITY).0;
                }
                p.counted = count;
                Ok(())
            },
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rayspace::Sample;
    use crate::sampling::samples::test_designs::*;

    #[test]
    fn closed_form_cases() {
        // N Q + T (K − N) inside the validity range, K Q outside it.
        assert_eq!(closed_form_new_samples(266, 15, 1, 1), 15 + 265);
        assert_eq!(closed_form_new_samples(266, 15, 2, 3), 30 + 3 * 264);
        assert_eq!(closed_form_new_samples(266, 15, 1, 15), 266 * 15);
        assert_eq!(closed_form_new_samples(266, 11, 1, 13), 266 * 11);
        assert_eq!(closed_form_new_samples(3, 15, 5, 2), 45);
    }

    #[test]
    fn counted_equals_eqs_8_9_on_every_plane() {
        let designs = [
            seed(),
            small(0.8, 14.0, 10, 23, 7),
            small(0.39, 20.0, 15, 40, 9),
        ];
        let mut checked = 0;
        for d in designs {
            for c in [1, 2] {
                let planes = design_coincidence_planes(&d, c, 5, None, Some(1)).unwrap();
                assert!(planes.iter().any(|p| p.side == Side::Near));
                assert!(planes.iter().any(|p| p.side == Side::Far));
                for p in &planes {
                    assert_eq!(p.counted, p.new_samples, "{c} {p:?}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 100);
    }

    #[test]
    fn out_of_focus_plane_collapses_to_k() {
        let d = seed();
        for (c, ch) in (1..).zip(&d.channels) {
            let z = LensOptics::of_channel(&d, ch, 0).out_of_focus_depth();
            assert_eq!(count(&d, c, Axis::X, z, 1e-6), ch.kx as u64);
            assert_eq!(design_count_distinct(&d, c, z, 1e-6).unwrap(), ch.kx as u64);
            assert_eq!(count(&d, c, Axis::Y, z, 1e-6), ch.ky as u64);
        }
        // Half 1 on its out-of-focus plane: pixelization, max gap = Q steps (one lens
        // pitch d in δ = μ z / L_1: d / μ = Q up to rounding, as d z / (Q v') did).
        let ch = &d.channels[0];
        let z1 = LensOptics::of_channel(&d, ch, 0).out_of_focus_depth();
        let r = design_new_samples(&d, &[z1], 1e-6, Sample::Chief, Some(1)).unwrap();
        assert!((r.max_gap[0] - 15.0).abs() < 1e-9);
    }
}
