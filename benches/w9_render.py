"""W9: raw images (`splitlf.render`, issue 21), measured in one process.

Three scenes, each rendered by the core and by a NumPy twin of the same integration
(benches/numpy_render.py):

- ``seed``: the seed design (exact route: rect grid, square aperture, ideal layout, image
  texture, fronto-parallel plane) on a random 512 x 512 image covering the view at
  1000 mm. Twin: `numpy_render.render_exact`, the same exact separable integration
  vectorised (per-axis polygon/cell weights, then a banded separable sum), every pixel of
  both channels; agreement <= 1e-12 of a fully lit white pixel.
- ``r12_fronto`` and ``r12_slanted``: `raytrix-r12` (hex, three lens types, circular
  aperture, sensor layout) with fewer lenses (Kx x Ky, the sensor shrunk to fit) on a
  random 512 x 512 image laid over the *full* R12's view at 1000 mm (so a texture cell is
  as large, relative to a pixel's footprint, as at full size), on the fronto-parallel
  plane at 1000 mm and on the plane Z = 1000 + 0.3 X + 0.1 Y. Twin:
  `numpy_render.render_pixels_s` (the core's order of integration, vectorised: a fixed
  `TWIN_NODES` x `TWIN_NODES` Gauss-Legendre rule over the pixel, per node the exact
  texture integral over the image of the lens cell clipped by the aperture's preimage)
  on a random sample of pixels; agreement <= 1e-3 of white on those pixels; its time is
  per pixel. Checked once (not timed in the rounds): a second, independent twin with
  the other order, `numpy_render.render_pixels` (`CHECK_NODES` per axis over the lens cell,
  exact inner integrals over the pixel's aperture square), also <= 1e-3 of white.

Alternating rounds (order rotated every round) of: twin, native at 1 thread, native at all
threads, for each scene; medians. Then, outside the timed rounds:

- Monte Carlo (tests/mc_render.py, plain NumPy, one thread): on a sample of pixels of each
  scene, its time per pixel and its standard error at `MC_RAYS` rays per lens (20
  independent batches); the rays a pixel needs for a standard error of 1e-3 of white,
  N = n (stderr / 1e-3 white)^2, and the time extrapolated to N; compared with the native
  time per pixel at 1 thread (and, for 2 cores, half the MC time with the native at all
  threads: MC parallelises perfectly, at best).
- Peak memory of the native seed render (all threads) in a fresh process (VmHWM above
  the post-setup resident set, as run.py's --memory) against its raws plus its texture.
- One `raytrix-r12` fronto-parallel render at tol 1e-3 on all threads in a fresh process
  (its wall time, pixels/s and peak memory against raws + texture): the full sensor when
  the reduced scene's native time per pixel predicts at most `FULL_LIMIT_S`, else the
  central quarter of the sensor (Kx/2 x Ky/2 lenses), extrapolated by the pixel count.
  Not with --quick.

    python benches/w9_render.py --memory seed [--quick]    # child: peak MiB (JSON)
    python benches/w9_render.py --full quarter|full          # child: the big render (JSON)
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))  # mc_render (and its `reference`)

import numpy_render  # noqa: E402
from timing import timed  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native  # noqa: E402

Z = 1000.0
PLANE = (1000.0, 0.3, 0.1)  # Z = z0 + gx X + gy Y
TEXTURE = 512
#: Gauss-Legendre nodes per axis of the general-route twin's outer rule (over the pixel).
TWIN_NODES = 3
#: ... and of the second, independent twin's (over the lens cell; checked once, not timed
#: in the rounds).
CHECK_NODES = 32
#: Rays per contributing lens of the Monte-Carlo sample (20 batches).
MC_RAYS = 20_000
#: Target standard error / agreement of the general route, in units of white.
TOL_WHITE = 1e-3
#: The exact route's agreement, in units of white.
EXACT_WHITE = 1e-12
#: The full-sensor render runs whole when predicted at most this long, else a quarter.
FULL_LIMIT_S = 300.0
#: Issue 21's targets.
TARGETS = {"twin": 20.0, "mc": 100.0, "threads": 1.8, "peak": 1.5, "r12_fronto_s": 20.0}


def sizes(quick: bool) -> dict[str, Any]:
    return {
        "seed": "seed, 66 x 22 lenses" if quick else "seed, 266 x 88 lenses",
        "seed_K": (66, 22) if quick else None,
        "texture": 128 if quick else TEXTURE,
        "r12": "raytrix-r12 with Kx x Ky lenses",
        "r12_K": (3, 3) if quick else (8, 8),
        "twin_pixels": 24 if quick else 1000,
        "twin_nodes": TWIN_NODES,
        "check_pixels": 12 if quick else 300,
        "check_nodes": CHECK_NODES,
        "mc_pixels": 3 if quick else 128,
        "mc_rays": 2_000 if quick else MC_RAYS,
        "z_mm": Z,
        "plane": list(PLANE),
        "quick": quick,
    }


def _reduced(design: splitlf.Design, kx: int, ky: int) -> splitlf.Design:
    """The design with kx x ky lenses per channel (a sensor layout's grid shrunk to fit)."""
    chs = tuple(ch.replace(Kx=kx, Ky=ky, Mx=None, My=None) if ch.layout == "sensor"
                else ch.replace(Kx=kx, Ky=ky) for ch in design.channels)
    return design.replace(channels=chs)


def _texture(design: splitlf.Design, n: int, seed: int) -> splitlf.Image:
    """A random n x n image covering the design's view on the plane at Z."""
    x0, x1, y0, y1 = (float(v) for v in _native.render_extent(design.core, Z))
    rng = np.random.default_rng(seed)
    return splitlf.Image(rng.random((n, n)), width=max(x1 - x0, y1 - y0))


def _twin_scene(scene: splitlf.Scene) -> dict[str, Any]:
    tex = scene.texture
    p = scene.depth
    return {"image": tex.array, "extent": tex.extent, "plane": (p.z0, p.gx, p.gy),
            "background": scene.background}


def setup(sz: dict[str, Any]) -> dict[str, Any]:
    seed = splitlf.Design.preset("seed")
    if sz["seed_K"] is not None:
        seed = _reduced(seed, *sz["seed_K"])
    seed_tex = _texture(seed, sz["texture"], 1)
    r12_full = splitlf.Design.preset("raytrix-r12")
    r12_tex = _texture(r12_full, sz["texture"], 2)  # cells sized by the full sensor's view
    r12 = _reduced(r12_full, *sz["r12_K"])
    res = r12.resolved()[0]
    rng = np.random.default_rng(3)
    n = sz["twin_pixels"]
    pick = (rng.integers(0, res["My"], n), rng.integers(0, res["Mx"], n))
    scenes = {
        "seed": (seed, splitlf.Scene(seed_tex, Z)),
        "r12_fronto": (r12, splitlf.Scene(r12_tex, Z)),
        "r12_slanted": (r12, splitlf.Scene(r12_tex, splitlf.Plane(*PLANE))),
    }
    return {"scenes": scenes, "pick": pick, "nodes": sz["twin_nodes"],
            "check_pixels": sz["check_pixels"], "check_nodes": sz["check_nodes"]}


def native(inp: dict[str, Any], name: str, n_threads: int | None) -> tuple[np.ndarray, ...]:
    design, scene = inp["scenes"][name]
    return splitlf.render(design, scene, n_threads=n_threads, progress=False).images


def twin(inp: dict[str, Any], name: str) -> tuple[np.ndarray, ...]:
    design, scene = inp["scenes"][name]
    if name == "seed":
        tex = scene.texture
        out = numpy_render.render_exact(design, Z, tex.array, tex.extent)
        return tuple(out[f"channel{i}"] for i in range(1, len(design.channels) + 1))
    rows, cols = inp["pick"]
    return (numpy_render.render_pixels_s(design, 1, rows, cols, _twin_scene(scene),
                                       n_s=inp["nodes"]),)


def white(design: splitlf.Design) -> float:
    """A fully lit pixel's value under a white albedo (channel 1)."""
    return numpy_render.render_white(design, design.channels[0])


def raw_shapes(design: splitlf.Design) -> list[tuple[int, int]]:
    """Each channel's raw shape (docs/model.md §10, Raw image layout)."""
    return [(ch["Ky"] * ch["Q"], ch["Kx"] * ch["Q"]) if ch["layout"] == "ideal"
            else (ch["My"], ch["Mx"]) for ch in design.resolved()]


def pixels(design: splitlf.Design) -> int:
    """Pixels of every channel's raw."""
    return sum(r * c for r, c in raw_shapes(design))


def check(inp: dict[str, Any], name: str) -> dict[str, Any]:
    """The twin against the native raws at all threads and at 1 thread (raises on a
    mismatch); returns the largest differences in units of white."""
    design, scene = inp["scenes"][name]
    wh = white(design)
    ref = twin(inp, name)
    a, b = native(inp, name, None), native(inp, name, 1)
    threads = max(float(np.max(np.abs(x - y))) for x, y in zip(a, b, strict=True)) / wh
    if name == "seed":
        diff = max(float(np.max(np.abs(x - y))) for x, y in zip(ref, a, strict=True)) / wh
        limit = EXACT_WHITE
    else:
        rows, cols = inp["pick"]
        diff = float(np.max(np.abs(ref[0] - a[0][rows, cols]))) / wh
        limit = TOL_WHITE
    assert diff <= limit, f"W9 {name}: NumPy twin and native differ by {diff:.3g} white"
    assert threads <= EXACT_WHITE, f"W9 {name}: 1 and all threads differ by {threads:.3g} white"
    out = {"max_diff_white": diff, "limit_white": limit, "threads_max_diff_white": threads,
           "white": wh}
    if name != "seed":  # the second twin (the other order), once
        n = inp["check_pixels"]
        rows, cols = rows[:n], cols[:n]
        t0 = time.perf_counter()
        v = numpy_render.render_pixels(design, 1, rows, cols, _twin_scene(scene),
                                     n_xi=inp["check_nodes"])
        dt = time.perf_counter() - t0
        d2 = float(np.max(np.abs(v - a[0][rows, cols]))) / wh
        assert d2 <= TOL_WHITE, f"W9 {name}: the second twin and native differ by {d2:.3g} white"
        out["second_twin"] = {"pixels": n, "nodes": inp["check_nodes"], "max_diff_white": d2,
                              "us_per_pixel": dt / n * 1e6}
    return out


def monte_carlo(inp: dict[str, Any], name: str, n_pixels: int, n_rays: int,
                rng: np.random.Generator) -> dict[str, Any]:
    """tests/mc_render.py on n_pixels random pixels of the scene: per pixel its time at
    n_rays rays per contributing lens and its standard error; the rays per lens it needs
    for a standard error of TOL_WHITE x white, N = n_rays (stderr / target)^2, and its time
    at N (time x N / n_rays: the cost is linear in the rays)."""
    import mc_render

    design, scene = inp["scenes"][name]
    wh = white(design)
    target = TOL_WHITE * wh
    tex = scene.texture
    p = scene.depth
    sc = mc_render.scene(("image", list(tex.extent), tex.array),
                         ("plane", [p.z0, p.gx, p.gy]), scene.background)
    ch = design.resolved()[0]
    shape = raw_shapes(design)[0]
    rows, cols = rng.integers(0, shape[0], n_pixels), rng.integers(0, shape[1], n_pixels)
    times, errs, lenses = [], [], []
    for r, c in zip(rows.tolist(), cols.tolist(), strict=True):
        s, own = mc_render.pixel_centre(ch, r, c)
        n_l = len(own) if ch["layout"] == "ideal" else len(
            mc_render.candidate_lenses(design, ch, s))
        t0 = time.perf_counter()
        _, err = mc_render.mc_pixels(design, 1, [(r, c)], sc, n_rays=n_rays, n_batches=20,
                                     rng=rng)
        times.append(time.perf_counter() - t0)
        errs.append(float(err[0]))
        lenses.append(n_l)
    t, e, nl = np.array(times), np.array(errs), np.array(lenses)
    need = n_rays * (e / target) ** 2  # rays per lens
    per_pixel = t * need / n_rays
    return {
        "pixels": n_pixels, "rays_per_lens_sampled": n_rays,
        "ns_per_ray": float(t.sum() / (n_rays * nl.sum()) * 1e9),
        "lenses_per_pixel": float(nl.mean()),
        # variance of one ray per lens, in white^2: stderr^2 x n_rays
        "per_ray_variance_white2": float(np.mean((e / wh) ** 2 * n_rays)),
        "rays_needed_per_pixel": float(np.mean(need * nl)),
        "us_per_pixel": float(per_pixel.mean() * 1e6),
    }


def _child(cmd: list[str]) -> dict[str, Any]:
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), *cmd],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _status_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise KeyError(field)


def _measured_render(design: splitlf.Design, scene: splitlf.Scene) -> dict[str, Any]:
    """One native render at all threads, after resetting the resident-set high-water mark:
    wall time, pixels, peak extra resident memory, raw and texture bytes."""
    gc.collect()
    Path("/proc/self/clear_refs").write_text("5")
    base = _status_kib("VmRSS")
    t0 = time.perf_counter()
    raw = splitlf.render(design, scene, progress=False)
    dt = time.perf_counter() - t0
    peak = _status_kib("VmHWM")
    return {"seconds": dt, "pixels": int(sum(a.size for a in raw.images)),
            "peak_mib": (peak - base) / 1024.0,
            "output_bytes": int(sum(a.nbytes for a in raw.images)),
            "texture_bytes": int(scene.texture.array.nbytes)}


def memory_child(quick: bool) -> dict[str, Any]:
    inp = setup(sizes(quick))
    design, scene = inp["scenes"]["seed"]
    return _measured_render(design, scene)


def full_child(part: str) -> dict[str, Any]:
    """The R12 fronto-parallel render at full size, or its central quarter."""
    design = splitlf.Design.preset("raytrix-r12")
    tex = _texture(design, TEXTURE, 2)
    full = pixels(design)
    if part == "quarter":
        ch = design.channels[0]
        design = _reduced(design, ch.Kx // 2, ch.Ky // 2)
    r = _measured_render(design, splitlf.Scene(tex, Z))
    res = design.resolved()[0]
    r.update({"part": part, "Kx": res["Kx"], "Ky": res["Ky"], "Mx": res["Mx"], "My": res["My"],
              "full_pixels": full, "threads": os.cpu_count() or 1,
              "full_seconds": r["seconds"] * full / r["pixels"]})
    return r


SCENES = ("seed", "r12_fronto", "r12_slanted")


def run(quick: bool, rounds: int) -> dict[str, Any]:
    sz = sizes(quick)
    inp = setup(sz)
    n_all = os.cpu_count() or 1
    agreement = {name: check(inp, name) for name in SCENES}
    sides = {}
    for name in SCENES:
        sides[f"{name}/numpy"] = (twin, inp, name)
        sides[f"{name}/native_1"] = (native, inp, name, 1)
        sides[f"{name}/native_all"] = (native, inp, name, None)
    times: dict[str, list[float]] = {k: [] for k in sides}
    order = list(sides)
    for r in range(rounds):
        for side in order[r % len(order):] + order[:r % len(order)]:
            fn, *args = sides[side]
            times[side].append(timed(fn, *args))
    med = {k: statistics.median(v) for k, v in times.items()}
    scenes: dict[str, Any] = {}
    rng = np.random.default_rng(4)
    for name in SCENES:
        n_px = pixels(inp["scenes"][name][0])
        n_twin = n_px if name == "seed" else len(inp["pick"][0])
        us = {"numpy": med[f"{name}/numpy"] / n_twin * 1e6,
              "native_1": med[f"{name}/native_1"] / n_px * 1e6,
              "native_all": med[f"{name}/native_all"] / n_px * 1e6}
        mc = monte_carlo(inp, name, sz["mc_pixels"], sz["mc_rays"], rng)
        design, _ = inp["scenes"][name]
        scenes[name] = {
            "pixels": n_px, "twin_pixels": n_twin,
            "median_s": {side: med[f"{name}/{side}"] for side in ("numpy", "native_1",
                                                                   "native_all")},
            "us_per_pixel": us,
            "pixels_per_s": {side: 1e6 / us[side] for side in ("native_1", "native_all")},
            "ratio_numpy_over_native_1": us["numpy"] / us["native_1"],
            "ratio_numpy_over_native_all": us["numpy"] / us["native_all"],
            "speedup_1_to_all": us["native_1"] / us["native_all"],
            "agreement": agreement[name],
            "monte_carlo": mc,
            "ratio_mc_over_native_1": mc["us_per_pixel"] / us["native_1"],
            # MC split over the cores (at best) against the native at all threads
            "ratio_mc_all_over_native_all": mc["us_per_pixel"] / n_all / us["native_all"],
            "times_s": {side: times[f"{name}/{side}"] for side in ("numpy", "native_1",
                                                                  "native_all")},
        }
    del inp
    gc.collect()
    seed_mem = _child(["--memory"] + (["--quick"] if quick else []))
    seed_mem["peak_over_outputs_and_texture"] = seed_mem["peak_mib"] * 2**20 / (
        seed_mem["output_bytes"] + seed_mem["texture_bytes"])
    result: dict[str, Any] = {
        "workload": "W9", "kind": "render",
        "title": "`render`: seed (exact route) and raytrix-r12 (fronto-parallel and slanted)",
        "sizes": sz, "rounds": rounds, "threads_all": n_all, "scenes": scenes,
        "peak_memory_seed": seed_mem, "targets": TARGETS,
    }
    if not quick:
        us = scenes["r12_fronto"]["us_per_pixel"]["native_all"]
        full_px = pixels(splitlf.Design.preset("raytrix-r12"))
        predicted = us * 1e-6 * full_px
        part = "full" if predicted <= FULL_LIMIT_S else "quarter"
        big = _child(["--full", part])
        big["predicted_full_seconds"] = predicted
        big["peak_over_outputs_and_texture"] = big["peak_mib"] * 2**20 / (
            big["output_bytes"] + big["texture_bytes"])
        result["r12_full"] = big
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description="W9 children (run.py --only W9 runs W9)")
    ap.add_argument("--memory", action="store_true")
    ap.add_argument("--full", choices=("full", "quarter"))
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    if args.memory:
        print(json.dumps(memory_child(args.quick)))
    elif args.full:
        print(json.dumps(full_child(args.full)))
    else:
        ap.error("run W9 with `python benches/run.py --only W9`")


if __name__ == "__main__":
    main()
