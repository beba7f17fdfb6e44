//! A checked uniform grid of samples over a rectangle: the shape that an image texture
//! ([`crate::imaging::texture`]) and a depth map ([`crate::imaging::scene`]) share, and
//! its validation, written once; and the walk of a segment over its cells, which the
//! texture's edge integrals and the render's summed-area closed form share.

use crate::infra::error::{Error, Result};
use crate::infra::polygon::Pt;

/// `rows` × `cols` uniform cells of hx × hy over [x0, x1] × [y0, y1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleGrid {
    pub x0: f64,
    pub x1: f64,
    pub y0: f64,
    pub y1: f64,
    pub rows: usize,
    pub cols: usize,
    pub hx: f64,
    pub hy: f64,
}

impl SampleGrid {
    /// The grid of `rows` × `cols` samples over `extent` = [X0, X1, Y0, Y1], checked: at
    /// least one and at most `max` samples (else an error on parameter `name`, counting
    /// `unit`s), and a finite extent with X0 < X1 and Y0 < Y1 of finite widths.
    pub fn new(
        name: &'static str,
        (rows, cols): (usize, usize),
        extent: [f64; 4],
        (max, unit): (usize, &str),
    ) -> Result<SampleGrid> {
        if rows == 0 || cols == 0 || rows.saturating_mul(cols) > max {
            return Err(Error::param(
                name,
                format!("{rows} x {cols}"),
                format!("a non-empty 2-D array of at most {max} {unit}"),
            ));
        }
        let [x0, x1, y0, y1] = extent;
        if !(extent.iter().all(|v| v.is_finite())
            && x1 > x0
            && y1 > y0
            && (x1 - x0).is_finite()
            && (y1 - y0).is_finite())
        {
            return Err(Error::param(
                "extent",
                format!("({x0}, {x1}, {y0}, {y1})"),
                "finite X0 < X1 and Y0 < Y1 (mm)",
            ));
        }
        Ok(SampleGrid {
            x0,
            x1,
            y0,
            y1,
            rows,
            cols,
            hx: (x1 - x0) / cols as f64,
            hy: (y1 - y0) / rows as f64,
        })
    }

    /// [X0, X1, Y0, Y1].
    pub fn extent(&self) -> [f64; 4] {
        [self.x0, self.x1, self.y0, self.y1]
    }

    /// The grid's lines along X and along Y, for [`walk`].
    pub(crate) fn lines(&self) -> (Lines, Lines) {
        (
            Lines {
                origin: self.x0,
                step: self.hx,
                cells: self.cols,
            },
            Lines {
                origin: self.y0,
                step: self.hy,
                cells: self.rows,
            },
        )
    }
}

/// One axis of a grid of uniform cells: its first line, the step between lines and the
/// cells between them (lines 0..=cells).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lines {
    pub origin: f64,
    pub step: f64,
    pub cells: usize,
}

/// The cells the segment a → b crosses on the grid of lines `x` × `y`, in order along it
/// (a digital differential analyser; the region beyond the grid is one more column or row
/// on each side: −1 and `cells`): `piece(c, r, t0, t1)` for each piece of the segment's
/// parameter t ∈ [0, 1] inside cell (c, r), bottom-up row r, with t1 > t0. A cell is the
/// one of its piece's points up to rounding at the lines.
pub(crate) fn walk(x: Lines, y: Lines, a: Pt, b: Pt, mut piece: impl FnMut(i64, i64, f64, f64)) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    // Cell of a point, and the parameter t of the next line crossed along the step's
    // direction: line k + 1 going up, k going down (lines 0..=n).
    let cell = |u: f64, n: i64| -> i64 {
        if u >= 0.0 {
            (u.min(n as f64) as i64).min(n)
        } else {
            -1
        }
    };
    let next_t = |k: i64, step: i64, l: Lines, a: f64, d: f64| -> f64 {
        let line = if step > 0 { k + 1 } else { k };
        if d == 0.0 || line < 0 || line > l.cells as i64 {
            f64::INFINITY
        } else {
            (l.origin + line as f64 * l.step - a) / d
        }
    };
    let mut c = cell((a[0] - x.origin) / x.step, x.cells as i64);
    let mut r = cell((a[1] - y.origin) / y.step, y.cells as i64);
    let (sx, sy) = (if dx > 0.0 { 1 } else { -1 }, if dy > 0.0 { 1 } else { -1 });
    let mut tx = next_t(c, sx, x, a[0], dx);
    let mut ty = next_t(r, sy, y, a[1], dy);
    let mut t0 = 0.0f64;
    loop {
        let t1 = tx.min(ty).clamp(t0, 1.0);
        if t1 > t0 {
            piece(c, r, t0, t1);
        }
        if t1 >= 1.0 {
            break;
        }
        t0 = t1;
        if tx <= ty {
            c += sx;
            tx = next_t(c, sx, x, a[0], dx);
        } else {
            r += sy;
            ty = next_t(r, sy, y, a[1], dy);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_holds_its_cells_and_refuses_a_bad_shape_or_extent() {
        let g = SampleGrid::new("m", (2, 4), [-1.0, 1.0, 0.0, 3.0], (8, "cells")).unwrap();
        assert_eq!((g.rows, g.cols, g.hx, g.hy), (2, 4, 0.5, 1.5));
        assert_eq!(g.extent(), [-1.0, 1.0, 0.0, 3.0]);
        for shape in [(0, 4), (3, 0), (3, 3)] {
            let e = SampleGrid::new("m", shape, [0.0, 1.0, 0.0, 1.0], (8, "cells"));
            assert!(format!("{:?}", e.unwrap_err()).contains("at most 8 cells"));
        }
        let huge = f64::MAX;
        for ext in [
            [0.0, f64::NAN, 0.0, 1.0],
            [1.0, 1.0, 0.0, 1.0],
            [0.0, 1.0, 2.0, 1.0],
            [-huge, huge, 0.0, 1.0],
        ] {
            let e = SampleGrid::new("m", (2, 2), ext, (8, "cells"));
            assert!(
                format!("{:?}", e.unwrap_err()).contains("extent"),
                "{ext:?}"
            );
        }
    }
}
