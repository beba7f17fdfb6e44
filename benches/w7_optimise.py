"""W7: inverse design of the split sensor over (kappa, D, v) with 200 depths.

Differential evolution with generations x population fixed (``tol = atol = 0`` so every
generation runs; no polish), in-process: time per evaluated design, and the share of the
wall time spent outside ``splitlf.evaluate`` (the core's ``design_figures_of_merit`` and the
closed-form merits; outside it: building and validating each candidate, SciPy, the
history). The issue's target: under 20 %.

A workload of the harness (``python benches/run.py --only W7``), which also checks the
search before timing it; this file defines the search and runs it on its own:

    python benches/w7_optimise.py            # 30 generations x 45 designs
    python benches/w7_optimise.py --quick    # the harness's --quick size (smoke test)

Prints one JSON document.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from typing import Any

import numpy as np

import splitlf

#: The free fields and their bounds, the objective and the constraint of the search.
FREE = {"kappa": (0.05, 0.8), "D": (8.0, 40.0), "v": (0.4, 0.9)}
OBJECTIVE = "sharp_fraction_union"  # the union of both halves (was sharp_fraction_split)
CONSTRAINTS = {"max_gap_worst_union": ("<=", 3.0)}
#: Scene depths of the merits: 200, log-spaced over 150 mm - 10 m.
N_DEPTHS = 200
#: Generations and population per free field: full size, and --quick (the CI smoke test).
FULL = {"generations": 30, "popsize": 15}
QUICK = {"generations": 2, "popsize": 4}
#: The issue's target on the share of the search's time spent outside the core.
TARGET_SHARE_OUTSIDE_CORE = 0.20


def depths() -> np.ndarray:
    return np.geomspace(150.0, 10_000.0, N_DEPTHS)


def search(generations: int, popsize: int, n_threads: int | None,
           seed: int = 0) -> splitlf.OptimiseResult:
    """The W7 search: the seed camera, (kappa, D, v) free, every generation run."""
    return splitlf.optimise(
        splitlf.Camera.paper(), FREE, OBJECTIVE, constraints=CONSTRAINTS, depths=depths(),
        seed=seed, maxiter=generations, popsize=popsize, polish=False,
        de_options={"tol": 0.0, "atol": 0.0}, n_threads=n_threads, progress=False)


def figures(res: splitlf.OptimiseResult) -> dict[str, float]:
    """What one search measured: candidates, designs evaluated by the core, its time in
    the core and outside it."""
    t = res.timing
    evaluated = int(t["evaluations"])
    return {
        "generations": res.generations,
        "candidates": res.nfev,
        "evaluated_by_core": evaluated,
        "invalid": int((~res.history["valid"]).sum()),
        "search_s": t["total_s"],
        "core_s": t["core_s"],
        "ms_per_candidate": 1e3 * t["total_s"] / res.nfev,
        "ms_per_evaluated_design": 1e3 * t["total_s"] / max(evaluated, 1),
        "core_ms_per_evaluated_design": 1e3 * t["core_s"] / max(evaluated, 1),
        "share_outside_core": 1.0 - t["core_s"] / t["total_s"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help=f"{QUICK['generations']} generations, population {QUICK['popsize']} "
                    "per free field")
    ap.add_argument("--generations", type=int, default=FULL["generations"])
    ap.add_argument("--popsize", type=int, default=FULL["popsize"],
                    help="population per free field")
    ap.add_argument("--threads", type=int, default=None, help="core threads (default all)")
    args = ap.parse_args()
    size: dict[str, Any] = QUICK if args.quick else {"generations": args.generations,
                                                     "popsize": args.popsize}
    t0 = time.perf_counter()
    res = search(size["generations"], size["popsize"], args.threads)
    wall = time.perf_counter() - t0
    doc = {"workload": "W7", "machine": platform.machine(), "python": platform.python_version(),
           "splitlf": splitlf.__version__, "threads": args.threads, "wall_s": wall,
           **figures(res)}
    print(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
