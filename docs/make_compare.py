"""Regenerate the study of docs/compare.md: every architecture optimised on the seed's
sensor and on the Raytrix R12's, for one objective, then evaluated over 150 mm - 10 m.

    python docs/make_compare.py            # about 10-15 minutes on 2 loaded cores
    python docs/make_compare.py --mtf-only # about a minute: the MTF50 columns alone

Writes docs/compare/<preset>.png (splitlf.plot.compare), docs/compare/<preset>_table.csv,
docs/compare/<preset>_curves.csv and one docs/compare/<preset>/<architecture>.toml per
optimised design, and prints each table as Markdown (the tables of docs/compare.md) with
the run's timing. ``--mtf-only`` re-optimises nothing: it loads the saved designs
(docs/compare/<preset>/*.toml), computes their super-resolution MTF50 at SIMULATE_DEPTHS
(splitlf.compare.mtf50) and replaces the MTF50 columns of docs/compare/<preset>_table.csv.
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

import splitlf
from splitlf.compare import ARCHITECTURES, LABELS, PRESETS, SIMULATE_OPTIONS, compare, mtf50

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
#: Depths of the super-resolution MTF50 columns [mm] (splitlf.compare.mtf50).
SIMULATE_DEPTHS = (150.0, 300.0, 1000.0, 3000.0, 10_000.0)
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
    cols = list(COLUMNS)
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


def mtf_markdown(table, labels, designs) -> str:
    """The MTF50 columns of ``table`` as Markdown: per depth the MTF50 [cycles/mm on the
    object] and, in brackets, those cycles over the width channel 1's pixel row sees at
    that depth (MTF50 x field_at_1m_mm x z / 1 m: delta(z) is linear in z); "≥" where the
    contrast never fell below 0.5 (the MTF50 is then the highest tested frequency,
    (n - 1)/n of the design's Nyquist 1/(2 delta(z))); "–" for a design the 1-D simulation
    cannot run (hex)."""
    n = SIMULATE_OPTIONS["n_frequencies"]
    cols = [c for c in table.columns if c.startswith("mtf50_")]
    zs = [float(c[6:-2]) for c in cols]
    out = ["| architecture | " + " | ".join(f"{z:g} mm" for z in zs) + " |",
           "| --- |" + " --- |" * len(cols)]
    for name in table.index:
        cells = []
        for c, z in zip(cols, zs, strict=True):
            v = float(table.loc[name, c])
            field = float(table.loc[name, "field_at_1m_mm"]) * z / 1000.0
            if not math.isfinite(v):
                cells.append("– (hex)")
                continue
            top = (n - 1) / n * (0.5 / designs[name].resolution_step(z))
            floor = "≥ " if v == top else ""
            cells.append(f"{floor}{v:.2f} ({v * field:,.0f})")
        out.append(f"| {labels[name]} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def mtf_only() -> int:
    """Fill the MTF50 columns of the saved study from its saved designs."""
    t_all = time.perf_counter()
    for preset in PRESETS:
        designs = {n: splitlf.Design.from_toml(HERE / preset / f"{n}.toml")
                   for n in ARCHITECTURES if (HERE / preset / f"{n}.toml").exists()}
        t0 = time.perf_counter()
        cols = mtf50(designs, SIMULATE_DEPTHS,
                     conventional=[n for n in designs if n == "conventional"],
                     seed=BUDGET["seed"])
        dt = time.perf_counter() - t0
        path = HERE / f"{preset}_table.csv"
        table = pd_read(path)
        table = table.drop(columns=[c for c in table.columns if c.startswith("mtf50_")])
        table = table.join(cols)
        table.to_csv(path)
        print(f"## {preset}: MTF50 [cycles/mm] (cycles over the field)\n")
        print(mtf_markdown(table, LABELS, designs))
        print(f"\nMTF50 {dt:.1f} s\n")
        sys.stdout.flush()
    print(f"total {time.perf_counter() - t_all:.1f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def pd_read(path):
    """A saved table (pandas reads its floats back exactly: the file rewritten unchanged)."""
    import pandas as pd

    return pd.read_csv(path, index_col="architecture")


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
        res = compare(preset, sharp_then_fine, "max", CONSTRAINTS, progress=False,
                      simulate_depths=SIMULATE_DEPTHS, **BUDGET)
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
        print()
        print(mtf_markdown(res.table, LABELS, res.designs))
        print(f"\noptimise {res.timing['optimise_s']:.1f} s, evaluate "
              f"{res.timing['evaluate_s']:.1f} s\n")
        sys.stdout.flush()
    print(f"total {time.perf_counter() - t_all:.1f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(mtf_only() if sys.argv[1:] == ["--mtf-only"] else main())
