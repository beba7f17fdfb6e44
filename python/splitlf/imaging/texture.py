"""Textures: albedos T(X, Y) >= 0 on object space (docs/model.md §10, "Textures").

X, Y are object-space positions [mm] on a plane in front of the main lens, X right, Y up,
0 on the optical axis. Each texture is an exact function of (X, Y); the 1-D
:func:`~splitlf.simulate` reads the row Y = 0 (an :class:`Image` the row it names) through
``antiderivative`` (exact cell averages along X), and :func:`~splitlf.render` hands the
whole 2-D texture to the core through ``seam`` (the native scene's description).

- :class:`Sinusoid`: mean + amplitude sin(2 pi f X + phase), constant along Y
- :class:`BarChart`: a square wave along X, constant along Y
- :class:`SlantedEdge`: two albedos either side of a straight edge
- :class:`SiemensStar`: ``spokes`` bright sectors around a centre
- :class:`RandomAlbedo`: i.i.d. uniform albedos on square cells, drawn per use
- :class:`Image`: a user array of albedos, ``width`` mm wide, centred on the axis
- :class:`Constant`: one albedo everywhere (a number given as a :class:`~splitlf.Scene`'s
  texture is one)

Colour (docs/model.md §12): an :class:`Image` of shape (rows, cols, 3) holds three albedos
(red, green, blue) per cell, and :class:`ColourTexture` puts any three of the textures
above together, one per colour. A colour texture renders only through a colour filter
array (``render(..., cfa=...)``); every other texture is grey, the same albedo in every
colour. ``texture.colour(k)`` is colour k's grey texture (k = 0 red, 1 green, 2 blue).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import sys
from typing import Any

import numpy as np

from .. import _validate
from .._validate import finite as _finite
from .._validate import positive as _positive
from ..errors import InvalidParameter, TooLargeError

__all__ = [
    "MAX_ALBEDO",
    "MAX_RANDOM_CELLS",
    "MAX_SPOKES",
    "TEXTURES",
    "COLOURS",
    "BarChart",
    "ColourTexture",
    "Constant",
    "Image",
    "RandomAlbedo",
    "SiemensStar",
    "Sinusoid",
    "SlantedEdge",
]

#: Sinusoids of the MTF search (and :class:`Sinusoid`'s defaults): mean and amplitude.
MTF_MEAN, MTF_AMPLITUDE = 0.5, 0.4
#: Most spokes of a :class:`SiemensStar` (far beyond what any sensor resolves).
MAX_SPOKES = 100_000
#: Most cells of a 2-D :class:`RandomAlbedo` drawn for one render (8 bytes each: 1 GiB).
MAX_RANDOM_CELLS = 2**27
#: Largest albedo accepted (the core's bound: far beyond any physical albedo, small enough
#: that a pixel's integral and an image's sum cannot overflow).
MAX_ALBEDO = 1e100

#: The colours of a colour texture and a colour filter array, by index.
COLOURS = ("red", "green", "blue")

#: The description of a texture for the native scene: (kind, params, image or None).
Seam = tuple[str, list[float], np.ndarray | None]


# -- validation helpers (shared with splitlf.imaging.render) -------------------------------

def albedo(value: Any, name: str) -> float:
    """A finite albedo in [0, :data:`MAX_ALBEDO`], else ``TypeError`` /
    :class:`InvalidParameter` naming ``name``."""
    return _validate.nonnegative(value, name, MAX_ALBEDO)


def _center(value: Any, name: str = "center") -> tuple[float, float]:
    """A point (X0, Y0) of two finite reals [mm]."""
    if isinstance(value, str | bytes) or not hasattr(value, "__len__") or len(value) != 2:
        raise TypeError(f"{name} must be a pair (X0, Y0) of finite numbers in mm, "
                        f"got {value!r}")
    return _finite(value[0], f"{name}[0]"), _finite(value[1], f"{name}[1]")


def _steps_antiderivative(breaks: np.ndarray, values: np.ndarray, x: np.ndarray
                          ) -> np.ndarray:
    """The integral from 0 to x of the step function equal to values[0] left of breaks[0],
    values[i] on (breaks[i-1], breaks[i]) and values[-1] right of breaks[-1] (breaks
    sorted, len(values) = len(breaks) + 1)."""
    n = breaks.size
    cum = np.concatenate([[0.0], np.cumsum(values[1:-1] * np.diff(breaks))])

    def h(t: np.ndarray) -> np.ndarray:  # the integral from breaks[0] to t
        i = np.searchsorted(breaks, t)
        j = np.clip(i - 1, 0, n - 1)
        return cum[j] + values[i] * (t - breaks[j])

    x = np.asarray(x, dtype=np.float64)
    return h(x) - h(np.zeros(1))[0]


# -- the textures ----------------------------------------------------------------------------

class _TwoTones:
    """What the textures of two albedos share (:class:`BarChart`, :class:`SlantedEdge`,
    :class:`SiemensStar`): ``low`` and ``high`` checked, over equal shares of the plane."""

    low: float
    high: float

    def _check_tones(self) -> None:
        albedo(self.low, "low")
        albedo(self.high, "high")

    @property
    def mean(self) -> float:
        """The mean albedo (low + high) / 2: the bars, the two sides of the edge and the
        star's bright and dark sectors each cover half the plane."""
        return 0.5 * (float(self.low) + float(self.high))


@dataclasses.dataclass(frozen=True)
class Sinusoid:
    """mean + amplitude sin(2 pi frequency X + phase), constant along Y; frequency in
    cycles/mm on the object, X the object-space position [mm] (0 on the optical axis).

    ``frequency`` finite > 0; ``mean``, ``amplitude`` finite >= 0 with amplitude <= mean
    (albedo >= 0); ``phase`` [rad]. Raises ``TypeError`` (not real numbers) and
    :class:`~splitlf.errors.InvalidParameter` (out of range)."""

    frequency: float
    mean: float = MTF_MEAN
    amplitude: float = MTF_AMPLITUDE
    phase: float = 0.0

    def __post_init__(self) -> None:
        _positive(self.frequency, "frequency")
        m, a = albedo(self.mean, "mean"), albedo(self.amplitude, "amplitude")
        _validate.real(self.phase, "phase")
        if a > m:
            raise ValueError(f"invalid amplitude = {a}: allowed <= mean = {m} (albedo >= 0)")

    def antiderivative(self, x: np.ndarray) -> np.ndarray:
        """The integral of the albedo along X (at any Y) from 0 to each X in ``x`` [mm]
        (any shape); its differences give exact cell averages."""
        w = 2 * np.pi * self.frequency
        return self.mean * x - self.amplitude / w * np.cos(w * x + self.phase)

    def seam(self) -> Seam:
        """The native scene's description: ("sinusoid", [frequency, mean, amplitude,
        phase], None)."""
        return "sinusoid", [float(self.frequency), float(self.mean), float(self.amplitude),
                            float(self.phase)], None


@dataclasses.dataclass(frozen=True)
class BarChart(_TwoTones):
    """A square wave along X, constant along Y: ``high`` on the first half of each period,
    ``low`` on the second; ``frequency`` in bar pairs (cycles) per mm on the object, a bar
    edge at X = 0 (high on [0, 1/(2 frequency))).

    ``frequency`` finite > 0; ``low``, ``high`` finite albedos >= 0. Raises ``TypeError``
    (not real numbers) and :class:`~splitlf.errors.InvalidParameter` (out of range)."""

    frequency: float
    low: float = 0.1
    high: float = 0.9

    def __post_init__(self) -> None:
        _positive(self.frequency, "frequency")
        self._check_tones()

    def antiderivative(self, x: np.ndarray) -> np.ndarray:
        """The integral of the albedo along X from 0 to each X in ``x`` [mm] (any shape)."""
        s = self.frequency * x
        k = np.floor(s)
        high_part = 0.5 * k + np.minimum(s - k, 0.5)  # high-bar length, in periods
        return self.low * x + (self.high - self.low) * high_part / self.frequency

    def seam(self) -> Seam:
        """The native scene's description: ("bars", [frequency, low, high], None)."""
        return "bars", [float(self.frequency), float(self.low), float(self.high)], None


@dataclasses.dataclass(frozen=True)
class SlantedEdge(_TwoTones):
    """Two albedos either side of a straight edge through ``center`` (X0, Y0) [mm], at
    ``angle`` degrees from the +Y axis turning towards +X (0: a vertical edge): ``high``
    where (X - X0) cos(angle) - (Y - Y0) sin(angle) >= 0 (the side of +X), ``low``
    elsewhere. The classic slanted-edge MTF target is a few degrees (default 5).

    ``angle`` finite [deg]; ``low``, ``high`` finite albedos >= 0; ``center`` a pair of
    finite numbers [mm]. Raises ``TypeError`` (not real numbers, not a pair) and
    :class:`~splitlf.errors.InvalidParameter` (out of range)."""

    angle: float = 5.0
    low: float = 0.1
    high: float = 0.9
    center: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        _finite(self.angle, "angle")
        self._check_tones()
        object.__setattr__(self, "center", _center(self.center))

    def albedo(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The albedo at the points (x, y) [mm] (broadcast arrays)."""
        a = math.radians(self.angle)
        x0, y0 = self.center
        side = (np.asarray(x) - x0) * math.cos(a) - (np.asarray(y) - y0) * math.sin(a)
        return np.where(side >= 0, float(self.high), float(self.low))

    def antiderivative(self, x: np.ndarray) -> np.ndarray:
        """The integral of the albedo along the row Y = 0 from X = 0 to each X in ``x``
        [mm] (any shape): the 1-D :func:`~splitlf.simulate` reads that row."""
        a = math.radians(self.angle)
        c, s = math.cos(a), math.sin(a)
        x0, y0 = self.center
        x = np.asarray(x, dtype=np.float64)
        lo, hi = float(self.low), float(self.high)
        if c == 0.0:  # the edge along the row: one albedo on all of it
            return (hi if y0 * s >= 0 else lo) * x
        big = sys.float_info.max
        xe = min(max(x0 - y0 * s / c, -big), big)  # where the row crosses the edge
        if c > 0:  # high for X >= xe
            high_len = np.maximum(x, xe) - max(0.0, xe)
        else:  # high for X <= xe
            high_len = np.minimum(x, xe) - min(0.0, xe)
        return lo * x + (hi - lo) * high_len

    def seam(self) -> Seam:
        """The native scene's description: ("edge", [angle, low, high, X0, Y0], None)."""
        return "edge", [float(self.angle), float(self.low), float(self.high),
                        *self.center], None


@dataclasses.dataclass(frozen=True)
class SiemensStar(_TwoTones):
    """A Siemens star of ``spokes`` bright sectors centred at ``center`` (X0, Y0) [mm]:
    with the polar angle t = atan2(Y - Y0, X - X0) in [0, 2 pi), the albedo is ``high``
    where floor(t spokes / pi) is even, ``low`` elsewhere (the first bright sector starts
    along +X).

    ``spokes`` an integer in [1, :data:`MAX_SPOKES`]; ``low``, ``high`` finite albedos
    >= 0; ``center`` a pair of finite numbers [mm]. Raises ``TypeError`` and
    :class:`~splitlf.errors.InvalidParameter`."""

    spokes: int = 36
    low: float = 0.1
    high: float = 0.9
    center: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        n = _validate.integer_in(self.spokes, "spokes", 1, MAX_SPOKES,
                                 f"an integer in [1, {MAX_SPOKES}]")
        object.__setattr__(self, "spokes", n)
        self._check_tones()
        object.__setattr__(self, "center", _center(self.center))

    def albedo(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The albedo at the points (x, y) [mm] (broadcast arrays)."""
        x0, y0 = self.center
        t = np.arctan2(np.asarray(y, dtype=np.float64) - y0,
                       np.asarray(x, dtype=np.float64) - x0)
        t = np.where(t < 0, t + 2 * np.pi, t)
        even = np.floor(t * self.spokes / np.pi) % 2 == 0
        return np.where(even, float(self.high), float(self.low))

    def _row_breaks(self) -> np.ndarray:
        """Where the row Y = 0 crosses a sector boundary, sorted."""
        x0, y0 = self.center
        dy = -y0  # the row relative to the centre
        if dy == 0:
            return np.array([x0])
        t = np.arange(2 * self.spokes) * (np.pi / self.spokes)
        s = np.sin(t)
        keep = (np.sign(s) == np.sign(dy)) & (np.abs(s) > 1e-15)
        return np.unique(x0 + dy * np.cos(t[keep]) / s[keep])

    def antiderivative(self, x: np.ndarray) -> np.ndarray:
        """The integral of the albedo along the row Y = 0 from X = 0 to each X in ``x``
        [mm] (any shape): the 1-D :func:`~splitlf.simulate` reads that row (a row through
        the centre runs along sector boundaries: it takes the albedo the formula gives
        there)."""
        b = self._row_breaks()
        pad = max(1.0, float(np.abs(b).max()))
        probe = np.concatenate([[b[0] - pad], 0.5 * (b[1:] + b[:-1]), [b[-1] + pad]])
        return _steps_antiderivative(b, self.albedo(probe, np.zeros_like(probe)), x)

    def seam(self) -> Seam:
        """The native scene's description: ("star", [spokes, low, high, X0, Y0], None)."""
        return "star", [float(self.spokes), float(self.low), float(self.high),
                        *self.center], None


@dataclasses.dataclass(frozen=True)
class RandomAlbedo:
    """Independent albedos uniform in [low, high] on square cells of ``cell`` mm (default
    delta(z) at the scene's depth, :meth:`splitlf.Design.resolution_step`), aligned with
    X = 0 and Y = 0, drawn afresh from the seeded generator of each use (the simulation's,
    the render's). A row of a 2D i.i.d. albedo field is a 1D i.i.d. albedo, so the 1-D
    simulation draws the row only.

    ``cell`` [mm] finite > 0 or None; 0 <= ``low`` <= ``high``, finite. Raises
    ``TypeError`` and :class:`~splitlf.errors.InvalidParameter`."""

    cell: float | None = None
    low: float = 0.0
    high: float = 1.0

    def __post_init__(self) -> None:
        if self.cell is not None:
            _positive(self.cell, "cell")
        lo, hi = albedo(self.low, "low"), albedo(self.high, "high")
        if hi < lo:
            raise ValueError(f"invalid high = {hi}: allowed >= low = {lo}")

    @property
    def mean(self) -> float:
        """The expected albedo (low + high) / 2."""
        return 0.5 * (float(self.low) + float(self.high))

    def seam(self, extent: tuple[float, float, float, float], step: float,
             rng: np.random.Generator) -> Seam:
        """An image texture of i.i.d. cells covering ``extent`` (X0, X1, Y0, Y1) [mm]:
        cells of ``cell`` mm (``step`` when ``cell`` is None), their edges on multiples of
        the cell, drawn by ``rng.uniform(low, high, (rows, cols))`` (row 0 at the top).
        :class:`~splitlf.errors.TooLargeError` beyond :data:`MAX_RANDOM_CELLS` cells."""
        cell = _positive(step, "cell") if self.cell is None else float(self.cell)
        x0, x1, y0, y1 = extent
        span = [x0 / cell, x1 / cell, y0 / cell, y1 / cell]
        if not all(math.isfinite(v) for v in span) or (
                (span[1] - span[0]) * (span[3] - span[2]) > 1e200):
            # Far beyond any memory (the cells' count may not even be a float): the cell
            # is at fault, and the least one this scene allows is known.
            least = math.sqrt((x1 - x0) * (y1 - y0) / MAX_RANDOM_CELLS)
            raise InvalidParameter.of("cell", cell, f"a cell of at least {least:.3g} mm for "
                                      f"this scene (at most {MAX_RANDOM_CELLS} cells)")
        k0, k1 = math.floor(span[0]), math.ceil(span[1])
        j0, j1 = math.floor(span[2]), math.ceil(span[3])
        cols, rows = max(k1 - k0, 1), max(j1 - j0, 1)
        if rows * cols > MAX_RANDOM_CELLS:
            raise TooLargeError(
                f"a random texture of {rows} x {cols} cells of {cell:g} mm "
                f"({rows * cols * 8 / 2**30:.1f} GiB) to cover the scene; the limit is "
                f"{MAX_RANDOM_CELLS} cells: give RandomAlbedo a larger cell",
                what="RandomAlbedo", nbytes=rows * cols * 8, limit=MAX_RANDOM_CELLS * 8)
        image = rng.uniform(float(self.low), float(self.high), size=(rows, cols))
        return "image", [k0 * cell, (k0 + cols) * cell, j0 * cell, (j0 + rows) * cell], image


@dataclasses.dataclass(frozen=True, eq=False)
class Image:
    """A user image: a 2D array of albedos (finite, >= 0) ``width`` mm wide on the object,
    centred on the optical axis, in square cells of width/cols mm: X in [-width/2,
    width/2], Y in [-height/2, height/2] with height = width rows / cols; row 0 at the
    top (largest Y), column 0 at the left (smallest X). Outside the image the albedo is
    the array's mean (the 1-D simulation, which reads one row, ``row``, default the middle
    one: that row's mean).

    A (rows, cols, 3) array is a colour image (docs/model.md §12): three albedos per
    cell, red, green and blue; :meth:`colour` gives each colour's grey image (outside the
    image: that colour's mean). It renders through a colour filter array only
    (``render(..., cfa=...)``); the 1-D simulation refuses it.

    ``array``: 2D (rows, columns) or 3D (rows, columns, 3) numeric array; ``width`` [mm]
    finite > 0; ``row`` an integer in [0, rows) or None. Raises ``TypeError`` (dtype, row
    type) and ``ValueError`` (shape, non-finite or negative albedo, range)."""

    array: np.ndarray
    width: float
    row: int | None = None

    def __post_init__(self) -> None:
        a = np.asarray(self.array)
        if a.dtype == object or not (np.issubdtype(a.dtype, np.floating)
                                     or np.issubdtype(a.dtype, np.integer)
                                     or a.dtype == np.bool_):
            raise TypeError(f"Image.array must be a numeric 2D array, got dtype {a.dtype}")
        if a.ndim not in (2, 3) or min(a.shape) < 1 or (a.ndim == 3 and a.shape[2] != 3):
            raise InvalidParameter.of("Image.array", f"an array of shape {a.shape}",
                                      "a non-empty 2D array (rows, cols) or a colour "
                                      "array (rows, cols, 3)")
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > MAX_ALBEDO):
            raise InvalidParameter.of("Image.array", "values outside the range",
                                      f"finite albedos in [0, {MAX_ALBEDO:g}]")
        _positive(self.width, "width")
        if self.row is not None:
            if isinstance(self.row, bool) or not isinstance(self.row, numbers.Integral):
                raise TypeError(f"Image.row must be an integer or None, got {self.row!r}")
            if not 0 <= int(self.row) < a.shape[0]:
                raise ValueError(f"invalid row = {self.row}: allowed 0..{a.shape[0] - 1}")
        a.setflags(write=False)
        object.__setattr__(self, "array", a)

    @property
    def is_colour(self) -> bool:
        """Whether the image holds three colours (a (rows, cols, 3) array)."""
        return self.array.ndim == 3

    def colour(self, k: int) -> Image:
        """Colour ``k``'s grey image (0 red, 1 green, 2 blue); a grey image is itself."""
        k = colour_index(k)
        if not self.is_colour:
            return self
        return Image(self.array[:, :, k], self.width, self.row)

    @property
    def mean(self) -> float:
        """The array's mean albedo (the albedo outside the image in 2-D; a colour image's
        mean over its three colours)."""
        return float(self.array.mean())

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(X0, X1, Y0, Y1) [mm]: the image on the object, centred on the axis."""
        rows, cols = self.array.shape[:2]
        w = float(self.width)
        h = w * rows / cols
        return -w / 2, w / 2, -h / 2, h / 2

    def _grey(self, what: str) -> None:
        if self.is_colour:
            raise InvalidParameter.of("texture", "a colour Image (rows, cols, 3)",
                                      f"a grey texture for {what}; render a colour "
                                      "texture with cfa=..., or take Image.colour(k)")

    def line(self) -> np.ndarray:
        """The row the simulation reads (``row``, default the middle one), shape (width,)."""
        self._grey("the 1-D simulation")
        r = self.array.shape[0] // 2 if self.row is None else int(self.row)
        return self.array[r]

    def seam(self) -> Seam:
        """The native scene's description: ("image", [X0, X1, Y0, Y1], array)."""
        self._grey("a render without a colour filter array")
        return "image", list(self.extent), np.ascontiguousarray(self.array)


@dataclasses.dataclass(frozen=True)
class Constant:
    """One albedo everywhere (a number given as a :class:`~splitlf.Scene`'s texture is
    one): a scene of it renders to ``albedo`` × the white raw.

    ``albedo`` finite in [0, :data:`MAX_ALBEDO`]. Raises ``TypeError`` and
    :class:`~splitlf.errors.InvalidParameter`."""

    albedo: float = 1.0

    def __post_init__(self) -> None:
        if isinstance(self.albedo, bool | np.bool_):
            raise TypeError(f"albedo must be a real number, got {self.albedo!r}")
        object.__setattr__(self, "albedo", albedo(self.albedo, "albedo"))

    @property
    def mean(self) -> float:
        """The albedo."""
        return float(self.albedo)

    def antiderivative(self, x: np.ndarray) -> np.ndarray:
        """The integral of the albedo along X from 0 to each X in ``x`` [mm]."""
        return self.albedo * np.asarray(x, dtype=np.float64)

    def seam(self) -> Seam:
        """The native scene's description: ("constant", [albedo], None)."""
        return "constant", [float(self.albedo)], None


def colour_index(k: Any) -> int:
    """A colour index 0 (red), 1 (green) or 2 (blue), else ``TypeError`` /
    :class:`InvalidParameter` naming ``colour``."""
    return _validate.integer_in(k, "colour", 0, 2, "0 (red), 1 (green) or 2 (blue)")


@dataclasses.dataclass(frozen=True)
class ColourTexture:
    """A colour texture of three grey ones (docs/model.md §12): ``red``, ``green`` and
    ``blue``, each a :class:`Sinusoid`, :class:`BarChart`, :class:`SlantedEdge`,
    :class:`SiemensStar`, :class:`RandomAlbedo` (drawn once per colour, red first),
    grey :class:`Image`, :class:`Constant` or a number (a Constant). It renders through a
    colour filter array only (``render(..., cfa=...)``). Raises ``TypeError``."""

    red: Any
    green: Any
    blue: Any

    def __post_init__(self) -> None:
        for name in COLOURS:
            tex = getattr(self, name)
            if isinstance(tex, numbers.Real) and not isinstance(tex, bool | np.bool_):
                tex = Constant(float(tex))
            if not isinstance(tex, TEXTURES) or (isinstance(tex, Image) and tex.is_colour):
                raise TypeError(f"ColourTexture.{name} must be a grey texture (Sinusoid, "
                                "BarChart, SlantedEdge, SiemensStar, RandomAlbedo, grey "
                                f"Image, Constant or a number), got {type(tex).__name__}")
            object.__setattr__(self, name, tex)

    def colour(self, k: int) -> Any:
        """Colour ``k``'s grey texture (0 red, 1 green, 2 blue)."""
        return getattr(self, COLOURS[colour_index(k)])

    @property
    def mean(self) -> float:
        """The mean of the three colours' mean albedos."""
        return sum(float(self.colour(k).mean) for k in range(3)) / 3


#: The texture classes (every one works in 1-D :func:`~splitlf.simulate` and in
#: :func:`~splitlf.render`).
TEXTURES = (Sinusoid, BarChart, SlantedEdge, SiemensStar, RandomAlbedo, Image, Constant)
#: The textures with an exact ``antiderivative`` along X.
ANALYTIC = (Sinusoid, BarChart, SlantedEdge, SiemensStar, Constant)


def texture_mean(texture: Any) -> float:
    """The mean albedo of a texture of :data:`TEXTURES` (the default background)."""
    return float(texture.mean)
