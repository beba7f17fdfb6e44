//! The running minima of the cost curves: each layer of costs folded in candidate order
//! (docs/depth.md), so that the cost volume is never held whole.

use super::KEEP_MINIMA;

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
    pub(super) const BYTES_PER_ENTRY: u128 = (7 * 8 + 2 * 4 + KEEP_MINIMA * 16) as u128;

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
                    self.min[c] = v;
                    self.arg[c] = k;
                    self.left[c] = self.prev[c];
                    self.right[c] = f64::NAN;
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
}
