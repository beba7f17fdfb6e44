//! Micro-image centres: where the main lens's centre is imaged through each microlens onto
//! the sensor, in the pixel coordinates of the channel's raw (docs/model.md §9, §10). This
//! is what a light field decoder calibrates from a white image.
//!
//! The ray through the centre of the main lens (w = 0) and the centre c of lens (j, k)
//! continues undeviated (it passes the lens's own centre) and meets the sensor, v behind
//! the array, at s = c (1 + v/L): the lens's image centre of §9 (§10's s = α x − (v/L) w +
//! (v/f) c with w = 0 and x = c gives the same for every focal length). In the raw's
//! coordinates (row, column; row 0 at the top, pixel (r, c) centred on the integers):
//! `sensor` layout column s_x/μ + (M_x − 1)/2 and row s_y/μ + (M_y − 1)/2 (§9, "Pixel
//! layouts"); `ideal` layout, whose Q × Q pixels are centred on the lens's image, column
//! j Q + (Q − 1)/2 and row k Q + (Q − 1)/2 (§10, "Raw layout").

use crate::model::design::{Channel, Grid, Layout, SQRT3_2};

/// One lens's micro-image centre in raw pixel coordinates, with the lens's indices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MicroImageCenter {
    /// Row coordinate (sub-pixel; row 0 at the top, pixel centres on the integers).
    pub row: f64,
    /// Column coordinate (sub-pixel; column 0 at the left).
    pub col: f64,
    /// The lens's row index k in the lattice (0 … K_y − 1).
    pub k: u32,
    /// The lens's column index j in the lattice (0 … K_x − 1).
    pub j: u32,
}

impl Channel {
    /// The micro-image centre of lens (j, k) in raw pixel coordinates (module docs).
    pub fn micro_image_center(&self, j: u32, k: u32) -> MicroImageCenter {
        let (row, col) = match self.layout {
            Layout::Ideal { q } => {
                let half = (q as f64 - 1.0) / 2.0;
                (k as f64 * q as f64 + half, j as f64 * q as f64 + half)
            }
            Layout::Sensor { mx, my } => {
                let c = self.lens_center(j, k);
                let m = self.magnification();
                (
                    c[1] * m / self.mu + (my as f64 - 1.0) / 2.0,
                    c[0] * m / self.mu + (mx as f64 - 1.0) / 2.0,
                )
            }
        };
        MicroImageCenter { row, col, k, j }
    }

    /// The lattice's steps between micro-image centres in raw pixels, (row step, column
    /// step): the column step between neighbours in a row and the row step between lattice
    /// rows (module docs: Q and Q in the ideal layout; p/μ and p/μ on a rect grid and
    /// (√3/2) p/μ and p/μ on a hex one in the sensor layout, p = d (1 + v/L) the image
    /// pitch). Defined for any lattice, one lens wide or one row high included.
    pub fn micro_image_steps(&self) -> (f64, f64) {
        match self.layout {
            Layout::Ideal { q } => (q as f64, q as f64),
            Layout::Sensor { .. } => {
                let col = self.image_pitch() / self.mu;
                match self.grid {
                    Grid::Rect => (col, col),
                    Grid::Hex => (col * SQRT3_2, col),
                }
            }
        }
    }

    /// Every lens's micro-image centre, row by row of the lattice (k, then j ascending).
    pub fn micro_image_centers(&self) -> Vec<MicroImageCenter> {
        (0..self.ky)
            .flat_map(|k| (0..self.kx).map(move |j| (j, k)))
            .map(|(j, k)| self.micro_image_center(j, k))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::model::presets::preset;

    #[test]
    fn the_centre_ray_lands_on_the_image_centre_in_pixels() {
        // lytro-illum: hex, sensor layout. The middle of the lattice's mean lies on the
        // sensor's centre pixel coordinate; neighbours are one image pitch apart.
        let d = preset("lytro-illum").unwrap();
        let ch = &d.channels[0];
        let p = ch.image_pitch() / ch.mu;
        let a = ch.micro_image_center(10, 10);
        let b = ch.micro_image_center(11, 10);
        let c = ch.micro_image_center(10, 11);
        assert!((b.col - a.col - p).abs() < 1e-9 && (b.row - a.row).abs() < 1e-12);
        // odd row: shifted half a pitch to +x, √3/2 pitch down
        assert!((c.col - a.col - p / 2.0).abs() < 1e-9);
        assert!((c.row - a.row - p * 3f64.sqrt() / 2.0).abs() < 1e-9);
        let (rs, cs) = ch.micro_image_steps();
        assert!((cs - p).abs() < 1e-12 && (c.row - a.row - rs).abs() < 1e-9);
        let all = ch.micro_image_centers();
        assert_eq!(all.len(), (ch.kx * ch.ky) as usize);
        let n = all.len() as f64;
        let (mr, mc) = all
            .iter()
            .fold((0.0, 0.0), |(r, c), m| (r + m.row / n, c + m.col / n));
        assert!((mr - (5368.0 - 1.0) / 2.0).abs() < 1e-6, "{mr}");
        assert!((mc - (7728.0 - 1.0) / 2.0).abs() < 1e-6, "{mc}");
    }

    #[test]
    fn the_ideal_layout_centres_each_block() {
        let d = preset("seed").unwrap();
        let ch = &d.channels[1];
        let crate::model::design::Layout::Ideal { q } = ch.layout else {
            panic!("the seed's halves have the ideal layout")
        };
        let (q, half) = (q as f64, (q as f64 - 1.0) / 2.0);
        let m = ch.micro_image_center(3, 2);
        assert_eq!(
            (m.row, m.col, m.k, m.j),
            (2.0 * q + half, 3.0 * q + half, 2, 3)
        );
    }
}
