"""Fig. 1 (blur against depth) and Fig. 5 (repetitions against depth)."""

from __future__ import annotations

import math
from typing import Any

from .. import _validate
from ..model.design import Design
from ..model.optics import curves
from ._mpl import (
    ROW_COLORS,
    axes,
    channel_colors,
    depth_grid,
    mark_channels_out_of_focus,
)


def _row_colors(c: Any) -> tuple[list[str], dict[int, str]]:
    """Colours of a Curves' per-type rows, and of each channel (its first row's): one
    colour per row, so both channels and lens types are told apart (for one type per
    channel: channel i's colour, the halves' blue and orange for channels 1 and 2)."""
    row_colors = [ROW_COLORS[i % len(ROW_COLORS)] for i in range(len(c.rows))]
    first: dict[int, str] = {}
    for i, name in enumerate(c.rows):
        first.setdefault(int(name.split()[1]), row_colors[i])
    return row_colors, first


def blur(camera: Design, z_range: tuple[float, float] = (100.0, 10_000.0), *, n: int = 4000,
         threshold_px: float = 0.5, ax: Any = None, n_threads: int | None = None) -> Any:
    """The paper's Fig. 1: blur radius in pixels against depth (log axis) for each light
    field channel (solid, bounded by the microlens image; one curve per lens type) and the
    conventional camera with the sensor on each channel's array plane (dashed), the
    sharpness line and the out-of-focus planes (dotted).

    - ``camera``: a :class:`~splitlf.Design` (the :class:`~splitlf.Camera` is one; its
      channels are "array 1" and "array 2"): per channel its lens types' curves
      (``curves(design).rows``), then its dashed conventional curve
    - ``threshold_px``: the sharpness line [pixels], finite > 0
    - ``z_range``: (near, far) depths [mm], F < near < far < inf, drawn on a log axis
    - ``n``: log-spaced depths drawn (an integer in [2, 10**6]); every out-of-focus plane
      is added so that the peaks are drawn
    - ``ax``: a matplotlib Axes, or None for a new figure
    - ``n_threads``: threads of the core (None: all cores)

    Returns the Axes. Raises ``TypeError`` (camera) and ``ValueError`` (z_range, n);
    ``ImportError`` without matplotlib.
    """
    cam = _validate.design(camera, "camera")
    threshold_px = _validate.real(threshold_px, "threshold_px")
    if not (math.isfinite(threshold_px) and threshold_px > 0):
        raise ValueError(f"invalid threshold_px = {threshold_px}: allowed a finite number > 0")
    z = depth_grid(cam, z_range, n)
    c = curves(cam, z, n_threads=n_threads)
    ax = axes(ax)
    colors, first = _row_colors(c)
    for ch in first:
        for i, name in enumerate(c.rows):
            if int(name.split()[1]) == ch:
                ax.plot(z, c.blur_px[i], color=colors[i], lw=1.8,
                        label=f"light field, array {name.partition(' ')[2]}")
        ax.plot(z, c.conventional_px[ch - 1], color=first[ch], lw=1.2, ls="--",
                label=f"conventional, sensor on plane {ch}")
    ax.axhline(threshold_px, color="0.3", lw=0.9, ls="-.", label=f"sharp: < {threshold_px:g} px")
    mark_channels_out_of_focus(ax, cam, first, label=False)
    radii = [cam.image_radius(ch) / cam.channels[ch - 1].mu for ch in first]
    ax.set_xscale("log")
    top = 1.25 * max(radii)
    ax.set_ylim(0.0, max(top, 2 * threshold_px))
    ax.set_xlim(z[0], z[-1])
    ax.set_xlabel("depth z [mm] (log scale)")
    ax.set_ylabel("blur radius [pixels]")
    ax.set_title("Blur against depth (Fig. 1)")
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, which="both", alpha=0.25)
    return ax


def repetitions(camera: Design, z_range: tuple[float, float] = (100.0, 10_000.0), *,
                n: int = 4000, ax: Any = None, n_threads: int | None = None) -> Any:
    """The paper's Fig. 5: repetitions 2 H_i / d under each array against depth (log axis).
    Where one array's repetitions drop to zero (its out-of-focus plane) the other's are high.

    - ``camera``: a :class:`~splitlf.Design` (the :class:`~splitlf.Camera` is one): one
      curve per channel
    - ``z_range``, ``n``, ``ax``, ``n_threads``: as in :func:`blur`

    Returns the Axes; raises what :func:`blur` raises for the same parameters.
    """
    cam = _validate.design(camera, "camera")
    z = depth_grid(cam, z_range, n)
    c = curves(cam, z, n_threads=n_threads)
    ax = axes(ax)
    colors = channel_colors(cam)
    for ch in colors:
        ax.plot(z, c.repetitions[ch - 1], color=colors[ch], lw=1.8, label=f"array {ch}")
    mark_channels_out_of_focus(ax, cam, colors)
    ax.set_xscale("log")
    ax.set_xlim(z[0], z[-1])
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("depth z [mm] (log scale)")
    ax.set_ylabel("repetitions 2H/d")
    ax.set_title("Repetitions under each microlens array (Fig. 5)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.25)
    return ax
