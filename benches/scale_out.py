"""Wall time of one render in-process against the same render cut into bands of rows on a
2-worker executor (docs/render.md, "Scale-out and datasets"): raytrix-r12 cut to 6 x 6
lenses, a random texture at 1000 mm, tol 1e-3. Each way is timed ``--rounds`` times in this
one process, interleaved, and the medians and their ratios printed as JSON; every raw is
checked bit for bit against the in-process one. No timed assertion: the numbers are for
docs/render.md.

    python benches/scale_out.py [--rounds 3] [--lenses 6] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import os
import statistics
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
from timing import timed_call

import splitlf


def design(lenses: int) -> splitlf.Design:
    d = splitlf.Design.preset("raytrix-r12")
    return d.replace(channels=tuple(c.replace(Kx=lenses, Ky=lenses, Mx=None, My=None)
                                    for c in d.channels))


def ways(dask: Any) -> dict[str, tuple[Callable[[], Any], Callable[[], None]]]:
    """Each way as (make its executor or None, close it): built once, outside the timing
    (a pool's or a cluster's start is not the render's)."""
    out: dict[str, Any] = {
        "in-process, 2 threads": (lambda: None, 2),
        "in-process, 1 thread": (lambda: None, 1),
        "ProcessPool(2), 1 thread a task": (lambda: cf.ProcessPoolExecutor(2), 1),
    }
    if dask is not None:
        out["Dask LocalCluster(2 processes), 1 thread a task"] = ("dask", 1)
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--lenses", type=int, default=6)
    p.add_argument("--out", default=None)
    args = p.parse_args()
    try:
        import distributed
    except ImportError:
        distributed = None
    d = design(args.lenses)
    scene = splitlf.Scene("random", 1000.0)
    kw: dict[str, Any] = {"tol": 1e-3, "seed": 1, "progress": False}
    executors: dict[str, Any] = {}
    cluster = client = None
    for name, (make, threads) in ways(distributed).items():
        if make == "dask":
            cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1,
                                               processes=True, dashboard_address=None)
            client = distributed.Client(cluster)
            executors[name] = (client.get_executor(), threads)
        else:
            executors[name] = (make(), threads)
    load_start = os.getloadavg()
    times: dict[str, list[float]] = {n: [] for n in executors}
    reference = None
    try:
        for _ in range(args.rounds):
            for name, (ex, threads) in executors.items():
                t, raw = timed_call(lambda ex=ex, threads=threads: splitlf.render(
                    d, scene, executor=ex, n_threads=threads, **kw))
                if reference is None:
                    reference = raw
                same = all(a.tobytes() == b.tobytes() for a, b
                           in zip(raw.images, reference.images, strict=True))
                if not same:
                    raise SystemExit(f"{name}: the raw differs from the in-process raw")
                times[name].append(t)
    finally:
        for ex, _ in executors.values():
            if isinstance(ex, cf.ProcessPoolExecutor):
                ex.shutdown()
        if client is not None:
            client.close()
            cluster.close()
    median = {n: statistics.median(v) for n, v in times.items()}
    base = median["in-process, 2 threads"]
    pixels = sum(a.size for a in reference.images)
    doc = {"design": f"raytrix-r12, {args.lenses} x {args.lenses} lenses",
           "pixels": int(pixels), "tol": kw["tol"], "rounds": args.rounds,
           "cores": os.cpu_count(), "load_average": [load_start, os.getloadavg()],
           "times_s": times, "median_s": median,
           "ratio_to_in_process_2_threads": {n: m / base for n, m in median.items()},
           "bit_for_bit": True, "raw_max": float(np.max(reference.images[0]))}
    text = json.dumps(doc, indent=2)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    sys.stdout.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
