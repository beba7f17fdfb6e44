"""Benchmark harness: the native core against honest NumPy implementations of the same work.

For each workload, in one process: build identical inputs, check that NumPy and native
results agree (1e-12 relative), then alternate NumPy, native at 1 thread, native at all
threads and the memory-bandwidth floor (allocate + fill arrays of the output's total
size) over several rounds and report medians. Peak memory of each side is measured in a
fresh subprocess (ru_maxrss above the post-setup baseline).

    python benches/run.py            # full sizes -> benches/results.json, benches/RESULTS.md
    python benches/run.py --quick    # small sizes (CI smoke test) -> benches/out/
    python benches/run.py --only W1  # one workload

Release builds only: install with `pip install .` (maturin builds release).
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import numpy_impl  # noqa: E402

import splitlf  # noqa: E402


@dataclasses.dataclass
class Workload:
    name: str
    title: str
    sizes: Callable[[bool], dict[str, Any]]
    setup: Callable[[dict[str, Any]], dict[str, Any]]
    numpy: Callable[[dict[str, Any]], dict[str, np.ndarray]]
    native: Callable[[dict[str, Any], int | None], dict[str, np.ndarray]]
    out_bytes: Callable[[dict[str, Any]], int] | None = None


WORKLOADS: dict[str, Workload] = {}


def workload(w: Workload) -> Workload:
    WORKLOADS[w.name] = w
    return w


# -- W1: closed forms --------------------------------------------------------------------

def _w1_setup(sizes):
    cam = splitlf.Camera.paper()
    z = np.geomspace(cam.F * 1.001, 1e5, sizes["depths"])
    return {"cam": cam, "z": z}


def _w1_native(inp, n_threads):
    c = splitlf.curves(inp["cam"], inp["z"], n_threads=n_threads)
    return {k: getattr(c, k) for k in ("conjugate", "main_blur", "repetitions",
                                       "microlens_blur", "blur_px", "conventional_px")}


workload(Workload(
    name="W1",
    title="closed forms: every `curves` array",
    sizes=lambda quick: {"depths": 10**5 if quick else 10**7},
    setup=_w1_setup,
    numpy=lambda inp: numpy_impl.curves(inp["cam"], inp["z"]),
    native=_w1_native,
    out_bytes=lambda inp: 11 * 8 * inp["z"].size,
))


# -- W3: new samples ---------------------------------------------------------------------

def _w3_setup(sizes):
    return {"cam": splitlf.Camera.paper(), "z": np.geomspace(150.0, 10_000.0, sizes["depths"]),
            "tol": 1e-6}


def _w3_native(inp, n_threads):
    r = splitlf.new_samples(inp["cam"], inp["z"], tol=inp["tol"], n_threads=n_threads)
    return {"distinct": r.distinct, "max_gap": r.max_gap}


workload(Workload(
    name="W3",
    title="samples: `new_samples` (distinct per half and union, max gap)",
    sizes=lambda quick: {"depths": 200 if quick else 10**4},
    setup=_w3_setup,
    numpy=lambda inp: numpy_impl.new_samples(inp["cam"], inp["z"], inp["tol"]),
    native=_w3_native,
))


# -- harness -------------------------------------------------------------------------------

def check_equal(a: dict[str, np.ndarray], b: dict[str, np.ndarray], name: str) -> None:
    assert set(a) == set(b), (name, sorted(a), sorted(b))
    for key in a:
        np.testing.assert_allclose(b[key], a[key], rtol=1e-12, atol=0, equal_nan=True,
                                   err_msg=f"{name}: {key}")


def floor_run(nbytes: int) -> None:
    """Memory-bandwidth floor: allocate and write fresh arrays of the output's size."""
    a = np.empty(nbytes // 8)
    a.fill(1.0)
    del a


def timed(fn: Callable[..., Any], *args: Any) -> float:
    gc.collect()
    t0 = time.perf_counter()
    r = fn(*args)
    dt = time.perf_counter() - t0
    del r
    return dt


def peak_memory(name: str, side: str, quick: bool) -> float:
    """Peak extra resident memory (MiB) of one run of `side`, in a fresh subprocess."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--memory", name, side]
    if quick:
        cmd.append("--quick")
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def _memory_child(name: str, side: str, quick: bool) -> None:
    w = WORKLOADS[name]
    inp = w.setup(w.sizes(quick))
    gc.collect()
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    if side == "numpy":
        r = w.numpy(inp)
    elif side == "native":
        r = w.native(inp, None)
    else:
        floor_run(w.out_bytes(inp))
        r = None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    del r
    print((peak - base) / 1024.0)  # ru_maxrss is KiB on Linux


def run_workload(w: Workload, quick: bool, rounds: int) -> dict[str, Any]:
    sizes = w.sizes(quick)
    inp = w.setup(sizes)
    check_equal(w.numpy(inp), w.native(inp, None), w.name)
    check_equal(w.numpy(inp), w.native(inp, 1), w.name)
    n_all = os.cpu_count() or 1
    times: dict[str, list[float]] = {"numpy": [], "native_1": [], "native_all": [], "floor": []}
    for _ in range(rounds):
        times["numpy"].append(timed(w.numpy, inp))
        times["native_1"].append(timed(w.native, inp, 1))
        times["native_all"].append(timed(w.native, inp, None))
        if w.out_bytes is not None:
            times["floor"].append(timed(floor_run, w.out_bytes(inp)))
    med = {k: statistics.median(v) for k, v in times.items() if v}
    result: dict[str, Any] = {
        "workload": w.name,
        "title": w.title,
        "sizes": sizes,
        "rounds": rounds,
        "threads_all": n_all,
        "median_s": med,
        "ratio_numpy_over_native_1": med["numpy"] / med["native_1"],
        "ratio_numpy_over_native_all": med["numpy"] / med["native_all"],
        "speedup_1_to_all": med["native_1"] / med["native_all"],
    }
    if "floor" in med:
        result["output_bytes"] = w.out_bytes(inp)
        result["numpy_over_floor"] = med["numpy"] / med["floor"]
        result["native_all_over_floor"] = med["native_all"] / med["floor"]
    del inp
    gc.collect()
    result["peak_mib"] = {side: peak_memory(w.name, side, quick) for side in ("numpy", "native")}
    if w.out_bytes is not None:
        result["output_mib"] = result["output_bytes"] / 2**20
    return result


def git_commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _fmt_sizes(s: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v:,}" if isinstance(v, int) else f"{k}={v}" for k, v in s.items())


def write_markdown(doc: dict[str, Any], path: Path) -> None:
    lines = [
        "# Benchmark results",
        "",
        f"Generated by `python benches/run.py{' --quick' if doc['quick'] else ''}` on "
        f"{doc['machine']['cores']} cores ({doc['machine']['platform']}), commit "
        f"`{doc['commit']}`, {doc['rounds']} alternating rounds, medians. Ratios are NumPy "
        "time / native time; 'x floor' is a side's time over allocating and filling fresh "
        "arrays of the output's total size. Peak memory: extra resident memory of one run in "
        "a fresh process.",
        "",
        "| workload | sizes | NumPy [s] | native 1 thr [s] | native all [s] | NumPy/native 1 "
        "| NumPy/native all | 1→all speed-up | NumPy x floor | native x floor | "
        "peak MiB NumPy / native / output |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in doc["results"]:
        m = r["median_s"]
        floor = (f"{r['numpy_over_floor']:.2f} | {r['native_all_over_floor']:.2f}"
                 if "numpy_over_floor" in r else "– | –")
        out_mib = f"{r['output_mib']:.0f}" if "output_mib" in r else "–"
        lines.append(
            f"| {r['workload']}: {r['title']} | {_fmt_sizes(r['sizes'])} | {m['numpy']:.4g} | "
            f"{m['native_1']:.4g} | {m['native_all']:.4g} | "
            f"{r['ratio_numpy_over_native_1']:.1f} | {r['ratio_numpy_over_native_all']:.1f} | "
            f"{r['speedup_1_to_all']:.2f} | {floor} | "
            f"{r['peak_mib']['numpy']:.0f} / {r['peak_mib']['native']:.0f} / {out_mib} |"
        )
    path.write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (CI smoke test)")
    ap.add_argument("--only", nargs="*", choices=sorted(WORKLOADS), help="workloads to run")
    ap.add_argument("--rounds", type=int, default=None,
                    help="alternating rounds (default 7, 3 with --quick)")
    ap.add_argument("--out", type=Path, default=None,
                    help="output folder (default benches/ for full runs, benches/out/ for --quick)")
    ap.add_argument("--memory", nargs=2, metavar=("WORKLOAD", "SIDE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.memory:
        _memory_child(args.memory[0], args.memory[1], args.quick)
        return 0
    rounds = args.rounds or (3 if args.quick else 7)
    out_dir = args.out or (HERE / "out" if args.quick else HERE)
    out_dir.mkdir(parents=True, exist_ok=True)
    results = []
    for name in args.only or sorted(WORKLOADS):
        r = run_workload(WORKLOADS[name], args.quick, rounds)
        results.append(r)
        m = r["median_s"]
        print(f"{name}: numpy {m['numpy']:.4g}s, native 1 thr {m['native_1']:.4g}s, all "
              f"{m['native_all']:.4g}s -> ratio {r['ratio_numpy_over_native_all']:.1f}x",
              flush=True)
    doc = {
        "quick": args.quick,
        "rounds": rounds,
        "commit": git_commit(),
        "machine": {"cores": os.cpu_count(), "platform": platform.platform(),
                    "python": platform.python_version(), "numpy": np.__version__},
        "results": results,
    }
    (out_dir / "results.json").write_text(json.dumps(doc, indent=2) + "\n")
    write_markdown(doc, out_dir / "RESULTS.md")
    print(f"wrote {out_dir / 'results.json'} and {out_dir / 'RESULTS.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
