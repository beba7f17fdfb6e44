"""Coincidence planes, genuinely new samples (Eqs. 8-9) and resolution at every depth.

docs/model.md §6; derivations in ``docs/samples.md``. Thin wrappers: the counts run in the
Rust core (``splitlf._native``), parallel over depths with the GIL released.
"""

from __future__ import annotations

import dataclasses
import numbers
from typing import Any

import numpy as np

from . import _native, _validate
from .camera import Camera

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


def _int(value: Any, name: str, allow_none: bool = False) -> int | None:
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        kind = "an integer >= 1" + (" or None" if allow_none else "")
        raise TypeError(f"{name} must be {kind}, got {value!r}")
    return int(value)


def _half(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"half must be 1 or 2, got {value!r}")
    if int(value) not in (1, 2):
        raise ValueError(f"invalid half = {value}: allowed 1 or 2")
    return int(value)


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

    def __len__(self) -> int:
        return len(self.z)

    def columns(self) -> dict[str, np.ndarray]:
        """The columns in order, as a dict of arrays."""
        return {c: getattr(self, c) for c in PLANE_COLUMNS}

    def rows(self) -> list[dict[str, Any]]:
        """JSON-ready rows (plain Python numbers)."""
        cols = self.columns()
        return [{c: v[i].item() for c, v in cols.items()} for i in range(len(self))]

    def to_pandas(self):
        """The table as a ``pandas.DataFrame`` (needs pandas)."""
        try:
            import pandas as pd
        except ImportError as e:
            raise ImportError(
                "CoincidencePlanes.to_pandas() needs pandas: pip install pandas"
            ) from e
        return pd.DataFrame(self.columns())


def coincidence_planes(
    camera: Camera,
    half: int,
    max_n: int = 4,
    max_t: int | None = None,
    n_threads: int | None = None,
) -> CoincidencePlanes:
    """Every coincidence plane of ``half`` with coprime N <= ``max_n`` and T <= ``max_t``
    (default Q), on both sides of its out-of-focus plane wherever it exists (1 - r > 0 and
    z' > F), with Eq. 8/9 and the brute-force count of distinct chief samples."""
    cam = _validate.camera(camera)
    h = _half(half)
    n = _int(max_n, "max_n")
    t = _int(max_t, "max_t", allow_none=True)
    cols = _native.coincidence_planes(cam.core, h, n, t, _validate.n_threads(n_threads))
    values = list(cols)
    values[2] = np.array(values[2], dtype="<U4")
    return CoincidencePlanes(h, *values)


@dataclasses.dataclass(frozen=True)
class NewSamples:
    """Distinct samples and resolution at m depths. Rows: 0 half 1, 1 half 2, 2 the split
    sensor (union of both halves).

    - ``z`` (m,) depths [mm]; ``tol`` merge tolerance in units of delta(z); ``sample`` mode
    - ``distinct`` (3, m) int64: distinct samples along x (positions closer than
      ``tol * delta(z)`` merge; see docs/samples.md for the exact rule)
    - ``distinct_2d`` (3, m) int64: over the whole 2D half-sensors (separable count)
    - ``max_gap`` (3, m): largest gap between consecutive samples along x over the central
      field |X| <= K_x d z / (4 v'), in units of delta(z) = d z / (Q v'); about 1 is full
      sensor resolution, Q the microlens resolution; ``inf`` when the samples do not cover
      the field
    - ``lit`` (3,) int64: pixels along x that yield a sample (``chief``: lit, K_x Q_lit;
      ``centroid``: collecting any light) of half 1, of half 2, their sum
    """

    z: np.ndarray
    tol: float
    sample: str
    distinct: np.ndarray
    distinct_2d: np.ndarray
    max_gap: np.ndarray
    lit: np.ndarray


def new_samples(
    camera: Camera,
    z,
    tol: float = 1e-6,
    sample: str = "chief",
    n_threads: int | None = None,
) -> NewSamples:
    """Count the distinct sample positions of each half and of the split sensor at every
    depth in ``z`` (mm, each finite and > F), and the worst gap between them.

    ``sample`` is ``"chief"`` (the chief ray's projection, the paper's convention; lit pixels
    only) or ``"centroid"`` (the projection of each pixel's integration-polygon centroid,
    docs/model.md §5; every pixel that collects light, so partially vignetted pixels count too).
    """
    cam = _validate.camera(camera)
    zs = _validate.depths(z)
    t = _validate.real(tol, "tol")
    if not isinstance(sample, str):
        raise TypeError(f"sample must be \"chief\" or \"centroid\", got {sample!r}")
    out = _native.new_samples(cam.core, zs, t, sample, _validate.n_threads(n_threads))
    return NewSamples(zs, t, sample, *out)


def sweep_depths(
    camera: Camera, z_range: tuple[float, float], n: int = 600, max_n: int = 3
) -> np.ndarray:
    """Depths for a resolution sweep: ``n`` log-spaced depths over ``z_range`` plus, inside
    it, both out-of-focus planes and every coincidence plane (N <= ``max_n``, T <= Q) of
    both halves — where the counts dip and the gaps peak — so that the worst case is
    sampled exactly. Sorted, unique."""
    cam = _validate.camera(camera)
    lo, hi = (_validate.real(v, "z_range") for v in z_range)
    if not (cam.F < lo < hi < np.inf):
        raise ValueError(
            f"invalid z_range = ({lo}, {hi}): allowed F = {cam.F} mm < near < far < inf"
        )
    n = _int(n, "n")
    if n < 2:
        raise ValueError(f"invalid n = {n}: allowed an integer >= 2")
    extra = [cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)]
    for h in (1, 2):
        extra.extend(coincidence_planes(cam, h, max_n=max_n).z)
    z = np.concatenate([np.geomspace(lo, hi, n), extra])
    return np.unique(z[(z >= lo) & (z <= hi)])


def worst_resolution(
    camera: Camera,
    z_range: tuple[float, float] = (150.0, 10_000.0),
    n: int = 2000,
    max_n: int = 3,
    tol: float = 1e-6,
    n_threads: int | None = None,
) -> dict[str, Any]:
    """Largest max gap (worst resolution, in delta(z)) of half 1, half 2 and the split
    sensor over ``z_range``, on :func:`sweep_depths` (``n`` log-spaced depths plus the
    out-of-focus and coincidence planes, N <= ``max_n``). JSON-ready (inf -> None)."""
    z = sweep_depths(camera, z_range, n=n, max_n=max_n)
    r = new_samples(camera, z, tol=tol, n_threads=n_threads)
    out: dict[str, Any] = {
        "z_range_mm": [float(z_range[0]), float(z_range[1])],
        "depths": int(z.size),
        "sampling": f"{n} log-spaced depths plus the out-of-focus planes and the "
                    f"coincidence planes (N <= {max_n}) of both halves inside the range",
    }
    for row, key in enumerate(("half1", "half2", "split")):
        k = int(np.argmax(r.max_gap[row]))
        g = float(r.max_gap[row, k])
        out[key] = {
            "max_gap": None if not np.isfinite(g) else g,
            "z_mm": float(z[k]),
            "min_distinct": int(r.distinct[row].min()),
        }
    return out
