"""General plenoptic architectures (docs/model.md §9): a main lens and one or more channels.

A :class:`Channel` is one microlens array with the sensor region behind it, reached by a
share of the light; a :class:`Design` is a main lens (focal length ``F``, aperture width
``D``, ``aperture="square"`` or ``"circle"``) with its channels. The split-sensor
:class:`~splitlf.Camera` is the two-channel design ``Camera.design``; a plain light field
camera is one channel; a Raytrix-style multi-focus camera is one hexagonal channel with
three lens types.

Ranges and every derived value are checked by the Rust core (``splitlf._native.DesignCore``);
this module checks Python types and holds the fields.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Any

from . import _native
from .errors import InvalidParameter

__all__ = ["Channel", "Design", "CHANNEL_FIELDS"]

#: Channel fields, in constructor order.
CHANNEL_FIELDS = ("L", "d", "v", "mu", "Kx", "Ky", "f", "grid", "layout", "Q", "Mx", "My",
                  "share")

_CHANNEL_DESCRIPTIONS = {
    "L": "optical path main lens -> microlens array [mm], > F",
    "d": "microlens pitch [mm]",
    "v": "microlens array -> sensor [mm]",
    "mu": "pixel pitch [mm]",
    "Kx": "microlenses per row",
    "Ky": "rows of microlenses",
    "f": "microlens focal lengths of the lens types [mm], or None for Ng's setting",
    "grid": '"rect" or "hex"',
    "layout": '"ideal" (Q x Q pixels per lens, rect grids) or "sensor" (a uniform pixel grid)',
    "Q": "pixels per microlens along one axis (ideal layout)",
    "Mx": "sensor pixels along x (sensor layout; default: the smallest grid covering the array)",
    "My": "sensor pixels along y (sensor layout; default: the smallest grid covering the array)",
    "share": "fraction of the light reaching this channel, in (0, 1]",
}

_COUNT_LIMITS = {"Kx": _native.MAX_K, "Ky": _native.MAX_K, "Q": _native.MAX_Q,
                 "Mx": _native.MAX_M, "My": _native.MAX_M}


def _real(owner: str, name: str, value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{owner}.{name} must be a real number ({what}), "
                        f"got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf if value > 0 else -math.inf
    if not math.isfinite(x):
        raise InvalidParameter.of(name, x, f"a finite value ({what})")
    return x


def _count(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"Channel.{name} must be an integer ({_CHANNEL_DESCRIPTIONS[name]}), "
                        f"got {type(value).__name__} {value!r}")
    n = int(value)
    if not -(2**62) < n < 2**62:
        shown = n if abs(n) < 10**15 else f"{str(n)[:12]}... ({len(str(abs(n)))} digits)"
        raise InvalidParameter.of(name, shown, f"an integer in [1, {_COUNT_LIMITS[name]}]")
    return n


def _choice(owner: str, name: str, value: Any, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{owner}.{name} must be one of {allowed}, got "
                        f"{type(value).__name__} {value!r}")
    if value not in allowed:
        raise InvalidParameter.of(name, value, " or ".join(repr(a) for a in allowed))
    return value


def _focal_lengths(value: Any) -> tuple[float, ...] | None:
    if value is None:
        return None
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        value = (value,)
    if isinstance(value, str | bytes) or not hasattr(value, "__iter__"):
        raise TypeError("Channel.f must be None (Ng's setting), a focal length or a sequence "
                        f"of focal lengths [mm], got {type(value).__name__} {value!r}")
    return tuple(_real("Channel", "f", x, _CHANNEL_DESCRIPTIONS["f"]) for x in value)


@dataclasses.dataclass(frozen=True)
class Channel:
    """One microlens array and the sensor region behind it (docs/model.md §9). Lengths in mm.

    ``L`` main lens to array (> F of the design), ``d`` microlens pitch, ``v`` array to
    sensor, ``mu`` pixel pitch; ``Kx`` lenses per row and ``Ky`` rows (integers in
    [1, 10**7]); ``f`` the focal lengths of the lens types (one value: a uniform array;
    None: Ng's setting 1/f = 1/L + 1/v); ``grid`` ``"rect"`` or ``"hex"``; ``layout``
    ``"ideal"`` (``Q`` x ``Q`` pixels per lens; rect grids only) or ``"sensor"`` (a
    uniform grid of ``Mx`` x ``My`` pixels, each belonging to the lens whose image is
    nearest; default the smallest grid covering every image cell); ``share`` the fraction
    of the main lens's light reaching the channel, in (0, 1].

    A channel is checked on its own for types (``TypeError``); its ranges are checked when
    it becomes part of a :class:`Design` (:class:`~splitlf.errors.InvalidParameter` named
    ``channels[i].NAME``), since some depend on the main lens.
    """

    L: float
    d: float
    v: float
    mu: float
    Kx: int
    Ky: int
    f: tuple[float, ...] | None = None
    grid: str = "rect"
    layout: str = "ideal"
    Q: int | None = None
    Mx: int | None = None
    My: int | None = None
    share: float = 1.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ("L", "d", "v", "mu", "share"):
            set_(self, name, _real("Channel", name, getattr(self, name),
                                   _CHANNEL_DESCRIPTIONS[name]))
        for name in ("Kx", "Ky"):
            set_(self, name, _count(name, getattr(self, name)))
        for name in ("Q", "Mx", "My"):
            value = getattr(self, name)
            set_(self, name, None if value is None else _count(name, value))
        set_(self, "f", _focal_lengths(self.f))
        set_(self, "grid", _choice("Channel", "grid", self.grid, ("rect", "hex")))
        set_(self, "layout", _choice("Channel", "layout", self.layout, ("ideal", "sensor")))

    def replace(self, **changes: Any) -> Channel:
        """A copy with some fields changed."""
        unknown = set(changes) - set(CHANNEL_FIELDS)
        if unknown:
            raise TypeError(f"unknown Channel field(s) {sorted(unknown)}; "
                            f"allowed fields: {', '.join(CHANNEL_FIELDS)}")
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        """The fields as given (``f`` as a list or None)."""
        out = {n: getattr(self, n) for n in CHANNEL_FIELDS}
        out["f"] = None if self.f is None else list(self.f)
        return out


@dataclasses.dataclass(frozen=True)
class Design:
    """A plenoptic camera design (docs/model.md §9): a thin main lens of focal length ``F``
    and aperture width ``D`` [mm] (``aperture="square"``: |w_x|, |w_y| < D/2, the paper's;
    ``"circle"``: |w| < D/2) and one or more :class:`Channel` s (1 to 64) whose shares sum
    to at most 1.

    Raises ``TypeError`` for fields of the wrong type and
    :class:`~splitlf.errors.InvalidParameter` for values out of range, a channel's named
    ``channels[i].NAME`` (i from 1): L <= F, a lens-type tuple that does not fit the grid
    (two types on a hex grid, more types than the pattern can place), the ideal layout
    on a hex grid, shares summing above 1, microlens images that overlap (the aperture's
    image behind a lens, D v / L wide, larger than the lens's image cell). Immutable,
    hashable, picklable.
    """

    F: float
    D: float
    channels: tuple[Channel, ...]
    aperture: str = "square"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "F", _real("Design", "F", self.F, "main lens focal length [mm]"))
        set_(self, "D", _real("Design", "D", self.D, "main lens aperture width [mm]"))
        set_(self, "aperture", _choice("Design", "aperture", self.aperture,
                                       ("square", "circle")))
        channels = self.channels
        if isinstance(channels, Channel):
            channels = (channels,)
        if isinstance(channels, str | bytes) or not hasattr(channels, "__iter__"):
            raise TypeError("Design.channels must be a sequence of Channel, got "
                            f"{type(channels).__name__}")
        channels = tuple(channels)
        for i, ch in enumerate(channels, 1):
            if not isinstance(ch, Channel):
                raise TypeError(f"Design.channels[{i}] must be a Channel, got "
                                f"{type(ch).__name__}")
        set_(self, "channels", channels)
        core = _native.DesignCore(self.F, self.D, self.aperture,
                                  [ch.as_dict() for ch in channels])
        set_(self, "_core", core)

    @classmethod
    def _from_core(cls, core: _native.DesignCore) -> Design:
        F, D, aperture = core.main_lens()
        channels = []
        for c in core.channels():
            f = None if c.pop("ng") else tuple(c["f"])
            channels.append(Channel(**{**c, "f": f}))
        return cls(F, D, tuple(channels), aperture)

    def replace(self, **changes: Any) -> Design:
        """A copy with some fields changed, validated again."""
        unknown = set(changes) - {"F", "D", "channels", "aperture"}
        if unknown:
            raise TypeError(f"unknown Design field(s) {sorted(unknown)}; "
                            "allowed fields: F, D, channels, aperture")
        return dataclasses.replace(self, **changes)

    def __reduce__(self):
        return (Design, (self.F, self.D, self.channels, self.aperture))

    # -- derived values (computed by the core) -------------------------------------------
    def resolved(self) -> list[dict[str, Any]]:
        """Each channel's fields as validated: ``f`` resolved (Ng's setting as one focal
        length), the sensor layout's ``Mx``, ``My`` resolved, and ``ng`` (f not given)."""
        return self._core.channels()

    def resolution_step(self, z: float) -> float:
        """delta(z) = mu_1 z / L_1 [mm]: one pixel of a conventional camera on channel 1's
        array plane, projected onto the plane at depth z (docs/model.md §9)."""
        return self._core.resolution_step(float(z))

    @property
    def core(self) -> _native.DesignCore:
        """The native handle (for the functions of this package)."""
        return self._core
