"""A render split over an executor: each channel's raw rows cut into bands, one task per
band on any ``concurrent.futures.Executor`` (a thread or process pool, Dask's
``client.get_executor()``), the bands gathered into the raws (docs/render.md, "Scale-out
and datasets").

A raw row is computed on its own by either route of the core (``_native.render_band``),
so the assembled raws are bit for bit those of the in-process render. The caller draws
the scene (a random texture, from the render's seed) once and sends it to every task as
plain arrays with the design (pickled by its own ``__reduce__``: plain fields, as the
sweep's tasks carry designs; on Dask the scene is scattered to the workers once); the
noise is added by the caller once the raws are assembled, as in-process.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _native, _validate
from .._progress import Progress, Show, progress_bar
from ..errors import InvalidParameter, TooLargeError
from ..model.design import Design

__all__ = ["DEFAULT_TASKS", "ScenePart", "band_task", "bands", "check_options", "render_bands"]

#: Tasks a render is cut into by default (as :func:`splitlf.sweep.sweep`'s batches): enough
#: for up to ~16 workers to even out rows of unequal cost (vignetted rows, the near side of a
#: tilted plane, the sensor's edge), few enough that each task's fixed cost (the scene sent
#: to its worker, the exact route's per-column tables, the worker's start) stays small
#: against its rows.
DEFAULT_TASKS = 64

#: The core's scene as plain values: (texture kind, texture parameters, texture image or
#: None, surface kind, surface parameters, depth map or None, background), the arguments of
#: ``_native.RenderScene``.
ScenePart = tuple[str, list[float], Any, str, list[float], Any, float]
#: The core's error target: tol, or (photons, read noise, fraction) of the noise.
Tol = float | tuple[float, float, float]

Band = tuple[int, int, int]


def check_options(executor: Any, rows_per_task: Any, n_threads: int | None
                  ) -> tuple[cf.Executor | None, int | None, int | None]:
    """The executor (a ``concurrent.futures.Executor`` or None, else ``TypeError``), the
    rows per task (an integer >= 1, or None for the default; only with an executor, else
    :class:`~splitlf.errors.InvalidParameter`) and the core threads of each task (with an
    executor ``n_threads``, default 1, so that the workers do not oversubscribe)."""
    if executor is not None and not isinstance(executor, cf.Executor):
        raise TypeError("executor must be a concurrent.futures.Executor (a thread or process "
                        "pool, Dask's client.get_executor()) or None, got "
                        f"{type(executor).__name__}")
    if rows_per_task is not None:
        n = _validate.integer(rows_per_task, "rows_per_task", "an integer >= 1 or None")
        if n < 1:
            raise InvalidParameter.of("rows_per_task", n, "an integer >= 1 or None")
        if executor is None:
            raise InvalidParameter.of("rows_per_task", n, "None without an executor (the "
                                      "in-process render is not cut into tasks)")
        rows_per_task = n
    threads = n_threads if executor is None or n_threads is not None else 1
    return executor, rows_per_task, threads


def bands(shapes: Sequence[tuple[int, int]], rows_per_task: int | None) -> list[Band]:
    """The tasks of a render of raws of ``shapes``: (channel from 0, r0, r1), each channel's
    rows cut into bands of ``rows_per_task`` rows (the last one shorter; default: the
    total rows over :data:`DEFAULT_TASKS`, rounded up), channel 1 first."""
    total = sum(r for r, _ in shapes)
    per = rows_per_task or max(1, math.ceil(total / DEFAULT_TASKS))
    return [(c, r0, min(r0 + per, rows)) for c, (rows, _) in enumerate(shapes)
            for r0 in range(0, rows, per)]


def band_task(design: Design, scene: ScenePart, band: Band, tol: Tol,
              n_threads: int | None, falloff: str | None = None) -> np.ndarray:
    """Worker task: the raw rows [r0, r1) of channel c (from 0), ``band`` = (c, r0, r1),
    of the scene ``scene`` (:data:`ScenePart`) rendered by the core on ``n_threads``
    threads with ``falloff`` (render's, checked): plain values in, a float64 array of
    r1 - r0 rows out."""
    native = _native.RenderScene(*scene)
    return _native.render_band(design.core, native, band, tol=tol, n_threads=n_threads,
                               falloff=falloff)


def _shared(executor: cf.Executor, scene: ScenePart) -> Any:
    """The scene as the tasks carry it. On Dask (``client.get_executor()``, whose client
    is its ``_client``) it is scattered once to every worker and the tasks carry its
    Dask future, which each task receives as the scene itself: otherwise every task's
    graph would hold its own copy (64 tasks of a full raytrix-r12 scene's 114 MiB texture:
    7 GiB through the scheduler). Any other executor pickles it with every task."""
    client: Any = getattr(executor, "_client", None)
    if type(executor).__module__.startswith("distributed") and hasattr(client, "scatter"):
        return client.scatter([scene], broadcast=True)[0]
    return scene


def _gather(futures: dict[cf.Future, Band], images: list[np.ndarray],
            bar: Progress | None) -> None:
    """Each band's rows into its channel's raw as its task finishes; on any exception
    (Ctrl-C: ``KeyboardInterrupt`` while waiting, or a task's error) the tasks not yet
    started are cancelled and the exception goes on."""
    try:
        for fut in cf.as_completed(futures):
            c, r0, r1 = futures[fut]
            images[c][r0:r1] = fut.result()
            if bar is not None:
                bar.update(r1 - r0)
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise


def check_raws_fit(shapes: Sequence[tuple[int, int]], noun: str, what: str) -> None:
    """:class:`~splitlf.errors.TooLargeError` (``what``: the call) when float64 raws of
    ``shapes`` (``noun`` in the message) need more than the memory available."""
    nbytes = sum(8 * r * c for r, c in shapes)
    limit = _native.available_memory()
    if nbytes > limit:
        raise TooLargeError(f"{noun} need {nbytes / 2**30:.1f} GiB, more than the "
                            f"{limit / 2**30:.1f} GiB available", what=what,
                            nbytes=nbytes, limit=limit)


def render_bands(executor: cf.Executor, design: Design, shapes: list[tuple[int, int]],
                 scene: ScenePart, tol: Tol, n_threads: int | None,
                 rows_per_task: int | None, show: Show,
                 falloff: str | None = None) -> list[np.ndarray]:
    """Every channel's raw (of ``shapes``) of ``scene`` rendered as bands of rows
    (:func:`bands`) on ``executor``, each task on ``n_threads`` core threads, assembled in
    the caller: the raws of ``_native.render`` bit for bit (``falloff`` as render's,
    checked). Progress (``show``) in raw rows
    as tasks finish. Raises :class:`~splitlf.errors.TooLargeError` (the raws beyond the
    memory available), the first task's error and ``KeyboardInterrupt`` (tasks not started
    are cancelled; running ones finish their band)."""
    check_raws_fit(shapes, "the rendered raws", "render")
    images = [np.empty(s) for s in shapes]
    tasks = bands(shapes, rows_per_task)
    plain = design.design  # its general form, pickled as plain fields
    scene = _shared(executor, scene)
    bar, _ = progress_bar(show, "splitlf render", "row", sum(r for r, _ in shapes))
    try:
        futures = {}
        try:
            for band in tasks:
                task = executor.submit(band_task, plain, scene, band, tol, n_threads, falloff)
                futures[task] = band
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
        _gather(futures, images, bar)
    finally:
        if bar is not None:
            bar.close()
    return images
