//! A checked uniform grid of samples over a rectangle: the shape that an image texture
//! ([`crate::imaging::texture`]) and a depth map ([`crate::imaging::scene`]) share, and
//! its validation, written once.

use crate::infra::error::{Error, Result};

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
