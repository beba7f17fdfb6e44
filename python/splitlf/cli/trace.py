"""``splitlf trace``: every pixel's ray-space polygon, written to an .npz file
(docs/model.md §3-4).

Trace every pixel of both halves along one axis (docs/model.md §3-4) and write the
arrays of splitlf.trace, prefixed half1_/half2_, with the camera as TOML, to an .npz
file. A general design with rect grids (--preset, or a --config file with a [design]
table) is traced channel by channel, prefixed channel1_, channel2_, ..., with the design
as TOML (design_toml).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from .._files import atomic_output
from . import _common

TRACE_FIELDS = ("vertices", "n_vertices", "area", "centroid", "lens", "pixel", "chief", "lit")




def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "trace", __doc__,
                               summary="write every pixel's ray-space polygon to .npz",
                               design="trace",
                               threads="threads of the trace")
    p.add_argument("--axis", choices=("x", "y"), default="x",
                   help="the sensor axis traced (default: x)")
    _common.output_group(p, "output file (default: trace.npz)", "FILE.npz", "trace.npz",
                         "print a JSON summary of the arrays instead of the path")
    p.set_defaults(func=run)


def _trace_half(t: Any) -> dict[str, Any]:
    """JSON summary of the trace of one half."""
    return {
        "pixels": int(t.area.size),
        "lit": int(np.count_nonzero(t.lit)),
        "polygons_by_vertex_count": {
            str(k): int(np.count_nonzero(t.n_vertices == k)) for k in range(7)
            if np.any(t.n_vertices == k)
        },
        "total_area_mm2": float(t.area.sum()),
    }


def run(args: argparse.Namespace) -> int:
    from ..plot._mpl import trace_threads
    from ..sampling import rayspace

    camera, source = _common.load_subject(args)
    out = Path(args.out)
    _common.check_suffix("--out", out, (".npz",))
    _common.check_output(out, args.force)
    threads = trace_threads(args.threads)
    hex_ = [i for i, ch in enumerate(camera.channels, start=1) if ch.grid != "rect"]
    if hex_:
        raise _common.CliError(f"trace: channel {hex_[0]} has a hex grid; the 1-D trace needs "
                               "rect grids (docs/architectures.md)")
    arrays: dict[str, Any] = {"design_toml": np.array(camera.to_toml())}
    parts = [(f"channel{c}", {"channel": c}) for c in range(1, len(camera.channels) + 1)]
    summary: dict[str, Any] = {"path": str(out), "source": source, "axis": args.axis}
    for prefix, which in parts:
        t = rayspace.trace(camera, axis=args.axis, **which, **threads)
        for name in TRACE_FIELDS:
            arrays[f"{prefix}_{name}"] = getattr(t, name)
        summary[prefix] = _trace_half(t)
    with atomic_output(out, force=args.force, hint=_common.FORCE_HINT) as tmp:
        np.savez_compressed(tmp, **arrays)
    sys.stdout.write(_common.json_text(summary) if args.json else f"{out}\n")
    return 0
