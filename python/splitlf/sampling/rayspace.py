"""Ray-space engine (docs/model.md §3-5): every pixel's integration polygon in (u, w) and its
footprint on a scene plane at any depth.

Thin wrappers: the geometry runs in the Rust core (parallel, GIL released); this module
checks argument types and packs the arrays. Derivations: ``docs/rayspace.md``.

:func:`trace` and :func:`footprints` take a :class:`~splitlf.Camera` and its ``half``, or a
:class:`~splitlf.Design` and its ``channel`` (numbered from 1; rect grids only, the 1-D
analysis of docs/model.md §9; see docs/architectures.md, "The 1-D engine"). A Camera's
half i is its design's channel i, bit for bit.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import numpy as np

from .. import _native, _validate
from ..model.design import Design

__all__ = ["Footprints", "SampleGrid", "Trace", "footprints", "sample_grid", "trace"]


@dataclasses.dataclass(frozen=True)
class Trace:
    """Every pixel of one half (or channel) along one axis: n = K Q, microlens-major (index
    j Q + q) for the ideal layout; n = M (sensor order, index m) for a design channel's
    sensor layout.

    - ``vertices`` (n, 6, 2): (u, w) of the integration polygon [mm], counter-clockwise,
      unused rows NaN (u: height on plane v', w: height on the main lens)
    - ``n_vertices`` (n,): vertex count (0 for a fully vignetted pixel)
    - ``area`` (n,): polygon area [mm^2], proportional to the light collected
    - ``centroid`` (n, 2): (u, w) of the polygon's centroid (NaN when empty)
    - ``lens``, ``pixel`` (n,): microlens index j and pixel index q under it (sensor
      layout: the lens whose image centre is nearest, and the sensor index m)
    - ``chief`` (n, 2): (u, w) of the chief ray (through microlens and pixel centres)
    - ``lit`` (n,): the chief ray passes the main-lens aperture (docs/model.md §6; sensor
      layout: and the pixel centre lies in its lens's image cell)
    - ``theta`` (n,): offset of the pixel centre from its lens's image centre c (1 + v/L)
      [mm]; ``type`` (n,): its lens's type j mod T (its focal length is ``f[type]``)
    - ``half``: the half (Camera) or channel (Design) number; ``channel`` the same number
    """

    half: int
    axis: str
    vertices: np.ndarray
    n_vertices: np.ndarray
    area: np.ndarray
    centroid: np.ndarray
    lens: np.ndarray
    pixel: np.ndarray
    chief: np.ndarray
    lit: np.ndarray
    theta: np.ndarray | None = None
    type: np.ndarray | None = None
    channel: int | None = None


def trace(camera: Design, half: int | None = None, axis: str = "x",
          n_threads: int | None = None, *, channel: int | None = None) -> Trace:
    """Integration polygon of every pixel of one half along one axis (docs/model.md §3-4).

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one) (rect channels).
        half: the channel number from 1 (half 1 or 2 of the split sensor); or pass ``channel``.
        axis: ``"x"`` (Kx microlenses, default) or ``"y"`` (Ky microlenses; for a Design
            the lens types along y are k mod T).
        n_threads: threads of the core, an integer in [1, ``_native.MAX_THREADS``];
            ``None`` (default) for all cores.
        channel: the channel number (from 1) of a Design (the same as ``half`` for a
            Camera); give ``half`` or ``channel``, not both.

    Returns:
        :class:`Trace` of n = K Q pixels (K = Kx or Ky; M for a sensor layout), with the
        shapes listed there.

    Raises:
        TypeError: ``camera`` is not a Design; ``half``/``channel`` or
            ``n_threads`` is not an integer (bools are refused); both or neither of
            ``half`` and ``channel`` given; ``axis`` is not a string.
        InvalidParameter: (a ``ValueError`` with ``.name``, ``.value``, ``.allowed``)
            ``half`` is not 1 or 2 (``channel`` not in [1, C]), ``axis`` not "x"/"y",
            ``n_threads`` out of range; a Design's channel on a hex grid
            (``.name == "channels[i].grid"``).
        TooLargeError: (a ``MemoryError``) the trace and its arrays (about 330 bytes per
            pixel) do not fit in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of pixels).
    """
    subject = _validate.design(camera)
    h = _validate.channel_number(subject, half, channel)
    ax = _validate.choice(axis, "axis", ("x", "y"))
    threads = _validate.n_threads(n_threads)
    r = _native.design_trace(subject.core, h, ax, threads)
    return Trace(h, ax, r.vertices, r.n_vertices, r.area, r.centroid, r.lens, r.pixel,
                 r.chief, r.lit, r.theta, r.type, h)


@dataclasses.dataclass(frozen=True)
class Footprints:
    """Footprints of n pixels (one half, one axis; order of :func:`trace`) at m depths.

    - ``position`` (m, n): object-space sample position X on the plane at each depth [mm];
      NaN where the pixel yields no sample (centroid: no light; chief: chief ray
      outside the aperture)
    - ``lo``, ``hi`` (m, n): extent of the footprint in X [mm] (NaN when no light)
    - ``kernel_breaks``, ``kernel_values`` (m, n, 6), only with ``kernel=True``: the
      piecewise-linear weight profile, breakpoints in X ascending [mm] and the aperture
      length (along w, mm) of the rays from that point that the pixel collects; NaN-padded
    """

    z: np.ndarray
    half: int
    axis: str
    sample: str
    position: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    kernel_breaks: np.ndarray | None = None
    kernel_values: np.ndarray | None = None
    #: The channel number (a Design's; for a Camera the same as ``half``).
    channel: int | None = None


def footprints(
    camera: Design,
    z: Any,
    half: int | None = None,
    axis: str = "x",
    sample: str = "centroid",
    kernel: bool = False,
    n_threads: int | None = None,
    *,
    channel: int | None = None,
) -> Footprints:
    """Footprint of every pixel of one half along one axis on the planes at depths ``z``
    (docs/model.md §5).

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one) (rect channels).
        z: depths in mm: a number or any 1-D array-like (m,), each finite and > F.
        half: the channel number from 1 (half 1 or 2 of the split sensor); or pass ``channel``.
        axis: ``"x"`` (default) or ``"y"``.
        sample: ``"centroid"`` (default: projection of the integration polygon's centroid)
            or ``"chief"`` (projection of the chief ray, the paper's convention).
        kernel: also return the piecewise-linear weight profiles (m, n, 6); default False.
        n_threads: threads of the core, ``None`` (default) for all cores.
        channel: the channel number (from 1) of a Design; give ``half`` or ``channel``.

    Returns:
        :class:`Footprints` of n pixels (order of :func:`trace`) at m depths. For a Design
        X = -p' z / L_1: ray space is referred to channel 1's array plane.

    Raises:
        TypeError: ``camera`` is not a Design; ``z`` is not real;
            ``half``/``channel`` or ``n_threads`` is not an integer (bools refused); both
            or neither of ``half`` and ``channel``; ``axis``/``sample`` is not a string;
            ``kernel`` is not a bool.
        InvalidParameter: (a ``ValueError``) ``z`` is not 1-D or an element is not finite
            or not > F (``.name == "z"``, ``.index`` the element); ``half``/``channel``,
            ``axis``, ``sample`` or ``n_threads`` is out of range; a hex channel
            (``channels[i].grid``).
        TooLargeError: (a ``MemoryError``) the outputs (24 bytes per depth and pixel, 120
            with ``kernel``) and working buffers (about 290 bytes per pixel) do not fit
            in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of depths).
    """
    subject = _validate.design(camera)
    zs = _validate.depths(z)
    h = _validate.channel_number(subject, half, channel)
    ax = _validate.choice(axis, "axis", ("x", "y"))
    s = _validate.choice(sample, "sample", ("centroid", "chief"))
    if not isinstance(kernel, bool | np.bool_):
        raise TypeError(f"kernel must be a bool, got {type(kernel).__name__} {kernel!r}")
    threads = _validate.n_threads(n_threads)
    r = _native.design_footprints(subject.core, zs, h, ax, s, bool(kernel), threads)
    return Footprints(zs, h, ax, s, r.position, r.lo, r.hi, r.kernel_breaks, r.kernel_values,
                      h)


@dataclasses.dataclass(frozen=True)
class SampleGrid:
    """Object-space sample positions of the full 2D sensor of one half on one plane.

    ``X``, ``Y`` (Ky Q, Kx Q) [mm]: rows along y, columns along x, each microlens-major;
    NaN where the pixel yields no sample. Unpacks as ``X, Y = sample_grid(...)``.
    """

    z: float
    half: int
    sample: str
    X: np.ndarray
    Y: np.ndarray
    #: The channel number (a Design's; for a Camera the same as ``half``).
    channel: int | None = None

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.X, self.Y))


def sample_grid(
    camera: Design, z: Any, half: int | None = None, sample: str = "chief",
    n_threads: int | None = None, *, channel: int | None = None,
) -> SampleGrid:
    """Sample position of every pixel of the full 2D sensor of one half on one plane.

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one) (rect channel).
        z: the plane's depth in mm, finite and > F: one depth only, given as a number, a
            0-d array or an array-like of exactly one element.
        half: the channel number from 1 (half 1 or 2 of the split sensor); or pass ``channel``.
        sample: ``"chief"`` (default, the paper's convention) or ``"centroid"`` (a
            Design's: square aperture only).
        n_threads: threads of the core, ``None`` (default) for all cores.
        channel: the channel number (from 1) of a Design; give ``half`` or ``channel``.

    Returns:
        :class:`SampleGrid` with ``X``, ``Y`` of shape (Ky Q, Kx Q) in mm ((My, Mx) for a
        sensor layout; NaN where a pixel yields no sample); unpacks as
        ``X, Y = sample_grid(...)``. For a Design X = -p' z / L_1 per axis (docs/model.md
        §5), the same values as :func:`splitlf.chief_samples` up to rounding.

    Raises:
        TypeError: ``camera`` is not a Design; ``z`` is not real;
            ``half``/``channel`` or ``n_threads`` is not an integer (bools refused); both
            or neither of ``half`` and ``channel``; ``sample`` is not a string.
        InvalidParameter: (a ``ValueError``) ``z`` holds more than one depth, is not
            finite or not > F; ``half``/``channel``, ``sample`` or ``n_threads`` is out of
            range; a hex channel (``channels[i].grid``); ``sample="centroid"`` behind a
            circular aperture (``aperture``).
        TooLargeError: (a ``MemoryError``) the two outputs (16 bytes per pixel of the
            2D half-sensor) do not fit in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of rows).
    """
    subject = _validate.design(camera)
    zf = _validate.depth(z)
    h = _validate.channel_number(subject, half, channel)
    s = _validate.choice(sample, "sample", ("centroid", "chief"))
    threads = _validate.n_threads(n_threads)
    r = _native.design_sample_grid(subject.core, zf, h, s, threads)
    return SampleGrid(zf, h, s, r.X, r.Y, h)
