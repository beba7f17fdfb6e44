//! Chief samples, distinct samples and the covering radius in 2-D, for any design
//! (docs/model.md §9: "Chief samples in 2-D", "Scale and field", "Distinct samples in
//! 2-D", "Covering radius"; the implementation is described in its "§9 implementation"
//! subsection).
//!
//! - [`chief_samples_into`]: every pixel of one channel's layout, its lens, type, lit flag
//!   and chief sample (X, Y) on the plane at depth z, row by row in parallel. The
//!   nearest-lens rule of the sensor layout is [`Channel::nearest_lens`] evaluated from
//!   per-column and per-row tables: the same candidates, the same floating-point
//!   expressions and the same tie rule, so the result is bit for bit that of
//!   [`Design::pixel`] and [`Design::chief_sample`] (a unit test checks every pixel).
//! - [`samples_2d`] and [`coverage`]: the distinct samples of each channel and of the
//!   union of all channels (connected components of |ΔX|, |ΔY| < tol·δ(z), found with a
//!   hash grid of cell tol·δ and union-find), their number inside the 2-D central field,
//!   and the covering radius ρ(z) of that field (Delaunay triangulation by the `spade`
//!   crate, whose predicates are exact: the sample sets are lattices, massively cocircular
//!   and collinear, which a non-robust triangulator such as `delaunator` gets wrong).
//!
//! Only samples near the field can matter, so each depth is computed from the samples
//! within a margin m of the field (Chebyshev distance), starting at two lens pitches imaged
//! on the plane, and the margin is widened (up to every pixel) until the result is provably
//! that of the full sample set: the representatives that can be wrong (those of
//! components reaching the margin's edge) lie farther than m₂ from the field, and ρ < m₂.
//! A trial pass at a narrower margin ([`TRIAL_MARGIN`] δ) comes first and is kept only when
//! its result is provably the first margin's, bit for bit (see [`row_pass`]).

use rayon::prelude::*;
use spade::{DelaunayTriangulation, HierarchyHintGenerator, Point2, Triangulation};

use crate::infra::error::{Error, Result};
use crate::infra::memory::{self, try_reserve, try_vec};
use crate::infra::parallel::{self, chunk_items, for_chunks, threads};
use crate::model::design::{Aperture, Channel, Design, Grid, Layout, SQRT3_2};
use crate::model::optics::check_design_depths;
use crate::sampling::samples::check_tol;

/// Default width of the 2-D central field, in lens pitches of channel 1.
pub const DEFAULT_WINDOW: f64 = 16.0;
/// Largest merge tolerance of the 2-D distinct samples, in δ(z): samples farther apart
/// than one conventional pixel are never "the same sample".
pub const MAX_TOL_2D: f64 = 1.0;
/// Largest |X| / (tol δ(z)) a sample may reach (2^42): the hash grid's integer cell
/// indices then stay exact with a wide margin, whatever the rounding of X / cell.
pub const MAX_CELL_INDEX: f64 = 4_398_046_511_104.0;
/// Largest work of one `coverage` call: pixels of all channels × depths (each depth may,
/// in the worst case, have to look at every pixel).
pub const MAX_COVERAGE_WORK: u128 = 1 << 36;
/// Relative slack of the covering radius's pruning: a candidate point whose upper bound
/// exceeds the largest distance found so far by less than this fraction is not evaluated
/// (the candidates are themselves rounded at about 1e-13 of ρ).
pub const PRUNE_RTOL: f64 = 1e-9;
/// Hash-grid cells are this fraction wider than tol·δ: two samples closer than tol·δ then
/// always fall in the same or adjacent cells despite the rounding of X / cell.
const CELL_SLACK: f64 = 1.0 / 1024.0;
/// The margin of the trial pass (see [`row_pass`]), in δ(z): wider than the covering
/// radius of the presets' sample sets (about 1–7 δ) and the margin of representatives its
/// triangulation takes (4 sample spacings of about a δ, widened to 2 ρ), narrower than the
/// first margin (two lens pitches on the plane, 2 d/μ δ: 30–46 δ for the presets), so a
/// depth usually settles at a fraction of the first pass's samples.
const TRIAL_MARGIN: f64 = 16.0;
/// Bytes one worker holds per sample near the field, at most: the sample, its cell key,
/// union-find entries, its representative, spade's triangulation (vertex, half-edges,
/// faces, hierarchy) and the candidate points of the covering radius.
const SAMPLE_BYTES: u128 = 640;
/// Coordinates (in δ) smaller than this are set to 0 before triangulation (spade refuses
/// nonzero coordinates below 2^-142): a shift far below any distance of interest.
const FLUSH: f64 = 1e-30;

// ---- per-channel tables --------------------------------------------------------------

/// Nearest-lens candidates of one sensor column: for each lattice-row parity (rect: 0
/// only) the lower and upper lens index that [`Channel::nearest_lens`] tries, and the
/// squared x distance of the pixel centre to each lens's image centre.
#[derive(Debug, Clone, Copy, Default)]
struct ColumnCandidates {
    j: [[u32; 2]; 2],
    dxx: [[f64; 2]; 2],
    /// Per parity, the candidate (lower 0 or upper 1) that wins against the other of the
    /// same lens row whatever that row's distance² (see [`Sensor::sure`]), when `amb` is
    /// false: 0 when dxx[0] ≤ dxx[1] (rounding is monotone and a tie goes to the lower j),
    /// 1 when dxx[1] is below dxx[0] by more than `sure`.
    sel: [u8; 2],
    /// Some parity has neither: both candidates are compared pixel by pixel.
    amb: bool,
}

/// Nearest-lens candidates of one sensor row: the lattice rows that
/// [`Channel::nearest_lens`] tries (rect: 2, hex: 4, clamped), their parities and squared y
/// distances, less the rows that can never win (see [`Tables::row`]).
#[derive(Debug, Clone, Copy)]
struct RowCandidates {
    k: [u32; 4],
    par: [usize; 4],
    dyy: [f64; 4],
    /// θ_y, w_y and the sample's Y of a pixel of this row belonging to row k's lenses.
    theta: [f64; 4],
    w: [f64; 4],
    y: [f64; 4],
    n: usize,
}

/// θ_x, w_x and the sample's X of a pixel of one column for each candidate lens
/// ([parity][lower/upper], as [`ColumnCandidates`]) on the plane at hand.
#[derive(Debug, Clone, Copy, Default)]
struct ColumnX {
    theta: [[f64; 2]; 2],
    w: [[f64; 2]; 2],
    x: [[f64; 2]; 2],
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

/// A sensor pixel: its lens, chief sample and lit flag.
#[derive(Debug, Clone, Copy)]
struct SensorPx {
    j: u32,
    k: u32,
    lit: bool,
    xy: [f64; 2],
}

/// The sensor layout's tables: pixel centres, per-column candidates, magnified centres.
#[derive(Debug)]
struct Sensor {
    sx: Vec<f64>,
    sy: Vec<f64>,
    cols: Vec<ColumnCandidates>,
    cxm: [Vec<f64>; 2],
    cym: Vec<f64>,
    /// Image pitch d (1 + v/L).
    p: f64,
    /// The hex lattice's mean (x, y) / d ([`Channel::hex_mean`]); rect: unused.
    mean: (f64, f64),
    /// Half the image pitch ([`Channel::in_cell`]) and the aperture's radius D/2
    /// ([`crate::model::design::Aperture::contains`]).
    half_cell: f64,
    radius: f64,
    /// A margin above which distance² differences survive rounding: 16 ulp of the largest
    /// candidate distance² B (dxx + dyy ≤ B for every candidate of every pixel). When two
    /// candidates' dxx (or dyy) differ by more than this, adding the same dyy (dxx) to both
    /// keeps their rounded sums in the same strict order.
    sure: f64,
}

#[derive(Debug)]
enum PixelTables {
    /// Q × Q pixels per lens: main-lens height w_q = −(L/v) θ_q of each pixel offset.
    Ideal { q: u32, w: Vec<f64> },
    /// A uniform pixel grid.
    Sensor(Sensor),
}

/// One pixel: its lens (j, k), the lattice-row parity used for j's centre, main-lens
/// height w of its chief ray and whether it is lit.
#[derive(Debug, Clone, Copy)]
struct Px {
    j: u32,
    k: u32,
    par: usize,
    w: [f64; 2],
    lit: bool,
}

/// A channel's lens and pixel tables, every value computed by the same expressions as
/// [`Channel::lens_center`], [`Channel::nearest_lens`] and [`Design::pixel`].
#[derive(Debug)]
struct Tables<'a> {
    design: &'a Design,
    ch: &'a Channel,
    hex: bool,
    /// L / v, as in [`Channel::chief_w`].
    lv: f64,
    /// Unmagnified lens centres: x per row parity (rect: parity 0) and lens index, y per row.
    cx: [Vec<f64>; 2],
    cy: Vec<f64>,
    /// j mod T, and the row's part of the type: k mod T (rect), (−⌊k/2⌋ − k) mod T (hex).
    jmod: Vec<u8>,
    kbase: Vec<u8>,
    types: u8,
    px: PixelTables,
    cols: usize,
    rows: usize,
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
fn tables_bytes(ch: &Channel) -> u128 {
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
    fn new(design: &'a Design, ch: &'a Channel) -> Result<Tables<'a>> {
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
    fn settle_columns(ch: &Channel, hex: bool, parities: usize, sen: &mut Sensor) {
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
    fn lens_type(&self, j: u32, k: u32) -> u8 {
        let t = self.jmod[j as usize] + self.kbase[k as usize];
        if t >= self.types {
            t - self.types
        } else {
            t
        }
    }

    /// Sensor row b's nearest-lens candidates (the rows of [`Channel::nearest_lens`]).
    fn row(&self, sen: &Sensor, s1: f64, g: f64, s: f64) -> RowCandidates {
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
    fn columns_x(&self, sen: &Sensor, g: f64, s: f64, out: &mut Vec<ColumnX>) -> Result<()> {
        out.clear();
        try_reserve(out, "chief samples (column tables)", sen.cols.len())?;
        out.extend((0..sen.cols.len()).map(|a| self.column_x(sen, a, g, s)));
        Ok(())
    }

    /// Column a's [`ColumnX`] on the plane (g = z/L, s = (L − z')/z').
    #[inline]
    fn column_x(&self, sen: &Sensor, a: usize, g: f64, s: f64) -> ColumnX {
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
    fn sensor_range(&self, centres: &[f64], g: f64, s: f64, b: f64) -> std::ops::Range<usize> {
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
    fn sensor_pixel<const N: usize, const HEX: bool, const CIRCLE: bool>(
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
    fn sample(&self, px: &Px, g: f64, s: f64) -> [f64; 2] {
        let c = [self.cx[px.par][px.j as usize], self.cy[px.k as usize]];
        [-g * (c[0] + px.w[0] * s), -g * (c[1] + px.w[1] * s)]
    }

    /// Fill one pixel row (b) of the chief-sample outputs.
    fn fill_row(&self, b: usize, g: f64, s: f64, colx: &[ColumnX], out: RowOut<'_>) {
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
    fn sensor_row<const N: usize, const HEX: bool, const CIRCLE: bool>(
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

    /// Largest |X| and |Y| of any lit sample on the plane (g = z/L, s = (L − z')/z'),
    /// with room for rounding: lens centres plus the aperture's half-width through s.
    fn sample_extent(&self, g: f64, s: f64) -> [f64; 2] {
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
    fn pass_pixels(&self, g: f64, s: f64, bx: f64, by: f64) -> u128 {
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
    fn candidate_columns(
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
    fn candidate_rows(&self, g: f64, s: f64, by: f64, out: &mut Vec<u32>) {
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
    fn gather_row<const N: usize, const HEX: bool, const CIRCLE: bool>(
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

    /// Append the lit samples with |X| ≤ bx and |Y| ≤ by to `out`.
    fn gather(
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
                for &b in rows.iter() {
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
                for &b in rows.iter() {
                    let rc = self.row(sen, sen.sy[b as usize], g, s);
                    dispatch!(self, rc, gather_row(sen, &rc, cols, colx, &keep, out));
                }
            }
        }
        Ok(())
    }
}

// ---- chief samples of every pixel -----------------------------------------------------

/// One pixel row of the [`chief_samples_into`] outputs.
struct RowOut<'a> {
    x: &'a mut [f64],
    y: &'a mut [f64],
    lit: &'a mut [bool],
    lens: &'a mut [i64],
    types: &'a mut [i64],
}

/// Output buffers of [`chief_samples_into`], row-major over the channel's pixel grid
/// (rows b, columns a; see [`Design::pixel_grid`]): `x`, `y`, `lit`, `types` one value per
/// pixel, `lens` two (j, k). Any initial content: every element is written once.
pub struct ChiefSamplesOut<'a> {
    pub x: &'a mut [f64],
    pub y: &'a mut [f64],
    pub lit: &'a mut [bool],
    pub lens: &'a mut [i64],
    pub types: &'a mut [i64],
}

/// Chief samples of every pixel of one channel (allocated by [`chief_samples`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ChiefSamples {
    /// Pixel rows (M_y, or K_y Q) and columns (M_x, or K_x Q).
    pub rows: usize,
    pub cols: usize,
    /// Sample X, Y [mm] on the plane (NaN where the pixel is unlit).
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub lit: Vec<bool>,
    /// (j, k) of each pixel's lens, interleaved.
    pub lens: Vec<i64>,
    /// Lens type t of each pixel's lens.
    pub types: Vec<i64>,
}

/// Bytes of the chief-sample outputs per pixel: X, Y, lit, (j, k), type.
pub const CHIEF_BYTES_PER_PIXEL: u128 = 8 + 8 + 1 + 16 + 8;

/// Validate a chief-samples call (threads, channel, depth) and check the memory of its
/// outputs and tables; returns the channel's index (from 0) and its (rows, columns).
pub fn check_chief_samples(
    design: &Design,
    channel: i64,
    z: f64,
    n_threads: Option<usize>,
) -> Result<(usize, usize, usize)> {
    let (index, _, rows, cols) = check_chief_rows(design, channel, z, n_threads, None)?;
    Ok((index, rows, cols))
}

/// [`check_chief_samples`] for the pixel rows `[start, stop)` of the window (every row for
/// `None`): validates the window too and checks the memory of the window's outputs only.
/// Returns the channel's index (from 0), the first row, and the (rows, columns) computed.
pub fn check_chief_rows(
    design: &Design,
    channel: i64,
    z: f64,
    n_threads: Option<usize>,
    window: Option<(i64, i64)>,
) -> Result<(usize, usize, usize, usize)> {
    parallel::check_threads(n_threads)?;
    let ch = design.channel(channel)?;
    check_design_depths(design.f_main, &[z])?;
    let (cols, rows) = design.pixel_grid(ch);
    let (first, rows) = match window {
        None => (0, rows as usize),
        Some(w) => {
            let (start, stop) = check_row_window(rows as usize, w)?;
            (start, stop - start)
        }
    };
    let n = rows as u128 * cols as u128;
    memory::check(
        "chief_samples",
        n.saturating_mul(CHIEF_BYTES_PER_PIXEL) + tables_bytes(ch),
    )?;
    Ok((channel as usize - 1, first, rows, cols as usize))
}

/// Every pixel's chief sample on the plane at depth z, its lens, type and lit flag,
/// written into `out` (rows in parallel, interruptible between chunks of rows).
pub fn chief_samples_into(
    design: &Design,
    channel: i64,
    z: f64,
    out: ChiefSamplesOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    chief_samples_rows_into(design, channel, z, None, out, n_threads)
}

/// Validate a window of pixel rows `[start, stop)` of a grid of `rows` rows: it must lie
/// in the grid and not be empty. Returns (start, stop).
pub fn check_row_window(rows: usize, window: (i64, i64)) -> Result<(usize, usize)> {
    let rows = rows as i64;
    let (start, stop) = window;
    if !(0 <= start && start < stop && stop <= rows) {
        return Err(Error::param(
            "rows",
            format!("({start}, {stop})"),
            format!("(start, stop) with 0 <= start < stop <= {rows} (the channel's pixel rows)"),
        ));
    }
    Ok((start as usize, stop as usize))
}

/// [`chief_samples_into`] for the pixel rows `[start, stop)` of the channel only (all
/// rows for `None`): the outputs hold (stop − start) × columns pixels, row `start` first.
/// Every value is that of the whole grid's call, bit for bit (the rows are independent).
pub fn chief_samples_rows_into(
    design: &Design,
    channel: i64,
    z: f64,
    window: Option<(i64, i64)>,
    out: ChiefSamplesOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    let (index, first, rows, cols) = check_chief_rows(design, channel, z, n_threads, window)?;
    let n = rows * cols;
    let lens = [
        out.x.len(),
        out.y.len(),
        out.lit.len(),
        out.lens.len() / 2,
        out.types.len(),
    ];
    if lens.iter().any(|&l| l != n) || out.lens.len() != 2 * n {
        return Err(Error::param(
            "output length",
            format!("{lens:?}"),
            format!("{n} pixels ({rows} rows x {cols} columns)"),
        ));
    }
    if n == 0 {
        return Ok(());
    }
    let ch = &design.channels[index];
    let t = Tables::new(design, ch)?;
    let zc = design.conjugate(z);
    let (g, s) = (z / ch.l, (ch.l - zc) / zc);
    let mut colx = Vec::new();
    if let PixelTables::Sensor(sen) = &t.px {
        t.columns_x(sen, g, s, &mut colx)?;
    }
    let colx = &colx[..];
    let step = chunk_items(n_threads, 12 * cols as u128).max(1);
    let ChiefSamplesOut {
        x,
        y,
        lit,
        lens,
        types,
    } = out;
    for_chunks(n_threads, rows, step, |r| {
        let (lo, hi) = (r.start * cols, r.end * cols);
        (
            x[lo..hi].par_chunks_mut(cols),
            y[lo..hi].par_chunks_mut(cols),
            lit[lo..hi].par_chunks_mut(cols),
            lens[2 * lo..2 * hi].par_chunks_mut(2 * cols),
            types[lo..hi].par_chunks_mut(cols),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(i, (x, y, lit, lens, types))| {
                let out = RowOut {
                    x,
                    y,
                    lit,
                    lens,
                    types,
                };
                t.fill_row(first + r.start + i, g, s, colx, out);
            });
        Ok(())
    })
}

/// [`chief_samples_into`] with its own (fallibly allocated) outputs.
pub fn chief_samples(
    design: &Design,
    channel: i64,
    z: f64,
    n_threads: Option<usize>,
) -> Result<ChiefSamples> {
    let (_, rows, cols) = check_chief_samples(design, channel, z, n_threads)?;
    let n = rows * cols;
    let what = "chief_samples";
    let mut r = ChiefSamples {
        rows,
        cols,
        x: try_vec(what, n, 0.0)?,
        y: try_vec(what, n, 0.0)?,
        lit: try_vec(what, n, false)?,
        lens: try_vec(what, 2 * n, 0)?,
        types: try_vec(what, n, 0)?,
    };
    let out = ChiefSamplesOut {
        x: &mut r.x,
        y: &mut r.y,
        lit: &mut r.lit,
        lens: &mut r.lens,
        types: &mut r.types,
    };
    chief_samples_into(design, channel, z, out, n_threads)?;
    Ok(r)
}

// ---- distinct samples: hash grid and union-find --------------------------------------

/// Two samples are one when both coordinates differ by less than eps.
#[inline]
fn linked(a: [f64; 2], b: [f64; 2], eps: f64) -> bool {
    (a[0] - b[0]).abs() < eps && (a[1] - b[1]).abs() < eps
}

/// (X, Y) lexicographic order: the representative is the least member.
#[inline]
fn before(a: [f64; 2], b: [f64; 2]) -> bool {
    a[0] < b[0] || (a[0] == b[0] && a[1] < b[1])
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

fn unite(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// One occupied hash-grid cell: its key, its members (a range of the sorted cell list),
/// whether they are pairwise linked (a clique) and their bounding box.
#[derive(Debug, Clone, Copy)]
struct Cell {
    key: (i64, i64),
    start: u32,
    end: u32,
    clique: bool,
    lo: [f64; 2],
    hi: [f64; 2],
}

/// Reusable buffers of [`components`].
#[derive(Debug, Default)]
struct CompWork {
    keys: Vec<(i64, i64, u32)>,
    parent: Vec<u32>,
    cells: Vec<Cell>,
    best: Vec<u32>,
    touch: Vec<bool>,
}

/// Connected components of the relation [`linked`] (eps > 0) over `pts`: hash grid of
/// cell eps (1 + CELL_SLACK), union-find over members of the same and the adjacent cells.
/// Writes one (representative index, touching) per component to `reps`, where a component
/// touches when one of its members has Chebyshev excess over the field above `band`.
fn components(
    pts: &[[f64; 2]],
    eps: f64,
    field: [f64; 2],
    band: f64,
    w: &mut CompWork,
    reps: &mut Vec<(u32, bool)>,
) -> Result<()> {
    let what = "coverage (union-find buffers)";
    let n = pts.len();
    reps.clear();
    let cell = eps * (1.0 + CELL_SLACK);
    w.keys.clear();
    try_reserve(&mut w.keys, what, n)?;
    w.keys.extend(pts.iter().enumerate().map(|(i, p)| {
        (
            (p[0] / cell).floor() as i64,
            (p[1] / cell).floor() as i64,
            i as u32,
        )
    }));
    w.keys.sort_unstable();
    parallel::checkpoint()?;
    w.parent.clear();
    try_reserve(&mut w.parent, what, n)?;
    w.parent.extend(0..n as u32);
    // Cells: runs of equal keys.
    w.cells.clear();
    let mut i = 0;
    while i < n {
        let key = (w.keys[i].0, w.keys[i].1);
        let mut e = i;
        let (mut lo, mut hi) = (pts[w.keys[i].2 as usize], pts[w.keys[i].2 as usize]);
        while e < n && (w.keys[e].0, w.keys[e].1) == key {
            let p = pts[w.keys[e].2 as usize];
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
            e += 1;
        }
        // Members differ by at most the box's extents: below eps, every pair is linked.
        let clique = hi[0] - lo[0] < eps && hi[1] - lo[1] < eps;
        w.cells.push(Cell {
            key,
            start: i as u32,
            end: e as u32,
            clique,
            lo,
            hi,
        });
        i = e;
    }
    let (keys, parent, cells) = (&w.keys, &mut w.parent, &w.cells);
    let member = |i: u32| keys[i as usize].2;
    // Within each cell.
    for c in cells.iter() {
        if c.clique {
            for i in c.start + 1..c.end {
                unite(parent, member(c.start), member(i));
            }
        } else {
            for i in c.start..c.end {
                for k in i + 1..c.end {
                    let (a, b) = (member(i), member(k));
                    if linked(pts[a as usize], pts[b as usize], eps) {
                        unite(parent, a, b);
                    }
                }
            }
        }
    }
    // Between a cell and its forward neighbours (kx, ky + 1), (kx + 1, ky − 1 ..= ky + 1):
    // every adjacent pair once. The cells are sorted by key, so the neighbours in column
    // kx + 1 are found by a pointer that only moves forward.
    let link_cells = |parent: &mut [u32], a: &Cell, b: &Cell| {
        let gap_x = (b.lo[0] - a.hi[0]).max(a.lo[0] - b.hi[0]);
        let gap_y = (b.lo[1] - a.hi[1]).max(a.lo[1] - b.hi[1]);
        if gap_x >= eps || gap_y >= eps {
            return;
        }
        let both = a.clique && b.clique;
        for i in a.start..a.end {
            for k in b.start..b.end {
                let (p, q) = (member(i), member(k));
                if linked(pts[p as usize], pts[q as usize], eps) {
                    unite(parent, p, q);
                    if both {
                        return;
                    }
                }
            }
        }
    };
    parallel::checkpoint()?;
    let mut ptr = 0;
    for (ci, c) in cells.iter().enumerate() {
        let (kx, ky) = c.key;
        if let Some(next) = cells.get(ci + 1) {
            if next.key == (kx, ky + 1) {
                link_cells(parent, c, next);
            }
        }
        let first = (kx + 1, ky - 1);
        while ptr < cells.len() && cells[ptr].key < first {
            ptr += 1;
        }
        let mut q = ptr;
        while q < cells.len() && cells[q].key <= (kx + 1, ky + 1) {
            link_cells(parent, c, &cells[q]);
            q += 1;
        }
    }
    // Representatives (least (X, Y)) and touching flags, per root.
    w.best.clear();
    try_reserve(&mut w.best, what, n)?;
    w.best.extend(0..n as u32);
    w.touch.clear();
    try_reserve(&mut w.touch, what, n)?;
    w.touch.resize(n, false);
    for i in 0..n as u32 {
        let r = find(parent, i) as usize;
        let p = pts[i as usize];
        if before(p, pts[w.best[r] as usize]) {
            w.best[r] = i;
        }
        if excess(p, field) > band {
            w.touch[r] = true;
        }
    }
    try_reserve(reps, what, n)?;
    for i in 0..n as u32 {
        if parent[i as usize] == i {
            reps.push((w.best[i as usize], w.touch[i as usize]));
        }
    }
    Ok(())
}

/// Chebyshev distance by which p lies outside the field |X| ≤ h_x, |Y| ≤ h_y (≤ 0 inside).
#[inline]
fn excess(p: [f64; 2], field: [f64; 2]) -> f64 {
    (p[0].abs() - field[0]).max(p[1].abs() - field[1])
}

// ---- covering radius -------------------------------------------------------------------

/// Items of a long serial loop between two interrupt checkpoints.
const CHECK_ITEMS: usize = 1 << 16;

type Tri = DelaunayTriangulation<Point2<f64>, (), (), (), HierarchyHintGenerator<f64>>;

#[inline]
fn dist(p: [f64; 2], q: Point2<f64>) -> f64 {
    ((p[0] - q.x).powi(2) + (p[1] - q.y).powi(2)).sqrt()
}

#[inline]
fn flush(x: f64) -> f64 {
    if x.abs() < FLUSH {
        0.0
    } else {
        x
    }
}

/// The covering radius of the box |x| ≤ field[0], |y| ≤ field[1] by `points`: the largest
/// distance from a point of the box to its nearest point of the set (+∞ for an empty set).
///
/// The distance function's maximum over the box lies at a Voronoi vertex inside it, where
/// a Voronoi edge crosses its boundary, or at a corner. The candidates are: the Delaunay
/// circumcentres inside the box (clamped in when they lie within rounding of its edge),
/// the crossings of each Delaunay edge's perpendicular bisector with the four sides, kept
/// where they lie on the edge's Voronoi segment (between the circumcentres of its two
/// faces, or the ray / line of a hull edge; widened by a relative 1e-6 against rounding),
/// and the four corners. Every candidate is a point of the box, and the distance to the
/// nearest point is evaluated there exactly (spade's nearest-neighbour walk), so extra
/// candidates never change the result. They are visited in decreasing order of an upper
/// bound (the distance to a point of the set that defines them), stopping when no bound
/// exceeds the best found by more than [`PRUNE_RTOL`].
///
/// No triangles (one point, two, or all collinear) needs no special case: the bisectors
/// of the hull's edges are whole lines then, and the corners are always candidates.
pub fn covering_radius(points: &[[f64; 2]], field: [f64; 2]) -> Result<f64> {
    if points.is_empty() {
        return Ok(f64::INFINITY);
    }
    let what = "covering radius (triangulation)";
    let mut verts = Vec::new();
    try_reserve(&mut verts, what, points.len())?;
    verts.extend(points.iter().map(|p| Point2::new(flush(p[0]), flush(p[1]))));
    // Seconds for millions of points, in spade, with no checkpoint: then on a thread of its
    // own (the call can stop meanwhile).
    let tri = if verts.len() >= CHECK_ITEMS {
        parallel::detached(move || Tri::bulk_load(verts))?
    } else {
        Tri::bulk_load(verts)
    };
    let tri = tri.map_err(|e| {
        Error::param(
            "samples",
            format!("a set spade cannot triangulate ({e:?})"),
            "finite sample coordinates",
        )
    })?;
    let nearest = |p: [f64; 2]| -> f64 {
        tri.nearest_neighbor(Point2::new(p[0], p[1]))
            .map_or(f64::INFINITY, |v| dist(p, v.position()))
    };
    let [hx, hy] = field;
    let mut best = [[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]]
        .into_iter()
        .map(nearest)
        .fold(0.0, f64::max);
    // Circumcentres, indexed by face (index 0 is the outer face).
    let mut centres: Vec<[f64; 2]> = Vec::new();
    try_reserve(&mut centres, what, tri.num_all_faces())?;
    centres.resize(tri.num_all_faces(), [f64::NAN; 2]);
    let mut cand: Vec<(f64, [f64; 2])> = Vec::new();
    try_reserve(&mut cand, what, tri.num_inner_faces() + 4)?;
    let near_box = |c: f64, h: f64| c.abs() <= h + 1e-12 * (h + c.abs());
    for (i, f) in tri.inner_faces().enumerate() {
        if i % CHECK_ITEMS == 0 {
            parallel::checkpoint()?;
        }
        let c = f.circumcenter();
        let c = [c.x, c.y];
        centres[f.fix().index()] = c;
        if near_box(c[0], hx) && near_box(c[1], hy) {
            let p = [c[0].clamp(-hx, hx), c[1].clamp(-hy, hy)];
            let u = f
                .vertices()
                .iter()
                .map(|v| dist(p, v.position()))
                .fold(f64::INFINITY, f64::min);
            cand.push((u, p));
        }
    }
    const T_SLACK: f64 = 1e-6;
    for (i, e) in tri.undirected_edges().enumerate() {
        if i % CHECK_ITEMS == 0 {
            parallel::checkpoint()?;
        }
        let d = e.as_directed();
        let (a, b) = (d.from().position(), d.to().position());
        let mid = [(a.x + b.x) / 2.0, (a.y + b.y) / 2.0];
        // The bisector mid + t·dir, dir the left normal of a → b (spade's face() is the
        // face to the left of a directed edge).
        let dir = [-(b.y - a.y), b.x - a.x];
        let len2 = dir[0] * dir[0] + dir[1] * dir[1];
        let t_of = |c: [f64; 2]| ((c[0] - mid[0]) * dir[0] + (c[1] - mid[1]) * dir[1]) / len2;
        let left = d.face().as_inner().map(|f| t_of(centres[f.fix().index()]));
        let right = d
            .rev()
            .face()
            .as_inner()
            .map(|f| t_of(centres[f.fix().index()]));
        // The Voronoi segment; a hull edge's runs away from its inner face to infinity.
        let (lo, hi) = match (left, right) {
            (Some(l), Some(r)) => (l.min(r), l.max(r)),
            (Some(l), None) => (f64::NEG_INFINITY, l),
            (None, Some(r)) => (r, f64::INFINITY),
            (None, None) => (f64::NEG_INFINITY, f64::INFINITY),
        };
        let (lo, hi) = (
            lo - T_SLACK * (1.0 + lo.abs()),
            hi + T_SLACK * (1.0 + hi.abs()),
        );
        for (axis, side) in [(0, -hx), (0, hx), (1, -hy), (1, hy)] {
            let other = 1 - axis;
            if dir[axis] == 0.0 {
                continue;
            }
            let t = (side - mid[axis]) / dir[axis];
            if !(t >= lo && t <= hi) {
                continue;
            }
            let v = mid[other] + t * dir[other];
            if !near_box(v, field[other]) {
                continue;
            }
            let mut p = [0.0; 2];
            p[axis] = side;
            p[other] = v.clamp(-field[other], field[other]);
            cand.push((dist(p, a), p));
        }
    }
    // Evaluate the candidate of largest bound, keep only those that can still beat the
    // best, then visit them in decreasing order of bound.
    if let Some(&(_, p)) = cand.iter().max_by(|x, y| x.0.total_cmp(&y.0)) {
        best = best.max(nearest(p));
    }
    cand.retain(|c| c.0 > best * (1.0 + PRUNE_RTOL));
    cand.sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
    for (i, &(u, p)) in cand.iter().enumerate() {
        if u <= best * (1.0 + PRUNE_RTOL) {
            break;
        }
        if i % CHECK_ITEMS == 0 {
            parallel::checkpoint()?;
        }
        best = best.max(nearest(p));
    }
    Ok(best)
}

// ---- separable channels ----------------------------------------------------------------

/// The representatives of values linked when they differ by less than eps (chains of
/// sorted values): each chain's least value. Sorts `v` and leaves the representatives.
fn reps_1d(v: &mut Vec<f64>, eps: f64) {
    v.sort_unstable_by(f64::total_cmp);
    let mut out = 0;
    for i in 0..v.len() {
        if i == 0 || v[i] - v[i - 1] >= eps {
            v[out] = v[i];
            out += 1;
        }
    }
    v.truncate(out);
}

/// The covering radius of [−h, h] by the sorted values `r`: the distance to the nearest
/// value is largest at an end of the interval or halfway between two consecutive values.
fn cover_1d(r: &[f64], h: f64) -> f64 {
    if r.is_empty() {
        return f64::INFINITY;
    }
    let at = |x: f64| {
        let i = r.partition_point(|&v| v < x);
        let hi = r.get(i).map_or(f64::INFINITY, |&v| v - x);
        let lo = if i > 0 { x - r[i - 1] } else { f64::INFINITY };
        hi.min(lo)
    };
    let mut best = at(-h).max(at(h));
    for p in r.windows(2) {
        let mid = p[0] + (p[1] - p[0]) / 2.0;
        if mid >= -h && mid <= h {
            best = best.max((mid - p[0]).min(p[1] - mid));
        }
    }
    best
}

/// A channel whose lit samples form a Cartesian product: the ideal layout (X depends on
/// the column only, Y on the row only) behind a square aperture (a pixel is lit when
/// |w_x| < D/2 and |w_y| < D/2, one condition per axis). Then two samples are linked when
/// their X values and their Y values are, the components are products of the 1-D chains,
/// each represented by (least X, least Y), the distinct count is the product of the 1-D
/// counts inside the field, and the squared distance to the nearest representative is the
/// sum of the 1-D squared distances, so ρ² = ρ_x² + ρ_y² with ρ_x, ρ_y the 1-D covering
/// radii of [−h_x, h_x] and [−h_y, h_y]. Exact over every pixel, no margin needed.
/// None for any other channel.
fn separable_row(
    t: &Tables<'_>,
    g: f64,
    s: f64,
    geom: &DepthGeom,
    keep: Option<&mut Vec<[f64; 2]>>,
) -> Result<Option<RowResult>> {
    let PixelTables::Ideal { w, .. } = &t.px else {
        return Ok(None);
    };
    if t.design.shape != crate::model::design::Aperture::Square {
        return Ok(None);
    }
    let r = t.design.aperture / 2.0;
    let what = "coverage (separable channel)";
    let axis = |c: &[f64]| -> Result<Vec<f64>> {
        let mut v = Vec::new();
        try_reserve(&mut v, what, c.len() * w.len())?;
        for &cj in c {
            // As Tables::sample: −g (c + w s), lit pixels only.
            v.extend(
                w.iter()
                    .filter(|wq| wq.abs() < r)
                    .map(|&wq| -g * (cj + wq * s)),
            );
        }
        Ok(v)
    };
    let (mut xs, mut ys) = (axis(&t.cx[0])?, axis(&t.cy)?);
    if xs.is_empty() || ys.is_empty() {
        if let Some(out) = keep {
            out.clear();
        }
        return Ok(Some(RowResult::default()));
    }
    reps_1d(&mut xs, geom.eps);
    reps_1d(&mut ys, geom.eps);
    let [hx, hy] = geom.field;
    let inside = |v: &[f64], h: f64| {
        let lo = v.partition_point(|&x| x < -h);
        let hi = v.partition_point(|&x| x <= h);
        lo..hi.max(lo)
    };
    let (ix, iy) = (inside(&xs, hx), inside(&ys, hy));
    let distinct = (ix.len() * iy.len()) as u64;
    let (rx, ry) = (cover_1d(&xs, hx), cover_1d(&ys, hy));
    let rho_mm = (rx * rx + ry * ry).sqrt();
    if let Some(out) = keep {
        out.clear();
        try_reserve(out, "samples_2d (representatives)", distinct as usize)?;
        for &x in &xs[ix] {
            out.extend(ys[iy.clone()].iter().map(|&y| [x, y]));
        }
    }
    Ok(Some(RowResult {
        distinct,
        rho: rho_mm / geom.delta,
        rho_mm,
    }))
}

// ---- one depth -------------------------------------------------------------------------

/// Results of one row (a channel, or the union) at one depth.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RowResult {
    distinct: u64,
    /// ρ in δ(z) and in mm.
    rho: f64,
    rho_mm: f64,
}

impl Default for RowResult {
    fn default() -> Self {
        RowResult {
            distinct: 0,
            rho: f64::INFINITY,
            rho_mm: f64::INFINITY,
        }
    }
}

/// A validated call: the design, its channel tables, tolerance and window.
struct Ctx<'a> {
    design: &'a Design,
    tables: Vec<Tables<'a>>,
    tol: f64,
    window: f64,
    /// Use the separable computation for channels whose samples are a Cartesian product
    /// (see [`separable_row`]); off only to test it against the general one.
    separable: bool,
    /// Give a one-channel design's union row the channel row's result instead of
    /// computing it again on the same samples (see [`rows_from`]); off only to test it.
    union_is_channel: bool,
    /// Try a pass at [`TRIAL_MARGIN`] before the first margin (see [`row_pass`]); off
    /// only to test it.
    trial: bool,
}

/// The geometry of one depth.
struct DepthGeom {
    delta: f64,
    eps: f64,
    field: [f64; 2],
    /// Per channel: z/L and (L − z')/z'.
    gs: Vec<(f64, f64)>,
    /// A margin at which every lit sample of every channel lies within the bounds.
    complete: f64,
    /// The first margin: two lens pitches (the largest of the channels) on the plane.
    first: f64,
    /// The trial pass's margin, [`TRIAL_MARGIN`] δ.
    trial: f64,
}

impl<'a> Ctx<'a> {
    fn geom(&self, z: f64) -> DepthGeom {
        let zc = self.design.conjugate(z);
        let delta = self.design.resolution_step(z);
        let field = self.design.central_field(z, self.window);
        let mut complete = 0.0f64;
        let mut first = 0.0f64;
        let mut gs = Vec::with_capacity(self.tables.len());
        for t in &self.tables {
            let (g, s) = (z / t.ch.l, (t.ch.l - zc) / zc);
            gs.push((g, s));
            let ext = t.sample_extent(g, s);
            complete = complete.max(ext[0] - field[0]).max(ext[1] - field[1]);
            first = first.max(2.0 * t.ch.d * g);
        }
        DepthGeom {
            delta,
            eps: self.tol * delta,
            field,
            gs,
            complete: complete.max(0.0),
            first,
            trial: TRIAL_MARGIN * delta,
        }
    }

    /// Upper bound on the samples a pass at margin m gathers (all channels).
    fn pass_samples(&self, geom: &DepthGeom, m: f64) -> u128 {
        let b = [geom.field[0] + m, geom.field[1] + m];
        self.tables
            .iter()
            .zip(&geom.gs)
            .map(|(t, &(g, s))| t.pass_pixels(g, s, b[0], b[1]))
            .sum()
    }
}

/// Reusable buffers of one worker.
#[derive(Debug, Default)]
struct Work {
    pts: Vec<[f64; 2]>,
    /// Start of each channel's samples in `pts` (and the end of the last).
    offsets: Vec<usize>,
    idx: (Vec<u32>, Vec<u32>, Vec<ColumnX>),
    comp: CompWork,
    reps: Vec<(u32, bool)>,
    band: Vec<[f64; 2]>,
}

/// The outcome of one pass over one row: its result when provably exact, else the margin
/// to try next (or, for a trial pass, that it cannot stand for the first pass).
enum Pass {
    Exact(RowResult),
    Widen(f64),
    Reject,
}

/// One row at margin m over its samples `pts` (every lit sample within Chebyshev distance
/// m of the field; `complete`: every lit sample). Fills `field_reps` (when given) with the
/// representatives inside the field.
///
/// `trial`: a pass narrower than the first margin, accepted only when its result is bit
/// for bit the one the first margin gives ([`Pass::Reject`] otherwise, before any
/// triangulation it can avoid): no component touches the margin's edge, so every component
/// it holds is a complete component of the full sample set with its true representative,
/// and every margin m1 of the covering radius stays below m and below the farthest
/// representative. Then the representatives within m1 of the field (the set triangulated,
/// in the same order: gathers keep the samples' relative order) are those of any wider
/// pass — a component with a member within m1 < m of the field lies wholly inside this
/// pass, else it would touch its edge — so each m1 step sees the same points, the same ρ
/// and the same next m1, and the distinct count is the same.
fn row_pass(
    pts: &[[f64; 2]],
    geom: &DepthGeom,
    m: f64,
    complete: bool,
    trial: bool,
    w: &mut Work,
    field_reps: Option<&mut Vec<[f64; 2]>>,
) -> Result<Pass> {
    let (field, eps, delta) = (geom.field, geom.eps, geom.delta);
    // A member within 3 eps of the margin's edge may be linked to a sample beyond it.
    let band = if complete {
        f64::INFINITY
    } else {
        m - 3.0 * eps
    };
    let mut reps = std::mem::take(&mut w.reps);
    components(pts, eps, field, band, &mut w.comp, &mut reps)?;
    if trial && reps.iter().any(|&(_, touching)| touching) {
        w.reps = reps;
        return Ok(Pass::Reject);
    }
    // m2: every representative that may be wrong (of a touching component) lies at least
    // m2 from the field; the true and the computed representatives agree closer than that.
    let mut m2 = if complete { f64::INFINITY } else { m };
    let mut distinct = 0u64;
    let mut near = 0.0f64; // largest excess of any representative
    for &(r, touching) in &reps {
        let e = excess(pts[r as usize], field);
        near = near.max(e);
        if touching {
            m2 = m2.min(e);
        }
        if e <= 0.0 {
            distinct += 1;
        }
    }
    // The covering radius from the representatives within an inner margin m1, widened
    // until ρ < m1 (then no representative beyond m1 is nearest to any field point).
    let area = 4.0 * field[0] * field[1];
    let spacing = (area / distinct.max(1) as f64).sqrt();
    let mut m1 = if distinct > 0 { 4.0 * spacing } else { m };
    let rho = loop {
        let all = m1 >= near;
        if trial && (all || m1 >= m) {
            w.reps = reps;
            return Ok(Pass::Reject);
        }
        w.band.clear();
        try_reserve(&mut w.band, "coverage (representatives)", reps.len())?;
        w.band.extend(
            reps.iter()
                .map(|&(r, _)| pts[r as usize])
                .filter(|&p| all || excess(p, field) <= m1)
                .map(|p| [p[0] / delta, p[1] / delta]),
        );
        let rho = covering_radius(&w.band, [field[0] / delta, field[1] / delta])?;
        if all || rho * delta * (1.0 + 1e-9) < m1 {
            break rho;
        }
        m1 = if rho.is_finite() {
            (2.0 * m1).max(2.0 * rho * delta)
        } else {
            4.0 * m1
        };
    };
    let exact = complete || rho * delta * (1.0 + 1e-9) < m2;
    if trial && !exact {
        w.reps = reps;
        return Ok(Pass::Reject);
    }
    if !exact {
        let next = if rho.is_finite() {
            (2.0 * m).max(3.0 * rho * delta)
        } else {
            4.0 * m
        };
        w.reps = reps;
        return Ok(Pass::Widen(next));
    }
    if let Some(out) = field_reps {
        parallel::checkpoint()?;
        out.clear();
        try_reserve(out, "samples_2d (representatives)", distinct as usize)?;
        out.extend(
            reps.iter()
                .map(|&(r, _)| pts[r as usize])
                .filter(|&p| excess(p, field) <= 0.0),
        );
        out.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    }
    w.reps = reps;
    Ok(Pass::Exact(RowResult {
        distinct,
        rho,
        rho_mm: rho * delta,
    }))
}

/// Every row (channels, then the union) at depth z. `keep`: the field's representatives
/// of each row (samples_2d).
fn depth_rows(
    ctx: &Ctx<'_>,
    z: f64,
    w: &mut Work,
    keep: Option<&mut Vec<Vec<[f64; 2]>>>,
    check_between: bool,
) -> Result<Vec<RowResult>> {
    let geom = ctx.geom(z);
    rows_from(ctx, &geom, geom.first, w, keep, check_between)
}

/// [`depth_rows`] from the first margin `first`.
fn rows_from(
    ctx: &Ctx<'_>,
    geom: &DepthGeom,
    first: f64,
    w: &mut Work,
    mut keep: Option<&mut Vec<Vec<[f64; 2]>>>,
    check_between: bool,
) -> Result<Vec<RowResult>> {
    let n_ch = ctx.tables.len();
    let n_rows = n_ch + 1;
    let mut done: Vec<Option<RowResult>> = vec![None; n_rows];
    for (r, (t, &(g, s))) in ctx.tables.iter().zip(&geom.gs).enumerate() {
        if ctx.separable {
            let slot = keep.as_deref_mut().map(|k| &mut k[r]);
            done[r] = separable_row(t, g, s, geom, slot)?;
        }
    }
    // One channel computed by the general path: the union is the same sample set at the
    // same margin, so its pass is the channel's, result for result (not recomputed).
    let union_is_channel = ctx.union_is_channel && n_ch == 1 && done[0].is_none();
    // First a trial pass at a narrower margin: the rows it settles have the first margin's
    // result bit for bit (see row_pass); the others go on from the first margin.
    let mut trial = ctx.trial && geom.trial < first && geom.trial < geom.complete;
    let mut m = if trial { geom.trial } else { first };
    let mut pass = 0;
    loop {
        let complete = m >= geom.complete;
        let m_pass = if complete { m.max(geom.complete) } else { m };
        if pass > 0 {
            // A wider pass than the one checked up front: check its memory now.
            let n = ctx.pass_samples(geom, m_pass);
            memory::check(
                "coverage (a wider pass: samples near the field)",
                n.saturating_mul(SAMPLE_BYTES),
            )?;
            if check_between {
                parallel::checkpoint()?;
            }
        }
        let bounds = [geom.field[0] + m_pass, geom.field[1] + m_pass];
        w.pts.clear();
        w.offsets.clear();
        for (t, &(g, s)) in ctx.tables.iter().zip(&geom.gs) {
            w.offsets.push(w.pts.len());
            t.gather(g, s, bounds, &mut w.idx, &mut w.pts)?;
        }
        w.offsets.push(w.pts.len());
        let mut next = 0.0f64;
        for r in 0..n_rows {
            if done[r].is_some() {
                continue;
            }
            if r == n_ch && union_is_channel {
                // Row 0 ran just before on the same points: exact now or widening.
                if let Some(res) = done[0] {
                    if let Some(k) = keep.as_deref_mut() {
                        let (chan, union) = k.split_at_mut(1);
                        union[0].clear();
                        try_reserve(&mut union[0], "samples_2d (representatives)", chan[0].len())?;
                        union[0].extend_from_slice(&chan[0]);
                    }
                    done[r] = Some(res);
                }
                continue;
            }
            let range = if r < n_ch {
                w.offsets[r]..w.offsets[r + 1]
            } else {
                0..w.pts.len()
            };
            let pts = std::mem::take(&mut w.pts);
            let slot = keep.as_deref_mut().map(|k| &mut k[r]);
            let outcome = row_pass(&pts[range], geom, m_pass, complete, trial, w, slot);
            w.pts = pts;
            match outcome? {
                Pass::Exact(res) => done[r] = Some(res),
                Pass::Widen(to) => next = next.max(to),
                Pass::Reject => {}
            }
        }
        if done.iter().all(Option::is_some) {
            return Ok(done.into_iter().map(Option::unwrap_or_default).collect());
        }
        if trial {
            // The first pass proper, as without the trial.
            trial = false;
            m = first;
            continue;
        }
        // Never reached when complete: a complete pass is always exact.
        m = next.max(2.0 * m);
        pass += 1;
    }
}

// ---- validation ------------------------------------------------------------------------

/// Validate the merge tolerance of the 2-D distinct samples: [`check_tol`] (finite,
/// ≥ 0), then > 0 (the relation is strict: with 0 nothing merges, not even coincident
/// samples) and at most [`MAX_TOL_2D`].
pub fn check_tol_2d(tol: f64) -> Result<f64> {
    let tol = check_tol(tol)?;
    if tol > 0.0 && tol <= MAX_TOL_2D {
        Ok(tol)
    } else {
        Err(Error::param(
            "tol",
            tol,
            format!(
                "a number in (0, {MAX_TOL_2D}] (a multiple of delta(z); two samples merge when \
                 both coordinates differ by less than tol * delta(z))"
            ),
        ))
    }
}

/// Validate the window (width of the 2-D central field in lens pitches of channel 1).
pub fn check_window(window: f64) -> Result<f64> {
    if window.is_finite() && window > 0.0 {
        Ok(window)
    } else {
        Err(Error::param(
            "window",
            window,
            "a finite number > 0 (the central field's width in lens pitches of channel 1)",
        ))
    }
}

/// The hash grid's cell indices |X| / (tol δ) must stay below [`MAX_CELL_INDEX`] for every
/// sample at every depth, and tol δ must be a normal number.
fn check_cells(design: &Design, z: &[f64], tol: f64) -> Result<()> {
    let mut worst = 0.0f64;
    for &zi in z {
        let zc = design.conjugate(zi);
        let delta = design.resolution_step(zi);
        let eps = tol * delta;
        if !(eps.is_normal() && eps > 0.0) {
            return Err(Error::param(
                "tol",
                tol,
                format!("a tolerance whose tol * delta(z) is a normal number (delta({zi}) = {delta} mm)"),
            ));
        }
        for ch in &design.channels {
            let cmax = {
                let a = ch.lens_center(0, 0);
                let b = ch.lens_center(ch.kx - 1, ch.ky - 1);
                let c = ch.lens_center(ch.kx - 1, ch.ky.min(2) - 1);
                let d = ch.lens_center(0, ch.ky.min(2) - 1);
                [a, b, c, d]
                    .iter()
                    .map(|p| p[0].abs().max(p[1].abs()))
                    .fold(0.0, f64::max)
            };
            let (g, s) = (zi / ch.l, (ch.l - zc) / zc);
            let extent = g * (cmax + design.aperture / 2.0 * s.abs());
            worst = worst.max(extent / eps);
        }
    }
    if worst * (1.0 + 1e-6) > MAX_CELL_INDEX {
        let need = tol * worst / MAX_CELL_INDEX * 1.01;
        return Err(Error::param(
            "tol",
            tol,
            format!(
                "at least {} for this design at these depths (its samples reach {} tol*delta(z) \
                 from the axis; at most 2^42 hash-grid cells are allowed)",
                crate::infra::error::short_number(need),
                crate::infra::error::short_number(worst)
            ),
        ));
    }
    Ok(())
}

/// Pixels of every channel.
fn all_pixels(design: &Design) -> u128 {
    design.channels.iter().map(|c| c.pixel_count()).sum()
}

/// Validate a coverage (or samples_2d) call before any work: threads, tolerance, window,
/// depths, the hash grid's range, the work limit and the memory of the first pass of
/// every depth on `threads` workers. Returns (tol, window).
fn check_coverage(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    n_threads: Option<usize>,
    what: &str,
) -> Result<(f64, f64)> {
    parallel::check_threads(n_threads)?;
    let tol = check_tol_2d(tol)?;
    let window = check_window(window)?;
    check_design_depths(design.f_main, z)?;
    check_cells(design, z, tol)?;
    let work = all_pixels(design).saturating_mul(z.len() as u128);
    if work > MAX_COVERAGE_WORK {
        return Err(Error::TooMuchWork {
            what: format!(
                "{what} over {} pixels of {} channels at {} depths",
                all_pixels(design),
                design.channels.len(),
                z.len()
            ),
            amount: work,
            limit: MAX_COVERAGE_WORK,
            unit: "pixel-depths",
        });
    }
    Ok((tol, window))
}

/// Bytes of the tables of every channel.
fn all_tables_bytes(design: &Design) -> u128 {
    design.channels.iter().map(tables_bytes).sum()
}

fn context<'a>(design: &'a Design, tol: f64, window: f64) -> Result<Ctx<'a>> {
    let tables = design
        .channels
        .iter()
        .map(|ch| Tables::new(design, ch))
        .collect::<Result<Vec<_>>>()?;
    Ok(Ctx {
        design,
        tables,
        tol,
        window,
        separable: true,
        union_is_channel: true,
        trial: true,
    })
}

// ---- entry points ----------------------------------------------------------------------

/// The distinct samples of one depth: per row (channels, then the union) the
/// representatives inside the central field sorted by X then Y ([X, Y] in mm), their
/// number and the covering radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples2d {
    pub samples: Vec<Vec<[f64; 2]>>,
    pub distinct: Vec<u64>,
    /// ρ in δ(z) units and in mm (+∞ when the field holds no sample).
    pub covering_radius: Vec<f64>,
    pub covering_radius_mm: Vec<f64>,
}

/// Distinct samples and covering radius at one depth (validated first; on the calling
/// thread, interruptible between passes).
pub fn samples_2d(design: &Design, z: f64, tol: f64, window: f64) -> Result<Samples2d> {
    let (tol, window) = check_coverage(design, &[z], tol, window, Some(1), "samples_2d")?;
    let ctx = context(design, tol, window)?;
    let geom = ctx.geom(z);
    let first = ctx.pass_samples(&geom, geom.first);
    memory::check(
        "samples_2d",
        all_tables_bytes(design) + first.saturating_mul(SAMPLE_BYTES),
    )?;
    let mut w = Work::default();
    let mut keep = vec![Vec::new(); design.channels.len() + 1];
    let rows = depth_rows(&ctx, z, &mut w, Some(&mut keep), true)?;
    Ok(Samples2d {
        samples: keep,
        distinct: rows.iter().map(|r| r.distinct).collect(),
        covering_radius: rows.iter().map(|r| r.rho).collect(),
        covering_radius_mm: rows.iter().map(|r| r.rho_mm).collect(),
    })
}

/// Distinct counts and covering radii at m depths: row-major (n_channels + 1, m) arrays,
/// rows the channels then the union. Owned (what [`coverage`] returns) or the caller's
/// buffers ([`CoverageOut`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage<U = Vec<u64>, F = Vec<f64>> {
    pub distinct: U,
    pub covering_radius: F,
    pub covering_radius_mm: F,
}

/// Output buffers of [`coverage_into`]. Any initial content: every element is written
/// once.
pub type CoverageOut<'a> = Coverage<&'a mut [u64], &'a mut [f64]>;

/// Bytes a coverage call at the depths `z` holds at its peak when every depth is settled by
/// its first pass: the outputs (24 bytes per row and depth), one chunk of per-depth
/// results, every channel's tables, and per worker the samples of the largest first pass
/// ([`SAMPLE_BYTES`] each). A depth that needs a wider pass checks that pass's memory
/// before it starts.
fn coverage_bytes(ctx: &Ctx<'_>, z: &[f64], workers: usize) -> u128 {
    let rows = ctx.tables.len() as u128 + 1;
    let m = z.len() as u128;
    let outputs = 24 * rows * m;
    let chunk = (24 * rows + 24) * m.min(1 << 20);
    let first = z
        .iter()
        .map(|&zi| {
            let g = ctx.geom(zi);
            ctx.pass_samples(&g, g.first)
        })
        .max()
        .unwrap_or(0);
    let per_worker = first.saturating_mul(SAMPLE_BYTES);
    outputs + chunk + all_tables_bytes(ctx.design) + (workers as u128).saturating_mul(per_worker)
}

/// Depths per parallel task of [`coverage_into`].
const CHUNK: usize = 1;

/// [`coverage`] written into caller-provided buffers. Validates everything first
/// (see [`check_coverage`] and [`coverage_bytes`]).
pub fn coverage_into(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    out: CoverageOut<'_>,
    n_threads: Option<usize>,
) -> Result<()> {
    let (tol, window) = check_coverage(design, z, tol, window, n_threads, "coverage")?;
    let rows = design.channels.len() + 1;
    let m = z.len();
    let lens = [
        out.distinct.len(),
        out.covering_radius.len(),
        out.covering_radius_mm.len(),
    ];
    if lens.iter().any(|&l| l != rows * m) {
        return Err(Error::param(
            "output length",
            format!("{lens:?}"),
            format!("{} ({rows} rows x m = {m} depths)", rows * m),
        ));
    }
    memory::check("coverage (channel tables)", all_tables_bytes(design))?;
    let ctx = context(design, tol, window)?;
    let workers = threads(n_threads).min(m.max(1));
    memory::check("coverage", coverage_bytes(&ctx, z, workers))?;
    // Elementary steps per depth: about the samples of a first pass.
    let cost = z
        .iter()
        .take(16)
        .map(|&zi| {
            let g = ctx.geom(zi);
            ctx.pass_samples(&g, g.first)
        })
        .max()
        .unwrap_or(1)
        .saturating_mul(64);
    let step = chunk_items(n_threads, cost).min(1 << 20);
    let mut res = try_vec(
        "coverage (per-depth results)",
        step.min(m),
        Vec::<RowResult>::new(),
    )?;
    for_chunks(n_threads, m, step, |r| {
        let res = &mut res[..r.len()];
        res.par_chunks_mut(CHUNK)
            .zip(z[r.clone()].par_chunks(CHUNK))
            .try_for_each_init(Work::default, |w, (rs, zs)| -> Result<()> {
                for (ri, &zi) in rs.iter_mut().zip(zs) {
                    *ri = depth_rows(&ctx, zi, w, None, false)?;
                }
                Ok(())
            })?;
        for (k, d) in r.zip(res.iter()) {
            for (row, v) in d.iter().enumerate() {
                out.distinct[row * m + k] = v.distinct;
                out.covering_radius[row * m + k] = v.rho;
                out.covering_radius_mm[row * m + k] = v.rho_mm;
            }
        }
        Ok(())
    })
}

/// Distinct 2-D samples inside the central field and the covering radius of each channel
/// and of the union at every depth (validated first), parallel over depths.
pub fn coverage(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    n_threads: Option<usize>,
) -> Result<Coverage> {
    let n = (design.channels.len() + 1) * z.len();
    let what = "coverage";
    let mut distinct = try_vec(what, n, 0)?;
    let mut radius = try_vec(what, n, 0.0)?;
    let mut radius_mm = try_vec(what, n, 0.0)?;
    let out = Coverage {
        distinct: &mut distinct[..],
        covering_radius: &mut radius[..],
        covering_radius_mm: &mut radius_mm[..],
    };
    coverage_into(design, z, tol, window, out, n_threads)?;
    Ok(Coverage {
        distinct,
        covering_radius: radius,
        covering_radius_mm: radius_mm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera::Camera;
    use crate::model::design::{Aperture, ChannelSpec};

    #[allow(clippy::too_many_arguments)]
    fn spec(
        l: f64,
        d: f64,
        v: f64,
        mu: f64,
        kx: i64,
        ky: i64,
        grid: Grid,
        f: Option<Vec<f64>>,
        layout: &str,
        q: Option<i64>,
        m: Option<(i64, i64)>,
    ) -> ChannelSpec {
        ChannelSpec {
            l,
            d,
            v,
            mu,
            kx,
            ky,
            grid,
            f,
            layout: layout.into(),
            q,
            mx: m.map(|m| m.0),
            my: m.map(|m| m.1),
            share: 0.5,
        }
    }

    /// One channel of 40 x 36 lenses of pitch `d` with Q = 1 pixel per lens (pixel pitch
    /// 0.01), behind a square main lens of aperture `aperture` (F = 50, L = 60, v = 0.3).
    fn one_pixel_lenses(aperture: f64, d: f64) -> Design {
        let channel = spec(
            60.0,
            d,
            0.3,
            0.01,
            40,
            36,
            Grid::Rect,
            None,
            "ideal",
            Some(1),
            None,
        );
        Design::new(50.0, aperture, Aperture::Square, &[channel]).unwrap()
    }

    /// Small designs of every kind: rect/hex, ideal/sensor, square/circle, several types,
    /// sensors wider than the array (pixels beyond its edge).
    fn designs() -> Vec<Design> {
        let hex3 = Some(vec![0.3, 0.31, 0.32]);
        vec![
            Design::new(
                50.0,
                10.0,
                Aperture::Circle,
                &[
                    spec(
                        60.0,
                        0.1,
                        0.3,
                        0.011,
                        9,
                        8,
                        Grid::Hex,
                        hex3.clone(),
                        "sensor",
                        None,
                        None,
                    ),
                    spec(
                        75.0,
                        0.1,
                        0.3,
                        0.013,
                        7,
                        6,
                        Grid::Hex,
                        None,
                        "sensor",
                        None,
                        Some((80, 70)),
                    ),
                ],
            )
            .unwrap(),
            Design::new(
                50.0,
                8.0,
                Aperture::Square,
                &[
                    spec(
                        60.0,
                        0.1,
                        0.4,
                        0.02,
                        6,
                        5,
                        Grid::Rect,
                        None,
                        "ideal",
                        Some(5),
                        None,
                    ),
                    spec(
                        70.0,
                        0.1,
                        0.4,
                        0.0125,
                        6,
                        5,
                        Grid::Rect,
                        Some(vec![0.35, 0.37]),
                        "ideal",
                        Some(8),
                        None,
                    ),
                ],
            )
            .unwrap(),
            Design::new(
                50.0,
                9.0,
                Aperture::Square,
                &[spec(
                    65.0,
                    0.12,
                    0.5,
                    0.017,
                    7,
                    4,
                    Grid::Rect,
                    hex3,
                    "sensor",
                    None,
                    Some((61, 40)),
                )],
            )
            .unwrap(),
            Design::new(
                40.0,
                12.0,
                Aperture::Circle,
                &[spec(
                    55.0,
                    0.15,
                    0.5,
                    0.01,
                    5,
                    1,
                    Grid::Hex,
                    None,
                    "sensor",
                    None,
                    None,
                )],
            )
            .unwrap(),
            // Pixel pitch a tenth of the image pitch (0.1 (1 + 0.3/60) / 10) and odd pixel
            // counts: pixel centres fall (within rounding) midway between two lens images,
            // the nearest-lens search's ties.
            Design::new(
                50.0,
                10.0,
                Aperture::Square,
                &[spec(
                    60.0,
                    0.1,
                    0.3,
                    0.01005,
                    8,
                    6,
                    Grid::Rect,
                    None,
                    "sensor",
                    None,
                    Some((81, 61)),
                )],
            )
            .unwrap(),
            small_camera().design(),
        ]
    }

    fn small_camera() -> Camera {
        let p = Camera::paper();
        Camera::new(
            80.0, 20.0, p.v1, 0.3866, p.d, p.v, p.mu, 15, 12, 9, None, None,
        )
        .unwrap()
    }

    #[test]
    fn chief_samples_are_design_pixels_bit_for_bit() {
        // Both paths of the nearest-lens search run: columns settled once (`sel`) and
        // columns within rounding of a tie (`amb`, every pixel compares both candidates).
        let (mut settled, mut ambiguous) = (0, 0);
        for d in designs() {
            for ch in &d.channels {
                if let PixelTables::Sensor(sen) = &Tables::new(&d, ch).unwrap().px {
                    ambiguous += sen.cols.iter().filter(|c| c.amb).count();
                    settled += sen.cols.iter().filter(|c| !c.amb).count();
                }
            }
        }
        assert!(settled > 0 && ambiguous > 0, "{settled} {ambiguous}");
        for d in designs() {
            for (i, ch) in d.channels.iter().enumerate() {
                for z in [d.f_main * 1.3, 300.0, 2000.0] {
                    let r = chief_samples(&d, i as i64 + 1, z, Some(2)).unwrap();
                    let (cols, rows) = d.pixel_grid(ch);
                    assert_eq!((r.rows, r.cols), (rows as usize, cols as usize));
                    let zc = d.conjugate(z);
                    let mut lit = 0;
                    for b in 0..rows {
                        for a in 0..cols {
                            let px = d.pixel(ch, a, b);
                            let o = b as usize * cols as usize + a as usize;
                            assert_eq!(r.lit[o], px.lit, "{a} {b}");
                            assert_eq!(
                                (r.lens[2 * o], r.lens[2 * o + 1]),
                                (px.j as i64, px.k as i64)
                            );
                            assert_eq!(r.types[o], px.t as i64);
                            if px.lit {
                                lit += 1;
                                let c = ch.lens_center(px.j, px.k);
                                let xy = Design::chief_sample(ch, c, ch.chief_w(px.theta), z, zc);
                                assert_eq!(r.x[o].to_bits(), xy[0].to_bits());
                                assert_eq!(r.y[o].to_bits(), xy[1].to_bits());
                            } else {
                                assert!(r.x[o].is_nan() && r.y[o].is_nan());
                            }
                        }
                    }
                    assert!(lit > 0);
                }
            }
        }
    }

    /// Brute-force components: O(n²) pairs, union-find.
    fn brute_components(pts: &[[f64; 2]], eps: f64) -> Vec<[f64; 2]> {
        let n = pts.len();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        for i in 0..n {
            for k in i + 1..n {
                if linked(pts[i], pts[k], eps) {
                    unite(&mut parent, i as u32, k as u32);
                }
            }
        }
        let mut best: Vec<Option<[f64; 2]>> = vec![None; n];
        for (i, &p) in pts.iter().enumerate() {
            let r = find(&mut parent, i as u32) as usize;
            if best[r].is_none_or(|b| before(p, b)) {
                best[r] = Some(p);
            }
        }
        let mut reps: Vec<[f64; 2]> = best.into_iter().flatten().collect();
        reps.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        reps
    }

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn components_equal_brute_force() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut w = CompWork::default();
        let mut reps = Vec::new();
        for case in 0..300 {
            let n = 1 + (rng.next() * 120.0) as usize;
            let eps = 0.05 + rng.next() * 0.3;
            // Clusters, chains along the axes and coincident points: every cell situation.
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|_| {
                    let c = (rng.next() * 6.0).floor();
                    match case % 3 {
                        0 => [
                            c * 0.7 + rng.next() * 0.4,
                            (c * 1.3) % 2.0 + rng.next() * 0.4,
                        ],
                        1 => [(rng.next() * 20.0).floor() * eps * 0.9, c * eps * 1.5],
                        _ => [
                            (rng.next() * 5.0).floor() * eps,
                            (rng.next() * 5.0).floor() * eps,
                        ],
                    }
                })
                .collect();
            components(&pts, eps, [1.0, 1.0], f64::INFINITY, &mut w, &mut reps).unwrap();
            let mut got: Vec<[f64; 2]> = reps.iter().map(|&(r, _)| pts[r as usize]).collect();
            got.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
            assert_eq!(got, brute_components(&pts, eps), "case {case}");
        }
    }

    /// Brute-force covering radius: the largest nearest distance over a dense grid of the
    /// field (a lower bound, within half a grid diagonal of the truth).
    fn grid_search(pts: &[[f64; 2]], field: [f64; 2], n: usize) -> f64 {
        let mut worst = 0.0f64;
        for i in 0..=n {
            for k in 0..=n {
                let p = [
                    -field[0] + 2.0 * field[0] * i as f64 / n as f64,
                    -field[1] + 2.0 * field[1] * k as f64 / n as f64,
                ];
                let d = pts
                    .iter()
                    .map(|q| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d);
            }
        }
        worst
    }

    #[test]
    fn covering_radius_of_degenerate_sets() {
        let f = [1.0, 2.0];
        assert_eq!(covering_radius(&[], f).unwrap(), f64::INFINITY);
        // One point: the farthest corner.
        assert_eq!(covering_radius(&[[0.0, 0.0]], f).unwrap(), 5f64.sqrt());
        let r = covering_radius(&[[0.5, -3.0]], f).unwrap();
        assert!((r - (1.5f64.powi(2) + 25.0).sqrt()).abs() < 1e-12);
        // Two points, duplicates, collinear rows (no triangle): bisector crossings count.
        let two = [[-0.5, 0.0], [0.5, 0.0], [0.5, 0.0]];
        let r = covering_radius(&two, f).unwrap();
        assert!((r - (0.25f64 + 4.0).sqrt()).abs() < 1e-12, "{r}");
        let line: Vec<[f64; 2]> = (-10..=10).map(|i| [i as f64 * 0.3, 0.7]).collect();
        let r = covering_radius(&line, f).unwrap();
        assert!(
            (r - (0.15f64.powi(2) + 2.7f64.powi(2)).sqrt()).abs() < 1e-12,
            "{r}"
        );
        let diag: Vec<[f64; 2]> = (-10..=10)
            .map(|i| [i as f64 * 0.3, i as f64 * 0.3])
            .collect();
        let r = covering_radius(&diag, f).unwrap();
        let g = grid_search(&diag, f, 400);
        assert!(r >= g - 1e-12 && r <= g + 0.01, "{r} {g}");
        // Far outside the field, all on one side.
        let far = [[10.0, 0.0], [10.0, 1.0], [11.0, 0.5]];
        let r = covering_radius(&far, f).unwrap();
        let g = grid_search(&far, f, 400);
        assert!(r >= g - 1e-12 && r <= g + 0.01, "{r} {g}");
    }

    #[test]
    fn square_grid_covers_at_one_over_root_two() {
        let pts: Vec<[f64; 2]> = (-12..=12)
            .flat_map(|i| (-12..=12).map(move |k| [i as f64, k as f64]))
            .collect();
        for field in [[8.0, 8.0], [7.5, 7.5], [8.3, 5.1], [0.25, 0.25]] {
            let r = covering_radius(&pts, field).unwrap();
            let want = if field == [0.25, 0.25] {
                (2.0 * 0.25f64.powi(2)).sqrt()
            } else {
                0.5f64.sqrt()
            };
            assert!((r - want).abs() < 1e-12, "{field:?} {r}");
        }
        // Through the whole pipeline: one channel of Q = 1 pixel per lens and d = mu, so
        // the samples are the lens centres' image, a square grid of pitch delta(z).
        let d = one_pixel_lenses(2.0, 0.01);
        let z = [120.0, 500.0, 3000.0];
        let c = coverage(&d, &z, 1e-6, 16.0, Some(2)).unwrap();
        for (k, &zk) in z.iter().enumerate() {
            for row in 0..2 {
                assert_eq!(c.distinct[row * 3 + k], 256);
                let r = c.covering_radius[row * 3 + k];
                assert!((r - 0.5f64.sqrt()).abs() < 1e-9, "{r}");
                let mm = c.covering_radius_mm[row * 3 + k];
                assert!((mm - r * d.resolution_step(zk)).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn covering_radius_equals_grid_search_on_random_sets() {
        let mut rng = Rng(12345);
        for case in 0..40 {
            let n = 3 + (rng.next() * 40.0) as usize;
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|_| {
                    let p = [rng.next() * 6.0 - 3.0, rng.next() * 6.0 - 3.0];
                    if case % 2 == 0 {
                        [(p[0] * 2.0).round() / 2.0, (p[1] * 2.0).round() / 2.0]
                    } else {
                        p
                    }
                })
                .collect();
            let field = [1.0 + rng.next(), 0.5 + rng.next()];
            let r = covering_radius(&pts, field).unwrap();
            let g = grid_search(&pts, field, 300);
            let cell = 2.0 * field[0].max(field[1]) / 300.0;
            assert!(r >= g - 1e-12 && r <= g + cell, "case {case}: {r} vs {g}");
        }
    }

    #[test]
    fn widening_from_any_margin_gives_the_complete_answer() {
        for d in designs() {
            let ctx = context(&d, 1e-6, 16.0).unwrap();
            let mut w = Work::default();
            for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                let geom = ctx.geom(z);
                let all = rows_from(&ctx, &geom, geom.complete * 1.5, &mut w, None, false).unwrap();
                for first in [geom.first, geom.first / 50.0, geom.complete / 3.0] {
                    let got = rows_from(&ctx, &geom, first, &mut w, None, false).unwrap();
                    assert_eq!(got, all, "z = {z}, first margin {first}");
                }
            }
        }
    }

    /// One pass of [`rows_from`] at a depth: its rows, the samples it kept and how many
    /// points it gathered.
    struct Pass {
        rows: Vec<RowResult>,
        keep: Vec<Vec<[f64; 2]>>,
        gathered: usize,
    }

    /// The pass at depth z with one of the context's shortcuts on, then off (`set`
    /// switches it): what the shortcut must not change.
    fn on_and_off(
        ctx: &mut Ctx<'_>,
        z: f64,
        w: &mut Work,
        set: fn(&mut Ctx<'_>, bool),
    ) -> [Pass; 2] {
        [true, false].map(|on| {
            set(ctx, on);
            let geom = ctx.geom(z);
            let mut keep = vec![Vec::new(); ctx.tables.len() + 1];
            let rows = rows_from(ctx, &geom, geom.first, w, Some(&mut keep), false).unwrap();
            Pass {
                rows,
                keep,
                gathered: w.pts.len(),
            }
        })
    }

    #[test]
    fn separable_channels_equal_the_general_computation() {
        let mut checked = 0;
        for d in designs() {
            let mut ctx = context(&d, 1e-6, 16.0).unwrap();
            let mut w = Work::default();
            for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                let [fast, slow] = on_and_off(&mut ctx, z, &mut w, |c, on| c.separable = on);
                for (r, (a, b)) in fast.rows.iter().zip(&slow.rows).enumerate() {
                    assert_eq!(a.distinct, b.distinct, "z = {z}");
                    assert!((a.rho - b.rho).abs() <= 1e-12 * b.rho, "{a:?} {b:?}");
                    assert_eq!(fast.keep[r], slow.keep[r]);
                }
                let separable = d.channels.iter().zip(&ctx.tables).any(|(_, t)| {
                    matches!(t.px, PixelTables::Ideal { .. }) && d.shape == Aperture::Square
                });
                checked += separable as usize;
            }
        }
        assert!(checked >= 8, "{checked}");
    }

    #[test]
    fn one_channel_union_is_the_channel_row_bit_for_bit() {
        let mut checked = 0;
        for d in designs().into_iter().filter(|d| d.channels.len() == 1) {
            let mut ctx = context(&d, 1e-6, 16.0).unwrap();
            let mut w = Work::default();
            for separable in [true, false] {
                ctx.separable = separable;
                for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                    let [fast, slow] =
                        on_and_off(&mut ctx, z, &mut w, |c, on| c.union_is_channel = on);
                    assert_eq!(fast.rows, slow.rows, "z = {z}");
                    assert_eq!(fast.keep, slow.keep, "z = {z}");
                    checked += 1;
                }
            }
        }
        assert!(checked >= 8, "{checked}");
    }

    #[test]
    fn trial_pass_changes_no_bit() {
        // The trial pass at TRIAL_MARGIN δ gives what the first margin gives, bit for bit.
        // These small designs are mostly settled whole by the first margin or separable;
        // some depths the trial settles with fewer samples (its gather is the last).
        let (mut settled, mut cases) = (0, 0);
        for d in designs() {
            for (tol, window) in [(1e-6, 16.0), (1e-6, 2.0), (0.05, 4.0), (1.0, 4.0)] {
                let mut ctx = context(&d, tol, window).unwrap();
                let mut w = Work::default();
                for z in [d.f_main * 1.2, 200.0, 700.0, 5000.0] {
                    let [on, off] = on_and_off(&mut ctx, z, &mut w, |c, on| c.trial = on);
                    assert_eq!(on.rows, off.rows, "z = {z}, tol {tol}, window {window}");
                    assert_eq!(on.keep, off.keep, "z = {z}, tol {tol}, window {window}");
                    settled += (on.gathered < off.gathered) as usize;
                    cases += 1;
                }
            }
        }
        assert!(settled >= 8, "{settled} of {cases}");
    }

    #[test]
    fn coarse_tolerance_chains_are_exact() {
        // Lens pitch 0.99 delta and tol = 1: every sample is linked to its neighbours, the
        // whole grid is one component, represented by its least (X, Y) member at the far
        // corner of the array, well beyond every margin but the last.
        let d = one_pixel_lenses(1.9, 0.0099);
        let ctx = context(&d, 1.0, 16.0).unwrap();
        let mut w = Work::default();
        let geom = ctx.geom(500.0);
        let all = rows_from(&ctx, &geom, geom.complete * 2.0, &mut w, None, false).unwrap();
        let got = rows_from(&ctx, &geom, geom.first, &mut w, None, false).unwrap();
        assert_eq!(got, all);
        // Row 0 by the separable computation, row 1 (the union of the one channel) by the
        // general one, which has to widen its margin to the whole sensor.
        let want = 0.99 * (27.5f64.powi(2) + 25.5f64.powi(2)).sqrt();
        for row in &all {
            assert_eq!(row.distinct, 0);
            assert!((row.rho - want).abs() < 1e-9, "{} {want}", row.rho);
        }
    }

    #[test]
    fn union_is_at_least_each_channel_and_threads_agree() {
        let d = Camera::paper().design();
        let z: Vec<f64> = (0..12)
            .map(|i| 150.0 * (8000.0f64 / 150.0).powf(i as f64 / 11.0))
            .collect();
        let a = coverage(&d, &z, 1e-6, 16.0, Some(1)).unwrap();
        let b = coverage(&d, &z, 1e-6, 16.0, Some(2)).unwrap();
        assert_eq!(a, b);
        let m = z.len();
        for k in 0..m {
            let u = a.distinct[2 * m + k];
            assert!(u >= a.distinct[k] && u >= a.distinct[m + k]);
            assert!(u <= a.distinct[k] + a.distinct[m + k]);
            assert!(
                a.covering_radius[2 * m + k]
                    <= a.covering_radius[k].min(a.covering_radius[m + k]) + 1e-12
            );
        }
        // Channel 1 on its out-of-focus plane: one sample per lens.
        let z1 = crate::model::lens::depth_of_conjugate(d.f_main, d.channels[0].l);
        let s = samples_2d(&d, z1, 1e-6, 16.0).unwrap();
        assert_eq!(s.distinct[0], 16 * 16);
        assert_eq!(s.samples[0].len(), 256);
        // The lens pitch on the plane is Q delta: cell centres are Q / sqrt 2 away.
        assert!(
            (s.covering_radius[0] - 15.0 / 2f64.sqrt()).abs() < 1e-9,
            "{}",
            s.covering_radius[0]
        );
        assert!(s
            .samples
            .iter()
            .all(|v| v.windows(2).all(|p| before(p[0], p[1]))));
    }

    #[test]
    fn bad_input_is_refused() {
        let d = designs().remove(0);
        let z = [300.0];
        for tol in [0.0, -1.0, f64::NAN, 1.5, f64::INFINITY] {
            let e = coverage(&d, &z, tol, 16.0, None).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("tol"), "{tol}");
        }
        let e = coverage(&d, &z, 1e-15, 16.0, None).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("tol"));
        for window in [0.0, -2.0, f64::NAN, f64::INFINITY] {
            let e = samples_2d(&d, 300.0, 1e-6, window).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("window"));
        }
        for zi in [50.0, 10.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                coverage(&d, &[300.0, zi], 1e-6, 16.0, None),
                Err(Error::InvalidDepth { index: 1, .. })
            ));
            assert!(matches!(
                chief_samples(&d, 1, zi, None),
                Err(Error::InvalidDepth { .. })
            ));
        }
        for ch in [0, 3, -1] {
            let e = chief_samples(&d, ch, 300.0, None).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("channel"));
        }
        assert!(chief_samples(&d, 1, 300.0, Some(0)).is_err());
        let many: Vec<f64> = vec![300.0; 1 << 24];
        assert!(matches!(
            coverage(&Camera::paper().design(), &many, 1e-6, 16.0, None),
            Err(Error::TooMuchWork { .. })
        ));
        // Empty depth arrays are fine.
        let c = coverage(&d, &[], 1e-6, 16.0, None).unwrap();
        assert!(c.distinct.is_empty());
    }
}
