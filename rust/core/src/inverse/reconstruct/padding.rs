//! A reconstruction's padding ([`Plan::pad`]): the cells within a pixel's span beyond the
//! region, solved for and cropped so that every pixel that sees the region is explained;
//! on a tilted plane clipped where it would come nearer than [`PAD_NEAREST`] F.

use crate::imaging::scene::Surface;
use crate::infra::error::Result;
use crate::inverse::system::{self, CellGrid};

use super::Plan;

/// A padded tilted plane reaches at least this many times F deep: where the padding would
/// come nearer, it is clipped ([`Plan::clip`]). A tenth of F beyond the model's own limit
/// (depths > F, docs/model.md) leaves room for the grid's rounding and keeps the padded
/// cells' pixel spans (finite at F) from growing with the clip.
pub const PAD_NEAREST: f64 = 1.1;

/// The padded grid around a region: the grid and its padding in cells (left, right,
/// bottom, top).
pub(super) struct Padded {
    pub(super) grid: CellGrid,
    pub(super) sides: [usize; 4],
}

impl Padded {
    /// The grid of `inner`'s cells padded by `sides` cells (left, right, bottom, top).
    pub(super) fn around(inner: &CellGrid, sides: [usize; 4]) -> Result<Padded> {
        let h = inner.step;
        let [l, r, b, t] = sides.map(|v| v as f64 * h);
        let [x0, x1, y0, y1] = inner.extent();
        let grid = CellGrid::covering([x0 - l, x1 + r, y0 - b, y1 + t], h)?;
        Ok(Padded { grid, sides })
    }

    /// The widest padding (cells).
    pub(super) fn most(&self) -> usize {
        self.sides.iter().copied().max().unwrap_or(0)
    }
}

impl Plan<'_> {
    /// The padding (cells) of the grid: the widest pixel span over the surface's depths
    /// there (twice: the padded region's depth range can be wider), and the padded grid.
    /// A tilted plane's padding is clipped where the plane comes nearer than
    /// [`PAD_NEAREST`] F ([`Plan::clip`]); the region itself must be deeper than F.
    pub(super) fn pad(&self, inner: &CellGrid) -> Result<Padded> {
        let h = inner.step;
        let e = inner.extent();
        let (zlo, _) = self.depths(e);
        self.deeper_than_f(zlo, "least depth over the region", "")?;
        let mut padded = Padded::around(inner, [0; 4])?;
        for _ in 0..2 {
            let (zlo, zhi) = self.depths(padded.grid.extent());
            self.deeper_than_f(zlo, "least depth over the padded region", "")?;
            let span = |z| system::pixel_span(self.req.design, &self.req.channels, z);
            let pad = (span(zlo)?.max(span(zhi)?) / h).ceil() as usize;
            padded = Padded::around(inner, self.clip(inner, pad))?;
        }
        Ok(padded)
    }

    /// The padding (cells: left, right, bottom, top) of `pad` cells per side, clipped on
    /// the sides toward which a tilted plane comes nearer, so that the padded grid stays
    /// at least [`PAD_NEAREST`] F deep (the region's own cells are never clipped: a region
    /// between F and that depth gets no padding on those sides). The rows of pixels that
    /// would see beyond the clipped grid are dropped as for any pixel seeing off the grid.
    fn clip(&self, inner: &CellGrid, pad: usize) -> [usize; 4] {
        let Surface::Plane { g, .. } = &self.surface else {
            return [pad; 4];
        };
        let (zi, _) = self.depths(inner.extent());
        let reach = (g[0].abs() + g[1].abs()) * inner.step;
        let nearest = PAD_NEAREST * self.req.design.f_main;
        if reach == 0.0 || zi - pad as f64 * reach >= nearest {
            return [pad; 4];
        }
        // Cells of padding toward the nearer sides: the corner there drops by `reach` per
        // cell (one cell of slack for the rounding).
        let keep = ((zi - nearest) / reach - 1.0)
            .floor()
            .clamp(0.0, pad as f64) as usize;
        let side = |gi: f64, toward_low: bool| {
            if gi == 0.0 || (gi > 0.0) != toward_low {
                pad
            } else {
                keep
            }
        };
        [
            side(g[0], true),
            side(g[0], false),
            side(g[1], true),
            side(g[1], false),
        ]
    }
}
