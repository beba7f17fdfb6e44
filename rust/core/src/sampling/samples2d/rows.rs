//! One depth: the rows (each channel and the union) from the samples within a margin of
//! the field, the margin widened until the result is provably that of every sample; or, for
//! a channel whose samples are a product of two 1-D sets, exactly from those sets.

use super::components::{components, excess, CompWork};
use super::cover::{cover_1d, reps_1d};
use super::tables::{ColumnX, PixelTables, Tables};
use super::*;
use crate::infra::error::Result;
use crate::infra::memory::{self, try_reserve};
use crate::infra::parallel::{self};
use crate::model::design::Design;

// ---- one depth -------------------------------------------------------------------------

/// Results of one row (a channel, or the union) at one depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct RowResult {
    pub(super) distinct: u64,
    /// ρ in δ(z) and in mm.
    pub(super) rho: f64,
    pub(super) rho_mm: f64,
}

impl Default for RowResult {
    fn default() -> Self {
        RowResult {
            distinct: 0,
            rho: f64::INFINITY,
            rho_mm: f64::INFINITY,
        }
    }
}

/// A validated call: the design, its channel tables, tolerance and window.
pub(super) struct Ctx<'a> {
    pub(super) design: &'a Design,
    pub(super) tables: Vec<Tables<'a>>,
    pub(super) tol: f64,
    pub(super) window: f64,
    /// Use the separable computation for channels whose samples are a Cartesian product
    /// (see [`separable_row`]); off only to test it against the general one.
    pub(super) separable: bool,
    /// Give a one-channel design's union row the channel row's result instead of
    /// computing it again on the same samples (see [`rows_from`]); off only to test it.
    pub(super) union_is_channel: bool,
    /// Try a pass at [`TRIAL_MARGIN`] before the first margin (see [`row_pass`]); off
    /// only to test it.
    pub(super) trial: bool,
}

/// The geometry of one depth.
pub(super) struct DepthGeom {
    pub(super) delta: f64,
    pub(super) eps: f64,
    pub(super) field: [f64; 2],
    /// Per channel: z/L and (L − z')/z'.
    pub(super) gs: Vec<(f64, f64)>,
    /// A margin at which every lit sample of every channel lies within the bounds.
    pub(super) complete: f64,
    /// The first margin: two lens pitches (the largest of the channels) on the plane.
    pub(super) first: f64,
    /// The trial pass's margin, [`TRIAL_MARGIN`] δ.
    pub(super) trial: f64,
}

impl<'a> Ctx<'a> {
    pub(super) fn geom(&self, z: f64) -> DepthGeom {
        let zc = self.design.conjugate(z);
        let delta = self.design.resolution_step(z);
        let field = self.design.central_field(z, self.window);
        let mut complete = 0.0f64;
        let mut first = 0.0f64;
        let mut gs = Vec::with_capacity(self.tables.len());
        for t in &self.tables {
            let (g, s) = (z / t.ch.l, (t.ch.l - zc) / zc);
            gs.push((g, s));
            let ext = t.sample_extent(g, s);
            complete = complete.max(ext[0] - field[0]).max(ext[1] - field[1]);
            first = first.max(2.0 * t.ch.d * g);
        }
        DepthGeom {
            delta,
            eps: self.tol * delta,
            field,
            gs,
            complete: complete.max(0.0),
            first,
            trial: TRIAL_MARGIN * delta,
        }
    }

    /// Upper bound on the samples a pass at margin m gathers (all channels).
    pub(super) fn pass_samples(&self, geom: &DepthGeom, m: f64) -> u128 {
        let b = [geom.field[0] + m, geom.field[1] + m];
        self.tables
            .iter()
            .zip(&geom.gs)
            .map(|(t, &(g, s))| t.pass_pixels(g, s, b[0], b[1]))
            .sum()
    }
}

/// Reusable buffers of one worker.
#[derive(Debug, Default)]
pub(super) struct Work {
    pub(super) pts: Vec<[f64; 2]>,
    /// Start of each channel's samples in `pts` (and the end of the last).
    pub(super) offsets: Vec<usize>,
    pub(super) idx: (Vec<u32>, Vec<u32>, Vec<ColumnX>),
    pub(super) comp: CompWork,
    pub(super) reps: Vec<(u32, bool)>,
    pub(super) band: Vec<[f64; 2]>,
}

/// The outcome of one pass over one row: its result when provably exact, else the margin
/// to try next (or, for a trial pass, that it cannot stand for the first pass).
enum Pass {
    Exact(RowResult),
    Widen(f64),
    Reject,
}

/// One row at margin m over its samples `pts` (every lit sample within Chebyshev distance
/// m of the field; `complete`: every lit sample). Fills `field_reps` (when given) with the
/// representatives inside the field.
///
/// `trial`: a pass narrower than the first margin, accepted only when its result is bit
/// for bit the one the first margin gives ([`Pass::Reject`] otherwise, before any
/// triangulation it can avoid): no component touches the margin's edge, so every component
/// it holds is a complete component of the full sample set with its true representative,
/// and every margin m1 of the covering radius stays below m and below the farthest
/// representative. Then the representatives within m1 of the field (the set triangulated,
/// in the same order: gathers keep the samples' relative order) are those of any wider
/// pass — a component with a member within m1 < m of the field lies wholly inside this
/// pass, else it would touch its edge — so each m1 step sees the same points, the same ρ
/// and the same next m1, and the distinct count is the same.
fn row_pass(
    pts: &[[f64; 2]],
    geom: &DepthGeom,
    m: f64,
    complete: bool,
    trial: bool,
    w: &mut Work,
    field_reps: Option<&mut Vec<[f64; 2]>>,
) -> Result<Pass> {
    let (field, eps, delta) = (geom.field, geom.eps, geom.delta);
    // A member within 3 eps of the margin's edge may be linked to a sample beyond it.
    let band = if complete {
        f64::INFINITY
    } else {
        m - 3.0 * eps
    };
    let mut reps = std::mem::take(&mut w.reps);
    components(pts, eps, field, band, &mut w.comp, &mut reps)?;
    if trial && reps.iter().any(|&(_, touching)| touching) {
        w.reps = reps;
        return Ok(Pass::Reject);
    }
    // m2: every representative that may be wrong (of a touching component) lies at least
    // m2 from the field; the true and the computed representatives agree closer than that.
    parallel::checkpoint()?;
    let mut m2 = if complete { f64::INFINITY } else { m };
    let mut distinct = 0u64;
    let mut near = 0.0f64; // largest excess of any representative
    for &(r, touching) in &reps {
        let e = excess(pts[r as usize], field);
        near = near.max(e);
        if touching {
            m2 = m2.min(e);
        }
        if e <= 0.0 {
            distinct += 1;
        }
    }
    // The covering radius from the representatives within an inner margin m1, widened
    // until ρ < m1 (then no representative beyond m1 is nearest to any field point).
    let area = 4.0 * field[0] * field[1];
    let spacing = (area / distinct.max(1) as f64).sqrt();
    let mut m1 = if distinct > 0 { 4.0 * spacing } else { m };
    let rho = loop {
        let all = m1 >= near;
        if trial && (all || m1 >= m) {
            w.reps = reps;
            return Ok(Pass::Reject);
        }
        parallel::checkpoint()?;
        w.band.clear();
        try_reserve(&mut w.band, "coverage (representatives)", reps.len())?;
        w.band.extend(
            reps.iter()
                .map(|&(r, _)| pts[r as usize])
                .filter(|&p| all || excess(p, field) <= m1)
                .map(|p| [p[0] / delta, p[1] / delta]),
        );
        let rho = covering_radius(&w.band, [field[0] / delta, field[1] / delta])?;
        if all || rho * delta * (1.0 + 1e-9) < m1 {
            break rho;
        }
        m1 = if rho.is_finite() {
            (2.0 * m1).max(2.0 * rho * delta)
        } else {
            4.0 * m1
        };
    };
    let exact = complete || rho * delta * (1.0 + 1e-9) < m2;
    if trial && !exact {
        w.reps = reps;
        return Ok(Pass::Reject);
    }
    if !exact {
        let next = if rho.is_finite() {
            (2.0 * m).max(3.0 * rho * delta)
        } else {
            4.0 * m
        };
        w.reps = reps;
        return Ok(Pass::Widen(next));
    }
    if let Some(out) = field_reps {
        parallel::checkpoint()?;
        out.clear();
        try_reserve(out, "samples_2d (representatives)", distinct as usize)?;
        out.extend(
            reps.iter()
                .map(|&(r, _)| pts[r as usize])
                .filter(|&p| excess(p, field) <= 0.0),
        );
        out.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    }
    w.reps = reps;
    Ok(Pass::Exact(RowResult {
        distinct,
        rho,
        rho_mm: rho * delta,
    }))
}

/// Every row (channels, then the union) at depth z. `keep`: the field's representatives
/// of each row (samples_2d).
pub(super) fn depth_rows(
    ctx: &Ctx<'_>,
    z: f64,
    w: &mut Work,
    keep: Option<&mut Vec<Vec<[f64; 2]>>>,
    check_between: bool,
) -> Result<Vec<RowResult>> {
    let geom = ctx.geom(z);
    rows_from(ctx, &geom, geom.first, w, keep, check_between)
}

/// [`depth_rows`] from the first margin `first`.
fn rows_from(
    ctx: &Ctx<'_>,
    geom: &DepthGeom,
    first: f64,
    w: &mut Work,
    mut keep: Option<&mut Vec<Vec<[f64; 2]>>>,
    check_between: bool,
) -> Result<Vec<RowResult>> {
    let n_ch = ctx.tables.len();
    let n_rows = n_ch + 1;
    let mut done: Vec<Option<RowResult>> = vec![None; n_rows];
    for (r, (t, &(g, s))) in ctx.tables.iter().zip(&geom.gs).enumerate() {
        if ctx.separable {
            let slot = keep.as_deref_mut().map(|k| &mut k[r]);
            done[r] = separable_row(t, g, s, geom, slot)?;
        }
    }
    // One channel computed by the general path: the union is the same sample set at the
    // same margin, so its pass is the channel's, result for result (not recomputed).
    let union_is_channel = ctx.union_is_channel && n_ch == 1 && done[0].is_none();
    // First a trial pass at a narrower margin: the rows it settles have the first margin's
    // result bit for bit (see row_pass); the others go on from the first margin.
    let mut trial = ctx.trial && geom.trial < first && geom.trial < geom.complete;
    let mut m = if trial { geom.trial } else { first };
    let mut pass = 0;
    loop {
        let complete = m >= geom.complete;
        let m_pass = if complete { m.max(geom.complete) } else { m };
        if pass > 0 {
            // A wider pass than the one checked up front: check its memory now.
            let n = ctx.pass_samples(geom, m_pass);
            memory::check(
                "coverage (a wider pass: samples near the field)",
                n.saturating_mul(SAMPLE_BYTES),
            )?;
            if check_between {
                parallel::checkpoint()?;
            }
        }
        let bounds = [geom.field[0] + m_pass, geom.field[1] + m_pass];
        w.pts.clear();
        w.offsets.clear();
        for (t, &(g, s)) in ctx.tables.iter().zip(&geom.gs) {
            w.offsets.push(w.pts.len());
            t.gather(g, s, bounds, &mut w.idx, &mut w.pts)?;
        }
        w.offsets.push(w.pts.len());
        let mut next = 0.0f64;
        for r in 0..n_rows {
            if done[r].is_some() {
                continue;
            }
            if r == n_ch && union_is_channel {
                // Row 0 ran just before on the same points: exact now or widening.
                if let Some(res) = done[0] {
                    if let Some(k) = keep.as_deref_mut() {
                        let (chan, union) = k.split_at_mut(1);
                        union[0].clear();
                        try_reserve(&mut union[0], "samples_2d (representatives)", chan[0].len())?;
                        union[0].extend_from_slice(&chan[0]);
                    }
                    done[r] = Some(res);
                }
                continue;
            }
            let range = if r < n_ch {
                w.offsets[r]..w.offsets[r + 1]
            } else {
                0..w.pts.len()
            };
            let pts = std::mem::take(&mut w.pts);
            let slot = keep.as_deref_mut().map(|k| &mut k[r]);
            let outcome = row_pass(&pts[range], geom, m_pass, complete, trial, w, slot);
            w.pts = pts;
            match outcome? {
                Pass::Exact(res) => done[r] = Some(res),
                Pass::Widen(to) => next = next.max(to),
                Pass::Reject => {}
            }
        }
        if done.iter().all(Option::is_some) {
            return Ok(done.into_iter().map(Option::unwrap_or_default).collect());
        }
        if trial {
            // The first pass proper, as without the trial.
            trial = false;
            m = first;
            continue;
        }
        // Never reached when complete: a complete pass is always exact.
        m = next.max(2.0 * m);
        pass += 1;
    }
}

// ---- separable channels ----------------------------------------------------------------

/// A channel whose lit samples form a Cartesian product: the ideal layout (X depends on
/// the column only, Y on the row only) behind a square aperture (a pixel is lit when
/// |w_x| < D/2 and |w_y| < D/2, one condition per axis). Then two samples are linked when
/// their X values and their Y values are, the components are products of the 1-D chains,
/// each represented by (least X, least Y), the distinct count is the product of the 1-D
/// counts inside the field, and the squared distance to the nearest representative is the
/// sum of the 1-D squared distances, so ρ² = ρ_x² + ρ_y² with ρ_x, ρ_y the 1-D covering
/// radii of [−h_x, h_x] and [−h_y, h_y]. Exact over every pixel, no margin needed.
/// None for any other channel.
fn separable_row(
    t: &Tables<'_>,
    g: f64,
    s: f64,
    geom: &DepthGeom,
    keep: Option<&mut Vec<[f64; 2]>>,
) -> Result<Option<RowResult>> {
    let PixelTables::Ideal { w, .. } = &t.px else {
        return Ok(None);
    };
    if t.design.shape != crate::model::design::Aperture::Square {
        return Ok(None);
    }
    let r = t.design.aperture / 2.0;
    let what = "coverage (separable channel)";
    let axis = |c: &[f64]| -> Result<Vec<f64>> {
        let mut v = Vec::new();
        try_reserve(&mut v, what, c.len() * w.len())?;
        for &cj in c {
            // As Tables::sample: −g (c + w s), lit pixels only.
            v.extend(
                w.iter()
                    .filter(|wq| wq.abs() < r)
                    .map(|&wq| -g * (cj + wq * s)),
            );
        }
        Ok(v)
    };
    let (mut xs, mut ys) = (axis(&t.cx[0])?, axis(&t.cy)?);
    if xs.is_empty() || ys.is_empty() {
        if let Some(out) = keep {
            out.clear();
        }
        return Ok(Some(RowResult::default()));
    }
    reps_1d(&mut xs, geom.eps);
    reps_1d(&mut ys, geom.eps);
    let [hx, hy] = geom.field;
    let inside = |v: &[f64], h: f64| {
        let lo = v.partition_point(|&x| x < -h);
        let hi = v.partition_point(|&x| x <= h);
        lo..hi.max(lo)
    };
    let (ix, iy) = (inside(&xs, hx), inside(&ys, hy));
    let distinct = (ix.len() * iy.len()) as u64;
    let (rx, ry) = (cover_1d(&xs, hx), cover_1d(&ys, hy));
    let rho_mm = (rx * rx + ry * ry).sqrt();
    if let Some(out) = keep {
        out.clear();
        try_reserve(out, "samples_2d (representatives)", distinct as usize)?;
        for &x in &xs[ix] {
            out.extend(ys[iy.clone()].iter().map(|&y| [x, y]));
        }
    }
    Ok(Some(RowResult {
        distinct,
        rho: rho_mm / geom.delta,
        rho_mm,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::design::Aperture;
    use crate::sampling::samples2d::tables::PixelTables;
    use crate::sampling::samples2d::test_designs::*;

    #[test]
    fn widening_from_any_margin_gives_the_complete_answer() {
        for d in designs() {
            let ctx = context(&d, 1e-6, 16.0).unwrap();
            let mut w = Work::default();
            for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                let geom = ctx.geom(z);
                let all = rows_from(&ctx, &geom, geom.complete * 1.5, &mut w, None, false).unwrap();
                for first in [geom.first, geom.first / 50.0, geom.complete / 3.0] {
                    let got = rows_from(&ctx, &geom, first, &mut w, None, false).unwrap();
                    assert_eq!(got, all, "z = {z}, first margin {first}");
                }
            }
        }
    }

    /// One pass of [`rows_from`] at a depth: its rows, the samples it kept and how many
    /// points it gathered.
    struct Pass {
        rows: Vec<RowResult>,
        keep: Vec<Vec<[f64; 2]>>,
        gathered: usize,
    }

    /// The pass at depth z with one of the context's shortcuts on, then off (`set`
    /// switches it): what the shortcut must not change.
    fn on_and_off(
        ctx: &mut Ctx<'_>,
        z: f64,
        w: &mut Work,
        set: fn(&mut Ctx<'_>, bool),
    ) -> [Pass; 2] {
        [true, false].map(|on| {
            set(ctx, on);
            let geom = ctx.geom(z);
            let mut keep = vec![Vec::new(); ctx.tables.len() + 1];
            let rows = rows_from(ctx, &geom, geom.first, w, Some(&mut keep), false).unwrap();
            Pass {
                rows,
                keep,
                gathered: w.pts.len(),
            }
        })
    }

    #[test]
    fn separable_channels_equal_the_general_computation() {
        let mut checked = 0;
        for d in designs() {
            let mut ctx = context(&d, 1e-6, 16.0).unwrap();
            let mut w = Work::default();
            for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                let [fast, slow] = on_and_off(&mut ctx, z, &mut w, |c, on| c.separable = on);
                for (r, (a, b)) in fast.rows.iter().zip(&slow.rows).enumerate() {
                    assert_eq!(a.distinct, b.distinct, "z = {z}");
                    assert!((a.rho - b.rho).abs() <= 1e-12 * b.rho, "{a:?} {b:?}");
                    assert_eq!(fast.keep[r], slow.keep[r]);
                }
                let separable = d.channels.iter().zip(&ctx.tables).any(|(_, t)| {
                    matches!(t.px, PixelTables::Ideal { .. }) && d.shape == Aperture::Square
                });
                checked += separable as usize;
            }
        }
        assert!(checked >= 8, "{checked}");
    }

    #[test]
    fn one_channel_union_is_the_channel_row_bit_for_bit() {
        let mut checked = 0;
        for d in designs().into_iter().filter(|d| d.channels.len() == 1) {
            let mut ctx = context(&d, 1e-6, 16.0).unwrap();
            let mut w = Work::default();
            for separable in [true, false] {
                ctx.separable = separable;
                for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                    let [fast, slow] =
                        on_and_off(&mut ctx, z, &mut w, |c, on| c.union_is_channel = on);
                    assert_eq!(fast.rows, slow.rows, "z = {z}");
                    assert_eq!(fast.keep, slow.keep, "z = {z}");
                    checked += 1;
                }
            }
        }
        assert!(checked >= 8, "{checked}");
    }

    #[test]
    fn trial_pass_changes_no_bit() {
        // The trial pass at TRIAL_MARGIN δ gives what the first margin gives, bit for bit.
        // These small designs are mostly settled whole by the first margin or separable;
        // some depths the trial settles with fewer samples (its gather is the last).
        let (mut settled, mut cases) = (0, 0);
        for d in designs() {
            for (tol, window) in [(1e-6, 16.0), (1e-6, 2.0), (0.05, 4.0), (1.0, 4.0)] {
                let mut ctx = context(&d, tol, window).unwrap();
                let mut w = Work::default();
                for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                    let [on, off] = on_and_off(&mut ctx, z, &mut w, |c, on| c.trial = on);
                    assert_eq!(on.rows, off.rows, "z = {z}, tol {tol}, window {window}");
                    assert_eq!(on.keep, off.keep, "z = {z}, tol {tol}, window {window}");
                    settled += (on.gathered < off.gathered) as usize;
                    cases += 1;
                }
            }
        }
        assert!(settled >= 8, "{settled} of {cases}");
    }

    #[test]
    fn coarse_tolerance_chains_are_exact() {
        // Lens pitch 0.99 delta and tol = 1: every sample is linked to its neighbours, the
        // whole grid is one component, represented by its least (X, Y) member at the far
        // corner of the array, well beyond every margin but the last.
        let d = one_pixel_lenses(1.9, 0.0099);
        let ctx = context(&d, 1.0, 16.0).unwrap();
        let mut w = Work::default();
        let geom = ctx.geom(500.0);
        let all = rows_from(&ctx, &geom, geom.complete * 2.0, &mut w, None, false).unwrap();
        let got = rows_from(&ctx, &geom, geom.first, &mut w, None, false).unwrap();
        assert_eq!(got, all);
        // Row 0 by the separable computation, row 1 (the union of the one channel) by the
        // general one, which has to widen its margin to the whole sensor.
        let want = 0.99 * (27.5f64.powi(2) + 25.5f64.powi(2)).sqrt();
        for row in &all {
            assert_eq!(row.distinct, 0);
            assert!((row.rho - want).abs() < 1e-9, "{} {want}", row.rho);
        }
    }
}
