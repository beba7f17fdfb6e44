"""``splitlf export``: a raw for PlenoptiCam, plenpy or any TIFF reader (docs/export.md).

Write a raw file (splitlf render, Raw.save) into the folder DIR for --to plenopticam
(16-bit TIFFs, PlenoptiCam's calibration JSON beside the white image), plenpy (its camera
folder: Images/, Calibration/ with 16-bit PNGs and its grid file) or tiff (16-bit TIFFs and
the micro-image centres as CSV): per channel chN/, the raw, the white image of its design
(a noise-free render of a uniform white scene) and the centres of its micro images; beside
them splitlf.json (scale, clipping, orientation, design, noise model) and design.toml.
With --truth (a dataset's sceneK_truth.npz), the ground truth too (truth/). DIR must be
missing or empty unless --force; it is written whole or not at all.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from .._files import check_new_folder, open_regular
from . import _common

#: The targets, as splitlf.export names them.
TARGETS = ("plenopticam", "plenpy", "tiff")


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("export", help="a raw for PlenoptiCam, plenpy or TIFF readers",
                              description=_common.described(__doc__))
    p.add_argument("raw", metavar="RAW.npz", help="a raw file (splitlf render, Raw.save)")
    p.add_argument("directory", metavar="DIR", help="the folder to write (missing or empty)")
    p.add_argument("--to", required=True, choices=TARGETS, dest="target",
                   help="the target: plenopticam, plenpy or tiff")
    p.add_argument("--truth", default=None, metavar="TRUTH.npz",
                   help="the raw's ground truth as splitlf dataset writes it "
                   "(sceneK_truth.npz): its texture and plane, exported to truth/")
    p.add_argument("--scale", type=_common.real_type("--scale", 0.0, "a number > 0"),
                   default=None, metavar="S",
                   help="digital numbers per unit of value (default: 65535 over the white "
                   "image's brightest pixel)")
    _common.threads_option(p, "threads of the core for the white image")
    _common.output_group(p, None, json_help="print the sidecar (splitlf.json) on stdout")
    p.set_defaults(func=run)


def _truth_scene(path: str) -> Any:
    """The scene of a dataset's truth file (format splitlf-truth/1): its texture as an
    Image over texture_extent on the plane Z = Z0 + GX X + GY Y."""
    from ..imaging.render import Plane, Scene
    from ..imaging.texture import Image
    from .dataset import TRUTH_FORMAT

    try:
        with open_regular(path, "a truth file") as fh, np.load(fh, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except FileNotFoundError:
        raise
    except (OSError, ValueError, EOFError) as e:
        raise _common.CliError(f"--truth {path}: not a NumPy .npz archive ({e})") from None
    need = ("format", "texture", "texture_extent", "plane", "background")
    if any(k not in arrays for k in need) or str(arrays["format"]) != TRUTH_FORMAT:
        raise _common.CliError(f"--truth {path}: not a {TRUTH_FORMAT} file (splitlf dataset's "
                               f"sceneK_truth.npz, with {', '.join(need)})")
    x0, x1, _, _ = (float(v) for v in arrays["texture_extent"])
    image = Image(arrays["texture"], x1 - x0)
    z0, gx, gy = (float(v) for v in arrays["plane"])
    return Scene(image, Plane(z0, gx, gy), background=float(arrays["background"]))


def run(args: argparse.Namespace) -> int:
    from ..exchange.export import libraries

    for module in libraries(args.target, args.truth is not None):
        _common.need(module, "export", "export")
    from ..exchange.export import export
    from ..imaging.render import Raw

    _common.check_folder(Path(args.directory), "DIR")
    check_new_folder(args.directory, args.force, _common.FORCE_HINT)
    raw = Raw.load(args.raw)
    scene = None if args.truth is None else _truth_scene(args.truth)
    opts = {} if args.threads is None else {"n_threads": args.threads}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        done = export(raw, args.target, args.directory, scene=scene, scale=args.scale,
                      white_options=opts, overwrite=args.force)
    for w in caught:
        print(f"splitlf export: warning: {w.message}", file=sys.stderr)
    if args.json:
        sys.stdout.write(_common.json_text(done.sidecar))
    else:
        n = len(done.sidecar["channels"])
        print(f"wrote {done.directory} ({args.target}: {n} channel(s), scale "
              f"{done.sidecar['scale']['dn_per_unit']:.6g} DN per unit, "
              f"{done.clipped} pixels clipped)")
    return 0

