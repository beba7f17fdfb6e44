//! The running minima of the cost curves: each layer of costs folded in candidate order
//! (docs/depth.md), so that the cost volume is never held whole.

use super::{KEEP_MINIMA, RESOLUTION_SPAN, RIDGE};
use crate::infra::error::Result;
use crate::infra::memory;

/// Running minima of the cost curves (candidates folded in order).
pub(super) struct Fold {
    /// The least cost, its candidate and its two neighbours' costs.
    pub(super) min: Vec<f64>,
    pub(super) arg: Vec<u32>,
    pub(super) left: Vec<f64>,
    pub(super) right: Vec<f64>,
    /// Per cell the [`KEEP_MINIMA`] least local minima of the curve (a missing cost counts
    /// as +∞), as (cost, candidate) in increasing cost.
    pub(super) lm: Vec<(f64, u32)>,
    pub(super) sum: Vec<f64>,
    pub(super) count: Vec<u32>,
    /// The costs of the last two candidates folded (k − 1 and k − 2).
    pub(super) prev: Vec<f64>,
    pub(super) prev2: Vec<f64>,
    /// Per entry the least costs beyond a ridge ([`Ridge`]).
    pub(super) ridge: Vec<Ridge>,
    /// The costs of the candidates that bracket the points [`RESOLUTION_SPAN`] either side
    /// of the least cost in ln z ([`Reach`] of its candidate): before it (a, b) and after.
    pub(super) before: Vec<[f64; 2]>,
    pub(super) after: Vec<[f64; 2]>,
    /// Per candidate where the resolution reads the curve ([`reaches`]).
    pub(super) reach: Vec<Option<Reach>>,
    /// The last `ring` layers folded, layer k at slot k % ring (the costs before a new
    /// least cost).
    hist: Vec<f64>,
    ring: usize,
}

/// One side of a least cost at candidate k, where the resolution (`confidence` in the
/// module above) reads its curve: the cost at `h` from ln z_k, linear in ln z between the
/// candidates `j` and `j + 1` ((1 − t) C_j + t C_{j+1}; t = 0: C_j alone).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Side {
    pub(super) j: u32,
    pub(super) t: f64,
    pub(super) h: f64,
}

impl Side {
    /// The cost at this side from the costs of its candidates (a, b).
    pub(super) fn cost(&self, ab: [f64; 2]) -> f64 {
        if self.t == 0.0 {
            ab[0]
        } else {
            (1.0 - self.t) * ab[0] + self.t * ab[1]
        }
    }
}

/// Where the resolution reads the curve of a least cost at candidate k: each side at
/// [`RESOLUTION_SPAN`] in ln z from it, interpolated between the candidates around that
/// point, or at the neighbour itself where it lies farther (candidates coarser than the
/// span); `None` where the span reaches beyond the candidates (the dip is not bracketed
/// over it: the truth may lie beyond) and at the ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Reach {
    pub(super) left: Side,
    pub(super) right: Side,
}

/// [`Reach`] per candidate (increasing, > 0).
pub(super) fn reaches(candidates: &[f64]) -> Vec<Option<Reach>> {
    let n = candidates.len();
    let ln: Vec<f64> = candidates.iter().map(|z| z.ln()).collect();
    (0..n)
        .map(|k| {
            if k == 0 || k + 1 >= n {
                return None;
            }
            let left = if ln[k] - ln[k - 1] >= RESOLUTION_SPAN {
                Side {
                    j: k as u32 - 1,
                    t: 0.0,
                    h: ln[k] - ln[k - 1],
                }
            } else {
                let u = ln[k] - RESOLUTION_SPAN;
                // the last j < k − 1 with ln z_j ≤ u (ln z_{j+1} > u)
                let j = ln[..k].iter().rposition(|&l| l <= u)?;
                let t = (u - ln[j]) / (ln[j + 1] - ln[j]);
                Side {
                    j: j as u32,
                    t,
                    h: RESOLUTION_SPAN,
                }
            };
            let right = if ln[k + 1] - ln[k] >= RESOLUTION_SPAN {
                Side {
                    j: k as u32 + 1,
                    t: 0.0,
                    h: ln[k + 1] - ln[k],
                }
            } else {
                let u = ln[k] + RESOLUTION_SPAN;
                // the first j + 1 > k + 1 with ln z_{j+1} ≥ u (ln z_j < u)
                let j1 = k + 2 + ln[k + 2..].iter().position(|&l| l >= u)?;
                let j = j1 - 1;
                let t = (u - ln[j]) / (ln[j1] - ln[j]);
                Side {
                    j: j as u32,
                    t,
                    h: RESOLUTION_SPAN,
                }
            };
            Some(Reach { left, right })
        })
        .collect()
}

/// The ring's length: the farthest back a least cost's left side reads (at least 1).
fn ring_of(reach: &[Option<Reach>]) -> usize {
    reach
        .iter()
        .enumerate()
        .filter_map(|(k, r)| r.map(|r| k - r.left.j as usize))
        .max()
        .unwrap_or(1)
}

/// The least costs that lie beyond a ridge from the least cost so far: a cost C_j counts
/// when the curve strictly between candidate j and the least cost's rises to at least
/// [`RIDGE`] C_j (a dip of its own, however near). Missing costs are skipped.
#[derive(Clone, Copy)]
pub(super) struct Ridge {
    /// The least such cost before the least cost and after it.
    before: f64,
    after: f64,
    /// The highest and the least cost folded since the least cost.
    high: f64,
    low: f64,
    /// The least cost folded since the least cost that a later one (so far) rises to
    /// [`RIDGE`] times: a ridge for the least cost yet to come.
    ridged: f64,
}

impl Ridge {
    const NONE: Ridge = Ridge {
        before: f64::INFINITY,
        after: f64::INFINITY,
        high: f64::NEG_INFINITY,
        low: f64::INFINITY,
        ridged: f64::INFINITY,
    };

    /// A new least cost after `old` (the previous least cost, +∞ at first): what lay
    /// before `old` keeps its ridge, which only rises; `old` itself has the highest cost
    /// since it as its ridge; the costs since it have [`Ridge::ridged`].
    fn new_least(&mut self, old: f64) {
        let before = if RIDGE * old <= self.high {
            old
        } else {
            self.before
        };
        *self = Ridge {
            before: before.min(self.ridged),
            ..Ridge::NONE
        };
    }

    /// A cost v not below the least cost.
    fn after_least(&mut self, v: f64) {
        if RIDGE * v <= self.high {
            self.after = self.after.min(v);
        }
        if RIDGE * self.low <= v {
            self.ridged = self.ridged.min(self.low);
        }
        self.high = self.high.max(v);
        self.low = self.low.min(v);
    }
}

/// A missing cost as +∞ (for comparisons).
fn or_inf(v: f64) -> f64 {
    if v.is_nan() {
        f64::INFINITY
    } else {
        v
    }
}

impl Fold {
    /// Bytes a fold over `candidates` holds per entry (cell and channel): its minima, its
    /// ridges and its ring of the last layers ([`reaches`]).
    pub(super) fn bytes_per_entry(candidates: &[f64]) -> u128 {
        let ring = ring_of(&reaches(candidates));
        (11 * 8 + 2 * 4 + KEEP_MINIMA * 16 + std::mem::size_of::<Ridge>() + ring * 8) as u128
    }

    /// A fold before any layer. Its ring of layers is hundreds of megabytes on a large grid
    /// of many candidates, filled with a check for Ctrl-C between slices.
    pub(super) fn new(cells: usize, candidates: &[f64]) -> Result<Fold> {
        let reach = reaches(candidates);
        let ring = ring_of(&reach);
        let hist = memory::try_vec_interruptible(
            "the depth sweep's last layers",
            cells.saturating_mul(ring),
            f64::NAN,
        )?;
        Ok(Fold {
            min: vec![f64::INFINITY; cells],
            arg: vec![u32::MAX; cells],
            left: vec![f64::NAN; cells],
            right: vec![f64::NAN; cells],
            lm: vec![(f64::INFINITY, u32::MAX); cells * KEEP_MINIMA],
            sum: vec![0.0; cells],
            count: vec![0; cells],
            prev: vec![f64::NAN; cells],
            prev2: vec![f64::NAN; cells],
            ridge: vec![Ridge::NONE; cells],
            before: vec![[f64::NAN; 2]; cells],
            after: vec![[f64::NAN; 2]; cells],
            reach,
            hist,
            ring,
        })
    }

    /// Note `m`, the cost of candidate k lower than both its neighbours', as a local
    /// minimum.
    fn local(&mut self, c: usize, m: f64, k: u32) {
        let kept = &mut self.lm[c * KEEP_MINIMA..(c + 1) * KEEP_MINIMA];
        if m < kept[KEEP_MINIMA - 1].0 {
            let at = kept.partition_point(|e| e.0 <= m);
            kept[at..].rotate_right(1);
            kept[at] = (m, k);
        }
    }

    /// The least local minimum more than `sep` candidates from the least cost (+∞: none
    /// among those kept).
    pub(super) fn rival(&self, c: usize, sep: u32) -> f64 {
        let arg = self.arg[c];
        self.lm[c * KEEP_MINIMA..(c + 1) * KEEP_MINIMA]
            .iter()
            .find(|e| e.1 != u32::MAX && e.1.abs_diff(arg) > sep)
            .map_or(f64::INFINITY, |e| e.0)
    }

    /// The least cost beyond a ridge from the least cost ([`Ridge`]; +∞: none).
    pub(super) fn ridged(&self, c: usize) -> f64 {
        let r = &self.ridge[c];
        r.before.min(r.after)
    }

    pub(super) fn add(&mut self, k: u32, layer: &[f64]) {
        let cells = layer.len();
        let ring = self.ring;
        // A new least cost here reads its left side from the ring (not yet overwritten:
        // k − j ≤ ring).
        let back = self.reach.get(k as usize).copied().flatten().map(|r| {
            let (a, t) = (r.left.j as usize, r.left.t);
            let b = if t == 0.0 { a } else { a + 1 };
            (a % ring * cells, b % ring * cells)
        });
        for (c, &v) in layer.iter().enumerate() {
            let arg = self.arg[c];
            if arg != u32::MAX && k > 0 && arg == k - 1 {
                self.right[c] = v;
            }
            if let Some(Some(r)) = self.reach.get(arg as usize) {
                if k == r.right.j {
                    self.after[c][0] = v;
                } else if k == r.right.j + 1 {
                    self.after[c][1] = v;
                }
            }
            let p = or_inf(self.prev[c]);
            if k > 0 && p.is_finite() && p < or_inf(self.prev2[c]) && p <= or_inf(v) {
                self.local(c, p, k - 1);
            }
            if v.is_finite() {
                self.sum[c] += v;
                self.count[c] += 1;
                if v < self.min[c] {
                    self.ridge[c].new_least(self.min[c]);
                    self.min[c] = v;
                    self.arg[c] = k;
                    self.left[c] = self.prev[c];
                    self.right[c] = f64::NAN;
                    self.before[c] =
                        back.map_or([f64::NAN; 2], |(a, b)| [self.hist[a + c], self.hist[b + c]]);
                    self.after[c] = [f64::NAN; 2];
                } else {
                    self.ridge[c].after_least(v);
                }
            }
        }
        std::mem::swap(&mut self.prev2, &mut self.prev);
        self.prev.copy_from_slice(layer);
        let slot = k as usize % ring * cells;
        self.hist[slot..slot + cells].copy_from_slice(layer);
    }

    /// After the last candidate: it is a local minimum when lower than the one before.
    pub(super) fn end(&mut self, n: u32) {
        for c in 0..self.min.len() {
            let p = or_inf(self.prev[c]);
            if n > 0 && p.is_finite() && p < or_inf(self.prev2[c]) {
                self.local(c, p, n - 1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Candidates 100 · 2^k: a relative step (ln 2) far coarser than the span, so K = 1.
    const UNIFORM: [f64; 16] = {
        let mut c = [100.0; 16];
        let mut k = 1;
        while k < 16 {
            c[k] = 2.0 * c[k - 1];
            k += 1;
        }
        c
    };

    /// The cost of the curve at u in ln z, linear in ln z between the candidates around
    /// it (brute force).
    fn at(ln: &[f64], curve: &[f64], u: f64) -> f64 {
        let j = ln.iter().rposition(|&l| l <= u).unwrap();
        if ln[j] == u {
            return curve[j];
        }
        let t = (u - ln[j]) / (ln[j + 1] - ln[j]);
        (1.0 - t) * curve[j] + t * curve[j + 1]
    }

    #[test]
    fn reaches_read_the_curve_a_fixed_relative_depth_away() {
        // Coarse candidates: the neighbours.
        for (k, r) in reaches(&UNIFORM).into_iter().enumerate() {
            let want = (k > 0 && k < 15).then(|| {
                let s = |j: usize| Side {
                    j: j as u32,
                    t: 0.0,
                    h: 2f64.ln(),
                };
                Reach {
                    left: s(k - 1),
                    right: s(k + 1),
                }
            });
            let near = |a: Option<Reach>, b: Option<Reach>| match (a, b) {
                (None, None) => true,
                (Some(a), Some(b)) => {
                    a.left.j == b.left.j
                        && a.right.j == b.right.j
                        && (a.left.h - b.left.h).abs() < 1e-12
                        && (a.right.h - b.right.h).abs() < 1e-12
                        && a.left.t == 0.0
                        && a.right.t == 0.0
                }
                _ => false,
            };
            assert!(near(r, want), "{k} {r:?}");
        }
        // 200 candidates uniform in 1/z from 250 mm to 4 m: a cost linear in ln z is read
        // at ±RESOLUTION_SPAN exactly where the step is finer, at the neighbour where not;
        // none within the span of the first candidate.
        let n = 200;
        let c: Vec<f64> = (0..n)
            .map(|i| 1.0 / (1.0 / 250.0 + (1.0 / 4000.0 - 1.0 / 250.0) * i as f64 / 199.0))
            .collect();
        let ln: Vec<f64> = c.iter().map(|z| z.ln()).collect();
        let curve: Vec<f64> = ln.iter().map(|l| 3.0 * l + 1.0).collect();
        let mut coarse = 0;
        for (k, r) in reaches(&c).into_iter().enumerate() {
            let inside = k > 0 && k + 1 < n && ln[k] - RESOLUTION_SPAN >= ln[0];
            assert_eq!(r.is_some(), inside, "{k}");
            let Some(r) = r else { continue };
            for (side, sign) in [(r.left, -1.0), (r.right, 1.0)] {
                let j = side.j as usize;
                let ab = [curve[j], curve.get(j + 1).copied().unwrap_or(f64::NAN)];
                let u = ln[k] + sign * side.h;
                assert!((side.cost(ab) - at(&ln, &curve, u)).abs() < 1e-9, "{k}");
                if side.t == 0.0 {
                    assert!(side.h >= RESOLUTION_SPAN && j.abs_diff(k) == 1);
                    coarse += 1;
                } else {
                    assert_eq!(side.h, RESOLUTION_SPAN);
                }
            }
        }
        assert!(coarse > 10 && coarse < 300, "{coarse}");
    }

    #[test]
    fn fold_keeps_the_costs_a_span_either_side_of_the_minimum() {
        use crate::infra::random::splitmix64;
        let c: Vec<f64> = (0..40)
            .map(|k| 500.0 * (k as f64 * RESOLUTION_SPAN / 3.3).exp())
            .collect();
        let reach = reaches(&c);
        let mut seen = 0;
        for seed in 0..400u64 {
            let curve: Vec<f64> = (0..40u64)
                .map(|i| {
                    let u = splitmix64(seed << 8 | (i + 1));
                    if u % 23 == 0 {
                        f64::NAN
                    } else {
                        ((u >> 8) % 1000) as f64
                    }
                })
                .collect();
            let mut f = Fold::new(1, &c).unwrap();
            for (k, &v) in curve.iter().enumerate() {
                f.add(k as u32, &[v]);
            }
            let k = f.arg[0] as usize;
            let Some(r) = reach[k] else { continue };
            seen += 1;
            let pair = |s: Side| [curve[s.j as usize], curve[s.j as usize + 1]];
            let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
            assert!(
                same(r.left.cost(f.before[0]), r.left.cost(pair(r.left))),
                "{seed}"
            );
            assert!(
                same(r.right.cost(f.after[0]), r.right.cost(pair(r.right))),
                "{seed}"
            );
        }
        assert!(seen > 200, "{seen}");
    }

    #[test]
    fn fold_tracks_the_neighbours_of_the_minimum() {
        let mut f = Fold::new(1, &UNIFORM).unwrap();
        for (k, v) in [5.0, 3.0, 1.0, 2.0, 4.0].into_iter().enumerate() {
            f.add(k as u32, &[v]);
        }
        assert_eq!(
            (f.arg[0], f.min[0], f.left[0], f.right[0]),
            (2, 1.0, 3.0, 2.0)
        );
        assert_eq!((f.sum[0], f.count[0]), (15.0, 5));
        f.end(5);
        assert_eq!(f.lm[0], (1.0, 2));
        assert_eq!(f.rival(0, 1), f64::INFINITY);
    }

    #[test]
    fn fold_keeps_the_least_local_minima() {
        let mut f = Fold::new(1, &UNIFORM).unwrap();
        for (k, v) in [1.0, 4.0, 2.0, 3.0, f64::NAN, 5.0, 0.5]
            .into_iter()
            .enumerate()
        {
            f.add(k as u32, &[v]);
        }
        f.end(7);
        // Local minima: 1 (first, a missing neighbour counts as +inf), 2, 0.5 (last).
        assert_eq!(
            &f.lm[..4],
            &[(0.5, 6), (1.0, 0), (2.0, 2), (f64::INFINITY, u32::MAX)]
        );
        assert_eq!((f.arg[0], f.min[0]), (6, 0.5));
        assert_eq!((f.rival(0, 3), f.rival(0, 6)), (1.0, f64::INFINITY));
    }

    /// The least cost C_j (j not the first least cost) whose curve strictly between it and
    /// the least cost rises to RIDGE C_j, missing costs skipped: by brute force.
    fn ridged_by_brute_force(curve: &[f64]) -> f64 {
        let finite = |i: &usize| curve[*i].is_finite();
        let Some(k) =
            (0..curve.len())
                .filter(finite)
                .reduce(|a, b| if curve[b] < curve[a] { b } else { a })
        else {
            return f64::INFINITY;
        };
        (0..curve.len())
            .filter(|j| finite(j) && *j != k)
            .filter(|&j| {
                let (a, b) = (j.min(k) + 1, j.max(k));
                let ridge = (a..b)
                    .filter(finite)
                    .map(|i| curve[i])
                    .fold(f64::NEG_INFINITY, f64::max);
                ridge >= RIDGE * curve[j]
            })
            .map(|j| curve[j])
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn ridged_rival_is_the_least_cost_beyond_a_ridge() {
        use crate::infra::random::splitmix64;
        // Curves of 1 to 16 costs from 0 to 7 (ties and costs exactly RIDGE times another
        // included), one in 7 missing.
        let mut found = 0;
        for seed in 0..4000u64 {
            let n = 1 + (splitmix64(seed) % 16) as usize;
            let curve: Vec<f64> = (0..n as u64)
                .map(|i| {
                    let u = splitmix64(seed << 8 | (i + 1));
                    if u % 7 == 0 {
                        f64::NAN
                    } else {
                        ((u >> 8) % 8) as f64
                    }
                })
                .collect();
            let mut f = Fold::new(1, &UNIFORM).unwrap();
            for (k, &v) in curve.iter().enumerate() {
                f.add(k as u32, &[v]);
            }
            f.end(n as u32);
            let want = ridged_by_brute_force(&curve);
            assert_eq!(f.ridged(0), want, "{curve:?}");
            found += usize::from(want.is_finite());
        }
        assert!(found > 1000, "{found}");
        // The R12's case (docs/depth.md): a least cost beside a second dip three
        // candidates away behind a ridge; the far rival misses it, the ridge does not.
        let mut f = Fold::new(1, &UNIFORM).unwrap();
        for (k, v) in [0.8, 0.051, 0.12, 0.28, 0.058, 0.075, 0.2, 0.8]
            .into_iter()
            .enumerate()
        {
            f.add(k as u32, &[v]);
        }
        f.end(8);
        assert_eq!(
            (f.arg[0], f.ridged(0), f.rival(0, 4)),
            (1, 0.058, f64::INFINITY)
        );
    }
}
