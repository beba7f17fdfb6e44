"""Lazy matplotlib access: the plot extra is optional, and the library never picks a backend."""

from __future__ import annotations

from typing import Any

HALF_COLORS = {1: "tab:blue", 2: "tab:orange"}
#: Most depths a curve figure draws (far beyond what a figure can show).
MAX_POINTS = 1_000_000
SPLIT_COLOR = "black"


def pyplot() -> Any:
    """``matplotlib.pyplot``, imported on first use; ``ImportError`` naming the extra."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - exercised only without matplotlib
        raise ImportError(
            "splitlf.plot needs matplotlib: pip install \"splitlf[plot]\""
        ) from e
    return plt


def axes(ax: Any) -> Any:
    """The given Axes, or a new figure's Axes."""
    if ax is not None:
        return ax
    _, ax = pyplot().subplots(figsize=(7.0, 4.2), layout="constrained")
    return ax


def axes_pair(ax: Any, figsize: tuple[float, float], names: str) -> list[Any]:
    """Two stacked Axes sharing x: the given pair, or a new figure's."""
    if ax is None:
        _, axs = pyplot().subplots(2, 1, sharex=True, figsize=figsize, layout="constrained")
        return list(axs)
    axs = list(ax)
    if len(axs) != 2:
        raise ValueError(f"ax must be None or a pair of Axes ({names})")
    return axs


#: Colours of the rows of a general design's figures (channels, or lens types), cycled.
ROW_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
              "tab:pink", "tab:olive", "tab:cyan", "tab:gray")


def channels(camera: Any) -> range:
    """The channel numbers of a Design (1..C), or a Camera's halves (1, 2)."""
    n = len(camera.channels) if hasattr(camera, "channels") else 2
    return range(1, n + 1)


def mark_channels_out_of_focus(ax: Any, design: Any, colors: dict[int, str]) -> None:
    """Dotted vertical lines at every channel's out-of-focus plane [mm], labelled."""
    for c in channels(design):
        z = design.out_of_focus_depth(c)
        ax.axvline(z, color=colors[c], lw=0.8, ls=":",
                   label=f"out-of-focus plane {c} ({z:.0f} mm)")


def mark_out_of_focus(ax: Any, camera: Any, label: bool = True) -> None:
    """Dotted vertical lines at both out-of-focus planes [mm] on ``ax`` (labelled when
    ``label``)."""
    for h in (1, 2):
        z = camera.out_of_focus_depth(h)
        ax.axvline(z, color=HALF_COLORS[h], lw=0.8, ls=":",
                   label=f"out-of-focus plane {h} ({z:.0f} mm)" if label else None)


def depth_grid(camera: Any, z_range: tuple[float, float], n: int) -> Any:
    """Log-spaced depths over z_range plus both out-of-focus planes (so peaks are drawn)."""
    import numpy as np

    lo, hi = (float(z_range[0]), float(z_range[1]))
    if not (camera.F < lo < hi and np.isfinite(hi)):
        raise ValueError(
            f"invalid z_range = ({lo}, {hi}): allowed F = {camera.F} < near < far < inf (mm)"
        )
    if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= MAX_POINTS:
        raise ValueError(f"invalid n = {n!r}: allowed an integer in [2, {MAX_POINTS}]")
    z = np.geomspace(lo, hi, n)
    extra = [camera.out_of_focus_depth(h) for h in channels(camera)]
    extra = [e for e in extra if lo < e < hi]
    return np.unique(np.concatenate([z, extra]))


def trace_threads(n_threads: int | None) -> dict[str, int]:
    """Keyword arguments that run :func:`splitlf.trace` on ``n_threads`` threads (empty for
    None: all cores)."""
    return {} if n_threads is None else {"n_threads": n_threads}
