"""The architecture comparison (docs/compare.md): covering radius against depth for every
optimised design, with a table of the designs' numbers."""

from __future__ import annotations

import math
from typing import Any

from ._mpl import ROW_COLORS, pyplot

__all__ = ["compare", "TABLE_COLUMNS"]

#: The table's columns drawn under the figure: (column of ``Comparison.table``, heading,
#: format).
TABLE_COLUMNS = (
    ("sharp_fraction", "sharp\nfraction", "{:.3f}"),
    ("covering_radius_worst", "worst rho\n[delta]", "{:.2f}"),
    ("covering_radius_median", "median rho\n[delta]", "{:.3f}"),
    ("distinct_2d_median", "median distinct\n(2-D field)", "{:.0f}"),
    ("light_relative", "light per pixel\n/ conventional", "{:.3f}"),
    ("out_of_focus_mm", "out-of-focus\nplanes [mm]", "{}"),
)
#: How the depths where a design is not sharp are marked on its curve.
NOT_SHARP = {"marker": "x", "ls": "none", "ms": 5, "mew": 1.0}


def _cell(value: Any, fmt: str) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return "n/a"
    return fmt.format(value)


def compare(result: Any, ax: Any = None, *, table: bool = True):
    """Covering radius [mm] of the union of channels against depth (log-log) for every
    architecture of a :class:`splitlf.compare.Comparison`, each a line through the
    evaluated depths, with an ``x`` on the depths where it is not sharp (its blur at or
    above the threshold); under it (``table=True``) a table of the designs' numbers
    (:data:`TABLE_COLUMNS` of ``result.table``).

    - ``ax``: None (a new figure), an Axes (the curves; no table), or a pair of Axes
      (curves, table)

    Returns the Axes drawn on (a pair when a table is drawn). The curve of architecture
    ``name`` is the line labelled with its label (``result.architectures[name].label``);
    its not-sharp marks are the line labelled ``"<label>: not sharp"`` (hidden from the
    legend). Raises ``TypeError`` for a result that is not a Comparison, ``ValueError``
    for ``ax`` of the wrong shape, ``ImportError`` without matplotlib.
    """
    from ..compare import Comparison

    if not isinstance(result, Comparison):
        raise TypeError(f"result must be a splitlf.compare.Comparison, got "
                        f"{type(result).__name__}")
    if ax is None:
        rows = 2 if table else 1
        fig, axs = pyplot().subplots(rows, 1, figsize=(9.5, 8.6 if table else 5.6),
                                     layout="constrained", squeeze=False,
                                     height_ratios=[3, 1.25] if table else None)
        axs = [a[0] for a in axs]
        a_plot, a_table = axs[0], (axs[1] if table else None)
    elif hasattr(ax, "plot"):
        a_plot, a_table = ax, None
    else:
        pair = list(ax)
        if len(pair) != 2:
            raise ValueError("ax must be None, an Axes or a pair of Axes (curves, table)")
        a_plot, a_table = pair
    for k, name in enumerate(result.designs):
        c = result.curve(name)
        label = result.architectures[name].label
        color = ROW_COLORS[k % len(ROW_COLORS)]
        conv = result.architectures[name].conventional
        a_plot.plot(c["z_mm"], c["covering_radius_mm"], color=color, lw=1.6,
                    ls="--" if conv else "-", label=label)
        bad = c[~c["sharp"]]
        a_plot.plot(bad["z_mm"], bad["covering_radius_mm"], color=color,
                    label=f"_{label}: not sharp", **NOT_SHARP)
    a_plot.plot([], [], color="0.3", label="x: not sharp there (blur >= "
                f"{result.settings['threshold_px']:g} px)", **NOT_SHARP)
    a_plot.set_xscale("log")
    a_plot.set_yscale("log")
    a_plot.set_xlabel("depth z [mm]")
    a_plot.set_ylabel("covering radius of the union [mm on the plane]")
    obj = result.settings["objective"]
    cons = ", ".join(f"{m} {op} {v:g}" for m, (op, v) in result.settings["constraints"].items())
    a_plot.set_title(f"{result.preset} sensor: optimised architectures ({obj}"
                     f"{'; ' + cons if cons else ''})", fontsize=9)
    a_plot.grid(True, which="both", lw=0.3, alpha=0.5)
    a_plot.legend(fontsize=8, loc="upper left")
    if a_table is None:
        return a_plot
    t = result.table
    cols = [(c, h, f) for c, h, f in TABLE_COLUMNS if c in t.columns]
    cells = [[_cell(t.loc[n, c], f) for c, _, f in cols] for n in result.designs]
    a_table.axis("off")
    tab = a_table.table(cellText=cells, colLabels=[h for _, h, _ in cols],
                        rowLabels=[result.architectures[n].label for n in result.designs],
                        loc="center", cellLoc="center")
    tab.auto_set_font_size(False)
    tab.set_fontsize(7.5)
    tab.scale(1.0, 1.9)
    return a_plot, a_table
