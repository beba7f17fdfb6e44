"""``splitlf explore``: the interactive design explorer in the browser (docs/explore.md).

Start the design explorer (docs/explore.md), a local web app, for a preset, a [design]
or [camera] TOML file, or the seed design, and print its URL. It binds 127.0.0.1 and
accepts only pages and websockets addressed to it. Ctrl-C stops it.
"""

from __future__ import annotations

import argparse
from typing import Any

from . import _common


def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "explore", __doc__,
                               summary="the interactive design explorer in the browser",
                               design="start from")
    p.add_argument("--port", type=_common.integer_type("port", 0, 65535), default=5006,
                   help="TCP port, an integer in [0, 65535]; 0 picks a free one (default 5006)")
    p.add_argument("--compare", default=None, metavar="NAME|FILE.toml",
                   help="a second design drawn on the same axes: a preset name or a "
                   "[design] or [camera] TOML file (e.g. an optimise result)")
    p.add_argument("--address", default="127.0.0.1", metavar="IP",
                   help="address to bind (default 127.0.0.1: this machine only)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        raise _common.CliError('explore needs Bokeh: pip install "splitlf[explore]"') from None
    from ..explorer import serve

    subject, _ = _common.load_subject(args)
    reference = None if args.compare is None else _common.named_design(args.compare)
    try:
        serve(subject, port=args.port, address=args.address, reference=reference)
    except OSError as e:
        raise _common.CliError(f"--port {args.port}: cannot listen on {args.address}: "
                               f"{e.strerror or e}") from None
    return 0
