"""The ``splitlf`` command line: :func:`main` and the top parser. Each command lives in a
module of its own beside its parser (``add_parser(subparsers)`` and ``run(args)``); the
option groups, argument types and helpers the commands share are in ``cli/_common.py``.

A user error (bad input, a file that cannot be read or would be overwritten) is one line on
stderr and exit status 2; every option is checked before any work or any file is written.
A fault of splitlf itself (``RuntimeError``, ``AssertionError``, ...) keeps its traceback.
Output files are never overwritten without ``--force`` and are written atomically (a
temporary file in the same folder, then a rename), so a failed run leaves the previous
file intact.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import NoReturn

from . import (
    compare,
    dataset,
    depth,
    explore,
    export,
    figures,
    optimise,
    reconstruct,
    render,
    report,
    simulate,
    sweep,
    trace,
)
from ._common import USER_ERRORS, CliError, json_text, load_design

__all__ = ["COMMANDS", "USER_ERRORS", "CliError", "build_parser", "json_text", "load_design",
           "main"]

#: The subcommands, in the order of ``splitlf --help``: each module's ``add_parser``
#: registers its parser and its ``run``.
COMMANDS = (report, figures, trace, sweep, simulate, render, dataset, export, reconstruct,
            depth, optimise, compare, explore)


class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line, like every other error of the command line."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand (report, figures, trace, sweep, simulate,
    render, dataset, export, reconstruct, depth, optimise, compare, explore)."""
    parser = _Parser(
        prog="splitlf",
        description="Design and analysis of split-sensor light field cameras.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                help="what to do (COMMAND --help for its options)")
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line on ``argv`` (default: ``sys.argv[1:]``); returns the exit
    status: 0, or 2 after a one-line message on stderr for a user error (argparse exits 2
    itself for a malformed command line). Other exceptions propagate: they are bugs."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print(f"splitlf {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (e.g. `splitlf report | head`): not an error of ours.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except FileNotFoundError as e:
        # an OSError names its file; check_new's (a missing output folder) says it all
        msg = f"no such file: {e.filename}" if e.filename is not None else str(e)
        print(f"splitlf {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except USER_ERRORS as e:
        msg = " ".join(str(e).split()) or type(e).__name__
        print(f"splitlf {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
