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
import numbers
import os
from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .. import _native
from .._files import read_toml, text_file
from .._validate import field_count, field_real, register_design
from ..errors import InvalidParameter

__all__ = ["Channel", "Design", "CHANNEL_FIELDS", "DESIGN_FIELDS", "PRESETS"]

#: Channel fields, in constructor order.
CHANNEL_FIELDS = ("L", "d", "v", "mu", "Kx", "Ky", "f", "grid", "layout", "Q", "Mx", "My",
                  "share")
#: Channel fields without a default.
_REQUIRED_CHANNEL_FIELDS = ("L", "d", "v", "mu", "Kx", "Ky")
#: Design fields, in constructor order.
DESIGN_FIELDS = ("F", "D", "channels", "aperture")
#: The names of :meth:`Design.preset` (from the core), in the documented order.
PRESETS: tuple[str, ...] = tuple(_native.DesignCore.presets())

DESIGN_DESCRIPTIONS = {
    "F": "main lens focal length [mm]",
    "D": "main lens aperture width (side of the square, diameter of the circle) [mm]",
    "aperture": 'main lens aperture shape, "square" or "circle"',
}

CHANNEL_DESCRIPTIONS = {
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


def _choice(owner: str, name: str, value: Any, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{owner}.{name} must be one of {allowed}, got "
                        f"{type(value).__name__} {value!r}")
    if value not in allowed:
        raise InvalidParameter.of(name, value, " or ".join(repr(a) for a in allowed))
    return value


def _channel_count(name: str, value: Any) -> int:
    return field_count("Channel", name, value, CHANNEL_DESCRIPTIONS[name], _COUNT_LIMITS[name])


def _focal_lengths(value: Any) -> tuple[float, ...] | None:
    if value is None:
        return None
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        value = (value,)
    # A mapping or a set has no order of lens types (a dict's keys would be taken silently).
    if (isinstance(value, str | bytes | Mapping | AbstractSet)
            or not hasattr(value, "__iter__")):
        raise TypeError("Channel.f must be None (Ng's setting), a focal length or a sequence "
                        f"of focal lengths [mm], got {type(value).__name__} {value!r}")
    return tuple(field_real("Channel", "f", x, CHANNEL_DESCRIPTIONS["f"]) for x in value)


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
            set_(self, name, field_real("Channel", name, getattr(self, name),
                                   CHANNEL_DESCRIPTIONS[name]))
        for name in ("Kx", "Ky"):
            set_(self, name, _channel_count(name, getattr(self, name)))
        for name in ("Q", "Mx", "My"):
            value = getattr(self, name)
            set_(self, name, None if value is None else _channel_count(name, value))
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


@register_design
@dataclasses.dataclass(frozen=True, eq=False)
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

    if TYPE_CHECKING:  # set in __post_init__ (not a dataclass field)
        @property
        def _core(self) -> _native.DesignCore: ...

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "F", field_real("Design", "F", self.F, "main lens focal length [mm]"))
        set_(self, "D", field_real("Design", "D", self.D, "main lens aperture width [mm]"))
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

    @staticmethod
    def _from_core(core: _native.DesignCore) -> Design:
        design = object.__new__(Design)
        design._adopt(core)
        return design

    def _adopt(self, core: _native.DesignCore) -> None:
        """Take the fields of a design the core has already validated (a preset, a
        camera's), without building and validating it a second time."""
        F, D, aperture = core.main_lens()
        channels = []
        for c in core.channels():
            f = None if c.pop("ng") else tuple(c["f"])
            channels.append(Channel(**{**c, "f": f}))
        set_ = object.__setattr__
        for name, value in (("F", F), ("D", D), ("channels", tuple(channels)),
                            ("aperture", aperture), ("_core", core)):
            set_(self, name, value)

    def _key(self) -> tuple[Any, ...]:
        return (self.F, self.D, self.channels, self.aperture)

    def __eq__(self, other: object) -> bool:
        """Two designs are equal when their main lens and channels are: a
        :class:`~splitlf.Camera` equals the Design it builds."""
        if not isinstance(other, Design):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    @property
    def design(self) -> Design:
        """The general form of this design: a plain :class:`Design` equal to it (itself for
        a Design; for a :class:`~splitlf.Camera`, the two-channel design it builds, whose
        fields :meth:`replace`, :meth:`as_dict` and :meth:`to_toml` use)."""
        if type(self) is Design:
            return self
        return Design(self.F, self.D, self.channels, self.aperture)

    def replace(self, **changes: Any) -> Design:
        """A copy with some fields changed, validated again."""
        unknown = set(changes) - {"F", "D", "channels", "aperture"}
        if unknown:
            raise TypeError(f"unknown Design field(s) {sorted(unknown)}; "
                            "allowed fields: F, D, channels, aperture")
        return dataclasses.replace(self, **changes)

    def __reduce__(self) -> tuple[Any, ...]:
        return (Design, (self.F, self.D, self.channels, self.aperture))

    # -- presets ------------------------------------------------------------------------
    @classmethod
    def preset(cls, name: str) -> Design:
        """A named design (docs/architectures.md, "Presets"): ``"seed"`` (the split sensor
        of docs/model.md §7, equal to ``Camera.paper().design``), ``"seed-plain"`` (its
        half 1 alone on the whole sensor), ``"split3"`` (a three-way split),
        ``"raytrix-r12"`` and ``"lytro-illum"`` (two commercial plenoptic cameras rebuilt
        from public numbers). ``TypeError`` for a non-string, :class:`InvalidParameter`
        (``.name == "preset"``) for another name."""
        if not isinstance(name, str):
            raise TypeError(f"preset must be one of {PRESETS}, got {type(name).__name__} "
                            f"{name!r}")
        return Design._from_core(_native.DesignCore.preset(name))

    # -- dict and TOML ------------------------------------------------------------------
    def as_dict(self) -> dict[str, Any]:
        """The fields as given: ``F``, ``D``, ``aperture`` and ``channels`` (a list of
        :meth:`Channel.as_dict`); :meth:`from_dict` inverts it."""
        return {"F": self.F, "D": self.D, "aperture": self.aperture,
                "channels": [ch.as_dict() for ch in self.channels]}

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "design") -> Design:
        """Build from a mapping with ``F``, ``D``, ``channels`` (a list of mappings of
        channel fields; omitted optional fields take their defaults) and optionally
        ``aperture``. ``source`` names the input in messages (a file, for
        :meth:`from_toml`); a channel is named ``channels[i]`` (i from 1).

        Raises ``TypeError`` (not a mapping, a field of the wrong type), ``ValueError``
        for unknown or missing fields, and :class:`InvalidParameter` for values out of
        range (``.name`` as the constructor names it, e.g. ``channels[2].L``); every
        message starts with ``source``."""
        missing = missing_fields(data, source, "design", DESIGN_FIELDS, ("F", "D", "channels"))
        if missing:
            raise ValueError(f"{source}: missing design field(s) {missing}")
        tables = data["channels"]
        if not isinstance(tables, list | tuple):
            raise TypeError(f"{source}: channels must be a list of tables of channel fields "
                            f"([[design.channels]] in TOML), got {type(tables).__name__}")
        channels = tuple(_channel_from_dict(t, f"{source}: channels[{i}]", i)
                         for i, t in enumerate(tables, 1))
        fields = {k: v for k, v in data.items() if k != "channels"}
        with _in_source(source):
            return cls(channels=channels, **fields)

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> Design:
        """Read a design from a TOML file: a ``[design]`` table (``F``, ``D``,
        ``aperture``) and one ``[[design.channels]]`` table per channel (see
        :meth:`to_toml`).

        Raises ``OSError`` when the file cannot be read, ``ValueError`` naming the file for
        invalid TOML, a non-text file, a missing ``[design]`` table or other top-level
        keys, and the errors of :meth:`from_dict` (naming the file and the key)."""
        name = os.fspath(path)
        doc = read_toml(path)
        if not isinstance(doc.get("design"), dict):
            raise ValueError(f"{name}: needs a [design] table with [[design.channels]] "
                             "tables")
        extra = [k for k in doc if k != "design"]
        if extra:
            raise ValueError(f"{name}: unknown top-level key(s) {extra}; a design file holds "
                             "one [design] table and its [[design.channels]]")
        return cls.from_dict(doc["design"], source=name)

    def to_toml(self, path: str | os.PathLike[str] | None = None) -> str:
        """The design as TOML text: ``[design]`` and one ``[[design.channels]]`` per
        channel; exact (floats by repr), so :meth:`from_toml` gives an equal design.
        Optional channel fields left to their defaults (``f`` None for Ng's setting, ``Q``,
        ``Mx``, ``My`` None) are omitted. With ``path`` the file is also written,
        atomically (a temporary file in its folder, then renamed over it); ``OSError`` if
        it cannot be."""
        lines = ["# splitlf design: lengths in mm (docs/architectures.md)", "[design]"]
        for name in ("F", "D"):
            lines.append(f"{f'{name} = {getattr(self, name)!r}':<40} # "
                         f"{DESIGN_DESCRIPTIONS[name]}")
        lines.append(f"{f'aperture = {_toml_string(self.aperture)}':<40} # "
                     f"{DESIGN_DESCRIPTIONS['aperture']}")
        for ch in self.channels:
            lines += ["", "[[design.channels]]"]
            for name in CHANNEL_FIELDS:
                text = _toml_field(name, getattr(ch, name))
                if text is not None:
                    lines.append(f"{text:<40} # {CHANNEL_DESCRIPTIONS[name]}")
                elif name == "f":
                    lines.append("# f omitted: Ng's setting 1/f = 1/L + 1/v")
        return text_file(lines, path)

    # -- derived values (computed by the core) -------------------------------------------
    @property
    def f_number(self) -> float:
        """Main-lens f-number F / D."""
        return self.F / self.D

    def out_of_focus_depth(self, channel: int) -> float:
        """Depth whose conjugate lies on channel ``channel``'s array (from 1):
        F L / (L - F) [mm]."""
        return self._core.out_of_focus_depth(channel)

    def image_radius(self, channel: int) -> float:
        """R = D v / (2 L) of channel ``channel`` (from 1): radius of one microlens image
        on the sensor [mm], the bound of its light field blur."""
        return self._core.image_radius(channel)

    def focus_depths(self, channel: int) -> list[float | None]:
        """The depth [mm] each lens type of channel ``channel`` (from 1) is focused on
        (microlens blur 0: 1/(L - z') = 1/f_t - 1/v), or None where no depth is (Ng's
        setting: the microlenses are focused on the main lens)."""
        return self._core.focus_depths(channel)

    def resolved(self) -> list[dict[str, Any]]:
        """Each channel's fields as validated: ``f`` resolved (Ng's setting as one focal
        length), the sensor layout's ``Mx``, ``My`` resolved, and ``ng`` (f not given)."""
        return self._core.channels()

    def micro_image_centers(self, channel: int) -> np.ndarray:
        """Channel ``channel``'s (from 1) micro-image centres in its raw's pixel
        coordinates: where the ray through the main lens's centre and each microlens's
        centre meets the sensor, s = c (1 + v/L) (docs/model.md §9, "Pixel layouts"), in
        the raw's [row, column] frame of §10 (row 0 at the top, pixel (r, c) centred on the
        integers; ``ideal`` layout: the centre of each lens's Q x Q block).

        A float64 array of shape (Kx Ky, 4), one row ``[row, column, k, j]`` per lens
        (k its lattice row, j its place in the row), lattice rows first (k, then j
        ascending). Computed by the core (``splitlf_core::model::centers``)."""
        return self._core.micro_image_centers(channel)

    def micro_image_steps(self, channel: int) -> tuple[float, float]:
        """Channel ``channel``'s (from 1) steps between micro-image centres in its raw's
        pixels, (row step, column step): the column step between neighbours in a lattice
        row, the row step between lattice rows (``ideal`` layout: Q, Q; ``sensor``
        layout: the image pitch d (1 + v/L) / mu along a row, times sqrt(3)/2 between the
        rows of a hex grid). Computed by the core."""
        return self._core.micro_image_steps(channel)

    def resolution_step(self, z: float) -> float:
        """delta(z) = mu_1 z / L_1 [mm]: one pixel of a conventional camera on channel 1's
        array plane, projected onto the plane at depth z (docs/model.md §9)."""
        return self._core.resolution_step(float(z))

    @property
    def core(self) -> _native.DesignCore:
        """The native handle (for the functions of this package)."""
        return self._core


def _toml_string(text: str) -> str:
    """A TOML basic string (the values written are plain names: no escapes needed)."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _toml_field(name: str, value: Any) -> str | None:
    """``name = value`` in TOML, or None for a field left to its default None."""
    if value is None:
        return None
    if name == "f":
        return f"f = [{', '.join(repr(x) for x in value)}]"
    if name in ("grid", "layout"):
        return f"{name} = {_toml_string(value)}"
    if name in _COUNT_LIMITS:
        return f"{name} = {int(value)}"
    return f"{name} = {value!r}"


class _in_source:
    """Context manager: errors of a constructor re-raised with ``source: `` in front (the
    same class, and for :class:`InvalidParameter` the same name, value and allowed range,
    ``name`` qualified by ``channel`` when given)."""

    def __init__(self, source: str, channel: int | None = None) -> None:
        self.source = source
        self.channel = channel

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: Any, e: Any, tb: Any) -> Literal[False]:
        if isinstance(e, InvalidParameter):
            name = e.name if self.channel is None else f"channels[{self.channel}].{e.name}"
            raise InvalidParameter(f"{self.source}: {e}", name=name, value=e.value,
                                   allowed=e.allowed, index=e.index) from None
        if isinstance(e, TypeError):
            raise TypeError(f"{self.source}: {e}") from None
        return False


def missing_fields(table: Any, where: str, what: str, allowed: tuple[str, ...],
                   required: tuple[str, ...]) -> list[str]:
    """The ``required`` keys that ``table`` (a mapping of ``what`` fields read from
    ``where``) lacks; ``TypeError`` when it is not a dict, ``ValueError`` for keys not in
    ``allowed``."""
    if not isinstance(table, dict):
        raise TypeError(f"{where}: expected a table of {what} fields, got "
                        f"{type(table).__name__}")
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise ValueError(f"{where}: unknown {what} field(s) {unknown}; allowed fields: "
                         f"{', '.join(allowed)}")
    return [k for k in required if k not in table]


def _channel_from_dict(table: Any, where: str, number: int) -> Channel:
    """Channel ``number`` (from 1) of a design's mapping, its errors prefixed by ``where``."""
    missing = missing_fields(table, where, "channel", CHANNEL_FIELDS, _REQUIRED_CHANNEL_FIELDS)
    if missing:
        # A field of the wrong type is named even when others are missing too: the
        # Channel's own checks run on the given fields, with stand-ins for the missing.
        stand_in = {"L": 1.0, "d": 1.0, "v": 1.0, "mu": 1.0, "Kx": 1, "Ky": 1}
        with _in_source(where, number):
            Channel(**{**{k: stand_in[k] for k in missing}, **table})
        raise ValueError(f"{where}: missing channel field(s) {missing}")
    with _in_source(where, number):
        return Channel(**table)
