//! General plenoptic architectures (docs/model.md §9): a main lens and one or more
//! channels, each a microlens array with its own sensor region reached by a share of the
//! light. The seed's split sensor is a two-channel design (`Camera::design`); a
//! plain light field camera is one channel; Raytrix-style multi-focus arrays are one
//! hexagonal channel with several lens types.
//!
//! This module holds the validated design and its geometry on the sensor: lens centres
//! on both lattices, the lens-type pattern, the pixel layouts (ideal: Q × Q per lens;
//! sensor: one uniform pixel grid, each pixel belonging to the lens whose image is
//! nearest), which pixels are lit (square or circular aperture) and each pixel's 2-D chief
//! sample on a plane at depth z. All lengths in mm.

use crate::infra::error::{Error, Result};
use crate::model::lens::{
    conjugate, count, derived, ng_focal_length, positive as length, MAX_K, MAX_Q,
};

/// Most channels a design may have.
pub const MAX_CHANNELS: usize = 64;
/// Most lens types (distinct microlens focal lengths) a channel may have.
pub const MAX_TYPES: usize = 64;
/// Most sensor pixels along one axis of a channel's sensor layout.
pub const MAX_M: u64 = 10_000_000;
/// Relative slack of the rule "shares sum to at most 1" (three shares of 1/3 sum to
/// 1.0000000000000002 in floating point).
pub const SHARE_RTOL: f64 = 1e-12;

/// √3/2, the row spacing of the hex lattice in pitches (shared with `samples2d`, which
/// replicates the nearest-lens rule bit for bit).
pub(crate) const SQRT3_2: f64 = 0.866_025_403_784_438_6;

/// The microlens lattice of a channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Grid {
    /// Lens (j, k) at d (j − (K_x−1)/2, k − (K_y−1)/2).
    Rect,
    /// Flat rows along x, odd rows shifted by half a pitch, row spacing d √3/2, centred.
    Hex,
}

impl Grid {
    pub fn from_name(name: &str) -> Result<Grid> {
        match name {
            "rect" => Ok(Grid::Rect),
            "hex" => Ok(Grid::Hex),
            _ => Err(Error::param(
                "grid",
                format!("{name:?}"),
                "\"rect\" or \"hex\"",
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Grid::Rect => "rect",
            Grid::Hex => "hex",
        }
    }
}

/// The shape of the main-lens aperture of width D.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Aperture {
    /// |w_x|, |w_y| < D/2 (the paper's).
    Square,
    /// |w| < D/2.
    Circle,
}

impl Aperture {
    pub fn from_name(name: &str) -> Result<Aperture> {
        match name {
            "square" => Ok(Aperture::Square),
            "circle" => Ok(Aperture::Circle),
            _ => Err(Error::param(
                "aperture",
                format!("{name:?}"),
                "\"square\" or \"circle\"",
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Aperture::Square => "square",
            Aperture::Circle => "circle",
        }
    }

    /// Is the main-lens point w strictly inside the aperture of width `d_main`?
    #[inline]
    pub fn contains(self, d_main: f64, w: [f64; 2]) -> bool {
        let r = d_main / 2.0;
        match self {
            Aperture::Square => w[0].abs() < r && w[1].abs() < r,
            Aperture::Circle => w[0] * w[0] + w[1] * w[1] < r * r,
        }
    }
}

/// Where a channel's pixels are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layout {
    /// Q × Q pixels per lens centred on its image (the paper's; rect grids only).
    Ideal { q: u32 },
    /// A uniform grid of M_x × M_y pixels centred on the axis.
    Sensor { mx: u32, my: u32 },
}

impl Layout {
    pub fn name(self) -> &'static str {
        match self {
            Layout::Ideal { .. } => "ideal",
            Layout::Sensor { .. } => "sensor",
        }
    }
}

/// A channel's fields as given (before validation); `f = None` is Ng's setting,
/// `layout` is `"ideal"` (needs `q`) or `"sensor"` (`mx`, `my` default to the smallest
/// grid covering every image cell).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelSpec {
    pub l: f64,
    pub d: f64,
    pub v: f64,
    pub mu: f64,
    pub kx: i64,
    pub ky: i64,
    pub grid: Grid,
    pub f: Option<Vec<f64>>,
    pub layout: String,
    pub q: Option<i64>,
    pub mx: Option<i64>,
    pub my: Option<i64>,
    pub share: f64,
}

/// A validated channel: one microlens array and the sensor region behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// L, optical path from the main lens to the array (> F).
    pub l: f64,
    /// d, microlens pitch.
    pub d: f64,
    /// v, array to sensor.
    pub v: f64,
    /// μ, pixel pitch.
    pub mu: f64,
    pub kx: u32,
    pub ky: u32,
    pub grid: Grid,
    /// f_1 … f_T, the focal lengths of the lens types (Ng's setting: one type).
    pub f: Vec<f64>,
    /// True when f was not given: every lens in Ng's setting 1/f = 1/L + 1/v.
    pub ng: bool,
    pub layout: Layout,
    /// Fraction of the main lens's light that reaches this channel.
    pub share: f64,
}

/// Number of distinct values of the lens-type index before `mod T` over the lattice: the
/// pattern uses every type iff T is at most this.
fn type_span(grid: Grid, kx: u32, ky: u32) -> u64 {
    match grid {
        // (j + k) over j < K_x, k < K_y: 0 ..= K_x + K_y − 2.
        Grid::Rect => kx as u64 + ky as u64 - 1,
        // j − ⌊k/2⌋ − k: row k spans [−⌊k/2⌋ − k, K_x − 1 − ⌊k/2⌋ − k]; successive rows
        // shift by 1 or 2, so the union is contiguous when K_x ≥ 2.
        Grid::Hex => {
            let last = ky as u64 - 1;
            let shift = last / 2 + last;
            if kx >= 2 {
                kx as u64 + shift
            } else {
                // One lens per row: the values −⌊k/2⌋ − k, all distinct.
                ky as u64
            }
        }
    }
}

impl Channel {
    /// Validate one channel behind a main lens of focal length `f_main`.
    pub fn new(spec: &ChannelSpec, f_main: f64) -> Result<Channel> {
        let l = spec.l;
        if !(l.is_finite() && l > f_main) {
            return Err(Error::param(
                "L",
                l,
                format!(
                    "a finite length > F = {f_main} mm (the array must lie behind the focal plane)"
                ),
            ));
        }
        let d = length("d", spec.d)?;
        let v = length("v", spec.v)?;
        let mu = length("mu", spec.mu)?;
        let kx = count("Kx", spec.kx, MAX_K)?;
        let ky = count("Ky", spec.ky, MAX_K)?;
        let share = spec.share;
        if !(share.is_finite() && share > 0.0 && share <= 1.0) {
            return Err(Error::param("share", share, "a number in (0, 1]"));
        }
        let layout = Self::layout(spec, kx, ky)?;
        let (f, ng) = match &spec.f {
            None => (vec![ng_focal_length(l, v)], true),
            Some(fs) => {
                if fs.is_empty() || fs.len() > MAX_TYPES {
                    return Err(Error::param(
                        "f",
                        format!("a list of {} focal lengths", fs.len()),
                        format!("None (Ng's setting) or 1 to {MAX_TYPES} focal lengths > 0 mm"),
                    ));
                }
                for &x in fs {
                    length("f", x)?;
                }
                (fs.clone(), false)
            }
        };
        let ch = Channel {
            l,
            d,
            v,
            mu,
            kx,
            ky,
            grid: spec.grid,
            f,
            ng,
            layout,
            share,
        };
        ch.check_types()?;
        ch.check_derived()?;
        let layout = match (spec.layout.as_str(), layout) {
            ("sensor", Layout::Sensor { .. }) if spec.mx.is_none() || spec.my.is_none() => {
                let (mx, my) = ch.covering_sensor()?;
                Layout::Sensor {
                    mx: spec.mx.map_or(Ok(mx), |m| count("Mx", m, MAX_M))?,
                    my: spec.my.map_or(Ok(my), |m| count("My", m, MAX_M))?,
                }
            }
            _ => layout,
        };
        Ok(Channel { layout, ..ch })
    }

    fn layout(spec: &ChannelSpec, kx: u32, ky: u32) -> Result<Layout> {
        match spec.layout.as_str() {
            "ideal" => {
                if spec.grid != Grid::Rect {
                    return Err(Error::param(
                        "layout",
                        "\"ideal\"",
                        "\"sensor\" on a hex grid (the ideal layout is defined on rect grids only)",
                    ));
                }
                if spec.mx.is_some() || spec.my.is_some() {
                    return Err(Error::param(
                        "Mx",
                        spec.mx.or(spec.my).unwrap_or_default(),
                        "None with the ideal layout (its pixels are Q x Q per lens)",
                    ));
                }
                let q = spec.q.ok_or_else(|| {
                    Error::param(
                        "Q",
                        "None",
                        "an integer in [1, 65535] with the ideal layout",
                    )
                })?;
                Ok(Layout::Ideal {
                    q: count("Q", q, MAX_Q)?,
                })
            }
            "sensor" => {
                if let Some(q) = spec.q {
                    return Err(Error::param(
                        "Q",
                        q,
                        "None with the sensor layout (pixels per lens follow from mu and d)",
                    ));
                }
                // Placeholders until the covering grid is known (see Channel::new).
                let mx = spec.mx.map_or(Ok(1), |m| count("Mx", m, MAX_M))?;
                let my = spec.my.map_or(Ok(1), |m| count("My", m, MAX_M))?;
                let _ = (kx, ky);
                Ok(Layout::Sensor { mx, my })
            }
            other => Err(Error::param(
                "layout",
                format!("{other:?}"),
                "\"ideal\" or \"sensor\"",
            )),
        }
    }

    /// The lens-type pattern must use every type, and (hex) give every lens's six
    /// neighbours other types than its own: T = 2 cannot (docs/model.md §9).
    fn check_types(&self) -> Result<()> {
        let t = self.f.len() as u64;
        if self.grid == Grid::Hex && t == 2 {
            return Err(Error::param(
                "f",
                "2 focal lengths",
                "1 or >= 3 lens types on a hex grid (with 2 types some neighbours share a type)",
            ));
        }
        let span = type_span(self.grid, self.kx, self.ky);
        if t > span {
            return Err(Error::param(
                "f",
                format!("{t} focal lengths"),
                format!("at most {span} lens types on this {} grid of {} x {} lenses (every type must occur)", self.grid.name(), self.kx, self.ky),
            ));
        }
        Ok(())
    }

    fn check_derived(&self) -> Result<()> {
        derived("d v / 2", self.d * self.v / 2.0, "d and v")?;
        derived("L / v", self.l / self.v, "L and v")?;
        derived(
            "image pitch d (1 + v / L)",
            self.image_pitch(),
            "d, v and L",
        )?;
        if let Layout::Ideal { q } = self.layout {
            // The chief ray height of the outermost pixel, (L / v) mu (Q - 1) / 2.
            let edge = self.chief_w([self.mu * (0.0 - (q as f64 - 1.0) / 2.0), 0.0])[0];
            if !edge.is_finite() {
                return Err(Error::param(
                    "mu",
                    self.mu,
                    "small enough that the outermost pixel's chief ray height (L / v) mu (Q - 1) / 2 is finite",
                ));
            }
        }
        if !self.ng {
            return Ok(());
        }
        derived("f", self.f[0], "Ng's setting 1/f = 1/L + 1/v (f not given)")
    }

    /// The smallest centred sensor grid (M_x, M_y) that covers every image cell.
    fn covering_sensor(&self) -> Result<(u32, u32)> {
        let (ex, ey) = self.covering_extent();
        let m = |name: &'static str, e: f64| -> Result<u32> {
            let n = (e / self.mu).ceil();
            if n.is_finite() && n <= MAX_M as f64 {
                Ok((n as u32).max(1))
            } else {
                Err(Error::param(
                    name,
                    "the covering grid",
                    format!("at most {MAX_M} pixels per axis; give Mx, My or a larger mu"),
                ))
            }
        };
        Ok((m("Mx", ex)?, m("My", ey)?))
    }

    /// Number of lens types T.
    pub fn types(&self) -> usize {
        self.f.len()
    }

    /// Magnification of lens centres onto the sensor, 1 + v/L.
    #[inline]
    pub fn magnification(&self) -> f64 {
        1.0 + self.v / self.l
    }

    /// Pitch of the microlens images on the sensor, d (1 + v/L).
    #[inline]
    pub fn image_pitch(&self) -> f64 {
        self.d * self.magnification()
    }

    /// Width and height of the bounding box of the array's lens cells: K_x d × K_y d
    /// (rect); (K_x + 1/2) d × ((K_y − 1) √3/2 + 2/√3) d (hex with ≥ 2 rows; K_x d wide
    /// with one row).
    pub fn array_extent(&self) -> (f64, f64) {
        let (kx, ky) = (self.kx as f64, self.ky as f64);
        match self.grid {
            Grid::Rect => (kx * self.d, ky * self.d),
            Grid::Hex => {
                let w = if self.ky >= 2 { kx + 0.5 } else { kx };
                let h = (ky - 1.0) * SQRT3_2 + 1.0 / SQRT3_2;
                (w * self.d, h * self.d)
            }
        }
    }

    /// The array extent scaled onto the sensor, (1 + v/L) × [`Channel::array_extent`].
    pub fn image_extent(&self) -> (f64, f64) {
        let (w, h) = self.array_extent();
        let m = self.magnification();
        (w * m, h * m)
    }

    /// Width and height of the smallest axis-centred box that holds every image cell: the
    /// image extent, widened on hex grids with an odd number K_y ≥ 3 of rows by twice the
    /// offset |⌊K_y/2⌋/K_y − 1/2| d/2 of the mean-centred lattice from its bounding box's
    /// centre, scaled onto the sensor (docs/model.md §9, Pixel layouts). Zero offset,
    /// and so the image extent itself, on rect grids, with even K_y or with one row.
    pub fn covering_extent(&self) -> (f64, f64) {
        let (w, h) = self.image_extent();
        if self.grid == Grid::Rect || self.ky < 2 {
            return (w, h);
        }
        let (mx, _) = self.hex_mean();
        // The cells' bounding box spans [−1/2, K_x] d before centring; its centre is
        // (K_x/2 − 1/4) d and the lattice's mean mx d.
        let off = (self.kx as f64 / 2.0 - 0.25 - mx).abs();
        (w + 2.0 * off * self.d * self.magnification(), h)
    }

    /// The mean of the hex lattice's uncentred centres, (x, y) / d.
    pub(crate) fn hex_mean(&self) -> (f64, f64) {
        let odd = (self.ky / 2) as f64 / self.ky as f64;
        (
            (self.kx as f64 - 1.0) / 2.0 + odd / 2.0,
            SQRT3_2 * (self.ky as f64 - 1.0) / 2.0,
        )
    }

    /// Centre of lens (j, k) on the array plane (docs/model.md §9, Lattices).
    #[inline]
    pub fn lens_center(&self, j: u32, k: u32) -> [f64; 2] {
        match self.grid {
            Grid::Rect => [
                self.d * (j as f64 - (self.kx as f64 - 1.0) / 2.0),
                self.d * (k as f64 - (self.ky as f64 - 1.0) / 2.0),
            ],
            Grid::Hex => {
                let (mx, my) = self.hex_mean();
                let x = j as f64 + (k % 2) as f64 / 2.0;
                let y = k as f64 * SQRT3_2;
                [self.d * (x - mx), self.d * (y - my)]
            }
        }
    }

    /// Type t of lens (j, k): (j − ⌊k/2⌋ − k) mod T on hex grids, (j + k) mod T on rect.
    #[inline]
    pub fn lens_type(&self, j: u32, k: u32) -> usize {
        let t = self.f.len() as i64;
        let i = match self.grid {
            Grid::Rect => j as i64 + k as i64,
            Grid::Hex => j as i64 - (k / 2) as i64 - k as i64,
        };
        i.rem_euclid(t) as usize
    }

    /// Is the sensor offset θ from a lens's image centre inside that lens's image cell
    /// (closed: the square of side p, or the hexagon of pitch p with flat sides facing
    /// the row neighbours)?
    #[inline]
    pub fn in_cell(&self, theta: [f64; 2]) -> bool {
        let half = self.image_pitch() / 2.0;
        let (ax, ay) = (theta[0].abs(), theta[1].abs());
        match self.grid {
            Grid::Rect => ax <= half && ay <= half,
            Grid::Hex => ax <= half && ax / 2.0 + ay * SQRT3_2 <= half,
        }
    }

    /// The lens whose image centre is nearest the sensor point s (ties to the lower j,
    /// then the lower k), over every lens of the array.
    pub fn nearest_lens(&self, s: [f64; 2]) -> (u32, u32) {
        let m = self.magnification();
        let dist2 = |j: u32, k: u32| {
            let c = self.lens_center(j, k);
            let (dx, dy) = (s[0] - c[0] * m, s[1] - c[1] * m);
            dx * dx + dy * dy
        };
        let p = self.image_pitch();
        let clamp = |x: f64, n: u32| -> u32 { x.clamp(0.0, n as f64 - 1.0) as u32 };
        match self.grid {
            Grid::Rect => {
                // Separable: the nearest index per axis (round half down to the lower).
                let axis = |x: f64, n: u32| {
                    let t = x / p + (n as f64 - 1.0) / 2.0;
                    let lo = clamp(t.floor(), n);
                    let hi = clamp(t.ceil(), n);
                    (lo, hi)
                };
                let (j0, j1) = axis(s[0], self.kx);
                let (k0, k1) = axis(s[1], self.ky);
                let mut best = (j0, k0);
                let mut bd = dist2(j0, k0);
                for (j, k) in [(j0, k1), (j1, k0), (j1, k1)] {
                    let dd = dist2(j, k);
                    if dd < bd || (dd == bd && (j, k) < best) {
                        best = (j, k);
                        bd = dd;
                    }
                }
                best
            }
            Grid::Hex => {
                let (mx, my) = self.hex_mean();
                let row = s[1] / (p * SQRT3_2) + my / SQRT3_2;
                // The nearest lens lies in the nearest row of each parity (rows of one
                // parity share their x positions): among k0 − 1 ..= k0 + 2, clamped.
                let k0 = clamp(row.floor(), self.ky) as f64;
                let mut best = (u32::MAX, u32::MAX);
                let mut bd = f64::INFINITY;
                for dk in -1..=2 {
                    let k = clamp(k0 + dk as f64, self.ky);
                    let t = s[0] / p + mx - (k % 2) as f64 / 2.0;
                    for j in [clamp(t.floor(), self.kx), clamp(t.ceil(), self.kx)] {
                        let dd = dist2(j, k);
                        if dd < bd || (dd == bd && (j, k) < best) {
                            best = (j, k);
                            bd = dd;
                        }
                    }
                }
                best
            }
        }
    }

    /// Main-lens height of the chief ray of a pixel at offset θ from its lens's image
    /// centre: w = −(L/v) θ (independent of the lens's focal length).
    #[inline]
    pub fn chief_w(&self, theta: [f64; 2]) -> [f64; 2] {
        let s = self.l / self.v;
        [-s * theta[0], -s * theta[1]]
    }

    /// Number of pixels of the channel's layout: K_x K_y Q² (ideal) or M_x M_y (sensor).
    pub fn pixel_count(&self) -> u128 {
        match self.layout {
            Layout::Ideal { q } => self.kx as u128 * self.ky as u128 * q as u128 * q as u128,
            Layout::Sensor { mx, my } => mx as u128 * my as u128,
        }
    }
}

/// The image of the aperture behind one lens (the square of side D v/L, or the disc of
/// that diameter) must fit inside the lens's image cell: otherwise neighbouring microlens
/// images overlap on the sensor and a pixel would collect light through two lenses, which
/// the model (one lens per pixel) does not describe.
fn check_images(shape: Aperture, aperture: f64, ch: &Channel) -> Result<()> {
    let size = aperture * ch.v / ch.l;
    let fits = match shape {
        Aperture::Square => ch.in_cell([size / 2.0, size / 2.0]),
        Aperture::Circle => size <= ch.image_pitch(),
    };
    if fits {
        Ok(())
    } else {
        Err(Error::param(
            "D",
            aperture,
            format!(
                "an aperture whose image behind a lens (D v / L = {} mm) fits in the lens's image cell (pitch d (1 + v / L) = {} mm): otherwise neighbouring microlens images overlap",
                crate::infra::error::short_number(size),
                crate::infra::error::short_number(ch.image_pitch())
            ),
        ))
    }
}

/// A validated design: a main lens and its channels.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// F, main lens focal length.
    pub f_main: f64,
    /// D, main lens aperture width (side of the square or diameter of the circle).
    pub aperture: f64,
    pub shape: Aperture,
    pub channels: Vec<Channel>,
}

/// One pixel of a channel's layout: its lens, that lens's type, its offset θ from the
/// lens's image centre, and whether it is lit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pixel {
    pub j: u32,
    pub k: u32,
    pub t: usize,
    pub theta: [f64; 2],
    pub lit: bool,
}

impl Design {
    /// Validate a design; a channel's invalid field is named `channels[i].name`.
    pub fn new(
        f_main: f64,
        aperture: f64,
        shape: Aperture,
        specs: &[ChannelSpec],
    ) -> Result<Design> {
        let f_main = length("F", f_main)?;
        let aperture = length("D", aperture)?;
        if specs.is_empty() || specs.len() > MAX_CHANNELS {
            return Err(Error::param(
                "channels",
                format!("{} channels", specs.len()),
                format!("1 to {MAX_CHANNELS} channels"),
            ));
        }
        let mut channels = Vec::with_capacity(specs.len());
        for (i, spec) in specs.iter().enumerate() {
            let ch = Channel::new(spec, f_main).map_err(|e| e.in_channel(i + 1))?;
            derived("D L / 2", aperture * ch.l / 2.0, "D and L")
                .and_then(|_| derived("D v / (2 L)", aperture * ch.v / (2.0 * ch.l), "D, v and L"))
                .map_err(|e| e.in_channel(i + 1))?;
            check_images(shape, aperture, &ch).map_err(|e| e.in_channel(i + 1))?;
            channels.push(ch);
        }
        let total: f64 = channels.iter().map(|c| c.share).sum();
        if total > 1.0 + SHARE_RTOL {
            return Err(Error::param(
                "share",
                format!("a total of {total}"),
                "shares that sum to at most 1 (a beam splitter divides the light, it makes none)",
            ));
        }
        Ok(Design {
            f_main,
            aperture,
            shape,
            channels,
        })
    }

    /// Channel `number` (from 1).
    pub fn channel(&self, number: i64) -> Result<&Channel> {
        let n = self.channels.len();
        if number >= 1 && (number as u64) <= n as u64 {
            Ok(&self.channels[number as usize - 1])
        } else {
            Err(Error::param(
                "channel",
                number,
                format!("an integer in [1, {n}]"),
            ))
        }
    }

    /// Is the chief ray with main-lens height w inside the aperture?
    #[inline]
    pub fn passes(&self, w: [f64; 2]) -> bool {
        self.shape.contains(self.aperture, w)
    }

    /// Pixel (a, b) of channel `ch`'s layout: a, b index the ideal layout's lens-major
    /// columns and rows (a = j Q + q_x, b = k Q + q_y) or the sensor grid (m_x, m_y).
    pub fn pixel(&self, ch: &Channel, a: u32, b: u32) -> Pixel {
        match ch.layout {
            Layout::Ideal { q } => {
                let (j, qx) = (a / q, a % q);
                let (k, qy) = (b / q, b % q);
                let off = |i: u32| ch.mu * (i as f64 - (q as f64 - 1.0) / 2.0);
                let theta = [off(qx), off(qy)];
                Pixel {
                    j,
                    k,
                    t: ch.lens_type(j, k),
                    theta,
                    lit: self.passes(ch.chief_w(theta)),
                }
            }
            Layout::Sensor { mx, my } => {
                let s = [
                    ch.mu * (a as f64 - (mx as f64 - 1.0) / 2.0),
                    ch.mu * (b as f64 - (my as f64 - 1.0) / 2.0),
                ];
                let (j, k) = ch.nearest_lens(s);
                let c = ch.lens_center(j, k);
                let m = ch.magnification();
                let theta = [s[0] - c[0] * m, s[1] - c[1] * m];
                Pixel {
                    j,
                    k,
                    t: ch.lens_type(j, k),
                    theta,
                    lit: ch.in_cell(theta) && self.passes(ch.chief_w(theta)),
                }
            }
        }
    }

    /// Width and height of channel `ch`'s pixel grid (columns a, rows b of [`Design::pixel`]).
    pub fn pixel_grid(&self, ch: &Channel) -> (u32, u32) {
        match ch.layout {
            Layout::Ideal { q } => (ch.kx * q, ch.ky * q),
            Layout::Sensor { mx, my } => (mx, my),
        }
    }

    /// The chief sample (X, Y) on the plane at depth z (conjugate `zc`) of a pixel of
    /// lens centre c and chief height w: X = −(z/L) [c + w (L − z')/z'].
    #[inline]
    pub fn chief_sample(ch: &Channel, c: [f64; 2], w: [f64; 2], z: f64, zc: f64) -> [f64; 2] {
        let s = (ch.l - zc) / zc;
        let g = z / ch.l;
        [-g * (c[0] + w[0] * s), -g * (c[1] + w[1] * s)]
    }

    /// δ(z) = μ_1 z / L_1: one pixel of a conventional camera on channel 1's array plane.
    pub fn resolution_step(&self, z: f64) -> f64 {
        let ch = &self.channels[0];
        let mz = ch.mu * z;
        if mz.is_finite() {
            mz / ch.l
        } else {
            ch.mu * (z / ch.l)
        }
    }

    /// Half-widths (h_x, h_y) of the 2-D central field on the plane at depth z: (window/2)
    /// lens pitches of channel 1 imaged onto the plane, clipped to half the half-extent of
    /// channel 1's array image on it (docs/model.md §9).
    pub fn central_field(&self, z: f64, window: f64) -> [f64; 2] {
        let ch = &self.channels[0];
        let (ex, ey) = ch.array_extent();
        let g = z / ch.l;
        let w = window / 2.0 * ch.d;
        [w.min(ex / 4.0) * g, w.min(ey / 4.0) * g]
    }

    /// Conjugate of depth z through the main lens (Eq. 1).
    #[inline]
    pub fn conjugate(&self, z: f64) -> f64 {
        conjugate(self.f_main, z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex_spec(kx: i64, ky: i64, f: Option<Vec<f64>>) -> ChannelSpec {
        ChannelSpec {
            l: 60.0,
            d: 0.1,
            v: 0.3,
            mu: 0.005,
            kx,
            ky,
            grid: Grid::Hex,
            f,
            layout: "sensor".into(),
            q: None,
            mx: None,
            my: None,
            share: 1.0,
        }
    }

    #[test]
    fn hex_types_differ_from_all_six_neighbours() {
        let d = Design::new(
            50.0,
            10.0,
            Aperture::Circle,
            &[hex_spec(9, 8, Some(vec![0.3, 0.31, 0.32]))],
        )
        .unwrap();
        let ch = &d.channels[0];
        for k in 0..ch.ky {
            for j in 0..ch.kx {
                let c = ch.lens_center(j, k);
                for k2 in 0..ch.ky {
                    for j2 in 0..ch.kx {
                        let c2 = ch.lens_center(j2, k2);
                        let r = ((c[0] - c2[0]).powi(2) + (c[1] - c2[1]).powi(2)).sqrt();
                        if (j, k) != (j2, k2) && (r - ch.d).abs() < 1e-9 {
                            assert_ne!(ch.lens_type(j, k), ch.lens_type(j2, k2));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn hex_centres_have_zero_mean_and_unit_pitch() {
        let d = Design::new(50.0, 10.0, Aperture::Circle, &[hex_spec(7, 5, None)]).unwrap();
        let ch = &d.channels[0];
        let (mut sx, mut sy) = (0.0, 0.0);
        for k in 0..5 {
            for j in 0..7 {
                let c = ch.lens_center(j, k);
                sx += c[0];
                sy += c[1];
            }
        }
        assert!(sx.abs() < 1e-12 && sy.abs() < 1e-12);
        let (a, b) = (ch.lens_center(2, 1), ch.lens_center(2, 2));
        let r = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        assert!((r - 0.1).abs() < 1e-12);
    }

    #[test]
    fn nearest_lens_is_brute_force_nearest() {
        for grid in [Grid::Hex, Grid::Rect] {
            let spec = ChannelSpec {
                grid,
                ..hex_spec(6, 5, None)
            };
            let d = Design::new(50.0, 10.0, Aperture::Circle, &[spec]).unwrap();
            let ch = &d.channels[0];
            let m = ch.magnification();
            for a in -40..40 {
                for b in -40..40 {
                    let s = [a as f64 * 0.0137, b as f64 * 0.0119];
                    let mut best = (0, 0);
                    let mut bd = f64::INFINITY;
                    for j in 0..ch.kx {
                        for k in 0..ch.ky {
                            let c = ch.lens_center(j, k);
                            let dd = (s[0] - c[0] * m).powi(2) + (s[1] - c[1] * m).powi(2);
                            if dd < bd || (dd == bd && (j, k) < best) {
                                bd = dd;
                                best = (j, k);
                            }
                        }
                    }
                    assert_eq!(ch.nearest_lens(s), best, "{grid:?} {s:?}");
                }
            }
        }
    }

    #[test]
    fn rejects_bad_designs() {
        let e = Design::new(
            50.0,
            10.0,
            Aperture::Circle,
            &[hex_spec(9, 8, Some(vec![0.3, 0.31]))],
        )
        .unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("channels[1].f"));
        let mut two = vec![hex_spec(9, 8, None), hex_spec(9, 8, None)];
        two[1].share = 0.6;
        let e = Design::new(50.0, 10.0, Aperture::Circle, &two).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("share"));
        let bad_l = ChannelSpec {
            l: 40.0,
            ..hex_spec(9, 8, None)
        };
        let e = Design::new(50.0, 10.0, Aperture::Circle, &[bad_l]).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("channels[1].L"));
        let ideal_hex = ChannelSpec {
            layout: "ideal".into(),
            q: Some(5),
            ..hex_spec(9, 8, None)
        };
        assert!(Design::new(50.0, 10.0, Aperture::Circle, &[ideal_hex]).is_err());
    }
}
