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

#: Default sharpness threshold on the blur radius, in pixels (from the core).
DEFAULT_THRESHOLD_PX: float = _native.DEFAULT_THRESHOLD_PX


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
    """Evaluate every closed form (Eqs. 1-7) at the depths ``z``.

    Parameters:
        camera: the design (:class:`splitlf.Camera`).
        z: depths in mm: a number or any 1-D array-like of real numbers (n,), each finite
            and > F. Integers are converted to float64; a float64 array is not copied.
        n_threads: threads of the core (an integer in [1, ``_native.MAX_THREADS``]);
            ``None`` (default) uses all cores.

    Returns:
        :class:`Curves` with ``z`` (n,) and the arrays listed there (float64).

    Raises:
        TypeError: ``camera`` is not a Camera, ``z`` is not real, ``n_threads`` is not an
            integer.
        InvalidParameter: (a ``ValueError``) ``z`` is not 1-D, or an element is not finite
            or not > F (``.name == "z"``, ``.index`` the element), or ``n_threads`` is out
            of range.
        TooLargeError: (a ``MemoryError``) the outputs (88 bytes per depth) do not fit in
            the memory available.
        KeyboardInterrupt: on Ctrl-C (checked between chunks of about a million depths).
    """
    cam = _validate.camera(camera)
    zs = _validate.depths(z)
    r = _native.curves(cam.core, zs, _validate.n_threads(n_threads))
    return Curves(zs, r.conjugate, r.main_blur, r.repetitions, r.microlens_blur, r.blur_px,
                  r.conventional_px)


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


def depth_of_field(camera: Camera, threshold_px: float = DEFAULT_THRESHOLD_PX) -> DepthOfField:
    """Sharp depth intervals of each configuration, every boundary solved in closed form
    (the blur equations inverted; no sampling).

    Parameters:
        camera: the design.
        threshold_px: a depth is sharp where the blur radius is below this many pixels
            (a finite number > 0; default ``DEFAULT_THRESHOLD_PX`` = 0.5).

    Returns:
        :class:`DepthOfField`: for each configuration a sorted list of disjoint open
        intervals (near, far) in mm with near < far; ``far`` may be ``inf``.

    Raises:
        TypeError: ``threshold_px`` is not a real number.
        InvalidParameter: ``threshold_px`` is not finite or not > 0.
    """
    cam = _validate.camera(camera)
    t = _validate.real(threshold_px, "threshold_px")
    r = _native.depth_of_field(cam.core, t)
    return DepthOfField(t, r.half1, r.half2, r.split, r.conventional1, r.conventional2)


def sharp_fractions(camera: Camera, z_range: tuple[float, float],
                    threshold_px: float = DEFAULT_THRESHOLD_PX) -> dict[str, float]:
    """Fraction of the depth range that is sharp, measured in log depth, for each
    configuration of :func:`depth_of_field`.

    Parameters:
        camera: the design.
        z_range: (near, far) in mm, finite, 0 < near < far.
        threshold_px: as in :func:`depth_of_field` (default 0.5 px).

    Returns:
        ``{"half1", "half2", "split", "conventional1", "conventional2"}`` -> fraction in
        [0, 1]: the summed log length of the sharp intervals inside the range over
        log(far / near).

    Raises:
        TypeError: a bound or ``threshold_px`` is not a real number.
        InvalidParameter: the range is not 0 < near < far (finite), or ``threshold_px``
            is not finite and > 0.
    """
    cam = _validate.camera(camera)
    lo, hi = (_validate.real(v, "z_range") for v in z_range)
    t = _validate.real(threshold_px, "threshold_px")
    values = _native.sharp_fractions(cam.core, t, lo, hi)
    return dict(zip(("half1", "half2", "split", "conventional1", "conventional2"), values,
                    strict=True))
