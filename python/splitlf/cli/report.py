"""``splitlf report``: where a design is sharp and how densely it samples.

Print where the design (the seed design unless --config or --preset) is sharp and how
densely it samples: a summary of the design, its out-of-focus planes, the depth of field
of each channel (each half of the split sensor) and of their union, and the worst
resolution. --full adds every field of every channel, its lens types and the coincidence
planes where docs/model.md §6 holds.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..study.report import format_report, report_data
from . import _common


def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "report", __doc__,
                               summary="where a design is sharp and how densely it samples",
                               design="report",
                               threads="threads for the coincidence planes and the "
                               "resolution figures")
    _common.threshold_option(p)
    p.add_argument("--full", action="store_true",
                   help="every field of every channel, its lens types and the coincidence "
                   "planes (default: the short answer)")
    _common.output_group(p, None)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    subject, source = _common.load_subject(args)
    data = report_data(subject, args.threshold, n_threads=args.threads)
    if args.json:
        sys.stdout.write(_common.json_text({"source": source, **data}))
    else:
        sys.stdout.write(format_report(data, f"splitlf report: {source}", full=args.full))
    return 0
