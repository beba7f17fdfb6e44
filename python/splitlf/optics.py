"""Closed-form optics over depth (docs/model.md §2, Eqs. 1-7) and the depth of field.

Thin wrappers: the arithmetic runs in the Rust core, vectorised and parallel over depth.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import _native, _validate
from .camera import Camera

__all__ = ["Curves", "DepthOfField", "curves", "depth_of_field", "sharp_fractions"]


@dataclasses.dataclass(frozen=True)
class Curves:
    """Closed forms at n depths. Two-row arrays: row 0 half 1, row 1 half 2.

    - ``z`` (n,) depths [mm]; ``conjugate`` (n,) z' = F z / (z - F) [mm] (Eq. 1)
    - ``main_blur`` (2, n) H_i, main-lens blur radius on array plane i [mm]
    - ``repetitions`` (2, n) 2 H_i / d (Eqs. 4-5)
    - ``microlens_blur`` (2, n) b_i, unbounded microlens blur radius on the sensor [mm]
      (Eqs. 6-7; infinite on the out-of-focus plane)
    - ``blur_px`` (2, n) min(b_i, R_i) / mu, the bounded LF blur of Fig. 1 [px]
    - ``conventional_px`` (2, n) H_i / mu, the camera without microlenses [px]
    """

    z: np.ndarray
    conjugate: np.ndarray
    main_blur: np.ndarray
    repetitions: np.ndarray
    microlens_blur: np.ndarray
    blur_px: np.ndarray
    conventional_px: np.ndarray


def curves(camera: Camera, z, n_threads: int | None = None) -> Curves:
    """Evaluate every closed form at the depths ``z`` (mm, each finite and > F)."""
    cam = _validate.camera(camera)
    zs = _validate.depths(z)
    out = _native.curves(cam.core, zs, _validate.n_threads(n_threads))
    return Curves(zs, *out)


Intervals = list[tuple[float, float]]


@dataclasses.dataclass(frozen=True)
class DepthOfField:
    """Sharp depth intervals (near, far) in mm, open, sorted; ``far`` may be ``inf``.

    A depth is sharp when its blur is below ``threshold_px``: for ``half1``/``half2`` the
    bounded LF blur, for ``split`` either half's, for ``conventional1``/``conventional2``
    the main-lens blur with the sensor on array plane 1 or 2.
    """

    threshold_px: float
    half1: Intervals
    half2: Intervals
    split: Intervals
    conventional1: Intervals
    conventional2: Intervals

    def as_dict(self) -> dict:
        """JSON-ready dict; an infinite ``far`` becomes ``None``."""

        def fmt(iv: Intervals) -> list[list[float | None]]:
            return [[a, None if math.isinf(b) else b] for a, b in iv]

        return {
            "threshold_px": self.threshold_px,
            **{k: fmt(getattr(self, k)) for k in
               ("half1", "half2", "split", "conventional1", "conventional2")},
        }


def depth_of_field(camera: Camera, threshold_px: float = 0.5) -> DepthOfField:
    """Sharp depth intervals, every boundary solved in closed form (blur equations inverted)."""
    cam = _validate.camera(camera)
    t = _validate.real(threshold_px, "threshold_px")
    h1, h2, split, c1, c2 = _native.depth_of_field(cam.core, t)
    return DepthOfField(t, h1, h2, split, c1, c2)


def sharp_fractions(camera: Camera, z_range: tuple[float, float],
                    threshold_px: float = 0.5) -> dict[str, float]:
    """Fraction of the depth range [near, far] that is sharp, measured in log depth, for
    each configuration of :func:`depth_of_field` (keys ``half1``, ``half2``, ``split``,
    ``conventional1``, ``conventional2``)."""
    cam = _validate.camera(camera)
    lo, hi = (_validate.real(v, "z_range") for v in z_range)
    t = _validate.real(threshold_px, "threshold_px")
    values = _native.sharp_fractions(cam.core, t, lo, hi)
    return dict(zip(("half1", "half2", "split", "conventional1", "conventional2"), values,
                    strict=True))
