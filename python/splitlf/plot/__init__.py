"""Figures (matplotlib, optional: ``pip install "splitlf[plot]"``). matplotlib is imported
only when a figure is drawn; every function takes ``ax=None`` and returns the Axes it drew
on (:func:`raw`, which draws panels of its own, returns the Figure); this package never
selects a backend."""

from .architecture import microlens_images, sample_map
from .compare import compare
from .curves import blur, repetitions
from .depth import depth
from .raw import raw
from .rayspace import ray_space
from .resolution import resolution
from .samples import samples

__all__ = [
    "DESIGN_FIGURES",
    "FIGURES",
    "RECT_ONLY",
    "blur",
    "compare",
    "depth",
    "microlens_images",
    "raw",
    "ray_space",
    "repetitions",
    "resolution",
    "sample_map",
    "samples",
]

#: What ``splitlf figures`` writes for a design (the seed camera, ``--preset``, a
#: ``[design]`` file): file stem -> (function name in this module, the panels it draws on:
#: a number stacked, or "channels" for one per channel side by side, figure size in inches
#: (per panel side by side)).
FIGURES = {
    "fig1_blur": ("blur", 1, (7.0, 4.2)),
    "fig4_ray_space": ("ray_space", 1, (9.0, 6.0)),
    "fig5_repetitions": ("repetitions", 1, (7.0, 4.2)),
    "samples": ("samples", 2, (11.5, 7.5)),
    "microlens_images": ("microlens_images", "channels", (4.6, 5.0)),
    "sample_map": ("sample_map", 1, (7.0, 8.4)),
}

#: The figures of :data:`FIGURES` that analyse along x (docs/model.md §9: 1-D analysis on
#: rect grids only), left out for a design with a hex channel.
RECT_ONLY = frozenset({"fig4_ray_space", "samples"})

#: The same table as :data:`FIGURES` (every design draws the same figures; kept for
#: callers of the two-table form).
DESIGN_FIGURES = FIGURES
