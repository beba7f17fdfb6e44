"""The general route's cost against the texture's detail (docs/render.md, "Speed").

A random n x n photograph laid over the *full* design's view on a fronto-parallel plane,
rendered on a cut of the design (release build, 1 thread, tol 1e-3) with the closed form
of a lens's interior boxes (``_native.render``, as ``splitlf.render``) and without it
(``_native.render_quadrature``), each timed ``--rounds`` times interleaved in one process;
medians. Also the largest difference between the two raws (of white) and the share of
pixels whose value the closed form changed (those with at least one box in closed form).

    python benches/texture_cost.py --rounds 3
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import splitlf
from splitlf import _native
from splitlf.imaging.render import scene_parts

SIZES = (0, 16, 64, 128, 256, 512)  # 0: a constant texture
CUTS = {"raytrix-r12": (3, 3), "lytro-illum": (16, 14)}
Z = 1000.0


def cut(name: str) -> splitlf.Design:
    """The preset cut to the lenses of CUTS (a sensor layout's grid shrunk to fit)."""
    d = splitlf.Design.preset(name)
    kx, ky = CUTS[name]
    chs = tuple(ch.replace(Kx=kx, Ky=ky, Mx=None, My=None) if ch.layout == "sensor"
                else ch.replace(Kx=kx, Ky=ky) for ch in d.channels)
    return d.replace(channels=chs)


def scene(name: str, n: int) -> splitlf.Scene:
    """A random n x n image over the full design's view at Z (a constant 0.5 for n = 0)."""
    if n == 0:
        return splitlf.Scene(splitlf.Constant(0.5), Z)
    full = splitlf.Design.preset(name)
    x0, x1, y0, y1 = (float(v) for v in _native.render_extent(full.core, Z))
    rng = np.random.default_rng(n)
    return splitlf.Scene(splitlf.Image(rng.random((n, n)), width=max(x1 - x0, y1 - y0)), Z)


def timed(f) -> tuple[float, list[np.ndarray]]:
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, [np.asarray(a) for a in out]


def measure(name: str, n: int, rounds: int) -> dict:
    d = cut(name)
    core = _native.RenderScene(*scene_parts(scene(name, n), d, np.random.default_rng(0)))
    new_t, old_t = [], []
    for _ in range(rounds):
        t, new = timed(lambda: _native.render(d.core, core, tol=1e-3, n_threads=1))
        new_t.append(t)
        t, old = timed(lambda: _native.render_quadrature(d.core, core, 1e-3, 1))
        old_t.append(t)
    px = sum(a.size for a in new)
    white = max(float(np.asarray(a).max()) for a in
                splitlf.render(d, splitlf.Scene(1.0, Z), n_threads=1).images)
    diff = max(float(np.abs(a - b).max()) for a, b in zip(new, old, strict=True)) / white
    changed = sum(int((a != b).sum()) for a, b in zip(new, old, strict=True)) / px
    return {"design": name, "n": n, "pixels": px,
            "us_px_closed": 1e6 * float(np.median(new_t)) / px,
            "us_px_quadrature": 1e6 * float(np.median(old_t)) / px,
            "max_diff_of_white": diff, "share_changed": changed}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--designs", nargs="*", default=list(CUTS))
    ap.add_argument("--sizes", nargs="*", type=int, default=list(SIZES))
    args = ap.parse_args()
    for name in args.designs:
        for n in args.sizes:
            print(json.dumps(measure(name, n, args.rounds)), flush=True)


if __name__ == "__main__":
    main()
