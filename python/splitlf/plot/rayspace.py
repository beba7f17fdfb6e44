"""The ray space of the split-sensor camera: the right panel of the paper's Fig. 4."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _validate
from ..model.design import Design
from ..sampling import rayspace
from ._mpl import channel_name, pyplot, trace_threads

__all__ = ["ray_space"]

#: The paper's colours: half 1 (channel 1) grey, half 2 yellow; scene planes red, green,
#: blue.
HALF_COLOURS = {1: ("0.62", "0.30"), 2: ("#f5d000", "#9a7d00")}
DEPTH_COLOURS = ("#d62728", "#2ca02c", "#1f5fd6")
#: Channels 3, 4, ... of a design (none of them red, green or blue, the planes' colours).
MORE_CHANNEL_COLOURS = ("#b07cc6", "#c49c94", "#e377c2", "#bcbd22", "#17becf")


def _polygons(tr: rayspace.Trace, keep: np.ndarray) -> list[np.ndarray]:
    """The integration polygons of the pixels ``keep`` (a boolean mask) of ``tr``."""
    return [tr.vertices[i, : tr.n_vertices[i]] for i in np.flatnonzero(keep)]


def _check(camera: Design, depths: Sequence[float] | None, n_lenses: int,
           default: Sequence[float]) -> np.ndarray:
    """The depths to draw (``default`` when None), validated with ``n_lenses``."""
    zs = _validate.depths(default if depths is None else depths, "depths")
    if not 1 <= len(zs) <= len(DEPTH_COLOURS):
        raise ValueError(f"depths: give 1 to {len(DEPTH_COLOURS)} depths, got {len(zs)}")
    if not np.all(np.isfinite(zs) & (zs > camera.F)):
        raise ValueError(f"invalid depths = {zs.tolist()}: allowed finite depths > F = "
                         f"{camera.F} mm")
    if isinstance(n_lenses, bool) or not isinstance(n_lenses, int) or n_lenses < 1:
        raise ValueError(f"invalid n_lenses = {n_lenses!r}: allowed an integer >= 1")
    return zs


def _channel_colours(c: int) -> tuple[str, str]:
    """(face, edge) of channel c: the paper's grey and yellow for 1 and 2, then a palette."""
    if c in HALF_COLOURS:
        return HALF_COLOURS[c]
    colour = MORE_CHANNEL_COLOURS[(c - 3) % len(MORE_CHANNEL_COLOURS)]
    return colour, colour


def ray_space(
    camera: Design,
    depths: Sequence[float] | None = None,
    n_lenses: int = 3,
    axis: str = "x",
    ax: Any = None,
    *,
    n_threads: int | None = None,
) -> Any:
    """The paper's Fig. 4 (right) for a design: in the ray space (u on channel 1's array
    plane, v' for the seed; w on the main lens), the integration regions of every pixel
    under ``n_lenses`` neighbouring central microlenses of each channel (half 1 grey,
    half 2 yellow, further channels a palette), and the constant-intensity lines
    u + sigma w = p' of up to three scene planes (red, green, blue), one line through each
    drawn microlens centre at w = 0 (of the channel whose out-of-focus plane it is, else
    of channel 1).

    - ``camera``: a :class:`~splitlf.Design` with rect channels (the
      :class:`~splitlf.Camera` is one; a two-channel design's channels are named half 1
      and half 2)
    - ``depths``: 1 to 3 scene depths [mm], finite and > F; default the channels'
      out-of-focus planes (the first three), then a far plane at 2.5 z_1 while there is
      room: for the seed, half 1's plane (vertical lines), half 2's (lines parallel to
      half 2's microlens columns) and 2.5 z_1
    - ``n_lenses``: microlenses drawn per channel (an integer >= 1)
    - ``axis``: "x" or "y", the axis traced (:func:`splitlf.trace`)
    - ``ax``: a matplotlib Axes, or None for a new figure
    - ``n_threads``: threads of the trace (None: all cores)

    Returns the Axes. Raises ``TypeError`` (camera, types) and ``ValueError`` (depths,
    n_lenses, axis out of range; a hex channel, by name); ``ImportError`` without
    matplotlib.
    """
    from matplotlib.collections import PolyCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    des = _validate.design(camera, "camera")
    n_ch = len(des.channels)
    oof = [des.out_of_focus_depth(c) for c in range(1, n_ch + 1)]
    default = oof[:3] + [2.5 * oof[0]] * (n_ch < 3)
    zs = _check(des, depths, n_lenses, default)
    if ax is None:
        _, ax = pyplot().subplots(figsize=(9.0, 6.0), layout="constrained")
    L1 = des.channels[0].L
    handles: list[Any] = []
    drawn: list[np.ndarray] = []
    centres: dict[int, np.ndarray] = {}
    for c, ch in enumerate(des.channels, start=1):
        tr = rayspace.trace(des, channel=c, axis=axis, **trace_threads(n_threads))
        K = int(tr.lens.max()) + 1
        first = max(0, (K - n_lenses) // 2)
        keep = (tr.lens >= first) & (tr.lens < first + n_lenses) & (tr.n_vertices > 0)
        face, edge = _channel_colours(c)
        alpha = 0.75 if c == 1 else 0.6
        ax.add_collection(PolyCollection(_polygons(tr, keep), facecolors=face,
                                         edgecolors=edge, linewidths=0.7, alpha=alpha,
                                         zorder=1 + c))
        j = np.arange(first, min(first + n_lenses, K))
        centres[c] = L1 / ch.L * (j - (K - 1) / 2) * ch.d  # u at w = 0 of the lens centres
        drawn.append(tr.vertices[keep])
        handles.append(Patch(facecolor=face, edgecolor=edge, alpha=alpha,
                             label=f"{channel_name(des, c)}: {int(keep.sum())} pixels under "
                                   f"{len(j)} microlenses"))
    w = np.array([-des.D / 2, des.D / 2])
    for z, colour in zip(zs, DEPTH_COLOURS, strict=False):
        zc = des.F * z / (z - des.F)
        sigma = (L1 - zc) / zc  # a point of the plane is the line u + sigma w = p'
        # through the microlens centres of the channel this plane is out of focus for (the
        # lines then run along its microlens columns), else of channel 1
        own = [c for c in range(1, n_ch + 1) if np.isclose(z, oof[c - 1], rtol=1e-9)]
        for p in centres[own[0] if own else 1]:
            ax.plot(p - sigma * w, w, color=colour, lw=1.5, zorder=5 + n_ch)
        label = f"scene plane z = {z:.0f} mm" + \
            (f" (out-of-focus plane of {channel_name(des, own[0])})" if own else "")
        handles.append(Line2D([], [], color=colour, lw=1.5, label=label))
    allv = np.concatenate(drawn)
    u_lo, u_hi = np.nanmin(allv[..., 0]), np.nanmax(allv[..., 0])
    pad = 0.03 * (u_hi - u_lo)
    half_d = des.D / 2
    ax.set_xlim(u_lo - pad, u_hi + pad)
    ax.set_ylim(-1.08 * half_d, 1.08 * half_d)
    for y in (-half_d, half_d):
        ax.axhline(y, color="0.15", lw=0.9, ls="--", zorder=6 + n_ch)
    ax.text(u_hi, half_d, "aperture edge  ", ha="right", va="bottom", fontsize=8, color="0.15")
    ax.set_xlabel("u: ray height on the plane of microlens array 1 [mm]")
    ax.set_ylabel("w: ray height on the main lens [mm]")
    ax.set_title("Ray space: pixel integration regions and constant-intensity lines")
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=2,
              fontsize=8.5)
    return ax
