"""Depth from the raw (docs/model.md §11, docs/depth.md).

:func:`estimate_depth` checks its arguments and makes one call of the core
(``_native.estimate_depth``, rust/core/src/inverse/depth/: the default region and grid,
the whites and the plane sweep): at each candidate depth every lens's micro-image (its
pixels' values divided by their whites, the design's raw under a white albedo, rendered
once per design and kept; on a sensor layout the pixels that take light through a
neighbouring lens as well are left out) is resampled at the centres of a grid of cells,
where its pixels' mean rays meet the plane at that depth; the cost is the spread of the
lenses' values within each cell, pooled over a window of cells, per channel (at the true
depth the lenses that see a cell saw the same patch). Each channel's least cost per cell,
refined by a V-fit, is its depth; the contrast of its cost curve is its confidence, and
each cell takes the most confident channel's depth.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .. import _native, _validate
from .._progress import progress_bar as _progress
from .._progress import progress_flag as _progress_flag
from .._validate import channels as _channels
from .._validate import extent as _extent
from ..errors import InvalidParameter
from ..imaging.render import DepthMap, Raw, Scene, render
from ..imaging.render import native_scene as _native_scene
from ..imaging.texture import Sinusoid
from ..model.design import Design

Extent = tuple[float, float, float, float]

#: Candidates of a (zmin, zmax) range, uniform in 1/z.
DEFAULT_CANDIDATES = 64
#: The default window radius (cells): costs are pooled over (2 r + 1)^2 cells.
DEFAULT_WINDOW = 6
#: The default grid pitch, in delta(z) (docs/model.md §9) at the reference depth.
DEFAULT_STEP: float = _native.DEPTH_DEFAULT_STEP
#: Cells whose confidence (the least of the cost curve's contrast and resolution,
#: docs/depth.md step 6) is at least this are confident.
DEFAULT_MIN_CONFIDENCE = 0.5
#: On a sensor layout the sweep keeps a pixel only when at least this share of its white
#: comes through its own lens: the rest also see a neighbouring lens's footprint, far away
#: on the scene, and their value is a blend of the two (docs/depth.md, step 1).
MIN_OWN_SHARE = 0.99
#: Most candidate depths (each is a pass over every lens).
MAX_CANDIDATES: int = _native.DEPTH_MAX_CANDIDATES
#: Largest window radius, in cells.
MAX_WINDOW: int = _native.DEPTH_MAX_WINDOW

_WHITES: dict[int, tuple[Design, tuple[np.ndarray, ...]]] = {}


@dataclasses.dataclass(frozen=True, eq=False)
class DepthSweep:
    """What the plane sweep saw, per cell of the estimate's grid (row 0 at the top):
    ``candidates`` (mm, increasing), ``index`` (the refined candidate index, fractional;
    NaN where no candidate had a cost), ``min_cost`` and ``mean_cost`` (the cost curve's
    least and mean value, relative to the spread of all the channel's lens values at each
    depth; NaN where none), ``channel`` (the channel, numbered from 1, whose curve gave the
    estimate: the most confident), ``estimate`` (the refined depth before the unconfident
    cells were filled; NaN where none), ``window`` (radius, cells), ``channels`` (numbered
    from 1) and ``samples`` (pixels of the lenses that took part)."""

    candidates: np.ndarray
    index: np.ndarray
    min_cost: np.ndarray
    mean_cost: np.ndarray
    channel: np.ndarray
    estimate: np.ndarray
    window: int
    channels: tuple[int, ...]
    samples: int


def _white_scene(design: Design) -> Scene:
    """The white scene: albedo 1 everywhere, on a fronto-parallel plane well in front of
    the lens (any depth gives the same raws)."""
    return Scene(Sinusoid(1.0, 1.0, 0.0), 2.0 * design.F + 1000.0, background=1.0)


def _white(design: Design) -> tuple[np.ndarray, ...]:
    """The design's raws under a white albedo (depth-independent: every ray a pixel
    collects meets a fronto-parallel plane), rendered once per design."""
    hit = _WHITES.get(id(design))
    if hit is not None and hit[0] is design:
        return hit[1]
    raw = render(design, _white_scene(design), progress=False)
    if len(_WHITES) >= 4:
        _WHITES.pop(next(iter(_WHITES)))
    _WHITES[id(design)] = (design, raw.images)
    return raw.images


def _own_lens_whites(design: Design) -> tuple[np.ndarray, ...]:
    """The raws of :func:`_white`'s scene with each pixel's own lens alone (the core's
    own-lens render: on a sensor layout, without the light its neighbours' lenses send
    it). Not kept."""
    native = _native_scene(_white_scene(design), design, np.random.default_rng(0))
    return tuple(_native.render(design.core, native, own_lens=True))


def _sweep_whites(design: Design) -> tuple[np.ndarray, ...]:
    """The whites the sweep takes, as the core makes them for :func:`estimate_depth`
    (``_native.depth_whites``): :func:`_white`, with 0 (not valid) for the pixels of a
    sensor-layout channel that take less than :data:`MIN_OWN_SHARE` of their white through
    their own lens (the core's own-lens render of the same white scene). On the ideal
    layout a pixel sees its own lens alone, and the whites are :func:`_white`'s."""
    return tuple(_native.depth_whites(design.core, MIN_OWN_SHARE))


def _candidates(design: Design, depths: Any, n: Any) -> np.ndarray:
    arr = np.asarray(depths, dtype=np.float64) if not isinstance(depths, str) else None
    if arr is None or arr.ndim != 1:
        raise TypeError("depths must be (zmin, zmax) or a 1-D array of candidate depths "
                        f"(mm), got {depths!r}"[:300])
    if arr.size == 2:
        zmin, zmax = float(arr[0]), float(arr[1])
        if not (math.isfinite(zmin) and math.isfinite(zmax)):
            raise InvalidParameter.of("depths", f"({zmin}, {zmax})", "finite depths (mm)")
        if not zmin < zmax:
            raise InvalidParameter.of("depths", f"({zmin}, {zmax})",
                                      "a range zmin < zmax (mm)")
        if zmin <= design.F:
            raise InvalidParameter.of("depths", f"zmin = {zmin}",
                                      f"depths > F = {design.F:g} mm")
        if (isinstance(n, bool) or not isinstance(n, int | np.integer)
                or not 3 <= n <= MAX_CANDIDATES):
            raise InvalidParameter.of("candidates", n, f"an integer in [3, {MAX_CANDIDATES}]")
        return 1.0 / np.linspace(1.0 / zmin, 1.0 / zmax, int(n))
    if not 3 <= arr.size <= MAX_CANDIDATES:
        raise InvalidParameter.of("depths", f"{arr.size} candidates",
                                  f"(zmin, zmax) or 3 to {MAX_CANDIDATES} candidate depths")
    bad = np.flatnonzero(~(np.isfinite(arr) & (arr > design.F)))
    if bad.size:
        i = int(bad[0])
        raise InvalidParameter.of("depths", f"{arr[i]!r} (candidate {i})",
                                  f"finite depths > F = {design.F:g} mm")
    if np.any(np.diff(arr) <= 0.0):
        i = int(np.flatnonzero(np.diff(arr) <= 0.0)[0]) + 1
        raise InvalidParameter.of("depths", f"{arr[i]!r} after {arr[i - 1]!r} (candidate {i})",
                                  "strictly increasing candidate depths")
    return arr


def estimate_depth(raw: Raw, *, depths: Any, region: Any = None, step: float | None = None,
                   candidates: int = DEFAULT_CANDIDATES, window: int = DEFAULT_WINDOW,
                   min_confidence: float = DEFAULT_MIN_CONFIDENCE, channels: Any = None,
                   tilt: bool = False, n_threads: int | None = None,
                   progress: bool | None = None) -> DepthMap:
    """The depth of the scene over a region, from the raw alone (docs/depth.md).

    - ``raw``: a :class:`~splitlf.Raw` (rendered or wrapped)
    - ``depths``: ``(zmin, zmax)`` (``candidates`` depths uniform in 1/z between them) or
      a 1-D array of 3 to 4096 increasing candidate depths, all finite and > F (mm)
    - ``candidates``: the count of a (zmin, zmax) range, an integer in [3, 4096]
    - ``region``: (X0, X1, Y0, Y1) mm (default: what every chosen channel sees through at
      least half its aperture at the reference depth, the middle candidate in 1/z; when
      there is no such point, what the first chosen channel sees so)
    - ``step``: the grid's pitch in mm (default: delta(z) of docs/model.md §9 at the
      reference depth)
    - ``window``: costs are pooled over (2 window + 1)^2 cells (an integer in
      [0, 64])
    - ``min_confidence``: the least confidence of a confident cell, in [0, 1] (at the
      default 0.5: the cost curve's least value at most half its mean and its rival
      minima, and its dip narrow enough in relative depth, docs/depth.md step 6)
    - ``tilt``: pool each cell's window again along the surface's local slope, fitted to
      the confident cells' fronto-parallel estimates (docs/depth.md step 7: it narrows the
      spread of a steep slope's band errors, costs about 1.5x the time and 8 bytes per
      cell, channel and candidate; default False, the fronto-parallel window's estimate)
    - ``channels``: the channels used (numbered from 1; default all)
    - ``progress``: a tqdm bar over the candidates (None: only when stderr is a terminal)

    Returns a :class:`~splitlf.DepthMap` with ``depth`` (mm, row 0 at the top; cells
    that are not confident take the depth of the nearest confident cell, so the map can
    be handed to :func:`~splitlf.reconstruct`), ``confidence`` (the least of the most
    confident channel's cost-curve contrast, 1 - min / min(mean, rival minima: more
    than n/16 candidates away, beyond a ridge twice their cost, or at the mirror of the
    least cost's depth in 1/z about the channel's out-of-focus plane behind a ridge
    there), and its
    resolution, 1 / (1 + (w / 0.045)^2) with w the dip's width in relative depth, read
    from the curve 5 % of the depth either side of the least cost (or at its neighbours
    where the candidates are coarser), so that it does not depend on their count; 0 where
    the least cost is at an end of the candidates or those 5 % reach beyond them; in
    [0, 1]), ``confident``
    (bool) and ``sweep`` (a :class:`DepthSweep`).
    A raw without texture (all zeros, a uniform albedo) gives no confident cell.
    A mosaiced raw (``raw.cfa``) is matched as its grey raw (``raw.grey()``: each pixel
    divided by its colour's QE), exact for a grey scene; on a colour scene the colours'
    differences are texture to the sweep (docs/depth.md, "Colour").
    Raises ``TypeError``, :class:`~splitlf.errors.InvalidParameter` naming the parameter,
    :class:`~splitlf.errors.TooLargeError` (before any work, from the memory of the whole
    call: the whites, the sweep's buffers and its outputs) and ``KeyboardInterrupt``.
    """
    if not isinstance(raw, Raw):
        raise TypeError(f"raw must be a splitlf.Raw, got {type(raw).__name__}")
    design = raw.design
    chans = _channels(design, channels)
    cand = _candidates(design, depths, candidates)
    mc = _validate.real(min_confidence, "min_confidence")
    if not 0.0 <= mc <= 1.0:
        raise InvalidParameter.of("min_confidence", mc, "a value in [0, 1]")
    radius = _window(window)
    if not isinstance(tilt, bool | np.bool_):
        raise TypeError(f"tilt must be True or False, got {tilt!r}")
    request: dict[str, Any] = {
        "channels": list(chans), "candidates": [float(z) for z in cand], "window": radius,
        "min_own_share": MIN_OWN_SHARE, "keep_volume": False, "tilt": bool(tilt),
        "step": None if step is None else _validate.positive_length(step, "step"),
        "region": None if region is None else _extent(region, "region")}
    _validate.n_threads(n_threads)
    grey = raw.grey()  # a mosaic's grey raw: each pixel over its colour's QE (§12)
    raws = [np.ascontiguousarray(grey.images[c - 1], dtype=np.float64) for c in chans]
    bar, report = _progress(_progress_flag(progress), "splitlf depth", "depth")
    try:
        depth, index, conf, cmin, cmean, chan, samples, _, grid = _native.estimate_depth(
            design.core, raws, request, n_threads, report)
    finally:
        if bar is not None:
            bar.close()
    x0, y1, h, nx, ny = grid
    extent = (x0, x0 + nx * h, y1 - ny * h, y1)
    ok = np.isfinite(depth)
    if not ok.any():
        raise InvalidParameter.of(
            "region", "({:.6g}, {:.6g}, {:.6g}, {:.6g})".format(*extent),
            "a region the chosen channels' pixels see at the candidate depths")
    confident = ok & (conf >= mc) & (conf > 0.0)
    sweep = DepthSweep(candidates=cand, index=index, min_cost=cmin, mean_cost=cmean,
                       channel=chan, estimate=depth, window=radius, channels=chans,
                       samples=int(samples))
    return DepthMap(_fill(depth, confident, ok, cand), extent, confidence=conf,
                    confident=confident, sweep=sweep)


def _window(window: Any) -> int:
    """The window's radius: an integer in [0, :data:`MAX_WINDOW`] cells."""
    if isinstance(window, bool) or not isinstance(window, int | np.integer):
        raise TypeError(f"window must be an integer number of cells, got {window!r}")
    if not 0 <= window <= MAX_WINDOW:
        raise InvalidParameter.of("window", window, f"an integer in [0, {MAX_WINDOW}] cells")
    return int(window)


def _fill(depth: np.ndarray, confident: np.ndarray, ok: np.ndarray,
          cand: np.ndarray) -> np.ndarray:
    """Every cell's depth: its own where confident, else the nearest confident cell's
    (Euclidean, scipy.ndimage's distance transform); with no confident cell, its own
    estimate where it has one, else the middle candidate in 1/z."""
    if confident.any():
        from scipy.ndimage import distance_transform_edt

        _, (ri, ci) = distance_transform_edt(~confident, return_indices=True)
        return depth[ri, ci]
    mid = float(1.0 / np.median(1.0 / cand))
    return np.where(ok, depth, mid)
