"""The camera description: an immutable, validated set of docs/model.md symbols.

Validation of ranges and every derived optical value live in the Rust core
(`splitlf._native.CameraCore`); this module checks Python types, holds the fields, and
reads and writes TOML.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
from typing import TYPE_CHECKING, Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10 (the tomli backport)
    import tomli as tomllib

from . import _native
from ._files import atomic_output
from .errors import InvalidParameter

if TYPE_CHECKING:
    from .design import Design

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
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(
            f"Camera.{name} must be a real number ({_DESCRIPTIONS[name]}), "
            f"got {type(value).__name__} {value!r}"
        )
    try:
        x = float(value)
    except OverflowError:  # an integer beyond the float range (e.g. a 400-digit TOML integer)
        x = math.inf if value > 0 else -math.inf
    if math.isnan(x) or math.isinf(x):
        shown = x if isinstance(value, float) else f"{str(value)[:12]}... ({x})"
        raise InvalidParameter.of(name, shown, f"a finite value ({_DESCRIPTIONS[name]})")
    return x


def _count(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(
            f"Camera.{name} must be an integer ({_DESCRIPTIONS[name]}), "
            f"got {type(value).__name__} {value!r}"
        )
    n = int(value)
    if not -(2**62) < n < 2**62:  # the core checks the range; this keeps n within an i64
        shown = n if abs(n) < 10**15 else f"{str(n)[:12]}... ({len(str(abs(n)))} digits)"
        raise InvalidParameter.of(name, shown,
                                  f"an integer in [1, {_COUNT_LIMITS[name]}]")
    return n


def _half(value: Any) -> int:
    """The half argument of the per-half methods: the integer 1 or 2 (never a bool)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"half must be the integer 1 or 2, got {type(value).__name__} {value!r}")
    if value not in (1, 2):
        raise InvalidParameter.of("half", int(value), "1 or 2 (the half of the split sensor)")
    return int(value)


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse a TOML file. Every parse error names the file: ``ValueError`` for invalid
    TOML or text that is not UTF-8 (e.g. a binary file); ``OSError`` when unreadable."""
    name = os.fspath(path)
    with open(path, "rb") as fh:
        data = fh.read()
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise ValueError(f"{name}: not a TOML text file (not UTF-8 at byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{name}: not valid TOML: {e}") from None


@dataclasses.dataclass(frozen=True)
class Camera:
    """A split-sensor light field camera (docs/model.md §1). Lengths in mm.

    Half 1 is the conventional light field camera (array at ``v1``); half 2 has its array
    at ``v1 * (1 + kappa)``. ``f1``/``f2`` default to Ng's setting, 1/f_i = 1/L_i + 1/v,
    and keep tracking it through :meth:`replace` unless given explicitly.

    Fields: ``F`` main lens focal length, ``D`` aperture width (square), ``v1`` main lens
    to array 1 (> F), ``kappa`` extra optical path of half 2 over v1 (>= 0, no unit),
    ``d`` microlens pitch, ``v`` array to sensor, ``mu`` pixel width (all mm, finite,
    > 0 unless stated); ``Q`` pixels per microlens (an integer in [1, 65535]), ``Kx``,
    ``Ky`` microlenses per half along x, y (integers in [1, 10**7]); ``f1``, ``f2``
    microlens focal lengths [mm] or None for Ng's setting.

    Raises ``TypeError`` for a field of the wrong type (a count must be an integer, never
    a bool or a float) and :class:`~splitlf.errors.InvalidParameter` (a ``ValueError``)
    for a value, given or derived, out of range. Per-half methods take ``half``, the
    integer 1 or 2 (``TypeError`` for anything else, :class:`InvalidParameter` for other
    integers). Instances are immutable, hashable, picklable.
    """

    F: float
    D: float
    v1: float
    kappa: float
    d: float
    v: float
    mu: float
    Q: int
    Kx: int
    Ky: int
    f1: float | None = None
    f2: float | None = None

    def __post_init__(self) -> None:
        values = {}
        for name in LENGTH_FIELDS:
            values[name] = _real(name, getattr(self, name))
        for name in COUNT_FIELDS:
            values[name] = _count(name, getattr(self, name))
        explicit = {}
        for name in ("f1", "f2"):
            raw = getattr(self, name)
            explicit[name] = raw is not None
            values[name] = None if raw is None else _real(name, raw)
        core = _native.CameraCore(*(values[n] for n in FIELDS))
        resolved = dict(zip(FIELDS, core.fields(), strict=True))
        for name in FIELDS:
            object.__setattr__(self, name, resolved[name])
        object.__setattr__(self, "_core", core)
        object.__setattr__(self, "_explicit", explicit)

    # -- construction -------------------------------------------------------------------
    @classmethod
    def paper(cls) -> Camera:
        """The seed design (docs/model.md §7): a reconstruction from the paper's out-of-focus
        planes, 642 mm (array 1) and 217 mm (array 2), in Ng's setting."""
        f = _native.CameraCore.paper().fields()
        return cls(*f[:10])

    def replace(self, **changes: Any) -> Camera:
        """A copy with some fields changed, validated again. Microlens focal lengths that
        were not given explicitly stay in Ng's setting for the new geometry."""
        unknown = set(changes) - set(FIELDS)
        if unknown:
            raise TypeError(
                f"unknown Camera field(s) {sorted(unknown)}; allowed fields: {', '.join(FIELDS)}"
            )
        args = self.as_dict(resolved=False)
        args.update(changes)
        return Camera(**args)

    def as_dict(self, resolved: bool = True) -> dict[str, Any]:
        """Fields as a dict; with ``resolved=False`` Ng-default focal lengths are None."""
        out = {n: getattr(self, n) for n in FIELDS}
        if not resolved:
            for n in ("f1", "f2"):
                if not self._explicit[n]:
                    out[n] = None
        return out

    def __reduce__(self):
        # Pickle the fields, never the native handle (it is rebuilt on load).
        return (_from_dict, (self.as_dict(resolved=False),))

    # -- TOML ---------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "camera") -> Camera:
        """Build from a mapping of field names (``source`` names it in messages).

        Raises ``TypeError`` when ``data`` is not a dict, ``ValueError`` naming ``source``
        for unknown or missing fields, and the errors of the constructor."""
        if not isinstance(data, dict):
            raise TypeError(
                f"{source}: expected a table of camera fields, got {type(data).__name__}"
            )
        unknown = [k for k in data if k not in FIELDS]
        if unknown:
            raise ValueError(
                f"{source}: unknown camera field(s) {unknown}; allowed fields: {', '.join(FIELDS)}"
            )
        missing = [k for k in FIELDS[:10] if k not in data]
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
        body = "\n".join(lines) + "\n"
        if path is not None:
            with atomic_output(path, force=True) as tmp:
                tmp.write_text(body, encoding="utf-8")
        return body

    # -- derived values (computed by the core) -------------------------------------------
    @property
    def rho(self) -> float:
        """rho = kappa v', the extra optical path of half 2 (one prism side) [mm]."""
        return self._core.rho()

    @property
    def f_number(self) -> float:
        """Main-lens f-number F / D."""
        return self._core.f_number()

    def L(self, half: int) -> float:
        """Array plane of half 1 or 2: L_1 = v', L_2 = v'(1 + kappa) [mm]."""
        return self._core.array_plane(_half(half))

    def out_of_focus_depth(self, half: int) -> float:
        """Depth whose conjugate lies on array ``half``: z_i = F L_i / (L_i - F) [mm]."""
        return self._core.out_of_focus_depth(_half(half))

    def lit_pixels(self, half: int) -> int:
        """Pixels per microlens (one axis) whose chief ray passes the aperture (docs/model.md
        §6)."""
        return self._core.lit_pixels(_half(half))

    def image_radius(self, half: int) -> float:
        """R_i = D v / (2 L_i): radius of one microlens image on the sensor [mm]."""
        return self._core.image_radius(_half(half))

    def ng_focal_length(self, half: int) -> float:
        """Microlens focal length of Ng's setting for this geometry, 1/(1/L_i + 1/v) [mm]."""
        return self._core.ng_focal_length(_half(half))

    def is_ng(self, half: int) -> bool:
        """True when half's microlens focal length was left to Ng's setting."""
        return not self._explicit[f"f{_half(half)}"]

    @property
    def design(self) -> Design:
        """The camera as a general two-channel :class:`~splitlf.design.Design`
        (docs/model.md §9): channel i is half i (L_1 = v', L_2 = v'(1 + kappa)), rect
        grids, the ideal layout with Q, shares 1/2 each, a square aperture, and each half's
        microlens focal length (None where it is Ng's setting)."""
        from .design import Design

        return Design._from_core(_native.DesignCore.from_camera(self._core))

    @property
    def core(self) -> _native.CameraCore:
        """The native handle (for the functions of this package)."""
        return self._core


def _from_dict(data: dict[str, Any]) -> Camera:
    return Camera(**data)
