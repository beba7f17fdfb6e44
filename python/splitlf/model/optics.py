"""Closed-form optics over depth (docs/model.md §2, Eqs. 1-7) and the depth of field of any
:class:`~splitlf.Design` (docs/model.md §9; the split-sensor :class:`~splitlf.Camera` is
one; result shapes in docs/architectures.md).

Thin wrappers: the arithmetic runs in the Rust core, vectorised and parallel over depth.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .. import _native, _validate
from .design import Design

__all__ = ["Curves", "DepthOfField", "curves", "depth_of_field", "sharp_fractions"]

#: Default sharpness threshold on the blur radius, in pixels (from the core).
DEFAULT_THRESHOLD_PX: float = _native.DEFAULT_THRESHOLD_PX


@dataclasses.dataclass(frozen=True)
class Curves:
    """Closed forms of a :class:`~splitlf.Design` at n depths (docs/architectures.md).
    For the split sensor (:class:`~splitlf.Camera`), row 0 is half 1, row 1 half 2.

    Rows are named: ``channels`` names the rows of the per-channel arrays
    (``"channel 1"``, ...), ``rows`` those of the per-lens-type arrays, one per (channel,
    lens type): ``"channel c"`` for a channel with one lens type (Ng's setting or one
    focal length), ``"channel c type t"`` for each type of a channel with several.

    - ``z`` (n,) depths [mm]; ``conjugate`` (n,) z' = F z / (z - F) [mm]
    - per channel (C, n): ``main_blur`` H = (D L / 2) |1/z' - 1/L| [mm], ``repetitions``
      2 H / d, ``conventional_px`` H / mu [px], ``channel_blur_px`` the smallest
      ``blur_px`` of the channel's lens types [px] (the channel is sharp where it is below
      the threshold)
    - per lens type (R, n): ``microlens_blur`` b_t = (d v / 2) |1/f_t - 1/(L - z') - 1/v|
      [mm] (unbounded), ``blur_px`` min(b_t, R) / mu with R = D v / (2 L) [px]
    - ``union_blur_px`` (n,) the smallest ``blur_px`` of all rows [px]: the design is
      sharp where it is below the threshold
    """

    z: np.ndarray
    conjugate: np.ndarray
    channels: tuple[str, ...]
    rows: tuple[str, ...]
    main_blur: np.ndarray
    repetitions: np.ndarray
    conventional_px: np.ndarray
    channel_blur_px: np.ndarray
    microlens_blur: np.ndarray
    blur_px: np.ndarray
    union_blur_px: np.ndarray


def _channel_names(n: int) -> tuple[str, ...]:
    return tuple(f"channel {i}" for i in range(1, n + 1))


def _type_names(rows: list[tuple[int, int]]) -> tuple[str, ...]:
    """Names of the per-type rows ((channel, type) from 0, as the core lists them)."""
    types: dict[int, int] = {}
    for c, _ in rows:
        types[c] = types.get(c, 0) + 1
    return tuple(f"channel {c + 1}" if types[c] == 1 else f"channel {c + 1} type {t + 1}"
                 for c, t in rows)


def curves(design: Design, z: Any, n_threads: int | None = None) -> Curves:
    """Evaluate every closed form (Eqs. 1-7) at the depths ``z``.

    Parameters:
        design: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one).
        z: depths in mm: a number or any 1-D array-like of real numbers (n,), each finite
            and > F. Integers are converted to float64; a float64 array is not copied.
        n_threads: threads of the core (an integer in [1, ``_native.MAX_THREADS``]);
            ``None`` (default) uses all cores.

    Returns:
        :class:`Curves`: ``z`` (n,), per-channel arrays (C, n), per-lens-type arrays
        (R, n) with named rows, and their union (n,). Float64 throughout.

    Raises:
        TypeError: ``design`` is not a Design, ``z`` is not real, ``n_threads`` is not an
            integer.
        InvalidParameter: (a ``ValueError``) ``z`` is not 1-D, or an element is not finite
            or not > F (``.name == "z"``, ``.index`` the element), or ``n_threads`` is out
            of range.
        TooLargeError: (a ``MemoryError``) the outputs (8 (2 + 4 C + 2 R) bytes per depth)
            do not fit in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of about a million depths).
    """
    subject = _validate.design(design)
    zs = _validate.depths(z)
    threads = _validate.n_threads(n_threads)
    d = _native.design_curves(subject.core, zs, threads)
    return Curves(zs, d.conjugate, _channel_names(len(subject.channels)),
                  _type_names(d.rows), d.main_blur, d.repetitions, d.conventional_px,
                  d.channel_blur_px, d.microlens_blur, d.blur_px, d.union_blur_px)


Intervals = list[tuple[float, float]]


def _json_intervals(iv: Intervals) -> list[list[float | None]]:
    return [[a, None if math.isinf(b) else b] for a, b in iv]


@dataclasses.dataclass(frozen=True)
class DepthOfField:
    """Sharp depth intervals (near, far) of a :class:`~splitlf.Design`, in mm, open,
    sorted; ``far`` may be ``inf`` (docs/architectures.md).

    ``rows`` names the light field rows and ``intervals`` holds theirs, in this order: for
    each channel, each of its lens types (``"channel c type t"``, only when it has several)
    and then the channel (``"channel c"``: sharp where any of its types is); last
    ``"union"`` (sharp where any channel is), when the design has several channels.
    ``channels`` names the rows of ``conventional``: the camera without microlenses with
    its sensor on that channel's array plane (blur H / mu). ``dof[name]`` is a row's
    intervals; :attr:`union` is the design's (the ``"union"`` row, or the only channel's).
    """

    threshold_px: float
    rows: tuple[str, ...]
    intervals: tuple[Intervals, ...]
    channels: tuple[str, ...]
    conventional: tuple[Intervals, ...]

    def __getitem__(self, name: str) -> Intervals:
        try:
            return self.intervals[self.rows.index(name)]
        except ValueError:
            raise KeyError(f"{name!r}: the rows are {', '.join(self.rows)}") from None

    @property
    def union(self) -> Intervals:
        """Where the design is sharp: the last row (the union, or the only channel)."""
        return self.intervals[-1]

    # The split sensor's words (docs/model.md §1): half i is channel i.
    @property
    def half1(self) -> Intervals:
        """Channel 1's intervals (half 1 of the split sensor)."""
        return self["channel 1"]

    @property
    def half2(self) -> Intervals:
        """Channel 2's intervals (half 2 of the split sensor); ``KeyError`` for a design
        with one channel."""
        return self["channel 2"]

    @property
    def split(self) -> Intervals:
        """Where the design is sharp (:attr:`union`): for the split sensor, where either
        half is."""
        return self.union

    @property
    def conventional1(self) -> Intervals:
        """The conventional camera with its sensor on channel 1's array plane."""
        return self.conventional[0]

    @property
    def conventional2(self) -> Intervals:
        """The conventional camera with its sensor on channel 2's array plane;
        ``IndexError`` for a design with one channel."""
        return self.conventional[1]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``threshold_px``, ``light_field`` and ``conventional`` (row
        name -> list of [near, far], an infinite ``far`` as ``None``)."""
        return {
            "threshold_px": self.threshold_px,
            "light_field": {n: _json_intervals(iv)
                            for n, iv in zip(self.rows, self.intervals, strict=True)},
            "conventional": {n: _json_intervals(iv)
                             for n, iv in zip(self.channels, self.conventional, strict=True)},
        }


def _dof(design: Design, t: float) -> DepthOfField:
    r = _native.design_depth_of_field(design.core, t)
    type_names = _type_names(r.rows)
    rows: list[str] = []
    intervals: list[Intervals] = []
    for c, channel in enumerate(_channel_names(len(design.channels))):
        own = [k for k, (ch, _) in enumerate(r.rows) if ch == c]
        if len(own) > 1:
            rows += [type_names[k] for k in own]
            intervals += [r.types[k] for k in own]
        rows.append(channel)
        intervals.append(r.channels[c])
    if len(design.channels) > 1:
        rows.append("union")
        intervals.append(r.union)
    return DepthOfField(t, tuple(rows), tuple(intervals),
                              _channel_names(len(design.channels)), tuple(r.conventional))


def depth_of_field(design: Design, threshold_px: float = DEFAULT_THRESHOLD_PX
                   ) -> DepthOfField:
    """Sharp depth intervals of each configuration, every boundary solved in closed form
    (the blur equations inverted; no sampling).

    Parameters:
        design: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one).
        threshold_px: a depth is sharp where the blur radius is below this many pixels
            (a finite number > 0; default ``DEFAULT_THRESHOLD_PX`` = 0.5).

    Returns:
        :class:`DepthOfField`: per lens type, per channel, their union, and the
        conventional cameras (``.half1``, ``.half2``, ``.split`` name the split sensor's).
        Each configuration is a sorted list of disjoint open intervals (near, far) in mm
        with near < far; ``far`` may be ``inf``.

    Raises:
        TypeError: ``design`` is not a Design, or ``threshold_px`` is not a real number.
        InvalidParameter: ``threshold_px`` is not finite or not > 0.
    """
    subject = _validate.design(design)
    t = _validate.real(threshold_px, "threshold_px")
    return _dof(subject, t)


def sharp_fractions(design: Design, z_range: tuple[float, float],
                    threshold_px: float = DEFAULT_THRESHOLD_PX) -> dict[str, float]:
    """Fraction of the depth range that is sharp, measured in log depth, for each
    configuration of :func:`depth_of_field`.

    Parameters:
        design: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one).
        z_range: (near, far) in mm, finite, 0 < near < far.
        threshold_px: as in :func:`depth_of_field` (default 0.5 px).

    Returns:
        Row name -> fraction in [0, 1]: the summed log length of the sharp intervals inside
        the range over log(far / near). The keys are the rows of :func:`depth_of_field`
        (``DepthOfField.rows``: lens types where a channel has several, each channel,
        ``"union"`` when there are several channels), then ``"conventional channel 1"``,
        ... (one per channel). For the split sensor ``"channel 1"`` is half 1 and
        ``"union"`` the split sensor.

    Raises:
        TypeError: ``design`` is not a Design, a bound or ``threshold_px`` is not a real
            number.
        InvalidParameter: the range is not 0 < near < far (finite), or ``threshold_px``
            is not finite and > 0.
    """
    subject = _validate.design(design)
    lo, hi = (_validate.real(v, "z_range") for v in z_range)
    t = _validate.real(threshold_px, "threshold_px")
    return _fractions(subject, t, lo, hi)


def _fractions(design: Design, t: float, lo: float, hi: float) -> dict[str, float]:
    """:func:`sharp_fractions` in the row order of :func:`_dof`."""
    types, channels, union, conventional = _native.design_sharp_fractions(design.core, t, lo, hi)
    rows = _native.design_depth_of_field(design.core, t).rows
    type_names = _type_names(rows)
    out: dict[str, float] = {}
    names = _channel_names(len(design.channels))
    for c, channel in enumerate(names):
        own = [k for k, (ch, _) in enumerate(rows) if ch == c]
        if len(own) > 1:
            out.update({type_names[k]: types[k] for k in own})
        out[channel] = channels[c]
    if len(design.channels) > 1:
        out["union"] = union
    out.update({f"conventional {name}": v for name, v in zip(names, conventional, strict=True)})
    return out
