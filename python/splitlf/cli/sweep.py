"""``splitlf sweep``: figures of merit over a grid of designs, from a sweep TOML file.

Full-factorial design sweep from a TOML file with [grid], [depths] (min, max, num;
log-spaced), [options] and an optional base: a [camera] table, or a [design] table whose
fields the grid names by path ("channels[2].L" = [...]; docs/architectures.md). Without
a base in the file: --preset, --config, or the seed design.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from .._files import atomic_output, read_toml
from ..model.camera import Camera
from ..model.design import Design
from . import _common


def add_parser(subparsers: Any) -> None:
    p = _common.design_command(subparsers, "sweep", __doc__,
                               summary="figures of merit over a grid of designs",
                               design="sweep around",
                               threads="threads of the core for in-process sweeps")
    p.add_argument("--grid", required=True, metavar="SWEEP.toml",
                   help="the sweep file: [grid], [depths], [options], [camera] or [design]")
    _common.scheduler_option(p)
    _common.merits_2d_options(p, "also compute the 2-D merits (covering radius, distinct 2-D "
                              "samples; a 2-D analysis per depth: slower); also [options] "
                              "merits_2d = true", "default 16, or [options] window")
    _common.output_group(p, "write the sweep to .nc (NetCDF), .parquet or .json",
                         json_help="print the designs as JSON records (with --out: as well)")
    p.set_defaults(func=run)


def _toml_real(where: str, value: Any) -> float:
    """A finite real number from a TOML file (a 400-digit integer is out of range too)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _common.CliError(f"{where}: expected a number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        shown = value if isinstance(value, float) else f"{str(value)[:12]}..."
        raise _common.CliError(f"{where} = {shown}: allowed a finite number")
    return x


def _toml_count(where: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        shown = value if not isinstance(value, int) or abs(value) < 10**15 \
            else f"{str(value)[:12]}..."
        raise _common.CliError(f"{where} = {shown!r}: allowed an integer in [{lo}, {hi}]")
    return value


def _linspace(where: str, spec: Any) -> list[Any]:
    """A grid axis from TOML: a list of values, or {start, stop, num, log}."""
    from ..study.sweep import MAX_DESIGNS

    if isinstance(spec, list):
        return spec
    if not isinstance(spec, dict):
        raise _common.CliError(f"{where}: expected a list of values or {{start, stop, num}}")
    unknown = set(spec) - {"start", "stop", "num", "log"}
    if unknown or not {"start", "stop", "num"} <= set(spec):
        raise _common.CliError(f"{where}: a range needs start, stop, num (and optional log)")
    lo, hi = _toml_real(f"{where}.start", spec["start"]), _toml_real(f"{where}.stop", spec["stop"])
    num = _toml_count(f"{where}.num", spec["num"], 1, MAX_DESIGNS)
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise _common.CliError(f"{where}.log = {log!r}: allowed true or false")
    if log and not (lo > 0 and hi > 0):
        raise _common.CliError(f"{where}: a log range needs start > 0 and stop > 0")
    return (np.geomspace if log else np.linspace)(lo, hi, num).tolist()


def _sweep_depths(path: str, dep: Any) -> np.ndarray:
    """[depths] min, max (mm), num (log-spaced), checked before anything is allocated."""
    from ..study.sweep import MAX_DEPTHS

    if not isinstance(dep, dict):
        raise _common.CliError(f"{path}: [depths] must be a table")
    bad = set(dep) - {"min", "max", "num"}
    if bad:
        raise _common.CliError(f"{path}: unknown [depths] key(s) {sorted(bad)}; "
                               "allowed: min, max, num")
    lo = _toml_real(f"{path}: depths.min", dep.get("min", 150.0))
    hi = _toml_real(f"{path}: depths.max", dep.get("max", 10_000.0))
    num = _toml_count(f"{path}: depths.num", dep.get("num", 200), 2, MAX_DEPTHS)
    if not 0 < lo < hi:
        raise _common.CliError(f"{path}: depths needs 0 < min < max (mm), "
                               f"got min={lo!r}, max={hi!r}")
    return np.geomspace(lo, hi, num)


def load_sweep(path: str) -> dict[str, Any]:
    """Read and check a sweep TOML file: ``[grid]`` (required; field -> list of values or
    ``{start, stop, num, log}``), ``[depths]`` (``min``, ``max`` in mm, ``num`` log-spaced
    depths), ``[options]`` (``threshold_px``, ``tol``, ``merits_2d``, ``window``) and an
    optional base: a ``[camera]`` table, or a ``[design]`` table with its
    ``[[design.channels]]`` (docs/architectures.md; the grid then names the design's fields
    by path, ``"channels[2].L"``).

    Returns {"grid", "depths", "options", "base" (the [camera] or [design] table's design,
    None without one)}. Raises
    :class:`CliError` / ``ValueError`` naming the file and the key for anything invalid
    (ranges, limits :data:`splitlf.sweep.MAX_DESIGNS` and :data:`~splitlf.sweep.MAX_DEPTHS`),
    ``OSError`` when the file cannot be read.
    """
    doc = read_toml(path)
    unknown = set(doc) - {"grid", "depths", "options", "camera", "design"}
    if unknown:
        raise _common.CliError(f"{path}: unknown table(s) {sorted(unknown)}; "
                               "allowed: grid, depths, options, camera or design")
    if "camera" in doc and "design" in doc:
        raise _common.CliError(f"{path}: a [camera] and a [design] table: give one base")
    if not isinstance(doc.get("grid"), dict) or not doc["grid"]:
        raise _common.CliError(f"{path}: needs a non-empty [grid] table of camera fields")
    grid = {k: _linspace(f"{path}: grid.{k}", v) for k, v in doc["grid"].items()}
    depths = _sweep_depths(path, doc.get("depths", {}))
    options = _sweep_options(path, doc.get("options", {}))
    base = None
    for table, build in (("camera", Camera.from_dict), ("design", Design.from_dict)):
        if table in doc:
            try:
                base = build(doc[table], source=f"{path} [{table}]")
            except (ValueError, TypeError) as e:
                msg = str(e)
                raise _common.CliError(msg if msg.startswith(path) else f"{path} [{table}]: {msg}"
                               ) from None
    return {"grid": grid, "depths": depths, "options": options, "base": base}


SWEEP_OPTIONS = ("threshold_px", "tol", "merits_2d", "window")


def _sweep_options(path: str, opts: Any) -> dict[str, Any]:
    """The [options] table of a sweep file, checked as :func:`splitlf.evaluate` checks
    them."""
    from ..study import _options
    from ..study import merit as ev

    bad = set(opts) - set(SWEEP_OPTIONS) if isinstance(opts, dict) else {"(not a table)"}
    if bad:
        raise _common.CliError(f"{path}: unknown [options] key(s) {sorted(bad)}; "
                               f"allowed: {', '.join(SWEEP_OPTIONS)}")
    full = {"threshold_px": ev.DEFAULT_THRESHOLD_PX, "tol": ev.DEFAULT_TOL,
            "merits_2d": False, "window": ev.DEFAULT_WINDOW, **opts}
    try:  # the checks of splitlf.evaluate's options
        _options.threshold_option(full["threshold_px"])
        _options.options_2d(full["merits_2d"], full["window"], _options.tol_option(full["tol"]))
    except (ValueError, TypeError) as e:
        raise _common.CliError(f"{path}: options: {e}") from None
    return dict(opts)


SWEEP_SUFFIXES = (".nc", ".parquet", ".json")


def _sweep_document(ds: Any) -> dict[str, Any]:
    """The sweep as JSON: attributes (without the base's TOML) and one record per design,
    every number exact (Python floats, written by repr; pandas' ``to_json`` would keep 10
    digits); :func:`json_text` writes NaN as null."""
    df = ds.to_dataframe().reset_index()
    return {"attrs": {k: v for k, v in ds.attrs.items()
                      if k not in ("base_design", "base_camera")},
            "designs": df.to_dict(orient="records")}


def _write_sweep(ds: Any, out: Path, force: bool) -> None:
    with atomic_output(out, force=force, hint=_common.FORCE_HINT) as tmp:
        if out.suffix == ".nc":
            ds.to_netcdf(tmp)
        elif out.suffix == ".parquet":
            ds.to_dataframe().reset_index().to_parquet(tmp)
        else:
            tmp.write_text(_common.json_text(_sweep_document(ds)), encoding="utf-8")


def _run_sweep(camera: Design, spec: dict[str, Any], scheduler: str | None,
               n_threads: int | None) -> Any:
    from ..study.sweep import sweep

    if scheduler is None:
        return sweep(camera, spec["grid"], spec["depths"], n_threads=n_threads,
                     **spec["options"])
    try:
        from distributed import Client
    except ImportError:
        raise _common.CliError('--scheduler needs Dask: pip install "splitlf[dask]"') from None
    with Client(scheduler) as client:
        return sweep(camera, spec["grid"], spec["depths"], executor=client.get_executor(),
                     n_threads=n_threads, **spec["options"])


def _sweep_base(args: argparse.Namespace, spec: dict[str, Any]) -> Design:
    """The base of a sweep: the file's [camera] or [design] table, else --preset,
    --config or the seed; never two of them."""
    if spec["base"] is None:
        return _common.load_subject(args)[0]
    if args.preset is not None or args.config is not None:
        option = "--preset" if args.preset is not None else "--config"
        raise _common.CliError(f"{option}: {args.grid} has a [camera] or [design] base already; "
                               "give the base in one place")
    return spec["base"]


def _sweep_table(ds: Any, base: Design, spec: dict[str, Any]) -> str:
    from ..study.merit import merit_names

    df = ds.to_dataframe().reset_index()
    cols = list(spec["grid"]) + ["sharp_fraction_union", "max_gap_worst_union",
                                 "covering_radius_worst_union", "reason"]
    cols = [c for c in cols if c in df.columns]
    two_d = bool(spec["options"].get("merits_2d"))
    window = f" (2-D merits on a central field of {spec['options'].get('window', 16.0):g} " \
        "lens pitches)" if two_d else ""
    return (df[cols].to_string(index=False) + "\n\n" + f"{len(df)} designs{window}; metrics: "
            f"{', '.join(merit_names(base, two_d))}\n")


def run(args: argparse.Namespace) -> int:
    _common.need("xarray", "sweep", "sweep")
    out = None if args.out is None else Path(args.out)
    if out is not None:
        _common.check_suffix("--out", out, SWEEP_SUFFIXES)
        _common.check_output(out, args.force)
    spec = load_sweep(args.grid)
    if args.merits_2d:
        spec["options"]["merits_2d"] = True
    if args.window is not None:
        spec["options"]["window"] = args.window
    base = _sweep_base(args, spec)
    ds = _run_sweep(base, spec, args.scheduler, args.threads)
    if out is not None:
        _write_sweep(ds, out, args.force)
    return _common.print_result(args, out, lambda: _sweep_document(ds),
                                lambda: _sweep_table(ds, base, spec))
