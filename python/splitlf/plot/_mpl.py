"""Lazy matplotlib access: the plot extra is optional, and the library never picks a backend."""

from __future__ import annotations

from typing import Any

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


def channels(design: Any) -> range:
    """The channel numbers of a design, 1..C."""
    return range(1, len(design.channels) + 1)


def is_split(design: Any) -> bool:
    """Whether the figures speak the split sensor's words (docs/model.md §1): a design of
    two channels, whose channel i is half i and whose union is the split sensor."""
    return len(design.channels) == 2


def channel_name(design: Any, c: int) -> str:
    """Channel c's name in a figure: ``"half c"`` for a two-channel design (the split
    sensor, e.g. the seed), else ``"channel c"``."""
    return f"half {c}" if is_split(design) else f"channel {c}"


def row_name(design: Any, row: str) -> str:
    """A result row's name (``"channel c"``, ``"channel c type t"``, ``"union"``) in a
    figure's words: :func:`channel_name`, and ``"split sensor"`` for the union of a
    two-channel design."""
    if row == "union":
        return "split sensor" if is_split(design) else "union"
    words = row.split()
    if len(words) >= 2 and words[0] == "channel":
        return " ".join([channel_name(design, int(words[1])), *words[2:]])
    return row


def channel_colors(design: Any) -> dict[int, str]:
    """Each channel's colour (channels 1 and 2: the halves' blue and orange)."""
    return {c: ROW_COLORS[(c - 1) % len(ROW_COLORS)] for c in channels(design)}


def mark_channels_out_of_focus(ax: Any, design: Any, colors: dict[int, str],
                               label: bool = True) -> None:
    """Dotted vertical lines at every channel's out-of-focus plane [mm] on ``ax``
    (labelled when ``label``)."""
    for c in channels(design):
        z = design.out_of_focus_depth(c)
        ax.axvline(z, color=colors[c], lw=0.8, ls=":",
                   label=f"out-of-focus plane {c} ({z:.0f} mm)" if label else None)


def depth_grid(camera: Any, z_range: tuple[float, float], n: int) -> Any:
    """Log-spaced depths over z_range plus every channel's out-of-focus plane (so peaks
    are drawn)."""
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
