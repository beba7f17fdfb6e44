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
    ("field_at_1m_mm", "field at\n1 m [mm]", "{:.0f}"),
    ("out_of_focus_mm", "out-of-focus\nplanes [mm]", "{}"),
)
#: How the depths where a design is not sharp are marked on its curve.
NOT_SHARP = {"marker": "x", "ls": "none", "ms": 7, "mew": 1.6}


def _cell(value: Any, fmt: str) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return "n/a"
    return fmt.format(value)


def compare(result: Any, ax: Any = None, *, table: bool = True) -> Any:
    """The covering radius of the union of channels against depth for every architecture
    of a :class:`splitlf.compare.Comparison`: in mm on the plane (log-log) and, below it,
    in units of each design's delta(z) = mu z / L_1 (which normalises the field of view),
    each a line through the evaluated depths with an ``x`` on the depths where the design
    is not sharp (its blur at or above the threshold); under them (``table=True``) a
    table of the designs' numbers (:data:`TABLE_COLUMNS` of ``result.table``).

    - ``ax``: None (a new figure: mm curves, delta curves and, with ``table``, the table),
      an Axes (the mm curves only), or a sequence of 2 Axes (mm curves, delta curves) or
      3 (mm curves, delta curves, table)

    Returns the Axes drawn on (one, or a tuple of all). The curve of architecture ``name``
    is the line labelled with its label (``result.architectures[name].label``); its
    not-sharp marks are the line labelled ``"_<label>: not sharp"`` (hidden from the
    legend). Raises ``TypeError`` for a result that is not a Comparison, ``ValueError``
    for ``ax`` of the wrong shape, ``ImportError`` without matplotlib.
    """
    from ..study.compare import Comparison

    if not isinstance(result, Comparison):
        raise TypeError(f"result must be a splitlf.compare.Comparison, got "
                        f"{type(result).__name__}")
    if ax is None:
        n = 3 if table else 2
        _, axs = pyplot().subplots(n, 1, figsize=(9.5, 12.0 if table else 9.0),
                                   layout="constrained",
                                   height_ratios=[3, 2, 1.3] if table else [3, 2])
        axs = list(axs)
    elif hasattr(ax, "plot"):
        axs = [ax]
    else:
        axs = list(ax)
        if len(axs) not in (2, 3):
            raise ValueError("ax must be None, an Axes (mm curves), or a sequence of 2 Axes "
                             "(mm curves, delta curves) or 3 (mm curves, delta curves, table)")
    a_mm = axs[0]
    a_delta = axs[1] if len(axs) > 1 else None
    a_table = axs[2] if len(axs) > 2 else None
    curves = [(a_mm, "covering_radius_mm", "covering radius of the union [mm on the plane]")]
    if a_delta is not None:
        curves.append((a_delta, "covering_radius",
                       "covering radius of the union [delta(z) = mu z / L_1]"))
    for a, column, ylabel in curves:
        for k, name in enumerate(result.designs):
            c = result.curve(name)
            label = result.architectures[name].label
            color = ROW_COLORS[k % len(ROW_COLORS)]
            conv = result.architectures[name].conventional
            a.plot(c["z_mm"], c[column], color=color, lw=1.5, ls="--" if conv else "-",
                   label=label)
            bad = c[~c["sharp"]]
            a.plot(bad["z_mm"], bad[column], color=color, label=f"_{label}: not sharp",
                   zorder=3, **NOT_SHARP)
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_ylabel(ylabel, fontsize=9)
        a.grid(True, which="both", lw=0.3, alpha=0.5)
    a_mm.plot([], [], color="0.3", label="x: not sharp there (blur >= "
              f"{result.settings['threshold_px']:g} px)", **NOT_SHARP)
    a_mm.legend(fontsize=8, loc="upper left")
    (a_delta or a_mm).set_xlabel("depth z [mm]")
    obj = result.settings["objective"]
    cons = ", ".join(f"{m} {op} {v:g}" for m, (op, v) in result.settings["constraints"].items())
    a_mm.set_title(f"{result.preset} sensor: optimised architectures ({obj}"
                   f"{'; ' + cons if cons else ''})", fontsize=9)
    if a_table is not None:
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
    drawn = [a for a in (a_mm, a_delta, a_table) if a is not None]
    return drawn[0] if len(drawn) == 1 else tuple(drawn)
