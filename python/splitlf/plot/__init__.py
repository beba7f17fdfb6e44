"""Figures (matplotlib, optional: ``pip install "splitlf[plot]"``). matplotlib is imported
only when a figure is drawn; every function takes ``ax=None`` and returns the Axes it drew
on; this package never selects a backend."""

from .curves import blur, repetitions
from .rayspace import ray_space
from .resolution import resolution
from .samples import samples

__all__ = ["FIGURES", "blur", "ray_space", "repetitions", "resolution", "samples"]

#: What ``splitlf figures`` writes: file stem -> (function name in this module, number of
#: stacked panels the function draws on, figure size in inches).
FIGURES = {
    "fig1_blur": ("blur", 1, (7.0, 4.2)),
    "fig4_ray_space": ("ray_space", 1, (9.0, 6.0)),
    "fig5_repetitions": ("repetitions", 1, (7.0, 4.2)),
    "samples": ("samples", 2, (11.5, 7.5)),
}
