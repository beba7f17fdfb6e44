"""A raw image as a picture (docs/model.md §10, "Raw image layout"): each channel's sensor
image in grey, with a zoom on a few micro-images at its centre."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _validate
from ._mpl import channel_name, pyplot

__all__ = ["raw"]

#: Most lens pitches the zoom spans per axis.
MAX_ZOOM = 100


def _pitch(ch: dict[str, Any]) -> tuple[float, float]:
    """A micro-image's pitch in pixels (rows, columns): Q for the ideal layout, the
    image cell d (1 + v/L) over mu for the sensor layout (hex rows: sqrt(3)/2 of it)."""
    if ch["layout"] == "ideal":
        return float(ch["Q"]), float(ch["Q"])
    p = ch["d"] * (1 + ch["v"] / ch["L"]) / ch["mu"]
    return (p * math.sqrt(3) / 2 if ch["grid"] == "hex" else p), p


def _crop(shape: tuple[int, ...], ch: dict[str, Any], zoom: int) -> tuple[slice, slice]:
    """The centred crop spanning ``zoom`` micro-images per axis (on lens boundaries for
    the ideal layout), clipped to the raw."""
    out = []
    for n, p, k in zip(shape, _pitch(ch), ("Ky", "Kx"), strict=True):
        if ch["layout"] == "ideal":
            q = int(p)
            first = max(ch[k] // 2 - zoom // 2, 0) * q
            out.append(slice(first, min(first + zoom * q, n)))
        else:
            half = max(1, math.ceil(zoom * p / 2))
            out.append(slice(max(n // 2 - half, 0), min(n // 2 + half, n)))
    return out[0], out[1]


def _show(ax: Any, image: np.ndarray, rows: slice, cols: slice, vmax: float,
          nearest: bool) -> None:
    ax.imshow(image[rows, cols], cmap="gray", vmin=0.0, vmax=vmax, origin="upper",
              interpolation="nearest" if nearest else "antialiased",
              extent=(cols.start - 0.5, cols.stop - 0.5, rows.stop - 0.5, rows.start - 0.5))


def _draw(raw: Any, c: int, zoom: int, ax: Any, zax: Any) -> None:
    """Channel c's raw on ``ax`` and its zoom on ``zax`` (None: an inset of ``ax``)."""
    image = raw.images[c - 1]
    ch = raw.design.resolved()[c - 1]
    rows, cols = image.shape
    vmax = max(float(image.max()), 1e-300)
    _show(ax, image, slice(0, rows), slice(0, cols), vmax, nearest=False)
    name = channel_name(raw.design, c)
    ax.set_title(f"{name} raw: {ch['layout']} layout, {ch['grid']} grid, {rows} x {cols} "
                 f"pixels (grey 0 to {vmax:.3g})", fontsize=9)
    ax.set_xlabel("column (pixel)")
    ax.set_ylabel("row (pixel)")
    r, k = _crop(image.shape, ch, zoom)
    inset = zax is None
    if inset:
        zax = ax.inset_axes((0.62, 0.55, 0.36, 0.42))
    _show(zax, image, r, k, vmax, nearest=True)
    zax.set_title(f"centre, {zoom} x {zoom} micro-images", fontsize=8)
    if inset:
        zax.tick_params(labelsize=6)
        ax.indicate_inset_zoom(zax, edgecolor="tab:red")
    else:
        zax.set_xlabel("column (pixel)")
        ax.add_patch(pyplot().Rectangle((k.start - 0.5, r.start - 0.5), k.stop - k.start,
                                        r.stop - r.start, fill=False, ec="tab:red", lw=1.0))


def raw(raw: Any, channel: int | None = None, zoom: int = 3, ax: Any = None) -> Any:
    """Each channel's raw (:class:`~splitlf.Raw`) as a grey image (row 0 at the top, as
    stored: docs/model.md §10), from 0 to the channel's brightest pixel, with a zoom on
    ``zoom`` x ``zoom`` micro-images at its centre (nearest-pixel, so the pixels show).

    - ``channel``: the channel, from 1; None (default): every channel, one above the other
    - ``zoom``: micro-images per axis in the zoom, an integer in [1, :data:`MAX_ZOOM`]
    - ``ax``: None (a new figure: each raw with its zoom in a panel beside it) or the Axes
      to draw on (a sequence of one per channel when ``channel`` is None; the zoom is then
      an inset)

    Returns the matplotlib Figure. Raises ``TypeError``/``ValueError`` for bad arguments,
    ``ImportError`` without matplotlib."""
    from ..imaging.render import Raw

    if not isinstance(raw, Raw):
        raise TypeError(f"raw must be a splitlf.Raw, got {type(raw).__name__}")
    n = len(raw.images)
    chans = (list(range(1, n + 1)) if channel is None
             else [_validate.integer_in(channel, "channel", 1, n)])
    zoom = _validate.integer_in(zoom, "zoom", 1, MAX_ZOOM)
    if ax is None:
        rows0, cols0 = raw.images[chans[0] - 1].shape
        width = 9.0
        height = len(chans) * (width * 0.7 * rows0 / cols0 + 0.9)
        fig, axs = pyplot().subplots(len(chans), 2, figsize=(width, max(height, 3.0)),
                                     layout="constrained", squeeze=False,
                                     gridspec_kw={"width_ratios": (2.4, 1.0)})
        for c, (a, z) in zip(chans, axs, strict=True):
            _draw(raw, c, zoom, a, z)
        return fig
    axes = [ax] if hasattr(ax, "imshow") else list(ax)
    if len(axes) != len(chans):
        raise ValueError(f"ax must be None, an Axes or a sequence of {len(chans)} Axes "
                         f"(one per channel), got {len(axes)}")
    for c, a in zip(chans, axes, strict=True):
        _draw(raw, c, zoom, a, None)
    return axes[0].figure
