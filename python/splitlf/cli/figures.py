"""``splitlf figures``: every figure of a design, written to a folder.

Write the paper's figures (1, 4, 5), the samples figure, the microlens images on the
sensor and the 2-D sample map for the camera (the seed design unless --config). A
general design (--preset, or a --config file with a [design] table;
docs/architectures.md) gets Figs. 1 and 5 per channel and lens type, its microlens
images and its sample map. Every option is checked, and no existing file is overwritten
without --force, before the folder is created.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from .._files import atomic_output
from ..model.design import Design
from . import _common

#: Resolution of ``splitlf figures`` [dots per inch]: the allowed range.
DPI_RANGE = (10, 1000)


_dpi = _common.integer_type("dpi", *DPI_RANGE)




def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "figures", __doc__,
                               summary="write every figure of a design", design="draw",
                               threads="threads of the core for every figure")
    p.add_argument("--z", type=_common.depth_type, default=None, metavar="MM",
                   help="depth of the sample map [mm], > F (default: channel 1's "
                   "out-of-focus plane with several channels, twice it with one)")
    p.add_argument("--format", choices=("png", "svg"), default="png",
                   help="image format (default: png)")
    p.add_argument("--dpi", type=_dpi, default=150,
                   help=f"resolution in dots per inch, an integer in [{DPI_RANGE[0]}, "
                   f"{DPI_RANGE[1]}] (default 150)")
    _common.output_group(p, "output folder, created if missing (default: figures)", "DIR",
                         "figures", json_help="")
    p.set_defaults(func=run)


def figure_functions() -> dict[str, tuple[Any, Any, tuple[float, float]]]:
    """File stem -> (plot function taking (design, ax=..., n_threads=...), its panels: a
    number stacked or "channels" side by side, figure size [in])."""
    from .. import plot

    return {stem: (getattr(plot, fn), panels, size) for stem, (fn, panels, size)
            in plot.FIGURES.items()}


def _figures_of(subject: Design) -> dict[str, tuple[Any, Any, tuple[float, float]]]:
    """:func:`figure_functions` for a design; a design with a hex channel has no figure
    along x (``plot.RECT_ONLY``: ray space, samples along x)."""
    from .. import plot

    rect = all(ch.grid == "rect" for ch in subject.channels)
    return {stem: f for stem, f in figure_functions().items()
            if rect or stem not in plot.RECT_ONLY}


def _figure_targets(out: Path, fmt: str, force: bool, subject: Design) -> dict[str, Path]:
    """The file of every figure, checked (folder not a file, no file overwritten without
    --force, the folder writable) before the folder is created or anything is drawn."""
    _common.check_folder(out)
    targets = {stem: out / f"{stem}.{fmt}" for stem in _figures_of(subject)}
    for path in targets.values():
        if out.is_dir():
            _common.check_output(path, force)
    return targets


def run(args: argparse.Namespace) -> int:
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise _common.CliError('figures need matplotlib: pip install "splitlf[plot]"') from None
    from ..plot._mpl import trace_threads

    trace_threads(args.threads)  # the ray-space figure traces: refuse what it cannot honour
    subject, _ = _common.load_subject(args)
    if args.z is not None and not args.z > subject.F:
        raise _common.CliError(f"invalid --z {args.z:g}: allowed a depth > F = {subject.F:g} mm")
    out = Path(args.out)
    targets = _figure_targets(out, args.format, args.force, subject)
    out.mkdir(parents=True, exist_ok=True)
    for stem, (fn, panels, (w, h)) in _figures_of(subject).items():
        # A bare Figure needs no pyplot backend: nothing global is changed.
        if panels == "channels":
            n = len(subject.channels)
            fig = Figure(figsize=(w * n, h), layout="constrained")
            ax: Any = list(fig.subplots(1, n, squeeze=False)[0])
        else:
            fig = Figure(figsize=(w, h), layout="constrained")
            ax = fig.add_subplot() if panels == 1 else fig.subplots(panels, 1, sharex=True)
        extra = {"z": args.z} if stem == "sample_map" else {}
        fn(subject, ax=ax, n_threads=args.threads, **extra)
        with atomic_output(targets[stem], force=args.force, hint=_common.FORCE_HINT) as tmp:
            fig.savefig(tmp, dpi=args.dpi, format=args.format)
        print(targets[stem])
    return 0
