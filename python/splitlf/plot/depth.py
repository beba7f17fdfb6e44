"""A depth estimate as a picture (docs/depth.md): the depth in a colour map over the
estimate's extent, the cells the method does not stand behind in grey."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._mpl import axes

__all__ = ["depth"]

#: The colour of cells that are not confident.
UNCONFIDENT = (0.55, 0.55, 0.55, 1.0)


def depth(estimate: Any, ax: Any = None, *, cmap: str = "viridis",
          vmin: float | None = None, vmax: float | None = None) -> Any:
    """Draw ``estimate`` (a :class:`~splitlf.DepthMap`, e.g. from
    :func:`~splitlf.estimate_depth`) on ``ax``: the depth [mm] in ``cmap`` with a colour
    bar, the cells whose ``confident`` is False in grey; X and Y in object-space mm. The
    colour range defaults to the confident cells' 2nd to 98th
    percentile of depth. Returns the Axes."""
    from ..imaging.render import DepthMap

    if not isinstance(estimate, DepthMap):
        raise TypeError(f"estimate must be a splitlf.DepthMap, got {type(estimate).__name__}")
    ax = axes(ax)
    import matplotlib as mpl

    z = np.asarray(estimate.depth, dtype=np.float64)
    conf = (np.ones(z.shape, bool) if estimate.confident is None
            else np.asarray(estimate.confident))
    shown = z[conf] if conf.any() else z
    p2, p98 = np.percentile(shown, [2.0, 98.0])
    lo = float(p2) if vmin is None else vmin
    hi = float(p98) if vmax is None else vmax
    if not hi > lo:
        lo, hi = lo - 1.0, hi + 1.0
    colours = mpl.colormaps[cmap](mpl.colors.Normalize(lo, hi)(z))
    colours[~conf] = UNCONFIDENT
    x0, x1, y0, y1 = estimate.extent
    ax.imshow(colours, extent=(x0, x1, y0, y1), origin="upper", interpolation="nearest")
    bar = ax.figure.colorbar(mpl.cm.ScalarMappable(mpl.colors.Normalize(lo, hi), cmap),
                             ax=ax, shrink=0.85)
    bar.set_label("depth [mm]")
    ax.set_xlabel("X [mm]")
    ax.set_ylabel("Y [mm]")
    share = float(conf.mean())
    ax.set_title(f"estimated depth ({share:.0%} of cells confident; grey: not confident)")
    return ax
