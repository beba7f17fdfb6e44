"""Regenerate the study of docs/compare.md: every architecture optimised on the seed's
sensor and on the Raytrix R12's, for one objective, then evaluated over 150 mm - 10 m.

    python docs/make_compare.py            # about 10-15 minutes on 2 loaded cores

Writes docs/compare/<preset>.png (splitlf.plot.compare), docs/compare/<preset>_table.csv,
docs/compare/<preset>_curves.csv and one docs/compare/<preset>/<architecture>.toml per
optimised design, and prints each table as Markdown (the tables of docs/compare.md) with
the run's timing.
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from splitlf.compare import PRESETS, compare

HERE = Path(__file__).resolve().parent / "compare"
#: The study's objective, the same for every light field architecture: the largest share
#: of the depth range (log depth) where the union of channels is sharp, subject to a median
#: covering radius of at most RHO_MAX delta(z) (docs/compare.md, "The objective").
RHO_MAX = 1.2
CONSTRAINTS = {"covering_radius_median_union": ("<=", RHO_MAX)}
#: Weight of the tie-break: 0.001 delta of median covering radius per unit sharp fraction.
TIE_BREAK = 1e-3


def sharp_then_fine(m: dict[str, float]) -> float:
    """The sharp fraction of the union, ties broken by the finer median covering radius."""
    return m["sharp_fraction_union"] - TIE_BREAK * m["covering_radius_median_union"]


#: The budget (docs/compare.md, "Budget").
BUDGET = {"maxiter": 20, "popsize": 8, "polish": False, "seed": 0,
          "de_options": {"tol": 0.0},
          "optimise_depths": np.geomspace(150.0, 10_000.0, 8), "optimise_window": 3.0,
          "depths": np.geomspace(150.0, 10_000.0, 40), "window": 12.0}
#: Depth bands of the "who wins where" table [mm].
BANDS = ((150.0, 400.0), (400.0, 1500.0), (1500.0, 10_000.0))
COLUMNS = (("feasible", "feasible", "{}"), ("sharp_fraction", "sharp fraction", "{:.3f}"),
           ("covering_radius_worst", "worst ρ [δ]", "{:.2f}"),
           ("covering_radius_median", "median ρ [δ]", "{:.3f}"),
           ("distinct_2d_median", "median distinct (field)", "{:,.0f}"),
           ("light_relative", "light per pixel / conventional", "{:.3f}"),
           ("field_at_1m_mm", "field at 1 m [mm]", "{:.0f}"),
           ("out_of_focus_mm", "out-of-focus planes [mm]", "{}"))


def markdown(res) -> str:
    t = res.table
    cols = list(COLUMNS) + [(c, f"MTF50 {c[6:-2]} mm [c/mm]", "{:.2f}")
                            for c in t.columns if c.startswith("mtf50_")]
    out = ["| architecture | " + " | ".join(h for _, h, _ in cols) + " |",
           "| --- |" + " --- |" * len(cols)]
    for name in t.index:
        cells = []
        for c, _, f in cols:
            v = t.loc[name, c]
            if v is None or (isinstance(v, float) and not math.isfinite(v)):
                cells.append("–")
            else:
                cells.append(f.format(v + 0.0 if isinstance(v, float) else v))
        out.append(f"| {res.architectures[name].label} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def bands(res) -> str:
    """Per depth band: each design's share of the band's evaluated depths where it is sharp
    and its median covering radius [delta] over those sharp depths (a reduction of
    ``res.curves``), as Markdown."""
    head = " | ".join(f"{lo:g}–{hi:g} mm" for lo, hi in BANDS)
    out = [f"| architecture | {head} |", "| --- |" + " --- |" * len(BANDS)]
    c = res.curves
    for name in res.designs:
        cells = []
        for lo, hi in BANDS:
            z = c[(c["architecture"] == name) & (c["z_mm"] >= lo)
                  & ((c["z_mm"] < hi) if hi < 10_000.0 else (c["z_mm"] <= hi))]
            sharp = z[z["sharp"]]
            med = f"{np.median(sharp['covering_radius']):.2f} δ" if len(sharp) else "–"
            cells.append(f"{len(sharp)}/{len(z)} sharp, {med}")
        out.append(f"| {res.architectures[name].label} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> int:
    from matplotlib.figure import Figure

    from splitlf.plot import compare as plot_compare

    HERE.mkdir(exist_ok=True)
    t_all = time.perf_counter()
    for preset in PRESETS:
        res = compare(preset, sharp_then_fine, "max", CONSTRAINTS, progress=False, **BUDGET)
        fig = Figure(figsize=(9.5, 12.0), layout="constrained")
        plot_compare(res, ax=fig.subplots(3, 1, height_ratios=[3, 2, 1.3]))
        fig.savefig(HERE / f"{preset}.png", dpi=110)
        res.table.to_csv(HERE / f"{preset}_table.csv")
        res.curves.to_csv(HERE / f"{preset}_curves.csv", index=False)
        (HERE / preset).mkdir(exist_ok=True)
        for name, d in res.designs.items():
            d.to_toml(HERE / preset / f"{name}.toml")
        print(f"## {preset}\n")
        print(markdown(res))
        print()
        for name, r in res.optimisations.items():
            print(f"- {name}: {r.nfev} candidates, {int(r.timing['evaluations'])} valid, "
                  f"{r.timing['total_s']:.1f} s; free = "
                  + ", ".join(f"{k} = {v:.5g}" for k, v in r.free.items())
                  + f"; active: {'; '.join(r.active) or 'none'}")
        print()
        print(bands(res))
        print(f"\noptimise {res.timing['optimise_s']:.1f} s, evaluate "
              f"{res.timing['evaluate_s']:.1f} s\n")
        sys.stdout.flush()
    print(f"total {time.perf_counter() - t_all:.1f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
