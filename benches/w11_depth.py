"""W11 depth (issue 23): the full seed's raw of a textured plane at 1 m (i.i.d. cells of
10 delta(z), photon noise N = 2000), a 256 x 256-cell region, 64 candidates from 250 mm to
4 m uniform in 1/z, the default window (13 x 13 cells).

- **Native**: `splitlf.estimate_depth` (one call of the core) at 1 and at all threads.
  The design's white raws are rendered once per design and kept (3.7 s for the seed; the
  core keeps its own, `_native.depth_whites`), so they are made before the timing, for
  both sides.
- **NumPy reference**: the same sweep vectorised in NumPy: each lens's columns and rows
  X(z) = p + z q from `splitlf.sample_grid` (centroid) at the first and last candidates,
  per candidate the same thinning, the tents of all kept lenses at once and their
  micro-images resampled by batched matrix products, the sums by `np.bincount`, the
  window by cumulative sums, the whole cost volume, the most confident channel and the
  same refinement. Timed in the same process, alternating, medians; its depth map is
  checked against the native one.
- **Peak memory** of the native call: the process's VmHWM growth over the call, in a
  fresh child process (raws and whites already held).

    python benches/w11_depth.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from timing import timed_call  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native  # noqa: E402
from splitlf.inverse.depth import (  # noqa: E402
    DEFAULT_STEP,
    DEFAULT_WINDOW,
    _sweep_whites,
    _white,
)

Z = 1000.0
DEPTHS = (250.0, 4000.0)
NOISE = {"photons": 2000.0, "read_noise": 0.0}


def setup(cells: int, kx: int | None = None) -> tuple[splitlf.Raw, tuple[float, ...], float]:
    d = splitlf.Design.preset("seed")
    if kx is not None:
        d = d.replace(channels=tuple(c.replace(Kx=kx, Ky=max(8, kx * 2 // 3))
                                     for c in d.channels))
    tex = splitlf.RandomAlbedo(10 * d.resolution_step(Z))
    raw = splitlf.render(d, splitlf.Scene(tex, Z), noise=NOISE, seed=1)
    _sweep_whites(d)  # the core's whites, kept for the native calls
    _white(d)  # the NumPy reference's
    cand = 1.0 / np.linspace(1 / DEPTHS[0], 1 / DEPTHS[1], 64)
    step = DEFAULT_STEP * d.resolution_step(float(1.0 / np.median(1.0 / cand)))
    half = cells * step / 2.0 * (1.0 - 1e-9)
    return raw, (-half, half, -half, half), step


def native(raw: splitlf.Raw, region: tuple[float, ...], step: float,
           n_threads: int | None) -> splitlf.DepthMap:
    return splitlf.estimate_depth(raw, depths=DEPTHS, region=region, step=step,
                                  n_threads=n_threads, progress=False)


def _splitmix(x: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        x = x + np.uint64(0x9E3779B97F4A7C15)
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def _first_cells(lo: np.ndarray, hi: np.ndarray, c0: float, sign: float, h: float,
                 n: int) -> tuple[np.ndarray, np.ndarray]:
    """The cells whose centres c0 + sign (i + 0.5) h lie strictly within (lo, hi)."""
    f0, f1 = ((lo - c0) / h - 0.5, (hi - c0) / h - 0.5) if sign > 0 else \
        ((c0 - hi) / h - 0.5, (c0 - lo) / h - 0.5)
    return np.maximum(np.floor(f0) + 1, 0).astype(np.int64), \
        np.minimum(np.ceil(f1) - 1, n - 1).astype(np.int64)


def _tents(x: np.ndarray, hw: np.ndarray, first: np.ndarray, last: np.ndarray, c0: float,
           sign: float, h: float) -> np.ndarray:
    """(lenses, cells of the longest range, positions): the tents of docs/depth.md."""
    span = int((last - first).max()) + 1
    i = first[:, None] + np.arange(span)[None, :]
    centre = c0 + sign * (i + 0.5) * h
    t = np.maximum(0.0, 1.0 - np.abs(centre[:, :, None] - np.where(np.isfinite(x), x, np.inf)
                                      [:, None, :]) / hw[:, None, None])
    return np.where((i <= last[:, None])[:, :, None] & np.isfinite(x)[:, None, :], t, 0.0)


def numpy_reference(raw: splitlf.Raw, region: tuple[float, ...], step: float) -> np.ndarray:
    """The refined depth per cell (NaN where no candidate had a cost), as the core, for an
    ideal rect layout (lens (j, k) owns its Q x Q block): the lenses' micro-images resampled
    by tents at the cell centres with batched matrix products, the sums by np.bincount, the
    window by cumulative sums, the whole cost volume, the most confident channel."""
    d = raw.design
    r = DEFAULT_WINDOW
    cand = 1.0 / np.linspace(1 / DEPTHS[0], 1 / DEPTHS[1], 64)
    n = cand.size
    x0, y1, h, nx, ny = _native.cell_grid(region, step)
    enx, eny = nx + 2 * r, ny + 2 * r
    ex0, ey1 = x0 - r * h, y1 + r * h
    wx1, wy0 = ex0 + enx * h, ey1 - eny * h
    whites = _white(d)
    z0, z1 = cand[0], cand[-1]
    chans = []
    for c, ch in enumerate(d.channels, start=1):
        q = d.resolved()[c - 1]["Q"]
        kx, ky = ch.Kx, ch.Ky
        g0 = splitlf.sample_grid(d, z0, channel=c, sample="centroid")
        g1 = splitlf.sample_grid(d, z1, channel=c, sample="centroid")
        om = whites[c - 1] / ch.share
        valid = (om >= 0.05) & np.isfinite(g0.X + g0.Y + g1.X + g1.Y)
        v4 = valid.reshape(ky, q, kx, q)
        colv, rowv = v4.any(axis=1), v4.any(axis=3)  # (ky, kx, q) and (ky, q, kx)
        qx = (g1.X[0] - g0.X[0]) / (z1 - z0)  # centroid X depends on the column alone
        px = g0.X[0] - z0 * qx
        qy = (g1.Y[:, 0] - g0.Y[:, 0]) / (z1 - z0)
        py = g0.Y[:, 0] - z0 * qy
        # per lens (k, j): its columns' (p, q) and rows' (p, q), NaN where not valid
        pxl = np.where(colv, px.reshape(kx, q)[None], np.nan)
        qxl = np.where(colv, qx.reshape(kx, q)[None], np.nan)
        pyl = np.where(rowv.transpose(0, 2, 1), py.reshape(ky, q)[:, None], np.nan)
        qyl = np.where(rowv.transpose(0, 2, 1), qy.reshape(ky, q)[:, None], np.nan)
        # per lens (k, j): its block of (omega, omega v), zeros where not valid
        omb, ovb = (np.where(v4, a.reshape(ky, q, kx, q), 0.0).transpose(0, 2, 1, 3)
                    for a in (om, raw.images[c - 1] / ch.share))

        def extent(p: np.ndarray, qq: np.ndarray, z: float) -> tuple[np.ndarray, ...]:
            x = p + z * qq
            cnt = np.isfinite(x).sum(-1)
            with np.errstate(invalid="ignore"):
                lo, hi = np.nanmin(np.where(cnt[..., None] > 0, x, 0.0), -1), \
                    np.nanmax(np.where(cnt[..., None] > 0, x, 0.0), -1)
            s = np.where(cnt > 1, (hi - lo) / np.maximum(cnt - 1, 1), 0.0)
            return x, lo, hi, np.maximum(h, s), cnt, s

        has = colv.any(-1)
        reach = np.ones_like(has)
        for p_, q_, lo_b, hi_b in ((pxl, qxl, ex0, wx1), (pyl, qyl, wy0, ey1)):
            e = [extent(p_, q_, z)[:5] for z in (z0, z1)]
            lo = np.minimum(e[0][1] - e[0][3], e[1][1] - e[1][3])
            hi = np.maximum(e[0][2] + e[0][3], e[1][2] + e[1][3])
            reach &= (hi >= lo_b) & (lo <= hi_b)
        keep_l = has & reach
        kk, jj = np.nonzero(keep_l)
        key = jj.astype(np.uint64) | (kk.astype(np.uint64) << np.uint64(24)) \
            | (np.uint64(c - 1) << np.uint64(48))
        u = (_splitmix(key) >> np.uint64(11)).astype(np.float64) / 2.0**53
        chans.append((pxl[kk, jj], qxl[kk, jj], pyl[kk, jj], qyl[kk, jj], omb[kk, jj],
                      ovb[kk, jj], u))
    nch = len(chans)
    vol = np.full((n, nch, ny * nx), np.nan)
    m_ = 2 * r + 1

    def box(a: np.ndarray) -> np.ndarray:
        cs = np.zeros((eny + 1, enx + 1))
        cs[1:, 1:] = a.reshape(eny, enx).cumsum(0).cumsum(1)
        return (cs[m_:, m_:] - cs[:-m_, m_:] - cs[m_:, :-m_] + cs[:-m_, :-m_]).ravel()

    for i, z in enumerate(cand):
        for c, (pxl, qxl, pyl, qyl, omb, ovb, u) in enumerate(chans):
            X, xlo, xhi, hx, cx, sx = extent(pxl, qxl, z)
            Y, ylo, yhi, hy, cy, sy = extent(pyl, qyl, z)
            fin = (cx > 0) & (cy > 0)
            clip = lambda a, b, lo, hi: np.maximum(0.0, np.minimum(b, hi) - np.maximum(a, lo))  # noqa: E731
            area = np.where(fin, clip(xlo - hx, xhi + hx, ex0, wx1)
                            * clip(ylo - hy, yhi + hy, wy0, ey1), 0.0).sum()
            keep = min(1.0, 48.0 * (enx * h) * (eny * h) / area) if area > 0 else 1.0
            fx0, fx1 = _first_cells(xlo - hx, xhi + hx, ex0, 1.0, h, enx)
            fy0, fy1 = _first_cells(ylo - hy, yhi + hy, ey1, -1.0, h, eny)
            sel = np.flatnonzero(fin & (u < keep) & (fx0 <= fx1) & (fy0 <= fy1))
            s = np.zeros((4, eny * enx))
            own = np.zeros((2, eny * enx))
            for part in np.array_split(sel, max(1, sel.size // 2000)):
                if part.size == 0:
                    continue
                tx = _tents(X[part], hx[part], fx0[part], fx1[part], ex0, 1.0, h)
                ty = _tents(Y[part], hy[part], fy0[part], fy1[part], ey1, -1.0, h)
                txt, tyt = tx.transpose(0, 2, 1), ty
                tw = tyt @ omb[part] @ txt
                ttw = (tyt**2) @ omb[part] @ (txt**2)
                twv = tyt @ ovb[part] @ txt
                # the share of the tents that valid pixels cover
                tt = tyt @ (omb[part] > 0) @ txt
                with np.errstate(invalid="ignore", divide="ignore"):
                    big = np.where(ttw > 0, tw * tw / ttw * np.minimum(tt, 1.0), 0.0)
                    mv = np.where(ttw > 0, twv / tw, 0.0)
                use = big >= 0.05
                ly, lx = tw.shape[1], tw.shape[2]
                iy = fy0[part][:, None, None] + np.arange(ly)[None, :, None]
                ix = fx0[part][:, None, None] + np.arange(lx)[None, None, :]
                inside = use & (iy <= fy1[part][:, None, None]) & (ix <= fx1[part][:, None, None])
                k = (iy * enx + ix)[inside]
                b, mm = big[inside], mv[inside]
                for j, val in enumerate((b, b * mm, b * mm * mm, b * b)):
                    s[j] += np.bincount(k, val, eny * enx)
                # the lenses' own pixels, weighted (1 - s/h) per axis (near the out-of-focus
                # plane, where they are denser than the cells)
                gate = np.maximum(0.0, 1 - sx[part] / h) * np.maximum(0.0, 1 - sy[part] / h)
                on = gate > 0
                if on.any():
                    with np.errstate(invalid="ignore", divide="ignore"):
                        ovv = np.where(omb[part][on] > 0, ovb[part][on] ** 2
                                       / np.where(omb[part][on] > 0, omb[part][on], 1.0), 0.0)
                    tv2 = tyt[on] @ ovv @ txt[on]
                    with np.errstate(invalid="ignore", divide="ignore"):
                        w1 = np.where(use[on], tw[on], 1.0)
                        sp = np.maximum(tv2 - twv[on] ** 2 / w1, 0.0) * gate[on][:, None, None]
                        df = np.maximum(tt[on] - ttw[on] / w1, 0.0) * gate[on][:, None, None]
                    ins = inside[on]
                    kk = (np.broadcast_to(iy, inside.shape)[on] * enx
                          + np.broadcast_to(ix, inside.shape)[on])[ins]
                    own[0] += np.bincount(kk, sp[ins], eny * enx)
                    own[1] += np.bincount(kk, df[ins], eny * enx)
            s0, s1, s2, s3 = s
            with np.errstate(invalid="ignore", divide="ignore"):
                spread = np.where(s0 > 0, np.maximum(s2 - s1 * s1 / s0, 0.0) + own[0], 0.0)
                dof = np.where(s0 > 0, np.maximum(s0 - s3 / s0, 0.0) + own[1], 0.0)
            t0, t1, t2, t3 = s.sum(axis=1)
            mean = t1 / t0 if t0 > 0 else 0.0
            tdof = t0 - t3 / t0 if t0 > 0 else 0.0
            total = max(t2 - t1 * mean, 0.0) / tdof if tdof > 0 else 0.0
            scale = 1.0 / total if total > 1e-12 * max(mean * mean, 1e-300) else 0.0
            num, den = box(spread), box(dof)
            vol[i, c] = np.where(den >= 2.0, num / np.where(den > 0, den, 1.0) * scale, np.nan)
    # per channel: the least cost, its neighbours, the confidence; the most confident wins
    cost = np.where(np.isfinite(vol), vol, np.inf)
    k = np.argmin(cost, axis=0)
    m = np.take_along_axis(cost, k[None], 0)[0]
    before = np.concatenate([np.full_like(cost[:1], np.inf), cost[:-1]])
    after = np.concatenate([cost[1:], np.full_like(cost[:1], np.inf)])
    local = (cost < before) & (cost <= after) & np.isfinite(cost)
    far = np.abs(np.arange(n)[:, None, None] - k[None]) > max(n // 16, 2)
    # the rival: among the 4 least local minima (the core keeps 4), the first far one
    lm = np.where(local, cost, np.inf)
    order = np.argsort(lm, axis=0, kind="stable")[:4]
    least = np.take_along_axis(lm, order, 0)
    far4 = np.take_along_axis(far, order, 0) & np.isfinite(least)
    rival = np.where(far4.any(0), np.take_along_axis(least, np.argmax(far4, 0)[None], 0)[0],
                     np.inf)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # cells no candidate costs: NaN
        against = np.minimum(np.nanmean(vol, axis=0), rival)
        conf = np.where((against > 0) & np.isfinite(against), np.clip(1 - m / against, 0, 1), 0.0)
    conf = np.where(np.isfinite(m), conf, -1.0)
    best = np.argmax(conf, axis=0)
    kb = np.take_along_axis(k, best[None], 0)[0]
    curve = np.take_along_axis(cost, best[None, None], 1)[:, 0]
    mb = np.take_along_axis(curve, kb[None], 0)[0]
    left = np.take_along_axis(curve, np.maximum(kb - 1, 0)[None], 0)[0]
    right = np.take_along_axis(curve, np.minimum(kb + 1, n - 1)[None], 0)[0]
    left = np.where(kb > 0, left, np.inf)
    right = np.where(kb < n - 1, right, np.inf)
    rise = np.fmax(left, right) - mb
    ok = np.isfinite(left) & np.isfinite(right) & (rise > 0)
    off = np.where(ok, np.clip(0.5 * (left - right) / np.where(ok, rise, 1.0), -0.5, 0.5), 0.0)
    kf = kb + off
    k0 = np.minimum(np.floor(kf).astype(int), n - 2)
    t = kf - k0
    out = 1.0 / ((1 - t) / cand[k0] + t / cand[k0 + 1])
    return np.where(np.isfinite(mb), out, np.nan).reshape(ny, nx)


def peak_child(cells: int, quick: bool) -> float:
    """VmHWM growth (MiB) over one native call, in a fresh process."""
    kx = 12 if quick else None
    code = (
        f"import sys; sys.path.insert(0, {str(HERE)!r})\n"
        "import w11_depth as w\n"
        "def hwm():\n"
        "    for line in open('/proc/self/status'):\n"
        "        if line.startswith('VmHWM'): return int(line.split()[1])\n"
        f"raw, region, step = w.setup({cells}, {kx!r})\n"
        "b = hwm(); w.native(raw, region, step, None); print((hwm() - b) / 1024)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


def run(quick: bool, rounds: int) -> dict[str, Any]:
    cells = 64 if quick else 256
    raw, region, step = setup(cells, 12 if quick else None)
    t_all, t_one, t_np = [], [], []
    est = ref = None
    for _ in range(rounds):
        t, est = timed_call(native, raw, region, step, None)
        t_all.append(t)
        t_one.append(timed_call(native, raw, region, step, 1)[0])
        t, ref = timed_call(numpy_reference, raw, region, step)
        t_np.append(t)
    assert est is not None and ref is not None
    same = np.isfinite(ref)
    agree = float(np.mean(np.abs(est.sweep.estimate[same] - ref[same])
                          <= 1e-9 * ref[same]))
    med = statistics.median
    return {
        "cells": [cells, cells], "candidates": 64, "window": DEFAULT_WINDOW,
        "samples": est.sweep.samples,
        "native_s": med(t_all), "native_1thread_s": med(t_one), "numpy_s": med(t_np),
        "ratio_numpy": med(t_np) / med(t_all), "threads_speedup": med(t_one) / med(t_all),
        "agree_share": agree, "peak_mib": peak_child(cells, quick), "rounds": rounds,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a 64 x 64 region of a cut seed")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    print(json.dumps(run(args.quick, args.rounds), indent=2))


if __name__ == "__main__":
    main()
