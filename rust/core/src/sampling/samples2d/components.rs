//! Distinct samples: connected components of |ΔX|, |ΔY| < eps with a hash grid and
//! union-find, each represented by its least member (docs/model.md §9).

use super::*;
use crate::infra::error::Result;
use crate::infra::memory::try_reserve;
use crate::infra::parallel::{self};

// ---- distinct samples: hash grid and union-find --------------------------------------

/// Two samples are one when both coordinates differ by less than eps.
#[inline]
pub(super) fn linked(a: [f64; 2], b: [f64; 2], eps: f64) -> bool {
    (a[0] - b[0]).abs() < eps && (a[1] - b[1]).abs() < eps
}

/// (X, Y) lexicographic order: the representative is the least member.
#[inline]
pub(super) fn before(a: [f64; 2], b: [f64; 2]) -> bool {
    a[0] < b[0] || (a[0] == b[0] && a[1] < b[1])
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

fn unite(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// One occupied hash-grid cell: its key, its members (a range of the sorted cell list),
/// whether they are pairwise linked (a clique) and their bounding box.
#[derive(Debug, Clone, Copy)]
struct Cell {
    key: (i64, i64),
    start: u32,
    end: u32,
    clique: bool,
    lo: [f64; 2],
    hi: [f64; 2],
}

/// Reusable buffers of [`components`].
#[derive(Debug, Default)]
pub(super) struct CompWork {
    keys: Vec<(i64, i64, u32)>,
    parent: Vec<u32>,
    cells: Vec<Cell>,
    best: Vec<u32>,
    touch: Vec<bool>,
}

/// Cells (or keys) between two checks for Ctrl-C in [`components`]: millions of samples
/// (a window of the Illum) take seconds in all, tens of milliseconds between checks.
const CHECK_EVERY_CELLS: usize = 1 << 16;

/// Keys at most per slice of [`sort_keys`]: sorted in tens of milliseconds.
const SORT_SLICE: usize = 1 << 18;

/// `keys.sort_unstable()` with a check for Ctrl-C every slice: partitioned in place by
/// ranges of kx of equal width (American flag sort), then each range sorted. The keys are
/// distinct (their third field is the sample's index), so the order is the one sort.
fn sort_keys(keys: &mut [(i64, i64, u32)]) -> Result<()> {
    let n = keys.len();
    if n <= SORT_SLICE {
        keys.sort_unstable();
        return parallel::checkpoint();
    }
    let (lo, hi) = keys
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), k| (a.min(k.0), b.max(k.0)));
    let buckets = n.div_ceil(SORT_SLICE);
    let span = hi as i128 - lo as i128 + 1;
    let bucket =
        |k: &(i64, i64, u32)| ((k.0 as i128 - lo as i128) * buckets as i128 / span) as usize;
    let mut start = vec![0usize; buckets + 1];
    for k in keys.iter() {
        start[bucket(k) + 1] += 1;
    }
    for b in 0..buckets {
        start[b + 1] += start[b];
    }
    parallel::checkpoint()?;
    // Cycle leader: every key is moved straight to the next free place of its range.
    let mut next = start[..buckets].to_vec();
    for b in 0..buckets {
        while next[b] < start[b + 1] {
            let mut v = keys[next[b]];
            let mut t = bucket(&v);
            while t != b {
                std::mem::swap(&mut v, &mut keys[next[t]]);
                next[t] += 1;
                t = bucket(&v);
            }
            keys[next[b]] = v;
            next[b] += 1;
        }
        parallel::checkpoint()?;
    }
    for b in 0..buckets {
        keys[start[b]..start[b + 1]].sort_unstable();
        parallel::checkpoint()?;
    }
    Ok(())
}

/// Unite the linked members within each cell.
fn within_cells(
    pts: &[[f64; 2]],
    eps: f64,
    keys: &[(i64, i64, u32)],
    cells: &[Cell],
    parent: &mut [u32],
) -> Result<()> {
    let member = |i: u32| keys[i as usize].2;
    for (ci, c) in cells.iter().enumerate() {
        if ci % CHECK_EVERY_CELLS == 0 {
            parallel::checkpoint()?;
        }
        if c.clique {
            for i in c.start + 1..c.end {
                unite(parent, member(c.start), member(i));
            }
        } else {
            for i in c.start..c.end {
                for k in i + 1..c.end {
                    let (a, b) = (member(i), member(k));
                    if linked(pts[a as usize], pts[b as usize], eps) {
                        unite(parent, a, b);
                    }
                }
            }
        }
    }
    Ok(())
}

/// Connected components of the relation [`linked`] (eps > 0) over `pts`: hash grid of
/// cell eps (1 + CELL_SLACK), union-find over members of the same and the adjacent cells.
/// Writes one (representative index, touching) per component to `reps`, where a component
/// touches when one of its members has Chebyshev excess over the field above `band`.
pub(super) fn components(
    pts: &[[f64; 2]],
    eps: f64,
    field: [f64; 2],
    band: f64,
    w: &mut CompWork,
    reps: &mut Vec<(u32, bool)>,
) -> Result<()> {
    let what = "coverage (union-find buffers)";
    let n = pts.len();
    reps.clear();
    let cell = eps * (1.0 + CELL_SLACK);
    w.keys.clear();
    try_reserve(&mut w.keys, what, n)?;
    w.keys.extend(pts.iter().enumerate().map(|(i, p)| {
        (
            (p[0] / cell).floor() as i64,
            (p[1] / cell).floor() as i64,
            i as u32,
        )
    }));
    parallel::checkpoint()?;
    sort_keys(&mut w.keys)?;
    w.parent.clear();
    try_reserve(&mut w.parent, what, n)?;
    w.parent.extend(0..n as u32);
    // Cells: runs of equal keys.
    w.cells.clear();
    let mut i = 0;
    while i < n {
        if w.cells.len() % CHECK_EVERY_CELLS == 0 {
            parallel::checkpoint()?;
        }
        let key = (w.keys[i].0, w.keys[i].1);
        let mut e = i;
        let (mut lo, mut hi) = (pts[w.keys[i].2 as usize], pts[w.keys[i].2 as usize]);
        while e < n && (w.keys[e].0, w.keys[e].1) == key {
            let p = pts[w.keys[e].2 as usize];
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
            e += 1;
        }
        // Members differ by at most the box's extents: below eps, every pair is linked.
        let clique = hi[0] - lo[0] < eps && hi[1] - lo[1] < eps;
        w.cells.push(Cell {
            key,
            start: i as u32,
            end: e as u32,
            clique,
            lo,
            hi,
        });
        i = e;
    }
    let (keys, parent, cells) = (&w.keys, &mut w.parent, &w.cells);
    let member = |i: u32| keys[i as usize].2;
    within_cells(pts, eps, keys, cells, parent)?;
    // Between a cell and its forward neighbours (kx, ky + 1), (kx + 1, ky − 1 ..= ky + 1):
    // every adjacent pair once. The cells are sorted by key, so the neighbours in column
    // kx + 1 are found by a pointer that only moves forward.
    let link_cells = |parent: &mut [u32], a: &Cell, b: &Cell| {
        let gap_x = (b.lo[0] - a.hi[0]).max(a.lo[0] - b.hi[0]);
        let gap_y = (b.lo[1] - a.hi[1]).max(a.lo[1] - b.hi[1]);
        if gap_x >= eps || gap_y >= eps {
            return;
        }
        let both = a.clique && b.clique;
        for i in a.start..a.end {
            for k in b.start..b.end {
                let (p, q) = (member(i), member(k));
                if linked(pts[p as usize], pts[q as usize], eps) {
                    unite(parent, p, q);
                    if both {
                        return;
                    }
                }
            }
        }
    };
    parallel::checkpoint()?;
    let mut ptr = 0;
    for (ci, c) in cells.iter().enumerate() {
        if ci % CHECK_EVERY_CELLS == 0 {
            parallel::checkpoint()?;
        }
        let (kx, ky) = c.key;
        if let Some(next) = cells.get(ci + 1) {
            if next.key == (kx, ky + 1) {
                link_cells(parent, c, next);
            }
        }
        let first = (kx + 1, ky - 1);
        while ptr < cells.len() && cells[ptr].key < first {
            ptr += 1;
        }
        let mut q = ptr;
        while q < cells.len() && cells[q].key <= (kx + 1, ky + 1) {
            link_cells(parent, c, &cells[q]);
            q += 1;
        }
    }
    // Representatives (least (X, Y)) and touching flags, per root.
    w.best.clear();
    try_reserve(&mut w.best, what, n)?;
    w.best.extend(0..n as u32);
    w.touch.clear();
    try_reserve(&mut w.touch, what, n)?;
    w.touch.resize(n, false);
    for i in 0..n as u32 {
        if i as usize % CHECK_EVERY_CELLS == 0 {
            parallel::checkpoint()?;
        }
        let r = find(parent, i) as usize;
        let p = pts[i as usize];
        if before(p, pts[w.best[r] as usize]) {
            w.best[r] = i;
        }
        if excess(p, field) > band {
            w.touch[r] = true;
        }
    }
    try_reserve(reps, what, n)?;
    parallel::checkpoint()?;
    for i in 0..n as u32 {
        if parent[i as usize] == i {
            reps.push((w.best[i as usize], w.touch[i as usize]));
        }
    }
    Ok(())
}

/// Chebyshev distance by which p lies outside the field |X| ≤ h_x, |Y| ≤ h_y (≤ 0 inside).
#[inline]
pub(super) fn excess(p: [f64; 2], field: [f64; 2]) -> f64 {
    (p[0].abs() - field[0]).max(p[1].abs() - field[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::samples2d::test_designs::*;

    /// The sliced sort is the plain one: keys over a wide, a one-column and a negative
    /// range of kx, more than one slice each (so the partition runs).
    #[test]
    fn sort_keys_equals_sort_unstable() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let n = 2 * SORT_SLICE + 12_345;
        for (lo, width) in [(-3_000_000i64, 6_000_000.0), (7, 1.0), (-900, 400.0)] {
            let mut keys: Vec<(i64, i64, u32)> = (0..n as u32)
                .map(|i| {
                    let kx = lo + (rng.next() * width) as i64;
                    (kx, (rng.next() * 50.0) as i64 - 25, i)
                })
                .collect();
            let mut want = keys.clone();
            want.sort_unstable();
            sort_keys(&mut keys).unwrap();
            assert!(keys == want, "kx from {lo}, width {width}");
        }
    }

    /// Brute-force components: O(n²) pairs, union-find.
    fn brute_components(pts: &[[f64; 2]], eps: f64) -> Vec<[f64; 2]> {
        let n = pts.len();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        for i in 0..n {
            for k in i + 1..n {
                if linked(pts[i], pts[k], eps) {
                    unite(&mut parent, i as u32, k as u32);
                }
            }
        }
        let mut best: Vec<Option<[f64; 2]>> = vec![None; n];
        for (i, &p) in pts.iter().enumerate() {
            let r = find(&mut parent, i as u32) as usize;
            if best[r].is_none_or(|b| before(p, b)) {
                best[r] = Some(p);
            }
        }
        let mut reps: Vec<[f64; 2]> = best.into_iter().flatten().collect();
        reps.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        reps
    }

    #[test]
    fn components_equal_brute_force() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut w = CompWork::default();
        let mut reps = Vec::new();
        for case in 0..300 {
            let n = 1 + (rng.next() * 120.0) as usize;
            let eps = 0.05 + rng.next() * 0.3;
            // Clusters, chains along the axes and coincident points: every cell situation.
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|_| {
                    let c = (rng.next() * 6.0).floor();
                    match case % 3 {
                        0 => [
                            c * 0.7 + rng.next() * 0.4,
                            (c * 1.3) % 2.0 + rng.next() * 0.4,
                        ],
                        1 => [(rng.next() * 20.0).floor() * eps * 0.9, c * eps * 1.5],
                        _ => [
                            (rng.next() * 5.0).floor() * eps,
                            (rng.next() * 5.0).floor() * eps,
                        ],
                    }
                })
                .collect();
            components(&pts, eps, [1.0, 1.0], f64::INFINITY, &mut w, &mut reps).unwrap();
            let mut got: Vec<[f64; 2]> = reps.iter().map(|&(r, _)| pts[r as usize]).collect();
            got.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
            assert_eq!(got, brute_components(&pts, eps), "case {case}");
        }
    }
}
