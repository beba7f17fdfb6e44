"""``splitlf simulate``: super-resolution simulation at one or more depths
(docs/simulate.md).

Image a textured plane with half 1, half 2, the split sensor and the conventional
camera, reconstruct it with known depth and print RMSE, PSNR and MTF50
(docs/simulate.md). A general design with rect grids (--preset, or a --config file with
a [design] table) is simulated per channel, for their union and for the conventional
camera on channel 1's array plane.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from . import _common

#: Depths of ``splitlf simulate --z-range``: the allowed range of ``--n``.
SIMULATE_N_RANGE = (1, 1000)

#: Cells of delta(z) in the central field that ``splitlf simulate`` scores.
SIMULATE_WINDOW = 256


_n_depths = _common.integer_type("depth count", *SIMULATE_N_RANGE)




def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "simulate", __doc__,
                               summary="super-resolution simulation at one or more depths",
                               design="simulate", threads="threads of the core")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--z", type=_common.depth_type, default=1000.0, metavar="MM",
                       help="depth of the plane in mm (default 1000)")
    where.add_argument("--z-range", type=_common.depth_type, nargs=2, metavar=("A", "B"),
                       help="log-spaced depths from A to B mm (see --n)")
    p.add_argument("--n", type=_n_depths, default=None,
                   help=f"depths of --z-range, an integer in [{SIMULATE_N_RANGE[0]}, "
                   f"{SIMULATE_N_RANGE[1]}] (default 8)")
    p.add_argument("--texture", default="random",
                   help="random | sinusoid:F | bars:F (cycles/mm) | image:FILE.npy:WIDTH_MM")
    p.add_argument("--photons", type=_common.photons_type, default=None,
                   help="add noise: photo-electrons of a full-aperture pixel, white texture")
    p.add_argument("--read-noise", type=_common.read_noise_type, default=None, metavar="E",
                   help="read noise in electrons rms (needs --photons; default 0)")
    p.add_argument("--seed", type=_common.seed_type, default=0,
                   help="seed of the random texture and the noise, an integer >= 0 "
                   "(default 0)")
    p.add_argument("--no-conventional", action="store_true",
                   help="leave out the conventional camera (only the light field rows)")
    _common.output_group(p, "write the JSON document to a file", "FILE.json",
                         json_help="print one JSON document (with --out: as well)")
    p.set_defaults(func=run)


def parse_texture(spec: str) -> Any:
    """The texture of ``--texture``: random | sinusoid:F | bars:F (F in cycles/mm on the
    object) | image:FILE.npy:WIDTH_MM (a 2D array of albedos, WIDTH mm wide). Raises
    :class:`CliError` (or the loader's ``OSError``/``ValueError``) for anything else."""
    from ..inverse.simulate import BarChart, Image, RandomAlbedo, Sinusoid

    kind, _, rest = spec.partition(":")
    try:
        if kind == "random" and not rest:
            return RandomAlbedo()
        if kind in ("sinusoid", "bars"):
            f = float(rest)
            return Sinusoid(f) if kind == "sinusoid" else BarChart(f)
        if kind == "image":
            path, _, width = rest.rpartition(":")
            return Image(_common.load_npy(path, "texture"), float(width))
    except ValueError as e:
        raise _common.CliError(f"--texture {spec}: {e}") from None
    raise _common.CliError(f"--texture {spec}: allowed random, sinusoid:F, bars:F (cycles/mm) "
                           "or image:FILE.npy:WIDTH_MM")


def _simulate_depths(args: argparse.Namespace) -> list[float]:
    if args.z_range is None:
        if args.n is not None:
            raise _common.CliError("--n: only with --z-range")
        return [args.z]
    lo, hi = args.z_range
    if not lo < hi:
        raise _common.CliError(f"--z-range {lo:g} {hi:g}: needs 0 < A < B (mm)")
    return np.geomspace(lo, hi, 8 if args.n is None else args.n).tolist()


def _simulate_noise(args: argparse.Namespace) -> dict[str, float] | None:
    if args.photons is None:
        if args.read_noise is not None:
            raise _common.CliError("--read-noise: only with --photons (noise-free without it)")
        return None
    return {"photons": args.photons, "read_noise": args.read_noise or 0.0}


def _simulate_table(rows: list[dict[str, Any]], source: str, args: argparse.Namespace) -> str:
    """One line per depth and row of the simulation (each channel, the union, the
    conventional camera unless --no-conventional)."""
    noise = "noise-free" if args.photons is None else f"{args.photons:g} photons"
    width = max(13, *(len(c) + 1 for r in rows for c in r["rmse"]))
    out = [f"splitlf simulate: {source}; texture {args.texture}; {noise}; window "
           f"{SIMULATE_WINDOW} cells of delta(z)",
           f"{'z [mm]':>9}  {'config':<{width}}{'RMSE':>9}{'PSNR [dB]':>11}"
           f"{'MTF50 [c/mm]':>14}{'window [mm]':>13}"]
    for r in rows:
        for c in r["rmse"]:
            psnr = r["psnr_db"][c]
            out.append(f"{r['z_mm']:>9.1f}  {c:<{width}}{r['rmse'][c]:>9.4f}"
                       f"{math.inf if psnr is None else psnr:>11.2f}"
                       f"{r['mtf50_cycles_per_mm'][c]:>14.3f}"
                       f"{SIMULATE_WINDOW * r['delta_mm']:>13.3f}")
    return "\n".join(out) + "\n"


def run(args: argparse.Namespace) -> int:
    _common.need("scipy", "simulate", "simulate")
    from ..inverse.simulate import simulate

    out = None if args.out is None else Path(args.out)
    if out is not None:
        _common.check_suffix("--out", out, (".json",))
        _common.check_output(out, args.force)
    depths = _simulate_depths(args)
    noise = _simulate_noise(args)
    camera, source = _common.load_subject(args)
    texture = parse_texture(args.texture)
    rows = [simulate(camera, z, texture=texture, noise=noise, seed=args.seed,
                     window=SIMULATE_WINDOW, conventional=not args.no_conventional,
                     n_threads=args.threads).summary() for z in depths]
    doc = {"source": source, "texture": args.texture, "window_cells": SIMULATE_WINDOW,
           "results": rows}
    if out is not None:
        _common.write_text(out, _common.json_text(doc), args.force)
    return _common.print_result(args, out, lambda: doc, lambda: _simulate_table(rows, source, args))
