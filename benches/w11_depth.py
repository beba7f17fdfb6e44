"""W11 depth (issue 23): the full seed's raw of a textured plane at 1 m (i.i.d. cells of
10 delta(z), photon noise N = 2000), a 256 x 256-cell region, 64 candidates from 250 mm to
4 m uniform in 1/z, the default window (13 x 13 cells).

- **Native**: `splitlf.estimate_depth` at 1 and at all threads. The design's white raws
  are rendered once per design and kept (3.7 s for the seed), so they are made before the
  timing, for both sides.
- **NumPy reference**: the same sweep vectorised in NumPy: each pixel's sample
  X(z) = p + z q from `splitlf.sample_grid` (centroid) at the first and last candidates,
  per candidate the bilinear splat by `np.bincount`, the pooled variance by cumulative
  sums, the running minimum; the same refinement. Timed in the same process, alternating,
  medians; its depth map is checked against the native one.
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
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from timing import timed_call  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native  # noqa: E402
from splitlf.depth_estimation import DEFAULT_STEP, DEFAULT_WINDOW, _white  # noqa: E402

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
    _white(d)
    cand = 1.0 / np.linspace(1 / DEPTHS[0], 1 / DEPTHS[1], 64)
    step = DEFAULT_STEP * d.resolution_step(float(1.0 / np.median(1.0 / cand)))
    half = cells * step / 2.0 * (1.0 - 1e-9)
    return raw, (-half, half, -half, half), step


def native(raw: splitlf.Raw, region: tuple[float, ...], step: float,
           n_threads: int | None) -> splitlf.DepthMap:
    return splitlf.estimate_depth(raw, depths=DEPTHS, region=region, step=step,
                                  n_threads=n_threads, progress=False)


def numpy_reference(raw: splitlf.Raw, region: tuple[float, ...], step: float) -> np.ndarray:
    """The refined depth per cell (NaN where no candidate had a cost), as the core."""
    d = raw.design
    r = DEFAULT_WINDOW
    cand = 1.0 / np.linspace(1 / DEPTHS[0], 1 / DEPTHS[1], 64)
    x0, y1, h, nx, ny = _native.cell_grid(region, step)
    enx, eny = nx + 2 * r, ny + 2 * r
    ex0, ey1 = x0 - r * h, y1 + r * h
    whites = _white(d)
    ps, qs, vs, ws, cs = [], [], [], [], []
    z0, z1 = cand[0], cand[-1]
    for c, ch in enumerate(d.channels, start=1):
        g0 = splitlf.sample_grid(d, z0, channel=c, sample="centroid")
        g1 = splitlf.sample_grid(d, z1, channel=c, sample="centroid")
        wt = whites[c - 1].ravel() / ch.share
        ok = (np.isfinite(g0.X) & np.isfinite(g0.Y)).ravel() & (wt >= 0.05)
        qx = (g1.X.ravel()[ok] - g0.X.ravel()[ok]) / (z1 - z0)
        qy = (g1.Y.ravel()[ok] - g0.Y.ravel()[ok]) / (z1 - z0)
        px, py = g0.X.ravel()[ok] - z0 * qx, g0.Y.ravel()[ok] - z0 * qy
        # Keep the samples that can reach the widened grid (as the core does).
        pad = (r + 1) * h
        xa, xb = px + z0 * qx, px + z1 * qx
        ya, yb = py + z0 * qy, py + z1 * qy
        keep = ((np.maximum(xa, xb) >= x0 - pad) & (np.minimum(xa, xb) <= x0 + nx * h + pad)
                & (np.maximum(ya, yb) >= y1 - ny * h - pad) & (np.minimum(ya, yb) <= y1 + pad))
        ps.append(np.c_[px, py][keep])
        qs.append(np.c_[qx, qy][keep])
        vs.append((raw.images[c - 1].ravel()[ok] / whites[c - 1].ravel()[ok])[keep])
        ws.append(wt[ok][keep])
        cs.append(np.full(int(keep.sum()), c - 1))
    p, q, v, w, chan = (np.concatenate(a) for a in (ps, qs, vs, ws, cs))
    nch = len(d.channels)
    n_e = eny * enx
    best = np.full(ny * nx, np.inf)
    arg = np.full(ny * nx, -1)
    costs = []
    for z in cand:
        fx = (p[:, 0] + z * q[:, 0] - ex0) / h - 0.5
        fy = (ey1 - (p[:, 1] + z * q[:, 1])) / h - 0.5
        ix, iy = np.floor(fx), np.floor(fy)
        tx, ty = fx - ix, fy - iy
        ix, iy = ix.astype(np.int64), iy.astype(np.int64)
        s = np.zeros((4, n_e * nch))  # per cell and channel (channels pooled apart)
        for dx, ax in ((0, 1 - tx), (1, tx)):
            for dy, ay in ((0, 1 - ty), (1, ty)):
                cx, cy = ix + dx, iy + dy
                inside = (cx >= 0) & (cx < enx) & (cy >= 0) & (cy < eny)
                k = ((cy * enx + cx) * nch + chan)[inside]
                a = (w * ax * ay)[inside]
                vv = v[inside]
                s[0] += np.bincount(k, a, n_e * nch)
                s[1] += np.bincount(k, a * vv, n_e * nch)
                s[2] += np.bincount(k, a * vv * vv, n_e * nch)
                s[3] += np.bincount(k, a * a, n_e * nch)
        with np.errstate(invalid="ignore", divide="ignore"):
            ssd = np.where(s[0] > 0, np.maximum(s[2] - s[1] ** 2 / s[0], 0.0), 0.0)
            dof = np.where(s[0] > 0, np.maximum(s[0] - s[3] / s[0], 0.0), 0.0)
        ssd = ssd.reshape(n_e, nch).sum(axis=1)
        dof = dof.reshape(n_e, nch).sum(axis=1)

        def box(a: np.ndarray) -> np.ndarray:
            c = np.zeros((eny + 1, enx + 1))
            c[1:, 1:] = a.reshape(eny, enx).cumsum(0).cumsum(1)
            m = 2 * r + 1
            return (c[m:, m:] - c[:-m, m:] - c[m:, :-m] + c[:-m, :-m]).ravel()

        num, den = box(ssd), box(dof)
        cost = np.where(den >= 2.0, np.maximum(num, 0.0) / np.where(den > 0, den, 1.0), np.nan)
        costs.append(cost)
        better = np.isfinite(cost) & (cost < best)
        best[better] = cost[better]
        arg[better] = len(costs) - 1
    vol = np.array(costs)
    out = np.full(ny * nx, np.nan)
    idx = np.arange(ny * nx)
    have = arg >= 0
    k = arg[have]
    m = best[have]
    left = np.where(k > 0, vol[np.maximum(k - 1, 0), idx[have]], np.nan)
    right = np.where(k < 63, vol[np.minimum(k + 1, 63), idx[have]], np.nan)
    rise = np.fmax(left, right) - m
    off = np.where(np.isfinite(left) & np.isfinite(right) & (rise > 0),
                   np.clip(0.5 * (left - right) / np.where(rise > 0, rise, 1.0), -0.5, 0.5),
                   0.0)
    kf = k + off
    k0 = np.minimum(np.floor(kf).astype(int), 62)
    t = kf - k0
    out[have] = 1.0 / ((1 - t) / cand[k0] + t / cand[k0 + 1])
    return out.reshape(ny, nx)


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
