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
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from . import _native, _validate
from .camera import FIELDS, Camera

__all__ = ["METRICS", "sweep", "evaluate_design"]

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


def evaluate_design(camera: Camera, depths, *, threshold_px: float = 0.5, tol: float = 1e-6,
                    n_threads: int | None = None) -> dict[str, float]:
    """Figures of merit of one design over ``depths`` (mm), computed by the core."""
    cam = _validate.camera(camera)
    z = _validate.depths(depths, "depths")
    values = _native.figures_of_merit(cam.core, z, float(threshold_px), float(tol),
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


def _grid(grid: Mapping[str, Any]) -> dict[str, np.ndarray]:
    if not isinstance(grid, Mapping) or not grid:
        raise TypeError("grid must be a non-empty mapping of camera field names to values")
    out = {}
    for name, values in grid.items():
        if name not in FIELDS:
            raise ValueError(f"unknown grid field {name!r}; allowed fields: {', '.join(FIELDS)}")
        arr = np.atleast_1d(np.asarray(values))
        if arr.ndim != 1 or arr.size == 0:
            raise ValueError(f"grid[{name!r}] must be a non-empty 1-D sequence of values")
        if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number)):
            raise TypeError(f"grid[{name!r}] must hold numbers, got dtype {arr.dtype}")
        out[name] = arr
    return out


def _py(value: Any) -> Any:
    """NumPy scalar -> Python scalar (ints stay ints, so counts validate as counts)."""
    return value.item() if isinstance(value, np.generic) else value


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


def sweep(camera: Camera, grid: Mapping[str, Sequence[Any]], depths,
          executor: cf.Executor | None = None, progress: bool | None = None, *,
          threshold_px: float = 0.5, tol: float = 1e-6, n_threads: int | None = None,
          batch_size: int | None = None, threads_per_task: int = 1):
    """Figures of merit for every design of a full-factorial grid around ``camera``.

    ``grid`` maps camera field names to 1-D arrays of values; ``depths`` (mm) are the
    scene depths the samples are analysed at, and [min, max] of them is the depth range of
    the sharp fractions. Returns an ``xarray.Dataset`` (the ``sweep`` extra) with one
    dimension per grid field, the variables of :data:`METRICS`, ``valid`` and ``reason``
    (why a design is invalid; its metrics are NaN). ``executor``: any
    ``concurrent.futures.Executor``; None runs in-process on the Rust pool of ``n_threads``.
    ``progress``: a tqdm bar; None = only when stderr is a terminal.
    """
    try:
        import xarray as xr
    except ImportError as e:
        raise ImportError('splitlf.sweep needs xarray: pip install "splitlf[sweep]"') from e
    cam = _validate.camera(camera)
    axes = _grid(grid)
    z = _validate.depths(depths, "depths")
    if z.size < 2 or not np.all(np.isfinite(z)) or z.min() <= 0 or z.min() == z.max():
        raise ValueError("depths must hold at least two distinct finite depths > 0 mm")
    threshold_px = _validate.real(threshold_px, "threshold_px")
    tol = _validate.real(tol, "tol")
    n_threads = _validate.n_threads(n_threads)
    threads_per_task = _validate.n_threads(threads_per_task)
    names = list(axes)
    designs = [dict(zip(names, map(_py, combo), strict=True))
               for combo in itertools.product(*axes.values())]
    base = cam.as_dict(resolved=False)
    if batch_size is not None and (
        isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1
    ):
        raise ValueError(f"invalid batch_size = {batch_size!r}: allowed an integer >= 1")
    # In-process: one design at a time (each call is parallel over depths). With an
    # executor: at most 64 tasks, each a batch of designs, so a task is real work.
    default = 1 if executor is None else max(1, math.ceil(len(designs) / 64))
    batch = batch_size or default
    tasks = [designs[i:i + batch] for i in range(0, len(designs), batch)]

    results: list[tuple[list[float] | None, str] | None] = [None] * len(designs)
    bar = _progress_bar(len(designs), progress)
    try:
        if executor is None:
            start = 0
            for task in tasks:
                part = _evaluate_batch(base, task, z, threshold_px, tol, n_threads)
                results[start:start + len(part)] = part
                start += len(part)
                if bar is not None:
                    bar.update(len(part))
        else:
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
    finally:
        if bar is not None:
            bar.close()

    shape = tuple(a.size for a in axes.values())
    values = np.full((len(designs), len(METRICS)), np.nan)
    reasons = np.empty(len(designs), dtype=object)
    for i, r in enumerate(results):
        assert r is not None
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
    coords = {n: a for n, a in axes.items()}
    attrs = {
        "depth_min_mm": float(z.min()),
        "depth_max_mm": float(z.max()),
        "n_depths": int(z.size),
        "threshold_px": threshold_px,
        "tol": tol,
        "base_camera": cam.to_toml(),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)
