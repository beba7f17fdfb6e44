"""Per-depth cost of ``splitlf.sampling.samples2d`` on every preset, and of the 2-D merits in an
optimisation (the cost behind issue 12's 2-D objectives).

For each preset (``splitlf.Design.preset``) and window (4 and 16 lens pitches): 20 depths
geometric over [150, 10 000] mm, each depth timed alone on one core thread (the best of
``--rounds`` calls; wall time and the process's CPU time, which a loaded machine disturbs
less), reported as the median and the largest over the depths; and the whole 20-depth
call on all threads (median of the rounds). Then ``--optimise``: the raytrix-r12 preset
optimised for its worst covering radius at window 4 and 20 depths, seconds per evaluated
design (``OptimiseResult.timing``, and the process's CPU time over the evaluations).

    python benches/coverage_depths.py [--rounds 3] [--optimise]

Self-contained (no NumPy twin: the NumPy/SciPy comparison of ``coverage`` is W5 of
run.py). Prints one JSON document, with the load average before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import time

import numpy as np

import splitlf

PRESETS = ("seed", "seed-plain", "split3", "raytrix-r12", "lytro-illum")
WINDOWS = (4.0, 16.0)


def per_depth(name: str, window: float, z: np.ndarray, rounds: int) -> dict[str, float]:
    d = splitlf.Design.preset(name)
    one, cpu = [], []
    for zi in z:
        best = best_cpu = np.inf
        for _ in range(rounds):
            c, t = time.process_time(), time.perf_counter()
            splitlf.coverage(d, [zi], window=window, n_threads=1)
            best = min(best, time.perf_counter() - t)
            best_cpu = min(best_cpu, time.process_time() - c)
        one.append(best)
        cpu.append(best_cpu)
    whole = []
    for _ in range(rounds):
        t = time.perf_counter()
        splitlf.coverage(d, z, window=window)
        whole.append(time.perf_counter() - t)
    return {"median_ms_per_depth_1_thread": 1e3 * float(np.median(one)),
            "max_ms_per_depth_1_thread": 1e3 * float(np.max(one)),
            "median_cpu_ms_per_depth_1_thread": 1e3 * float(np.median(cpu)),
            "ms_20_depths_all_threads": 1e3 * float(np.median(whole))}


def optimise_raytrix(z: np.ndarray) -> dict[str, float]:
    base = splitlf.Design.preset("raytrix-r12")
    c = time.process_time()
    res = splitlf.optimise(
        base, {"channels[1].L": (56.0, 58.0), "channels[1].v": (0.30, 0.36)},
        "covering_radius_worst_channel1", depths=z, window=4.0, maxiter=3, popsize=4,
        polish=False, de_options={"tol": 0.0, "atol": 0.0}, progress=False)
    cpu = time.process_time() - c
    t = res.timing
    n = max(int(t["evaluations"]), 1)
    return {"candidates": res.nfev, "evaluated_by_core": n,
            "s_per_evaluated_design": t["total_s"] / n,
            "core_s_per_evaluated_design": t["core_s"] / n,
            "cpu_s_per_evaluated_design": cpu / n,
            "best": res.merits["covering_radius_worst_channel1"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--optimise", action="store_true",
                    help="also time an optimisation of raytrix-r12 with a 2-D objective")
    ap.add_argument("--presets", nargs="*", default=list(PRESETS))
    args = ap.parse_args()
    z = np.geomspace(150.0, 10_000.0, 20)
    load0 = os.getloadavg()
    out: dict[str, object] = {"cores": os.cpu_count(), "platform": platform.platform()}
    try:
        out["commit"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"],
                                       capture_output=True, text=True).stdout.strip()
    except OSError:
        pass
    out["coverage"] = {f"{p} window {w:g}": per_depth(p, w, z, args.rounds)
                       for p in args.presets for w in WINDOWS}
    if args.optimise:
        out["optimise_raytrix_r12_window4_20_depths"] = optimise_raytrix(z)
    out["load_average_1min_before_after"] = [load0[0], os.getloadavg()[0]]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
