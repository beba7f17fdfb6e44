"""Argument checks of the study functions' shared options (``threshold_px``, ``tol``, the
2-D merits' ``merits_2d`` and ``window``), shared by :mod:`.merit`, :mod:`.sweep` and
:mod:`.optimise`."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from typing import Any

from .. import _native
from ..errors import InvalidParameter

__all__ = ["check_options", "merits_2d_option", "options_2d", "real_option",
           "threshold_option", "tol_option", "window_option"]


def real_option(value: Any, name: str, allowed: str, ok: Callable[[float], bool]) -> float:
    """A real option: ``TypeError`` if not a real number, :class:`InvalidParameter` unless
    ``ok(x)`` (an integer beyond the float range is inf)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:  # an integer (or a Fraction) beyond the float range
        x = -math.inf if value < 0 else math.inf
    if not ok(x):
        raise InvalidParameter.of(name, x, allowed)
    return x


def threshold_option(value: Any) -> float:
    return real_option(value, "threshold_px", "a finite number > 0 (pixels)",
                       lambda x: math.isfinite(x) and x > 0)


def tol_option(value: Any) -> float:
    return real_option(value, "tol", "a finite number >= 0 (a multiple of delta(z))",
                       lambda x: math.isfinite(x) and x >= 0)


def merits_2d_option(value: Any) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"merits_2d must be True or False, got {type(value).__name__} "
                        f"{value!r}")
    return value


def window_option(value: Any) -> float:
    return real_option(value, "window", "a finite number > 0 (the central field's width "
                       "in lens pitches of channel 1)", lambda x: math.isfinite(x) and x > 0)


def options_2d(merits_2d: Any, window: Any, tol: float) -> float | None:
    """The core's ``window`` argument: the checked window when the 2-D merits are asked
    for, else None (they are not computed). ``window`` is checked either way; with the 2-D
    merits, ``tol`` must also suit the 2-D distinct samples, (0, MAX_TOL_2D]."""
    on, w = merits_2d_option(merits_2d), window_option(window)
    if not on:
        return None
    if not 0.0 < tol <= _native.MAX_TOL_2D:
        raise InvalidParameter.of("tol", tol, f"a number in (0, {_native.MAX_TOL_2D:g}] with "
                                  "the 2-D merits (a multiple of delta(z))")
    return w


def check_options(threshold_px: Any, tol: Any, merits_2d: Any, window: Any
                  ) -> tuple[float, float, float | None]:
    """The options of :func:`splitlf.evaluate` (and of a sweep file's ``[options]``)
    checked: (threshold_px, tol, the core's window or None without the 2-D merits)."""
    thr, t = threshold_option(threshold_px), tol_option(tol)
    return thr, t, options_2d(merits_2d, window, t)
