//! The tilted route's geometry and profiles (see [`super::tilted`]): the plane's slabs
//! over the grid, a channel's pixel lines, and their profiles along the tilted axis t and
//! the other axis o.

use rayon::prelude::*;

use super::CellGrid;
use crate::imaging::render::exact::{
    mean_ray, pixel_offset, ray_set_area, tilted_profile, Profile, Tilt,
};
use crate::imaging::render::Chan;
use crate::imaging::scene::Surface;
use crate::infra::error::Result;
use crate::infra::memory;
use crate::infra::parallel::checkpoint;
use crate::model::design::{Channel, Design, Layout};

/// Sub-slabs of a grid row (or column) on the tilted route: enough that a slab spans at
/// most [`SLAB_DEPTH`] of its depth (the other axis's profile is taken at the slab's
/// middle depth).
pub(super) const SLAB_DEPTH: f64 = 2e-4;
/// The most sub-slabs a grid row or column is cut into.
pub(super) const MAX_SLABS: usize = 64;
/// The tilted route's geometry over the grid (see [`super::tilted::build_tilted`]): t the axis of the
/// larger tilt (Y on a tie), o the other, each grid row (column) along t cut into slabs.
pub(super) struct Slabs {
    /// The axis t (0: X, 1: Y).
    pub(super) axis: usize,
    pub(super) z0: f64,
    /// The plane's tilts along t and o.
    pub(super) gt: f64,
    pub(super) go: f64,
    /// The grid's first edge along t; its first and last edges and its cells along o.
    pub(super) t0: f64,
    pub(super) o0: f64,
    pub(super) o1: f64,
    pub(super) nco: usize,
    /// The grid's step, the slabs per cell, a slab's width and the slabs along t.
    pub(super) h: f64,
    pub(super) hs: f64,
    pub(super) slabs: usize,
    pub(super) ns: usize,
    /// The grid's columns and rows.
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) plane: Surface,
}

impl Slabs {
    /// The geometry of the plane Z = z0 + gx X + gy Y over the grid; None when the plane
    /// is not in front of the lens there.
    pub(super) fn new(z0: f64, g: [f64; 2], grid: &CellGrid) -> Option<Slabs> {
        let [gx0, gx1, gy0, gy1] = grid.extent();
        let corners = [[gx0, gy0], [gx0, gy1], [gx1, gy0], [gx1, gy1]];
        let depth = |c: &[f64; 2]| z0 + g[0] * c[0] + g[1] * c[1];
        let zmin = corners.iter().map(depth).fold(f64::INFINITY, f64::min);
        // `build_surface` has already required zmin > F over this grid; this check keeps
        // the slab count finite for direct callers (the tests).
        if zmin.is_nan() || zmin <= 0.0 {
            return None;
        }
        let axis = usize::from(g[1].abs() >= g[0].abs());
        let (gt, go) = (g[axis], g[1 - axis]);
        // Along the tilted axis (t): the grid's first edge and cells; along the other (o):
        // its first and last edges and cells.
        let ((t0, nct), (o0, o1, nco)) = if axis == 0 {
            ((gx0, grid.nx), (gy0, gy1, grid.ny))
        } else {
            ((gy0, grid.ny), (gx0, gx1, grid.nx))
        };
        let h = grid.step;
        let slabs = ((gt.abs() * h / (SLAB_DEPTH * zmin)).ceil() as usize).clamp(1, MAX_SLABS);
        Some(Slabs {
            axis,
            z0,
            gt,
            go,
            t0,
            o0,
            o1,
            nco,
            h,
            hs: h / slabs as f64,
            slabs,
            ns: nct * slabs,
            nx: grid.nx,
            ny: grid.ny,
            plane: Surface::Plane { z0, g },
        })
    }

    /// The depth of the plane at the middle of slab k along t (at U_o = 0).
    pub(super) fn slab_z(&self, k: usize) -> f64 {
        self.z0 + self.gt * (self.t0 + (k as f64 + 0.5) * self.hs)
    }

    /// Slab edge k along t.
    pub(super) fn edge_t(&self, k: usize) -> f64 {
        self.t0 + k as f64 * self.hs
    }

    /// Cell edge n along o.
    pub(super) fn edge_o(&self, n: usize) -> f64 {
        self.o0 + n as f64 * self.h
    }

    /// The cell of slab k (counted from the tilted axis's low edge) and of cell n of the
    /// other axis (counted from its low edge): rows run from the top (largest Y).
    pub(super) fn cell(&self, k: usize, n: usize) -> u32 {
        let (c, r) = if self.axis == 0 {
            (k / self.slabs, self.ny - 1 - n)
        } else {
            (n, self.ny - 1 - k / self.slabs)
        };
        (r * self.nx + c) as u32
    }

    /// The planes tilted along t alone between which the pixels' planes lie.
    pub(super) fn offsets(&self) -> Vec<f64> {
        if self.go == 0.0 {
            vec![self.z0]
        } else {
            vec![self.z0 + self.go * self.o0, self.z0 + self.go * self.o1]
        }
    }

    /// The plane along t seen by the o rays around the mean o ray (w_o, a_o): the ray is
    /// at U_o = w_o − Z a_o at depth Z, so Z = z0 + g_t U_t + g_o U_o is the plane
    /// Z = (z0 + g_o w_o) / (1 + g_o a_o) + g_t / (1 + g_o a_o) U_t along t, exact for
    /// that o ray with every t ray; None when the o ray runs away from the plane.
    pub(super) fn along_t(&self, wo: f64, ao: f64) -> Option<(f64, f64)> {
        let den = 1.0 + self.go * ao;
        (den > 0.0).then(|| ((self.z0 + self.go * wo) / den, self.gt / den))
    }

    /// The depth at which the ray (w_t, a_t) along t and (w_o, a_o) along o meets the
    /// plane (`Surface::hit`, with the axes put back in X, Y order); None when it runs
    /// away from the plane or meets it behind the main lens.
    pub(super) fn hit(&self, (wt, at): (f64, f64), (wo, ao): (f64, f64)) -> Option<f64> {
        let (w, a) = if self.axis == 0 {
            ([wt, wo], [at, ao])
        } else {
            ([wo, wt], [ao, at])
        };
        self.plane.hit(w, a).map(|(z, _)| z)
    }

    /// Slab k's o areas times the t area a_t into a row's entries and its light on the
    /// grid (`inside`); the number of o cells it reaches (0: none).
    pub(super) fn add(
        &self,
        k: usize,
        op: &Profile,
        a_t: f64,
        entries: &mut Vec<(u32, f64)>,
        inside: &mut f64,
    ) -> usize {
        let mut span = (usize::MAX, 0);
        for (n, &a_o) in op.areas.iter().enumerate() {
            if a_o != 0.0 {
                *inside += a_o * a_t;
                entries.push((self.cell(k, op.first + n), a_t * a_o));
                span = (span.0.min(n), n);
            }
        }
        (span.1 + 1).saturating_sub(span.0)
    }
}

/// One channel on the tilted route: its number, spec, pixels per lens (the ideal layout),
/// geometry, raw's shape, and its pixels along t and along o.
pub(super) struct Line<'a> {
    pub(super) i: usize,
    pub(super) ch: &'a Channel,
    pub(super) q: u32,
    pub(super) chan: Chan<'a>,
    pub(super) rows: usize,
    pub(super) cols: usize,
    pub(super) npt: usize,
    pub(super) npo: usize,
}

impl<'a> Line<'a> {
    pub(super) fn open(design: &'a Design, i: usize, axis: usize) -> Line<'a> {
        let ch = &design.channels[i];
        let Layout::Ideal { q } = ch.layout else {
            unreachable!("checked by `supported` in the caller")
        };
        let (rows, cols) = crate::imaging::render::raw_shape(ch);
        let chan = Chan::new(design, ch, crate::imaging::render::DEFAULT_TOL);
        // Raw columns run along X, rows along Y.
        let (npt, npo) = if axis == 0 {
            (cols, rows)
        } else {
            (rows, cols)
        };
        Line {
            i,
            ch,
            q,
            chan,
            rows,
            cols,
            npt,
            npo,
        }
    }

    /// A pixel line's lens centre along axis ax (raw columns run along X, rows along Y).
    pub(super) fn center(&self, p: u32, ax: usize) -> f64 {
        if ax == 0 {
            self.ch.lens_center(p / self.q, 0)[0]
        } else {
            self.ch.lens_center(0, p / self.q)[1]
        }
    }

    /// A pixel line's offset under its lens.
    pub(super) fn theta(&self, i: u32) -> f64 {
        pixel_offset(self.ch.mu, self.q, i)
    }

    /// The lens type of pixel (column a, row b).
    pub(super) fn typ(&self, a: usize, b: usize) -> usize {
        self.ch.lens_type(a as u32 / self.q, b as u32 / self.q)
    }
}

/// A slab's o profiles per pixel line along o (None: a slab no kept pixel reaches).
pub(super) type Slab = Option<Vec<Option<Profile>>>;

/// A channel's profiles on the tilted route, per lens type (none for a type not kept).
pub(super) struct Profiles {
    /// Per offset plane and pixel line along t, against the slab edges.
    pub(super) pt: Vec<Vec<Vec<Option<Profile>>>>,
    /// Per slab, the o profiles.
    pub(super) po: Vec<Vec<Slab>>,
    /// The o polygons' whole areas per pixel line along o.
    pub(super) ototal: Vec<Vec<f64>>,
    /// With a tilt along o, each pixel line's mean ray along t and along o.
    pub(super) rt: Vec<Vec<Option<(f64, f64)>>>,
    pub(super) ro: Vec<Vec<Option<(f64, f64)>>>,
}

/// Tilted profiles per type, offset plane and pixel line along t, against the slab edges;
/// None where some of the line's rays miss the plane (its pixels are then not kept, as on
/// the general route: part of their light is not on the grid). A type not kept has no
/// profiles (its pixels are no rows). Without a tilt along o these are the pixels'
/// profiles; with one, the bounds of the slabs they reach.
fn t_profiles(
    sl: &Slabs,
    ln: &Line,
    keeps: &(dyn Fn(usize) -> bool + Sync),
) -> Result<Vec<Vec<Vec<Option<Profile>>>>> {
    let offsets = sl.offsets();
    let nt = ln.chan.types.len();
    let mut pt = Vec::with_capacity(nt);
    for t in 0..nt {
        if !keeps(t) {
            pt.push(Vec::new());
            continue;
        }
        let mut per = Vec::with_capacity(offsets.len());
        for &zp in &offsets {
            per.push(
                (0..ln.npt as u32)
                    .into_par_iter()
                    .map(|b| {
                        let c = ln.center(b, sl.axis);
                        tilted_profile(
                            &ln.chan,
                            ln.chan.types[t].0,
                            c,
                            ln.theta(b),
                            Tilt { z0: zp, g: sl.gt },
                            sl.ns,
                            |k| sl.edge_t(k),
                        )
                    })
                    .collect::<Vec<_>>(),
            );
            checkpoint()?;
        }
        pt.push(per);
    }
    Ok(pt)
}

/// The slabs some kept pixel's rays reach (with a tilt along o: every slab between a
/// line's reach on the two bounding planes, the reach moving monotonically with the
/// plane's offset).
fn used_slabs(sl: &Slabs, pt: &[Vec<Vec<Option<Profile>>>], npt: usize) -> Vec<bool> {
    let mut used = vec![false; sl.ns];
    for per in pt.iter().filter(|v| !v.is_empty()) {
        for it in 0..npt {
            let (mut lo, mut hi) = (usize::MAX, 0);
            for p in per.iter().filter_map(|v| v[it].as_ref()) {
                for (j, &a) in p.areas.iter().enumerate() {
                    if a != 0.0 {
                        if sl.go == 0.0 {
                            used[p.first + j] = true;
                        }
                        lo = lo.min(p.first + j);
                        hi = hi.max(p.first + j + 1);
                    }
                }
            }
            if sl.go != 0.0 && lo < hi {
                used[lo..hi].fill(true);
            }
        }
    }
    used
}

/// The other axis's profiles in the slabs `used`, per type, in blocks of slabs with a
/// check for Ctrl-C between them.
fn o_profiles(
    sl: &Slabs,
    ln: &Line,
    keeps: &(dyn Fn(usize) -> bool + Sync),
    used: &[bool],
) -> Result<Vec<Vec<Slab>>> {
    let (nt, ns) = (ln.chan.types.len(), sl.ns);
    let mut po: Vec<Vec<Slab>> = Vec::with_capacity(nt);
    for t in 0..nt {
        if !keeps(t) {
            po.push((0..ns).map(|_| None).collect());
            continue;
        }
        let mut v = Vec::with_capacity(ns);
        for start in (0..ns).step_by(64) {
            checkpoint()?;
            v.par_extend((start..(start + 64).min(ns)).into_par_iter().map(|k| {
                used[k].then(|| {
                    (0..ln.npo as u32)
                        .map(|a| {
                            tilted_profile(
                                &ln.chan,
                                ln.chan.types[t].0,
                                ln.center(a, 1 - sl.axis),
                                ln.theta(a),
                                Tilt {
                                    z0: sl.slab_z(k),
                                    g: sl.go,
                                },
                                sl.nco,
                                |n| sl.edge_o(n),
                            )
                        })
                        .collect()
                })
            }));
        }
        po.push(v);
    }
    Ok(po)
}

/// A channel's profiles (see [`Profiles`]), the memory of the o profiles checked first.
pub(super) fn profiles(
    sl: &Slabs,
    ln: &Line,
    keeps: &(dyn Fn(usize) -> bool + Sync),
) -> Result<Profiles> {
    let nt = ln.chan.types.len();
    let kept = (0..nt).filter(|&t| keeps(t)).count() as u128;
    let pt = t_profiles(sl, ln, keeps)?;
    let used = used_slabs(sl, &pt, ln.npt);
    memory::check(
        "the tilted route's profiles",
        (used.iter().filter(|&&u| u).count() as u128) * kept * (ln.npo as u128) * 96,
    )?;
    let po = o_profiles(sl, ln, keeps, &used)?;
    // The other axis's polygons' whole areas (its profile on any plane has the same
    // total), and with a tilt along o each pixel line's mean ray per axis.
    let ototal: Vec<Vec<f64>> = (0..nt)
        .map(|t| {
            (0..ln.npo as u32)
                .map(|a| ray_set_area(&ln.chan, ln.chan.types[t].0, ln.theta(a)))
                .collect()
        })
        .collect();
    let rays = |n: usize, ax: usize| -> Vec<Vec<Option<(f64, f64)>>> {
        (0..nt)
            .map(|t| {
                if sl.go == 0.0 {
                    return Vec::new();
                }
                (0..n as u32)
                    .map(|a| mean_ray(&ln.chan, ln.chan.types[t].0, ln.center(a, ax), ln.theta(a)))
                    .collect()
            })
            .collect()
    };
    let (rt, ro) = (rays(ln.npt, sl.axis), rays(ln.npo, 1 - sl.axis));
    checkpoint()?;
    Ok(Profiles {
        pt,
        po,
        ototal,
        rt,
        ro,
    })
}
