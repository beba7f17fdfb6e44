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
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from . import _native, _validate
from .camera import COUNT_FIELDS, FIELDS, Camera
from .errors import InvalidParameter, TooLargeError

__all__ = ["DEFAULT_THRESHOLD_PX", "DEFAULT_TOL", "MAX_DEPTHS", "MAX_DESIGNS", "METRICS",
           "evaluate_design", "sweep"]

#: Most designs one sweep evaluates (the product of the grid's sizes); a larger grid is
#: refused before any work. At ~1-10 ms per design this is hours of work already.
MAX_DESIGNS = 1_000_000
#: Most depths per design (each depth is a full sample analysis of the design).
MAX_DEPTHS = 100_000
#: Default sharpness threshold on the blur radius [px] and merge tolerance [delta(z)].
DEFAULT_THRESHOLD_PX = _native.DEFAULT_THRESHOLD_PX
DEFAULT_TOL = _native.DEFAULT_TOL

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


def evaluate_design(camera: Camera, depths, *, threshold_px: float = DEFAULT_THRESHOLD_PX,
                    tol: float = DEFAULT_TOL, n_threads: int | None = None) -> dict[str, float]:
    """Figures of merit of one design over ``depths``, computed by the core.

    - ``camera``: the :class:`~splitlf.Camera`
    - ``depths``: 1-D array-like of scene depths [mm], each finite and > F; [min, max] of
      them is the depth range of the sharp fractions
    - ``threshold_px``: sharpness threshold on the blur radius [pixels], finite > 0
    - ``tol``: merge tolerance of the sample positions [multiples of delta(z)], finite >= 0
    - ``n_threads``: threads of the core (None: all cores)

    Returns a dict {name in :data:`METRICS`: value}. Raises ``TypeError`` for arguments of
    the wrong type and :class:`~splitlf.errors.InvalidParameter` (a ``ValueError``) for
    values out of range.
    """
    cam = _validate.camera(camera)
    z = _validate.depths(depths, "depths")
    values = _native.figures_of_merit(cam.core, z, _threshold(threshold_px), _tol(tol),
                                      _validate.n_threads(n_threads))
    return dict(zip(METRICS, values, strict=True))


def _evaluate_batch(base: dict[str, Any], batch: list[dict[str, Any]], depths: np.ndarray,
                    threshold_px: float, tol: float,
                    n_threads: int | None) -> list[tuple[list[float] | None, str]]:
    """Worker task: plain dicts in, plain lists out (picklable both ways)."""
    out: list[tuple[list[float] | None, str]] = []
    for changes in batch:
        try:
            cam = Camera(**{**base, **changes})
            values = _native.figures_of_merit(cam.core, depths, threshold_px, tol, n_threads)
        except (ValueError, TypeError) as e:
            out.append((None, str(e)))
            continue
        out.append((list(values), ""))
    return out


def _axis(name: str, values: Any) -> np.ndarray:
    """One grid axis as a 1-D numeric array; a count field whose values are all integral
    becomes an integer axis (``np.linspace(100, 300, 3)`` gives the counts 100, 200, 300)."""
    if name not in FIELDS:
        raise InvalidParameter.of("grid", name, f"camera field names: {', '.join(FIELDS)}")
    arr = np.atleast_1d(np.asarray(values))
    if arr.ndim != 1 or arr.size == 0:
        raise InvalidParameter.of(f"grid[{name!r}]", f"an array of shape {arr.shape}",
                                  "a non-empty 1-D sequence of values")
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number)):
        raise TypeError(f"grid[{name!r}] must hold numbers, got dtype {arr.dtype}")
    if (name in COUNT_FIELDS and np.issubdtype(arr.dtype, np.floating)
            and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))
            and np.all(np.abs(arr) < 2.0**62)):
        arr = arr.astype(np.int64)
    return arr


def _grid(grid: Mapping[str, Any]) -> dict[str, np.ndarray]:
    if not isinstance(grid, Mapping) or not grid:
        raise TypeError("grid must be a non-empty mapping of camera field names to values")
    axes = {name: _axis(name, values) for name, values in grid.items()}
    n = math.prod(a.size for a in axes.values())
    if n > MAX_DESIGNS:
        sizes = " x ".join(str(a.size) for a in axes.values())
        raise TooLargeError(f"the grid has {sizes} = {n} designs; the limit is {MAX_DESIGNS} "
                            "designs per sweep (splitlf.sweep.MAX_DESIGNS): split the sweep",
                            what="sweep grid", limit=MAX_DESIGNS)
    return axes


def _depths(depths: Any, camera: Camera, axes: Mapping[str, np.ndarray]) -> np.ndarray:
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


def _design_value(name: str, value: Any) -> Any:
    """NumPy scalar -> Python scalar; an integral float of a count field -> int (a
    non-integral one stays a float, and that design is invalid)."""
    v = value.item() if isinstance(value, np.generic) else value
    if name in COUNT_FIELDS and isinstance(v, float) and math.isfinite(v) and v.is_integer():
        return int(v)
    return v


def _designs(axes: Mapping[str, np.ndarray]) -> Iterator[dict[str, Any]]:
    """The designs of the full-factorial grid, last axis fastest, as field dicts."""
    names = list(axes)
    for combo in itertools.product(*axes.values()):
        yield {n: _design_value(n, v) for n, v in zip(names, combo, strict=True)}


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
         results: list[Result | None], bar: Any) -> None:
    """Evaluate every task into ``results`` (in order): in-process on the core's pool of
    ``n_threads``, or on ``executor`` with ``threads_per_task`` each. ``args`` = (base
    fields, depths, threshold_px, tol)."""
    base, z, threshold_px, tol = args
    if executor is None:
        start = 0
        for task in tasks:
            part = _evaluate_batch(base, task, z, threshold_px, tol, n_threads)
            results[start:start + len(part)] = part
            start += len(part)
            if bar is not None:
                bar.update(len(part))
        return
    futures = {}
    start = 0
    for task in tasks:
        fut = executor.submit(_evaluate_batch, base, task, z, threshold_px, tol,
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
             attrs: dict[str, Any]):
    """The ``xarray.Dataset`` of a sweep: one dimension per grid field."""
    names = list(axes)
    shape = tuple(a.size for a in axes.values())
    values = np.full((len(results), len(METRICS)), np.nan)
    reasons = np.empty(len(results), dtype=object)
    for i, r in enumerate(results):
        if r is None:
            raise RuntimeError(f"sweep: design {i} was never evaluated")
        metrics, reason = r
        if metrics is not None:
            values[i] = metrics
        reasons[i] = reason
    data = {m: (names, values[:, k].reshape(shape), {"description": _DOCS[m]})
            for k, m in enumerate(METRICS)}
    data["valid"] = (names, (reasons == "").reshape(shape),
                     {"description": "the design passed validation"})
    data["reason"] = (names, reasons.astype(str).reshape(shape),
                      {"description": "why the design is invalid (empty when valid)"})
    return xr.Dataset(data, coords=dict(axes), attrs=attrs)


def sweep(camera: Camera, grid: Mapping[str, Sequence[Any]], depths,
          executor: cf.Executor | None = None, progress: bool | None = None, *,
          threshold_px: float = DEFAULT_THRESHOLD_PX, tol: float = DEFAULT_TOL,
          n_threads: int | None = None, batch_size: int | None = None,
          threads_per_task: int = 1):
    """Figures of merit for every design of a full-factorial grid around ``camera``.

    - ``camera``: the base :class:`~splitlf.Camera`; each design changes the grid's fields
      (focal lengths left to Ng's setting keep tracking the geometry)
    - ``grid``: {camera field name: 1-D array-like of values}; the counts Q, Kx, Ky take
      integers or integral floats (``np.linspace(100, 300, 3)``); at most
      :data:`MAX_DESIGNS` designs in all
    - ``depths``: 1-D array-like of scene depths [mm], 2..:data:`MAX_DEPTHS` values, finite,
      > 0, at least two distinct; [min, max] is the depth range of the sharp fractions
    - ``executor``: any ``concurrent.futures.Executor`` (e.g. Dask's
      ``client.get_executor()``); None runs in-process on the core's pool of ``n_threads``
    - ``progress``: a tqdm bar; None = only when stderr is a terminal
    - ``threshold_px``: sharpness threshold [pixels], finite > 0; ``tol``: merge tolerance
      [delta(z)], finite >= 0
    - ``batch_size``: designs per executor task (default: at most 64 tasks);
      ``threads_per_task``: core threads of each executor task

    Returns an ``xarray.Dataset`` (the ``sweep`` extra) with one dimension per grid field,
    the variables of :data:`METRICS`, ``valid`` and ``reason`` (why a design is invalid;
    its metrics are NaN). An invalid design is a row, not an error; what concerns the whole
    sweep is one error before any work: ``TypeError`` (wrong types),
    :class:`~splitlf.errors.InvalidParameter` (threshold_px, tol, depths, grid, batch_size,
    n_threads out of range), :class:`~splitlf.errors.TooLargeError` (too many designs or
    depths), ``ImportError`` without xarray.
    """
    try:
        import xarray as xr
    except ImportError as e:
        raise ImportError('splitlf.sweep needs xarray: pip install "splitlf[sweep]"') from e
    cam = _validate.camera(camera)
    axes = _grid(grid)
    z = _depths(depths, cam, axes)
    threshold_px, tol = _threshold(threshold_px), _tol(tol)
    n_threads = _validate.n_threads(n_threads)
    threads_per_task = _validate.n_threads(threads_per_task)
    n_designs = math.prod(a.size for a in axes.values())
    batch = _batch_size(batch_size, n_designs, executor)
    args = (cam.as_dict(resolved=False), z, threshold_px, tol)
    results: list[Result | None] = [None] * n_designs
    bar = _progress_bar(n_designs, progress)
    try:
        _run(_batches(_designs(axes), batch), args, executor, n_threads, threads_per_task,
             results, bar)
    finally:
        if bar is not None:
            bar.close()
    attrs = {
        "depth_min_mm": float(z.min()),
        "depth_max_mm": float(z.max()),
        "n_depths": int(z.size),
        "threshold_px": threshold_px,
        "tol": tol,
        "base_camera": cam.to_toml(),
    }
    return _dataset(xr, axes, results, attrs)
