"""Distinct samples and resolution (max gap) against depth: docs/model.md §6, docs/samples.md."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate
from ..camera import Camera
from ..design import Design
from ..errors import InvalidParameter
from ..samples import coincidence_planes, new_samples, sweep_depths
from ._mpl import ROW_COLORS, axes_pair

__all__ = ["samples"]

_COLORS = {1: "tab:blue", 2: "tab:orange", "split": "black"}


def samples(
    camera: Camera,
    z_range: tuple[float, float] = (150.0, 10_000.0),
    ax: Any = None,
    *,
    n: int = 600,
    max_n: int = 2,
    tol: float = 1e-6,
    n_threads: int | None = None,
):
    """Distinct samples (top) and max gap in units of delta(z) (bottom) against log depth,
    for half 1, half 2 and the split sensor (union), with the out-of-focus planes (dashed
    vertical lines) and the coincidence planes N <= ``max_n`` (ticks on the top axis) marked.

    - ``camera``: the :class:`~splitlf.Camera`, or a :class:`~splitlf.Design` with rect
      channels (one curve per channel, then the union; coincidence planes of the channels
      that have them: ideal layout, square aperture)
    - ``z_range``: (near, far) depths [mm]; ``n`` depths over it from
      :func:`splitlf.samples.sweep_depths` (log-spaced plus the coincidence planes)
    - ``ax``: None (a new figure with two stacked axes) or a pair of matplotlib Axes
      (counts, gap)
    - ``max_n``: coincidence planes marked up to this N; ``tol``: merge tolerance
      [delta(z)]; ``n_threads``: threads of the core (None: all cores)

    Returns the pair of Axes. Raises ``TypeError`` and ``ValueError`` for bad arguments
    (checked by the functions it calls), ``ImportError`` without matplotlib.
    """
    cam = _validate.camera_or_design(camera)
    if isinstance(cam, Design):
        return _design_samples(cam, z_range, ax, n=n, max_n=max_n, tol=tol,
                               n_threads=n_threads)
    axes = axes_pair(ax, (11.5, 7.5), "counts, gap")
    a_count, a_gap = axes
    z = sweep_depths(cam, z_range, n=n, max_n=max(max_n, 1))
    r = new_samples(cam, z, tol=tol, n_threads=n_threads)
    labels = {0: f"half 1 ({r.sampled[0]} pixels)", 1: f"half 2 ({r.sampled[1]} pixels)",
              2: f"split sensor ({r.sampled[2]} pixels)"}
    colors = [_COLORS[1], _COLORS[2], _COLORS["split"]]
    for row in range(3):
        lw = 1.6 if row == 2 else 1.1
        a_count.plot(z, r.distinct[row], color=colors[row], lw=lw, label=labels[row])
        gap = np.where(np.isfinite(r.max_gap[row]), r.max_gap[row], np.nan)
        a_gap.plot(z, gap, color=colors[row], lw=lw, label=labels[row].split(" (")[0])
    for row in range(3):
        a_count.axhline(r.sampled[row], color=colors[row], lw=0.6, ls=":")
    a_gap.axhline(1.0, color="0.4", lw=0.8, ls=":")
    a_gap.axhline(cam.Q, color="0.4", lw=0.8, ls=":")
    a_gap.annotate("full sensor resolution (1)", (z[-1], 1.0), xytext=(-4, -11), ha="right",
                   textcoords="offset points", fontsize=8, color="0.3")
    a_gap.annotate(f"microlens resolution, Q = {cam.Q}", (z[-1], cam.Q), xytext=(-4, 3),
                   ha="right", textcoords="offset points", fontsize=8, color="0.3")
    lo, hi = z[0], z[-1]
    for h in (1, 2):
        zo = cam.out_of_focus_depth(h)
        if lo <= zo <= hi:
            for a in axes:
                a.axvline(zo, color=_COLORS[h], lw=0.9, ls="--")
            a_count.annotate(f"out-of-focus plane {h}\n{zo:.0f} mm", (zo, 0.02),
                             xycoords=("data", "axes fraction"), xytext=(3, 0),
                             textcoords="offset points", fontsize=8, color=_COLORS[h])
        planes = coincidence_planes(cam, h, max_n=max_n)
        zc = planes.z[(planes.z >= lo) & (planes.z <= hi)]
        a_count.plot(zc, np.full(zc.size, 1.0 - 0.03 * h), ls="none", marker="|", ms=9,
                     color=_COLORS[h], transform=a_count.get_xaxis_transform(),
                     label=f"coincidence planes, half {h} (N <= {max_n})")
    a_count.set_xscale("log")
    a_count.set_ylabel("distinct samples along x")
    a_count.set_ylim(0, r.sampled[2] * 1.12)
    a_count.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    a_count.set_title("Genuinely new samples and resolution (chief samples, docs/model.md §6)")
    a_gap.set_yscale("log")
    a_gap.set_ylabel("max gap in the central field [delta(z)]")
    a_gap.set_xlabel("depth z [mm] (log)")
    a_gap.set_ylim(0.75, cam.Q * 1.5)
    a_gap.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for a in axes:
        a.grid(True, which="both", lw=0.3, alpha=0.5)
    return a_count, a_gap


def _design_samples(des: Design, z_range: tuple[float, float], ax: Any, *, n: int, max_n: int,
                    tol: float, n_threads: int | None):
    """:func:`samples` for a Design: the rows of :func:`splitlf.new_samples`."""
    axes = axes_pair(ax, (11.5, 7.5), "counts, gap")
    a_count, a_gap = axes
    z = sweep_depths(des, z_range, n=n, max_n=max(max_n, 1))
    r = new_samples(des, z, tol=tol, n_threads=n_threads)
    n_ch = len(des.channels)
    colors = [ROW_COLORS[i % len(ROW_COLORS)] for i in range(n_ch)] + ["black"]
    for row, name in enumerate(r.rows):
        lw = 1.6 if row == n_ch else 1.1
        a_count.plot(z, r.distinct[row], color=colors[row], lw=lw,
                     label=f"{name} ({r.sampled[row]} pixels)")
        gap = np.where(np.isfinite(r.max_gap[row]), r.max_gap[row], np.nan)
        a_gap.plot(z, gap, color=colors[row], lw=lw, label=name)
        a_count.axhline(r.sampled[row], color=colors[row], lw=0.6, ls=":")
    a_gap.axhline(1.0, color="0.4", lw=0.8, ls=":")
    a_gap.annotate("one pixel of a conventional camera on plane 1 (1)", (z[-1], 1.0),
                   xytext=(-4, -11), ha="right", textcoords="offset points", fontsize=8,
                   color="0.3")
    lo, hi = z[0], z[-1]
    for c in range(1, n_ch + 1):
        zo = des.out_of_focus_depth(c)
        if lo <= zo <= hi:
            for a in axes:
                a.axvline(zo, color=colors[c - 1], lw=0.9, ls="--")
            a_count.annotate(f"out-of-focus plane {c}\n{zo:.0f} mm", (zo, 0.02 + 0.09 * (c - 1)),
                             xycoords=("data", "axes fraction"), xytext=(3, 0),
                             textcoords="offset points", fontsize=8, color=colors[c - 1],
                             bbox={"fc": "white", "ec": "none", "alpha": 0.75, "pad": 1.0})
        try:
            planes = coincidence_planes(des, channel=c, max_n=max_n)
        except InvalidParameter:  # no coincidence planes (sensor layout, circle aperture)
            continue
        zc = planes.z[(planes.z >= lo) & (planes.z <= hi)]
        a_count.plot(zc, np.full(zc.size, 1.0 - 0.03 * c), ls="none", marker="|", ms=9,
                     color=colors[c - 1], transform=a_count.get_xaxis_transform(),
                     label=f"coincidence planes, channel {c} (N <= {max_n})")
    a_count.set_xscale("log")
    a_count.set_ylabel("distinct samples along x")
    a_count.set_ylim(0, r.sampled[-1] * 1.12)
    a_count.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    a_count.set_title("Genuinely new samples and resolution along x (chief samples, "
                      "docs/model.md §6, §9)")
    a_gap.set_yscale("log")
    a_gap.set_ylabel("max gap in the central field [delta(z)]")
    a_gap.set_xlabel("depth z [mm] (log)")
    finite = r.max_gap[np.isfinite(r.max_gap)]
    a_gap.set_ylim(0.75, 1.5 * max(float(finite.max()) if finite.size else 1.0, 1.0))
    a_gap.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for a in axes:
        a.grid(True, which="both", lw=0.3, alpha=0.5)
    return a_count, a_gap
