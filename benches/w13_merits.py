"""W13 image merits (issue 49): the time of one evaluated design with image merits, and the
share of it spent outside the core.

`splitlf.evaluate(design, depths, image=[...], photons=2000, n_threads=2)` over 20 depths
log-spaced over 300 mm - 2 m, every image merit of the design named (PSNR and MTF50,
least and median, of each channel and the union): the image merits come from
`splitlf.image_merits` at `IMAGE_DEPTHS` (5) depths of that range (docs/merits.md, "In the
design tools"), the other merits from the core's one call. The design is docs/fig2.md's:
the seed cut to 24 x 16 lenses per half (the full seed takes tens of seconds a depth,
docs/merits.md, "Time"). `--quick`: the same design, half 1's least PSNR alone, over
630 - 660 mm (near its focus, where its padded patch is smallest).

The share outside the core: every function of `splitlf._native` is wrapped for the run
by a timer (outermost calls only); the share is 1 - (time inside them) / (the call's wall
time). Names bound by `from splitlf._native import f` elsewhere escape the wrapper and
count as outside: the share is an upper bound.

    python benches/w13_merits.py [--quick] [--rounds N]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
import types
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

import splitlf
from splitlf import _native
from splitlf.study.merit import image_merit_names

#: The issue's target on the share of the time spent outside the core.
TARGET_SHARE_OUTSIDE_CORE = 0.20
PHOTONS = 2000.0
N_DEPTHS = 20
THREADS = 2


def design() -> splitlf.Design:
    """docs/fig2.md's design: the seed cut to 24 x 16 lenses per half."""
    seed = splitlf.Design.preset("seed")
    return seed.replace(channels=tuple(c.replace(Kx=24, Ky=16) for c in seed.channels))


def sizes(quick: bool) -> dict[str, Any]:
    if quick:
        return {"depths": [630.0, 660.0], "image": ["psnr_worst_channel1"]}
    return {"depths": [300.0, 2000.0],
            "image": list(image_merit_names(design()))}


@contextmanager
def core_timer() -> Iterator[list[float]]:
    """Wrap every function of ``splitlf._native`` to add its time (outermost calls) to the
    yielded one-item list; restored afterwards."""
    spent = [0.0]
    depth = [0]
    saved: dict[str, Callable[..., Any]] = {}

    def wrap(f: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*a: Any, **k: Any) -> Any:
            if depth[0]:
                return f(*a, **k)
            depth[0] += 1
            t = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                spent[0] += time.perf_counter() - t
                depth[0] -= 1
        return timed

    for name in dir(_native):
        f = getattr(_native, name)
        if isinstance(f, types.BuiltinFunctionType):
            saved[name] = f
            setattr(_native, name, wrap(f))
    try:
        yield spent
    finally:
        for name, f in saved.items():
            setattr(_native, name, f)


def one(s: dict[str, Any]) -> dict[str, Any]:
    """One evaluation: its wall time, the time inside the core, the merits."""
    d = design()
    z = np.geomspace(*s["depths"], N_DEPTHS)
    with core_timer() as spent:
        t0 = time.perf_counter()
        m = splitlf.evaluate(d, z, image=s["image"], photons=PHOTONS, n_threads=THREADS)
        total = time.perf_counter() - t0
    return {"total_s": total, "core_s": spent[0],
            "merits": {n: float(m[n]) for n in s["image"]}}


def run(quick: bool, rounds: int = 3) -> dict[str, Any]:
    """W13 at its sizes: ``rounds`` evaluations (one with --quick), medians."""
    s = sizes(quick)
    runs = [one(s) for _ in range(1 if quick else max(rounds, 1))]
    same = all(r["merits"] == runs[0]["merits"] for r in runs)
    total = statistics.median(r["total_s"] for r in runs)
    core = statistics.median(r["core_s"] for r in runs)
    share = statistics.median(1.0 - r["core_s"] / r["total_s"] for r in runs)
    return {"title": "evaluate with image merits, the seed cut to 24 x 16 lenses per half",
            "sizes": {"depths": N_DEPTHS, "range_mm": s["depths"], "image": s["image"],
                      "photons": PHOTONS, "threads": THREADS, "quick": quick},
            "rounds": len(runs), "s_per_evaluated_design": total, "core_s": core,
            "share_outside_core": share, "target_share_outside_core":
            TARGET_SHARE_OUTSIDE_CORE, "same_merits_every_round": same,
            "merits": runs[0]["merits"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    print(json.dumps(run(a.quick, a.rounds), indent=1))


if __name__ == "__main__":
    main()
