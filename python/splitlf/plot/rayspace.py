"""The ray space of the split-sensor camera: the right panel of the paper's Fig. 4."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _validate, rayspace
from ..camera import Camera
from ..design import Design
from ._mpl import pyplot, trace_threads

__all__ = ["ray_space"]

#: The paper's colours: half 1 grey, half 2 yellow; scene planes red, green, blue.
HALF_COLOURS = {1: ("0.62", "0.30"), 2: ("#f5d000", "#9a7d00")}
DEPTH_COLOURS = ("#d62728", "#2ca02c", "#1f5fd6")
#: Channels 3, 4, ... of a design (none of them red, green or blue, the planes' colours).
MORE_CHANNEL_COLOURS = ("#b07cc6", "#c49c94", "#e377c2", "#bcbd22", "#17becf")


def _polygons(tr, keep):
    return [tr.vertices[i, : tr.n_vertices[i]] for i in np.flatnonzero(keep)]


def _check(camera: Camera | Design, depths: Sequence[float] | None, n_lenses: int,
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


def _draw_half(ax: Any, cam: Camera, half: int, axis: str, n_lenses: int,
               n_threads: int | None) -> tuple[np.ndarray, np.ndarray, Any]:
    """The integration polygons of ``n_lenses`` central microlenses of ``half``. Returns
    (their vertices, u at w = 0 of the drawn microlens centres, a legend handle)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    tr = rayspace.trace(cam, half, axis, **trace_threads(n_threads))
    K = int(tr.lens.max()) + 1
    first = max(0, (K - n_lenses) // 2)
    keep = (tr.lens >= first) & (tr.lens < first + n_lenses) & (tr.n_vertices > 0)
    face, edge = HALF_COLOURS[half]
    alpha = 0.75 if half == 1 else 0.6
    ax.add_collection(
        PolyCollection(
            _polygons(tr, keep),
            facecolors=face,
            edgecolors=edge,
            linewidths=0.7,
            alpha=alpha,
            zorder=1 + half,
        )
    )
    # u at w = 0 of the drawn microlens centres, (v'/L_i) c_j
    j = np.arange(first, min(first + n_lenses, K))
    centres = cam.v1 / cam.L(half) * (j - (K - 1) / 2) * cam.d
    n_px = int(keep.sum())
    handle = Patch(facecolor=face, edgecolor=edge, alpha=alpha,
                   label=f"half {half}: {n_px} pixels under {n_lenses} microlenses")
    return tr.vertices[keep], centres, handle


def _draw_planes(ax: Any, cam: Camera, zs: np.ndarray, centres: dict[int, np.ndarray]
                 ) -> list[Any]:
    """The constant-intensity lines of each scene plane; returns the legend handles."""
    from matplotlib.lines import Line2D

    w = np.array([-cam.D / 2, cam.D / 2])
    handles = []
    for z, colour in zip(zs, DEPTH_COLOURS, strict=False):
        zc = cam.F * z / (z - cam.F)
        sigma = (cam.v1 - zc) / zc  # a point of the plane is the line u + sigma w = p'
        # through the microlens centres of the half this plane is out of focus for
        # (the lines then run along its microlens columns), else of half 1
        own = [h for h in (1, 2) if np.isclose(z, cam.out_of_focus_depth(h), rtol=1e-9)]
        for p in centres[own[0] if own else 1]:
            ax.plot(p - sigma * w, w, color=colour, lw=1.5, zorder=5)
        handles.append(Line2D([], [], color=colour, lw=1.5, label=_depth_label(cam, z)))
    return handles


def ray_space(
    camera: Camera,
    depths: Sequence[float] | None = None,
    n_lenses: int = 3,
    axis: str = "x",
    ax: Any = None,
    *,
    n_threads: int | None = None,
) -> Any:
    """The paper's Fig. 4 (right) for ``camera``: in the ray space (u on plane v', w on the
    main lens), the integration regions of every pixel under ``n_lenses`` neighbouring
    central microlenses of half 1 (grey) and of half 2 (yellow), and the
    constant-intensity lines u + sigma w = p' of up to three scene planes (red, green,
    blue), one line through each drawn microlens centre at w = 0 (of the half
    whose out-of-focus plane it is, else of half 1).

    - ``camera``: the :class:`~splitlf.Camera`, or a :class:`~splitlf.Design` with rect
      channels: u is then on channel 1's array plane, each channel is drawn (channels 1
      and 2 in the paper's grey and yellow), and the default depths are the channels'
      out-of-focus planes (the first three; with one channel, its plane and 2.5 times it)
    - ``depths``: 1 to 3 scene depths [mm], finite and > F; default the out-of-focus
      planes of half 1 (vertical lines) and half 2 (lines parallel to half 2's microlens
      columns) and a far plane at 2.5 z_1
    - ``n_lenses``: microlenses drawn per half (an integer >= 1)
    - ``axis``: "x" or "y", the axis traced (:func:`splitlf.trace`)
    - ``ax``: a matplotlib Axes, or None for a new figure
    - ``n_threads``: threads of the trace (None: all cores)

    Returns the Axes. Raises ``TypeError`` (camera, types) and ``ValueError`` (depths,
    n_lenses, axis out of range); ``ImportError`` without matplotlib.
    """
    cam = _validate.camera_or_design(camera)
    if isinstance(cam, Design):
        return _design_ray_space(cam, depths, n_lenses, axis, ax, n_threads)
    z1 = cam.out_of_focus_depth(1)
    zs = _check(cam, depths, n_lenses, (z1, cam.out_of_focus_depth(2), 2.5 * z1))
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(9.0, 6.0), layout="constrained")

    handles, drawn, centres = [], [], {}
    for half in (1, 2):
        verts, centres[half], handle = _draw_half(ax, cam, half, axis, n_lenses, n_threads)
        drawn.append(verts)
        handles.append(handle)
    allv = np.concatenate(drawn)
    u_lo, u_hi = np.nanmin(allv[..., 0]), np.nanmax(allv[..., 0])
    handles += _draw_planes(ax, cam, zs, centres)

    half_d = cam.D / 2
    pad = 0.03 * (u_hi - u_lo)
    ax.set_xlim(u_lo - pad, u_hi + pad)
    ax.set_ylim(-1.08 * half_d, 1.08 * half_d)
    for y in (-half_d, half_d):
        ax.axhline(y, color="0.15", lw=0.9, ls="--", zorder=6)
    ax.text(u_hi, half_d, "aperture edge  ", ha="right", va="bottom", fontsize=8, color="0.15")
    ax.set_xlabel("u: ray height on the plane of microlens array 1 [mm]")
    ax.set_ylabel("w: ray height on the main lens [mm]")
    ax.set_title("Ray space: pixel integration regions and constant-intensity lines")
    ax.legend(
        handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=2, fontsize=8.5
    )
    return ax


def _depth_label(cam: Camera, z: float) -> str:
    for half in (1, 2):
        if np.isclose(z, cam.out_of_focus_depth(half), rtol=1e-9):
            return f"scene plane z = {z:.0f} mm (out-of-focus plane of half {half})"
    return f"scene plane z = {z:.0f} mm"


def _channel_colours(c: int) -> tuple[str, str]:
    """(face, edge) of channel c: the paper's grey and yellow for 1 and 2, then a palette."""
    if c in HALF_COLOURS:
        return HALF_COLOURS[c]
    colour = MORE_CHANNEL_COLOURS[(c - 3) % len(MORE_CHANNEL_COLOURS)]
    return colour, colour


def _design_ray_space(des: Design, depths: Sequence[float] | None, n_lenses: int, axis: str,
                      ax: Any, n_threads: int | None) -> Any:
    """:func:`ray_space` for a Design (rect channels): u on channel 1's array plane L_1."""
    from matplotlib.collections import PolyCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n_ch = len(des.channels)
    oof = [des.out_of_focus_depth(c) for c in range(1, n_ch + 1)]
    zs = _check(des, depths, n_lenses, oof[:3] if n_ch > 1 else [oof[0], 2.5 * oof[0]])
    if ax is None:
        _, ax = pyplot().subplots(figsize=(9.0, 6.0), layout="constrained")
    L1 = des.channels[0].L
    handles, drawn, centres = [], [], {}
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
                             label=f"channel {c}: {int(keep.sum())} pixels under "
                                   f"{len(j)} microlenses"))
    w = np.array([-des.D / 2, des.D / 2])
    for z, colour in zip(zs, DEPTH_COLOURS, strict=False):
        zc = des.F * z / (z - des.F)
        sigma = (L1 - zc) / zc  # a point of the plane is the line u + sigma w = p'
        own = [c for c in range(1, n_ch + 1) if np.isclose(z, oof[c - 1], rtol=1e-9)]
        for p in centres[own[0] if own else 1]:
            ax.plot(p - sigma * w, w, color=colour, lw=1.5, zorder=5 + n_ch)
        label = f"scene plane z = {z:.0f} mm" + \
            (f" (out-of-focus plane of channel {own[0]})" if own else "")
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
