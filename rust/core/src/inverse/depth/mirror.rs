//! The mirror rival of a least cost (docs/depth.md, step 6): a channel's lenses see a
//! point alike on both sides of its out-of-focus plane z_c (its micro-images collapse
//! there and flip beyond), so a cost curve that dips at z can dip as deep, or deeper, at
//! z's mirror in inverse depth, 1/z' = 2/z_c − 1/z, behind the peak at z_c. Such dips are
//! narrow near z_c (about 1 % of the depth on the seed's half 1 at 620 mm), and the
//! candidates read one of the two far from its bottom: on the seed at 64 candidates the
//! true dip (620 mm) read 2.5 times the mirror's least cost (665 mm) and the mirror won
//! with a contrast of 0.6. So after the sweep the costs are computed at the mirrors of
//! each entry's least cost and of its two neighbours (the mirrors of candidates uniform
//! in 1/z are uniform in 1/z: each mirror reads its dip at the same offset as its
//! candidate reads the other), and at z_c itself; the least of the three is the entry's
//! mirror reading, a rival of the least cost (as a cost beyond a ridge, [`RIDGE`]) where
//! the cost at z_c rises to [`RIDGE`] times it.

use rayon::prelude::*;

use super::layer::{self, Layer};
use super::micro::Micro;
use super::{Fold, Plan, RIDGE};
use crate::infra::error::Result;
use crate::infra::parallel::{checkpoint, for_chunks};
use crate::model::design::Design;
use crate::model::optics::LensOptics;

/// Bytes per entry (cell and channel) of the mirror pass: the least reading, the cost at
/// z_c and the rival returned.
pub(super) const BYTES_PER_ENTRY: u128 = 3 * 8;

/// The mirror of z in inverse depth about zc, where it is a depth within [lo, hi].
fn mirror(zc: f64, z: f64, lo: f64, hi: f64) -> Option<f64> {
    let inv = 2.0 / zc - 1.0 / z;
    (inv > 0.0)
        .then(|| 1.0 / inv)
        .filter(|&m| m >= lo && m <= hi)
}

/// The candidates whose mirrors about `zc` an entry with its least cost at candidate k
/// reads: k and its neighbours whose mirror lies within the candidates and beyond zc from
/// candidate k (none where candidate k is zc itself).
fn reads(cand: &[f64], zc: f64, k: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
    let n = cand.len();
    let (lo, hi) = (cand[0], cand[n - 1]);
    let js = if k < n && cand[k] != zc {
        k.saturating_sub(1)..(k + 2).min(n)
    } else {
        0..0
    };
    js.filter_map(move |j| {
        mirror(zc, cand[j], lo, hi)
            .filter(|&m| (cand[k] - zc) * (m - zc) < 0.0)
            .map(|m| (j, m))
    })
}

/// Per entry (channel-major, as the fold's) the mirror rival of its least cost: the least
/// cost of its channel at the mirrors about the channel's out-of-focus plane z_c of its
/// least cost's candidate and of that candidate's two neighbours ([`reads`]), where the
/// cost at z_c is at least [`RIDGE`] times it; +∞ elsewhere (and for a channel whose z_c
/// does not lie strictly inside the candidates). Each depth read is one more layer of the
/// sweep, computed as a candidate's, `workers` at a time.
pub(super) fn rivals(
    design: &Design,
    mi: &Micro,
    plan: &Plan,
    chosen: &[usize],
    fold: &Fold,
    workers: usize,
    n_threads: Option<usize>,
) -> Result<Vec<f64>> {
    let cand = plan.candidates;
    let n = cand.len();
    let entries = fold.arg.len();
    let cells = entries / chosen.len();
    let focus: Vec<Option<f64>> = chosen
        .iter()
        .map(|&i| {
            let zc = LensOptics::of_channel(design, &design.channels[i], 0).out_of_focus_depth();
            (zc > cand[0] && zc < cand[n - 1]).then_some(zc)
        })
        .collect();
    let mut rival = vec![f64::INFINITY; entries];
    if focus.iter().all(Option::is_none) {
        return Ok(rival);
    }
    // The depths to read (each channel's mirrors of the candidates some entry reads, and
    // every z_c), and per channel and candidate the index of its mirror among them.
    let mut depths: Vec<f64> = focus.iter().flatten().copied().collect();
    let mut wanted = vec![false; chosen.len() * n];
    for e in 0..entries {
        let ch = e / cells;
        if let Some(zc) = focus[ch] {
            for (j, _) in reads(cand, zc, fold.arg[e] as usize) {
                wanted[ch * n + j] = true;
            }
        }
    }
    for (i, _) in wanted.iter().enumerate().filter(|w| *w.1) {
        let (ch, j) = (i / n, i % n);
        if let Some(m) = focus[ch].and_then(|zc| mirror(zc, cand[j], cand[0], cand[n - 1])) {
            depths.push(m);
        }
    }
    depths.sort_by(f64::total_cmp);
    depths.dedup();
    let index = |z: f64| depths.binary_search_by(|d| d.total_cmp(&z)).ok();
    let ex = (
        plan.grid.nx + 2 * plan.radius,
        plan.grid.ny + 2 * plan.radius,
    );
    let mut least = vec![f64::INFINITY; entries];
    let mut ridge = vec![f64::NAN; entries];
    for_chunks(n_threads, depths.len(), workers, |range| {
        let chunk = range.clone();
        let layers = range
            .into_par_iter()
            .map(|i| {
                checkpoint()?;
                let mut buf = Layer::new(ex, mi.channels);
                let mut out = vec![0.0; entries];
                let z = depths[i];
                layer::layer(mi, &plan.grid, plan.radius, z, &mut buf, &mut out, None)?;
                Ok(out)
            })
            .collect::<Result<Vec<Vec<f64>>>>()?;
        let of = |z: f64| {
            index(z)
                .filter(|i| chunk.contains(i))
                .map(|i| i - chunk.start)
        };
        for e in 0..entries {
            let Some(zc) = focus[e / cells] else {
                continue;
            };
            for (_, m) in reads(cand, zc, fold.arg[e] as usize) {
                if let Some(l) = of(m) {
                    let v = layers[l][e];
                    if v < least[e] {
                        least[e] = v;
                    }
                }
            }
            if let Some(l) = of(zc) {
                ridge[e] = layers[l][e];
            }
        }
        Ok(())
    })?;
    for e in 0..entries {
        if least[e].is_finite() && ridge[e] >= RIDGE * least[e] {
            rival[e] = least[e];
        }
    }
    Ok(rival)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_reflects_inverse_depth_about_the_plane() {
        // 1/624 − 1/642 = 1/642 − 1/z'
        let m = mirror(642.0, 624.0, 250.0, 4000.0).unwrap();
        assert!((1.0 / 624.0 - 1.0 / 642.0 - (1.0 / 642.0 - 1.0 / m)).abs() < 1e-15);
        assert!((mirror(642.0, m, 250.0, 4000.0).unwrap() - 624.0).abs() < 1e-9);
        // beyond infinity (2/z_c < 1/z) and outside the candidates: none
        assert_eq!(mirror(642.0, 300.0, 250.0, 4000.0), None);
        assert_eq!(mirror(642.0, 400.0, 250.0, 1000.0), None);
    }

    #[test]
    fn reads_are_the_mirrors_beyond_the_plane() {
        let cand = [500.0, 600.0, 640.0, 650.0, 700.0, 800.0];
        let zc = 642.0;
        // least cost at 700 mm: the mirrors of 650, 700 and 800 mm, all below 642 mm
        let r: Vec<(usize, f64)> = reads(&cand, zc, 4).collect();
        assert_eq!(r.iter().map(|x| x.0).collect::<Vec<_>>(), vec![3, 4, 5]);
        for (j, m) in r {
            assert!(m < zc && (1.0 / m + 1.0 / cand[j] - 2.0 / zc).abs() < 1e-15);
        }
        // least cost at 650 mm: its neighbour at 640 mm lies on the other side of the
        // plane, and its mirror (644 mm) on the same side as 650 mm: not read
        assert_eq!(
            reads(&cand, zc, 3).map(|x| x.0).collect::<Vec<_>>(),
            vec![3, 4]
        );
        // at the last candidate; at z_c itself; with no least cost (u32::MAX)
        assert_eq!(
            reads(&cand, zc, 5).map(|x| x.0).collect::<Vec<_>>(),
            vec![4, 5]
        );
        assert_eq!(reads(&[500.0, 642.0, 800.0], zc, 1).count(), 0);
        assert_eq!(reads(&cand, zc, u32::MAX as usize).count(), 0);
    }
}
