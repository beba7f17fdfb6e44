"""Figures (matplotlib, optional: ``pip install "splitlf[plot]"``). matplotlib is imported
only when a figure is drawn; every function takes ``ax=None`` and returns the Axes it drew
on; this package never selects a backend."""

from .curves import blur, repetitions
from .samples import samples

__all__ = ["FIGURES", "blur", "repetitions", "samples"]

#: What ``splitlf figures`` writes: file stem -> function name in this module.
FIGURES = {
    "fig1_blur": "blur",
    "fig5_repetitions": "repetitions",
    "samples": "samples",
}
