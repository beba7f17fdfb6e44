"""2-D chief samples, distinct samples and the covering radius of a design.

docs/model.md §9 ("Chief samples in 2-D", "Scale and field", "Distinct samples in 2-D",
"Covering radius") and its "§9 implementation" subsection. Thin wrappers: everything is
computed by the Rust core (``splitlf._native``) with the GIL released; this module checks
Python types and names the results.

Every function takes a :class:`~splitlf.Design` (the split-sensor :class:`~splitlf.Camera`
is one: its halves are channels 1 and 2).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .. import _native, _validate
from ..errors import InvalidParameter
from ..model.design import Design

__all__ = [
    "DEFAULT_WINDOW",
    "MAX_TOL_2D",
    "ChiefSamples",
    "Coverage",
    "Samples2D",
    "chief_samples",
    "coverage",
    "samples_2d",
]

#: Default width of the 2-D central field, in lens pitches of channel 1 (from the core).
DEFAULT_WINDOW: float = _native.DEFAULT_WINDOW
#: Largest merge tolerance of the 2-D distinct samples, in delta(z) (from the core).
MAX_TOL_2D: float = _native.MAX_TOL_2D
#: Default merge tolerance in delta(z), the same as :func:`splitlf.new_samples`'s.
DEFAULT_TOL: float = _native.DEFAULT_TOL


def _design(value: Any) -> Design:
    return _validate.design(value)


def _rows(design: Design) -> tuple[str, ...]:
    return (*(f"channel {i}" for i in range(1, len(design.channels) + 1)), "union")


@dataclasses.dataclass(frozen=True)
class ChiefSamples:
    """The 2-D chief sample of every pixel of one channel on the plane at depth ``z``.

    Arrays are indexed like the channel's pixel grid, rows y then columns x: (My, Mx) for
    the sensor layout, (Ky Q, Kx Q) for the ideal layout (lens-major: column j Q + q_x);
    with a window of rows, (stop - start, cols) from row ``first_row``.

    - ``channel`` (from 1), ``z`` [mm], ``first_row``: the grid row of the arrays' row 0
    - ``X``, ``Y`` (rows, cols) float64: the sample [mm] on the plane,
      X = -(z/L) [c + w (L - z')/z'] (docs/model.md §9); NaN where the pixel is unlit
    - ``lit`` (rows, cols) bool: the chief ray passes the aperture (and, sensor layout, the
      pixel's centre lies in its lens's image cell)
    - ``lens`` (rows, cols, 2) int64: the pixel's lens (j, k); sensor layout: the lens whose
      image centre is nearest (ties to the lower j, then k)
    - ``type`` (rows, cols) int64: that lens's type t (its focal length is ``f[t]``)
    """

    channel: int
    z: float
    first_row: int
    X: np.ndarray
    Y: np.ndarray
    lit: np.ndarray
    lens: np.ndarray
    type: np.ndarray


@dataclasses.dataclass(frozen=True)
class Samples2D:
    """Distinct 2-D samples at one depth, one entry per row (``rows``: "channel 1", ...,
    "channel n", then "union" of all channels).

    - ``z`` [mm], ``tol`` (in delta(z)), ``window`` (lens pitches of channel 1)
    - ``samples``: one (n_k, 2) float64 array [X, Y] [mm] per row: the representatives
      (least X, then least Y, of each set of samples merged by the tolerance) inside the
      central field, sorted by X then Y
    - ``distinct`` (n_rows,) int64: their number (``len(samples[k])``)
    - ``covering_radius`` (n_rows,): the largest distance from a point of the central field
      to its nearest representative, in delta(z) = mu_1 z / L_1 (``inf`` when there is no
      sample at all); ``covering_radius_mm`` the same in mm
    """

    z: float
    tol: float
    window: float
    rows: tuple[str, ...]
    samples: tuple[np.ndarray, ...]
    distinct: np.ndarray
    covering_radius: np.ndarray
    covering_radius_mm: np.ndarray


@dataclasses.dataclass(frozen=True)
class Coverage:
    """Distinct 2-D samples and covering radii at m depths. Rows (``rows``): "channel 1",
    ..., "channel n", then "union" of all channels.

    - ``z`` (m,) [mm], ``tol`` (in delta(z)), ``window`` (lens pitches of channel 1)
    - ``distinct`` (n_rows, m) int64: distinct samples inside the 2-D central field
    - ``covering_radius`` (n_rows, m): the covering radius of the central field in
      delta(z) = mu_1 z / L_1 (1/sqrt(2) for a square grid of pitch delta; ``inf`` when
      there is no sample at all); ``covering_radius_mm`` (n_rows, m) the same in mm
    """

    z: np.ndarray
    tol: float
    window: float
    rows: tuple[str, ...]
    distinct: np.ndarray
    covering_radius: np.ndarray
    covering_radius_mm: np.ndarray


def chief_samples(
    design: Design,
    channel: int,
    z: float,
    n_threads: int | None = None,
    *,
    rows: tuple[int, int] | None = None,
) -> ChiefSamples:
    """Every pixel's chief sample, lens, lens type and lit flag for one channel on the
    plane at depth ``z`` (docs/model.md §9, "Chief samples in 2-D"), or for a window of
    its pixel rows.

    Parameters:
        design: a :class:`~splitlf.Design`, or a :class:`~splitlf.Camera` (its halves are
            channels 1 and 2).
        channel: the channel, an integer from 1 (a bool is refused).
        z: depth in mm, finite and > F (a number, or an array-like holding one).
        n_threads: threads of the core, ``None`` (default) for all cores.
        rows: ``None`` (default) for every pixel row, or ``(start, stop)``: the rows
            start..stop-1 only, 0 <= start < stop <= the grid's rows (each value equal to
            the whole grid's, bit for bit; a crop of a large sensor without its memory).

    Returns:
        :class:`ChiefSamples` with (rows, cols) arrays over the channel's pixel grid.

    Raises:
        TypeError: ``design`` is neither a Design nor a Camera; ``channel`` or
            ``n_threads`` is not an integer; ``z`` is not real.
        InvalidParameter: (a ``ValueError`` with ``.name``) ``channel`` outside
            [1, number of channels]; ``z`` not finite or not > F; ``n_threads`` out of
            range; ``rows`` not a window of the grid's rows.
        TooLargeError: (a ``MemoryError``) the outputs (41 bytes per pixel) and the
            channel's lens and pixel tables do not fit in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of rows).
    """
    d = _design(design)
    ch = _validate.integer(channel, "channel", "an integer from 1")
    zf = _validate.depth(z)
    window = None
    if rows is not None:
        if not isinstance(rows, tuple | list) or len(rows) != 2:
            raise TypeError(f"rows must be None or a pair (start, stop), got {rows!r}")
        window = (_validate.integer(rows[0], "rows[0]"), _validate.integer(rows[1], "rows[1]"))
        lim = 2**62
        if not all(-lim < v < lim for v in window):
            raise InvalidParameter.of("rows", tuple(rows), "(start, stop) with 0 <= start < "
                                      "stop <= the channel's pixel rows")
    r = _native.chief_samples(d.core, ch, zf, _validate.n_threads(n_threads), window)
    return ChiefSamples(ch, zf, 0 if window is None else window[0], r.X, r.Y, r.lit, r.lens,
                        r.type)


def samples_2d(
    design: Design,
    z: float,
    tol: float = DEFAULT_TOL,
    window: float = DEFAULT_WINDOW,
) -> Samples2D:
    """The distinct 2-D samples of every channel and of the union of all channels at one
    depth, with their number inside the central field and the field's covering radius
    (docs/model.md §9).

    Two samples are one when both coordinates differ by less than ``tol * delta(z)``
    (connected components over every lit pixel); a component is represented by its member
    of least X (then least Y). The central field is |X|, |Y| <= (window/2) d_1 z / L_1,
    clipped in each axis to half the extent of channel 1's array image.

    Parameters:
        design: a :class:`~splitlf.Design` or a :class:`~splitlf.Camera`.
        z: depth in mm, finite and > F (a number, or an array-like holding one).
        tol: merge tolerance in units of delta(z) = mu_1 z / L_1, in (0, ``MAX_TOL_2D``]
            = (0, 1] (default 1e-6); it must also be coarse enough for the design's sample
            coordinates (|X| / (tol delta) at most 2**42).
        window: width of the central field in lens pitches of channel 1, finite and > 0
            (default 16).

    Returns:
        :class:`Samples2D`, one entry per row (channels, then the union).

    Raises:
        TypeError: ``design`` is neither a Design nor a Camera; ``z``, ``tol`` or
            ``window`` is not real.
        InvalidParameter: (a ``ValueError`` with ``.name``) ``z`` not finite or not > F;
            ``tol`` or ``window`` out of range.
        TooLargeError: (a ``MemoryError``) the pixels of all channels above
            ``_native.MAX_COVERAGE_WORK``, or the samples near the field (about 640 bytes
            each) do not fit in the memory available (checked before the first pass, and
            again before any wider pass).
        KeyboardInterrupt: on Ctrl-C (checked between passes).
    """
    d = _design(design)
    zf = _validate.depth(z)
    t = _validate.real(tol, "tol")
    w = _validate.real(window, "window")
    r = _native.samples_2d(d.core, zf, t, w)
    return Samples2D(zf, t, w, _rows(d), tuple(r.samples), r.distinct, r.covering_radius,
                     r.covering_radius_mm)


def coverage(
    design: Design,
    z: Any,
    tol: float = DEFAULT_TOL,
    window: float = DEFAULT_WINDOW,
    n_threads: int | None = None,
) -> Coverage:
    """Distinct 2-D samples inside the central field and its covering radius, for every
    channel and for the union of all channels, at every depth (docs/model.md §9).

    The definitions are those of :func:`samples_2d`; the depths run in parallel.

    Parameters:
        design: a :class:`~splitlf.Design` or a :class:`~splitlf.Camera`.
        z: depths in mm: a number or any 1-D array-like (m,) of reals, each finite and > F.
        tol: merge tolerance in units of delta(z), in (0, 1] (default 1e-6); see
            :func:`samples_2d`.
        window: width of the central field in lens pitches of channel 1, finite and > 0
            (default 16).
        n_threads: threads of the core, ``None`` (default) for all cores.

    Returns:
        :class:`Coverage` with (n_channels + 1, m) arrays.

    Raises:
        TypeError: ``design`` is neither a Design nor a Camera; ``z`` is not an array of
            reals; ``tol`` or ``window`` is not real; ``n_threads`` is not an integer.
        InvalidParameter: (a ``ValueError`` with ``.name``) ``z`` not 1-D, or an element
            not finite or not > F (``.name == "z"``, ``.index``); ``tol``, ``window`` or
            ``n_threads`` out of range.
        TooLargeError: (a ``MemoryError``) pixels of all channels x depths above
            ``_native.MAX_COVERAGE_WORK``; or the outputs, tables and per-thread samples
            near the field (about 640 bytes each) do not fit in the memory available
            (checked up front for every depth's first pass, and again before any wider
            pass).
        KeyboardInterrupt: on Ctrl-C (checked between chunks of depths).
    """
    d = _design(design)
    zs = _validate.depths(z)
    t = _validate.real(tol, "tol")
    w = _validate.real(window, "window")
    r = _native.coverage(d.core, zs, t, w, _validate.n_threads(n_threads))
    return Coverage(zs, t, w, _rows(d), r.distinct, r.covering_radius, r.covering_radius_mm)
