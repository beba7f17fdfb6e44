"""A design's figures of merit over depth: the one evaluation layer that sweeps, the inverse
design, the architecture comparison and the explorer share (docs/architectures.md, "Design
sweeps and figures of merit").

:func:`evaluate` is the public call; :func:`core_merits` is the one place the core's
``design_figures_of_merit`` is called from (``tests/test_structure.py`` checks it), so every
caller gets the same numbers for the same design, depths and options.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from typing import Any

import numpy as np

from . import _native, _validate
from .design import Design
from .errors import InvalidParameter

__all__ = ["DEFAULT_THRESHOLD_PX", "DEFAULT_TOL", "DEFAULT_WINDOW", "Options", "core_merits",
           "describe", "evaluate", "metrics", "options"]

#: Default sharpness threshold on the blur radius [px] and merge tolerance [delta(z)].
DEFAULT_THRESHOLD_PX: float = _native.DEFAULT_THRESHOLD_PX
DEFAULT_TOL: float = _native.DEFAULT_TOL
#: Default width of the central field of the 2-D merits, in lens pitches of channel 1 (as
#: :func:`splitlf.coverage`'s).
DEFAULT_WINDOW: float = _native.DEFAULT_WINDOW

_DOCS = {
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


def metrics(design: Design, merits_2d: bool = False) -> tuple[str, ...]:
    """Names of the figures of merit of ``design`` (from the core), in the order
    :func:`evaluate` returns them: per channel (from 1) and union,
    ``sharp_fraction_channel1``, ..., ``sharp_fraction_union``, ``max_gap_worst_*``,
    ``max_gap_median_*``, then per channel ``lit_fraction_channel*`` and
    ``light_per_pixel_channel*`` (5 C + 3 names for C channels); with ``merits_2d``,
    followed by the 2-D merits per channel and union: ``covering_radius_worst_channel1``,
    ..., ``covering_radius_worst_union``, ``covering_radius_median_*``,
    ``distinct_2d_median_*`` (3 (C + 1) names more). For the split sensor channel i is
    half i and the union is the split sensor."""
    d = _validate.design(design)
    return tuple(_native.design_metrics(d.core, _merits_2d(merits_2d)))


def describe(name: str) -> str:
    """A one-line description of merit ``name`` (one of :func:`metrics`)."""
    prefix, _, row = name.rpartition("_")
    row = "the union of all channels" if row == "union" else row.replace("channel",
                                                                         "channel ")
    return _DOCS[prefix].format(row=row)


def _merits_2d(value: Any) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"merits_2d must be True or False, got {type(value).__name__} "
                        f"{value!r}")
    return value


def real_option(value: Any, name: str, allowed: str, ok: Callable[[float], bool]) -> float:
    """A real option: ``TypeError`` if not a real number, :class:`InvalidParameter` unless
    ``ok(x)`` (an integer beyond the float range is inf)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf if float(int(value)) > 0 else -math.inf
    if not ok(x):
        raise InvalidParameter.of(name, x, allowed)
    return x


Options = tuple[float, float, "float | None"]


def options(threshold_px: Any, tol: Any, merits_2d: Any, window: Any) -> Options:
    """The checked options of the core's figures of merit: ``(threshold_px, tol, window)``,
    window None when the 2-D merits are not asked for. ``window`` is checked either way;
    with the 2-D merits ``tol`` must also suit the 2-D distinct samples, (0, MAX_TOL_2D]."""
    thr = real_option(threshold_px, "threshold_px", "a finite number > 0 (pixels)",
                      lambda x: math.isfinite(x) and x > 0)
    t = real_option(tol, "tol", "a finite number >= 0 (a multiple of delta(z))",
                    lambda x: math.isfinite(x) and x >= 0)
    on = _merits_2d(merits_2d)
    w = real_option(window, "window", "a finite number > 0 (the central field's width in "
                    "lens pitches of channel 1)", lambda x: math.isfinite(x) and x > 0)
    if not on:
        return thr, t, None
    if not 0.0 < t <= _native.MAX_TOL_2D:
        raise InvalidParameter.of("tol", t, f"a number in (0, {_native.MAX_TOL_2D:g}] with "
                                  "the 2-D merits (a multiple of delta(z))")
    return thr, t, w


def core_merits(design: Design, z: np.ndarray, opts: Options,
                n_threads: int | None) -> list[float]:
    """The core's figures of merit of ``design`` at the checked depths ``z`` with the
    checked ``opts`` (:func:`options`), in the order of :func:`metrics`."""
    thr, t, w = opts
    return list(_native.design_figures_of_merit(design.core, z, thr, t, n_threads, w))


def evaluate(design: Design, depths: Any, *, threshold_px: float = DEFAULT_THRESHOLD_PX,
             tol: float = DEFAULT_TOL, merits_2d: bool = False,
             window: float = DEFAULT_WINDOW, n_threads: int | None = None
             ) -> dict[str, float]:
    """Figures of merit of one design over ``depths``, computed by the core.

    - ``design``: a :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one)
    - ``depths``: 1-D array-like of scene depths [mm], each finite and > F; [min, max] of
      them is the depth range of the sharp fractions
    - ``threshold_px``: sharpness threshold on the blur radius [pixels], finite > 0
    - ``tol``: merge tolerance of the sample positions [multiples of delta(z)], finite >= 0
      (in (0, 1] with ``merits_2d``: the 2-D distinct samples use it too)
    - ``merits_2d``: also compute the 2-D merits (``metrics(design, merits_2d=True)``): the
      worst and median covering radius and the median distinct 2-D samples of
      :func:`splitlf.coverage` over the depths. They cost far more than the others (a 2-D
      analysis per depth), so they are off by default and then absent from the result
    - ``window``: width of their central field in lens pitches of channel 1, finite > 0
      (default :data:`DEFAULT_WINDOW` = 16, as :func:`splitlf.coverage`; checked even when
      ``merits_2d`` is off)
    - ``n_threads``: threads of the core (None: all cores)

    Returns ``{name: value}`` in the order of :func:`metrics`. Raises ``TypeError`` for
    arguments of the wrong type and :class:`~splitlf.errors.InvalidParameter` (a
    ``ValueError``) for values out of range (a depth named ``depths`` with its index;
    ``tol`` outside (0, 1] with ``merits_2d``).
    """
    d = _validate.design(design)
    z = _validate.depths(depths, "depths")
    opts = options(threshold_px, tol, merits_2d, window)
    threads = _validate.n_threads(n_threads)
    return dict(zip(metrics(d, opts[2] is not None), core_merits(d, z, opts, threads),
                    strict=True))
