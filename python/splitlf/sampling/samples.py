"""Coincidence planes, genuinely new samples (Eqs. 8-9) and resolution at every depth.

docs/model.md §6; derivations in ``docs/samples.md``. Thin wrappers: the counts run in the
Rust core (``splitlf._native``), parallel over depths with the GIL released.

Every function takes a :class:`~splitlf.Camera` (rows half 1, half 2, union) or a
:class:`~splitlf.Design` (rows "channel 1", ..., "union"; rect grids only, the 1-D analysis
of docs/model.md §9; see docs/architectures.md, "The 1-D engine"). A Camera's half i is its
design's channel i.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .. import _native, _validate
from ..errors import InvalidParameter
from ..model.design import Design

__all__ = [
    "CoincidencePlanes",
    "NewSamples",
    "coincidence_planes",
    "new_samples",
    "sweep_depths",
    "worst_resolution",
]

#: Column order of :class:`CoincidencePlanes`.
PLANE_COLUMNS = (
    "N", "T", "side", "conjugate", "z", "repetitions",
    "new_samples_x", "new_samples_y", "new_samples", "counted",
)


#: Default merge tolerance in units of delta(z), and default largest N (from the core).
DEFAULT_TOL: float = _native.DEFAULT_TOL
DEFAULT_MAX_N: int = _native.DEFAULT_MAX_N


@dataclasses.dataclass(frozen=True)
class CoincidencePlanes:
    """Coincidence planes of one half (docs/model.md §6), one row per plane, sorted by depth ``z``
    (nearest to the camera first). Every column is a NumPy array of the same length.

    - ``N``, ``T`` (int64): coprime, microlenses j and j + N share a sample with pixel
      indices T apart
    - ``side`` (str): ``"far"`` beyond the half's out-of-focus plane (z' = L/(1 + r)),
      ``"near"`` in front of it (z' = L/(1 - r)), r = N d v / (T mu L)
    - ``conjugate`` z' and ``z`` [mm]; ``repetitions`` 2 H / d (Eqs. 4-5)
    - ``new_samples_x``, ``new_samples_y``: one factor of Eq. 8/9 each (K_x, K_y) with the
      lit pixel count Q_lit in place of Q; ``new_samples`` their product
    - ``counted``: the exact number of distinct chief samples over every lit pixel of the
      2D half, counted by brute force in the core (not from the formula)
    """

    half: int
    N: np.ndarray
    T: np.ndarray
    side: np.ndarray
    conjugate: np.ndarray
    z: np.ndarray
    repetitions: np.ndarray
    new_samples_x: np.ndarray
    new_samples_y: np.ndarray
    new_samples: np.ndarray
    counted: np.ndarray
    #: The channel number (a Design's; for a Camera the same as ``half``).
    channel: int | None = None

    def __len__(self) -> int:
        return len(self.z)

    def columns(self) -> dict[str, np.ndarray]:
        """The columns in order, as a dict of arrays."""
        return {c: getattr(self, c) for c in PLANE_COLUMNS}

    def rows(self) -> list[dict[str, Any]]:
        """JSON-ready rows (plain Python numbers)."""
        cols = self.columns()
        return [{c: v[i].item() for c, v in cols.items()} for i in range(len(self))]

    def to_pandas(self) -> Any:
        """The table as a ``pandas.DataFrame`` (needs pandas)."""
        try:
            import pandas as pd
        except ImportError as e:
            raise ImportError(
                "CoincidencePlanes.to_pandas() needs pandas: pip install pandas"
            ) from e
        return pd.DataFrame(self.columns())


def coincidence_planes(
    camera: Design,
    half: int | None = None,
    max_n: int = DEFAULT_MAX_N,
    max_t: int | None = None,
    n_threads: int | None = None,
    *,
    channel: int | None = None,
) -> CoincidencePlanes:
    """Every coincidence plane of one half with coprime N <= ``max_n`` and T <= ``max_t``,
    on both sides of its out-of-focus plane wherever it exists (1 - r > 0 and z' > F),
    with Eq. 8/9 and the brute-force count of distinct chief samples.

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one). For a Design the
            channel must have a rect grid and the ideal layout, and the aperture must be
            square (where docs/model.md §6 holds); anything else is refused.
        half: the channel number from 1 (half 1 or 2 of the split sensor); or pass ``channel``.
        max_n: largest N, an integer in [1, ``_native.MAX_PAIRS``] (default 4).
        max_t: largest T, an integer in [1, ``_native.MAX_PAIRS``]; ``None`` (default)
            for Q. At most ``_native.MAX_PAIRS`` (N, T) pairs in all.
        n_threads: threads of the core, ``None`` (default) for all cores.
        channel: the channel number (from 1) of a Design; give ``half`` or ``channel``.

    Returns:
        :class:`CoincidencePlanes`, one row per plane, sorted by depth. For a Design the
        brute-force count merges within 1e-6 delta(z), delta(z) = mu_1 z / L_1.

    Raises:
        TypeError: ``camera`` is not a Design; ``half``/``channel``,
            ``max_n``, ``max_t`` or ``n_threads`` is not an integer (bools refused; any
            size accepted); both or neither of ``half`` and ``channel``.
        InvalidParameter: (a ``ValueError`` with ``.name``) a parameter out of range, or
            ``max_n * max_t`` above ``_native.MAX_PAIRS``; for a Design, a hex channel
            (``channels[i].grid``), a sensor layout (``channels[i].layout``) or a circular
            aperture (``aperture``).
        TooLargeError: (a ``MemoryError``) K Q above ``_native.MAX_SAMPLES_PER_AXIS``; the
            brute-force count (planes x (Kx + Ky) x Q_lit sample positions) above
            ``_native.MAX_COINCIDENCE_WORK`` (refused before any counting; lower ``max_n``
            or ``max_t``); or the buffers do not fit in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of planes).
    """
    subject = _validate.design(camera)
    h = _validate.channel_number(subject, half, channel)
    n = _validate.integer(max_n, "max_n", "an integer >= 1")
    t = None if max_t is None else _validate.integer(max_t, "max_t", "an integer >= 1 or None")
    threads = _validate.n_threads(n_threads)
    r = _native.design_coincidence_planes(subject.core, h, n, t, threads)
    return CoincidencePlanes(
        h, r.N, r.T, np.array(r.side, dtype="<U4"), r.conjugate, r.z, r.repetitions,
        r.new_samples_x, r.new_samples_y, r.new_samples, r.counted, h,
    )


@dataclasses.dataclass(frozen=True)
class NewSamples:
    """Distinct samples along x and resolution of a :class:`~splitlf.Design` at m depths.
    Rows (``rows``): ``"channel 1"``, ..., ``"channel C"``, then ``"union"`` of all
    channels (also for a single channel, as in :func:`splitlf.coverage`).

    - ``z`` (m,) depths [mm]; ``tol`` merge tolerance in delta(z) = mu_1 z / L_1
      (docs/model.md §9, "Scale and field"); ``sample`` mode
    - ``distinct`` (C + 1, m) int64: distinct samples along x (the merge rule of
      docs/samples.md §4, positions closer than ``tol * delta(z)`` merge)
    - ``max_gap`` (C + 1, m): largest gap between consecutive samples along x over the
      central field |X| <= K_x d_1 z / (4 L_1) of channel 1, in delta(z); ``inf`` when the
      samples do not cover the field
    - ``sampled`` (C + 1,) int64: pixels along x that yield a sample, per channel and in
      all (chief: lit; centroid: area at least 1e-9 of the channel's largest)

    The 2-D counts of a design are :func:`splitlf.coverage`'s (connected components in
    2-D, docs/model.md §9); this result has no ``distinct_2d``.
    """

    z: np.ndarray
    tol: float
    sample: str
    rows: tuple[str, ...]
    distinct: np.ndarray
    max_gap: np.ndarray
    sampled: np.ndarray

    def __getitem__(self, name: str) -> dict[str, np.ndarray]:
        """One row by name: ``{"distinct": (m,), "max_gap": (m,)}``."""
        try:
            k = self.rows.index(name)
        except ValueError:
            raise KeyError(f"{name!r}: the rows are {', '.join(self.rows)}") from None
        return {"distinct": self.distinct[k], "max_gap": self.max_gap[k]}


def _rows(design: Design) -> tuple[str, ...]:
    return (*(f"channel {i}" for i in range(1, len(design.channels) + 1)), "union")


def new_samples(
    camera: Design,
    z: Any,
    tol: float = DEFAULT_TOL,
    sample: str = "chief",
    n_threads: int | None = None,
) -> NewSamples:
    """Count the distinct sample positions of each half and of the split sensor at every
    depth, and the worst gap between them (docs/model.md §6).

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one) (every channel on
            a rect grid; ideal or sensor layout).
        z: depths in mm: a number or any 1-D array-like (m,), each finite and > F.
        tol: merge tolerance in units of delta(z) = mu_1 z / L_1 (docs/model.md §9; for a
            Camera mu z / v', which is §6's d z / (Q v') only when d = Q mu),
            finite and >= 0
            (default ``DEFAULT_TOL`` = 1e-6; 0 merges only equal positions).
        sample: ``"chief"`` (default: the chief ray's projection, the paper's convention;
            lit pixels only) or ``"centroid"`` (the projection of each pixel's
            integration-polygon centroid, docs/model.md §5; every pixel that collects
            light, so partially vignetted pixels count too).
        n_threads: threads of the core, ``None`` (default) for all cores.

    Returns:
        :class:`NewSamples` with (C + 1, m) arrays: rows the channels (for the split
        sensor half 1, half 2), then their union; ``max_gap`` in delta(z) = mu_1 z / L_1
        (docs/model.md §9; §6's d z / (Q v') is the same when d = Q mu).

    Raises:
        TypeError: ``camera`` is not a Design; ``z`` or ``tol`` is not
            real; ``sample`` is not a string; ``n_threads`` is not an integer.
        InvalidParameter: (a ``ValueError``) ``z`` is not 1-D or an element is not finite
            or not > F (``.name == "z"``, ``.index``); ``tol`` is negative or not finite;
            ``sample`` is not "chief"/"centroid"; ``n_threads`` is out of range; a Design
            channel on a hex grid (``channels[i].grid``).
        TooLargeError: (a ``MemoryError``) Kx Q or Ky Q above
            ``_native.MAX_SAMPLES_PER_AXIS``, or the outputs (72 bytes per depth), the
            layout and the per-thread buffers (about 16 bytes per pixel of both halves
            along one axis, per thread; centroid mode also holds one trace, 168 bytes per
            pixel) do not fit in the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of depths).
    """
    subject = _validate.design(camera)
    zs = _validate.depths(z)
    t = _validate.real(tol, "tol")
    s = _validate.choice(sample, "sample", ("chief", "centroid"))
    threads = _validate.n_threads(n_threads)
    d = _native.design_new_samples(subject.core, zs, t, s, threads)
    return NewSamples(zs, t, s, _rows(subject), d.distinct, d.max_gap, d.sampled)


def sweep_depths(
    camera: Design, z_range: tuple[float, float], n: int = 600, max_n: int = 3
) -> np.ndarray:
    """Depths for a resolution sweep: ``n`` log-spaced depths over ``z_range`` plus, inside
    it, both out-of-focus planes and every coincidence plane (N <= ``max_n``, T <= Q) of
    both halves — where the counts dip and the gaps peak — so that the worst case is
    sampled exactly.

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one). For a Design the
            out-of-focus planes of every channel are added, and the coincidence planes of
            every channel where they are defined (rect grid, ideal layout, square
            aperture); other channels contribute their out-of-focus plane only.
        z_range: (near, far) in mm with F < near < far < inf.
        n: number of log-spaced depths, an integer >= 2 (default 600).
        max_n: largest N of the coincidence planes added (default 3).

    Returns:
        Sorted, unique float64 depths [mm] inside ``z_range``.

    Raises:
        TypeError: a bound is not real, ``n`` or ``max_n`` is not an integer.
        InvalidParameter: ``z_range`` is not F < near < far < inf, ``n`` < 2, or ``max_n``
            is out of range (see :func:`coincidence_planes`).
    """
    cam = _validate.design(camera)
    lo, hi = (_validate.real(v, "z_range") for v in z_range)
    if not (cam.F < lo < hi < np.inf):
        raise InvalidParameter.of("z_range", (lo, hi), f"F = {cam.F} mm < near < far < inf")
    n = _validate.integer(n, "n", "an integer >= 2")
    if n < 2:
        raise InvalidParameter.of("n", n, "an integer >= 2")
    numbers = range(1, len(cam.channels) + 1)
    extra = [cam.design.out_of_focus_depth(c) for c in numbers]
    for c in numbers:
        ch = cam.channels[c - 1]
        if ch.grid == "rect" and ch.layout == "ideal" and cam.aperture == "square":
            extra.extend(coincidence_planes(cam, channel=c, max_n=max_n).z)
    z = np.concatenate([np.geomspace(lo, hi, n), extra])
    return np.unique(z[(z >= lo) & (z <= hi)])


def worst_resolution(
    camera: Design,
    z_range: tuple[float, float] = (150.0, 10_000.0),
    n: int = 2000,
    max_n: int = 3,
    tol: float = DEFAULT_TOL,
    n_threads: int | None = None,
) -> dict[str, Any]:
    """Largest max gap (worst resolution, in delta(z)) of half 1, half 2 and the split
    sensor over ``z_range``, on :func:`sweep_depths` (``n`` log-spaced depths plus the
    out-of-focus and coincidence planes, N <= ``max_n``).

    Parameters:
        camera: a :class:`splitlf.Design` (a :class:`splitlf.Camera` is one) (rect channels).
        z_range: (near, far) in mm, F < near < far < inf (default 150 to 10,000 mm).
        n, max_n: as in :func:`sweep_depths` (defaults 2000 and 3).
        tol: merge tolerance in delta(z), as in :func:`new_samples` (default 1e-6).
        n_threads: threads of the core, ``None`` (default) for all cores.

    Returns:
        A JSON-ready dict: ``z_range_mm``, ``depths`` (how many), ``sampling`` (in words)
        and for ``half1``, ``half2``, ``split`` (a Design: each row name, ``"channel 1"``,
        ..., ``"union"``): ``max_gap`` (None when infinite), the depth ``z_mm`` where it
        occurs and ``min_distinct`` (fewest distinct samples along x).

    Raises:
        The errors of :func:`sweep_depths` and :func:`new_samples`.
    """
    z = sweep_depths(camera, z_range, n=n, max_n=max_n)
    r = new_samples(camera, z, tol=tol, n_threads=n_threads)
    out: dict[str, Any] = {
        "z_range_mm": [float(z_range[0]), float(z_range[1])],
        "depths": int(z.size),
        "sampling": f"{n} log-spaced depths plus the out-of-focus planes and the "
                    f"coincidence planes (N <= {max_n}) of all channels inside the range",
    }
    for row, key in enumerate(r.rows):
        k = int(np.argmax(r.max_gap[row]))
        g = float(r.max_gap[row, k])
        out[key] = {
            "max_gap": None if not np.isfinite(g) else g,
            "z_mm": float(z[k]),
            "min_distinct": int(r.distinct[row].min()),
        }
    return out
