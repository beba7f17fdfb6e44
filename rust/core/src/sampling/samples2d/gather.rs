//! The samples near the central field: which pixels' chief samples can fall within a
//! margin of it, gathered row by row from the [`Tables`].

use super::tables::{dispatch, ColumnX, PixelTables, Px, RowCandidates, Sensor, Tables};
use crate::infra::error::Result;
use crate::infra::memory::try_reserve;
use crate::model::design::Aperture;

/// Pixel rows between two checks for Ctrl-C in a gather (milliseconds of work).
const CHECK_EVERY_ROWS: usize = 64;

impl<'a> Tables<'a> {
    /// Largest |X| and |Y| of any lit sample on the plane (g = z/L, s = (L − z')/z'),
    /// with room for rounding: lens centres plus the aperture's half-width through s.
    pub(super) fn sample_extent(&self, g: f64, s: f64) -> [f64; 2] {
        let r = self.design.aperture / 2.0 * s.abs();
        let cxmax = self
            .cx
            .iter()
            .filter_map(|c| Some(c.first()?.abs().max(c.last()?.abs())))
            .fold(0.0, f64::max);
        let cymax = self.cy[0].abs().max(self.cy[self.cy.len() - 1].abs());
        let pad = 1.0 + 1e-9;
        [g * (cxmax + r) * pad, g * (cymax + r) * pad]
    }

    /// Upper bound on the pixels a gather at bounds |X| ≤ bx, |Y| ≤ by looks at (see
    /// [`Tables::candidate_columns`]): columns and rows whose lenses' sample boxes reach
    /// the bounds, widened by the candidate search's reach.
    pub(super) fn pass_pixels(&self, g: f64, s: f64, bx: f64, by: f64) -> u128 {
        let r = self.design.aperture / 2.0 * s.abs();
        let pad = 1.0 + 1e-9;
        // Lens centres within reach: |c| ≤ (bound / g + r) on the array plane.
        let reach = |b: f64| (b / g + r) * pad;
        let (cb, rb) = match &self.px {
            PixelTables::Ideal { q, .. } => {
                let lenses = |b: f64| 2.0 * reach(b) / self.ch.d + 2.0;
                (lenses(bx) * *q as f64, lenses(by) * *q as f64)
            }
            PixelTables::Sensor(Sensor { p, .. }) => {
                // Candidate lenses of a pixel lie within two image pitches of it.
                let m = self.ch.magnification();
                let px = |b: f64| 2.0 * (reach(b) * m + 2.0 * p) / self.ch.mu + 2.0;
                (px(bx), px(by))
            }
        };
        let c = if cb.is_finite() {
            (cb as u128).min(self.cols as u128)
        } else {
            self.cols as u128
        };
        let r = if rb.is_finite() {
            (rb as u128).min(self.rows as u128)
        } else {
            self.rows as u128
        };
        c * r
    }

    /// Columns whose samples can satisfy |X| ≤ bx: for each column, X of every candidate
    /// lens (the pixel's lens is one of them; ideal: X depends on the column only). The
    /// sensor layout looks only at the columns of [`Tables::sensor_range`] and writes each
    /// accepted column's [`ColumnX`] to `colx` (as [`Tables::columns_x`] computes it).
    pub(super) fn candidate_columns(
        &self,
        g: f64,
        s: f64,
        bx: f64,
        out: &mut Vec<u32>,
        colx: &mut Vec<ColumnX>,
    ) -> Result<()> {
        out.clear();
        colx.clear();
        match &self.px {
            PixelTables::Ideal { q, w } => {
                let mut a = 0u32;
                for j in 0..self.ch.kx as usize {
                    for &wx in w.iter() {
                        if (-g * (self.cx[0][j] + wx * s)).abs() <= bx {
                            out.push(a);
                        }
                        a += 1;
                    }
                }
                debug_assert_eq!(a as usize, self.ch.kx as usize * *q as usize);
            }
            PixelTables::Sensor(sen) => {
                let parities = if self.cx[1].is_empty() { 1 } else { 2 };
                let r = self.design.aperture / 2.0;
                let range = self.sensor_range(&sen.sx, g, s, bx);
                let what = "coverage (column tables)";
                try_reserve(out, what, range.len())?;
                try_reserve(colx, what, range.len())?;
                for a in range {
                    // A candidate that can be lit has |w_x| < D/2 (both aperture shapes).
                    let v = self.column_x(sen, a, g, s);
                    let hit = (0..parities).any(|par| {
                        (0..2).any(|h| v.w[par][h].abs() < r && v.x[par][h].abs() <= bx)
                    });
                    if hit {
                        out.push(a as u32);
                        colx.push(v);
                    }
                }
            }
        }
        Ok(())
    }

    /// Rows whose samples can satisfy |Y| ≤ by (as [`Tables::candidate_columns`]).
    pub(super) fn candidate_rows(&self, g: f64, s: f64, by: f64, out: &mut Vec<u32>) {
        out.clear();
        match &self.px {
            PixelTables::Ideal { w, .. } => {
                let mut b = 0u32;
                for k in 0..self.ch.ky as usize {
                    for &wy in w.iter() {
                        if (-g * (self.cy[k] + wy * s)).abs() <= by {
                            out.push(b);
                        }
                        b += 1;
                    }
                }
            }
            PixelTables::Sensor(sen) => {
                let r = self.design.aperture / 2.0;
                for b in self.sensor_range(&sen.sy, g, s, by) {
                    // The rows dropped by Tables::row never hold the pixel's lens.
                    let rc = self.row(sen, sen.sy[b], g, s);
                    let hit = (0..rc.n).any(|i| rc.w[i].abs() < r && rc.y[i].abs() <= by);
                    if hit {
                        out.push(b as u32);
                    }
                }
            }
        }
    }

    /// Append the lit samples of columns `cols` (their [`ColumnX`] in `colx`, in the same
    /// order) of one sensor row (`N` = `rc.n` candidate lens rows) that `keep` accepts to
    /// `out` (capacity reserved by the caller).
    #[inline(always)]
    pub(super) fn gather_row<const N: usize, const HEX: bool, const CIRCLE: bool>(
        &self,
        sen: &Sensor,
        rc: &RowCandidates,
        cols: &[u32],
        colx: &[ColumnX],
        keep: &impl Fn([f64; 2]) -> bool,
        out: &mut Vec<[f64; 2]>,
    ) {
        for (&a, cx) in cols.iter().zip(colx) {
            let px = self.sensor_pixel::<N, HEX, CIRCLE>(sen, &sen.cols[a as usize], cx, rc);
            if px.lit && keep(px.xy) {
                out.push(px.xy);
            }
        }
    }

    /// Append the lit samples with |X| ≤ bx and |Y| ≤ by to `out` (a check for Ctrl-C
    /// every [`CHECK_EVERY_ROWS`] rows: a window of the Illum gathers millions).
    pub(super) fn gather(
        &self,
        g: f64,
        s: f64,
        bounds: [f64; 2],
        idx: &mut (Vec<u32>, Vec<u32>, Vec<ColumnX>),
        out: &mut Vec<[f64; 2]>,
    ) -> Result<()> {
        let [bx, by] = bounds;
        let (cols, rows, colx) = idx;
        self.candidate_columns(g, s, bx, cols, colx)?;
        self.candidate_rows(g, s, by, rows);
        try_reserve(
            out,
            "coverage (samples near the field)",
            out.len() + cols.len() * rows.len(),
        )?;
        let keep = |xy: [f64; 2]| xy[0].abs() <= bx && xy[1].abs() <= by;
        match &self.px {
            PixelTables::Ideal { q, w } => {
                let q = *q as usize;
                for (i, &b) in rows.iter().enumerate() {
                    if i % CHECK_EVERY_ROWS == 0 {
                        crate::infra::parallel::checkpoint()?;
                    }
                    let (k, qy) = (b as usize / q, b as usize % q);
                    for &a in cols.iter() {
                        let (j, qx) = (a as usize / q, a as usize % q);
                        let pw = [w[qx], w[qy]];
                        if self.design.passes(pw) {
                            let px = Px {
                                j: j as u32,
                                k: k as u32,
                                par: 0,
                                w: pw,
                                lit: true,
                            };
                            let xy = self.sample(&px, g, s);
                            if keep(xy) {
                                out.push(xy);
                            }
                        }
                    }
                }
            }
            PixelTables::Sensor(sen) => {
                for (i, &b) in rows.iter().enumerate() {
                    if i % CHECK_EVERY_ROWS == 0 {
                        crate::infra::parallel::checkpoint()?;
                    }
                    let rc = self.row(sen, sen.sy[b as usize], g, s);
                    dispatch!(self, rc, gather_row(sen, &rc, cols, colx, &keep, out));
                }
            }
        }
        Ok(())
    }
}
