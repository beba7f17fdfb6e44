"""Design-space sweeps: figures of merit over a full-factorial grid of camera designs.

In-process by default (the Rust thread pool parallelises each design over depths); with
any ``concurrent.futures.Executor`` — e.g. a Dask cluster's ``client.get_executor()`` —
designs are sent in batches of plain field dicts (no native object is pickled) and every
task runs the core with ``threads_per_task`` rayon threads so workers do not oversubscribe.
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import math
import numbers
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from . import _native, _validate
from .camera import COUNT_FIELDS, FIELDS, Camera
from .design import Channel, Design
from .errors import InvalidParameter, TooLargeError

__all__ = ["DEFAULT_THRESHOLD_PX", "DEFAULT_TOL", "DEFAULT_WINDOW", "MAX_DEPTHS", "MAX_DESIGNS",
           "METRICS", "METRICS_2D", "design_fields", "design_metrics", "evaluate_design",
           "sweep"]

#: Most designs one sweep evaluates (the product of the grid's sizes); a larger grid is
#: refused before any work. At ~1-10 ms per design this is hours of work already.
MAX_DESIGNS = 1_000_000
#: Most depths per design (each depth is a full sample analysis of the design).
MAX_DEPTHS = 100_000
#: Default sharpness threshold on the blur radius [px] and merge tolerance [delta(z)].
DEFAULT_THRESHOLD_PX = _native.DEFAULT_THRESHOLD_PX
DEFAULT_TOL = _native.DEFAULT_TOL
#: Default width of the central field of the 2-D merits, in lens pitches of channel 1 (as
#: :func:`splitlf.coverage`'s).
DEFAULT_WINDOW = _native.DEFAULT_WINDOW

#: Figures of merit of one design, in the order the core returns them.
METRICS = (
    "sharp_fraction_half1",
    "sharp_fraction_split",
    "max_gap_worst_half1",
    "max_gap_worst_half2",
    "max_gap_worst_union",
    "max_gap_median_half1",
    "max_gap_median_half2",
    "max_gap_median_union",
    "lit_fraction_half2",
)

_DOCS = {
    "sharp_fraction_half1": "share of [min, max] depth (log) where half 1 alone is sharp",
    "sharp_fraction_split": "share of [min, max] depth (log) where either half is sharp",
    "max_gap_worst_half1": "largest max_gap of half 1 over the depths [delta(z)]",
    "max_gap_worst_half2": "largest max_gap of half 2 over the depths [delta(z)]",
    "max_gap_worst_union": "largest max_gap of both halves together over the depths [delta(z)]",
    "max_gap_median_half1": "median max_gap of half 1 over the depths [delta(z)]",
    "max_gap_median_half2": "median max_gap of half 2 over the depths [delta(z)]",
    "max_gap_median_union": "median max_gap of both halves together over the depths [delta(z)]",
    "lit_fraction_half2": "lit pixels per microlens of half 2 over Q",
}

#: The 2-D merits of a Camera (its two-channel ``Camera.design``), in the order the core
#: appends them to :data:`METRICS` when asked (``merits_2d=True``): the worst and median
#: covering radius of the central field over the depths [delta(z)] and the median number
#: of distinct 2-D samples inside it, for half 1, half 2 and the union
#: (docs/model.md §9, :func:`splitlf.coverage`).
METRICS_2D: tuple[str, ...] = tuple(_native.camera_metrics_2d())


_DESIGN_DOCS = {
    "sharp_fraction": "share of [min, max] depth (log) where {row} is sharp",
    "max_gap_worst": "largest max_gap of {row} over the depths [delta(z)] (NaN with a hex "
                     "channel)",
    "max_gap_median": "median max_gap of {row} over the depths [delta(z)] (NaN with a hex "
                      "channel)",
    "lit_fraction": "lit pixels over pixels of {row} along x (NaN for a hex channel)",
    "light_per_pixel": "share x mean polygon area of the lit pixels of {row} along x / L_1: "
                       "1-D etendue per lit pixel [mm rad] (NaN for a hex channel)",
    "covering_radius_worst": "largest covering radius of the central field by {row} over the "
                             "depths [delta(z)] (2-D, splitlf.coverage)",
    "covering_radius_median": "median covering radius of the central field by {row} over the "
                              "depths [delta(z)] (2-D, splitlf.coverage)",
    "distinct_2d_median": "median number of distinct 2-D samples of {row} in the central "
                          "field over the depths (splitlf.coverage)",
}

#: Numeric channel fields a design's grid or free fields may name (``channels[i].NAME``),
#: and the counts among them (integers).
DESIGN_CHANNEL_FIELDS = ("L", "d", "v", "mu", "Kx", "Ky", "Q", "Mx", "My", "share")
DESIGN_COUNT_FIELDS = ("Kx", "Ky", "Q", "Mx", "My")
_PATH = re.compile(r"channels\[(\d+)\]\.([A-Za-z]+)(?:\[(\d+)\])?")


def design_metrics(design: Design, merits_2d: bool = False) -> tuple[str, ...]:
    """Names of the figures of merit of ``design`` (from the core), in the order
    :func:`evaluate_design` returns them: per channel (from 1) and union,
    ``sharp_fraction_channel1``, ..., ``sharp_fraction_union``, ``max_gap_worst_*``,
    ``max_gap_median_*``, then per channel ``lit_fraction_channel*`` and
    ``light_per_pixel_channel*`` (5 C + 3 names for C channels); with ``merits_2d``,
    followed by the 2-D merits per channel and union: ``covering_radius_worst_channel1``,
    ..., ``covering_radius_worst_union``, ``covering_radius_median_*``,
    ``distinct_2d_median_*`` (3 (C + 1) names more)."""
    if not isinstance(design, Design):
        raise TypeError(f"design must be a splitlf.Design, got {type(design).__name__}")
    return tuple(_native.design_metrics(design.core, _merits_2d(merits_2d)))


def _design_doc(name: str) -> str:
    prefix, _, row = name.rpartition("_")
    row = "the union of all channels" if row == "union" else row.replace("channel",
                                                                         "channel ")
    return _DESIGN_DOCS[prefix].format(row=row)


def _camera_doc(name: str) -> str:
    if name in _DOCS:
        return _DOCS[name]
    prefix, _, row = name.rpartition("_")
    row = "both halves together" if row == "union" else row.replace("half", "half ")
    return _DESIGN_DOCS[prefix].format(row=row)


def _merits_2d(value: Any) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"merits_2d must be True or False, got {type(value).__name__} "
                        f"{value!r}")
    return value


def _window(value: Any) -> float:
    return _real_option(value, "window", "a finite number > 0 (the central field's width "
                        "in lens pitches of channel 1)", lambda x: math.isfinite(x) and x > 0)


def _options_2d(merits_2d: Any, window: Any, tol: float) -> float | None:
    """The core's ``window`` argument: the checked window when the 2-D merits are asked
    for, else None (they are not computed). ``window`` is checked either way; with the 2-D
    merits, ``tol`` must also suit the 2-D distinct samples, (0, MAX_TOL_2D]."""
    on, w = _merits_2d(merits_2d), _window(window)
    if not on:
        return None
    if not 0.0 < tol <= _native.MAX_TOL_2D:
        raise InvalidParameter.of("tol", tol, f"a number in (0, {_native.MAX_TOL_2D:g}] with "
                                  "the 2-D merits (a multiple of delta(z))")
    return w


def design_fields(design: Design) -> tuple[str, ...]:
    """The numeric fields of ``design`` a sweep grid or ``optimise``'s ``free`` may name:
    ``"F"``, ``"D"``, then for each channel i (from 1) ``"channels[i].L"``, ``.d``, ``.v``,
    ``.mu``, ``.Kx``, ``.Ky``, ``.Q``, ``.Mx``, ``.My``, ``.share`` and, when the channel
    gives its focal lengths, ``"channels[i].f[t]"`` for each lens type t (from 0)."""
    out = ["F", "D"]
    for i, ch in enumerate(design.channels, 1):
        out += [f"channels[{i}].{n}" for n in DESIGN_CHANNEL_FIELDS]
        if ch.f is not None:
            out += [f"channels[{i}].f[{t}]" for t in range(len(ch.f))]
    return tuple(out)


def _design_path(design: Design, name: Any, where: str) -> tuple[str, bool]:
    """Check a free-field name of ``design``: (name, is a count). ``InvalidParameter``
    named ``where`` for a malformed name, a channel or lens type the design lacks."""
    if not isinstance(name, str):
        raise TypeError(f"{where} keys must be field names (str), got {type(name).__name__}")
    if name in ("F", "D"):
        return name, False
    allowed = ('"F", "D", "channels[i].NAME" (i from 1, NAME one of '
               f'{", ".join(DESIGN_CHANNEL_FIELDS)}) or "channels[i].f[t]" (t from 0)')
    m = _PATH.fullmatch(name)
    if m is None or (m[3] is not None and m[2] != "f") \
            or (m[3] is None and m[2] not in DESIGN_CHANNEL_FIELDS):
        raise InvalidParameter.of(where, name, allowed)
    i, n = int(m[1]), len(design.channels)
    if not 1 <= i <= n:
        raise InvalidParameter.of(where, name, f"a channel number in [1, {n}] (the design "
                                  f"has {n} channel{'s' if n > 1 else ''})")
    if m[3] is not None:
        f = design.channels[i - 1].f
        if f is None:
            raise InvalidParameter.of(where, name, f"channel {i}'s focal lengths are Ng's "
                                      "setting (f = None): give the base channel explicit "
                                      "focal lengths to vary them")
        t = int(m[3])
        if t >= len(f):
            raise InvalidParameter.of(where, name, f"a lens type in [0, {len(f) - 1}] "
                                      f"(channel {i} has {len(f)} lens types)")
    return name, m[2] in DESIGN_COUNT_FIELDS


def _with_changes(base: Mapping[str, Any], changes: Mapping[str, Any]) -> Design:
    """The Design of the plain dict ``base`` (:meth:`Design.as_dict`) with the free-field
    ``changes`` applied (names checked by :func:`_design_path`); the Design constructor
    validates it."""
    fields = {k: v for k, v in base.items() if k != "channels"}
    channels = [dict(c) for c in base["channels"]]
    for name, value in changes.items():
        m = _PATH.fullmatch(name)
        if m is None:
            fields[name] = value
            continue
        ch = channels[int(m[1]) - 1]
        if m[3] is None:
            ch[m[2]] = value
        else:
            f = list(ch["f"])
            f[int(m[3])] = value
            ch["f"] = f
    return Design(channels=tuple(Channel(**c) for c in channels), **fields)


def _real_option(value: Any, name: str, allowed: str, ok: Callable[[float], bool]) -> float:
    """A real option of the whole sweep: ``TypeError`` if not a real number,
    :class:`InvalidParameter` unless ``ok(x)`` (an integer beyond the float range is inf)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf if value > 0 else -math.inf
    if not ok(x):
        raise InvalidParameter.of(name, x, allowed)
    return x


def _threshold(value: Any) -> float:
    return _real_option(value, "threshold_px", "a finite number > 0 (pixels)",
                        lambda x: math.isfinite(x) and x > 0)


def _tol(value: Any) -> float:
    return _real_option(value, "tol", "a finite number >= 0 (a multiple of delta(z))",
                        lambda x: math.isfinite(x) and x >= 0)


def evaluate_design(camera: Camera | Design, depths, *,
                    threshold_px: float = DEFAULT_THRESHOLD_PX, tol: float = DEFAULT_TOL,
                    merits_2d: bool = False, window: float = DEFAULT_WINDOW,
                    n_threads: int | None = None) -> dict[str, float]:
    """Figures of merit of one design over ``depths``, computed by the core.

    - ``camera``: the :class:`~splitlf.Camera` (merits :data:`METRICS`) or a
      :class:`~splitlf.Design` (merits :func:`design_metrics`: per channel and union)
    - ``depths``: 1-D array-like of scene depths [mm], each finite and > F; [min, max] of
      them is the depth range of the sharp fractions
    - ``threshold_px``: sharpness threshold on the blur radius [pixels], finite > 0
    - ``tol``: merge tolerance of the sample positions [multiples of delta(z)], finite >= 0
      (in (0, 1] with ``merits_2d``: the 2-D distinct samples use it too)
    - ``merits_2d``: also compute the 2-D merits (:data:`METRICS_2D`;
      ``design_metrics(design, merits_2d=True)``): the worst and median covering radius
      and the median distinct 2-D samples of :func:`splitlf.coverage` over the depths.
      They cost far more than the others (a 2-D analysis per depth), so they are off by
      default and then absent from the result
    - ``window``: width of their central field in lens pitches of channel 1, finite > 0
      (default :data:`DEFAULT_WINDOW` = 16, as :func:`splitlf.coverage`; checked even when
      ``merits_2d`` is off)
    - ``n_threads``: threads of the core (None: all cores)

    Returns a dict {name in :data:`METRICS` (:func:`design_metrics` for a Design): value}.
    Raises ``TypeError`` for arguments of the wrong type and
    :class:`~splitlf.errors.InvalidParameter` (a ``ValueError``) for values out of range.
    """
    cam = _validate.camera_or_design(camera)
    z = _validate.depths(depths, "depths")
    thr, t = _threshold(threshold_px), _tol(tol)
    w = _options_2d(merits_2d, window, t)
    threads = _validate.n_threads(n_threads)
    if isinstance(cam, Design):
        values = _native.design_figures_of_merit(cam.core, z, thr, t, threads, w)
        return dict(zip(design_metrics(cam, w is not None), values, strict=True))
    values = _native.figures_of_merit(cam.core, z, thr, t, threads, w)
    names = METRICS + (METRICS_2D if w is not None else ())
    return dict(zip(names, values, strict=True))


def _evaluate_batch(base: dict[str, Any], batch: list[dict[str, Any]], depths: np.ndarray,
                    threshold_px: float, tol: float, window: float | None,
                    n_threads: int | None) -> list[tuple[list[float] | None, str]]:
    """Worker task: plain dicts in, plain lists out (picklable both ways). ``window``:
    that of the 2-D merits, None without them."""
    out: list[tuple[list[float] | None, str]] = []
    for changes in batch:
        try:
            cam = Camera(**{**base, **changes})
            values = _native.figures_of_merit(cam.core, depths, threshold_px, tol, n_threads,
                                              window)
        except (ValueError, TypeError) as e:
            out.append((None, str(e)))
            continue
        out.append((list(values), ""))
    return out


def _evaluate_design_batch(base: dict[str, Any], batch: list[dict[str, Any]],
                           depths: np.ndarray, threshold_px: float, tol: float,
                           window: float | None,
                           n_threads: int | None) -> list[tuple[list[float] | None, str]]:
    """Worker task of a Design base: plain dicts in (``base`` is :meth:`Design.as_dict`,
    each change maps a free-field name to a value), plain lists out."""
    out: list[tuple[list[float] | None, str]] = []
    for changes in batch:
        try:
            design = _with_changes(base, changes)
            values = _native.design_figures_of_merit(design.core, depths, threshold_px, tol,
                                                     n_threads, window)
        except (ValueError, TypeError) as e:
            out.append((None, str(e)))
            continue
        out.append((list(values), ""))
    return out


def _axis(name: str, values: Any, counts: Sequence[str] = COUNT_FIELDS) -> np.ndarray:
    """One grid axis as a 1-D numeric array; a count field whose values are all integral
    becomes an integer axis (``np.linspace(100, 300, 3)`` gives the counts 100, 200, 300).
    The name is checked by the caller."""
    arr = np.atleast_1d(np.asarray(values))
    if arr.ndim != 1 or arr.size == 0:
        raise InvalidParameter.of(f"grid[{name!r}]", f"an array of shape {arr.shape}",
                                  "a non-empty 1-D sequence of values")
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number)):
        raise TypeError(f"grid[{name!r}] must hold numbers, got dtype {arr.dtype}")
    if (name in counts and np.issubdtype(arr.dtype, np.floating)
            and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))
            and np.all(np.abs(arr) < 2.0**62)):
        arr = arr.astype(np.int64)
    return arr


def _grid(grid: Mapping[str, Any], design: Design | None = None
          ) -> tuple[dict[str, np.ndarray], frozenset[str]]:
    """The axes of the grid and the names among them that are counts (integers)."""
    if not isinstance(grid, Mapping) or not grid:
        raise TypeError("grid must be a non-empty mapping of field names to values")
    if design is None:
        for name in grid:
            if name not in FIELDS:
                raise InvalidParameter.of("grid", name,
                                          f"camera field names: {', '.join(FIELDS)}")
        counts = frozenset(n for n in grid if n in COUNT_FIELDS)
    else:
        counts = frozenset(n for n in grid if _design_path(design, n, "grid")[1])
    axes = {name: _axis(name, values, counts) for name, values in grid.items()}
    n = math.prod(a.size for a in axes.values())
    if n > MAX_DESIGNS:
        sizes = " x ".join(str(a.size) for a in axes.values())
        raise TooLargeError(f"the grid has {sizes} = {n} designs; the limit is {MAX_DESIGNS} "
                            "designs per sweep (splitlf.sweep.MAX_DESIGNS): split the sweep",
                            what="sweep grid", limit=MAX_DESIGNS)
    return axes, counts


def _depths(depths: Any, camera: Camera | Design,
            axes: Mapping[str, np.ndarray]) -> np.ndarray:
    """The depths of the whole sweep: 2..MAX_DEPTHS finite values, at least two distinct,
    and not all designs' F or more (a depth <= F of one design makes that design invalid;
    <= every design's F, the whole sweep)."""
    z = _validate.depths(depths, "depths")
    if z.size > MAX_DEPTHS:
        raise TooLargeError(f"{z.size} depths; the limit is {MAX_DEPTHS} depths per design "
                            "(splitlf.sweep.MAX_DEPTHS)", what="sweep depths",
                            limit=MAX_DEPTHS)
    bad = np.flatnonzero(~np.isfinite(z) | (z <= 0))
    if bad.size:
        i = int(bad[0])
        raise InvalidParameter.of("depths", float(z[i]), "finite depths > 0 mm", index=i)
    if z.size < 2 or z.min() == z.max():
        raise InvalidParameter.of("depths", f"{z.size} depth(s), {np.unique(z).size} distinct",
                                  "at least two distinct depths (mm)")
    f_min = float(np.min(axes["F"])) if "F" in axes else camera.F
    if z.min() <= f_min:
        raise InvalidParameter.of("depths", float(z.min()),
                                  f"depths > F for some design (smallest F = {f_min} mm)",
                                  index=int(np.argmin(z)))
    return z


def _design_value(name: str, value: Any, counts: Sequence[str] = COUNT_FIELDS) -> Any:
    """NumPy scalar -> Python scalar; an integral float of a count field -> int (a
    non-integral one stays a float, and that design is invalid)."""
    v = value.item() if isinstance(value, np.generic) else value
    if name in counts and isinstance(v, float) and math.isfinite(v) and v.is_integer():
        return int(v)
    return v


def _designs(axes: Mapping[str, np.ndarray],
             counts: Sequence[str] = COUNT_FIELDS) -> Iterator[dict[str, Any]]:
    """The designs of the full-factorial grid, last axis fastest, as field dicts."""
    names = list(axes)
    for combo in itertools.product(*axes.values()):
        yield {n: _design_value(n, v, counts) for n, v in zip(names, combo, strict=True)}


def _batches(designs: Iterator[dict[str, Any]], size: int) -> Iterator[list[dict[str, Any]]]:
    while batch := list(itertools.islice(designs, size)):
        yield batch


def _progress_bar(total: int, progress: bool | None):
    if progress is None:
        progress = total > 1 and sys.stderr.isatty()
    if not progress:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm(total=total, desc="splitlf sweep", unit="design")


def _batch_size(batch_size: Any, n_designs: int, executor: cf.Executor | None) -> int:
    """In-process: one design at a time (each call is parallel over depths). With an
    executor: at most 64 tasks, each a batch of designs, so a task is real work."""
    if batch_size is not None:
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
            raise InvalidParameter.of("batch_size", batch_size, "an integer >= 1 or None")
        return batch_size
    return 1 if executor is None else max(1, math.ceil(n_designs / 64))


Result = tuple[list[float] | None, str]


def _run(tasks: Iterator[list[dict[str, Any]]], args: tuple[Any, ...],
         executor: cf.Executor | None, n_threads: int | None, threads_per_task: int | None,
         results: list[Result | None], bar: Any, worker: Callable = _evaluate_batch) -> None:
    """Evaluate every task into ``results`` (in order): in-process on the core's pool of
    ``n_threads``, or on ``executor`` with ``threads_per_task`` each. ``args`` = (base
    fields, depths, threshold_px, tol, window of the 2-D merits or None); ``worker`` the
    batch function (Camera or Design)."""
    base, z, threshold_px, tol, window = args
    if executor is None:
        start = 0
        for task in tasks:
            part = worker(base, task, z, threshold_px, tol, window, n_threads)
            results[start:start + len(part)] = part
            start += len(part)
            if bar is not None:
                bar.update(len(part))
        return
    futures = {}
    start = 0
    for task in tasks:
        fut = executor.submit(worker, base, task, z, threshold_px, tol, window,
                              threads_per_task)
        futures[fut] = start
        start += len(task)
    for fut in cf.as_completed(futures):
        part = fut.result()
        s = futures[fut]
        results[s:s + len(part)] = part
        if bar is not None:
            bar.update(len(part))


def _dataset(xr, axes: Mapping[str, np.ndarray], results: list[Result | None],
             attrs: dict[str, Any], metric_names: Sequence[str] = METRICS,
             docs: Callable[[str], str] = _DOCS.__getitem__):
    """The ``xarray.Dataset`` of a sweep: one dimension per grid field."""
    names = list(axes)
    shape = tuple(a.size for a in axes.values())
    values = np.full((len(results), len(metric_names)), np.nan)
    reasons = np.empty(len(results), dtype=object)
    for i, r in enumerate(results):
        if r is None:
            raise RuntimeError(f"sweep: design {i} was never evaluated")
        metrics, reason = r
        if metrics is not None:
            values[i] = metrics
        reasons[i] = reason
    data = {m: (names, values[:, k].reshape(shape), {"description": docs(m)})
            for k, m in enumerate(metric_names)}
    data["valid"] = (names, (reasons == "").reshape(shape),
                     {"description": "the design passed validation"})
    data["reason"] = (names, reasons.astype(str).reshape(shape),
                      {"description": "why the design is invalid (empty when valid)"})
    return xr.Dataset(data, coords=dict(axes), attrs=attrs)


def sweep(camera: Camera | Design, grid: Mapping[str, Sequence[Any]], depths,
          executor: cf.Executor | None = None, progress: bool | None = None, *,
          threshold_px: float = DEFAULT_THRESHOLD_PX, tol: float = DEFAULT_TOL,
          merits_2d: bool = False, window: float = DEFAULT_WINDOW,
          n_threads: int | None = None, batch_size: int | None = None,
          threads_per_task: int = 1):
    """Figures of merit for every design of a full-factorial grid around ``camera``.

    - ``camera``: the base :class:`~splitlf.Camera` or :class:`~splitlf.Design`; each
      design changes the grid's fields (focal lengths left to Ng's setting keep tracking
      the geometry)
    - ``grid``: {field name: 1-D array-like of values}: camera fields for a Camera;
      for a Design its free-field names (:func:`design_fields`: ``"F"``, ``"D"``,
      ``"channels[2].L"``, ``"channels[1].f[0]"``, channels from 1, lens types from 0),
      each design built by the Design constructor; the counts (Q, Kx, Ky; a channel's
      Kx, Ky, Q, Mx, My) take integers or integral floats (``np.linspace(100, 300, 3)``);
      at most :data:`MAX_DESIGNS` designs in all
    - ``depths``: 1-D array-like of scene depths [mm], 2..:data:`MAX_DEPTHS` values, finite,
      > 0, at least two distinct; [min, max] is the depth range of the sharp fractions
    - ``executor``: any ``concurrent.futures.Executor`` (e.g. Dask's
      ``client.get_executor()``); None runs in-process on the core's pool of ``n_threads``
    - ``progress``: a tqdm bar; None = only when stderr is a terminal
    - ``threshold_px``: sharpness threshold [pixels], finite > 0; ``tol``: merge tolerance
      [delta(z)], finite >= 0 (in (0, 1] with ``merits_2d``)
    - ``merits_2d``, ``window``: also compute the 2-D merits (:data:`METRICS_2D`;
      ``design_metrics(design, merits_2d=True)``) with a central field ``window`` lens
      pitches of channel 1 wide, as :func:`evaluate_design`; off by default (they cost a
      2-D analysis per depth), and then absent from the dataset
    - ``batch_size``: designs per executor task (default: at most 64 tasks);
      ``threads_per_task``: core threads of each executor task

    Returns an ``xarray.Dataset`` (the ``sweep`` extra) with one dimension per grid field,
    the variables of :data:`METRICS` (:func:`design_metrics` for a Design), ``valid`` and
    ``reason`` (why a design is invalid;
    its metrics are NaN). An invalid design is a row, not an error; what concerns the whole
    sweep is one error before any work: ``TypeError`` (wrong types),
    :class:`~splitlf.errors.InvalidParameter` (threshold_px, tol, window, depths, grid,
    batch_size, n_threads out of range), :class:`~splitlf.errors.TooLargeError` (too many designs or
    depths), ``ImportError`` without xarray.
    """
    try:
        import xarray as xr
    except ImportError as e:
        raise ImportError('splitlf.sweep needs xarray: pip install "splitlf[sweep]"') from e
    cam = _validate.camera_or_design(camera)
    is_design = isinstance(cam, Design)
    axes, counts = _grid(grid, cam if is_design else None)
    z = _depths(depths, cam, axes)
    threshold_px, tol = _threshold(threshold_px), _tol(tol)
    window_2d = _options_2d(merits_2d, window, tol)
    n_threads = _validate.n_threads(n_threads)
    threads_per_task = _validate.n_threads(threads_per_task)
    n_designs = math.prod(a.size for a in axes.values())
    batch = _batch_size(batch_size, n_designs, executor)
    on_2d = window_2d is not None
    if is_design:
        args = (cam.as_dict(), z, threshold_px, tol, window_2d)
        worker: Callable = _evaluate_design_batch
        metrics, docs = design_metrics(cam, on_2d), _design_doc
    else:
        args = (cam.as_dict(resolved=False), z, threshold_px, tol, window_2d)
        worker, metrics, docs = _evaluate_batch, METRICS + (METRICS_2D if on_2d else ()), \
            _camera_doc
    results: list[Result | None] = [None] * n_designs
    bar = _progress_bar(n_designs, progress)
    try:
        _run(_batches(_designs(axes, counts), batch), args, executor, n_threads,
             threads_per_task, results, bar, worker)
    finally:
        if bar is not None:
            bar.close()
    attrs = {
        "depth_min_mm": float(z.min()),
        "depth_max_mm": float(z.max()),
        "n_depths": int(z.size),
        "threshold_px": threshold_px,
        "tol": tol,
        "merits_2d": int(on_2d),
    }
    if on_2d:
        attrs["window"] = window_2d
    attrs["base_design" if is_design else "base_camera"] = cam.to_toml()
    return _dataset(xr, axes, results, attrs, metrics, docs)
