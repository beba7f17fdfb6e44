"""Figures (matplotlib, optional: ``pip install "splitlf[plot]"``). matplotlib is imported
only when a figure is drawn; every function takes ``ax=None`` and returns the Axes it drew
on; this package never selects a backend."""

from .curves import blur, repetitions
from .rayspace import ray_space
from .samples import samples

__all__ = ["FIGURES", "blur", "ray_space", "repetitions", "samples"]

#: What ``splitlf figures`` writes: file stem -> function name in this module.
FIGURES = {
    "fig1_blur": "blur",
    "fig4_ray_space": "ray_space",
    "fig5_repetitions": "repetitions",
    "samples": "samples",
}
