"""What the split sensor (or any design's channels and their union) buys: MTF50 and RMSE of the
reconstruction against depth (docs/simulate.md)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _validate
from ..inverse.simulate import simulate
from ..model.design import Design
from ._mpl import SPLIT_COLOR, axes_pair, channel_colors, is_split

__all__ = ["resolution"]


def _styles(design: Design, configs: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """Line styles of the simulation's rows (``Simulation.configs``): one colour per
    channel, the union thick and black, the conventional camera dashed green; a
    two-channel design in the split sensor's words (half 1 alone, the original light
    field camera; half 2 alone; the split sensor)."""
    colors = channel_colors(design)
    split = is_split(design)
    out: dict[str, dict[str, Any]] = {}
    for key in configs:
        kind, _, number = key.partition(" ")
        if kind == "channel":
            c = int(number)
            label = (f"half {c} alone" + (" (original LF camera)" if c == 1 else "")
                     if split else f"channel {c} alone")
            out[key] = dict(color=colors[c], lw=1.4, label=label)
        elif kind == "union":
            out[key] = dict(color=SPLIT_COLOR, lw=2.2, label="split sensor (both halves)"
                            if split else "union (all channels)")
        else:
            out[key] = dict(color="tab:green", lw=1.4, ls="--",
                            label=f"conventional (no microlenses, sensor on plane {number})")
    return out


def resolution(
    camera: Design,
    z_range: tuple[float, float] = (150.0, 10_000.0),
    ax: Any = None,
    *,
    n: int = 28,
    noise: Mapping[str, float] | None = None,
    seed: int = 0,
    window: int = 256,
    n_frequencies: int = 32,
    n_threads: int | None = None,
) -> tuple[Any, Any]:
    """MTF50 (top, cycles/mm on the object, log-log) and RMSE of a random albedo (bottom)
    against depth for each channel alone (the seed: half 1, half 2), their union (the
    split sensor) and the conventional camera on channel 1's array plane, with the delta(z)
    Nyquist frequency and the microlens frequency of channel 1's pitch, L_1 / (d_1 z)
    (the seed: v'/(d z)), for reference, and every channel's out-of-focus plane marked.
    ``n`` log-spaced depths over ``z_range`` plus the out-of-focus planes; ``noise``,
    ``seed``, ``window``, ``n_frequencies`` are passed to :func:`splitlf.simulate`.

    - ``camera``: a :class:`~splitlf.Design` whose channels all have rect grids (the
      :class:`~splitlf.Camera` is one): one curve per row of its simulation
      (``Simulation.configs``)
    - ``z_range``: (near, far) [mm], F < near < far < inf
    - ``ax``: None (a new figure with two stacked axes) or a pair of Axes
    - ``n``: log-spaced depths (an integer >= 2); ``n_threads``: threads of the core

    Returns the pair of Axes. Raises ``TypeError`` and ``ValueError`` for bad arguments
    (those of :func:`splitlf.simulate` too; a hex channel i is named
    ``channels[i].grid``, before anything is drawn), ``ImportError`` without matplotlib or
    SciPy.
    """
    cam = _validate.design(camera, "camera")
    _validate.rect_grids(cam)
    lo, hi = (_validate.real(v, "z_range") for v in z_range)
    if not (cam.F < lo < hi < np.inf):
        raise ValueError(f"invalid z_range = ({lo}, {hi}): allowed F = {cam.F} < near < far")
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise ValueError(f"invalid n = {n!r}: allowed an integer >= 2")
    colors = channel_colors(cam)
    numbers = tuple(colors)
    axes = axes_pair(ax, (9.0, 7.5), "MTF50, RMSE")
    a_mtf, a_rmse = axes
    extra = [cam.out_of_focus_depth(h) for h in numbers]
    z = np.unique(np.concatenate([np.geomspace(lo, hi, n), [e for e in extra if lo < e < hi]]))
    runs = [simulate(cam, zk, noise=noise, seed=seed, window=window,
                     n_frequencies=n_frequencies, oversample=4, n_threads=n_threads)
            for zk in z]
    styles = _styles(cam, runs[0].configs)
    for key, style in styles.items():
        a_mtf.plot(z, [r.mtf50[key] for r in runs], marker="o", ms=3, **style)
        a_rmse.plot(z, [r.rmse[key] for r in runs], marker="o", ms=3, **style)
    a_mtf.plot(z, [r.nyquist for r in runs], color="0.45", lw=0.9, ls=":",
               label="full sensor resolution: Nyquist of delta(z)")
    pitch = "microlens pitch" if is_split(cam) else "channel 1's microlens pitch"
    a_mtf.plot(z, [r.microlens_frequency for r in runs], color="0.45", lw=0.9, ls="-.",
               label=f"microlens resolution: one cycle per {pitch}")
    for h in numbers:
        zo = cam.out_of_focus_depth(h)
        if lo < zo < hi:
            for a in axes:
                a.axvline(zo, color=colors[h], lw=0.8, ls=":")
            a_mtf.annotate(f"out-of-focus\nplane {h}: {zo:.0f} mm", (zo, 0.02),
                           xycoords=("data", "axes fraction"), xytext=(3, 0),
                           textcoords="offset points", fontsize=8, color=colors[h])
    a_mtf.set_xscale("log")
    a_mtf.set_yscale("log")
    a_mtf.set_ylabel("MTF50 [cycles/mm on the object]")
    kind = "noise-free" if noise is None else (
        f"{noise['photons']:g} photons, read noise {noise.get('read_noise', 0):g} e-")
    what = "what the split sensor buys" if is_split(cam) else "each channel and their union"
    a_mtf.set_title(f"Reconstruction with known depth ({kind}): {what}")
    a_mtf.legend(fontsize=8, loc="upper right")
    a_rmse.set_ylabel("RMSE, random albedo on delta(z) cells")
    a_rmse.set_xlabel("depth z [mm] (log)")
    a_rmse.set_ylim(bottom=0.0)
    for a in axes:
        a.grid(True, which="both", lw=0.3, alpha=0.5)
    return a_mtf, a_rmse
