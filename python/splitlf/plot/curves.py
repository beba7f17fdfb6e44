"""Fig. 1 (blur against depth) and Fig. 5 (repetitions against depth)."""

from __future__ import annotations

import math
from typing import Any

from .. import _validate
from ..camera import Camera
from ..design import Design
from ..optics import curves
from ._mpl import (
    HALF_COLORS,
    ROW_COLORS,
    axes,
    depth_grid,
    mark_channels_out_of_focus,
    mark_out_of_focus,
)


def _row_colors(c: Any) -> tuple[list[str], dict[int, str]]:
    """Colours of a DesignCurves' per-type rows, and of each channel (its first row's):
    one colour per row, so both channels and lens types are told apart."""
    row_colors = [ROW_COLORS[i % len(ROW_COLORS)] for i in range(len(c.rows))]
    first: dict[int, str] = {}
    for i, name in enumerate(c.rows):
        first.setdefault(int(name.split()[1]), row_colors[i])
    return row_colors, first


def blur(camera, z_range: tuple[float, float] = (100.0, 10_000.0), *, n: int = 4000,
         threshold_px: float = 0.5, ax: Any = None, n_threads: int | None = None) -> Any:
    """The paper's Fig. 1: blur radius in pixels against depth (log axis) for both light
    field halves (solid, bounded by the microlens image) and the conventional cameras with
    the sensor on each array plane (dashed), the sharpness line and the out-of-focus planes.

    - ``threshold_px``: the sharpness line [pixels], finite > 0
    - ``camera``: the :class:`~splitlf.Camera`, or a :class:`~splitlf.Design`: one solid
      curve per lens type of each channel (``curves(design).rows``), one dashed
      conventional curve per channel
    - ``z_range``: (near, far) depths [mm], F < near < far < inf, drawn on a log axis
    - ``n``: log-spaced depths drawn (an integer in [2, 10**6]); every out-of-focus plane
      is added so that the peaks are drawn
    - ``ax``: a matplotlib Axes, or None for a new figure
    - ``n_threads``: threads of the core (None: all cores)

    Returns the Axes. Raises ``TypeError`` (camera) and ``ValueError`` (z_range, n);
    ``ImportError`` without matplotlib.
    """
    cam = _validate.camera_or_design(camera)
    threshold_px = _validate.real(threshold_px, "threshold_px")
    if not (math.isfinite(threshold_px) and threshold_px > 0):
        raise ValueError(f"invalid threshold_px = {threshold_px}: allowed a finite number > 0")
    z = depth_grid(cam, z_range, n)
    c = curves(cam, z, n_threads=n_threads)
    ax = axes(ax)
    if isinstance(cam, Design):
        colors, first = _row_colors(c)
        for i, name in enumerate(c.rows):
            ax.plot(z, c.blur_px[i], color=colors[i], lw=1.8, label=f"light field, {name}")
        for ch in range(len(c.channels)):
            ax.plot(z, c.conventional_px[ch], color=first[ch + 1], lw=1.2, ls="--",
                    label=f"conventional, sensor on plane {ch + 1}")
        mark_channels_out_of_focus(ax, cam, first)
        radii = [cam.image_radius(ch) / cam.channels[ch - 1].mu for ch in first]
    for h in (1, 2) if isinstance(cam, Camera) else ():
        ax.plot(z, c.blur_px[h - 1], color=HALF_COLORS[h], lw=1.8,
                label=f"light field, array {h}")
        ax.plot(z, c.conventional_px[h - 1], color=HALF_COLORS[h], lw=1.2, ls="--",
                label=f"conventional, sensor on plane {h}")
    ax.axhline(threshold_px, color="0.3", lw=0.9, ls="-.", label=f"sharp: < {threshold_px:g} px")
    if isinstance(cam, Camera):
        mark_out_of_focus(ax, cam, label=False)
        radii = [cam.image_radius(h) / cam.mu for h in (1, 2)]
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



def repetitions(camera, z_range: tuple[float, float] = (100.0, 10_000.0), *, n: int = 4000,
                ax: Any = None, n_threads: int | None = None) -> Any:
    """The paper's Fig. 5: repetitions 2 H_i / d under each array against depth (log axis).
    Where one array's repetitions drop to zero (its out-of-focus plane) the other's are high.

    - ``camera``: the :class:`~splitlf.Camera`, or a :class:`~splitlf.Design` (one curve
      per channel)
    - ``z_range``: (near, far) depths [mm], F < near < far < inf, drawn on a log axis
    - ``n``: log-spaced depths drawn (an integer in [2, 10**6]); every out-of-focus plane
      is added so that the peaks are drawn
    - ``ax``: a matplotlib Axes, or None for a new figure
    - ``n_threads``: threads of the core (None: all cores)

    Returns the Axes. Raises ``TypeError`` (camera) and ``ValueError`` (z_range, n);
    ``ImportError`` without matplotlib.
    """
    cam = _validate.camera_or_design(camera)
    z = depth_grid(cam, z_range, n)
    c = curves(cam, z, n_threads=n_threads)
    ax = axes(ax)
    if isinstance(cam, Design):
        colors = {ch: ROW_COLORS[(ch - 1) % len(ROW_COLORS)]
                  for ch in range(1, len(c.channels) + 1)}
        for ch in colors:
            ax.plot(z, c.repetitions[ch - 1], color=colors[ch], lw=1.8, label=f"array {ch}")
        mark_channels_out_of_focus(ax, cam, colors)
    else:
        for h in (1, 2):
            ax.plot(z, c.repetitions[h - 1], color=HALF_COLORS[h], lw=1.8,
                    label=f"array {h}")
        mark_out_of_focus(ax, cam)
    ax.set_xscale("log")
    ax.set_xlim(z[0], z[-1])
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("depth z [mm] (log scale)")
    ax.set_ylabel("repetitions 2H/d")
    ax.set_title("Repetitions under each microlens array (Fig. 5)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.25)
    return ax
