"""Argument checks shared by the public functions: Python types here, ranges in the core.

Wrong types raise ``TypeError`` naming the parameter; values outside their range raise
:class:`splitlf.errors.InvalidParameter` (a ``ValueError``). Limits come from the core
(``splitlf._native``), the single source of truth.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any, TypeVar, cast

import numpy as np

from . import _native
from .errors import InvalidParameter, TooLargeError

#: Largest thread count (from the core).
MAX_THREADS: int = _native.MAX_THREADS

T = TypeVar("T")

#: The design class, registered by :mod:`splitlf.model.design` when it loads (this module
#: sits below the model room, so the model names itself here instead of being imported).
_design_class: list[type] = []


def register_design(cls: type[T]) -> type[T]:
    """Make ``cls`` the class :func:`design` accepts (called once by splitlf.model.design)."""
    _design_class[:] = [cls]
    return cls


def design(value: T, name: str = "design") -> T:
    """A :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one), else
    ``TypeError``."""
    if not (_design_class and isinstance(value, _design_class[0])):
        raise TypeError(f"{name} must be a splitlf.Design (or a splitlf.Camera, which is one), "
                        f"got {type(value).__name__}")
    return value


def rect_grids(design: Any) -> None:
    """Every channel of ``design`` on a rect grid (the 1-D simulation runs along x,
    docs/model.md §9), else :class:`InvalidParameter` named ``channels[i].grid``."""
    for i, ch in enumerate(design.channels, 1):
        if ch.grid != "rect":
            allowed = ('"rect": the simulation runs the 1-D analysis along x (docs/model.md '
                       '§3-§6, §9), which needs rect grids')
            raise InvalidParameter(f'invalid channels[{i}].grid = "hex": allowed {allowed}',
                                   name=f"channels[{i}].grid", value="hex", allowed=allowed)


def channels(design: Any, value: Any) -> tuple[int, ...]:
    """Channel numbers of ``design`` (1-based): None for all, one number or a non-empty
    sequence of distinct ones; ``TypeError`` or :class:`InvalidParameter` otherwise."""
    n = len(design.channels)
    if value is None:
        return tuple(range(1, n + 1))
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        value = (value,)
    if not isinstance(value, Sequence) or isinstance(value, str) or not value:
        raise TypeError("channels must be None, a channel number or a non-empty sequence of "
                        f"them, got {value!r}")
    out: list[int] = []
    for c in value:
        if isinstance(c, bool) or not isinstance(c, (int, np.integer)):
            raise TypeError(f"channels must hold integers, got {c!r}")
        if not 1 <= int(c) <= n:
            raise InvalidParameter.of("channels", int(c), f"channel numbers in 1..{n}")
        if int(c) in out:
            raise InvalidParameter.of("channels", int(c), "each channel at most once")
        out.append(int(c))
    return tuple(out)


def field_real(owner: str, name: str, value: Any, what: str) -> float:
    """A finite real field of ``owner`` (a class name), else ``TypeError`` /
    :class:`InvalidParameter` naming it; ``what`` describes the field."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{owner}.{name} must be a real number ({what}), "
                        f"got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:  # an integer beyond the float range (e.g. a 400-digit TOML integer)
        x = math.inf if cast(int, value) > 0 else -math.inf
    if not math.isfinite(x):
        shown = x if isinstance(value, float) else f"{str(value)[:12]}... ({x})"
        raise InvalidParameter.of(name, shown, f"a finite value ({what})")
    return x


def field_count(owner: str, name: str, value: Any, what: str, limit: int) -> int:
    """An integer field (never a bool or a float), else ``TypeError``; one beyond any i64
    is :class:`InvalidParameter` here (the core checks the range ``[1, limit]``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{owner}.{name} must be an integer ({what}), "
                        f"got {type(value).__name__} {value!r}")
    n = int(value)
    if not -(2**62) < n < 2**62:
        shown = n if abs(n) < 10**15 else f"{str(n)[:12]}... ({len(str(abs(n)))} digits)"
        raise InvalidParameter.of(name, shown, f"an integer in [1, {limit}]")
    return n


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def integer(value: Any, name: str, kind: str = "an integer") -> int:
    """A Python or NumPy integer of any size (never a bool), else ``TypeError``."""
    if not _is_int(value):
        raise TypeError(f"{name} must be {kind}, got {type(value).__name__} {value!r}")
    return int(value)


def integer_in(value: Any, name: str, lo: int, hi: int, kind: str = "an integer") -> int:
    """An integer (:func:`integer`; ``kind`` words its ``TypeError``) in [lo, hi], else
    :class:`InvalidParameter` naming the range."""
    n = integer(value, name, kind)
    if not lo <= n <= hi:
        raise InvalidParameter.of(name, n, f"an integer in [{lo}, {hi}]")
    return n


def channel_number(design: Any, half: Any, channel: Any) -> int:
    """The channel number: exactly one of ``half`` and ``channel`` (two names of one
    number: the split sensor's half i is its channel i), in [1, C]; errors name the
    argument given."""
    if half is not None and channel is not None:
        raise TypeError("give half or channel, not both (half i of the split sensor is its "
                        "channel i)")
    if half is None and channel is None:
        raise TypeError("missing the channel number (half= or channel=)")
    name, value = ("half", half) if channel is None else ("channel", channel)
    n = integer(value, name, "an integer >= 1")
    count = len(design.channels)
    if not 1 <= n <= count:
        raise InvalidParameter.of(name, n, "1 or 2" if count == 2 and name == "half"
                                  else f"an integer in [1, {count}] (a channel number)")
    return n


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


def _real_or_inf(value: Any, name: str) -> float:
    """A real number (an integer beyond the float range becomes +-inf, for the range
    check to reject), else ``TypeError``."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        try:
            return float(value)
        except OverflowError:
            return -math.inf if value < 0 else math.inf
    return real(value, name)


def finite(value: Any, name: str) -> float:
    """A finite real number, else ``TypeError`` / :class:`InvalidParameter`."""
    x = _real_or_inf(value, name)
    if not math.isfinite(x):
        raise InvalidParameter.of(name, x, "a finite number")
    return x


def positive(value: Any, name: str, upper: float = math.inf) -> float:
    """A finite real number in (0, ``upper``], else ``TypeError`` / :class:`InvalidParameter`."""
    x = _real_or_inf(value, name)
    if not (math.isfinite(x) and 0 < x <= upper):
        allowed = "a finite value > 0" if upper == math.inf else f"a value in (0, {upper:g}]"
        raise InvalidParameter.of(name, x, allowed)
    return x


def nonnegative(value: Any, name: str, upper: float = math.inf) -> float:
    """A finite real number in [0, ``upper``] (an albedo, a noise level), else
    ``TypeError`` / :class:`InvalidParameter`."""
    x = _real_or_inf(value, name)
    if not (math.isfinite(x) and 0 <= x <= upper):
        allowed = ("a finite value >= 0" if upper == math.inf
                   else f"a finite value in [0, {upper:g}]")
        raise InvalidParameter.of(name, x, allowed)
    return x


def extent(value: Any, name: str = "extent") -> tuple[float, float, float, float]:
    """(X0, X1, Y0, Y1) [mm], finite, X0 < X1 and Y0 < Y1."""
    if isinstance(value, str | bytes) or not hasattr(value, "__len__") or len(value) != 4:
        raise TypeError(f"{name} must be (X0, X1, Y0, Y1) in mm, got {value!r}")
    x0, x1, y0, y1 = (finite(v, f"{name}[{i}]") for i, v in enumerate(value))
    if not (x0 < x1 and y0 < y1):
        raise InvalidParameter.of(name, (x0, x1, y0, y1), "X0 < X1 and Y0 < Y1 (mm)")
    return x0, x1, y0, y1
