"""``splitlf compare``: optimise every architecture on one sensor and compare them
(docs/compare.md).

Build the plain light field camera, the split sensor, a three-way split, a multi-focus
hex camera and a conventional camera on the sensor and main lens of a preset, optimise
each light field architecture for one objective (differential evolution, small budgets),
set the conventional camera's focus, and compare the optimised designs over the depths:
sharp fraction, covering radius, light per pixel, MTF50 (docs/compare.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from .._files import atomic_output
from . import _common

COMPARE_FILES = ("table.csv", "curves.csv")




def add_parser(subparsers: Any) -> None:
    from ..study.compare import ARCHITECTURES
    from ..study.compare import PRESETS as SENSORS

    p = subparsers.add_parser("compare", description=_common.described(__doc__),
                              help="optimise every architecture on one sensor and compare them")
    p.add_argument("--preset", choices=SENSORS, default="seed",
                   help="whose sensor and main lens: seed (36 x 24 mm, 9 um, F 80 mm) or "
                   "raytrix-r12 (4080 x 3068 px of 5.5 um, F 49.9 mm) (default seed)")
    _common.objective_options(p, "the merit every architecture optimises, e.g. "
                              "sharp_fraction_union (docs/optimise.md lists them)",
                              ", e.g. covering_radius_median_union<=1.5")
    p.add_argument("--architectures", default=None, metavar="A,B,...",
                   help=f"a comma-separated subset of {','.join(ARCHITECTURES)} "
                   "(default: all)")
    _common.depths_option(p, "--depths", "150:10000:60", "the evaluation")
    _common.depths_option(p, "--optimise-depths", "150:10000:12", "the merits inside the search")
    p.add_argument("--window", type=_common.real_type("window", 0.0, "a finite number > 0"),
                   default=16.0, metavar="PITCHES",
                   help="central field of the evaluation's covering radius, in lens "
                   "pitches (default 16)")
    p.add_argument("--optimise-window",
                   type=_common.real_type("window", 0.0, "a finite number > 0"),
                   default=4.0, metavar="PITCHES",
                   help="central field of the 2-D merits inside the search (default 4)")
    _common.evolution_options(p, maxiter=8, popsize=5)
    p.add_argument("--polish", action="store_true",
                   help="polish each optimum locally (Nelder-Mead; default off)")
    p.add_argument("--simulate-depths", default=None, metavar="Z1,Z2,...",
                   help="depths [mm] of the super-resolution MTF50 columns (default none)")
    _common.threshold_option(p)
    _common.threads_option(p, "threads of the core")
    _common.scheduler_option(p)
    p.add_argument("--figure", metavar="FILE.png",
                   help="write the comparison figure (splitlf.plot.compare), .png or .svg")
    p.add_argument("--wide", action="store_true",
                   help="print every column of the table, unabbreviated (default: the most "
                   f"useful columns, fitting {COMPARE_WIDTH} characters)")
    _common.output_group(p, "write table.csv, curves.csv and one NAME.toml per optimised design "
                         "into this folder (created if missing)", "DIR")
    p.set_defaults(func=run)


def _compare_targets(args: argparse.Namespace, names: list[str]) -> tuple[Path | None,
                                                                          Path | None]:
    """The folder and the figure of `compare`, checked (no file overwritten without
    --force, a writable folder, not a file) before any work."""
    out = None if args.out is None else Path(args.out)
    if out is not None:
        _common.check_folder(out)
        for name in [*COMPARE_FILES, *(f"{n}.toml" for n in names)]:
            if out.is_dir():
                _common.check_output(out / name, args.force)
    fig = None if args.figure is None else Path(args.figure)
    if fig is not None:
        _common.check_suffix("--figure", fig, (".png", ".svg"))
        _common.check_output(fig, args.force)
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise _common.CliError('--figure needs matplotlib: '
                                   'pip install "splitlf[plot]"') from None
    return out, fig


def _compare_names(spec: str | None) -> list[str]:
    from ..study.compare import ARCHITECTURES

    if spec is None:
        return list(ARCHITECTURES)
    names = [n.strip() for n in spec.split(",") if n.strip()]
    bad = [n for n in names if n not in ARCHITECTURES]
    if not names or bad or len(set(names)) < len(names):
        raise _common.CliError(f"--architectures {spec}: allowed distinct names among "
                               f"{', '.join(ARCHITECTURES)}, comma-separated")
    return [n for n in ARCHITECTURES if n in names]


def _compare_document(res: Any) -> dict[str, Any]:
    table = res.table.reset_index()
    return {
        "preset": res.preset, "settings": dict(res.settings), "timing": dict(res.timing),
        "table": json.loads(table.to_json(orient="records", double_precision=15)),
        "designs": {n: d.as_dict() for n, d in res.designs.items()},
        "curves": json.loads(res.curves.to_json(orient="records", double_precision=15)),
    }


#: Columns of the default (narrow) comparison table, most useful first, and their
#: abbreviations; MTF50 columns follow while the table fits :data:`COMPARE_WIDTH`.
COMPARE_COLUMNS = {"feasible": "feasible", "objective": "objective", "channels": "ch",
                   "pixels": "pixels", "sharp_fraction": "sharp",
                   "covering_radius_worst": "cov_worst",
                   "covering_radius_median": "cov_med", "light_per_pixel": "light/px",
                   "light_relative": "light_rel", "distinct_2d_median": "dist_2d"}

#: Width of the default comparison table [characters]; ``--wide`` prints every column.
COMPARE_WIDTH = 100


def _compare_frame(table: Any, wide: bool) -> Any:
    """The comparison table to print: every column (``wide``), or the most useful ones,
    abbreviated, as many as fit :data:`COMPARE_WIDTH` columns; the conventional row's
    feasible (not applicable: <NA>) shows as "-"."""
    tab = table.drop(columns=["light_from_rect_twin"], errors="ignore").copy()
    if "feasible" in tab.columns:
        tab["feasible"] = [_feasible_text(f) for f in tab["feasible"]]
    if wide:
        return tab
    keep = [c for c in [*COMPARE_COLUMNS,
                        *(c for c in tab.columns if c.startswith(("mtf50_", "psnr_")))]
            if c in tab.columns]
    short = tab[keep].rename(columns=COMPARE_COLUMNS)
    while len(short.columns) > 1 and max(
            map(len, _frame_text(short).splitlines())) > COMPARE_WIDTH:
        short = short.iloc[:, :-1]
    return short


def _frame_text(frame: Any) -> str:
    return str(frame.to_string(float_format=lambda x: f"{x:.4g}"))


def _feasible_text(value: Any) -> str:
    """A comparison row's feasible: True, False, or "-" where it does not apply (the
    conventional camera is not searched: pandas' <NA>)."""
    import pandas as pd

    return "-" if pd.isna(value) else str(bool(value))


def _compare_note(table: Any, objective: str) -> str | None:
    """Why the union's sharp fraction is 1 for every light field row, when it is."""
    if "sharp_fraction" not in table.columns or "feasible" not in table.columns:
        return None
    lf = table[[_feasible_text(f) != "-" for f in table["feasible"]]]
    if lf.empty or not (lf["sharp_fraction"] == 1.0).all():
        return None
    why = ("the objective maximised it" if objective == "sharp_fraction_union" else
           "some channel is sharp at every depth")
    return f"note: sharp (the union's sharp fraction) is 1 for every light field row: {why}"


def compare_text(res: Any, args: argparse.Namespace, constraints: dict[str, Any],
                 written: list[Path]) -> str:
    cons = ", ".join(f"{m} {op} {v:g}" for m, (op, v) in constraints.items())
    note = _compare_note(res.table, args.objective)
    frame = _compare_frame(res.table, args.wide)
    lines = [f"splitlf compare: preset {res.preset}; {args.objective}"
             f"{' (' + args.sense + ')' if args.sense else ''}"
             f"{'; subject to ' + cons if cons else ''}",
             _frame_text(frame),
             *([note] if note else []),
             *([] if args.wide else ["(--wide: every column, unabbreviated)"]),
             f"optimised in {res.timing['optimise_s']:.1f} s, evaluated in "
             f"{res.timing['evaluate_s']:.1f} s",
             *(str(p) for p in written)]
    return "\n".join(lines) + "\n"


def _write_compare(res: Any, out: Path | None, fig_path: Path | None,
                   force: bool) -> list[Path]:
    written = []
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with atomic_output(out / "table.csv", force=force, hint=_common.FORCE_HINT) as tmp:
            res.table.to_csv(tmp)
        with atomic_output(out / "curves.csv", force=force, hint=_common.FORCE_HINT) as tmp:
            res.curves.to_csv(tmp, index=False)
        written += [out / "table.csv", out / "curves.csv"]
        for n, d in res.designs.items():
            d.to_toml(out / f"{n}.toml")
            written.append(out / f"{n}.toml")
    if fig_path is not None:
        from matplotlib.figure import Figure

        from ..plot import compare as plot_compare

        fig = Figure(figsize=(9.5, 12.0), layout="constrained")
        plot_compare(res, ax=fig.subplots(3, 1, height_ratios=[3, 2, 1.3]))
        with atomic_output(fig_path, force=force, hint=_common.FORCE_HINT) as tmp:
            fig.savefig(tmp, dpi=150, format=fig_path.suffix[1:])
        written.append(fig_path)
    return written


def _simulate_depth_list(spec: str | None) -> list[float]:
    sim = []
    for text in (spec or "").split(","):
        if text.strip():
            try:
                sim.append(_common.depth_type(text.strip()))
            except argparse.ArgumentTypeError as e:
                raise _common.CliError(f"--simulate-depths: {e}") from None
    return sim


def run(args: argparse.Namespace) -> int:
    for module in ("scipy", "pandas"):
        _common.need(module, "compare", "sweep")
    from ..study.compare import compare

    names = _compare_names(args.architectures)
    out, fig_path = _compare_targets(args, names)
    constraints = dict(_common.parse_constraint(c) for c in args.constraint or [])
    kwargs = dict(which=names, depths=_common.log_depths(args.depths, "--depths"),
                  optimise_depths=_common.log_depths(args.optimise_depths, "--optimise-depths"),
                  window=args.window, optimise_window=args.optimise_window,
                  maxiter=args.maxiter, popsize=args.popsize, polish=args.polish,
                  seed=args.seed, simulate_depths=_simulate_depth_list(args.simulate_depths),
                  threshold_px=args.threshold, n_threads=args.threads)
    res = _common.search(compare, args, args.preset, args.objective, args.sense, constraints,
                         **kwargs)
    written = _write_compare(res, out, fig_path, args.force)
    if args.json:
        doc = _compare_document(res)
        doc["written"] = [str(p) for p in written]
        sys.stdout.write(_common.json_text(doc))
    else:
        sys.stdout.write(compare_text(res, args, constraints, written))
    return 0
