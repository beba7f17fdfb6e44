"""Figures of a general design (docs/model.md §9, docs/architectures.md): the microlens
images on the sensor, and the 2-D sample map on a plane at depth z."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from .. import _validate
from ..errors import InvalidParameter
from ._mpl import axes

__all__ = ["microlens_images", "sample_map"]

#: Colours of lens types 1, 2, 3, ... (cycled) and of the channels of a sample map.
TYPE_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")
UNLIT = (0.86, 0.86, 0.86)
BOUNDARY = (0.25, 0.25, 0.25)


def _design(design: Any) -> Any:
    """The design (a :class:`~splitlf.Camera` is one), else ``TypeError``."""
    return _validate.design(design)


def _crop(shape: tuple[int, int], half: tuple[int, int]) -> tuple[slice, slice]:
    """Rows and columns of the centred crop of ``2 half + 1`` pixels (clipped to the grid)."""
    (my, mx), (hy, hx) = shape, half
    cy, cx = my // 2, mx // 2
    return (slice(max(cy - hy, 0), min(cy + hy + 1, my)),
            slice(max(cx - hx, 0), min(cx + hx + 1, mx)))


def microlens_images(design: Any, channel: int | None = None, lenses: int = 6, ax: Any = None,
                     *, n_threads: int | None = None) -> Any:
    """The pixels of the centre of a channel's sensor: each lit pixel coloured by the
    type of the lens it belongs to (docs/model.md §9, lens types), unlit pixels grey,
    and a dark line between neighbouring pixels of different lenses (the image cells).

    - ``design``: a :class:`~splitlf.Design` (the :class:`~splitlf.Camera` is one)
    - ``channel``: the channel, from 1; None (default): every channel, side by side
    - ``lenses``: how many image pitches of the channel the crop spans per axis (1 to 200)
    - ``ax``: a matplotlib Axes (a sequence of one Axes per channel when ``channel`` is
      None) or None (a new figure); ``n_threads``: threads of the core

    Returns the Axes (a list of them when ``channel`` is None). Raises
    ``TypeError``/``ValueError`` for bad arguments, ``ImportError`` without matplotlib.
    """
    des = _design(design)
    lenses = _validate.integer_in(lenses, "lenses", 1, 200)
    if channel is None:
        n = len(des.channels)
        if ax is None:
            from ._mpl import pyplot

            _, axs = pyplot().subplots(1, n, figsize=(4.6 * n, 5.0), layout="constrained",
                                       squeeze=False)
            ax = list(axs[0])
        ax = list(ax) if not hasattr(ax, "plot") else [ax]
        if len(ax) != n:
            raise ValueError(f"ax must be None or a sequence of {n} Axes (one per channel), "
                             f"got {len(ax)}")
        return [_microlens_images(des, c, lenses, a, n_threads) for c, a in
                enumerate(ax, start=1)]
    channel = _validate.integer_in(channel, "channel", 1, len(des.channels))
    return _microlens_images(des, channel, lenses, ax, n_threads)


def _microlens_images(des: Any, channel: int, lenses: int, ax: Any,
                      n_threads: int | None) -> Any:
    from ..sampling.samples2d import chief_samples

    ch = des.channels[channel - 1]
    info = des.resolved()[channel - 1]
    # Which lens, type and lit flag a pixel has does not depend on the depth: any valid
    # depth serves (here 100 F). Only the crop's rows are computed.
    grid_rows, grid_cols = (info["My"], info["Mx"]) if info["layout"] == "sensor" else \
        (ch.Ky * info["Q"], ch.Kx * info["Q"])
    pitch_px = ch.d * (1.0 + ch.v / ch.L) / ch.mu
    half = int(np.ceil(lenses * pitch_px / 2.0))
    rows, cols = _crop((grid_rows, grid_cols), (half, half))
    s = chief_samples(des, channel, 100.0 * des.F, n_threads=n_threads,
                      rows=(rows.start, rows.stop))
    lit, kind, lens = s.lit[:, cols], s.type[:, cols], s.lens[:, cols]
    palette = np.array([_rgb(TYPE_COLORS[t % len(TYPE_COLORS)]) for t in range(len(info["f"]))])
    img = np.where(lit[..., None], palette[kind], np.array(UNLIT))
    ax = axes(ax)
    ny, nx = lit.shape
    x0, y0 = cols.start, rows.start
    extent = (x0 - 0.5, x0 + nx - 0.5, y0 - 0.5, y0 + ny - 0.5)
    ax.imshow(img, origin="lower", extent=extent, interpolation="nearest")
    ax.add_collection(_cell_edges(lens, x0, y0))
    ax.set_xlim(extent[:2])
    ax.set_ylim(extent[2:])
    ax.set_aspect("equal")
    ax.set_xlabel("sensor column")
    ax.set_ylabel("sensor row")
    types = len(info["f"])
    layout = f"ideal layout, Q = {info['Q']}" if info["layout"] == "ideal" else \
        f"sensor layout, {info['Mx']} x {info['My']} px"
    ax.set_title(f"channel {channel}: {ch.grid} grid, {layout}\n"
                 f"{types} lens type{'s' if types > 1 else ''}; "
                 f"{np.count_nonzero(lit)} of {lit.size} pixels shown are lit", fontsize=9)
    from matplotlib.patches import Patch

    handles = [Patch(color=TYPE_COLORS[t % len(TYPE_COLORS)],
                     label=f"type {t + 1}: f = {info['f'][t]:.4g} mm") for t in range(types)]
    handles.append(Patch(color=UNLIT, label="unlit"))
    ax.legend(handles=handles, loc="upper right", fontsize=7, framealpha=0.9)
    return ax


def _cell_edges(lens: np.ndarray, x0: int, y0: int) -> Any:
    """Line segments along the pixel edges between neighbouring pixels of different lenses
    (the image cells' outlines), for pixel (row r, column c) at (x0 + c, y0 + r)."""
    from matplotlib.collections import LineCollection

    segs = []
    r, c = np.nonzero(np.any(lens[:, 1:] != lens[:, :-1], axis=-1))  # between c and c + 1
    x = x0 + c + 0.5
    segs.append(np.stack([np.stack([x, y0 + r - 0.5], -1), np.stack([x, y0 + r + 0.5], -1)], 1))
    r, c = np.nonzero(np.any(lens[1:, :] != lens[:-1, :], axis=-1))  # between r and r + 1
    y = y0 + r + 0.5
    segs.append(np.stack([np.stack([x0 + c - 0.5, y], -1), np.stack([x0 + c + 0.5, y], -1)], 1))
    return LineCollection(list(np.concatenate(segs)), colors=[BOUNDARY], linewidths=1.0)


def _rgb(name: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(name)


MARKERS = ("o", "x", "+", "^", "s", "v")


def sample_map(design: Any, z: float | None = None, ax: Any = None, *, tol: float = 1e-6,
               window: float = 16.0, zoom: float = 2.0, n_threads: int | None = None) -> Any:
    """The 2-D chief samples of every channel on the plane at depth ``z`` (docs/model.md
    §9): each channel's distinct samples (one colour and marker per channel) in units of
    delta(z), in a box of ``zoom`` lens pitches of channel 1 about the axis, with the
    distinct count and covering radius of each channel and of the union over the whole
    central field in the legend.

    - ``design``: a :class:`~splitlf.Design` (the :class:`~splitlf.Camera` is one)
    - ``z``: depth [mm], finite and > F; None (default): with several channels, channel
      1's out-of-focus plane (where channel 1 alone resolves least and the others must
      make up for it); with one channel, twice that depth (where its lenses' samples have
      spread out again)
    - ``tol``: merge tolerance [delta(z)]; ``window``: the central field's width in lens
      pitches of channel 1 (docs/model.md §9)
    - ``zoom``: the width of the box drawn, in lens pitches of channel 1, finite and > 0
      (at most ``window``)
    - ``ax``: a matplotlib Axes or None (a new figure); ``n_threads`` is accepted for
      symmetry with the other figures (one depth runs on one thread)

    Returns the Axes. Raises ``TypeError``/``ValueError`` for bad arguments,
    ``ImportError`` without matplotlib.
    """
    from ..sampling.samples2d import samples_2d

    des = _design(design)
    if z is None:
        z = des.out_of_focus_depth(1) * (1.0 if len(des.channels) > 1 else 2.0)
    zoom_ = _real("zoom", zoom)
    r = samples_2d(des, z, tol=tol, window=window)
    if not 0.0 < zoom_ <= r.window:
        raise InvalidParameter.of("zoom", zoom_, f"a finite number in (0, window = {r.window:g}]")
    delta = des.resolution_step(r.z)
    ch1 = des.channels[0]
    half = zoom_ / 2.0 * ch1.d * r.z / ch1.L / delta  # the box's half width [delta]
    ax = axes(ax)
    n_ch = len(des.channels)
    for row in range(n_ch):
        pts = r.samples[row] / delta
        pts = pts[np.all(np.abs(pts) <= 1.02 * half, axis=1)]
        marker = MARKERS[row % len(MARKERS)] if n_ch > 1 else "."
        color = TYPE_COLORS[row % len(TYPE_COLORS)]
        style = {"facecolors": "none", "edgecolors": color} if marker in "o^sv" else \
            {"color": color}
        ax.scatter(pts[:, 0], pts[:, 1], s=36 if marker == "o" else 14, marker=marker,
                   linewidths=0.8, **style,
                   label=f"{r.rows[row]}: {r.distinct[row]} distinct, "
                         f"rho = {r.covering_radius[row]:.3g} delta")
    if n_ch > 1:
        ax.plot([], [], " ", label=f"union: {r.distinct[-1]} distinct, "
                                   f"rho = {r.covering_radius[-1]:.3g} delta")
    ax.set_xlim(-1.04 * half, 1.04 * half)
    ax.set_ylim(-1.04 * half, 1.04 * half)
    ax.set_aspect("equal")
    ax.set_xlabel("X / delta(z)")
    ax.set_ylabel("Y / delta(z)")
    ax.set_title(f"chief samples at z = {r.z:.4g} mm (delta = {delta * 1e3:.3g} um), "
                 f"{zoom_:g} of {r.window:g} lens pitches shown;\n"
                 f"counts and covering radius rho over the {r.window:g}-pitch central field",
                 fontsize=9)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=7, ncol=1,
              framealpha=0.9)
    return ax


def _real(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:  # an integer beyond the float range
        x = -math.inf if value < 0 else math.inf
    if not math.isfinite(x):
        raise InvalidParameter.of(name, x, "a finite number > 0")
    return x
