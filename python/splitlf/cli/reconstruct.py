"""``splitlf reconstruct``: a super-resolved image from a raw file (docs/model.md §11,
docs/reconstruct.md).

Reconstruct the albedo on a grid of cells over a region of a known surface from a raw
file (docs/model.md §11, docs/reconstruct.md) and write it as a picture or an array.
"""

from __future__ import annotations

import argparse
import logging
import sys
from typing import Any

from . import _common


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("reconstruct", description=_common.described(__doc__),
                              help="a super-resolved image from a raw file")
    p.add_argument("raw", metavar="RAW.npz", help="a raw file (splitlf render, Raw.save)")
    p.add_argument("--depth", required=True, metavar="SPEC",
                   help="the surface: a depth in mm (a fronto-parallel plane), "
                   "plane:Z0,GX,GY (Z = Z0 + GX X + GY Y), or a .npy depth map (with "
                   "--extent; e.g. from splitlf depth --npy)")
    p.add_argument("--extent", default=None, metavar="X0,X1,Y0,Y1",
                   help="a .npy depth map's extent [mm] (splitlf depth prints it)")
    _common.grid_options(p, "what every channel sees through half its aperture",
                         "the sensor step mu_1 z / L_1")
    p.add_argument("--noise", type=_common.noise_type, default=None, metavar="N[,READ]",
                   help="the raw's noise, as given to render (default: the noise model the "
                   "raw file carries; for a file without one, estimated from the data)")
    p.add_argument("--regularization", type=_common.real_type(
        "regularization", 0.0, "a finite weight > 0"), default=None, metavar="LAMBDA",
        help="the smoothness prior's weight (default: chosen from the data by GCV)")
    p.add_argument("--tile", type=_common.integer_type("tile", 16, 10**9), default=None,
                   metavar="CELLS",
                   help="at most this many cells per side in one solve (default: one "
                   "solve, or tiles of the size that fits when one would not)")
    p.add_argument("--lens-types", default=None, metavar="T[,U...]",
                   help="use only the pixels under these lens types of a multi-focus array "
                   "(numbers from 1, in the order of the channel's f; default: all)")
    p.add_argument("--allow-slow", action="store_true",
                   help="run a reconstruction expected to take more than a few minutes "
                   "(without it, such a reconstruct is refused before it starts, saying "
                   "how long it would take)")
    _common.threads_option(p, "threads of the core")
    _common.array_output(p, "the image to write (.png with axes in mm over the extent, or .npy for "
                         "the array)", "IMAGE.png")
    p.set_defaults(func=run)


def _lens_types_option(args: argparse.Namespace) -> tuple[int, ...] | None:
    """``--lens-types T[,U...]`` as lens type numbers (None: all)."""
    return None if args.lens_types is None else _common.ints(args.lens_types, "--lens-types")


def _slow(args: argparse.Namespace) -> dict[str, Any]:
    """``allow_slow=True`` with ``--allow-slow``, else nothing: the library's default
    (refuse a reconstruction expected to take more than a few minutes)."""
    return {"allow_slow": True} if args.allow_slow else {}


class _PlanLines(logging.Handler):
    """The library's notes on stderr, one line each (the stream of the moment, so a
    replaced ``sys.stderr`` gets them)."""

    def emit(self, record: logging.LogRecord) -> None:
        print(f"splitlf {record.getMessage()}", file=sys.stderr, flush=True)


_PLAN_LINES = _PlanLines()


def _say_the_plan() -> None:
    """The library logs the grid's size, the memory plan and the expected time before
    the work (logger ``splitlf.reconstruct``, INFO): the command line prints them on
    stderr, so a long run is announced before it starts."""
    log = logging.getLogger("splitlf.reconstruct")
    if _PLAN_LINES not in log.handlers:
        log.addHandler(_PLAN_LINES)
    log.setLevel(logging.INFO)


def run(args: argparse.Namespace) -> int:
    _common.need("scipy", "reconstruct", "reconstruct")
    _say_the_plan()
    from ..errors import TooLargeError
    from ..imaging.render import Raw
    from ..inverse.reconstruct import reconstruct
    from ..plot.image import image

    out, npy = _common.array_targets(args, "reconstruct")
    raw = Raw.load(args.raw)
    depth = _common.parse_render_depth(args.depth, args.extent)
    region = None if args.region is None else _common.floats(args.region, 4, "--region")
    try:
        rec = reconstruct(raw, depth, region=region, step=args.step,
                          channels=_common.channels_option(args), noise=args.noise,
                          regularization=args.regularization, tile=args.tile,
                          n_threads=args.threads, progress=None,
                          lens_types=_lens_types_option(args), **_slow(args))
    except TooLargeError as e:  # the library's advice, in the command line's words
        raise _common.CliError(str(e).replace("allow_slow=True", "--allow-slow")) from None
    picture = _common.figure_picture(lambda ax: image(rec, ax))
    _common.write_array(args, out, npy, rec.image, picture)
    summary = {"path": str(out), "npy": None if npy is None else str(npy),
               "shape": list(rec.image.shape), "extent": list(rec.extent), "step": rec.step,
               "depth": rec.depth, "channels": list(rec.channels)}
    solves = getattr(rec, "colours", (rec,))  # a mosaiced raw: one solve per colour
    fields = ("rows", "iterations", "residual", "regularization", "regularization_rule",
              "noise", "noise_model", "noise_source", "tiles")
    summary.update({f: getattr(solves[0], f) if len(solves) == 1
                    else [getattr(r, f) for r in solves] for f in fields})
    sys.stdout.write(_common.json_text(summary) if args.json else f"{out}\n")
    return 0
