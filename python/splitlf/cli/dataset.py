"""``splitlf dataset``: N raws of random scenes with their ground truth, in one call
(docs/render.md, "Scale-out and datasets").

Scene k (k = 0 .. N-1) has the seed S + k (S = --seed) and is drawn from
numpy.random.default_rng([S + k, 2]): a plane Z = Z0 + GX X + GY Y with Z0 log-uniform on
--depths ZMIN:ZMAX [mm] and GX, GY uniform on [-G, G] (G = --tilt, default 0:
fronto-parallel), then a texture of i.i.d. albedos uniform on [0, 1] in square cells of
--cell mm (default delta(Z0) = mu_1 Z0 / L_1), centred on the axis, its cell edges on
multiples of the cell, covering what the pixels see at the plane's nearest and farthest
depths over the view at Z0 (beyond it, a steep plane's far side, the albedo is the
texture's mean, as for any splitlf.Image). Its raw is splitlf.render of that scene with
the seed S + k (the noise of --noise) on the core's threads, or cut into bands of rows on
the Dask cluster of --scheduler (the same raw bit for bit).

Writes, in the folder --out: sceneK.npz (the raw: splitlf.Raw.load reads it),
sceneK_truth.npz (format "splitlf-truth/1"; texture: the albedo of each cell, row 0 at
the top, which are the texture's cell means; texture_extent X0,X1,Y0,Y1 [mm]; plane
Z0,GX,GY; background; seed) and, last, index.json listing every scene and its files.
Each file is written atomically (complete or absent after an error or Ctrl-C); the index,
written once every scene is, marks a complete dataset.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from .. import _native
from .._files import atomic_output
from ..model.design import Design
from . import _common

#: The format entries of the ground-truth files and of the index.
TRUTH_FORMAT = "splitlf-truth/1"
INDEX_FORMAT = "splitlf-dataset/1"
#: Most scenes one call writes.
MAX_SCENES = 100_000
#: Default depth range [mm]: the studies' (splitlf.compare's DEPTH_RANGE).
DEFAULT_DEPTHS = "150:10000"


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("dataset", description=_common.described(__doc__),
                              help="N raws of random scenes with their ground truth")
    _common.design_argument(p)
    p.add_argument("-n", type=_common.integer_type("scene count", 1, MAX_SCENES), required=True,
                   metavar="N", help=f"the number of scenes (1 to {MAX_SCENES})")
    p.add_argument("--depths", default=DEFAULT_DEPTHS, metavar="ZMIN:ZMAX",
                   help=f"the planes' depth range at the axis, mm (default {DEFAULT_DEPTHS}; "
                   "ZMIN > F)")
    p.add_argument("--tilt", type=_common.real_type("tilt", 0.0, "a finite slope >= 0",
                                                    lo_open=False),
                   default=0.0, metavar="G", help="largest slope |GX|, |GY| of the planes "
                   "(default 0: fronto-parallel, the seed's exact route; a tilted plane takes "
                   "the general route, about 1 ms a pixel)")
    p.add_argument("--cell", type=_common.real_type("cell", 0.0, "a finite cell > 0 (mm)"),
                   default=None, metavar="MM",
                   help="the texture's cell (default delta(Z0) = mu_1 Z0 / L_1)")
    p.add_argument("--noise", type=_common.noise_type, default=None, metavar="N[,READ]",
                   help="add noise: N photo-electrons for value 1 (Poisson), READ electrons "
                   "rms of read noise (default: noise-free)")
    p.add_argument("--seed", type=_common.seed_type, default=0,
                   help="the seed S of scene 0 (scene k: S + k), an integer >= 0 (default 0)")
    _common.threads_option(p, "threads of the core (with --scheduler: of each task)")
    _common.scheduler_option(p, ": render each scene there, in bands of rows (the same raws)")
    _common.output_group(p, "the folder to write (created if missing)", "FOLDER", required=True,
                         json_help="print the index as JSON instead of its path")
    p.set_defaults(func=run)


def _depth_range(text: str, design: Design) -> tuple[float, float]:
    lo, colon, hi = text.partition(":")
    if not colon:
        raise _common.CliError(f"--depths {text}: expected ZMIN:ZMAX (mm)")
    zmin, zmax = _common.numbers("--depths", f"{lo},{hi}", 2)
    if not design.F < zmin <= zmax:
        raise _common.CliError(f"--depths {text}: allowed F = {design.F:g} < ZMIN <= ZMAX (mm)")
    return zmin, zmax


def _view(design: Design, z: float) -> tuple[float, float]:
    """Half-widths (X, Y) of what the pixels see on the fronto-parallel plane at z."""
    x0, x1, y0, y1 = _native.render_extent(design.core, z)
    return max(-x0, x1), max(-y0, y1)


def draw_scene(design: Design, seed: int, depths: tuple[float, float], tilt: float,
               cell: float | None) -> tuple[Any, dict[str, Any]]:
    """Scene ``seed`` of the dataset (module docstring) and its record: (a
    :class:`~splitlf.Scene` of an :class:`~splitlf.Image` on a :class:`~splitlf.Plane`,
    {"seed", "plane", "cell_mm", "texture_shape", "texture_extent", "background"})."""
    from ..imaging.render import Plane, Scene
    from ..imaging.texture import Image

    rng = np.random.default_rng([seed, 2])
    zmin, zmax = depths
    z0 = zmin * (zmax / zmin) ** rng.uniform()
    gx, gy = rng.uniform(-tilt, tilt, 2) if tilt > 0 else (0.0, 0.0)
    plane = Plane(float(z0), float(gx), float(gy))
    step = design.resolution_step(z0) if cell is None else cell
    hx, hy = _view(design, z0)
    lo, hi = plane.depths((-hx, hx, -hy, hy))
    near = design.F * (1 + 1e-9)
    for z in (min(max(lo, near), 4 * z0), min(max(hi, near), 4 * z0)):
        hx, hy = max(hx, _view(design, z)[0]), max(hy, _view(design, z)[1])
    cols, rows = 2 * math.ceil(hx / step), 2 * math.ceil(hy / step)
    texture = rng.uniform(0.0, 1.0, (rows, cols))
    image = Image(texture, cols * step)
    scene = Scene(image, plane)
    return scene, {"seed": seed, "plane": [plane.z0, plane.gx, plane.gy], "cell_mm": step,
                   "texture_shape": [rows, cols], "texture_extent": list(image.extent),
                   "background": scene.background}


def _targets(out: Path, n: int, force: bool) -> list[tuple[Path, Path]]:
    """Every file of the dataset, checked before any work (not overwritten without
    --force, the folder writable)."""
    _common.check_folder(out)
    files = [(out / f"scene{k}.npz", out / f"scene{k}_truth.npz") for k in range(n)]
    if out.is_dir():
        for path in [p for pair in files for p in pair] + [out / "index.json"]:
            _common.check_output(path, force)
    return files


def _write_truth(path: Path, scene: Any, record: dict[str, Any], force: bool) -> None:
    arrays = {"format": np.array(TRUTH_FORMAT), "texture": scene.texture.array,
              "texture_extent": np.array(record["texture_extent"]),
              "plane": np.array(record["plane"]), "background": np.array(scene.background),
              "seed": np.array(record["seed"], dtype=np.uint64)}
    with atomic_output(path, force=force, hint=_common.FORCE_HINT) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)


def _index(design: Design, args: argparse.Namespace, depths: tuple[float, float],
           scenes: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "format": INDEX_FORMAT,
        "design": design.design.to_toml(),
        "noise": args.noise,
        "render": "splitlf.render(design, scene, noise=noise, seed=seed), its default tol",
        "distribution": {"depths_mm": list(depths), "depth": "log-uniform Z0 on depths_mm",
                         "tilt": args.tilt, "slopes": "GX, GY uniform on [-tilt, tilt]",
                         "cell_mm": args.cell, "albedo": "i.i.d. uniform on [0, 1] per cell",
                         "draw": "numpy.random.default_rng([seed, 2]): Z0, then GX, GY "
                                 "(when tilt > 0), then the cells (rows, cols)"},
        "files": {"raw": "the raw, splitlf.Raw.save's format (splitlf.Raw.load)",
                  "truth": f"{TRUTH_FORMAT}: texture (albedo per cell, row 0 at the top: the "
                           "cell means), texture_extent [X0, X1, Y0, Y1] mm, plane [Z0, GX, "
                           "GY] (Z = Z0 + GX X + GY Y, mm), background, seed"},
        "scenes": scenes,
    }


def run(args: argparse.Namespace) -> int:
    from ..imaging.render import render

    design = _common.named_design(args.design)
    depths = _depth_range(args.depths, design)
    if args.seed + args.n - 1 > 2**63 - 1:
        raise _common.CliError(f"--seed {args.seed}: the seeds S .. S + N - 1 must stay "
                               "below 2**63")
    out = Path(args.out)
    files = _targets(out, args.n, args.force)
    out.mkdir(parents=True, exist_ok=True)
    scenes = []
    with _common.scheduler_executor(args) as executor:
        for k, (raw_path, truth_path) in enumerate(files):
            scene, record = draw_scene(design, args.seed + k, depths, args.tilt, args.cell)
            raw = render(design, scene, noise=args.noise, seed=args.seed + k,
                         n_threads=args.threads, executor=executor)
            raw.save(raw_path, force=args.force)
            _write_truth(truth_path, scene, record, args.force)
            scenes.append({"raw": raw_path.name, "truth": truth_path.name, **record})
    index = _index(design, args, depths, scenes)
    _common.write_text(out / "index.json", _common.json_text(index), args.force)
    sys.stdout.write(_common.json_text(index) if args.json else f"{out / 'index.json'}\n")
    return 0
