"""``splitlf depth``: a depth map from a raw file alone (docs/model.md §11, docs/depth.md).

Estimate the scene's depth from a raw file alone (a plane sweep: docs/model.md §11,
docs/depth.md) and write it as a colour map (cells the method does not stand behind in
grey) or an array.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from .._files import atomic_output
from . import _common


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("depth", help="a depth map from a raw file",
                              description=_common.described(__doc__))
    p.add_argument("raw", metavar="RAW.npz", help="a raw file (splitlf render, Raw.save)")
    p.add_argument("--depths", required=True, metavar="ZMIN:ZMAX",
                   help="the candidate range in mm (uniform in 1/z), or Z1,Z2,... the "
                   "candidates themselves")
    p.add_argument("--candidates", type=int, default=None, metavar="N",
                   help="candidates of a ZMIN:ZMAX range (default 64)")
    _common.grid_options(p, "what the channels see at the middle candidate",
                         "3 sensor steps mu_1 z / L_1 at the middle candidate")
    _common.threads_option(p, "threads of the core")
    _common.array_output(p, "the depth map to write (.png, or .npy for the array in mm; every "
                         ".npy depth map gets its confidence beside it, NAME.confident.npy)",
                         "DEPTH.png",
                         npy_help="with a .png output, also write the depth in mm beside it "
                         "(.npy) and its confidence (NAME.confident.npy: True where the method "
                         "stands behind the cell; the depth .npy holds a depth in every cell, "
                         "elsewhere the nearest confident cell's)")
    p.set_defaults(func=run)


def _depth_range(text: str) -> Any:
    """``--depths ZMIN:ZMAX`` -> (zmin, zmax); ``Z1,Z2,...`` -> the candidates."""
    if ":" in text:
        lo, _, hi = text.partition(":")
        return _common.numbers("--depths", f"{lo},{hi}", 2)
    return _common.numbers("--depths", text, len(text.split(",")))


def confidence_path(depth_npy: Path) -> Path:
    """Where the confidence of the depth array ``depth_npy`` goes: NAME.confident.npy
    beside NAME.npy."""
    return depth_npy.with_name(f"{depth_npy.stem}.confident.npy")


def run(args: argparse.Namespace) -> int:
    _common.need("scipy", "depth", "reconstruct")
    from ..imaging.render import Raw
    from ..inverse.depth import estimate_depth
    from ..plot.depth import depth as depth_plot

    out, npy = _common.array_targets(args, "a depth map")
    depth_npy = out if out.suffix == ".npy" else npy
    conf_npy = None if depth_npy is None else _common.check_output(confidence_path(depth_npy),
                                                                   args.force)
    raw = Raw.load(args.raw)
    depths = _depth_range(args.depths)
    region = None if args.region is None else _common.floats(args.region, 4, "--region")
    kw: dict[str, Any] = {} if args.candidates is None else {"candidates": args.candidates}
    est = estimate_depth(raw, depths=depths, region=region, step=args.step,
                         channels=_common.channels_option(args), n_threads=args.threads,
                         progress=None, **kw)
    assert est.confident is not None and est.sweep is not None
    conf = est.confident
    picture = _common.figure_picture(lambda ax: depth_plot(est, ax))
    _common.write_array(args, out, npy, est.depth, picture)
    if conf_npy is not None:
        with atomic_output(conf_npy, force=args.force, hint=_common.FORCE_HINT) as tmp:
            np.save(tmp, np.asarray(conf, dtype=bool))
    z = est.depth[conf]
    summary = {"path": str(out), "npy": None if npy is None else str(npy),
               "confident_npy": None if conf_npy is None else str(conf_npy),
               "shape": list(est.depth.shape), "extent": list(est.extent),
               "candidates": [float(est.sweep.candidates[0]), float(est.sweep.candidates[-1]),
                              int(est.sweep.candidates.size)],
               "channels": list(est.sweep.channels), "samples": est.sweep.samples,
               "confident": float(conf.mean()),
               "median_depth": float(np.median(z)) if z.size else None}
    sys.stdout.write(_common.json_text(summary) if args.json else f"{out}\n")
    return 0
