"""A reconstructed image as a picture (docs/reconstruct.md): the albedo in grey over the
reconstruction's extent, X and Y in object-space mm, as :func:`~splitlf.plot.depth` draws
a depth map."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._mpl import axes

__all__ = ["image"]


def image(reconstruction: Any, ax: Any = None, *, cmap: str = "gray", vmin: float = 0.0,
          vmax: float | None = None) -> Any:
    """Draw ``reconstruction`` (a :class:`~splitlf.Reconstruction`, e.g. from
    :func:`~splitlf.reconstruct`) on ``ax``: its albedo in ``cmap`` with a colour bar, row 0
    at the top (the largest Y), over its ``extent`` in object-space mm. The range is
    ``vmin`` (default 0, black) to ``vmax`` (default: 1, white, or the image's largest value
    when that is higher). A :class:`~splitlf.ColourReconstruction` is drawn in colour
    (each colour scaled to that range, no colour bar). Returns the Axes."""
    from ..inverse.reconstruct import ColourReconstruction, Reconstruction

    if not isinstance(reconstruction, Reconstruction | ColourReconstruction):
        raise TypeError("reconstruction must be a splitlf.Reconstruction, got "
                        f"{type(reconstruction).__name__}")
    ax = axes(ax)
    img = np.asarray(reconstruction.image, dtype=np.float64)
    hi = max(1.0, float(img.max())) if vmax is None else vmax
    x0, x1, y0, y1 = reconstruction.extent
    if img.ndim == 3:  # a colour reconstruction: R, G, B scaled to [vmin, hi]
        shown = ax.imshow(np.clip((img - vmin) / (hi - vmin), 0.0, 1.0),
                          extent=(x0, x1, y0, y1), origin="upper", interpolation="nearest")
    else:
        shown = ax.imshow(img, extent=(x0, x1, y0, y1), origin="upper",
                          interpolation="nearest", cmap=cmap, vmin=vmin, vmax=hi)
        bar = ax.figure.colorbar(shown, ax=ax, shrink=0.85)
        bar.set_label("albedo")
    ax.set_xlabel("X [mm]")
    ax.set_ylabel("Y [mm]")
    rows, cols = img.shape[:2]
    ax.set_title(f"reconstructed albedo ({cols} x {rows} cells of "
                 f"{reconstruction.step:.4g} mm)")
    return ax
