//! The running minima of the cost curves: each layer of costs folded in candidate order
//! (docs/depth.md), so that the cost volume is never held whole.

use super::{KEEP_MINIMA, RIDGE};

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
    /// Bytes a fold holds per entry (cell and channel).
    pub(super) const BYTES_PER_ENTRY: u128 =
        (7 * 8 + 2 * 4 + KEEP_MINIMA * 16 + std::mem::size_of::<Ridge>()) as u128;

    pub(super) fn new(cells: usize) -> Fold {
        Fold {
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
        }
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
        for (c, &v) in layer.iter().enumerate() {
            if self.arg[c] != u32::MAX && k > 0 && self.arg[c] == k - 1 {
                self.right[c] = v;
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
                } else {
                    self.ridge[c].after_least(v);
                }
            }
        }
        std::mem::swap(&mut self.prev2, &mut self.prev);
        self.prev.copy_from_slice(layer);
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

    #[test]
    fn fold_tracks_the_neighbours_of_the_minimum() {
        let mut f = Fold::new(1);
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
        let mut f = Fold::new(1);
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
            let mut f = Fold::new(1);
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
        let mut f = Fold::new(1);
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
