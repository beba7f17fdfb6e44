"""The ``splitlf`` command line. Errors are one line on stderr and exit status 2."""

from __future__ import annotations

import argparse
import json
import sys

from .camera import Camera
from .report import format_report, report_data


def _load_camera(path: str | None) -> tuple[Camera, str]:
    if path is None:
        return Camera.paper(), "seed design (MODEL.md §7, reconstructed from the paper)"
    return Camera.from_toml(path), path


def _cmd_report(args: argparse.Namespace) -> int:
    camera, source = _load_camera(args.config)
    data = report_data(camera, args.threshold)
    if args.json:
        data = {"source": source, **data}
        json.dump(data, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_report(data, f"splitlf report: {source}"))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="splitlf",
        description="Design and analysis of split-sensor light field cameras.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    rep = sub.add_parser(
        "report",
        help="the camera, its derived values, out-of-focus planes and depth of field",
        description="Print the camera (the seed design unless --config), its derived values, "
        "the out-of-focus planes and the depth-of-field intervals of each half, of the split "
        "sensor and of the conventional cameras.",
    )
    rep.add_argument("--config", metavar="CAM.toml", help="camera TOML file (default: seed design)")
    rep.add_argument("--json", action="store_true", help="print one JSON document")
    rep.add_argument(
        "--threshold", type=float, default=0.5, metavar="PX",
        help="sharpness threshold on the blur radius in pixels (default 0.5)",
    )
    rep.set_defaults(func=_cmd_report)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:
        # The reader went away (e.g. `splitlf report | head`): not an error of ours.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (ValueError, TypeError, OSError) as e:
        print(f"splitlf {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
