"""Distinct samples and resolution (max gap) against depth: docs/model.md §6, docs/samples.md."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate
from ..errors import InvalidParameter
from ..model.design import Design
from ..sampling.samples import coincidence_planes, new_samples, sweep_depths
from ._mpl import ROW_COLORS, axes_pair, is_split, row_name

__all__ = ["samples"]

#: Out-of-focus planes closer than this ratio of depths get their labels stacked.
_CLOSE = 1.6


def _microlens_line(des: Design) -> tuple[float, str] | None:
    """Channel 1's microlens resolution in delta(z) (one sample per lens: its pitch d_1
    over the pixel mu_1) and its label; None for a sensor layout (no Q)."""
    ch1 = des.resolved()[0]
    q = ch1.get("Q")
    if q is None:
        return None
    ratio = des.channels[0].d / des.channels[0].mu
    if abs(ratio - q) <= 1e-9 * q:
        return float(q), f"microlens resolution, Q = {q}"
    return ratio, f"microlens resolution of channel 1, d/mu = {ratio:.3g}"


def samples(
    camera: Design,
    z_range: tuple[float, float] = (150.0, 10_000.0),
    ax: Any = None,
    *,
    n: int = 600,
    max_n: int = 2,
    tol: float = 1e-6,
    n_threads: int | None = None,
) -> tuple[Any, Any]:
    """Distinct samples (top) and max gap in units of delta(z) (bottom) against log depth,
    for each channel (the seed: half 1, half 2) and their union (the split sensor), with
    the out-of-focus planes (dashed vertical lines) and the coincidence planes N <=
    ``max_n`` (ticks on the top axis) marked.

    - ``camera``: a :class:`~splitlf.Design` with rect channels (the
      :class:`~splitlf.Camera` is one): one curve per channel, then the union;
      coincidence planes of the channels that have them (ideal layout, square aperture)
    - ``z_range``: (near, far) depths [mm]; ``n`` depths over it from
      :func:`splitlf.samples.sweep_depths` (log-spaced plus the coincidence planes)
    - ``ax``: None (a new figure with two stacked axes) or a pair of matplotlib Axes
      (counts, gap)
    - ``max_n``: coincidence planes marked up to this N; ``tol``: merge tolerance
      [delta(z)]; ``n_threads``: threads of the core (None: all cores)

    Returns the pair of Axes. Raises ``TypeError`` and ``ValueError`` for bad arguments
    (checked by the functions it calls), ``ImportError`` without matplotlib.
    """
    des = _validate.design(camera, "camera")
    axes = axes_pair(ax, (11.5, 7.5), "counts, gap")
    a_count, a_gap = axes
    z = sweep_depths(des, z_range, n=n, max_n=max(max_n, 1))
    r = new_samples(des, z, tol=tol, n_threads=n_threads)
    n_ch = len(des.channels)
    colors = [ROW_COLORS[i % len(ROW_COLORS)] for i in range(n_ch)] + ["black"]
    names = [row_name(des, name) for name in r.rows]
    for row, name in enumerate(names):
        lw = 1.6 if row == n_ch else 1.1
        a_count.plot(z, r.distinct[row], color=colors[row], lw=lw,
                     label=f"{name} ({r.sampled[row]} pixels)")
        gap = np.where(np.isfinite(r.max_gap[row]), r.max_gap[row], np.nan)
        a_gap.plot(z, gap, color=colors[row], lw=lw, label=name)
    for row in range(len(names)):
        a_count.axhline(r.sampled[row], color=colors[row], lw=0.6, ls=":")
    a_gap.axhline(1.0, color="0.4", lw=0.8, ls=":")
    one = ("full sensor resolution (1)" if is_split(des)
           else "one pixel of a conventional camera on plane 1 (1)")
    a_gap.annotate(one, (z[-1], 1.0), xytext=(-4, -11), ha="right",
                   textcoords="offset points", fontsize=8, color="0.3")
    microlens = _microlens_line(des)
    if microlens is not None:
        a_gap.axhline(microlens[0], color="0.4", lw=0.8, ls=":")
        a_gap.annotate(microlens[1], (z[-1], microlens[0]), xytext=(-4, 3), ha="right",
                       textcoords="offset points", fontsize=8, color="0.3")
    lo, hi = z[0], z[-1]
    oof = {c: des.out_of_focus_depth(c) for c in range(1, n_ch + 1)}
    shown = sorted(zo for zo in oof.values() if lo <= zo <= hi)
    # planes close on the log axis: their labels are stacked by channel, on white boxes
    crowded = any(b < _CLOSE * a for a, b in zip(shown, shown[1:], strict=False))
    box = {"fc": "white", "ec": "none", "alpha": 0.75, "pad": 1.0} if crowded else None
    for c in range(1, n_ch + 1):
        zo = oof[c]
        if lo <= zo <= hi:
            for a in axes:
                a.axvline(zo, color=colors[c - 1], lw=0.9, ls="--")
            height = 0.02 + 0.09 * (c - 1) * crowded
            a_count.annotate(f"out-of-focus plane {c}\n{zo:.0f} mm", (zo, height),
                             xycoords=("data", "axes fraction"), xytext=(3, 0),
                             textcoords="offset points", fontsize=8, color=colors[c - 1],
                             bbox=box)
        try:
            planes = coincidence_planes(des, channel=c, max_n=max_n)
        except InvalidParameter:  # no coincidence planes (sensor layout, circle aperture)
            continue
        zc = planes.z[(planes.z >= lo) & (planes.z <= hi)]
        a_count.plot(zc, np.full(zc.size, 1.0 - 0.03 * c), ls="none", marker="|", ms=9,
                     color=colors[c - 1], transform=a_count.get_xaxis_transform(),
                     label=f"coincidence planes, {row_name(des, f'channel {c}')} "
                           f"(N <= {max_n})")
    a_count.set_xscale("log")
    a_count.set_ylabel("distinct samples along x")
    a_count.set_ylim(0, r.sampled[-1] * 1.12)
    a_count.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    a_count.set_title("Genuinely new samples and resolution (chief samples, docs/model.md §6)")
    a_gap.set_yscale("log")
    a_gap.set_ylabel("max gap in the central field [delta(z)]")
    a_gap.set_xlabel("depth z [mm] (log)")
    finite = r.max_gap[np.isfinite(r.max_gap)]
    top = max(float(finite.max()) if finite.size else 1.0, 1.0,
              0.0 if microlens is None else microlens[0])
    a_gap.set_ylim(0.75, 1.5 * top)
    a_gap.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for a in axes:
        a.grid(True, which="both", lw=0.3, alpha=0.5)
    return a_count, a_gap
