"""The helpers every command of the command line shares, written once: the user error
(:class:`CliError`) and what counts as one, loading designs, JSON output, argument types
that name what they expect, the option groups (design source, threads, output, depths,
...), output checks and writers, and the parsing of values several commands take."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .. import _native
from .._files import atomic_output, check_writable, json_safe, probe_folder, read_npy, read_toml
from ..errors import InvalidParameter, SplitlfError
from ..model.camera import Camera
from ..model.design import PRESETS, Design

SEED = "seed design (docs/model.md §7, reconstructed from the paper)"

#: Threads of the core: the allowed range of ``--threads``.
THREADS_RANGE = (1, _native.MAX_THREADS)

#: What the CLI reports as a user error (one line, exit 2); anything else is a bug.
#: (read_toml reports invalid TOML as a ValueError naming the file; a MemoryError is input
#: too large for this machine: splitlf.TooLargeError, or NumPy's for a malformed .npy.)
USER_ERRORS = (SplitlfError, ValueError, TypeError, OSError, MemoryError)

FORCE_HINT = "pass --force to overwrite"


class CliError(SplitlfError):
    """A user error found by the command line, with a message fit for one line."""


def need(module: str, command: str, extra: str) -> None:
    """Refuse, in one line naming the extra to install, when an optional dependency is
    missing (``sys.modules[module] = None`` counts as missing too)."""
    import importlib

    try:
        importlib.import_module(module)
    except ImportError:
        raise CliError(f'{command} needs {module}: pip install "splitlf[{extra}]"') from None


def load_design(path: str) -> Design:
    """The design of a TOML file: a ``[design]`` table (and its ``[[design.channels]]``)
    or a ``[camera]`` table (the paper's fields; a Camera is a Design). Validated once,
    here, before any subcommand writes anything: every error is a :class:`CliError` that
    names the file (``no such file: PATH`` when it is missing)."""
    try:
        doc = read_toml(path)
        return (Design.from_toml if "design" in doc else Camera.from_toml)(path)
    except FileNotFoundError:
        raise CliError(f"no such file: {path}") from None
    except IsADirectoryError:
        raise CliError(f"{path}: a folder, not a TOML file") from None
    except (ValueError, TypeError) as e:
        msg = str(e)
        raise CliError(msg if msg.startswith(path) else f"{path}: {msg}") from None


def named_design(spec: str) -> Design:
    """A design named on the command line: a preset name, else a [design] or [camera]
    TOML file (:func:`load_design`)."""
    return Design.preset(spec) if spec in PRESETS else load_design(spec)


def json_text(data: Any) -> str:
    """The whole JSON document as text (built before anything is written, so a value that
    cannot be serialised never leaves half a document behind); inf and NaN become null."""
    return json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n"


def write_text(path: Path, text: str, force: bool) -> None:
    with atomic_output(path, force=force, hint=FORCE_HINT) as tmp:
        tmp.write_text(text, encoding="utf-8")


def check_suffix(option: str, path: Path, allowed: Iterable[str]) -> None:
    allowed = tuple(allowed)
    if path.suffix not in allowed:
        raise CliError(f"{option} {path}: allowed suffixes {', '.join(allowed)}")


def check_output(path: str | os.PathLike[str], force: bool) -> Path:
    """An output file, checked before any work (``splitlf._files.check_writable``): not
    overwritten without ``--force``, its folder exists, and a trial file can be created
    in that folder (an unwritable folder is refused now, in words naming it, not after
    the computation). Returns the path."""
    return check_writable(path, force, FORCE_HINT)


def check_folder(folder: Path, option: str = "--out") -> None:
    """An output folder that the command creates when missing: it, or its nearest
    existing ancestor when it is missing, must be a folder that can be written."""
    if folder.exists() and not folder.is_dir():
        raise CliError(f"{option} {folder}: exists and is not a folder")
    base = folder
    while not base.exists():
        base = base.parent
    if not base.is_dir():
        raise CliError(f"{option} {folder}: {base} is not a folder")
    try:
        probe_folder(base, folder)
    except OSError as e:
        raise CliError(e.strerror) from None


def integer_type(what: str, lo: int, hi: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        """An integer in [lo, hi], else argparse's error naming ``what``."""
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"invalid {what} {text!r}: allowed an integer in [{lo}, {hi}]") from None
        if not lo <= n <= hi:
            raise argparse.ArgumentTypeError(
                f"invalid {what} {text}: allowed an integer in [{lo}, {hi}]")
        return n

    parse.__name__ = what
    return parse


def real_type(what: str, lo: float, allowed: str, *, lo_open: bool = True
               ) -> Callable[[str], float]:
    def parse(text: str) -> float:
        """A finite real above ``lo``, else argparse's error naming ``what``."""
        try:
            x = float(text)
        except ValueError:
            x = math.nan
        if not (math.isfinite(x) and (x > lo if lo_open else x >= lo)):
            raise argparse.ArgumentTypeError(f"invalid {what} {text!r}: allowed {allowed}")
        return x

    parse.__name__ = what
    return parse


threads_type = integer_type("thread count", *THREADS_RANGE)


depth_type = real_type("depth", 0.0, "a finite depth > 0 (mm)")


seed_type = integer_type("seed", 0, 2**63 - 1)


photons_type = real_type("photon count", 0.0, "a finite number > 0")


read_noise_type = real_type("read noise", 0.0, "a finite number >= 0 (electrons rms)",
                            lo_open=False)


threshold_type = real_type("threshold", 0.0, "a finite number > 0 (pixels)")


window_type = real_type("window", 0.0, "a finite number > 0 (the 2-D central field's width in "
                        "lens pitches of channel 1)")


def load_subject(args: argparse.Namespace) -> tuple[Design, str]:
    """What a subcommand works on, and its name: a preset (``--preset``), a [design] or
    [camera] TOML file (``--config``), or the seed design."""
    if args.preset is not None:
        if args.config is not None:
            raise CliError("--preset and --config: give one of them")
        return Design.preset(args.preset), f"preset {args.preset}"
    if args.config is not None:
        return load_design(args.config), args.config
    return Camera.paper(), SEED


def load_npy(path: str, what: str = "array") -> Any:
    """The array of a .npy file, read safely (``splitlf._files.read_npy``: a regular
    file, its header checked, its declared size within the memory budget before loading);
    ``what`` names the input in errors ("texture", "depth")."""
    try:
        return read_npy(path, what)
    except FileNotFoundError:
        raise CliError(f"no such file: {path}") from None


def numbers(option: str, text: str, n: int) -> tuple[float, ...]:
    """``n`` comma-separated finite numbers, else :class:`CliError` naming ``option``."""
    try:
        values = tuple(float(t) for t in text.split(","))
    except ValueError:
        values = ()
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise CliError(f"{option} {text}: allowed {n} comma-separated finite number"
                       f"{'s' if n > 1 else ''}" + (" (a depth in mm, plane:Z0,GX,GY or a "
                                                    ".npy depth map)" if n == 1 else ""))
    return values


def noise_type(text: str) -> dict[str, float]:
    """``--noise N[,READ]``: photo-electrons for value 1 and read noise (electrons rms)."""
    photons, _, read = text.partition(",")
    try:
        return {"photons": photons_type(photons),
                "read_noise": read_noise_type(read) if read else 0.0}
    except argparse.ArgumentTypeError as e:
        raise argparse.ArgumentTypeError(f"--noise {text}: {e}") from None


noise_type.__name__ = "noise"


def parse_render_depth(spec: str, extent: str | None) -> Any:
    """The surface of ``render --depth``: a depth [mm] | plane:Z0,GX,GY | a .npy depth map
    (needs ``extent`` X0,X1,Y0,Y1 [mm])."""
    from ..imaging.render import DepthMap, Plane

    if spec.lower().endswith(".npy"):
        if extent is None:
            raise CliError(f"--depth {spec}: a depth map needs --extent X0,X1,Y0,Y1 (mm)")
        box: Any = numbers("--extent", extent, 4)
        try:
            return DepthMap(load_npy(spec, "depth"), box)
        except (TypeError, ValueError) as e:
            raise CliError(f"--depth {spec}: {e}") from None
    if extent is not None:
        raise CliError("--extent: only with a .npy depth map as --depth")
    try:
        if spec.startswith("plane:"):
            return Plane(*numbers("--depth plane:", spec[6:], 3))
        return Plane(numbers("--depth", spec, 1)[0])
    except ValueError as e:
        raise CliError(f"--depth {spec}: {e}") from None


def floats(text: str, n: int, option: str) -> tuple[float, ...]:
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != n:
        raise CliError(f"{option} {text}: give {n} comma-separated numbers")
    return values


def ints(text: str, option: str) -> tuple[int, ...]:
    """Comma-separated whole numbers (a number with a fraction is refused, not cut)."""
    values = floats(text, len(text.split(",")), option)
    if not all(math.isfinite(v) and v == int(v) for v in values):
        raise CliError(f"{option} {text}: give comma-separated whole numbers")
    return tuple(int(v) for v in values)


def channels_option(args: argparse.Namespace) -> tuple[int, ...] | None:
    """``--channels I[,J...]`` as channel numbers (None: all)."""
    return None if args.channels is None else ints(args.channels, "--channels")


def array_targets(args: argparse.Namespace, what: str) -> tuple[Path, Path | None]:
    """``--out`` (.png or .npy) and, with ``--npy`` beside a .png, the array's path; both
    checked as new (or ``--force``), matplotlib checked for a .png."""
    out = Path(args.out)
    check_suffix("--out", out, (".png", ".npy"))
    npy = out.with_suffix(".npy") if args.npy and out.suffix == ".png" else None
    if out.suffix == ".png":
        need("matplotlib", f"{what} to a PNG", "plot")
    for target in (out, npy):
        if target is not None:
            check_output(target, args.force)
    return out, npy


def write_array(args: argparse.Namespace, out: Path, npy: Path | None, array: Any,
                picture: Callable[[Any], None]) -> None:
    """The array as ``out`` (.npy) or as the picture ``picture(file)`` draws (.png), and
    beside it ``npy``: each written atomically."""
    import contextlib

    with contextlib.ExitStack() as stack:
        if npy is not None:
            with atomic_output(npy, force=args.force, hint=FORCE_HINT) as tmp:
                np.save(tmp, array)
        tmp = stack.enter_context(atomic_output(out, force=args.force, hint=FORCE_HINT))
        if out.suffix == ".npy":
            np.save(tmp, array)
        else:
            picture(tmp)


def parse_constraint(spec: str) -> tuple[str, tuple[str, float]]:
    """``--constraint MERIT<=VALUE`` or ``MERIT>=VALUE``."""
    for op in ("<=", ">="):
        merit, found, value = spec.partition(op)
        if found:
            try:
                return merit.strip(), (op, float(value))
            except ValueError:
                break
    raise CliError(f"--constraint {spec}: expected MERIT<=VALUE or MERIT>=VALUE")


def log_depths(spec: str, option: str = "--depths") -> np.ndarray:
    parts = spec.split(":")
    try:
        lo, hi, num = float(parts[0]), float(parts[1]), int(parts[2])
        if len(parts) != 3:
            raise ValueError
    except (ValueError, IndexError):
        raise CliError(f"{option} {spec}: expected MIN:MAX:NUM (mm, log-spaced)") from None
    if not (0 < lo < hi and math.isfinite(hi) and 2 <= num <= 100_000):
        raise CliError(f"{option} {spec}: needs 0 < MIN < MAX (mm) and NUM in [2, 100000]")
    return np.geomspace(lo, hi, num)


#: The API's parameter names of optimise and compare -> the options a CLI user wrote.
OPTION_OF = {"objective": "--objective", "constraints": "--constraint", "free": "--free",
             "sense": "--sense", "min_microlens_f_number": "--min-microlens-f-number",
             "merits_2d": "--merits-2d", "window": "--window", "which": "--architectures",
             "depths": "--depths", "optimise_depths": "--optimise-depths",
             "simulate_depths": "--simulate-depths", "threshold_px": "--threshold"}


def in_cli_words(e: InvalidParameter) -> CliError | InvalidParameter:
    """An API error of optimise or compare in the CLI's words: the option the user wrote
    instead of the parameter's name, and no callable (the CLI takes a merit name)."""
    import re

    key = e.name.split("[")[0]
    if key not in OPTION_OF:
        return e
    msg = str(e).replace(f"invalid {e.name}", f"invalid {OPTION_OF[key]}", 1)
    msg = re.sub(r"a merit name \((.*)\) or a callable.*$", r"one of: \1", msg)
    return CliError(msg.replace(" or a callable", ""))


def search(run: Callable[..., Any], args: argparse.Namespace, *call: Any,
           **kwargs: Any) -> Any:
    """``run(*call, **kwargs)`` in process or on the Dask scheduler of --scheduler, its
    argument errors in the CLI's words."""
    try:
        if args.scheduler is None:
            return run(*call, **kwargs)
        try:
            from distributed import Client
        except ImportError:
            raise CliError('--scheduler needs Dask: pip install "splitlf[dask]"') from None
        with Client(args.scheduler) as client:
            return run(*call, executor=client.get_executor(), **kwargs)
    except InvalidParameter as e:
        raise in_cli_words(e) from None


@contextlib.contextmanager
def scheduler_executor(args: argparse.Namespace) -> Iterator[Any]:
    """None without --scheduler; else, while the block runs, a client of that Dask
    scheduler's ``concurrent.futures`` executor (``client.get_executor()``)."""
    if args.scheduler is None:
        yield None
        return
    try:
        from distributed import Client
    except ImportError:
        raise CliError('--scheduler needs Dask: pip install "splitlf[dask]"') from None
    with Client(args.scheduler) as client:
        yield client.get_executor()


def design_argument(p: argparse.ArgumentParser) -> None:
    """The positional DESIGN of `render` and `dataset`: a preset or a TOML file."""
    p.add_argument("design", metavar="DESIGN",
                   help=f"a preset ({', '.join(PRESETS)}) or a TOML file with a [design] "
                   "or [camera] table")


def design_source(p: argparse.ArgumentParser, what: str) -> None:
    """The design source: --config FILE (a [camera] or [design] TOML) or --preset NAME."""
    g = p.add_argument_group("design (default: the seed design)")
    g.add_argument("--config", metavar="FILE.toml",
                   help="a TOML file with a [camera] table, or a [design] table and its "
                   "[[design.channels]] (docs/architectures.md)")
    g.add_argument("--preset", choices=PRESETS, default=None, metavar="NAME",
                   help=f"{what} a named design instead: {', '.join(PRESETS)} "
                   "(docs/architectures.md)")


def design_command(subparsers: Any, name: str, doc: str | None, *, summary: str, design: str,
                   threads: str | None = None) -> argparse.ArgumentParser:
    """The parser of a command that works on one design: its ``--help`` from the module
    docstring ``doc`` (:func:`described`), ``summary`` in the list of commands, the design
    source (``design`` says what the command does with it) and, when ``threads`` says what
    they run, ``--threads``."""
    p = subparsers.add_parser(name, description=described(doc), help=summary)
    design_source(p, design)
    if threads is not None:
        threads_option(p, threads)
    return p


def print_result(args: argparse.Namespace, out: Path | None, document: Callable[[], Any],
                 table: Callable[[], str]) -> int:
    """Print what a command that may also write ``out`` found: with ``--json`` its JSON
    document (with the path it wrote, if any), else the path it wrote, else its table.
    ``document`` and ``table`` are only called when printed. Returns 0."""
    if args.json:
        doc = document()
        sys.stdout.write(json_text(doc if out is None else {"path": str(out), **doc}))
    elif out is not None:
        print(out)
    else:
        sys.stdout.write(table())
    return 0


def threads_option(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--threads", type=threads_type, default=None, metavar="N",
                   help=f"{what} (an integer in [{THREADS_RANGE[0]}, "
                   f"{THREADS_RANGE[1]}]; default: all cores)")


def output_group(p: argparse.ArgumentParser, out: str | None, metavar: str = "FILE",
                 default: str | None = None, json_help: str = "print one JSON document",
                 required: bool = False) -> Any:
    """The output group: --out (when ``out`` says what it writes; also -o when
    ``required``), --force, --json (unless ``json_help`` is empty). Returns the group."""
    g = p.add_argument_group("output")
    if out is not None:
        g.add_argument("--out", *(["-o"] if required else []), default=default,
                       metavar=metavar, help=out, required=required)
    g.add_argument("--force", action="store_true",
                   help="overwrite existing output files (default: refuse)")
    if json_help:
        g.add_argument("--json", action="store_true", help=json_help)
    return g


def depths_option(p: argparse.ArgumentParser, option: str, default: str, what: str) -> None:
    p.add_argument(option, default=default, metavar="MIN:MAX:NUM",
                   help=f"log-spaced depths of {what} [mm] (default {default})")


def scheduler_option(p: argparse.ArgumentParser, what: str = "") -> None:
    """--scheduler ADDRESS; ``what`` says what the command does on it."""
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help=f"Dask scheduler address, e.g. tcp://host:8786{what}")


def threshold_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--threshold", type=threshold_type, default=0.5, metavar="PX",
                   help="sharpness threshold on the blur radius in pixels (default 0.5)")


def merits_2d_options(p: argparse.ArgumentParser, what: str, default: str) -> None:
    p.add_argument("--merits-2d", action="store_true", help=what)
    p.add_argument("--window", type=window_type, default=None, metavar="W",
                   help="width of the 2-D merits' central field in lens pitches of channel 1 "
                   f"({default}; docs/optimise.md, '2-D merits')")


def grid_options(p: Any, region_default: str, step_default: str) -> None:
    """--region, --step and --channels of the commands that solve on a grid of cells."""
    p.add_argument("--region", default=None, metavar="X0,X1,Y0,Y1",
                   help=f"the region [mm] (default: {region_default}; with a negative X0: "
                   "--region=X0,X1,Y0,Y1)")
    p.add_argument("--step", type=real_type("step", 0.0, "a finite step > 0 (mm)"),
                   default=None, metavar="MM", help=f"the cell pitch (default: {step_default})")
    p.add_argument("--channels", default=None, metavar="I[,J...]",
                   help="channel numbers from 1 (default: all)")


def array_output(p: Any, what: str, metavar: str,
                 npy_help: str = "with a .png output, also write the array beside it (.npy)"
                 ) -> None:
    """-o (.png or .npy), --json and --npy of the commands that write an array."""
    g = output_group(p, what, metavar, required=True,
                     json_help="print a JSON summary instead of the path")
    g.add_argument("--npy", action="store_true", help=npy_help)


def figure_picture(draw: Callable[[Any], Any]) -> Callable[[Any], None]:
    """The writer of a PNG of one Axes (7.5 x 5 in, 110 dpi) that ``draw(ax)`` fills:
    the picture of an array command (:func:`write_array`)."""
    def picture(tmp: Any) -> None:
        from ..plot._mpl import pyplot

        fig, ax = pyplot().subplots(figsize=(7.5, 5.0), layout="constrained")
        try:
            draw(ax)
            fig.savefig(tmp, format="png", dpi=110)
        finally:
            pyplot().close(fig)

    return picture


def objective_options(p: argparse.ArgumentParser, objective: str, example: str = "") -> None:
    """--objective (what it optimises: ``objective``), --sense and --constraint (repeat;
    ``example`` ends its help) of the commands that search for a design."""
    p.add_argument("--objective", required=True, metavar="MERIT", help=objective)
    p.add_argument("--sense", choices=("max", "min"), default=None,
                   help="maximise or minimise (default: the merit's natural direction)")
    p.add_argument("--constraint", action="append", metavar="MERIT<=VALUE",
                   help=f"a constraint MERIT<=VALUE or MERIT>=VALUE (repeat){example}")


def evolution_options(p: argparse.ArgumentParser, maxiter: int, popsize: int) -> None:
    """--maxiter and --popsize of differential evolution, with their defaults, and --seed of
    the search."""
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the search (default 0)")
    p.add_argument("--maxiter", type=integer_type("generation count", 1, 100_000),
                   default=maxiter,
                   help=f"generations of differential evolution (default {maxiter})")
    p.add_argument("--popsize", type=integer_type("population multiplier", 1, 10_000),
                   default=popsize, help=f"population per free field (default {popsize})")


def described(doc: str | None) -> str:
    """A command's ``--help`` description: its module docstring after the summary line
    (each command module's docstring is its summary, a blank line, then what the command
    does)."""
    return (doc or "").partition("\n\n")[2].strip()
