"""Lazy matplotlib import shared by the plotting functions."""

from __future__ import annotations

from typing import Any


def pyplot() -> Any:
    """``matplotlib.pyplot``, or an ImportError that says how to get it."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - exercised only without matplotlib
        raise ImportError(
            'splitlf.plot needs matplotlib, an optional extra: pip install "splitlf[plot]"'
        ) from e
    return plt
