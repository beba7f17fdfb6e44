"""Instruction counts of each workload's native call, for comparing two builds whatever the
machine's load (issue 46: the layout change against its baseline).

Each workload's call runs at ``n_threads=1`` under ``valgrind --tool=callgrind`` in a
fresh process with instrumentation off (``--instr-atstart=no``): the inputs are built and
the call is made once uninstrumented (warm: caches, the thread pool, lazy imports), then
instrumentation is switched on around a second call alone, through callgrind's client
requests (``CALLGRIND_START_INSTRUMENTATION`` / ``STOP``, compiled into a tiny helper
library with ``cc`` from ``valgrind/callgrind.h`` and called through ctypes). The count is
every instruction executed by the call (its Python wrapper, the binding, the core; all
threads), and repeats to a few parts in 10^5 whatever else the machine runs. Only the
public API is used, so the same script measures any build installed in the interpreter
that runs it (``python -c "import splitlf"`` must point at the build to measure).

    python benches/instructions.py W1 W3            # counts for the installed build, JSON
    python benches/instructions.py --wall 5 W1      # wall and CPU times of 5 calls instead
    python benches/instructions.py --compare /work/venv/base/bin/python W1 W2
        # counts under both interpreters (the other build first), then wall-clock rounds
        # alternating the two interpreters' processes; prints JSON and a Markdown table
    python benches/instructions.py --keep /tmp/cg W9s   # keep callgrind.out.W9s for
        # callgrind_annotate

Sizes are small (the ``--quick`` sizes or a little larger) so that each run takes at most
a few minutes under callgrind (~50x slower than native): instruction ratios at these
sizes are what the layout change did to the code each call runs, not full-size timings.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))  # w9_render's mc_render

import splitlf  # noqa: E402

Z = 1000.0
NOISE = {"photons": 2000.0, "read_noise": 0.0}

#: A workload: a function of nothing that builds its inputs and returns the native call
#: (a function of nothing, made at n_threads=1).
Setup = Callable[[], Callable[[], Any]]


def _table(name: str, sizes: dict[str, Any]) -> Setup:
    """W1-W6 from benches/workloads.py at the given sizes."""
    def setup() -> Callable[[], Any]:
        from workloads import WORKLOADS

        w = WORKLOADS[name]
        inp = w.setup(sizes)
        return lambda: w.native(inp, 1)
    return setup


def _w7() -> Callable[[], Any]:
    import w7_optimise

    q = w7_optimise.QUICK
    return lambda: w7_optimise.search(q["generations"], q["popsize"], 1)


def _w9(scene: str) -> Setup:
    """W9's --quick scenes (seed 66 x 22 lenses, raytrix-r12 3 x 3, 128^2 textures)."""
    def setup() -> Callable[[], Any]:
        import w9_render

        inp = w9_render.setup(w9_render.sizes(True))
        return lambda: w9_render.native(inp, scene, 1)
    return setup


def _small_seed(kx: int, ky: int | None = None) -> splitlf.Design:
    """The seed design with kx x ky lenses per channel (ky: 2/3 of kx, at least 8)."""
    d = splitlf.Design.preset("seed")
    ky = max(8, kx * 2 // 3) if ky is None else ky
    return d.replace(channels=tuple(c.replace(Kx=kx, Ky=ky) for c in d.channels))


def _centred(cells: int, step: float) -> tuple[float, float, float, float]:
    half = cells * step / 2.0 * (1.0 - 1e-9)
    return (-half, half, -half, half)


def _w10() -> Callable[[], Any]:
    """W10's reconstruct on a seed cut to 40 lenses across, 48 x 48 cells of delta(z)."""
    d = _small_seed(40)
    raw = splitlf.render(d, splitlf.Scene("random", Z), noise=NOISE, seed=1, progress=False)
    region = _centred(48, d.resolution_step(Z))
    return lambda: splitlf.reconstruct(raw, Z, region=region, noise=NOISE, n_threads=1,
                                       progress=False)


def _w11() -> Callable[[], Any]:
    """W11's estimate_depth (64 candidates over 250-4000 mm) on a seed cut to 24 lenses
    across, 48 x 48 cells at 3 delta of the candidates' median depth (the default step)."""
    d = _small_seed(24)
    tex = splitlf.RandomAlbedo(10 * d.resolution_step(Z))
    raw = splitlf.render(d, splitlf.Scene(tex, Z), noise=NOISE, seed=1, progress=False)
    cand = 1.0 / np.linspace(1 / 250.0, 1 / 4000.0, 64)
    step = 3.0 * d.resolution_step(float(1.0 / np.median(1.0 / cand)))
    region = _centred(48, step)
    return lambda: splitlf.estimate_depth(raw, depths=(250.0, 4000.0), region=region,
                                          step=step, n_threads=1, progress=False)


def _w12() -> Callable[[], Any]:
    """W12's two small calls, 6 of each one after the other (its serial side, k = 1)."""
    cam = splitlf.Camera.paper()
    z = np.geomspace(150.0, 1e4, 20)

    def calls() -> None:
        for _ in range(6):
            splitlf.sample_grid(cam, 800.0, 2, n_threads=1)
            splitlf.footprints(cam, z, 2, kernel=True, n_threads=1)
    return calls


def _sinusoid() -> Callable[[], Any]:
    """render of a Sinusoid (1 cycle/mm) at 1 m by the seed cut to 4 x 4 lenses (the
    general route: forced by a plane tilted by 1e-7, since a fronto plane takes the exact
    route, docs/render.md)."""
    d = _small_seed(4, 4)
    scene = splitlf.Scene(splitlf.Sinusoid(1.0), splitlf.Plane(Z, 1e-7, 0.0))
    return lambda: splitlf.render(d, scene, n_threads=1, progress=False).images


WORKLOADS: dict[str, tuple[str, Setup]] = {
    "W1": ("curves, seed, 10^6 depths", _table("W1", {"depths": 10**6})),
    "W2": ("footprints, seed, 300 depths x 2 halves", _table("W2", {"depths": 300})),
    "W3": ("new_samples, seed, 2,000 depths", _table("W3", {"depths": 2000})),
    "W4": ("sample_grid, 40-MP sensor / 4 per axis",
           _table("W4", {"Kx": 129, "Ky": 43})),
    "W5": ("coverage, raytrix-r12 / 4 per axis, 4 depths, window 4",
           _table("W5", {"quick": True, "depths": 4, "window": 4.0})),
    "W6": ("chief_samples, lytro-illum / 4 per axis", _table("W6", {"quick": True})),
    "W7": ("optimise, 2 generations x 12 candidates", _w7),
    "W9s": ("render, seed 66 x 22 lenses, 128^2 image (exact route)", _w9("seed")),
    "W9f": ("render, raytrix-r12 3 x 3 lenses, fronto-parallel", _w9("r12_fronto")),
    "W9t": ("render, raytrix-r12 3 x 3 lenses, slanted plane", _w9("r12_slanted")),
    "W10": ("reconstruct, seed 40 lenses across, 48^2 cells", _w10),
    "W11": ("estimate_depth, seed 24 lenses across, 48^2 cells x 64", _w11),
    "W12": ("sample_grid + footprints(kernel) x 6, serial", _w12),
    "sinusoid": ("render, seed 4 x 4 lenses, Sinusoid(1/mm)", _sinusoid),
}

_HELPER_C = """#include <valgrind/callgrind.h>
void cg_start(void) { CALLGRIND_ZERO_STATS; CALLGRIND_START_INSTRUMENTATION; }
void cg_stop(void) { CALLGRIND_STOP_INSTRUMENTATION; }
"""


def _helper(dirpath: Path) -> Path:
    """The client-request helper library, compiled with cc into dirpath."""
    src, lib = dirpath / "cgctl.c", dirpath / "libcgctl.so"
    src.write_text(_HELPER_C)
    subprocess.run(["cc", "-shared", "-fPIC", "-O1", "-o", str(lib), str(src)], check=True)
    return lib


def child(name: str, lib: str) -> None:
    """Inside valgrind: build, warm up, then one instrumented call."""
    call = WORKLOADS[name][1]()
    call()
    cg = ctypes.CDLL(lib)
    cg.cg_start()
    call()
    cg.cg_stop()


def count(name: str, python: str = sys.executable, keep: Path | None = None) -> dict[str, Any]:
    """Instructions of one workload's call under `python`'s build, from callgrind."""
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = keep or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        lib = _helper(Path(tmp))
        out = out_dir / f"callgrind.out.{name}"
        env = {**os.environ, "PYTHONHASHSEED": "0"}
        t0 = time.perf_counter()
        subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no",
                        f"--callgrind-out-file={out}", python, str(Path(__file__).resolve()),
                        "--child", name, str(lib)], check=True, env=env,
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        wall = time.perf_counter() - t0
        totals = [line for line in out.read_text().splitlines()
                  if line.startswith(("summary:", "totals:"))]
        ir = int(totals[-1].split()[1])
    return {"workload": name, "instructions": ir, "valgrind_s": round(wall, 1),
            "build": _where(python)}


def _where(python: str) -> str:
    return subprocess.run([python, "-c", "import splitlf; print(splitlf.__file__)"],
                          check=True, capture_output=True, text=True).stdout.strip()


def wall(name: str, calls: int) -> dict[str, list[float]]:
    """Wall and CPU seconds (user + system, all threads of this process) of `calls` calls
    after one warm-up call, in this process."""
    call = WORKLOADS[name][1]()
    call()
    out: dict[str, list[float]] = {"times_s": [], "cpu_s": []}
    for _ in range(calls):
        c0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
        call()
        t1, c1 = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
        out["times_s"].append(t1 - t0)
        out["cpu_s"].append(c1.ru_utime - c0.ru_utime + c1.ru_stime - c0.ru_stime)
    return out


def _wall_in(python: str, name: str, calls: int) -> tuple[float, float]:
    """Medians of the wall and CPU times of `calls` calls in a fresh process of `python`."""
    r = subprocess.run([python, str(Path(__file__).resolve()), "--wall", str(calls), name],
                       check=True, capture_output=True, text=True)
    doc = json.loads(r.stdout)[0]
    return statistics.median(doc["times_s"]), statistics.median(doc["cpu_s"])


def compare(old: str, new: str, names: list[str], rounds: int, calls: int,
            wall_only: set[str], count_too: bool = True) -> list[dict[str, Any]]:
    """Counts under both interpreters, then `rounds` rounds of wall medians alternating
    the two interpreters' processes (order swapped every round)."""
    rows = []
    for name in names:
        row: dict[str, Any] = {"workload": name, "what": WORKLOADS[name][0]}
        if count_too and name not in wall_only:
            row["instructions_old"] = count(name, old)["instructions"]
            row["instructions_new"] = count(name, new)["instructions"]
            row["instructions_ratio"] = row["instructions_new"] / row["instructions_old"]
        if rounds:
            row.update(_alternate(old, new, name, rounds, calls))
        print(json.dumps(row), file=sys.stderr, flush=True)
        rows.append(row)
    return rows


def _alternate(old: str, new: str, name: str, rounds: int, calls: int) -> dict[str, Any]:
    """Wall medians of fresh processes of the two interpreters, alternating."""
    t: dict[str, list[float]] = {"old": [], "new": []}
    cpu: dict[str, list[float]] = {"old": [], "new": []}
    load = [os.getloadavg()[0]]
    for r in range(rounds):
        order = [("old", old), ("new", new)][:: 1 if r % 2 == 0 else -1]
        for side, py in order:
            w, c = _wall_in(py, name, calls)
            t[side].append(w)
            cpu[side].append(c)
        load.append(os.getloadavg()[0])
    return {"wall_old_s": t["old"], "wall_new_s": t["new"],
            "wall_ratio": statistics.median(t["new"]) / statistics.median(t["old"]),
            "cpu_old_s": cpu["old"], "cpu_new_s": cpu["new"],
            "cpu_ratio": statistics.median(cpu["new"]) / statistics.median(cpu["old"]),
            "load_1min": [round(x, 2) for x in load]}


def markdown(rows: list[dict[str, Any]], noise: float = 0.03) -> str:
    lines = ["| workload | what | instructions new / old | wall median new / old | "
             "CPU median new / old | verdict |", "|---|---|---|---|---|---|"]
    for r in rows:
        ir, wr = r.get("instructions_ratio"), r.get("wall_ratio")
        worse = ir > 1 + noise if ir is not None else wr is not None and wr > 1.15
        lines.append(f"| {r['workload']} | {r['what']} | "
                     + (f"{ir:.4f}" if ir is not None else "(not counted)") + " | "
                     + (f"{wr:.3f}" if wr is not None else "(not timed)") + " | "
                     + (f"{r['cpu_ratio']:.3f}" if "cpu_ratio" in r else "(not timed)")
                     + f" | {'slower' if worse else 'not slower'} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help=f"workloads (default all): {', '.join(WORKLOADS)}")
    ap.add_argument("--wall", type=int, metavar="CALLS", help="time CALLS calls instead")
    ap.add_argument("--compare", metavar="OLD_PYTHON",
                    help="the other build's interpreter: count and time both")
    ap.add_argument("--rounds", type=int, default=5,
                    help="--compare's wall rounds (0: counts only)")
    ap.add_argument("--no-count", action="store_true", help="--compare: wall times only")
    ap.add_argument("--calls", type=int, default=3, help="--compare's calls per process")
    ap.add_argument("--wall-only", nargs="*", default=[], help="--compare: time, don't count")
    ap.add_argument("--keep", type=Path, help="keep the callgrind.out files in this folder")
    ap.add_argument("--child", nargs=2, metavar=("NAME", "LIB"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(*args.child)
        return
    names = args.names or list(WORKLOADS)
    if args.compare:
        rows = compare(args.compare, sys.executable, names, args.rounds, args.calls,
                       set(args.wall_only), not args.no_count)
        print(json.dumps(rows, indent=1))
        print(markdown(rows))
    elif args.wall:
        print(json.dumps([{"workload": n, **wall(n, args.wall)} for n in names]))
    else:
        print(json.dumps([count(n, keep=args.keep) for n in names], indent=1))


if __name__ == "__main__":
    main()
