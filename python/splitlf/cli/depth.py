"""``splitlf depth``: a depth map from a raw file alone (docs/model.md §11, docs/depth.md)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from ._common import (
    array_output,
    array_targets,
    channels_option,
    floats,
    grid_options,
    json_text,
    numbers,
    threads_option,
    write_array,
)

#: What ``splitlf depth --help`` says the command does.
DESCRIPTION = (
    "Estimate the scene's depth from a raw file alone (a plane sweep: docs/model.md §11, "
    "docs/depth.md) and write it as a colour map (cells the method does not stand behind in "
    "grey) or an array."
)


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("depth", help="a depth map from a raw file", description=DESCRIPTION)
    p.add_argument("raw", metavar="RAW.npz", help="a raw file (splitlf render, Raw.save)")
    p.add_argument("--depths", required=True, metavar="ZMIN:ZMAX",
                   help="the candidate range in mm (uniform in 1/z), or Z1,Z2,... the "
                   "candidates themselves")
    p.add_argument("--candidates", type=int, default=None, metavar="N",
                   help="candidates of a ZMIN:ZMAX range (default 64)")
    grid_options(p, "what the channels see at the middle candidate",
                 "3 sensor steps mu_1 z / L_1 at the middle candidate")
    threads_option(p, "threads of the core")
    array_output(p, "the depth map to write (.png, or .npy for the array in mm)", "DEPTH.png")
    p.set_defaults(func=run)


def _depth_range(text: str) -> Any:
    """``--depths ZMIN:ZMAX`` -> (zmin, zmax); ``Z1,Z2,...`` -> the candidates."""
    if ":" in text:
        lo, _, hi = text.partition(":")
        return numbers("--depths", f"{lo},{hi}", 2)
    return numbers("--depths", text, len(text.split(",")))


def run(args: argparse.Namespace) -> int:

    from ..imaging.render import Raw
    from ..inverse.depth import estimate_depth

    out, npy = array_targets(args, "a depth map")
    raw = Raw.load(args.raw)
    depths = _depth_range(args.depths)
    region = None if args.region is None else floats(args.region, 4, "--region")
    kw: dict[str, Any] = {} if args.candidates is None else {"candidates": args.candidates}
    est = estimate_depth(raw, depths=depths, region=region, step=args.step,
                         channels=channels_option(args), n_threads=args.threads,
                         progress=None, **kw)
    assert est.confident is not None and est.sweep is not None

    def picture(tmp: Any) -> None:
        from ..plot._mpl import pyplot
        from ..plot.depth import depth as depth_plot

        fig, ax = pyplot().subplots(figsize=(7.5, 5.0), layout="constrained")
        depth_plot(est, ax)
        fig.savefig(tmp, format="png", dpi=110)
        pyplot().close(fig)

    write_array(args, out, npy, est.depth, picture)
    conf = est.confident
    z = est.depth[conf]
    summary = {"path": str(out), "npy": None if npy is None else str(npy),
               "shape": list(est.depth.shape), "extent": list(est.extent),
               "candidates": [float(est.sweep.candidates[0]), float(est.sweep.candidates[-1]),
                              int(est.sweep.candidates.size)],
               "channels": list(est.sweep.channels), "samples": est.sweep.samples,
               "confident": float(conf.mean()),
               "median_depth": float(np.median(z)) if z.size else None}
    sys.stdout.write(json_text(summary) if args.json else f"{out}\n")
    return 0
