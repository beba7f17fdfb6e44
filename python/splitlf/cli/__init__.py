"""The ``splitlf`` command line.

A user error (bad input, a file that cannot be read or would be overwritten) is one line on
stderr and exit status 2; every option is checked before any work or any file is written.
A fault of splitlf itself (``RuntimeError``, ``AssertionError``, ...) keeps its traceback.
Output files are never overwritten without ``--force`` and are written atomically (a
temporary file in the same folder, then a rename), so a failed run leaves the previous
file intact.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .. import _native
from .._files import atomic_output, check_new, read_toml
from ..errors import InvalidParameter, SplitlfError
from ..model.camera import Camera
from ..model.design import PRESETS, Design
from ..study.report import format_report, report_data

SEED = "seed design (docs/model.md §7, reconstructed from the paper)"
#: Resolution of ``splitlf figures`` [dots per inch]: the allowed range.
DPI_RANGE = (10, 1000)
#: Depths of ``splitlf simulate --z-range``: the allowed range of ``--n``.
SIMULATE_N_RANGE = (1, 1000)
#: Cells of delta(z) in the central field that ``splitlf simulate`` scores.
SIMULATE_WINDOW = 256
#: Threads of the core: the allowed range of ``--threads``.
THREADS_RANGE = (1, _native.MAX_THREADS)
#: What the CLI reports as a user error (one line, exit 2); anything else is a bug.
#: (read_toml reports invalid TOML as a ValueError naming the file.)
USER_ERRORS = (SplitlfError, ValueError, TypeError, OSError)
FORCE_HINT = "pass --force to overwrite"


class CliError(SplitlfError):
    """A user error found by the command line, with a message fit for one line."""


def _need(module: str, command: str, extra: str) -> None:
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


def _named_design(spec: str) -> Design:
    """A design named on the command line: a preset name, else a [design] or [camera]
    TOML file (:func:`load_design`)."""
    return Design.preset(spec) if spec in PRESETS else load_design(spec)


def _finite(data: Any) -> Any:
    """``data`` with every non-finite float replaced by None (JSON has no inf or NaN)."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [_finite(v) for v in data]
    return data


def json_text(data: Any) -> str:
    """The whole JSON document as text (built before anything is written, so a value that
    cannot be serialised never leaves half a document behind); inf and NaN become null."""
    return json.dumps(_finite(data), indent=2, allow_nan=False) + "\n"


def _write_text(path: Path, text: str, force: bool) -> None:
    with atomic_output(path, force=force, hint=FORCE_HINT) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _check_suffix(option: str, path: Path, allowed: Iterable[str]) -> None:
    allowed = tuple(allowed)
    if path.suffix not in allowed:
        raise CliError(f"{option} {path}: allowed suffixes {', '.join(allowed)}")


# -- argument types: each named, so argparse's message says what was expected ----------------

def _integer_type(what: str, lo: int, hi: int) -> Callable[[str], int]:
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


def _real_type(what: str, lo: float, allowed: str, *, lo_open: bool = True
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


_threads = _integer_type("thread count", *THREADS_RANGE)
_depth = _real_type("depth", 0.0, "a finite depth > 0 (mm)")
_dpi = _integer_type("dpi", *DPI_RANGE)
_n_depths = _integer_type("depth count", *SIMULATE_N_RANGE)
_seed = _integer_type("seed", 0, 2**63 - 1)
_photons = _real_type("photon count", 0.0, "a finite number > 0")
_read_noise = _real_type("read noise", 0.0, "a finite number >= 0 (electrons rms)",
                         lo_open=False)
_threshold = _real_type("threshold", 0.0, "a finite number > 0 (pixels)")
_f_number = _real_type("f-number", 0.0, "a finite number > 0")
_window = _real_type("window", 0.0, "a finite number > 0 (the 2-D central field's width in "
                     "lens pitches of channel 1)")


# -- report ------------------------------------------------------------------------------

def _load_subject(args: argparse.Namespace) -> tuple[Design, str]:
    """What a subcommand works on, and its name: a preset (``--preset``), a [design] or
    [camera] TOML file (``--config``), or the seed design."""
    if args.preset is not None:
        if args.config is not None:
            raise CliError("--preset and --config: give one of them")
        return Design.preset(args.preset), f"preset {args.preset}"
    if args.config is not None:
        return load_design(args.config), args.config
    return Camera.paper(), SEED


def _cmd_report(args: argparse.Namespace) -> int:
    subject, source = _load_subject(args)
    data = report_data(subject, args.threshold, n_threads=args.threads)
    if args.json:
        sys.stdout.write(json_text({"source": source, **data}))
    else:
        sys.stdout.write(format_report(data, f"splitlf report: {source}", full=args.full))
    return 0


# -- figures -----------------------------------------------------------------------------

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
    --force) before the folder is created or anything is drawn."""
    if out.exists() and not out.is_dir():
        raise CliError(f"--out {out}: exists and is not a folder")
    targets = {stem: out / f"{stem}.{fmt}" for stem in _figures_of(subject)}
    for path in targets.values():
        if out.is_dir():
            check_new(path, force, FORCE_HINT)
    return targets


def _cmd_figures(args: argparse.Namespace) -> int:
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise CliError('figures need matplotlib: pip install "splitlf[plot]"') from None
    from ..plot._mpl import trace_threads

    trace_threads(args.threads)  # the ray-space figure traces: refuse what it cannot honour
    subject, _ = _load_subject(args)
    if args.z is not None and not args.z > subject.F:
        raise CliError(f"invalid --z {args.z:g}: allowed a depth > F = {subject.F:g} mm")
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
        with atomic_output(targets[stem], force=args.force, hint=FORCE_HINT) as tmp:
            fig.savefig(tmp, dpi=args.dpi, format=args.format)
        print(targets[stem])
    return 0


# -- trace -------------------------------------------------------------------------------

TRACE_FIELDS = ("vertices", "n_vertices", "area", "centroid", "lens", "pixel", "chief", "lit")


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


def _cmd_trace(args: argparse.Namespace) -> int:
    from ..plot._mpl import trace_threads
    from ..sampling import rayspace

    camera, source = _load_subject(args)
    out = Path(args.out)
    _check_suffix("--out", out, (".npz",))
    check_new(out, args.force, FORCE_HINT)
    threads = trace_threads(args.threads)
    hex_ = [i for i, ch in enumerate(camera.channels, start=1) if ch.grid != "rect"]
    if hex_:
        raise CliError(f"trace: channel {hex_[0]} has a hex grid; the 1-D trace needs "
                       "rect grids (docs/architectures.md)")
    arrays: dict[str, Any] = {"design_toml": np.array(camera.to_toml())}
    parts = [(f"channel{c}", {"channel": c}) for c in range(1, len(camera.channels) + 1)]
    summary: dict[str, Any] = {"path": str(out), "source": source, "axis": args.axis}
    for prefix, which in parts:
        t = rayspace.trace(camera, axis=args.axis, **which, **threads)
        for name in TRACE_FIELDS:
            arrays[f"{prefix}_{name}"] = getattr(t, name)
        summary[prefix] = _trace_half(t)
    with atomic_output(out, force=args.force, hint=FORCE_HINT) as tmp:
        np.savez_compressed(tmp, **arrays)
    sys.stdout.write(json_text(summary) if args.json else f"{out}\n")
    return 0


# -- sweep -------------------------------------------------------------------------------

def _toml_real(where: str, value: Any) -> float:
    """A finite real number from a TOML file (a 400-digit integer is out of range too)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise CliError(f"{where}: expected a number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        shown = value if isinstance(value, float) else f"{str(value)[:12]}..."
        raise CliError(f"{where} = {shown}: allowed a finite number")
    return x


def _toml_count(where: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        shown = value if not isinstance(value, int) or abs(value) < 10**15 \
            else f"{str(value)[:12]}..."
        raise CliError(f"{where} = {shown!r}: allowed an integer in [{lo}, {hi}]")
    return value


def _linspace(where: str, spec: Any) -> list[Any]:
    """A grid axis from TOML: a list of values, or {start, stop, num, log}."""
    from ..study.sweep import MAX_DESIGNS

    if isinstance(spec, list):
        return spec
    if not isinstance(spec, dict):
        raise CliError(f"{where}: expected a list of values or {{start, stop, num}}")
    unknown = set(spec) - {"start", "stop", "num", "log"}
    if unknown or not {"start", "stop", "num"} <= set(spec):
        raise CliError(f"{where}: a range needs start, stop, num (and optional log)")
    lo, hi = _toml_real(f"{where}.start", spec["start"]), _toml_real(f"{where}.stop", spec["stop"])
    num = _toml_count(f"{where}.num", spec["num"], 1, MAX_DESIGNS)
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise CliError(f"{where}.log = {log!r}: allowed true or false")
    if log and not (lo > 0 and hi > 0):
        raise CliError(f"{where}: a log range needs start > 0 and stop > 0")
    return (np.geomspace if log else np.linspace)(lo, hi, num).tolist()


def _sweep_depths(path: str, dep: Any) -> np.ndarray:
    """[depths] min, max (mm), num (log-spaced), checked before anything is allocated."""
    from ..study.sweep import MAX_DEPTHS

    if not isinstance(dep, dict):
        raise CliError(f"{path}: [depths] must be a table")
    bad = set(dep) - {"min", "max", "num"}
    if bad:
        raise CliError(f"{path}: unknown [depths] key(s) {sorted(bad)}; allowed: min, max, num")
    lo = _toml_real(f"{path}: depths.min", dep.get("min", 150.0))
    hi = _toml_real(f"{path}: depths.max", dep.get("max", 10_000.0))
    num = _toml_count(f"{path}: depths.num", dep.get("num", 200), 2, MAX_DEPTHS)
    if not 0 < lo < hi:
        raise CliError(f"{path}: depths needs 0 < min < max (mm), got min={lo!r}, max={hi!r}")
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
        raise CliError(f"{path}: unknown table(s) {sorted(unknown)}; "
                       "allowed: grid, depths, options, camera or design")
    if "camera" in doc and "design" in doc:
        raise CliError(f"{path}: a [camera] and a [design] table: give one base")
    if not isinstance(doc.get("grid"), dict) or not doc["grid"]:
        raise CliError(f"{path}: needs a non-empty [grid] table of camera fields")
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
                raise CliError(msg if msg.startswith(path) else f"{path} [{table}]: {msg}"
                               ) from None
    return {"grid": grid, "depths": depths, "options": options, "base": base}


SWEEP_OPTIONS = ("threshold_px", "tol", "merits_2d", "window")


def _sweep_options(path: str, opts: Any) -> dict[str, Any]:
    """The [options] table of a sweep file, checked as :func:`splitlf.evaluate` checks
    them."""
    from ..study import merit as ev

    bad = set(opts) - set(SWEEP_OPTIONS) if isinstance(opts, dict) else {"(not a table)"}
    if bad:
        raise CliError(f"{path}: unknown [options] key(s) {sorted(bad)}; "
                       f"allowed: {', '.join(SWEEP_OPTIONS)}")
    full = {"threshold_px": ev.DEFAULT_THRESHOLD_PX, "tol": ev.DEFAULT_TOL,
            "merits_2d": False, "window": ev.DEFAULT_WINDOW, **opts}
    try:  # the checks of splitlf.evaluate's options
        ev._threshold(full["threshold_px"])
        ev._options_2d(full["merits_2d"], full["window"], ev._tol(full["tol"]))
    except (ValueError, TypeError) as e:
        raise CliError(f"{path}: options: {e}") from None
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
    with atomic_output(out, force=force, hint=FORCE_HINT) as tmp:
        if out.suffix == ".nc":
            ds.to_netcdf(tmp)
        elif out.suffix == ".parquet":
            ds.to_dataframe().reset_index().to_parquet(tmp)
        else:
            tmp.write_text(json_text(_sweep_document(ds)), encoding="utf-8")


def _run_sweep(camera: Design, spec: dict[str, Any], scheduler: str | None,
               n_threads: int | None) -> Any:
    from ..study.sweep import sweep

    if scheduler is None:
        return sweep(camera, spec["grid"], spec["depths"], n_threads=n_threads,
                     **spec["options"])
    try:
        from distributed import Client
    except ImportError:
        raise CliError('--scheduler needs Dask: pip install "splitlf[dask]"') from None
    with Client(scheduler) as client:
        return sweep(camera, spec["grid"], spec["depths"], executor=client.get_executor(),
                     n_threads=n_threads, **spec["options"])


def _sweep_base(args: argparse.Namespace, spec: dict[str, Any]) -> Design:
    """The base of a sweep: the file's [camera] or [design] table, else --preset,
    --config or the seed; never two of them."""
    if spec["base"] is None:
        return _load_subject(args)[0]
    if args.preset is not None or args.config is not None:
        option = "--preset" if args.preset is not None else "--config"
        raise CliError(f"{option}: {args.grid} has a [camera] or [design] base already; "
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


def _cmd_sweep(args: argparse.Namespace) -> int:
    _need("xarray", "sweep", "sweep")
    out = None if args.out is None else Path(args.out)
    if out is not None:
        _check_suffix("--out", out, SWEEP_SUFFIXES)
        check_new(out, args.force, FORCE_HINT)
    spec = load_sweep(args.grid)
    if args.merits_2d:
        spec["options"]["merits_2d"] = True
    if args.window is not None:
        spec["options"]["window"] = args.window
    base = _sweep_base(args, spec)
    ds = _run_sweep(base, spec, args.scheduler, args.threads)
    if out is not None:
        _write_sweep(ds, out, args.force)
    if args.json:
        doc = _sweep_document(ds)
        sys.stdout.write(json_text(doc if out is None else {"path": str(out), **doc}))
    elif out is not None:
        print(out)
    else:
        sys.stdout.write(_sweep_table(ds, base, spec))
    return 0


# -- simulate ----------------------------------------------------------------------------

def parse_texture(spec: str) -> Any:
    """The texture of ``--texture``: random | sinusoid:F | bars:F (F in cycles/mm on the
    object) | image:FILE.npy:WIDTH_MM (a 2D array of albedos, WIDTH mm wide). Raises
    :class:`CliError` (or the loader's ``OSError``/``ValueError``) for anything else."""
    from ..inverse.simulate import BarChart, Image, RandomAlbedo, Sinusoid

    kind, _, rest = spec.partition(":")
    try:
        if kind == "random" and not rest:
            return RandomAlbedo()
        if kind in ("sinusoid", "bars"):
            f = float(rest)
            return Sinusoid(f) if kind == "sinusoid" else BarChart(f)
        if kind == "image":
            path, _, width = rest.rpartition(":")
            return Image(_load_npy(path), float(width))
    except ValueError as e:
        raise CliError(f"--texture {spec}: {e}") from None
    raise CliError(f"--texture {spec}: allowed random, sinusoid:F, bars:F (cycles/mm) "
                   "or image:FILE.npy:WIDTH_MM")


def _load_npy(path: str) -> Any:
    """The array of a .npy file; a file that is not one (e.g. a TOML file, or pickled
    objects) is refused in the CLI's words."""
    try:
        return np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise CliError(f"no such file: {path}") from None
    except (ValueError, EOFError):
        raise CliError(f"{path}: not a NumPy .npy array file") from None


def _simulate_depths(args: argparse.Namespace) -> list[float]:
    if args.z_range is None:
        if args.n is not None:
            raise CliError("--n: only with --z-range")
        return [args.z]
    lo, hi = args.z_range
    if not lo < hi:
        raise CliError(f"--z-range {lo:g} {hi:g}: needs 0 < A < B (mm)")
    return np.geomspace(lo, hi, 8 if args.n is None else args.n).tolist()


def _simulate_noise(args: argparse.Namespace) -> dict[str, float] | None:
    if args.photons is None:
        if args.read_noise is not None:
            raise CliError("--read-noise: only with --photons (noise-free without it)")
        return None
    return {"photons": args.photons, "read_noise": args.read_noise or 0.0}


def _simulate_table(rows: list[dict[str, Any]], source: str, args: argparse.Namespace) -> str:
    """One line per depth and row of the simulation (each channel, the union, the
    conventional camera unless --no-conventional)."""
    noise = "noise-free" if args.photons is None else f"{args.photons:g} photons"
    width = max(13, *(len(c) + 1 for r in rows for c in r["rmse"]))
    out = [f"splitlf simulate: {source}; texture {args.texture}; {noise}; window "
           f"{SIMULATE_WINDOW} cells of delta(z)",
           f"{'z [mm]':>9}  {'config':<{width}}{'RMSE':>9}{'PSNR [dB]':>11}"
           f"{'MTF50 [c/mm]':>14}{'window [mm]':>13}"]
    for r in rows:
        for c in r["rmse"]:
            psnr = r["psnr_db"][c]
            out.append(f"{r['z_mm']:>9.1f}  {c:<{width}}{r['rmse'][c]:>9.4f}"
                       f"{math.inf if psnr is None else psnr:>11.2f}"
                       f"{r['mtf50_cycles_per_mm'][c]:>14.3f}"
                       f"{SIMULATE_WINDOW * r['delta_mm']:>13.3f}")
    return "\n".join(out) + "\n"


def _cmd_simulate(args: argparse.Namespace) -> int:
    _need("scipy", "simulate", "simulate")
    from ..inverse.simulate import simulate

    out = None if args.out is None else Path(args.out)
    if out is not None:
        _check_suffix("--out", out, (".json",))
        check_new(out, args.force, FORCE_HINT)
    depths = _simulate_depths(args)
    noise = _simulate_noise(args)
    camera, source = _load_subject(args)
    texture = parse_texture(args.texture)
    rows = [simulate(camera, z, texture=texture, noise=noise, seed=args.seed,
                     window=SIMULATE_WINDOW, conventional=not args.no_conventional,
                     n_threads=args.threads).summary() for z in depths]
    doc = {"source": source, "texture": args.texture, "window_cells": SIMULATE_WINDOW,
           "results": rows}
    if out is not None:
        _write_text(out, json_text(doc), args.force)
    if args.json:
        sys.stdout.write(json_text(doc if out is None else {"path": str(out), **doc}))
    elif out is not None:
        print(out)
    else:
        sys.stdout.write(_simulate_table(rows, source, args))
    return 0


# -- render ------------------------------------------------------------------------------

def parse_render_texture(spec: str, width: float | None) -> Any:
    """The texture of ``render --texture``: random[:CELL] (CELL in mm; default delta(z))
    | sinusoid:F | bars:F (F in cycles/mm on the object) | edge[:ANGLE] (degrees) |
    star[:SPOKES] | an image file (.png or .npy; needs ``width`` [mm]). Raises
    :class:`CliError` for anything else."""
    from ..imaging.texture import BarChart, RandomAlbedo, SiemensStar, Sinusoid, SlantedEdge

    kind, colon, rest = spec.partition(":")
    known = {"random", "sinusoid", "bars", "edge", "star"}
    if kind not in known:
        return _image_texture(spec, width)
    if width is not None:
        raise CliError("--width: only with an image file as --texture")
    try:
        if kind == "random":
            return RandomAlbedo(float(rest)) if colon else RandomAlbedo()
        if kind in ("sinusoid", "bars"):
            return (Sinusoid if kind == "sinusoid" else BarChart)(float(rest))
        if kind == "edge":
            return SlantedEdge(float(rest)) if colon else SlantedEdge()
        return SiemensStar(int(rest)) if colon else SiemensStar()
    except ValueError as e:
        raise CliError(f"--texture {spec}: {e}") from None


TEXTURE_FORMS = ("random[:CELL] (mm), sinusoid:F, bars:F (cycles/mm), edge[:ANGLE], "
                 "star[:SPOKES] or an image file (.png, .npy) with --width")


def _image_texture(path: str, width: float | None) -> Any:
    """An :class:`~splitlf.Image` from a .npy array of albedos or a PNG (read by
    matplotlib: values in [0, 1], a colour image as the Rec. 709 luma of R, G, B)."""
    from ..imaging.texture import Image

    suffix = Path(path).suffix.lower()
    if suffix not in (".png", ".npy"):
        raise CliError(f"--texture {path}: allowed {TEXTURE_FORMS}")
    if width is None:
        raise CliError(f"--texture {path}: an image needs --width MM (its width on the "
                       "object)")
    if suffix == ".npy":
        array = _load_npy(path)
    else:
        _need("matplotlib", "render with a PNG texture", "plot")
        import matplotlib.image

        if not Path(path).is_file():
            raise CliError(f"no such file: {path}")
        try:
            array = np.asarray(matplotlib.image.imread(path), dtype=np.float64)
        except (OSError, ValueError, SyntaxError) as e:
            raise CliError(f"{path}: not a PNG image ({e})") from None
        if array.ndim == 3:
            array = array[..., :3] @ np.array([0.2126, 0.7152, 0.0722])[:array.shape[2]]
    try:
        return Image(array, width)
    except (TypeError, ValueError) as e:
        raise CliError(f"--texture {path}: {e}") from None


def parse_render_depth(spec: str, extent: str | None) -> Any:
    """The surface of ``render --depth``: a depth [mm] | plane:Z0,GX,GY | a .npy depth map
    (needs ``extent`` X0,X1,Y0,Y1 [mm])."""
    from ..imaging.render import DepthMap, Plane

    if spec.lower().endswith(".npy"):
        if extent is None:
            raise CliError(f"--depth {spec}: a depth map needs --extent X0,X1,Y0,Y1 (mm)")
        box: Any = _numbers("--extent", extent, 4)
        try:
            return DepthMap(_load_npy(spec), box)
        except (TypeError, ValueError) as e:
            raise CliError(f"--depth {spec}: {e}") from None
    if extent is not None:
        raise CliError("--extent: only with a .npy depth map as --depth")
    try:
        if spec.startswith("plane:"):
            return Plane(*_numbers("--depth plane:", spec[6:], 3))
        return Plane(_numbers("--depth", spec, 1)[0])
    except ValueError as e:
        raise CliError(f"--depth {spec}: {e}") from None


def _numbers(option: str, text: str, n: int) -> tuple[float, ...]:
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


def _render_noise(text: str) -> dict[str, float]:
    """``--noise N[,READ]``: photo-electrons for value 1 and read noise (electrons rms)."""
    photons, _, read = text.partition(",")
    try:
        return {"photons": _photons(photons),
                "read_noise": _read_noise(read) if read else 0.0}
    except argparse.ArgumentTypeError as e:
        raise argparse.ArgumentTypeError(f"--noise {text}: {e}") from None


_render_noise.__name__ = "noise"


def _render_targets(args: argparse.Namespace) -> tuple[Path, Path | None]:
    out = Path(args.out)
    _check_suffix("--out", out, (".npz",))
    check_new(out, args.force, FORCE_HINT)
    png = None if args.png is None else Path(args.png)
    if png is not None:
        _check_suffix("--png", png, (".png",))
        _need("matplotlib", "render --png", "plot")
        check_new(png, args.force, FORCE_HINT)
        if png.resolve() == out.resolve():
            raise CliError("--png and --out: give two different files")
    return out, png


def _render_summary(raw: Any, out: Path, png: Path | None, args: argparse.Namespace
                    ) -> dict[str, Any]:
    channels = [{"channel": i, "shape": list(a.shape), "min": float(a.min()),
                 "max": float(a.max()), "mean": float(a.mean())}
                for i, a in enumerate(raw.images, 1)]
    return {"path": str(out), "png": None if png is None else str(png),
            "design": args.design, "texture": args.texture, "depth": args.depth,
            "noise": args.noise, "seed": args.seed, "channels": channels}


def _write_render(raw: Any, out: Path, png: Path | None, force: bool) -> None:
    """The raw file, and its picture (both atomic; the picture is put in place only once
    the raw file is)."""
    import contextlib

    with contextlib.ExitStack() as stack:
        if png is not None:
            from ..plot import raw as plot_raw
            from ..plot._mpl import pyplot

            tmp = stack.enter_context(atomic_output(png, force=force, hint=FORCE_HINT))
            fig = plot_raw(raw)
            try:
                fig.savefig(tmp, dpi=150)
            finally:
                pyplot().close(fig)
        raw.save(out, force=force)


def _cmd_render(args: argparse.Namespace) -> int:
    from ..imaging.render import Scene, render

    out, png = _render_targets(args)
    design = _named_design(args.design)
    texture = parse_render_texture(args.texture, args.width)
    depth = parse_render_depth(args.depth, args.extent)
    scene = Scene(texture, depth)
    raw = render(design, scene, noise=args.noise, seed=args.seed, n_threads=args.threads)
    _write_render(raw, out, png, args.force)
    sys.stdout.write(json_text(_render_summary(raw, out, png, args)) if args.json
                     else f"{out}\n")
    return 0


# -- reconstruct -------------------------------------------------------------------------

def _floats(text: str, n: int, option: str) -> tuple[float, ...]:
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != n:
        raise CliError(f"{option} {text}: give {n} comma-separated numbers")
    return values


def _array_targets(args: argparse.Namespace, what: str) -> tuple[Path, Path | None]:
    """``--out`` (.png or .npy) and, with ``--npy`` beside a .png, the array's path; both
    checked as new (or ``--force``), matplotlib checked for a .png."""
    out = Path(args.out)
    _check_suffix("--out", out, (".png", ".npy"))
    npy = out.with_suffix(".npy") if args.npy and out.suffix == ".png" else None
    if out.suffix == ".png":
        _need("matplotlib", f"{what} to a PNG", "plot")
    for target in (out, npy):
        if target is not None:
            check_new(target, args.force, FORCE_HINT)
    return out, npy


def _write_array(args: argparse.Namespace, out: Path, npy: Path | None, array: Any,
                 picture: Callable[[Any], None]) -> None:
    """The array as ``out`` (.npy) or as the picture ``picture(file)`` draws (.png), and
    beside it ``npy``: each written atomically."""
    import contextlib

    import numpy as np

    with contextlib.ExitStack() as stack:
        if npy is not None:
            with atomic_output(npy, force=args.force, hint=FORCE_HINT) as tmp:
                np.save(tmp, array)
        tmp = stack.enter_context(atomic_output(out, force=args.force, hint=FORCE_HINT))
        if out.suffix == ".npy":
            np.save(tmp, array)
        else:
            picture(tmp)


def _ints(text: str, option: str) -> tuple[int, ...]:
    """Comma-separated whole numbers (a number with a fraction is refused, not cut)."""
    values = _floats(text, len(text.split(",")), option)
    if not all(math.isfinite(v) and v == int(v) for v in values):
        raise CliError(f"{option} {text}: give comma-separated whole numbers")
    return tuple(int(v) for v in values)


def _channels_option(args: argparse.Namespace) -> tuple[int, ...] | None:
    """``--channels I[,J...]`` as channel numbers (None: all)."""
    return None if args.channels is None else _ints(args.channels, "--channels")


def _lens_types_option(args: argparse.Namespace) -> tuple[int, ...] | None:
    """``--lens-types T[,U...]`` as lens type numbers (None: all)."""
    return None if args.lens_types is None else _ints(args.lens_types, "--lens-types")


def _cmd_reconstruct(args: argparse.Namespace) -> int:
    from ..imaging.render import Raw
    from ..inverse.reconstruct import reconstruct

    out, npy = _array_targets(args, "reconstruct")
    raw = Raw.load(args.raw)
    depth = parse_render_depth(args.depth, args.extent)
    region = None if args.region is None else _floats(args.region, 4, "--region")
    rec = reconstruct(raw, depth, region=region, step=args.step,
                      channels=_channels_option(args), noise=args.noise,
                      regularization=args.regularization, tile=args.tile,
                      n_threads=args.threads, progress=None,
                      lens_types=_lens_types_option(args))

    def picture(tmp: Any) -> None:
        from ..plot._mpl import pyplot

        pyplot().imsave(tmp, rec.image, cmap="gray", format="png",
                        vmin=0.0, vmax=max(1.0, float(rec.image.max())))

    _write_array(args, out, npy, rec.image, picture)
    summary = {"path": str(out), "npy": None if npy is None else str(npy),
               "shape": list(rec.image.shape), "extent": list(rec.extent), "step": rec.step,
               "depth": rec.depth, "channels": list(rec.channels), "rows": rec.rows,
               "iterations": rec.iterations, "residual": rec.residual,
               "regularization": rec.regularization, "noise": rec.noise, "tiles": rec.tiles}
    sys.stdout.write(json_text(summary) if args.json else f"{out}\n")
    return 0


# -- depth -------------------------------------------------------------------------------

def _depth_range(text: str) -> Any:
    """``--depths ZMIN:ZMAX`` -> (zmin, zmax); ``Z1,Z2,...`` -> the candidates."""
    if ":" in text:
        lo, _, hi = text.partition(":")
        return _numbers("--depths", f"{lo},{hi}", 2)
    return _numbers("--depths", text, len(text.split(",")))


def _cmd_depth(args: argparse.Namespace) -> int:
    import numpy as np

    from ..imaging.render import Raw
    from ..inverse.depth import estimate_depth

    out, npy = _array_targets(args, "a depth map")
    raw = Raw.load(args.raw)
    depths = _depth_range(args.depths)
    region = None if args.region is None else _floats(args.region, 4, "--region")
    kw: dict[str, Any] = {} if args.candidates is None else {"candidates": args.candidates}
    est = estimate_depth(raw, depths=depths, region=region, step=args.step,
                         channels=_channels_option(args), n_threads=args.threads,
                         progress=None, **kw)
    assert est.confident is not None and est.sweep is not None

    def picture(tmp: Any) -> None:
        from ..plot._mpl import pyplot
        from ..plot.depth import depth as depth_plot

        fig, ax = pyplot().subplots(figsize=(7.5, 5.0), layout="constrained")
        depth_plot(est, ax)
        fig.savefig(tmp, format="png", dpi=110)
        pyplot().close(fig)

    _write_array(args, out, npy, est.depth, picture)
    conf = est.confident
    z = est.depth[conf]
    summary = {"path": str(out), "npy": None if npy is None else str(npy),
               "shape": list(est.depth.shape), "extent": list(est.extent),
               "candidates": [float(est.sweep.candidates[0]), float(est.sweep.candidates[-1]),
                              int(est.sweep.candidates.size)],
               "channels": list(est.sweep.channels), "samples": est.sweep.samples,
               "confident": float(conf.mean()),
               "median_depth": float(np.median(z)) if z.size else None}
    sys.stdout.write(json_text(summary) if args.json else f"{out}\n")
    return 0


# -- optimise ----------------------------------------------------------------------------

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
        raise CliError(f"--free {spec}: expected NAME=LOW:HIGH, e.g. kappa=0.05:0.8") from None
    return name.strip(), (bounds[0], bounds[1])


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


def _optimise_depths(spec: str, option: str = "--depths") -> np.ndarray:
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


def _optimise_document(res: Any, source: str, args: argparse.Namespace) -> dict[str, Any]:
    return {"source": source, "objective": args.objective, "objective_value": res.objective,
            "free": res.free, "feasible": res.feasible, "active": list(res.active),
            "slack": res.slack, "merits": res.merits, "nfev": res.nfev,
            "generations": res.generations, "design": res.design.design.as_dict()}


#: The API's parameter names of optimise and compare -> the options a CLI user wrote.
OPTION_OF = {"objective": "--objective", "constraints": "--constraint", "free": "--free",
             "sense": "--sense", "min_microlens_f_number": "--min-microlens-f-number",
             "merits_2d": "--merits-2d", "window": "--window", "which": "--architectures",
             "depths": "--depths", "optimise_depths": "--optimise-depths",
             "simulate_depths": "--simulate-depths", "threshold_px": "--threshold"}


def _in_cli_words(e: InvalidParameter) -> CliError | InvalidParameter:
    """An API error of optimise or compare in the CLI's words: the option the user wrote
    instead of the parameter's name, and no callable (the CLI takes a merit name)."""
    import re

    key = e.name.split("[")[0]
    if key not in OPTION_OF:
        return e
    msg = str(e).replace(f"invalid {e.name}", f"invalid {OPTION_OF[key]}", 1)
    msg = re.sub(r"a merit name \((.*)\) or a callable.*$", r"one of: \1", msg)
    return CliError(msg.replace(" or a callable", ""))


def _search(run: Callable[..., Any], args: argparse.Namespace, *call: Any,
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
        raise _in_cli_words(e) from None


def _optimise_outputs(args: argparse.Namespace) -> tuple[Path | None, Path | None]:
    """--out and --history, checked before any work."""
    out = None if args.out is None else Path(args.out)
    if out is not None:
        _check_suffix("--out", out, (".toml",))
        check_new(out, args.force, FORCE_HINT)
    hist = None if args.history is None else Path(args.history)
    if hist is not None:
        _check_suffix("--history", hist, (".csv", ".parquet"))
        check_new(hist, args.force, FORCE_HINT)
    return out, hist


def _write_optimised(res: Any, out: Path | None, hist: Path | None, force: bool) -> None:
    if out is not None:
        with atomic_output(out, force=force, hint=FORCE_HINT) as tmp:
            tmp.write_text(res.design.to_toml(), encoding="utf-8")
    if hist is not None:
        with atomic_output(hist, force=force, hint=FORCE_HINT) as tmp:
            if hist.suffix == ".csv":
                res.history.to_csv(tmp, index=False)
            else:
                res.history.to_parquet(tmp, index=False)


def _cmd_optimise(args: argparse.Namespace) -> int:
    for module in ("scipy", "pandas"):
        _need(module, "optimise", "sweep")
    from ..study.optimise import optimise

    out, hist = _optimise_outputs(args)
    free = dict(parse_free(f) for f in args.free)
    constraints = dict(parse_constraint(c) for c in args.constraint or [])
    depths = _optimise_depths(args.depths)
    camera, source = _load_subject(args)
    kwargs = dict(sense=args.sense, constraints=constraints, depths=depths, seed=args.seed,
                  maxiter=args.maxiter, popsize=args.popsize, polish=not args.no_polish,
                  min_microlens_f_number=args.min_microlens_f_number, n_threads=args.threads,
                  merits_2d=True if args.merits_2d else None)
    if args.window is not None:
        kwargs["window"] = args.window
    res = _search(optimise, args, camera, free, args.objective, **kwargs)
    if not res.feasible:
        raise CliError(f"no feasible design found in {res.nfev} candidates (least violation: "
                       f"{res.slack}); widen --free or relax --constraint")
    _write_optimised(res, out, hist, args.force)
    doc = _optimise_document(res, source, args)
    if args.json:
        sys.stdout.write(json_text(doc if out is None else {"path": str(out), **doc}))
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


# -- compare -----------------------------------------------------------------------------

COMPARE_FILES = ("table.csv", "curves.csv")


def _compare_targets(args: argparse.Namespace, names: list[str]) -> tuple[Path | None,
                                                                          Path | None]:
    """The folder and the figure of `compare`, checked (no file overwritten without
    --force, a folder not a file) before any work."""
    out = None if args.out is None else Path(args.out)
    if out is not None:
        if out.exists() and not out.is_dir():
            raise CliError(f"--out {out}: exists and is not a folder")
        for name in [*COMPARE_FILES, *(f"{n}.toml" for n in names)]:
            if out.is_dir():
                check_new(out / name, args.force, FORCE_HINT)
    fig = None if args.figure is None else Path(args.figure)
    if fig is not None:
        _check_suffix("--figure", fig, (".png", ".svg"))
        check_new(fig, args.force, FORCE_HINT)
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise CliError('--figure needs matplotlib: pip install "splitlf[plot]"') from None
    return out, fig


def _compare_names(spec: str | None) -> list[str]:
    from ..study.compare import ARCHITECTURES

    if spec is None:
        return list(ARCHITECTURES)
    names = [n.strip() for n in spec.split(",") if n.strip()]
    bad = [n for n in names if n not in ARCHITECTURES]
    if not names or bad or len(set(names)) < len(names):
        raise CliError(f"--architectures {spec}: allowed distinct names among "
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
    keep = [c for c in [*COMPARE_COLUMNS, *(c for c in tab.columns if c.startswith("mtf50_"))]
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


def _compare_text(res: Any, args: argparse.Namespace, constraints: dict[str, Any],
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
        with atomic_output(out / "table.csv", force=force, hint=FORCE_HINT) as tmp:
            res.table.to_csv(tmp)
        with atomic_output(out / "curves.csv", force=force, hint=FORCE_HINT) as tmp:
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
        with atomic_output(fig_path, force=force, hint=FORCE_HINT) as tmp:
            fig.savefig(tmp, dpi=150, format=fig_path.suffix[1:])
        written.append(fig_path)
    return written


def _simulate_depth_list(spec: str | None) -> list[float]:
    sim = []
    for text in (spec or "").split(","):
        if text.strip():
            try:
                sim.append(_depth(text.strip()))
            except argparse.ArgumentTypeError as e:
                raise CliError(f"--simulate-depths: {e}") from None
    return sim


def _cmd_compare(args: argparse.Namespace) -> int:
    for module in ("scipy", "pandas"):
        _need(module, "compare", "sweep")
    from ..study.compare import compare

    names = _compare_names(args.architectures)
    out, fig_path = _compare_targets(args, names)
    constraints = dict(parse_constraint(c) for c in args.constraint or [])
    kwargs = dict(which=names, depths=_optimise_depths(args.depths, "--depths"),
                  optimise_depths=_optimise_depths(args.optimise_depths, "--optimise-depths"),
                  window=args.window, optimise_window=args.optimise_window,
                  maxiter=args.maxiter, popsize=args.popsize, polish=args.polish,
                  seed=args.seed, simulate_depths=_simulate_depth_list(args.simulate_depths),
                  threshold_px=args.threshold, n_threads=args.threads)
    res = _search(compare, args, args.preset, args.objective, args.sense, constraints,
                  **kwargs)
    written = _write_compare(res, out, fig_path, args.force)
    if args.json:
        doc = _compare_document(res)
        doc["written"] = [str(p) for p in written]
        sys.stdout.write(json_text(doc))
    else:
        sys.stdout.write(_compare_text(res, args, constraints, written))
    return 0


# -- parser ------------------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line, like every other error of the command line."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# -- explore -----------------------------------------------------------------------------

def _cmd_explore(args: argparse.Namespace) -> int:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        raise CliError('explore needs Bokeh: pip install "splitlf[explore]"') from None
    from ..explorer import serve

    subject, _ = _load_subject(args)
    reference = None if args.compare is None else _named_design(args.compare)
    try:
        serve(subject, port=args.port, address=args.address, reference=reference)
    except OSError as e:
        raise CliError(f"--port {args.port}: cannot listen on {args.address}: "
                       f"{e.strerror or e}") from None
    return 0


# -- option groups, declared once ----------------------------------------------------------

def _design_source(p: argparse.ArgumentParser, what: str) -> None:
    """The design source: --config FILE (a [camera] or [design] TOML) or --preset NAME."""
    g = p.add_argument_group("design (default: the seed design)")
    g.add_argument("--config", metavar="FILE.toml",
                   help="a TOML file with a [camera] table, or a [design] table and its "
                   "[[design.channels]] (docs/architectures.md)")
    g.add_argument("--preset", choices=PRESETS, default=None, metavar="NAME",
                   help=f"{what} a named design instead: {', '.join(PRESETS)} "
                   "(docs/architectures.md)")


def _threads_option(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--threads", type=_threads, default=None, metavar="N",
                   help=f"{what} (an integer in [{THREADS_RANGE[0]}, "
                   f"{THREADS_RANGE[1]}]; default: all cores)")


def _output(p: argparse.ArgumentParser, out: str | None, metavar: str = "FILE",
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


def _depths_option(p: argparse.ArgumentParser, option: str, default: str, what: str) -> None:
    p.add_argument(option, default=default, metavar="MIN:MAX:NUM",
                   help=f"log-spaced depths of {what} [mm] (default {default})")


def _scheduler_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="Dask scheduler address, e.g. tcp://host:8786")


def _threshold_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--threshold", type=_threshold, default=0.5, metavar="PX",
                   help="sharpness threshold on the blur radius in pixels (default 0.5)")


def _merits_2d_options(p: argparse.ArgumentParser, what: str, default: str) -> None:
    p.add_argument("--merits-2d", action="store_true", help=what)
    p.add_argument("--window", type=_window, default=None, metavar="W",
                   help="width of the 2-D merits' central field in lens pitches of channel 1 "
                   f"({default}; docs/optimise.md, '2-D merits')")


def _add_report(sub: Any) -> None:
    p = sub.add_parser(
        "report",
        help="where a design is sharp and how densely it samples",
        description="Print where the design (the seed design unless --config or --preset) "
        "is sharp and how densely it samples: a summary of the design, its out-of-focus "
        "planes, the depth of field of each channel (each half of the split sensor) and of "
        "their union, and the worst resolution. --full adds every field of every channel, "
        "its lens types and the coincidence planes where docs/model.md §6 holds.",
    )
    _design_source(p, "report")
    _threads_option(p, "threads for the coincidence planes and the resolution figures")
    _threshold_option(p)
    p.add_argument("--full", action="store_true",
                   help="every field of every channel, its lens types and the coincidence "
                   "planes (default: the short answer)")
    _output(p, None)
    p.set_defaults(func=_cmd_report)


def _add_figures(sub: Any) -> None:
    p = sub.add_parser("figures", help="write every figure of a design",
                       description="Write the paper's figures (1, 4, 5), the samples "
                       "figure, the microlens images on the sensor and the 2-D sample map "
                       "for the camera (the seed design unless --config). A general design "
                       "(--preset, or a --config file with a [design] table; "
                       "docs/architectures.md) gets Figs. 1 and 5 per channel and lens "
                       "type, its microlens images and its sample map. Every option is "
                       "checked, and no existing file is overwritten without --force, "
                       "before the folder is created.")
    _design_source(p, "draw")
    _threads_option(p, "threads of the core for every figure")
    p.add_argument("--z", type=_depth, default=None, metavar="MM",
                   help="depth of the sample map [mm], > F (default: channel 1's "
                   "out-of-focus plane with several channels, twice it with one)")
    p.add_argument("--format", choices=("png", "svg"), default="png",
                   help="image format (default: png)")
    p.add_argument("--dpi", type=_dpi, default=150,
                   help=f"resolution in dots per inch, an integer in [{DPI_RANGE[0]}, "
                   f"{DPI_RANGE[1]}] (default 150)")
    _output(p, "output folder, created if missing (default: figures)", "DIR", "figures",
            json_help="")
    p.set_defaults(func=_cmd_figures)


def _add_trace(sub: Any) -> None:
    p = sub.add_parser("trace", help="write every pixel's ray-space polygon to .npz",
                       description="Trace every pixel of both halves along one axis "
                       "(docs/model.md §3-4) and write the arrays of splitlf.trace, prefixed "
                       "half1_/half2_, with the camera as TOML, to an .npz file. A general "
                       "design with rect grids (--preset, or a --config file with a "
                       "[design] table) is traced channel by channel, prefixed channel1_, "
                       "channel2_, ..., with the design as TOML (design_toml).")
    _design_source(p, "trace")
    _threads_option(p, "threads of the trace")
    p.add_argument("--axis", choices=("x", "y"), default="x",
                   help="the sensor axis traced (default: x)")
    _output(p, "output file (default: trace.npz)", "FILE.npz", "trace.npz",
            "print a JSON summary of the arrays instead of the path")
    p.set_defaults(func=_cmd_trace)


def _add_sweep(sub: Any) -> None:
    p = sub.add_parser("sweep", help="figures of merit over a grid of designs",
                       description="Full-factorial design sweep from a TOML file with "
                       "[grid], [depths] (min, max, num; log-spaced), [options] and an "
                       "optional base: a [camera] table, or a [design] table whose fields "
                       "the grid names by path (\"channels[2].L\" = [...]; "
                       "docs/architectures.md). Without a base in the file: --preset, "
                       "--config, or the seed design.")
    _design_source(p, "sweep around")
    _threads_option(p, "threads of the core for in-process sweeps")
    p.add_argument("--grid", required=True, metavar="SWEEP.toml",
                   help="the sweep file: [grid], [depths], [options], [camera] or [design]")
    _scheduler_option(p)
    _merits_2d_options(p, "also compute the 2-D merits (covering radius, distinct 2-D "
                       "samples; a 2-D analysis per depth: slower); also [options] "
                       "merits_2d = true", "default 16, or [options] window")
    _output(p, "write the sweep to .nc (NetCDF), .parquet or .json",
            json_help="print the designs as JSON records (with --out: as well)")
    p.set_defaults(func=_cmd_sweep)


def _add_simulate(sub: Any) -> None:
    p = sub.add_parser("simulate", help="super-resolution simulation at one or more depths",
                       description="Image a textured plane with half 1, half 2, the split "
                       "sensor and the conventional camera, reconstruct it with known depth "
                       "and print RMSE, PSNR and MTF50 (docs/simulate.md). A general design "
                       "with rect grids (--preset, or a --config file with a [design] "
                       "table) is simulated per channel, for their union and for the "
                       "conventional camera on channel 1's array plane.")
    _design_source(p, "simulate")
    _threads_option(p, "threads of the core")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--z", type=_depth, default=1000.0, metavar="MM",
                       help="depth of the plane in mm (default 1000)")
    where.add_argument("--z-range", type=_depth, nargs=2, metavar=("A", "B"),
                       help="log-spaced depths from A to B mm (see --n)")
    p.add_argument("--n", type=_n_depths, default=None,
                   help=f"depths of --z-range, an integer in [{SIMULATE_N_RANGE[0]}, "
                   f"{SIMULATE_N_RANGE[1]}] (default 8)")
    p.add_argument("--texture", default="random",
                   help="random | sinusoid:F | bars:F (cycles/mm) | image:FILE.npy:WIDTH_MM")
    p.add_argument("--photons", type=_photons, default=None,
                   help="add noise: photo-electrons of a full-aperture pixel, white texture")
    p.add_argument("--read-noise", type=_read_noise, default=None, metavar="E",
                   help="read noise in electrons rms (needs --photons; default 0)")
    p.add_argument("--seed", type=_seed, default=0,
                   help="seed of the random texture and the noise, an integer >= 0 "
                   "(default 0)")
    p.add_argument("--no-conventional", action="store_true",
                   help="leave out the conventional camera (only the light field rows)")
    _output(p, "write the JSON document to a file", "FILE.json",
            json_help="print one JSON document (with --out: as well)")
    p.set_defaults(func=_cmd_simulate)


def _add_render(sub: Any) -> None:
    p = sub.add_parser("render", help="the raw sensor images of a textured scene",
                       description="Render what each channel's sensor records for a "
                       "textured surface (docs/model.md §10) and write the raws to an .npz "
                       "file that splitlf.Raw.load reads (and, with --png, a picture of "
                       "them with a zoom on a few micro-images).")
    p.add_argument("design", metavar="DESIGN",
                   help=f"a preset ({', '.join(PRESETS)}) or a TOML file with a [design] "
                   "or [camera] table")
    p.add_argument("--texture", required=True, metavar="SPEC",
                   help="random | sinusoid:F | bars:F (cycles/mm) | edge[:ANGLE] (degrees "
                   "from vertical, default 5) | star[:SPOKES] (default 36) | an image file "
                   "(.png or .npy of albedos) with --width")
    p.add_argument("--width", type=_real_type("width", 0.0, "a finite width > 0 (mm)"),
                   default=None, metavar="MM", help="an image texture's width on the object")
    p.add_argument("--depth", required=True, metavar="SPEC",
                   help="a depth in mm (a fronto-parallel plane) | plane:Z0,GX,GY "
                   "(Z = Z0 + GX X + GY Y) | a .npy depth map with --extent")
    p.add_argument("--extent", default=None, metavar="X0,X1,Y0,Y1",
                   help="a depth map's extent on the object [mm] (with a negative X0: "
                   "--extent=X0,X1,Y0,Y1)")
    p.add_argument("--noise", type=_render_noise, default=None, metavar="N[,READ]",
                   help="add noise: N photo-electrons for value 1 (Poisson), READ electrons "
                   "rms of read noise (default 0)")
    p.add_argument("--seed", type=_seed, default=0,
                   help="seed of the random texture and the noise, an integer >= 0 "
                   "(default 0)")
    _threads_option(p, "threads of the core")
    g = _output(p, "the raw file to write (.npz)", "RAW.npz", required=True,
                json_help="print a JSON summary of the raws instead of the path")
    g.add_argument("--png", default=None, metavar="FILE.png",
                   help="also write a picture of the raws (splitlf.plot.raw)")
    p.set_defaults(func=_cmd_render)


def _grid_options(p: Any, region_default: str, step_default: str) -> None:
    """--region, --step and --channels of the commands that solve on a grid of cells."""
    p.add_argument("--region", default=None, metavar="X0,X1,Y0,Y1",
                   help=f"the region [mm] (default: {region_default}; with a negative X0: "
                   "--region=X0,X1,Y0,Y1)")
    p.add_argument("--step", type=_real_type("step", 0.0, "a finite step > 0 (mm)"),
                   default=None, metavar="MM", help=f"the cell pitch (default: {step_default})")
    p.add_argument("--channels", default=None, metavar="I[,J...]",
                   help="channel numbers from 1 (default: all)")


def _array_output(p: Any, what: str, metavar: str) -> None:
    """-o (.png or .npy), --json and --npy of the commands that write an array."""
    g = _output(p, what, metavar, required=True,
                json_help="print a JSON summary instead of the path")
    g.add_argument("--npy", action="store_true",
                   help="with a .png output, also write the array beside it (.npy)")


def _add_depth(sub: Any) -> None:
    p = sub.add_parser("depth", help="a depth map from a raw file",
                       description="Estimate the scene's depth from a raw file alone (a plane "
                       "sweep: docs/model.md §11, docs/depth.md) and write it as a colour map "
                       "(cells the method does not stand behind in grey) or an array.")
    p.add_argument("raw", metavar="RAW.npz", help="a raw file (splitlf render, Raw.save)")
    p.add_argument("--depths", required=True, metavar="ZMIN:ZMAX",
                   help="the candidate range in mm (uniform in 1/z), or Z1,Z2,... the "
                   "candidates themselves")
    p.add_argument("--candidates", type=int, default=None, metavar="N",
                   help="candidates of a ZMIN:ZMAX range (default 64)")
    _grid_options(p, "what the channels see at the middle candidate",
                  "3 sensor steps mu_1 z / L_1 at the middle candidate")
    _threads_option(p, "threads of the core")
    _array_output(p, "the depth map to write (.png, or .npy for the array in mm)", "DEPTH.png")
    p.set_defaults(func=_cmd_depth)


def _add_reconstruct(sub: Any) -> None:
    p = sub.add_parser("reconstruct", help="a super-resolved image from a raw file",
                       description="Reconstruct the albedo on a grid of cells over a region "
                       "of a known surface from a raw file (docs/model.md §11, "
                       "docs/reconstruct.md) and write it as a picture or an array.")
    p.add_argument("raw", metavar="RAW.npz", help="a raw file (splitlf render, Raw.save)")
    p.add_argument("--depth", required=True, metavar="SPEC",
                   help="the surface: a depth in mm (a fronto-parallel plane), "
                   "plane:Z0,GX,GY (Z = Z0 + GX X + GY Y), or a .npy depth map (with "
                   "--extent; e.g. from splitlf depth --npy)")
    p.add_argument("--extent", default=None, metavar="X0,X1,Y0,Y1",
                   help="a .npy depth map's extent [mm] (splitlf depth prints it)")
    _grid_options(p, "what every channel sees through half its aperture",
                  "the sensor step mu_1 z / L_1")
    p.add_argument("--noise", type=_render_noise, default=None, metavar="N[,READ]",
                   help="the raw's noise, as given to render (default: noise-free)")
    p.add_argument("--regularization", type=_real_type(
        "regularization", 0.0, "a finite weight > 0"), default=None, metavar="LAMBDA",
        help="the smoothness prior's weight (default 4)")
    p.add_argument("--tile", type=_integer_type("tile", 16, 10**9), default=None,
                   metavar="CELLS",
                   help="at most this many cells per side in one solve (default: one "
                   "solve, or tiles of the size that fits when one would not)")
    p.add_argument("--lens-types", default=None, metavar="T[,U...]",
                   help="use only the pixels under these lens types of a multi-focus array "
                   "(numbers from 1, in the order of the channel's f; default: all)")
    _threads_option(p, "threads of the core")
    _array_output(p, "the image to write (.png, or .npy for the array)", "IMAGE.png")
    p.set_defaults(func=_cmd_reconstruct)


def _add_optimise(sub: Any) -> None:
    p = sub.add_parser("optimise", help="the best design for an objective (inverse design)",
                       description="Search the free fields of the camera (the seed design "
                       "unless --config or --preset) with differential evolution, polished "
                       "locally, for the design that optimises a figure of merit subject to "
                       "constraints (docs/optimise.md); write it as a TOML that report "
                       "--config reads (a [design] file for a design base).")
    _design_source(p, "optimise around")
    _threads_option(p, "threads of the core for in-process evaluation")
    p.add_argument("--free", action="append", required=True, metavar="NAME=LOW:HIGH",
                   help="a free field and its bounds (repeat; a camera field such as kappa, "
                   "or a design's by path such as channels[2].L; counts such as Q are "
                   "searched as integers)")
    p.add_argument("--objective", required=True, metavar="MERIT",
                   help="the merit to optimise (docs/optimise.md lists them)")
    p.add_argument("--sense", choices=("max", "min"), default=None,
                   help="maximise or minimise (default: the merit's natural direction)")
    p.add_argument("--constraint", action="append", metavar="MERIT<=VALUE",
                   help="a constraint MERIT<=VALUE or MERIT>=VALUE (repeat)")
    _depths_option(p, "--depths", "150:10000:200", "the merits")
    p.add_argument("--min-microlens-f-number", type=_f_number, default=None, metavar="N",
                   help="manufacturable floor on the microlens f-number f_i/d")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the search (default 0)")
    p.add_argument("--maxiter", type=_integer_type("generation count", 1, 100_000),
                   default=100, help="generations of differential evolution (default 100)")
    p.add_argument("--popsize", type=_integer_type("population multiplier", 1, 10_000),
                   default=15, help="population per free field (default 15)")
    p.add_argument("--no-polish", action="store_true", help="skip the local polish")
    _scheduler_option(p)
    p.add_argument("--history", metavar="FILE",
                   help="write every evaluated candidate to .csv or .parquet")
    _merits_2d_options(p, "compute and report the 2-D merits even when neither the "
                       "objective nor a constraint names one (they are computed when one "
                       "does)", "default 16")
    _output(p, "write the best design ([camera] TOML, [design] for a design base)",
            "BEST.toml")
    p.set_defaults(func=_cmd_optimise)


def _add_compare(sub: Any) -> None:
    from ..study.compare import ARCHITECTURES
    from ..study.compare import PRESETS as SENSORS

    p = sub.add_parser("compare", help="optimise every architecture on one sensor and "
                       "compare them", description="Build the plain light field camera, the "
                       "split sensor, a three-way split, a multi-focus hex camera and a "
                       "conventional camera on the sensor and main lens of a preset, optimise "
                       "each light field architecture for one objective (differential "
                       "evolution, small budgets), set the conventional camera's focus, and "
                       "compare the optimised designs over the depths: sharp fraction, "
                       "covering radius, light per pixel, MTF50 (docs/compare.md).")
    p.add_argument("--preset", choices=SENSORS, default="seed",
                   help="whose sensor and main lens: seed (36 x 24 mm, 9 um, F 80 mm) or "
                   "raytrix-r12 (4080 x 3068 px of 5.5 um, F 49.9 mm) (default seed)")
    p.add_argument("--objective", required=True, metavar="MERIT",
                   help="the merit every architecture optimises, e.g. sharp_fraction_union "
                   "(docs/optimise.md lists them)")
    p.add_argument("--sense", choices=("max", "min"), default=None,
                   help="maximise or minimise (default: the merit's natural direction)")
    p.add_argument("--constraint", action="append", metavar="MERIT<=VALUE",
                   help="a constraint MERIT<=VALUE or MERIT>=VALUE (repeat), e.g. "
                   "covering_radius_median_union<=1.5")
    p.add_argument("--architectures", default=None, metavar="A,B,...",
                   help=f"a comma-separated subset of {','.join(ARCHITECTURES)} "
                   "(default: all)")
    _depths_option(p, "--depths", "150:10000:60", "the evaluation")
    _depths_option(p, "--optimise-depths", "150:10000:12", "the merits inside the search")
    p.add_argument("--window", type=_real_type("window", 0.0, "a finite number > 0"),
                   default=16.0, metavar="PITCHES",
                   help="central field of the evaluation's covering radius, in lens "
                   "pitches (default 16)")
    p.add_argument("--optimise-window", type=_real_type("window", 0.0, "a finite number > 0"),
                   default=4.0, metavar="PITCHES",
                   help="central field of the 2-D merits inside the search (default 4)")
    p.add_argument("--maxiter", type=_integer_type("generation count", 1, 100_000),
                   default=8, help="generations of differential evolution (default 8)")
    p.add_argument("--popsize", type=_integer_type("population multiplier", 1, 10_000),
                   default=5, help="population per free field (default 5)")
    p.add_argument("--polish", action="store_true",
                   help="polish each optimum locally (Nelder-Mead; default off)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the search (default 0)")
    p.add_argument("--simulate-depths", default=None, metavar="Z1,Z2,...",
                   help="depths [mm] of the super-resolution MTF50 columns (default none)")
    _threshold_option(p)
    _threads_option(p, "threads of the core")
    _scheduler_option(p)
    p.add_argument("--figure", metavar="FILE.png",
                   help="write the comparison figure (splitlf.plot.compare), .png or .svg")
    p.add_argument("--wide", action="store_true",
                   help="print every column of the table, unabbreviated (default: the most "
                   f"useful columns, fitting {COMPARE_WIDTH} characters)")
    _output(p, "write table.csv, curves.csv and one NAME.toml per optimised design into "
            "this folder (created if missing)", "DIR")
    p.set_defaults(func=_cmd_compare)


def _add_explore(sub: Any) -> None:
    p = sub.add_parser("explore", help="the interactive design explorer in the browser",
                       description="Start the design explorer (docs/explore.md), a local "
                       "web app, for a preset, a [design] or [camera] TOML file, or the seed "
                       "design, and print its URL. It binds 127.0.0.1 and accepts only pages "
                       "and websockets addressed to it. Ctrl-C stops it.")
    _design_source(p, "start from")
    p.add_argument("--port", type=_integer_type("port", 0, 65535), default=5006,
                   help="TCP port, an integer in [0, 65535]; 0 picks a free one (default 5006)")
    p.add_argument("--compare", default=None, metavar="NAME|FILE.toml",
                   help="a second design drawn on the same axes: a preset name or a "
                   "[design] or [camera] TOML file (e.g. an optimise result)")
    p.add_argument("--address", default="127.0.0.1", metavar="IP",
                   help="address to bind (default 127.0.0.1: this machine only)")
    p.set_defaults(func=_cmd_explore)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand (report, figures, trace, sweep, simulate,
    render, optimise, compare, explore)."""
    parser = _Parser(
        prog="splitlf",
        description="Design and analysis of split-sensor light field cameras.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                help="what to do (COMMAND --help for its options)")
    for add in (_add_report, _add_figures, _add_trace, _add_sweep, _add_simulate,
                _add_render, _add_reconstruct, _add_depth, _add_optimise, _add_compare,
                _add_explore):
        add(sub)
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
