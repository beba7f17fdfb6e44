"""Ray-space engine (docs/model.md §3-5): every pixel's integration polygon in (u, w) and its
footprint on a scene plane at any depth.

Thin wrappers: the geometry runs in the Rust core (parallel, GIL released); this module
checks argument types and packs the arrays. Derivations: ``docs/rayspace.md``.
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Iterator
from typing import Any

import numpy as np

from . import _native, _validate
from .camera import Camera

__all__ = ["Footprints", "SampleGrid", "Trace", "footprints", "sample_grid", "trace"]


def _half(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"half must be the integer 1 or 2, got {type(value).__name__} {value!r}")
    return int(value)


def _choice(value: Any, name: str, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str):
        raise TypeError(
            f"{name} must be one of {', '.join(map(repr, allowed))}, "
            f"got {type(value).__name__} {value!r}"
        )
    return value


@dataclasses.dataclass(frozen=True)
class Trace:
    """Every pixel of one half along one axis, n = K Q, microlens-major (index j Q + q).

    - ``vertices`` (n, 6, 2): (u, w) of the integration polygon [mm], counter-clockwise,
      unused rows NaN (u: height on plane v', w: height on the main lens)
    - ``n_vertices`` (n,): vertex count (0 for a fully vignetted pixel)
    - ``area`` (n,): polygon area [mm^2], proportional to the light collected
    - ``centroid`` (n, 2): (u, w) of the polygon's centroid (NaN when empty)
    - ``lens``, ``pixel`` (n,): microlens index j and pixel index q under it
    - ``chief`` (n, 2): (u, w) of the chief ray (through microlens and pixel centres)
    - ``lit`` (n,): the chief ray passes the main-lens aperture (docs/model.md §6)
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


def trace(camera: Camera, half: int, axis: str = "x") -> Trace:
    """Integration polygon of every pixel of ``half`` (1 or 2) along ``axis`` ("x"/"y")."""
    cam = _validate.camera(camera)
    h = _half(half)
    ax = _choice(axis, "axis", ("x", "y"))
    return Trace(h, ax, *_native.trace(cam.core, h, ax))


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


def footprints(
    camera: Camera,
    z,
    half: int,
    axis: str = "x",
    sample: str = "centroid",
    kernel: bool = False,
    n_threads: int | None = None,
) -> Footprints:
    """Footprint of every pixel of ``half`` along ``axis`` on the planes at depths ``z``
    (mm, each finite and > F). ``sample`` is "centroid" (projection of the polygon's
    centroid) or "chief" (projection of the chief ray, the paper's convention)."""
    cam = _validate.camera(camera)
    zs = _validate.depths(z)
    h = _half(half)
    ax = _choice(axis, "axis", ("x", "y"))
    s = _choice(sample, "sample", ("centroid", "chief"))
    if not isinstance(kernel, bool | np.bool_):
        raise TypeError(f"kernel must be a bool, got {type(kernel).__name__} {kernel!r}")
    out = _native.footprints(cam.core, zs, h, ax, s, bool(kernel), _validate.n_threads(n_threads))
    return Footprints(zs, h, ax, s, *out)


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

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.X, self.Y))


def sample_grid(
    camera: Camera, z: float, half: int, sample: str = "chief", n_threads: int | None = None
) -> SampleGrid:
    """Sample position of every pixel of ``half`` on the plane at depth ``z`` (one depth)."""
    cam = _validate.camera(camera)
    zf = _validate.real(z, "z")
    h = _half(half)
    s = _choice(sample, "sample", ("centroid", "chief"))
    X, Y = _native.sample_grid(cam.core, zf, h, s, _validate.n_threads(n_threads))
    return SampleGrid(zf, h, s, X, Y)
