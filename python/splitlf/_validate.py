"""Argument checks shared by the public functions: Python types here, ranges in the core.

Wrong types raise ``TypeError`` naming the parameter; values outside their range raise
:class:`splitlf.errors.InvalidParameter` (a ``ValueError``). Limits come from the core
(``splitlf._native``), the single source of truth.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from . import _native
from .errors import InvalidParameter, TooLargeError
from .model.design import Design

#: Largest thread count (from the core).
MAX_THREADS: int = _native.MAX_THREADS


def design(value: Any, name: str = "design") -> Design:
    """A :class:`~splitlf.design.Design` (a :class:`~splitlf.Camera` is one), else
    ``TypeError``."""
    if not isinstance(value, Design):
        raise TypeError(f"{name} must be a splitlf.Design (or a splitlf.Camera, which is one), "
                        f"got {type(value).__name__}")
    return value


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def integer(value: Any, name: str, kind: str = "an integer") -> int:
    """A Python or NumPy integer of any size (never a bool), else ``TypeError``."""
    if not _is_int(value):
        raise TypeError(f"{name} must be {kind}, got {type(value).__name__} {value!r}")
    return int(value)


def n_threads(value: Any) -> int | None:
    if value is None:
        return None
    allowed = f"an integer in [1, {MAX_THREADS}] or None for all cores"
    n = integer(value, "n_threads", f"an integer >= 1 or None, not {type(value).__name__}")
    if not 1 <= n <= MAX_THREADS:
        raise InvalidParameter.of("n_threads", n, allowed)
    return n


def half(value: Any) -> int:
    """1 or 2 (the range is checked by the core)."""
    return integer(value, "half", "the integer 1 or 2")


def choice(value: Any, name: str, allowed: tuple[str, ...]) -> str:
    """A string (a non-string is a ``TypeError``; the core rejects a name not in ``allowed``
    with :class:`InvalidParameter`)."""
    if not isinstance(value, str):
        words = ", ".join(map(repr, allowed))
        raise TypeError(f"{name} must be one of {words}, got {type(value).__name__} {value!r}")
    return value


def depths(value: Any, name: str = "z") -> np.ndarray:
    """Any array-like of depths -> 1-D float64 array (no copy when already float64)."""
    if isinstance(value, np.ma.MaskedArray) and np.ma.is_masked(value):
        raise InvalidParameter.of(name, "a masked array with masked elements",
                                  "an array of depths with none masked (fill or compress it)")
    arr = np.asarray(value)
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise TypeError(f"{name} must be an array of real depths in mm, got dtype {arr.dtype}")
    arr = np.atleast_1d(arr).astype(np.float64, copy=False)
    if arr.ndim != 1:
        raise InvalidParameter.of(name, f"an array of shape {arr.shape}",
                                  "a scalar or a one-dimensional array of depths")
    return arr


#: Most depths a design is evaluated at (each depth is a full sample analysis).
MAX_DEPTHS = 100_000


def depth_range(value: Any, name: str = "depths") -> np.ndarray:
    """The depths a design's merits are taken over (sweeps, the inverse design, the
    comparison): 2..:data:`MAX_DEPTHS` finite values > 0, at least two distinct (their
    [min, max] is the range of the sharp fractions). ``TooLargeError`` beyond the limit,
    :class:`InvalidParameter` naming ``name`` (and the element) otherwise."""
    z = depths(value, name)
    if z.size > MAX_DEPTHS:
        raise TooLargeError(f"{z.size} depths; the limit is {MAX_DEPTHS} depths per design",
                            what=name, limit=MAX_DEPTHS)
    bad = np.flatnonzero(~np.isfinite(z) | (z <= 0))
    if bad.size:
        i = int(bad[0])
        raise InvalidParameter.of(name, float(z[i]), "finite depths > 0 mm", index=i)
    if z.size < 2 or z.min() == z.max():
        raise InvalidParameter.of(name, f"{z.size} depth(s), {np.unique(z).size} distinct",
                                  "at least two distinct depths (mm)")
    return z


def depth(value: Any, name: str = "z") -> float:
    """One depth: a real number, or an array-like holding exactly one (0-d or 1 element)."""
    if isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be a real depth in mm, got bool {value!r}")
    if isinstance(value, numbers.Real):
        return float(value)
    arr = depths(value, name)
    if arr.size != 1:
        allowed = "one depth: a number or an array-like of one element"
        raise InvalidParameter(f"invalid {name}: {arr.size} depths given, allowed {allowed}",
                               name=name, value=arr.size, allowed=allowed)
    return float(arr[0])


def real(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    return float(value)


def positive_length(value: Any, name: str) -> float:
    """A finite length > 0 (mm): a grid's step, a cell."""
    v = real(value, name)
    if not (math.isfinite(v) and v > 0.0):
        raise InvalidParameter.of(name, v, "a finite value > 0 (mm)")
    return v
