"""W7: inverse design of the split sensor over (kappa, D, v) with 200 depths.

Differential evolution with generations x population fixed (``tol = atol = 0`` so every
generation runs; no polish), in-process: time per evaluated design, and the share of the
wall time spent outside the core's ``figures_of_merit`` calls (validation, the Camera and
its §9 form, SciPy, the history). The issue's target: under 20 %.

    python benches/w7_optimise.py            # 30 generations x 45 designs
    python benches/w7_optimise.py --quick    # 3 generations (smoke test)

Self-contained (not yet a workload of run.py: W7 has no NumPy twin to compare against).
Prints one JSON document.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

import splitlf


def run(generations: int, popsize: int, n_threads: int | None) -> dict[str, float]:
    depths = np.geomspace(150.0, 10_000.0, 200)
    t0 = time.perf_counter()
    res = splitlf.optimise(
        splitlf.Camera.paper(), {"kappa": (0.05, 0.8), "D": (8.0, 40.0), "v": (0.4, 0.9)},
        "sharp_fraction_split", constraints={"max_gap_worst_union": ("<=", 3.0)},
        depths=depths, maxiter=generations, popsize=popsize, polish=False,
        de_options={"tol": 0.0, "atol": 0.0}, n_threads=n_threads, progress=False)
    wall = time.perf_counter() - t0
    t = res.timing
    evaluated = int(t["evaluations"])
    return {
        "generations": res.generations,
        "candidates": res.nfev,
        "evaluated_by_core": evaluated,
        "invalid": int((~res.history["valid"]).sum()),
        "wall_s": wall,
        "search_s": t["total_s"],
        "core_s": t["core_s"],
        "ms_per_candidate": 1e3 * t["total_s"] / res.nfev,
        "ms_per_evaluated_design": 1e3 * t["total_s"] / max(evaluated, 1),
        "core_ms_per_evaluated_design": 1e3 * t["core_s"] / max(evaluated, 1),
        "share_outside_core": 1.0 - t["core_s"] / t["total_s"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="3 generations")
    ap.add_argument("--generations", type=int, default=30)
    ap.add_argument("--popsize", type=int, default=15, help="population per free field")
    ap.add_argument("--threads", type=int, default=None, help="core threads (default all)")
    args = ap.parse_args()
    gens = 3 if args.quick else args.generations
    doc = {"workload": "W7", "machine": platform.machine(), "python": platform.python_version(),
           "splitlf": splitlf.__version__, "threads": args.threads,
           **run(gens, args.popsize, args.threads)}
    print(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
