//! Per-channel pixel tables: the nearest-lens candidates of every sensor column and row
//! (or the ideal layout's offsets), from which a pixel's lens, type, lit flag and chief
//! sample follow with the same floating-point expressions as [`Design::pixel`].

use crate::infra::error::Result;
use crate::infra::memory::try_reserve;
use crate::model::design::{Aperture, Channel, Design, Grid, Layout, SQRT3_2};

// ---- per-channel tables --------------------------------------------------------------

/// Nearest-lens candidates of one sensor column: for each lattice-row parity (rect: 0
/// only) the lower and upper lens index that [`Channel::nearest_lens`] tries, and the
/// squared x distance of the pixel centre to each lens's image centre.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct ColumnCandidates {
    pub(super) j: [[u32; 2]; 2],
    pub(super) dxx: [[f64; 2]; 2],
    /// Per parity, the candidate (lower 0 or upper 1) that wins against the other of the
    /// same lens row whatever that row's distance² (see [`Sensor::sure`]), when `amb` is
    /// false: 0 when dxx[0] ≤ dxx[1] (rounding is monotone and a tie goes to the lower j),
    /// 1 when dxx[1] is below dxx[0] by more than `sure`.
    pub(super) sel: [u8; 2],
    /// Some parity has neither: both candidates are compared pixel by pixel.
    pub(super) amb: bool,
}

/// Nearest-lens candidates of one sensor row: the lattice rows that
/// [`Channel::nearest_lens`] tries (rect: 2, hex: 4, clamped), their parities and squared y
/// distances, less the rows that can never win (see [`Tables::row`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct RowCandidates {
    pub(super) k: [u32; 4],
    pub(super) par: [usize; 4],
    pub(super) dyy: [f64; 4],
    /// θ_y, w_y and the sample's Y of a pixel of this row belonging to row k's lenses.
    pub(super) theta: [f64; 4],
    pub(super) w: [f64; 4],
    pub(super) y: [f64; 4],
    pub(super) n: usize,
}

/// θ_x, w_x and the sample's X of a pixel of one column for each candidate lens
/// ([parity][lower/upper], as [`ColumnCandidates`]) on the plane at hand.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct ColumnX {
    pub(super) theta: [[f64; 2]; 2],
    pub(super) w: [[f64; 2]; 2],
    pub(super) x: [[f64; 2]; 2],
}

/// Call `$t.$f::<N, HEX, CIRCLE>(args)` with the constants of row candidates `$rc` (N =
/// `rc.n`) and of the design (hex grid, circular aperture): the per-pixel loops of the
/// sensor layout, monomorphised so that they carry no branch on these.
macro_rules! dispatch {
    ($t:expr, $rc:expr, $f:ident($($arg:expr),*)) => {{
        let (hex, circle) = ($t.hex, $t.design.shape == Aperture::Circle);
        macro_rules! go {
            ($n:literal) => {
                match (hex, circle) {
                    (true, true) => $t.$f::<$n, true, true>($($arg),*),
                    (true, false) => $t.$f::<$n, true, false>($($arg),*),
                    (false, true) => $t.$f::<$n, false, true>($($arg),*),
                    (false, false) => $t.$f::<$n, false, false>($($arg),*),
                }
            };
        }
        match $rc.n {
            1 => go!(1),
            2 => go!(2),
            3 => go!(3),
            _ => go!(4),
        }
    }};
}
pub(super) use dispatch;

/// One pixel row of the [`chief_samples_into`](super::chief_samples_into) outputs.
pub(super) struct RowOut<'a> {
    pub(super) x: &'a mut [f64],
    pub(super) y: &'a mut [f64],
    pub(super) lit: &'a mut [bool],
    pub(super) lens: &'a mut [i64],
    pub(super) types: &'a mut [i64],
}

/// A sensor pixel: its lens, chief sample and lit flag.
#[derive(Debug, Clone, Copy)]
pub(super) struct SensorPx {
    pub(super) j: u32,
    pub(super) k: u32,
    pub(super) lit: bool,
    pub(super) xy: [f64; 2],
}

/// The sensor layout's tables: pixel centres, per-column candidates, magnified centres.
#[derive(Debug)]
pub(super) struct Sensor {
    pub(super) sx: Vec<f64>,
    pub(super) sy: Vec<f64>,
    pub(super) cols: Vec<ColumnCandidates>,
    pub(super) cxm: [Vec<f64>; 2],
    pub(super) cym: Vec<f64>,
    /// Image pitch d (1 + v/L).
    pub(super) p: f64,
    /// The hex lattice's mean (x, y) / d ([`Channel::hex_mean`]); rect: unused.
    pub(super) mean: (f64, f64),
    /// Half the image pitch ([`Channel::in_cell`]) and the aperture's radius D/2
    /// ([`crate::model::design::Aperture::contains`]).
    pub(super) half_cell: f64,
    pub(super) radius: f64,
    /// A margin above which distance² differences survive rounding: 16 ulp of the largest
    /// candidate distance² B (dxx + dyy ≤ B for every candidate of every pixel). When two
    /// candidates' dxx (or dyy) differ by more than this, adding the same dyy (dxx) to both
    /// keeps their rounded sums in the same strict order.
    pub(super) sure: f64,
}

#[derive(Debug)]
pub(super) enum PixelTables {
    /// Q × Q pixels per lens: main-lens height w_q = −(L/v) θ_q of each pixel offset.
    Ideal { q: u32, w: Vec<f64> },
    /// A uniform pixel grid.
    Sensor(Sensor),
}

/// One pixel: its lens (j, k), the lattice-row parity used for j's centre, main-lens
/// height w of its chief ray and whether it is lit.
#[derive(Debug, Clone, Copy)]
pub(super) struct Px {
    pub(super) j: u32,
    pub(super) k: u32,
    pub(super) par: usize,
    pub(super) w: [f64; 2],
    pub(super) lit: bool,
}

/// A channel's lens and pixel tables, every value computed by the same expressions as
/// [`Channel::lens_center`], [`Channel::nearest_lens`] and [`Design::pixel`].
#[derive(Debug)]
pub(super) struct Tables<'a> {
    pub(super) design: &'a Design,
    pub(super) ch: &'a Channel,
    pub(super) hex: bool,
    /// L / v, as in [`Channel::chief_w`].
    pub(super) lv: f64,
    /// Unmagnified lens centres: x per row parity (rect: parity 0) and lens index, y per row.
    pub(super) cx: [Vec<f64>; 2],
    pub(super) cy: Vec<f64>,
    /// j mod T, and the row's part of the type: k mod T (rect), (−⌊k/2⌋ − k) mod T (hex).
    pub(super) jmod: Vec<u8>,
    pub(super) kbase: Vec<u8>,
    pub(super) types: u8,
    pub(super) px: PixelTables,
    pub(super) cols: usize,
    pub(super) rows: usize,
}

fn clamp_index(x: f64, n: u32) -> u32 {
    // As Channel::nearest_lens's clamp.
    x.clamp(0.0, n as f64 - 1.0) as u32
}

/// Sensor row s1's candidate lens rows (before [`Tables::row`] drops any): those of
/// [`Channel::nearest_lens`] (rect: 2, hex: 4, clamped), in non-decreasing k; `p` the image
/// pitch, `mean` the hex lattice's mean ([`Channel::hex_mean`]).
fn row_ks(hex: bool, ky: u32, p: f64, mean: (f64, f64), s1: f64) -> ([u32; 4], usize) {
    if hex {
        let row = s1 / (p * SQRT3_2) + mean.1 / SQRT3_2;
        let k0 = clamp_index(row.floor(), ky) as f64;
        let mut ks = [0; 4];
        for (i, dk) in (-1..=2).enumerate() {
            ks[i] = clamp_index(k0 + dk as f64, ky);
        }
        (ks, 4)
    } else {
        let t = s1 / p + (ky as f64 - 1.0) / 2.0;
        (
            [clamp_index(t.floor(), ky), clamp_index(t.ceil(), ky), 0, 0],
            2,
        )
    }
}

/// Bytes of [`Tables::new`] for channel `ch`.
pub(super) fn tables_bytes(ch: &Channel) -> u128 {
    let (kx, ky) = (ch.kx as u128, ch.ky as u128);
    let lenses = 16 * kx + 8 * ky + kx + ky;
    match ch.layout {
        Layout::Ideal { q } => lenses + 8 * q as u128,
        Layout::Sensor { mx, my } => {
            let (mx, my) = (mx as u128, my as u128);
            // Pixel centres, column candidates (48 B) and their values on a plane (96 B).
            lenses + 16 * kx + 8 * ky + 8 * (mx + my) + 48 * mx + 96 * mx
        }
    }
}

impl<'a> Tables<'a> {
    pub(super) fn new(design: &'a Design, ch: &'a Channel) -> Result<Tables<'a>> {
        let what = "chief samples (lens and pixel tables)";
        let hex = ch.grid == Grid::Hex;
        let parities = if hex && ch.ky >= 2 { 2 } else { 1 };
        let mut cx: [Vec<f64>; 2] = Default::default();
        for (par, c) in cx.iter_mut().enumerate().take(parities) {
            try_reserve(c, what, ch.kx as usize)?;
            c.extend((0..ch.kx).map(|j| ch.lens_center(j, par as u32)[0]));
        }
        let mut cy = Vec::new();
        try_reserve(&mut cy, what, ch.ky as usize)?;
        cy.extend((0..ch.ky).map(|k| ch.lens_center(0, k)[1]));
        let t = ch.types() as i64;
        let mut jmod = Vec::new();
        try_reserve(&mut jmod, what, ch.kx as usize)?;
        jmod.extend((0..ch.kx).map(|j| (j as i64).rem_euclid(t) as u8));
        let mut kbase = Vec::new();
        try_reserve(&mut kbase, what, ch.ky as usize)?;
        kbase.extend((0..ch.ky).map(|k| {
            let i = if hex {
                -((k / 2) as i64) - k as i64
            } else {
                k as i64
            };
            i.rem_euclid(t) as u8
        }));
        let m = ch.magnification();
        let (cols, rows, px) = match ch.layout {
            Layout::Ideal { q } => {
                let s = ch.l / ch.v;
                let mut w = Vec::new();
                try_reserve(&mut w, what, q as usize)?;
                // θ_q as in Design::pixel, w = −(L/v) θ as in Channel::chief_w.
                w.extend((0..q).map(|i| -s * (ch.mu * (i as f64 - (q as f64 - 1.0) / 2.0))));
                let (c, r) = (ch.kx as usize * q as usize, ch.ky as usize * q as usize);
                (c, r, PixelTables::Ideal { q, w })
            }
            Layout::Sensor { mx, my } => {
                let centre = |n: u32| {
                    let mu = ch.mu;
                    move |i: u32| mu * (i as f64 - (n as f64 - 1.0) / 2.0)
                };
                let mut sx = Vec::new();
                try_reserve(&mut sx, what, mx as usize)?;
                sx.extend((0..mx).map(centre(mx)));
                let mut sy = Vec::new();
                try_reserve(&mut sy, what, my as usize)?;
                sy.extend((0..my).map(centre(my)));
                let mut cxm: [Vec<f64>; 2] = Default::default();
                for (par, c) in cxm.iter_mut().enumerate().take(parities) {
                    try_reserve(c, what, ch.kx as usize)?;
                    c.extend(cx[par].iter().map(|&x| x * m));
                }
                let mut cym = Vec::new();
                try_reserve(&mut cym, what, ch.ky as usize)?;
                cym.extend(cy.iter().map(|&y| y * m));
                let p = ch.image_pitch();
                let mean = if hex { ch.hex_mean() } else { (0.0, 0.0) };
                let mut cols = Vec::new();
                try_reserve(&mut cols, what, mx as usize)?;
                for &s0 in &sx {
                    let mut c = ColumnCandidates::default();
                    for (par, cxm) in cxm.iter().enumerate().take(parities) {
                        // Channel::nearest_lens: rect `x / p + (n − 1)/2`, hex
                        // `s[0] / p + mx − (k mod 2)/2`, floor and ceil, clamped.
                        let t = if hex {
                            s0 / p + mean.0 - par as f64 / 2.0
                        } else {
                            s0 / p + (ch.kx as f64 - 1.0) / 2.0
                        };
                        let js = [clamp_index(t.floor(), ch.kx), clamp_index(t.ceil(), ch.kx)];
                        for (h, &j) in js.iter().enumerate() {
                            let dx = s0 - cxm[j as usize];
                            c.j[par][h] = j;
                            c.dxx[par][h] = dx * dx;
                        }
                    }
                    cols.push(c);
                }
                let mut sen = Sensor {
                    sx,
                    sy,
                    cols,
                    cxm,
                    cym,
                    p,
                    mean,
                    half_cell: ch.image_pitch() / 2.0,
                    radius: design.aperture / 2.0,
                    sure: 0.0,
                };
                Tables::settle_columns(ch, hex, parities, &mut sen);
                let px = PixelTables::Sensor(sen);
                (mx as usize, my as usize, px)
            }
        };
        Ok(Tables {
            design,
            ch,
            hex,
            lv: ch.l / ch.v,
            cx,
            cy,
            jmod,
            kbase,
            types: t as u8,
            px,
            cols,
            rows,
        })
    }

    /// [`Sensor::sure`] and every column's `sel` and `amb` ([`ColumnCandidates`]).
    pub(super) fn settle_columns(ch: &Channel, hex: bool, parities: usize, sen: &mut Sensor) {
        let dxx_max = sen
            .cols
            .iter()
            .flat_map(|c| c.dxx[..parities].iter().flatten())
            .fold(0.0f64, |a, &b| a.max(b));
        let mut dyy_max = 0.0f64;
        for &s1 in &sen.sy {
            let (ks, n) = row_ks(hex, ch.ky, sen.p, sen.mean, s1);
            for &k in &ks[..n] {
                let dy = s1 - sen.cym[k as usize];
                dyy_max = dyy_max.max(dy * dy);
            }
        }
        // ulp(x) ≤ x 2^-52 for every x ≤ B: 2^-48 B is 16 ulp of the largest sum.
        let b = (dxx_max + dyy_max) * (1.0 + 1e-12);
        sen.sure = if b.is_finite() {
            b * 2f64.powi(-48)
        } else {
            f64::INFINITY
        };
        let sure = sen.sure;
        for c in sen.cols.iter_mut() {
            c.amb = false;
            for par in 0..parities {
                let [d0, d1] = c.dxx[par];
                c.sel[par] = if d1 >= d0 {
                    0
                } else if d0 - d1 > sure {
                    1
                } else {
                    c.amb = true;
                    0
                };
            }
        }
    }

    #[inline]
    pub(super) fn lens_type(&self, j: u32, k: u32) -> u8 {
        let t = self.jmod[j as usize] + self.kbase[k as usize];
        if t >= self.types {
            t - self.types
        } else {
            t
        }
    }

    /// Sensor row b's nearest-lens candidates (the rows of [`Channel::nearest_lens`]).
    pub(super) fn row(&self, sen: &Sensor, s1: f64, g: f64, s: f64) -> RowCandidates {
        let cym = &sen.cym;
        let mut rc = RowCandidates {
            k: [0; 4],
            par: [0; 4],
            dyy: [0.0; 4],
            theta: [0.0; 4],
            w: [0.0; 4],
            y: [0.0; 4],
            n: 0,
        };
        let (lv, cy) = (self.lv, &self.cy);
        let hex = self.hex;
        let mut push = |k: u32| {
            let dy = s1 - cym[k as usize];
            let (par, dyy) = (if hex { (k % 2) as usize } else { 0 }, dy * dy);
            // A row never wins when a row of the same parity (same lens x positions, so
            // the same j candidates) with a lower or equal index is no farther: for every j
            // its rounded distance² is no smaller and a tie goes to the lower k. Rows come
            // in non-decreasing k (clamping is monotone), so only the new row can be so
            // dominated; dropping it changes no result.
            let dominated = (0..rc.n).any(|i| rc.par[i] == par && rc.dyy[i] <= dyy);
            if !dominated {
                // As sensor_pixel and sample: θ = s − c m, w = −(L/v) θ, Y = −g (c + w s).
                let w = -lv * dy;
                rc.k[rc.n] = k;
                rc.par[rc.n] = par;
                rc.dyy[rc.n] = dyy;
                rc.theta[rc.n] = dy;
                rc.w[rc.n] = w;
                rc.y[rc.n] = -g * (cy[k as usize] + w * s);
                rc.n += 1;
            }
        };
        let (ks, n) = row_ks(self.hex, self.ch.ky, sen.p, sen.mean, s1);
        for &k in &ks[..n] {
            push(k);
        }
        // Conversely, a row also never wins when a later row of the same parity is nearer
        // by more than `sure`: for every j its rounded distance² is then strictly larger
        // (no tie to win). Drop it too.
        let mut kept = 0;
        for i in 0..rc.n {
            let beaten =
                (i + 1..rc.n).any(|l| rc.par[l] == rc.par[i] && rc.dyy[i] - rc.dyy[l] > sen.sure);
            if !beaten {
                rc.k[kept] = rc.k[i];
                rc.par[kept] = rc.par[i];
                rc.dyy[kept] = rc.dyy[i];
                rc.theta[kept] = rc.theta[i];
                rc.w[kept] = rc.w[i];
                rc.y[kept] = rc.y[i];
                kept += 1;
            }
        }
        rc.n = kept;
        rc
    }

    /// Every column's [`ColumnX`] on the plane (g = z/L, s = (L − z')/z').
    pub(super) fn columns_x(
        &self,
        sen: &Sensor,
        g: f64,
        s: f64,
        out: &mut Vec<ColumnX>,
    ) -> Result<()> {
        out.clear();
        try_reserve(out, "chief samples (column tables)", sen.cols.len())?;
        out.extend((0..sen.cols.len()).map(|a| self.column_x(sen, a, g, s)));
        Ok(())
    }

    /// Column a's [`ColumnX`] on the plane (g = z/L, s = (L − z')/z').
    #[inline]
    pub(super) fn column_x(&self, sen: &Sensor, a: usize, g: f64, s: f64) -> ColumnX {
        let (c, s0) = (&sen.cols[a], sen.sx[a]);
        let parities = if self.cx[1].is_empty() { 1 } else { 2 };
        let mut v = ColumnX::default();
        for par in 0..parities {
            for h in 0..2 {
                let j = c.j[par][h] as usize;
                let theta = s0 - sen.cxm[par][j];
                let w = -self.lv * theta;
                v.theta[par][h] = theta;
                v.w[par][h] = w;
                v.x[par][h] = -g * (self.cx[par][j] + w * s);
            }
        }
        v
    }

    /// The sensor pixel centres (`centres`, ascending) that can hold a lit sample with
    /// |X| ≤ b (or |Y| ≤ b): a range of indices. A candidate lens counts only with
    /// |w| < D/2, so its centre c satisfies |c| < b/g + (D/2)|s| (the sample is
    /// −g (c + w s)), and the pixel lies within |θ| = |w| v/L < (D/2)/(L/v) of the lens's
    /// image centre c m: |centre| < (b/g + (D/2)|s|) m + (D/2)/(L/v). Padded well beyond
    /// rounding and by a pixel, so the range holds every pixel the per-pixel tests accept.
    pub(super) fn sensor_range(
        &self,
        centres: &[f64],
        g: f64,
        s: f64,
        b: f64,
    ) -> std::ops::Range<usize> {
        let r = self.design.aperture / 2.0;
        let m = self.ch.magnification();
        let reach = ((b / g + r * s.abs()) * m + r / self.lv) * (1.0 + 1e-9) + self.ch.mu;
        if !reach.is_finite() {
            return 0..centres.len();
        }
        let lo = centres.partition_point(|&x| x < -reach);
        let hi = centres.partition_point(|&x| x <= reach);
        lo..hi.max(lo)
    }

    /// Sensor pixel of column candidates `c` (with their values `cx` on the plane) in a row
    /// of candidates `rc`. Its lens is the least (distance², j, k) over the candidates:
    /// exactly [`Channel::nearest_lens`]; θ, w and the sample are read from the tables,
    /// computed by the expressions of [`Design::pixel`] and [`Design::chief_sample`]; lit
    /// is [`Channel::in_cell`] and [`Design::passes`] with their constants hoisted.
    /// `N` is the row's candidate count `rc.n` (1 to 4), `HEX` the grid and `CIRCLE` the
    /// aperture's shape: constants, so that the candidate loop unrolls and the per-pixel
    /// code has no branch on the design (see [`Tables::sensor_row`] and `dispatch!`).
    #[inline(always)]
    pub(super) fn sensor_pixel<const N: usize, const HEX: bool, const CIRCLE: bool>(
        &self,
        sen: &Sensor,
        c: &ColumnCandidates,
        cx: &ColumnX,
        rc: &RowCandidates,
    ) -> SensorPx {
        debug_assert_eq!(N, rc.n);
        debug_assert_eq!(HEX, self.hex);
        debug_assert_eq!(CIRCLE, self.design.shape == Aperture::Circle);
        // (j, k) packed so that integer order is (j, k) order; selects, not branches.
        let mut best = u64::MAX;
        let mut bd = f64::INFINITY;
        let (mut bi, mut bh) = (0, 0);
        let mut consider = |i: usize, k: u32, par: usize, h: usize, dyy: f64| {
            let j = c.j[par][h];
            let dd = c.dxx[par][h] + dyy;
            let key = ((j as u64) << 32) | k as u64;
            let better = (dd < bd) | ((dd == bd) & (key < best));
            best = if better { key } else { best };
            bd = if better { dd } else { bd };
            bi = if better { i } else { bi };
            bh = if better { h } else { bh };
        };
        if c.amb {
            for i in 0..N {
                let (k, par, dyy) = (rc.k[i], rc.par[i] & 1, rc.dyy[i]);
                for h in 0..2 {
                    consider(i, k, par, h, dyy);
                }
            }
        } else {
            // Only the candidate of each lens row that beats (or ties and precedes) the
            // other of that row whatever the row's distance² (`sel`): the least over the
            // rest is the least over all.
            for i in 0..N {
                let (k, par, dyy) = (rc.k[i], rc.par[i] & 1, rc.dyy[i]);
                consider(i, k, par, c.sel[par] as usize & 1, dyy);
            }
        }
        let par = rc.par[bi] & 1;
        let (ax, ay) = (cx.theta[par][bh].abs(), rc.theta[bi].abs());
        let half = sen.half_cell;
        let in_cell = if HEX {
            (ax <= half) & (ax / 2.0 + ay * SQRT3_2 <= half)
        } else {
            (ax <= half) & (ay <= half)
        };
        let (w0, w1, r) = (cx.w[par][bh], rc.w[bi], sen.radius);
        let passes = if CIRCLE {
            w0 * w0 + w1 * w1 < r * r
        } else {
            (w0.abs() < r) & (w1.abs() < r)
        };
        SensorPx {
            j: (best >> 32) as u32,
            k: best as u32,
            lit: in_cell & passes,
            xy: [cx.x[par][bh], rc.y[bi]],
        }
    }

    /// Chief sample of a pixel: [`Design::chief_sample`] with g = z/L, s = (L − z')/z'.
    #[inline]
    pub(super) fn sample(&self, px: &Px, g: f64, s: f64) -> [f64; 2] {
        let c = [self.cx[px.par][px.j as usize], self.cy[px.k as usize]];
        [-g * (c[0] + px.w[0] * s), -g * (c[1] + px.w[1] * s)]
    }

    /// Fill one pixel row (b) of the chief-sample outputs.
    pub(super) fn fill_row(&self, b: usize, g: f64, s: f64, colx: &[ColumnX], out: RowOut<'_>) {
        let RowOut {
            x,
            y,
            lit,
            lens,
            types,
        } = out;
        let mut put = |a: usize, px: &Px| {
            let xy = if px.lit {
                self.sample(px, g, s)
            } else {
                [f64::NAN, f64::NAN]
            };
            x[a] = xy[0];
            y[a] = xy[1];
            lit[a] = px.lit;
            lens[2 * a] = px.j as i64;
            lens[2 * a + 1] = px.k as i64;
            types[a] = self.lens_type(px.j, px.k) as i64;
        };
        match &self.px {
            PixelTables::Ideal { q, w } => {
                let q = *q as usize;
                let (k, qy) = ((b / q) as u32, b % q);
                let mut a = 0;
                for j in 0..self.ch.kx {
                    for &wx in w.iter() {
                        let pw = [wx, w[qy]];
                        let px = Px {
                            j,
                            k,
                            par: 0,
                            w: pw,
                            lit: self.design.passes(pw),
                        };
                        put(a, &px);
                        a += 1;
                    }
                }
            }
            PixelTables::Sensor(sen) => {
                let rc = self.row(sen, sen.sy[b], g, s);
                let out = RowOut {
                    x,
                    y,
                    lit,
                    lens,
                    types,
                };
                dispatch!(self, rc, sensor_row(sen, &rc, colx, out));
            }
        }
    }

    /// One sensor row of the chief-sample outputs, its `N` = `rc.n` candidate lens rows.
    #[inline(always)]
    pub(super) fn sensor_row<const N: usize, const HEX: bool, const CIRCLE: bool>(
        &self,
        sen: &Sensor,
        rc: &RowCandidates,
        colx: &[ColumnX],
        out: RowOut<'_>,
    ) {
        let it = sen
            .cols
            .iter()
            .zip(colx)
            .zip(out.x.iter_mut().zip(out.y.iter_mut()))
            .zip(out.lit.iter_mut().zip(out.lens.chunks_exact_mut(2)))
            .zip(out.types.iter_mut());
        for ((((c, cx), (x, y)), (lit, lens)), t) in it {
            let px = self.sensor_pixel::<N, HEX, CIRCLE>(sen, c, cx, rc);
            *x = if px.lit { px.xy[0] } else { f64::NAN };
            *y = if px.lit { px.xy[1] } else { f64::NAN };
            *lit = px.lit;
            lens[0] = px.j as i64;
            lens[1] = px.k as i64;
            *t = self.lens_type(px.j, px.k) as i64;
        }
    }
}
