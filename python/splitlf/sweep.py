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
import sys
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from . import _validate
from .design import Design
from .errors import InvalidParameter, TooLargeError
from .merits import (
    DEFAULT_THRESHOLD_PX,
    DEFAULT_TOL,
    DEFAULT_WINDOW,
    Options,
    core_merits,
    describe,
    metrics,
    options,
)

__all__ = ["DEFAULT_THRESHOLD_PX", "DEFAULT_TOL", "DEFAULT_WINDOW", "MAX_DEPTHS", "MAX_DESIGNS",
           "sweep"]

#: Most designs one sweep evaluates (the product of the grid's sizes); a larger grid is
#: refused before any work. At ~1-10 ms per design this is hours of work already.
MAX_DESIGNS = 1_000_000
#: Most depths per design (each depth is a full sample analysis of the design).
MAX_DEPTHS = 100_000
def _evaluate_batch(base: Design, batch: list[dict[str, Any]], depths: np.ndarray,
                    opts: Options, n_threads: int | None) -> list[tuple[list[float] | None, str]]:
    """Worker task: the base design (it pickles as its fields, never a native object) and
    plain dicts of tunable-field changes in, plain lists out. An invalid design is a row
    with its reason, not an error."""
    out: list[tuple[list[float] | None, str]] = []
    for changes in batch:
        try:
            values = core_merits(base.with_fields(changes), depths, opts, n_threads)
        except (ValueError, TypeError) as e:
            out.append((None, str(e)))
            continue
        out.append((values, ""))
    return out


def _axis(name: str, values: Any, counts: frozenset[str]) -> np.ndarray:
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


def _grid(grid: Mapping[str, Any], design: Design
          ) -> tuple[dict[str, np.ndarray], frozenset[str]]:
    """The axes of the grid and the names among them that are counts (integers)."""
    if not isinstance(grid, Mapping) or not grid:
        raise TypeError("grid must be a non-empty mapping of field names to values")
    counts = frozenset(n for n in grid if design.field_is_count(n, "grid"))
    axes = {name: _axis(name, values, counts) for name, values in grid.items()}
    n = math.prod(a.size for a in axes.values())
    if n > MAX_DESIGNS:
        sizes = " x ".join(str(a.size) for a in axes.values())
        raise TooLargeError(f"the grid has {sizes} = {n} designs; the limit is {MAX_DESIGNS} "
                            "designs per sweep (splitlf.sweep.MAX_DESIGNS): split the sweep",
                            what="sweep grid", limit=MAX_DESIGNS)
    return axes, counts


def _depths(depths: Any, camera: Design, axes: Mapping[str, np.ndarray]) -> np.ndarray:
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


def _design_value(name: str, value: Any, counts: frozenset[str]) -> Any:
    """NumPy scalar -> Python scalar; an integral float of a count field -> int (a
    non-integral one stays a float, and that design is invalid)."""
    v = value.item() if isinstance(value, np.generic) else value
    if name in counts and isinstance(v, float) and math.isfinite(v) and v.is_integer():
        return int(v)
    return v


def _designs(axes: Mapping[str, np.ndarray],
             counts: frozenset[str]) -> Iterator[dict[str, Any]]:
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


def _run(tasks: Iterator[list[dict[str, Any]]], args: tuple[Design, np.ndarray, Options],
         executor: cf.Executor | None, n_threads: int | None, threads_per_task: int | None,
         results: list[Result | None], bar: Any) -> None:
    """Evaluate every task into ``results`` (in order): in-process on the core's pool of
    ``n_threads``, or on ``executor`` with ``threads_per_task`` each. ``args`` = (the base
    design, depths, the checked options of the figures of merit)."""
    base, z, opts = args
    if executor is None:
        start = 0
        for task in tasks:
            part = _evaluate_batch(base, task, z, opts, n_threads)
            results[start:start + len(part)] = part
            start += len(part)
            if bar is not None:
                bar.update(len(part))
        return
    futures = {}
    start = 0
    for task in tasks:
        fut = executor.submit(_evaluate_batch, base, task, z, opts, threads_per_task)
        futures[fut] = start
        start += len(task)
    for fut in cf.as_completed(futures):
        part = fut.result()
        s = futures[fut]
        results[s:s + len(part)] = part
        if bar is not None:
            bar.update(len(part))


def _dataset(xr: Any, axes: Mapping[str, np.ndarray], results: list[Result | None],
             attrs: dict[str, Any], metric_names: Sequence[str]) -> Any:
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
    data = {m: (names, values[:, k].reshape(shape), {"description": describe(m)})
            for k, m in enumerate(metric_names)}
    data["valid"] = (names, (reasons == "").reshape(shape),
                     {"description": "the design passed validation"})
    data["reason"] = (names, reasons.astype(str).reshape(shape),
                      {"description": "why the design is invalid (empty when valid)"})
    return xr.Dataset(data, coords=dict(axes), attrs=attrs)


def sweep(camera: Design, grid: Mapping[str, Sequence[Any]], depths,
          executor: cf.Executor | None = None, progress: bool | None = None, *,
          threshold_px: float = DEFAULT_THRESHOLD_PX, tol: float = DEFAULT_TOL,
          merits_2d: bool = False, window: float = DEFAULT_WINDOW,
          n_threads: int | None = None, batch_size: int | None = None,
          threads_per_task: int = 1):
    """Figures of merit for every design of a full-factorial grid around ``camera``.

    - ``camera``: the base :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one);
      each design changes the grid's fields (``base.with_fields(changes)``; a Camera's
      focal lengths left to Ng's setting keep tracking the geometry)
    - ``grid``: {field name: 1-D array-like of values}: the base's tunable fields
      (:meth:`~splitlf.Design.tunable_fields`: a Camera's own fields; for a Design
      ``"F"``, ``"D"``, ``"channels[2].L"``, ``"channels[1].f[0]"``, channels from 1, lens
      types from 0), each design built and validated by its constructor; the counts
      (Q, Kx, Ky; a channel's
      Kx, Ky, Q, Mx, My) take integers or integral floats (``np.linspace(100, 300, 3)``);
      at most :data:`MAX_DESIGNS` designs in all
    - ``depths``: 1-D array-like of scene depths [mm], 2..:data:`MAX_DEPTHS` values, finite,
      > 0, at least two distinct; [min, max] is the depth range of the sharp fractions
    - ``executor``: any ``concurrent.futures.Executor`` (e.g. Dask's
      ``client.get_executor()``); None runs in-process on the core's pool of ``n_threads``
    - ``progress``: a tqdm bar; None = only when stderr is a terminal
    - ``threshold_px``: sharpness threshold [pixels], finite > 0; ``tol``: merge tolerance
      [delta(z)], finite >= 0 (in (0, 1] with ``merits_2d``)
    - ``merits_2d``, ``window``: also compute the 2-D merits
      (``splitlf.metrics(design, merits_2d=True)``) with a central field ``window`` lens
      pitches of channel 1 wide, as :func:`splitlf.evaluate`; off by default (they cost a
      2-D analysis per depth), and then absent from the dataset
    - ``batch_size``: designs per executor task (default: at most 64 tasks);
      ``threads_per_task``: core threads of each executor task

    Returns an ``xarray.Dataset`` (the ``sweep`` extra) with one dimension per grid field,
    the variables of :func:`splitlf.metrics` of the base, ``valid`` and ``reason`` (why a
    design is invalid; its metrics are NaN), and in ``attrs["base"]`` the base's TOML.
    An invalid design is a row, not an error; what concerns the whole
    sweep is one error before any work: ``TypeError`` (wrong types),
    :class:`~splitlf.errors.InvalidParameter` (threshold_px, tol, window, depths, grid,
    batch_size, n_threads out of range), :class:`~splitlf.errors.TooLargeError` (too many designs or
    depths), ``ImportError`` without xarray.
    """
    try:
        import xarray as xr
    except ImportError as e:
        raise ImportError('splitlf.sweep needs xarray: pip install "splitlf[sweep]"') from e
    cam = _validate.design(camera, "camera")
    axes, counts = _grid(grid, cam)
    z = _depths(depths, cam, axes)
    opts = options(threshold_px, tol, merits_2d, window)
    n_threads = _validate.n_threads(n_threads)
    threads_per_task = _validate.n_threads(threads_per_task)
    n_designs = math.prod(a.size for a in axes.values())
    batch = _batch_size(batch_size, n_designs, executor)
    on_2d = opts[2] is not None
    results: list[Result | None] = [None] * n_designs
    bar = _progress_bar(n_designs, progress)
    try:
        _run(_batches(_designs(axes, counts), batch), (cam, z, opts), executor, n_threads,
             threads_per_task, results, bar)
    finally:
        if bar is not None:
            bar.close()
    attrs = {
        "depth_min_mm": float(z.min()),
        "depth_max_mm": float(z.max()),
        "n_depths": int(z.size),
        "threshold_px": opts[0],
        "tol": opts[1],
        "merits_2d": int(on_2d),
    }
    if on_2d:
        attrs["window"] = opts[2]
    attrs["base"] = cam.to_toml()  # as its own class writes it: [camera] or [design] TOML
    return _dataset(xr, axes, results, attrs, metrics(cam, on_2d))
