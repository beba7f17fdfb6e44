"""``splitlf optimise``: the best design for an objective under constraints
(docs/optimise.md).

Search the free fields of the camera (the seed design unless --config or --preset) with
differential evolution, polished locally, for the design that optimises a figure of
merit subject to constraints (docs/optimise.md); write it as a TOML that report --config
reads (a [design] file for a design base).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from .._files import atomic_output
from . import _common

_f_number = _common.real_type("f-number", 0.0, "a finite number > 0")




def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "optimise", __doc__,
                               summary="the best design for an objective (inverse design)",
                               design="optimise around",
                               threads="threads of the core for in-process evaluation")
    p.add_argument("--free", action="append", required=True, metavar="NAME=LOW:HIGH",
                   help="a free field and its bounds (repeat; a camera field such as kappa, "
                   "or a design's by path such as channels[2].L; counts such as Q are "
                   "searched as integers)")
    _common.objective_options(p, "the merit to optimise (docs/optimise.md lists them)")
    _common.depths_option(p, "--depths", "150:10000:200", "the merits")
    p.add_argument("--min-microlens-f-number", type=_f_number, default=None, metavar="N",
                   help="manufacturable floor on the microlens f-number f_i/d")
    _common.evolution_options(p, maxiter=100, popsize=15)
    p.add_argument("--no-polish", action="store_true", help="skip the local polish")
    _common.scheduler_option(p)
    p.add_argument("--history", metavar="FILE",
                   help="write every evaluated candidate to .csv or .parquet")
    _common.merits_2d_options(p, "compute and report the 2-D merits even when neither the "
                              "objective nor a constraint names one (they are computed when one "
                              "does)", "default 16")
    _common.output_group(p, "write the best design ([camera] TOML, [design] for a design base)",
                         "BEST.toml")
    p.set_defaults(func=run)


def parse_free(spec: str) -> tuple[str, tuple[float, float]]:
    """``--free NAME=LO:HI`` -> (NAME, (LO, HI)); integers stay integers (counts)."""
    name, eq, rng = spec.partition("=")
    lo, colon, hi = rng.partition(":")
    try:
        if not (eq and colon and name):
            raise ValueError
        bounds = tuple(int(b) if b.strip().lstrip("+-").isdigit() else float(b)
                       for b in (lo, hi))
    except ValueError:
        raise _common.CliError(f"--free {spec}: expected NAME=LOW:HIGH, "
                               "e.g. kappa=0.05:0.8") from None
    return name.strip(), (bounds[0], bounds[1])


def _optimise_document(res: Any, source: str, args: argparse.Namespace) -> dict[str, Any]:
    return {"source": source, "objective": args.objective, "objective_value": res.objective,
            "free": res.free, "feasible": res.feasible, "active": list(res.active),
            "slack": res.slack, "merits": res.merits, "nfev": res.nfev,
            "generations": res.generations, "design": res.design.design.as_dict()}


def _optimise_outputs(args: argparse.Namespace) -> tuple[Path | None, Path | None]:
    """--out and --history, checked before any work."""
    out = None if args.out is None else Path(args.out)
    if out is not None:
        _common.check_suffix("--out", out, (".toml",))
        _common.check_output(out, args.force)
    hist = None if args.history is None else Path(args.history)
    if hist is not None:
        _common.check_suffix("--history", hist, (".csv", ".parquet"))
        _common.check_output(hist, args.force)
    return out, hist


def _write_optimised(res: Any, out: Path | None, hist: Path | None, force: bool) -> None:
    if out is not None:
        with atomic_output(out, force=force, hint=_common.FORCE_HINT) as tmp:
            tmp.write_text(res.design.to_toml(), encoding="utf-8")
    if hist is not None:
        with atomic_output(hist, force=force, hint=_common.FORCE_HINT) as tmp:
            if hist.suffix == ".csv":
                res.history.to_csv(tmp, index=False)
            else:
                res.history.to_parquet(tmp, index=False)


def run(args: argparse.Namespace) -> int:
    for module in ("scipy", "pandas"):
        _common.need(module, "optimise", "sweep")
    from ..study.optimise import optimise

    out, hist = _optimise_outputs(args)
    free = dict(parse_free(f) for f in args.free)
    constraints = dict(_common.parse_constraint(c) for c in args.constraint or [])
    depths = _common.log_depths(args.depths)
    camera, source = _common.load_subject(args)
    kwargs = dict(sense=args.sense, constraints=constraints, depths=depths, seed=args.seed,
                  maxiter=args.maxiter, popsize=args.popsize, polish=not args.no_polish,
                  min_microlens_f_number=args.min_microlens_f_number, n_threads=args.threads,
                  merits_2d=True if args.merits_2d else None)
    if args.window is not None:
        kwargs["window"] = args.window
    res = _common.search(optimise, args, camera, free, args.objective, **kwargs)
    if not res.feasible:
        raise _common.CliError(f"no feasible design found in {res.nfev} candidates (least "
                               f"violation: {res.slack}); widen --free or relax --constraint")
    _write_optimised(res, out, hist, args.force)
    doc = _optimise_document(res, source, args)
    if args.json:
        sys.stdout.write(_common.json_text(doc if out is None else {"path": str(out), **doc}))
        return 0
    lines = [f"splitlf optimise: {source}; {res.generations} generations, {res.nfev} "
             "candidates",
             f"{args.objective} = {res.objective!r}",
             *(f"  {k} = {v!r}" for k, v in res.free.items()),
             "active: " + ("; ".join(res.active) if res.active else "none (an interior "
                           "optimum)")]
    if out is not None:
        lines.append(str(out))
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
