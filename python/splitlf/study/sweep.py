"""Design-space sweeps: the merits of :func:`splitlf.evaluate` over a full-factorial grid
of designs around a base design.

In-process by default (the Rust thread pool parallelises each design over depths); with
any ``concurrent.futures.Executor`` — e.g. a Dask cluster's ``client.get_executor()`` —
designs are sent in batches of plain field dicts beside the base (pickled by its own
``__reduce__``: plain fields, no native object) and every
task runs the core with ``threads_per_task`` rayon threads so workers do not oversubscribe.
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import math
import numbers
import re
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _validate
from .._progress import Progress, progress_bar, progress_flag
from ..errors import InvalidParameter, TooLargeError
from ..model.design import Design
from ._options import options_2d, threshold_option, tol_option
from .merit import (
    DEFAULT_THRESHOLD_PX,
    DEFAULT_TOL,
    DEFAULT_WINDOW,
    IMAGE_PHOTONS,
    evaluate,
    image_option,
    merit_doc,
    merit_names,
)

__all__ = ["DEFAULT_THRESHOLD_PX", "DEFAULT_TOL", "DEFAULT_WINDOW", "MAX_DEPTHS", "MAX_DESIGNS",
           "design_fields", "merit_names", "sweep"]

#: Most designs one sweep evaluates (the product of the grid's sizes); a larger grid is
#: refused before any work. At ~1-10 ms per design this is hours of work already.
MAX_DESIGNS = 1_000_000
#: Most depths per design (each depth is a full sample analysis of the design).
MAX_DEPTHS = _validate.MAX_DEPTHS

#: Numeric channel fields a Design's grid or free fields may name (``channels[i].NAME``),
#: and the counts among them (integers).
DESIGN_CHANNEL_FIELDS = ("L", "d", "v", "mu", "Kx", "Ky", "Q", "Mx", "My", "share")
DESIGN_COUNT_FIELDS = ("Kx", "Ky", "Q", "Mx", "My")
_PATH = re.compile(r"channels\[(\d+)\]\.([A-Za-z]+)(?:\[(\d+)\])?")


def _top_fields(base: Design) -> dict[str, bool]:
    """The base's own numeric fields ({name: is a count}): the numbers of its
    ``as_dict()`` (a Design's ``F``, ``D``; a Camera's paper fields ``F``, ``D``, ``v1``,
    ``kappa``, ..., ``Q``, ``Kx``, ``Ky``, ``f1``, ``f2``), which its ``replace`` takes."""
    return {k: isinstance(v, int) for k, v in base.as_dict().items()
            if isinstance(v, numbers.Real) and not isinstance(v, bool)}


def _has_channels(base: Design) -> bool:
    """Whether the base's own fields hold its channels (a Design: ``channels[i].NAME``
    paths are tunable), or derive them from other fields (a Camera's halves)."""
    return "channels" in base.as_dict()


def design_fields(design: Design) -> tuple[str, ...]:
    """The numeric fields of ``design`` a sweep grid or ``optimise``'s ``free`` may name,
    the fields its own ``replace`` takes: for a :class:`~splitlf.Camera` its paper fields
    (``"F"``, ``"D"``, ``"v1"``, ``"kappa"``, ..., ``"f1"``, ``"f2"``); for a Design
    ``"F"``, ``"D"``, then for each channel i (from 1) ``"channels[i].L"``, ``.d``,
    ``.v``, ``.mu``, ``.Kx``, ``.Ky``, ``.Q``, ``.Mx``, ``.My``, ``.share`` and, when the
    channel gives its focal lengths, ``"channels[i].f[t]"`` for each lens type t (from
    0)."""
    out = list(_top_fields(_validate.design(design)))
    if _has_channels(design):
        for i, ch in enumerate(design.channels, 1):
            out += [f"channels[{i}].{n}" for n in DESIGN_CHANNEL_FIELDS]
            if ch.f is not None:
                out += [f"channels[{i}].f[{t}]" for t in range(len(ch.f))]
    return tuple(out)


def check_field(base: Design, name: Any, where: str) -> tuple[str, bool]:
    """Check a field name of ``base`` (:func:`design_fields`): (name, is a count).
    ``InvalidParameter`` named ``where`` for an unknown or malformed name, a channel or
    lens type the design lacks."""
    if not isinstance(name, str):
        raise TypeError(f"{where} keys must be field names (str), got {type(name).__name__}")
    top = _top_fields(base)
    if name in top:
        return name, top[name]
    if not _has_channels(base):
        raise InvalidParameter.of(where, name, f"field names: {', '.join(top)}")
    allowed = ('"F", "D", "channels[i].NAME" (i from 1, NAME one of '
               f'{", ".join(DESIGN_CHANNEL_FIELDS)}) or "channels[i].f[t]" (t from 0)')
    m = _PATH.fullmatch(name)
    if m is None or (m[3] is not None and m[2] != "f") \
            or (m[3] is None and m[2] not in DESIGN_CHANNEL_FIELDS):
        raise InvalidParameter.of(where, name, allowed)
    i, n = int(m[1]), len(base.channels)
    if not 1 <= i <= n:
        raise InvalidParameter.of(where, name, f"a channel number in [1, {n}] (the design "
                                  f"has {n} channel{'s' if n > 1 else ''})")
    if m[3] is not None:
        f = base.channels[i - 1].f
        if f is None:
            raise InvalidParameter.of(where, name, f"channel {i}'s focal lengths are Ng's "
                                      "setting (f = None): give the base channel explicit "
                                      "focal lengths to vary them")
        t = int(m[3])
        if t >= len(f):
            raise InvalidParameter.of(where, name, f"a lens type in [0, {len(f) - 1}] "
                                      f"(channel {i} has {len(f)} lens types)")
    return name, m[2] in DESIGN_COUNT_FIELDS


def with_changes(base: Design, changes: Mapping[str, Any]) -> Design:
    """``base`` with the field ``changes`` ({name of :func:`design_fields`: value})
    applied by its own ``replace`` (a Camera's paper fields, focal lengths left to Ng's
    setting tracking the geometry; a Design's channel paths as new channels), validated
    again by its constructor."""
    top: dict[str, Any] = {}
    channels: dict[int, dict[str, Any]] = {}
    for name, value in changes.items():
        m = _PATH.fullmatch(name)
        if m is None:
            top[name] = value
            continue
        i = int(m[1]) - 1
        ch = channels.setdefault(i, {})
        if m[3] is None:
            ch[m[2]] = value
        else:
            f = list(ch.get("f", base.channels[i].f or ()))
            f[int(m[3])] = value
            ch["f"] = tuple(f)
    if channels:
        top["channels"] = tuple(ch.replace(**channels[i]) if i in channels else ch
                                for i, ch in enumerate(base.channels))
    return base.replace(**top)


def evaluate_batch(base: Design, batch: list[dict[str, Any]], depths: np.ndarray,
                    threshold_px: float, tol: float, window: float | None,
                    n_threads: int | None,
                    image: tuple[tuple[str, ...], float] = ((), IMAGE_PHOTONS),
                    ) -> list[tuple[list[float] | None, str]]:
    """Worker task: the base (pickled by its own ``__reduce__``: plain fields, never a
    native handle) and plain change dicts in, plain lists of :func:`evaluate`'s values
    out; an invalid design is (None, why). ``window``: that of the 2-D merits, None
    without them; ``image``: the image merits' names and photons."""
    out: list[tuple[list[float] | None, str]] = []
    for changes in batch:
        try:
            design = with_changes(base, changes)
            m = evaluate(design, depths, threshold_px=threshold_px, tol=tol,
                         merits_2d=window is not None,
                         window=DEFAULT_WINDOW if window is None else window,
                         image=image[0], photons=image[1], n_threads=n_threads)
        except (ValueError, TypeError) as e:
            out.append((None, str(e)))
            continue
        out.append((list(m.values()), ""))
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


def _grid(grid: Mapping[str, Any], base: Design
          ) -> tuple[dict[str, np.ndarray], frozenset[str]]:
    """The axes of the grid and the names among them that are counts (integers)."""
    if not isinstance(grid, Mapping) or not grid:
        raise TypeError("grid must be a non-empty mapping of field names to values")
    counts = frozenset(n for n in grid if check_field(base, n, "grid")[1])
    axes = {name: _axis(name, values, counts) for name, values in grid.items()}
    n = math.prod(a.size for a in axes.values())
    if n > MAX_DESIGNS:
        sizes = " x ".join(str(a.size) for a in axes.values())
        raise TooLargeError(f"the grid has {sizes} = {n} designs; the limit is {MAX_DESIGNS} "
                            "designs per sweep (splitlf.sweep.MAX_DESIGNS): split the sweep",
                            what="sweep grid", limit=MAX_DESIGNS)
    return axes, counts


def _depths(depths: Any, camera: Design,
            axes: Mapping[str, np.ndarray]) -> np.ndarray:
    """The depths of the whole sweep: 2..MAX_DEPTHS finite values, at least two distinct,
    and not all designs' F or more (a depth <= F of one design makes that design invalid;
    <= every design's F, the whole sweep)."""
    z = _validate.depth_range(depths)
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


def _progress_bar(total: int, progress: bool | None) -> Progress | None:
    """The sweep's report (splitlf._progress; None: only for more than one design)."""
    show = progress_flag(progress) if progress is not None or total > 1 else ""
    return progress_bar(show, "splitlf sweep", "design", total)[0]


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
    ``n_threads``, or on ``executor`` with ``threads_per_task`` each. ``args`` = (the
    base design, depths, threshold_px, tol, window of the 2-D merits or None, the image
    merits' names and photons)."""
    base, z, threshold_px, tol, window, image = args
    if executor is None:
        start = 0
        for task in tasks:
            part = evaluate_batch(base, task, z, threshold_px, tol, window, n_threads, image)
            results[start:start + len(part)] = part
            start += len(part)
            if bar is not None:
                bar.update(len(part))
        return
    futures = {}
    start = 0
    for task in tasks:
        fut = executor.submit(evaluate_batch, base, task, z, threshold_px, tol, window,
                              threads_per_task, image)
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
    data = {m: (names, values[:, k].reshape(shape), {"description": merit_doc(m)})
            for k, m in enumerate(metric_names)}
    data["valid"] = (names, (reasons == "").reshape(shape),
                     {"description": "the design passed validation"})
    data["reason"] = (names, reasons.astype(str).reshape(shape),
                      {"description": "why the design is invalid (empty when valid)"})
    return xr.Dataset(data, coords=dict(axes), attrs=attrs)


def sweep(camera: Design, grid: Mapping[str, Sequence[Any]], depths: Any,
          executor: cf.Executor | None = None, progress: bool | None = None, *,
          threshold_px: float = DEFAULT_THRESHOLD_PX, tol: float = DEFAULT_TOL,
          merits_2d: bool = False, window: float = DEFAULT_WINDOW,
          image: Sequence[str] = (), photons: float = IMAGE_PHOTONS,
          n_threads: int | None = None, batch_size: int | None = None,
          threads_per_task: int = 1) -> Any:
    """Figures of merit for every design of a full-factorial grid around ``camera``.

    - ``camera``: the base :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one);
      each design of the grid is the base with the grid's fields changed by its own
      ``replace`` (focal lengths left to Ng's setting keep tracking the geometry)
    - ``grid``: {field name: 1-D array-like of values}, names of :func:`design_fields`:
      a Camera's paper fields (``"D"``, ``"kappa"``, ...); a Design's ``"F"``, ``"D"``,
      ``"channels[2].L"``, ``"channels[1].f[0]"`` (channels from 1, lens types from 0);
      the counts (Q, Kx, Ky; a channel's Kx, Ky, Q, Mx, My) take integers or integral
      floats (``np.linspace(100, 300, 3)``); at most :data:`MAX_DESIGNS` designs in all
    - ``depths``: 1-D array-like of scene depths [mm], 2..:data:`MAX_DEPTHS` values, finite,
      > 0, at least two distinct; [min, max] is the depth range of the sharp fractions
    - ``executor``: any ``concurrent.futures.Executor`` (e.g. Dask's
      ``client.get_executor()``); None runs in-process on the core's pool of ``n_threads``
    - ``progress``: a tqdm bar; None = for more than one design, a bar when stderr is a
      terminal, else sparse lines on stderr once the sweep has run 10 s
    - ``threshold_px``: sharpness threshold [pixels], finite > 0; ``tol``: merge tolerance
      [delta(z)], finite >= 0 (in (0, 1] with ``merits_2d``)
    - ``merits_2d``, ``window``: also compute the 2-D merits with a central field
      ``window`` lens pitches of channel 1 wide, as :func:`splitlf.evaluate`; off by
      default (they cost a 2-D analysis per depth), and then absent from the dataset
    - ``image``, ``photons``: image merits to compute per design (names of
      :func:`splitlf.merits.image_merit_names`, e.g. ``psnr_worst_union``) at ``photons``
      photo-electrons for white, as :func:`splitlf.evaluate` (seconds per design: they
      reconstruct a patch's ensemble at several depths)
    - ``batch_size``: designs per executor task (default: at most 64 tasks);
      ``threads_per_task``: core threads of each executor task

    Returns an ``xarray.Dataset`` (the ``sweep`` extra) with one dimension per grid field,
    one variable per merit of :func:`splitlf.evaluate` (:func:`merit_names`: per channel
    and union, e.g. ``max_gap_worst_union``; each with its ``description``), ``valid``
    and ``reason`` (why a design is invalid, e.g. a Camera's D = 40 mm whose microlens
    images overlap; its merits are NaN). An invalid design is a row, not an error; what
    concerns the whole
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
    threshold_px, tol = threshold_option(threshold_px), tol_option(tol)
    window_2d = options_2d(merits_2d, window, tol)
    image_names = image_option(cam, image)
    n_photons = _validate.positive(photons, "photons")
    n_threads = _validate.n_threads(n_threads)
    task_threads = _validate.n_threads(threads_per_task)
    n_designs = math.prod(a.size for a in axes.values())
    batch = _batch_size(batch_size, n_designs, executor)
    on_2d = window_2d is not None
    args = (cam, z, threshold_px, tol, window_2d, (image_names, n_photons))
    results: list[Result | None] = [None] * n_designs
    bar = _progress_bar(n_designs, progress)
    try:
        _run(_batches(_designs(axes, counts), batch), args, executor, n_threads,
             task_threads, results, bar)
    finally:
        if bar is not None:
            bar.close()
    attrs: dict[str, Any] = {
        "depth_min_mm": float(z.min()),
        "depth_max_mm": float(z.max()),
        "n_depths": int(z.size),
        "threshold_px": threshold_px,
        "tol": tol,
        "merits_2d": int(on_2d),
    }
    if on_2d:
        attrs["window"] = window_2d
    if image_names:
        attrs["image_photons"] = n_photons
    # the base's own TOML: a [design] (channels of its own) or a [camera] (paper fields)
    attrs["base_design" if _has_channels(cam) else "base_camera"] = cam.to_toml()
    return _dataset(xr, axes, results, attrs, merit_names(cam, on_2d, image=image_names))
