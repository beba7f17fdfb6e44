"""A Bayer colour filter array on the sensor (docs/model.md §12).

A pixel in raw row r, column c of a channel (its own raw indices, row 0 at the top: the
whole Q K_y x Q K_x pixel array on the ideal layout, the sensor grid's on the sensor
layout) records colour ``P[r % 2][c % 2]`` of the pattern P, times that colour's quantum
efficiency (a plain factor). The patterns are named by their top-left 2 x 2 block read
row by row: ``"RGGB"``, ``"GRBG"``, ``"GBRG"``, ``"BGGR"``. The colour of each pixel,
the mosaic and the grey raw of a mosaic are the core's (``_native.cfa_colours``,
``_native.cfa_mosaic``, ``_native.cfa_grey``); this module validates and describes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .. import _native
from ..errors import InvalidParameter

__all__ = ["PATTERNS", "colours", "options"]

#: The four phases of the Bayer pattern.
PATTERNS = ("RGGB", "GRBG", "GBRG", "BGGR")


def _qe(value: Any, name: str = "qe") -> tuple[float, float, float]:
    """Three quantum efficiencies (red, green, blue), each a finite number in (0, 1]."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise TypeError(f"{name} must be 3 numbers (red, green, blue) in (0, 1], "
                        f"got {value!r}")
    if len(value) != 3:
        raise InvalidParameter.of(name, f"{len(value)} values", "3 numbers (red, green, "
                                  "blue) in (0, 1]")
    out = []
    for k, q in enumerate(value):
        if isinstance(q, bool | np.bool_) or not isinstance(q, int | float | np.integer
                                                             | np.floating):
            raise TypeError(f"{name}[{k}] must be a number in (0, 1], got {q!r}")
        if not (math.isfinite(float(q)) and 0.0 < float(q) <= 1.0):
            raise InvalidParameter.of(f"{name}[{k}]", float(q),
                                      "a quantum efficiency in (0, 1]")
        out.append(float(q))
    return out[0], out[1], out[2]


def options(cfa: Any, qe: Any = None) -> dict[str, Any] | None:
    """``cfa``: None (a grey sensor; then ``qe`` must be None) or one of
    :data:`PATTERNS`; ``qe``: None (1, 1, 1) or three numbers in (0, 1]. Returns None or
    ``{"pattern": str, "qe": (r, g, b)}``; ``TypeError`` / :class:`InvalidParameter`
    naming ``cfa`` or ``qe`` otherwise."""
    if cfa is None:
        if qe is not None:
            raise InvalidParameter.of("qe", qe, "None without a cfa (a grey sensor)")
        return None
    if not isinstance(cfa, str):
        raise TypeError(f"cfa must be None or one of {', '.join(PATTERNS)}, got {cfa!r}")
    if cfa not in PATTERNS:
        raise InvalidParameter.of("cfa", cfa, f"one of {', '.join(PATTERNS)}")
    return {"pattern": cfa, "qe": (1.0, 1.0, 1.0) if qe is None else _qe(qe)}


def stated(value: Any) -> dict[str, Any] | None:
    """A CFA as a :class:`~splitlf.Raw` carries it: None (grey) or ``{"pattern": P,
    "qe": (r, g, b)}`` (``qe`` optional, default 1s)."""
    if value is None:
        return None
    if not isinstance(value, Mapping) or set(value) - {"pattern", "qe"} or (
            "pattern" not in value):
        raise InvalidParameter.of("cfa", value, "None or {'pattern': one of "
                                  f"{', '.join(PATTERNS)}, 'qe': 3 numbers in (0, 1]}}")
    return options(value["pattern"], value.get("qe"))


def colours(cfa: Mapping[str, Any], shape: tuple[int, int]) -> np.ndarray:
    """The colour (0 red, 1 green, 2 blue) of every pixel of a raw of ``shape``
    (uint8, the core's ``cfa_colours``)."""
    return np.asarray(_native.cfa_colours(cfa["pattern"], int(shape[0]), int(shape[1])))


def mosaic(planes: Sequence[np.ndarray], cfa: Mapping[str, Any]) -> np.ndarray:
    """One channel's mosaic of its three noise-free raws (red, green, blue)."""
    r, g, b = (np.ascontiguousarray(p, dtype=np.float64) for p in planes)
    return np.asarray(_native.cfa_mosaic([r, g, b], cfa["pattern"], list(cfa["qe"])))


def grey(image: np.ndarray, cfa: Mapping[str, Any]) -> np.ndarray:
    """A mosaic's grey raw: each pixel divided by its colour's quantum efficiency."""
    return np.asarray(_native.cfa_grey(np.ascontiguousarray(image, dtype=np.float64),
                                       cfa["pattern"], list(cfa["qe"])))


def describe(cfa: Mapping[str, Any] | None) -> str:
    """A short text of the CFA ("grey" for none)."""
    if cfa is None:
        return "grey"
    return "{} (QE {:g}, {:g}, {:g})".format(cfa["pattern"], *cfa["qe"])
