"""Piecewise-constant functions of one variable, shared by the textures
(:mod:`splitlf.imaging.texture`) and the 1-D simulation (:mod:`splitlf.inverse.simulate`)."""

from __future__ import annotations

import numpy as np

__all__ = ["antiderivative"]


def antiderivative(edges: np.ndarray, values: np.ndarray, x: np.ndarray,
                   outside: float) -> np.ndarray:
    """Antiderivative at x of the function equal to values[i] on [edges[i], edges[i+1]]
    and ``outside`` elsewhere (0 at edges[0])."""
    cum = np.concatenate([[0.0], np.cumsum(values * np.diff(edges))])
    inside = np.interp(x, edges, cum)
    return inside + outside * (np.minimum(x - edges[0], 0.0) + np.maximum(x - edges[-1], 0.0))
