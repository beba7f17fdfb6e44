//! The reconstruction's cell grid, the map's rows, and the recorder that builds a row from
//! the forward model's integration (docs/model.md §11, docs/reconstruct.md). Kept apart
//! from [`crate::inverse::system`] (which builds maps from [`crate::imaging::render`]) so that the renderer
//! can hold a recorder without the two modules depending on each other.

use crate::infra::csr::Csr;
use crate::infra::error::{Error, Result};
use crate::infra::memory;
use crate::infra::polygon::{area_above, bounds, centroid, clip_into, signed_area, Pt};

/// A uniform grid of square cells over [x0, x0 + nx h] × [y1 − ny h, y1]; cell (r, c) (row
/// r from the top, column c from the left, like a texture) is unknown r nx + c.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellGrid {
    pub x0: f64,
    pub y1: f64,
    pub step: f64,
    pub nx: usize,
    pub ny: usize,
}

impl CellGrid {
    /// The grid of pitch `step` covering `extent` = [X0, X1, Y0, Y1] (the extent rounded
    /// out to whole cells, centred on the asked one).
    pub fn covering(extent: [f64; 4], step: f64) -> Result<CellGrid> {
        if !(step.is_finite() && step > 0.0) {
            return Err(Error::param("step", step, "a finite value > 0 (mm)"));
        }
        let [x0, x1, y0, y1] = extent;
        if !(extent.iter().all(|v| v.is_finite()) && x1 > x0 && y1 > y0) {
            return Err(Error::param(
                "region",
                format!("({x0}, {x1}, {y0}, {y1})"),
                "finite (X0, X1, Y0, Y1) with X0 < X1 and Y0 < Y1 (mm)",
            ));
        }
        let cells = |a: f64, b: f64| ((b - a) / step * (1.0 - 1e-12)).ceil().max(1.0);
        let (fx, fy) = (cells(x0, x1), cells(y0, y1));
        if fx * fy > 1e12 {
            return Err(Error::param(
                "step",
                step,
                "a pitch giving fewer than 1e12 cells over the region",
            ));
        }
        let (nx, ny) = (fx as usize, fy as usize);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        Ok(CellGrid {
            x0: cx - 0.5 * nx as f64 * step,
            y1: cy + 0.5 * ny as f64 * step,
            step,
            nx,
            ny,
        })
    }

    /// [X0, X1, Y0, Y1] of the grid.
    pub fn extent(&self) -> [f64; 4] {
        [
            self.x0,
            self.x0 + self.nx as f64 * self.step,
            self.y1 - self.ny as f64 * self.step,
            self.y1,
        ]
    }

    pub fn cells(&self) -> usize {
        self.nx * self.ny
    }
}

/// A pixel's row is kept when at most this share of its ray measure falls outside the
/// grid (its value must be explained by the grid's cells alone).
pub const OUTSIDE_SHARE: f64 = 1e-9;

/// The map, one row per kept pixel: per row the channel (from 0) and the pixel's flat
/// index b · cols + a in its raw, and the rows over the grid's cells.
#[derive(Debug, Clone)]
pub struct System {
    pub channel: Vec<u32>,
    pub pixel: Vec<u64>,
    pub rows: Csr,
}

/// Row chunks handed in by parallel workers, each tagged with its first raw row.
#[derive(Default)]
pub(crate) struct Chunks(std::sync::Mutex<Vec<(usize, Vec<System>)>>);

impl Chunks {
    pub(crate) fn push(&self, start: usize, chunk: Vec<System>) {
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push((start, chunk));
    }
}

impl System {
    /// A map of no rows over `cells` cells, to be built row by row (entries pushed on
    /// `rows`, then [`System::end_row`]).
    pub fn new(cells: usize) -> System {
        System {
            channel: Vec::new(),
            pixel: Vec::new(),
            rows: Csr::empty(cells),
        }
    }

    /// Close the row being written: pixel `pixel` (flat index) of channel `channel`.
    pub(crate) fn end_row(&mut self, channel: usize, pixel: usize) {
        self.channel.push(channel as u32);
        self.pixel.push(pixel as u64);
        self.rows.end_row();
    }

    /// Append the row chunks in raw-row order.
    pub(crate) fn append_chunks(&mut self, parts: Chunks) {
        let mut parts = parts
            .0
            .into_inner()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        parts.sort_by_key(|p| p.0);
        for (_, chunk) in parts {
            for s in chunk {
                self.channel.extend_from_slice(&s.channel);
                self.pixel.extend_from_slice(&s.pixel);
                self.rows.append(&s.rows);
            }
        }
    }
}

/// The recorder that turns the forward model's integration into a row of the map: where the
/// render averages the texture over a node's polygon image on the surface, the recorder
/// adds the node's weight to each grid cell in proportion to the image's area inside it
/// (the image of a polygon under the ray map, clipped by the cell: exact for cell-constant
/// albedo); the adaptive rule is replaced by a fixed one (the renderer's `fixed_rule`), since its
/// decisions must not depend on one texture's values. Rays outside the grid (or missing
/// the surface) add to `outside`.
pub(crate) struct Recorder {
    grid: CellGrid,
    vals: Vec<f64>,
    mark: Vec<bool>,
    touched: Vec<u32>,
    pub(crate) outside: f64,
    pub(crate) total: f64,
    /// The current node's weight: channel norm × the outer variable's Jacobian (outer s:
    /// (L/v)²) × the circle parametrisation's Jacobian × the quadrature weight.
    pub(crate) norm: f64,
    pub(crate) outer: f64,
    pub(crate) jac: f64,
    pub(crate) node: f64,
    strip: Vec<Pt>,
    tmp: Vec<Pt>,
}

impl Recorder {
    pub(crate) fn new(grid: CellGrid) -> Result<Recorder> {
        let n = grid.cells();
        Ok(Recorder {
            grid,
            vals: memory::try_vec("a map row's accumulator", n, 0.0)?,
            mark: memory::try_vec("a map row's accumulator", n, false)?,
            touched: Vec::new(),
            outside: 0.0,
            total: 0.0,
            norm: 1.0,
            outer: 1.0,
            jac: 1.0,
            node: 1.0,
            strip: Vec::new(),
            tmp: Vec::new(),
        })
    }

    fn weight(&self, area: f64) -> f64 {
        self.norm * self.outer * self.jac * self.node * area
    }

    #[inline]
    fn put(&mut self, k: usize, w: f64) {
        if !self.mark[k] {
            self.mark[k] = true;
            self.touched.push(k as u32);
        }
        self.vals[k] += w;
    }

    /// The cell holding point p, if on the grid.
    fn cell_of(&self, p: Pt) -> Option<usize> {
        let g = &self.grid;
        let c = ((p[0] - g.x0) / g.step).floor();
        let r = ((g.y1 - p[1]) / g.step).floor();
        (c >= 0.0 && r >= 0.0 && c < g.nx as f64 && r < g.ny as f64)
            .then(|| r as usize * g.nx + c as usize)
    }

    /// A node's polygon of ray measure `area` whose image on the surface is `mapped`.
    pub(crate) fn add(&mut self, mapped: &[Pt], area: f64) {
        let w = self.weight(area);
        if w == 0.0 {
            return;
        }
        let am = signed_area(mapped);
        let (x0, x1, y0, y1) = bounds(mapped);
        let scale = (x1 - x0).max(y1 - y0);
        if am.abs() <= 1e-12 * scale * scale || !am.is_finite() {
            // A point image (the pixel in focus on the surface): the centroid's cell.
            self.total += w;
            match self.cell_of(centroid(mapped)) {
                Some(k) => self.put(k, w),
                None => self.outside += w,
            }
            return;
        }
        self.total += w;
        let g = self.grid;
        let h = g.step;
        let [gx0, gx1, gy0, gy1] = g.extent();
        if x1 <= gx0 || x0 >= gx1 || y1 <= gy0 || y0 >= gy1 {
            self.outside += w;
            return;
        }
        let col = |x: f64| (((x - gx0) / h).floor().max(0.0) as usize).min(g.nx - 1);
        let row = |y: f64| (((gy1 - y) / h).floor().max(0.0) as usize).min(g.ny - 1);
        let (c0, c1, r0, r1) = (col(x0), col(x1), row(y1), row(y0));
        let inside_grid = x0 >= gx0 && x1 <= gx1 && y0 >= gy0 && y1 <= gy1;
        if c0 == c1 && r0 == r1 && inside_grid {
            self.put(r0 * g.nx + c0, w);
            return;
        }
        let mut share = 0.0;
        for c in c0..=c1 {
            let (sx0, sx1) = (gx0 + c as f64 * h, gx0 + (c + 1) as f64 * h);
            self.strip.clear();
            self.strip.extend_from_slice(mapped);
            if c0 != c1 || x0 < gx0 || x1 > gx1 {
                clip_into(&self.strip, &mut self.tmp, |p| p[0] - sx0);
                clip_into(&self.tmp, &mut self.strip, |p| sx1 - p[0]);
            }
            if self.strip.len() < 3 {
                continue;
            }
            let (_, _, sy0, sy1) = bounds(&self.strip);
            if sy1 <= gy0 || sy0 >= gy1 {
                continue;
            }
            // Down the strip: a cell's area is the difference of the strip's areas above
            // its two row lines (one half-plane pass per line, no polygon built).
            let (ra, rb) = (row(sy1), row(sy0));
            let mut above = area_above(&self.strip, gy1 - ra as f64 * h, sx0);
            for r in ra..=rb {
                let next = area_above(&self.strip, gy1 - (r + 1) as f64 * h, sx0);
                let a = (next - above) / am;
                above = next;
                if a > 0.0 {
                    share += a;
                    self.put(r * g.nx + c, w * a);
                }
            }
        }
        self.outside += w * (1.0 - share).max(0.0);
    }

    /// The grid the rows are over.
    pub(crate) fn grid(&self) -> &CellGrid {
        &self.grid
    }

    /// Ray measure `w` (normalised) on cell (col, row) of the grid's lattice, which may lie
    /// outside the grid (then it adds to `outside`).
    pub(crate) fn add_cell(&mut self, col: i64, row: i64, w: f64) {
        self.total += w;
        let g = self.grid;
        if col >= 0 && row >= 0 && (col as usize) < g.nx && (row as usize) < g.ny {
            self.put(row as usize * g.nx + col as usize, w);
        } else {
            self.outside += w;
        }
    }

    /// The row cannot be kept (rays may fall outside the grid).
    pub(crate) fn lose(&mut self) {
        self.outside = f64::INFINITY;
    }

    /// Has the row been found not to be kept?
    pub(crate) fn lost(&self) -> bool {
        self.outside == f64::INFINITY
    }

    /// A node's piece of ray measure `area` seen as one surface point p.
    pub(crate) fn add_point(&mut self, p: Pt, area: f64) {
        let w = self.weight(area);
        self.total += w;
        match self.cell_of(p) {
            Some(k) => self.put(k, w),
            None => self.outside += w,
        }
    }

    /// A node's piece of ray measure `area` that misses the surface.
    pub(crate) fn add_background(&mut self, area: f64) {
        let w = self.weight(area);
        self.total += w;
        self.outside += w;
    }

    pub(crate) fn reset(&mut self, norm: f64) {
        for &k in &self.touched {
            self.vals[k as usize] = 0.0;
            self.mark[k as usize] = false;
        }
        self.touched.clear();
        (self.outside, self.total, self.norm) = (0.0, 0.0, norm);
    }

    /// The recorded row (sorted cells, values) into `s`, when the pixel is lit and sees
    /// only the grid; whether it was kept.
    pub(crate) fn take(&mut self, s: &mut System) -> bool {
        let inside = self.total - self.outside;
        if !(self.total > 0.0 && inside > 0.0 && self.outside <= OUTSIDE_SHARE * self.total) {
            return false;
        }
        self.touched.sort_unstable();
        for &k in &self.touched {
            let v = self.vals[k as usize];
            if v != 0.0 {
                s.rows.indices.push(k);
                s.rows.data.push(v);
            }
        }
        true
    }
}
