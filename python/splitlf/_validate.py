"""Argument checks shared by the public functions (types here; ranges in the core)."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from .camera import Camera


def camera(value: Any) -> Camera:
    if not isinstance(value, Camera):
        raise TypeError(f"camera must be a splitlf.Camera, got {type(value).__name__}")
    return value


def n_threads(value: Any) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"n_threads must be an integer >= 1 or None, got {value!r}")
    if not 1 <= int(value) <= 1024:
        raise ValueError(f"invalid n_threads = {value}: allowed an integer in [1, 1024] or None")
    return int(value)


def depths(value: Any, name: str = "z") -> np.ndarray:
    """Any array-like of depths -> 1-D float64 array (no copy when already float64)."""
    arr = np.asarray(value)
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise TypeError(f"{name} must be an array of real depths in mm, got dtype {arr.dtype}")
    arr = np.atleast_1d(arr).astype(np.float64, copy=False)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    return arr


def real(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    return float(value)
