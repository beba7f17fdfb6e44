"""The camera description: an immutable, validated set of docs/model.md symbols.

Validation of ranges and every derived optical value live in the Rust core
(`splitlf._native.CameraCore`); this module checks Python types, holds the fields, and
reads and writes TOML.
"""

from __future__ import annotations

import numbers
import os
from typing import Any

from .. import _native
from .._files import read_toml, text_file
from .._validate import field_count, field_real
from ..errors import InvalidParameter
from .design import Design, missing_fields

__all__ = ["Camera", "LENGTH_FIELDS", "COUNT_FIELDS", "FIELDS"]

#: Fields that are lengths in mm (kappa is a ratio but is a real number too).
LENGTH_FIELDS = ("F", "D", "v1", "kappa", "d", "v", "mu")
#: Fields that are integer counts.
COUNT_FIELDS = ("Q", "Kx", "Ky")
#: Every field, in constructor order.
FIELDS = LENGTH_FIELDS + COUNT_FIELDS + ("f1", "f2")

_DESCRIPTIONS = {
    "F": "main lens focal length [mm]",
    "D": "main lens aperture width (square) [mm]",
    "v1": "main lens -> microlens array of half 1, v' [mm]",
    "kappa": "extra optical path of half 2 relative to v', rho / v' [-]",
    "d": "microlens pitch = diameter [mm]",
    "v": "microlens array -> sensor [mm]",
    "mu": "pixel width [mm]",
    "Q": "pixels per microlens along one axis",
    "Kx": "microlenses per half along x",
    "Ky": "microlenses per half along y",
    "f1": "microlens focal length, half 1 [mm]",
    "f2": "microlens focal length, half 2 [mm]",
}


#: The core's upper limits of the counts (pixels per microlens, microlenses per axis).
_COUNT_LIMITS = {"Q": _native.MAX_Q, "Kx": _native.MAX_K, "Ky": _native.MAX_K}


def _real(name: str, value: Any) -> float:
    return field_real("Camera", name, value, _DESCRIPTIONS[name])


def _count(name: str, value: Any) -> int:
    return field_count("Camera", name, value, _DESCRIPTIONS[name], _COUNT_LIMITS[name])


def _half(value: Any) -> int:
    """The half argument of the per-half methods: the integer 1 or 2 (never a bool)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"half must be the integer 1 or 2, got {type(value).__name__} {value!r}")
    if value not in (1, 2):
        raise InvalidParameter.of("half", int(value), "1 or 2 (the half of the split sensor)")
    return int(value)


class Camera(Design):
    """A split-sensor light field camera in the paper's parametrisation (docs/model.md §1):
    a :class:`~splitlf.Design` with two channels, built from the paper's symbols. Lengths
    in mm.

    Half i is channel i of the design: half 1 is the conventional light field camera
    (array at ``v1``); half 2 has its array at ``v1 * (1 + kappa)``; both have rect grids
    of ``Kx`` x ``Ky`` lenses with ``Q`` x ``Q`` pixels each (the ideal layout), a share of
    1/2 of the light and a square aperture. ``f1``/``f2`` default to Ng's setting,
    1/f_i = 1/L_i + 1/v, and keep tracking it through :meth:`replace` unless given
    explicitly. A Camera *is* a Design: every function of splitlf takes it as one, and it
    equals the Design it builds (``Camera.paper() == Design.preset("seed")``).

    Fields: ``F`` main lens focal length, ``D`` aperture width (square), ``v1`` main lens
    to array 1 (> F), ``kappa`` extra optical path of half 2 over v1 (>= 0, no unit),
    ``d`` microlens pitch, ``v`` array to sensor, ``mu`` pixel width (all mm, finite,
    > 0 unless stated); ``Q`` pixels per microlens (an integer in [1, 65535]), ``Kx``,
    ``Ky`` microlenses per half along x, y (integers in [1, 10**7]); ``f1``, ``f2``
    microlens focal lengths [mm] or None for Ng's setting.

    Validated exactly as the Design it builds (docs/model.md §9), with errors naming the
    camera's own fields: ``TypeError`` for a field of the wrong type (a count must be an
    integer, never a bool or a float) and :class:`~splitlf.errors.InvalidParameter` (a
    ``ValueError``) for a value, given or derived, out of range — microlens images that
    overlap (the aperture's image behind a lens, D v / L, wider than the pitch) included.
    Per-half methods take ``half``, the integer 1 or 2 (``TypeError`` for anything else,
    :class:`InvalidParameter` for other integers). Immutable, hashable, picklable.
    """

    v1: float
    kappa: float
    d: float
    v: float
    mu: float
    Q: int
    Kx: int
    Ky: int
    f1: float
    f2: float
    _camera_core: _native.CameraCore
    _explicit: dict[str, bool]

    def __init__(self, F: float, D: float, v1: float, kappa: float, d: float, v: float,
                 mu: float, Q: int, Kx: int, Ky: int, f1: float | None = None,
                 f2: float | None = None) -> None:
        given = dict(zip(FIELDS, (F, D, v1, kappa, d, v, mu, Q, Kx, Ky, f1, f2), strict=True))
        values: dict[str, Any] = {}
        for name in LENGTH_FIELDS:
            values[name] = _real(name, given[name])
        for name in COUNT_FIELDS:
            values[name] = _count(name, given[name])
        explicit = {}
        for name in ("f1", "f2"):
            explicit[name] = given[name] is not None
            values[name] = None if given[name] is None else _real(name, given[name])
        core = _native.CameraCore(values)
        self._adopt(_native.DesignCore.from_camera(core))  # validated by the core already
        set_ = object.__setattr__
        for name, value in zip(FIELDS, core.fields(), strict=True):
            if name not in ("F", "D"):
                set_(self, name, value)
        set_(self, "_camera_core", core)
        set_(self, "_explicit", explicit)

    def __repr__(self) -> str:
        return f"Camera({', '.join(f'{n}={getattr(self, n)!r}' for n in FIELDS)})"

    # -- construction -------------------------------------------------------------------
    @classmethod
    def paper(cls) -> Camera:
        """The seed design (docs/model.md §7): a reconstruction from the paper's out-of-focus
        planes, 642 mm (array 1) and 217 mm (array 2), in Ng's setting. Equal to
        ``Design.preset("seed")``."""
        f = _native.CameraCore.paper().fields()
        return cls(*f[:10])

    def replace(self, **changes: Any) -> Camera:
        """A copy with some of the camera's fields (:data:`FIELDS`) changed, validated
        again. Microlens focal lengths that were not given explicitly stay in Ng's setting
        for the new geometry. (``cam.design.replace(...)`` changes the general design's
        fields instead.)"""
        unknown = set(changes) - set(FIELDS)
        if unknown:
            raise TypeError(
                f"unknown Camera field(s) {sorted(unknown)}; allowed fields: {', '.join(FIELDS)}"
            )
        args = self.as_dict(resolved=False)
        args.update(changes)
        return Camera(**args)

    def as_dict(self, resolved: bool = True) -> dict[str, Any]:
        """The camera's fields as a dict (:meth:`from_dict` inverts it); with
        ``resolved=False`` Ng-default focal lengths are None. ``cam.design.as_dict()`` is
        the general design's form."""
        out = {n: getattr(self, n) for n in FIELDS}
        if not resolved:
            for n in ("f1", "f2"):
                if not self._explicit[n]:
                    out[n] = None
        return out

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickle the fields, never the native handles (they are rebuilt on load).
        return (_from_dict, (self.as_dict(resolved=False),))

    # -- TOML ---------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "camera") -> Camera:
        """Build from a mapping of field names (``source`` names it in messages).

        Raises ``TypeError`` when ``data`` is not a dict, ``ValueError`` naming ``source``
        for unknown or missing fields, and the errors of the constructor."""
        missing = missing_fields(data, source, "camera", FIELDS, FIELDS[:10])
        try:  # a field of the wrong type is named even when others are missing too
            for k, value in data.items():
                if k in COUNT_FIELDS:
                    _count(k, value)
                elif value is not None or k not in ("f1", "f2"):
                    _real(k, value)
        except TypeError as e:
            raise TypeError(f"{source}: {e}") from None
        if missing:
            raise ValueError(f"{source}: missing camera field(s) {missing}")
        return cls(**data)

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> Camera:
        """Read a camera from a TOML file: fields in a ``[camera]`` table (or at top level).

        Raises ``OSError`` when the file cannot be read, ``ValueError`` naming the file for
        invalid TOML, a non-text file or unknown keys, and the errors of
        :meth:`from_dict`."""
        doc = read_toml(path)
        table = doc.get("camera", doc) if isinstance(doc.get("camera"), dict) else doc
        if table is not doc:
            extra = [k for k in doc if k != "camera"]
            if extra:
                raise ValueError(
                    f"{os.fspath(path)}: unknown top-level key(s) {extra}; "
                    "a camera file holds one [camera] table"
                )
        return cls.from_dict(table, source=os.fspath(path))

    def to_toml(self, path: str | os.PathLike[str] | None = None) -> str:
        """The camera as TOML text (exact: floats by repr). With ``path``, the file is
        also written, atomically (a temporary file in its folder, then renamed over it: an
        existing file is replaced whole or not at all); ``OSError`` if it cannot be."""
        lines = ["# splitlf camera: lengths in mm (docs/model.md symbols)", "[camera]"]
        for name in FIELDS:
            value = getattr(self, name)
            text = f"{name} = {value!r}" if name not in COUNT_FIELDS else f"{name} = {int(value)}"
            if name in ("f1", "f2") and not self._explicit[name]:
                text = f"# {text}  (Ng's setting, derived: omit to keep tracking the geometry)"
            if not text.startswith("#"):
                text = f"{text:<40} # {_DESCRIPTIONS[name]}"
            lines.append(text)
        return text_file(lines, path)

    # -- per-half values (computed by the core) ------------------------------------------
    @property
    def rho(self) -> float:
        """rho = kappa v', the extra optical path of half 2 (one prism side) [mm]."""
        return float(self._camera_core.rho())

    def L(self, half: int) -> float:
        """Array plane of half 1 or 2: L_1 = v', L_2 = v'(1 + kappa) [mm]."""
        return float(self._camera_core.array_plane(_half(half)))

    def out_of_focus_depth(self, half: int) -> float:
        """Depth whose conjugate lies on array ``half``: z_i = F L_i / (L_i - F) [mm]."""
        return float(self._camera_core.out_of_focus_depth(_half(half)))

    def lit_pixels(self, half: int) -> int:
        """Pixels per microlens (one axis) whose chief ray passes the aperture (docs/model.md
        §6)."""
        return int(self._camera_core.lit_pixels(_half(half)))

    def image_radius(self, half: int) -> float:
        """R_i = D v / (2 L_i): radius of one microlens image on the sensor [mm]."""
        return float(self._camera_core.image_radius(_half(half)))

    def ng_focal_length(self, half: int) -> float:
        """Microlens focal length of Ng's setting for this geometry, 1/(1/L_i + 1/v) [mm]."""
        return float(self._camera_core.ng_focal_length(_half(half)))

    def is_ng(self, half: int) -> bool:
        """True when half's microlens focal length was left to Ng's setting."""
        return not self._explicit[f"f{_half(half)}"]


def _from_dict(data: dict[str, Any]) -> Camera:
    return Camera(**data)
