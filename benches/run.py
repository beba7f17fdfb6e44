"""Benchmark harness: the native core against honest NumPy implementations of the same work.

For each workload, in one process: build identical inputs, check that NumPy and native
results agree (1e-12 relative), then alternate NumPy, native at 1 thread, native at all
threads and the memory-bandwidth floor (allocate + fill arrays of the output's total
size) over several rounds, rotating their order every round, and report medians. Peak
memory of each side is measured in a fresh subprocess (VmHWM above the post-setup
resident set).

A study (W7, the inverse design) has no NumPy twin: it is checked (deterministic, the
same at 1 thread and all threads, its merits those of the public API), then run at 1
thread and all threads in alternation; it reports the time per evaluated design and the
share of its time spent outside the core, both measured in the same process.

    python benches/run.py            # full sizes -> benches/results.json, benches/RESULTS.md
    python benches/run.py --quick    # small sizes (CI smoke test) -> benches/out/
    python benches/run.py --only W1  # one workload
    python benches/run.py --only W8  # the explorer in headless chromium (w8_explore.py)

Release builds only: install with `pip install .` (maturin builds release).
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import json
import os
import platform
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

import w7_optimise  # noqa: E402
import w9_render  # noqa: E402
import w10_reconstruct  # noqa: E402
import w11_depth  # noqa: E402
import w13_merits  # noqa: E402
from timing import timed  # noqa: E402
from workloads import WORKLOADS, Workload  # noqa: E402

import splitlf  # noqa: E402

# -- W7: inverse design (a study: no NumPy twin) ---------------------------------------------

@dataclasses.dataclass
class Study:
    """A workload of the package's own orchestration around the core, with no NumPy twin:
    measured as time per unit of work and the share of its time outside the core, both
    within one process."""

    name: str
    title: str
    sizes: Callable[[bool], dict[str, Any]]
    # Checks the work before any timing (raises on a mismatch); returns what it measured.
    check: Callable[[dict[str, Any]], dict[str, Any]]
    # One timed run at n_threads (None: all) -> its figures (w7_optimise.figures).
    run: Callable[[dict[str, Any], int | None], dict[str, float]]
    max_rounds: int | None = None


STUDIES: dict[str, Study] = {}


def _w7_sizes(quick: bool) -> dict[str, Any]:
    size = w7_optimise.QUICK if quick else w7_optimise.FULL
    return {**size, "free": "kappa, D, v", "depths": w7_optimise.N_DEPTHS}


def _w7_run(sizes: dict[str, Any], n_threads: int | None) -> dict[str, float]:
    return w7_optimise.figures(w7_optimise.search(sizes["generations"], sizes["popsize"],
                                                  n_threads))


def _w7_check(sizes: dict[str, Any]) -> dict[str, Any]:
    """The search at all threads and at 1 thread: the same history, row for row; the best
    design's merits equal `splitlf.evaluate` of it (the public API, not the
    search's own path) exactly; the core evaluated exactly the valid candidates."""

    a = w7_optimise.search(sizes["generations"], sizes["popsize"], None)
    b = w7_optimise.search(sizes["generations"], sizes["popsize"], 1)
    assert a.history.equals(b.history) and a.free == b.free, "W7: threads changed the search"
    api = splitlf.evaluate(a.design, w7_optimise.depths())
    for name, value in api.items():
        np.testing.assert_array_equal(a.merits[name], value, err_msg=f"W7: merit {name}")
    valid = int(a.history["valid"].sum())
    assert valid == int(a.timing["evaluations"]), ("W7: core evaluations", valid, a.timing)
    assert a.generations == sizes["generations"], ("W7: generations", a.generations)
    return {"same_history_1_and_all_threads": True, "merits_equal_evaluate": True,
            "candidates": a.nfev, "valid_candidates": valid}


STUDIES["W7"] = Study(
    name="W7",
    title="`optimise` of the split sensor over (kappa, D, v), 200 depths",
    sizes=_w7_sizes,
    check=_w7_check,
    run=_w7_run,
    max_rounds=5,
)


#: Per-run figures of a study reported as medians per thread count.
STUDY_FIGURES = ("ms_per_candidate", "ms_per_evaluated_design", "core_ms_per_evaluated_design",
                 "share_outside_core")


def run_study(s: Study, quick: bool, rounds: int) -> dict[str, Any]:
    sizes = s.sizes(quick)
    rounds = min(rounds, s.max_rounds or rounds)
    agreement = s.check(sizes)
    runs = {"native_1": lambda: s.run(sizes, 1), "native_all": lambda: s.run(sizes, None)}
    per: dict[str, list[dict[str, float]]] = {side: [] for side in runs}
    order = list(runs)
    for r in range(rounds):
        for side in order[r % len(order):] + order[:r % len(order)]:
            gc.collect()
            per[side].append(runs[side]())
    counts = {(f["candidates"], f["evaluated_by_core"], f["invalid"])
              for fs in per.values() for f in fs}
    assert len(counts) == 1, (s.name, "runs differ in their candidates", counts)
    candidates, evaluated, invalid = counts.pop()

    def med(side: str, key: str) -> float:
        return statistics.median(f[key] for f in per[side])

    result: dict[str, Any] = {
        "workload": s.name,
        "kind": "study",
        "title": s.title,
        "sizes": sizes,
        "rounds": rounds,
        "threads_all": os.cpu_count() or 1,
        "agreement": agreement,
        "candidates": candidates,
        "evaluated_by_core": evaluated,
        "invalid": invalid,
        "median_s": {side: med(side, "search_s") for side in per},
        "times_s": {side: [f["search_s"] for f in fs] for side, fs in per.items()},
        "core_s": {side: [f["core_s"] for f in fs] for side, fs in per.items()},
        **{key: {side: med(side, key) for side in per} for key in STUDY_FIGURES},
        "target_share_outside_core": w7_optimise.TARGET_SHARE_OUTSIDE_CORE,
    }
    result["speedup_1_to_all"] = result["median_s"]["native_1"] / result["median_s"]["native_all"]
    return result


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


def floor_arrays_run(arrays: list[tuple[tuple[int, ...], Any]]) -> None:
    """Alloc-and-fill floor of given outputs: np.empty and fill each (shape, dtype)."""
    out = []
    for shape, dtype in arrays:
        a = np.empty(shape, dtype=dtype)
        a.fill(1)
        out.append(a)
    del out


def _floor(w: Workload, inp: dict[str, Any]) -> Callable[[], None]:
    if w.out_arrays is not None:
        arrays = w.out_arrays(inp)
        return lambda: floor_arrays_run(arrays)
    nbytes = w.out_bytes(inp)
    return lambda: floor_run(nbytes)


def peak_memory(name: str, side: str, quick: bool, traced: bool = False) -> float:
    """Peak extra resident memory (MiB) of one run of `side`, in a fresh subprocess; with
    `traced`, the peak tracemalloc sees instead (allocations through Python's and NumPy's
    allocators: rust-numpy's arrays, not the core's own Vec buffers)."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--memory", name, side]
    if quick:
        cmd.append("--quick")
    if traced:
        cmd.append("--traced")
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def _status_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise KeyError(field)


def _memory_child(name: str, side: str, quick: bool, traced: bool = False) -> None:
    """Peak resident memory of one run above the post-setup resident set. ru_maxrss would
    inherit the parent's high-water mark across fork/exec (a child of a harness that has
    already run big workloads would see no rise at all), so the child resets the kernel's
    per-process high-water mark (VmHWM, `echo 5 > /proc/self/clear_refs`) after setup.
    With `traced`: tracemalloc's peak over the run instead."""
    import tracemalloc

    w = WORKLOADS[name]
    inp = w.setup(w.sizes(quick))
    floor = _floor(w, inp) if w.out_bytes is not None else None
    gc.collect()
    if traced:
        tracemalloc.start()
    Path("/proc/self/clear_refs").write_text("5")
    base = _status_kib("VmRSS")
    if side == "numpy":
        r = w.numpy(inp)
    elif side == "native":
        r = w.native(inp, None)
    else:
        assert floor is not None, name
        r = floor()
    peak = _status_kib("VmHWM")
    if traced:
        peak_b = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        print(peak_b / 2**20)
    else:
        print((peak - base) / 1024.0)
    del r


def run_workload(w: Workload, quick: bool, rounds: int) -> dict[str, Any]:
    sizes = w.sizes(quick)
    inp = w.setup(sizes)
    rounds = min(rounds, w.max_rounds or rounds)
    check = w.check or check_equal
    # The NumPy side once, checked against the native side at all threads and at 1 thread.
    gc.collect()
    t0 = time.perf_counter()
    ref = w.numpy(inp)
    t_ref = time.perf_counter() - t0
    agreement = check(ref, w.native(inp, None), w.name)
    check(ref, w.native(inp, 1), w.name)
    del ref
    n_all = os.cpu_count() or 1
    times: dict[str, list[float]] = {"numpy": [], "native_1": [], "native_all": [], "floor": []}
    if w.max_rounds is not None:
        # A reference of minutes: its checked run is its first round.
        times["numpy"].append(t_ref)
    runs: dict[str, Callable[[], float]] = {
        "numpy": lambda x=inp: timed(w.numpy, x),
        "native_1": lambda x=inp: timed(w.native, x, 1),
        "native_all": lambda x=inp: timed(w.native, x, None),
    }
    if w.out_bytes is not None:
        floor = _floor(w, inp)
        runs["floor"] = lambda: timed(floor)
    order = list(runs)
    for r in range(rounds):
        # Rotate the order every round: the run right after a big free (of the previous
        # side's outputs) pays more for its page faults here, and no side should always
        # be the one in that position.
        for side in order[r % len(order):] + order[:r % len(order)]:
            if len(times[side]) < rounds:
                times[side].append(runs[side]())
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
        "times_s": times,
    }
    if agreement:
        result["agreement"] = agreement
    if "floor" in med:
        result["output_bytes"] = w.out_bytes(inp)
        result["numpy_over_floor"] = med["numpy"] / med["floor"]
        result["native_all_over_floor"] = med["native_all"] / med["floor"]
        result["native_1_over_floor"] = med["native_1"] / med["floor"]
    del inp, runs
    gc.collect()
    result["peak_mib"] = {side: peak_memory(w.name, side, quick) if side == "native"
                          or w.numpy_memory else None for side in ("numpy", "native")}
    if w.out_bytes is not None:
        result["output_mib"] = result["output_bytes"] / 2**20
        result["native_peak_over_output"] = result["peak_mib"]["native"] / result["output_mib"]
    if w.traced_memory:
        result["traced_peak_mib"] = {"native": peak_memory(w.name, "native", quick, True)}
    return result


# -- W9: raw images (`render`; benches/w9_render.py) ------------------------------------------

#: At most this many rounds of W9 (a round renders three scenes three ways: ~30 s).
W9_MAX_ROUNDS = 5
W9_NAMES = {"seed": "seed, exact route, fronto 1000 mm",
            "r12_fronto": "raytrix-r12, fronto 1000 mm",
            "r12_slanted": "raytrix-r12, slanted Z = 1000 + 0.3 X + 0.1 Y"}


def _met(ok: bool) -> str:
    return "met" if ok else "NOT met"


def _w9_summary(r: dict[str, Any]) -> str:
    parts = []
    for name, s in r["scenes"].items():
        parts.append(f"{name}: native {s['pixels_per_s']['native_all']:.3g} px/s, "
                     f"NumPy twin/native {s['ratio_numpy_over_native_all']:.1f}x (all) "
                     f"{s['ratio_numpy_over_native_1']:.1f}x (1 thr), MC/native "
                     f"{s['ratio_mc_over_native_1']:.0f}x (1 thr), 1->all "
                     f"{s['speedup_1_to_all']:.2f}x")
    m = r["peak_memory_seed"]
    parts.append(f"seed peak {m['peak_over_outputs_and_texture']:.2f}x raws+texture")
    if "r12_full" in r:
        b = r["r12_full"]
        parts.append(f"r12 fronto full sensor {b['full_seconds']:.1f} s on {b['threads']} "
                     f"threads ({b['part']}{', extrapolated' if b['part'] != 'full' else ''})")
    return "W9: " + "; ".join(parts)


def _markdown_render(doc: dict[str, Any]) -> list[str]:
    """The W9 table (render: per scene, per pixel) and its targets."""
    out = []
    for r in doc["results"]:
        if r.get("kind") != "render":
            continue
        t, sz = r["targets"], r["sizes"]
        out += ["", f"W9 ({r['title']}; {r['rounds']} alternating rounds, medians, "
                f"{r['threads_all']} cores). Times per pixel; the NumPy twins are "
                "benches/numpy_render.py's `render_exact` (the exact route, every pixel) and "
                f"`render_pixels_s` (the core's order: a fixed {sz['twin_nodes']} x "
                f"{sz['twin_nodes']} Gauss-Legendre rule over the pixel, exact texture "
                "integrals over the image of the lens cell clipped by the aperture's preimage; "
                f"on {sz['twin_pixels']} random pixels); second twin (once, not in the "
                f"rounds): `render_pixels` (the other order, {sz['check_nodes']} x "
                f"{sz['check_nodes']} nodes over the lens cell, exact inner integrals over the "
                f"pixel's aperture square, on {sz['check_pixels']} of those pixels). MC is "
                "tests/mc_render.py (NumPy, 1 thread) extrapolated to a standard error of "
                "1e-3 of white per pixel. Texture: random "
                f"{sz['texture']} x {sz['texture']} over the (full-size) view at 1000 mm; "
                f"raytrix-r12 with {sz['r12_K'][0]} x {sz['r12_K'][1]} lenses.", "",
                "| scene | pixels | native 1 thr / all [µs/px] | native all [px/s] | "
                "NumPy twin [µs/px] | twin/native 1 / all | agreement [white] | "
                "second twin [µs/px], agreement [white] | "
                "MC [µs/px] | MC/native 1 thr / MC÷cores/native all | 1→all |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]
        for name, s in r["scenes"].items():
            us, mc, a = s["us_per_pixel"], s["monte_carlo"], s["agreement"]
            b = a.get("second_twin")
            second = "–" if b is None else (f"{b['us_per_pixel']:.3g}, "
                                            f"{b['max_diff_white']:.1e}")
            out.append(
                f"| {W9_NAMES.get(name, name)} | {s['pixels']:,} | {us['native_1']:.3g} / "
                f"{us['native_all']:.3g} | {s['pixels_per_s']['native_all']:.3g} | "
                f"{us['numpy']:.3g} | {s['ratio_numpy_over_native_1']:.1f} / "
                f"{s['ratio_numpy_over_native_all']:.1f} | {a['max_diff_white']:.1e} "
                f"(≤ {a['limit_white']:.0e}) | {second} | {mc['us_per_pixel']:.3g} | "
                f"{s['ratio_mc_over_native_1']:.0f} / {s['ratio_mc_all_over_native_all']:.0f} | "
                f"{s['speedup_1_to_all']:.2f} |")
        sc = r["scenes"]
        twin = min(s["ratio_numpy_over_native_all"] for s in sc.values())
        mc = min(s["ratio_mc_over_native_1"] for s in sc.values())
        thr = min(s["speedup_1_to_all"] for s in sc.values())
        m = r["peak_memory_seed"]
        line = (f"Targets (issue 21): NumPy twin / native ≥ {t['twin']:.0f}x: worst "
                f"{twin:.1f}x, {_met(twin >= t['twin'])}; MC / native (same threads) ≥ "
                f"{t['mc']:.0f}x: worst {mc:.0f}x, {_met(mc >= t['mc'])}; 1 → "
                f"{r['threads_all']} threads ≥ {t['threads']}x: worst {thr:.2f}x, "
                f"{_met(thr >= t['threads'])}; peak ≤ {t['peak']}x raws + texture: seed "
                f"{m['peak_mib']:.0f} MiB = {m['peak_over_outputs_and_texture']:.2f}x "
                f"({(m['output_bytes'] + m['texture_bytes']) / 2**20:.0f} MiB), "
                f"{_met(m['peak_over_outputs_and_texture'] <= t['peak'])}")
        if "r12_full" in r:
            b = r["r12_full"]
            ok = b["peak_over_outputs_and_texture"] <= t["peak"]
            line += (f"; raytrix-r12 {b['part']} sensor ({b['Mx']} x {b['My']} pixels) "
                     f"{b['peak_mib']:.0f} MiB = {b['peak_over_outputs_and_texture']:.2f}x, "
                     f"{_met(ok)}")
            full = b["full_seconds"]
            how = ("measured" if b["part"] == "full" else
                   f"extrapolated from the central quarter ({b['seconds']:.1f} s for "
                   f"{b['pixels']:,} pixels; predicted from the reduced scene "
                   f"{b['predicted_full_seconds']:.0f} s)")
            line += (f"; raytrix-r12 fronto-parallel, full sensor ({b['full_pixels']:,} pixels), "
                     f"tol 1e-3, {b['threads']} threads ≤ {t['r12_fronto_s']:.0f} s: "
                     f"{full:.1f} s ({b['full_pixels'] / full:.3g} px/s, {how}), "
                     f"{_met(full <= t['r12_fronto_s'])}")
        out += ["", line + "."]
    return out


# -- W12: concurrent small calls (a ratio within one process, no NumPy twin) ----------------

#: Python threads of W12's concurrent runs.
W12_THREADS = (2, 8)


def _w12_calls(quick: bool) -> dict[str, Callable[[], Any]]:
    """Small calls at n_threads=1: the work a server or a thread pool executor hands out."""
    cam = splitlf.Camera.paper()
    z = np.geomspace(150.0, 1e4, 10 if quick else 20)
    return {
        "sample_grid": lambda: splitlf.sample_grid(cam, 800.0, 2, n_threads=1),
        "footprints_kernel": lambda: splitlf.footprints(cam, z, 2, kernel=True, n_threads=1),
    }


def _w12_serial(fn: Callable[[], Any], n: int) -> float:
    """Wall time of n calls one after the other."""
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return time.perf_counter() - t0


def _w12_concurrent(fn: Callable[[], Any], k: int, reps: int) -> float:
    """Wall time of k Python threads each making `reps` calls."""
    import threading

    go = threading.Barrier(k + 1)

    def work() -> None:
        go.wait()
        for _ in range(reps):
            fn()

    threads = [threading.Thread(target=work) for _ in range(k)]
    for t in threads:
        t.start()
    go.wait()
    t0 = time.perf_counter()
    for t in threads:
        t.join()
    return time.perf_counter() - t0


def run_w12(quick: bool, rounds: int) -> dict[str, Any]:
    """W12: k Python threads each making the same small call at n_threads=1, against the
    same k x reps calls made one after the other on one thread (alternating, medians of
    the ratio concurrent / serial). On c cores the ideal ratio is max(1/c, 1/k): concurrent
    calls hold no lock of the core's (the GIL is released, pools are per call)."""
    calls = _w12_calls(quick)
    reps = 2 if quick else 6
    ratios: dict[str, dict[str, float]] = {}
    times: dict[str, dict[str, list[float]]] = {}
    for name, fn in calls.items():
        fn()  # warm up (pools, caches)
        for k in W12_THREADS:
            per: list[float] = []
            serial_s: list[float] = []
            for r in range(rounds):
                gc.collect()
                order = (0, 1) if r % 2 == 0 else (1, 0)
                got = {}
                for side in order:
                    if side == 0:
                        got[0] = _w12_serial(fn, k * reps)
                    else:
                        got[1] = _w12_concurrent(fn, k, reps)
                serial_s.append(got[0])
                per.append(got[1] / got[0])
            key = f"{name}_x{k}"
            ratios[key] = statistics.median(per)
            times[key] = {"serial_s": serial_s, "ratio": per}
    return {"workload": "W12", "kind": "concurrent",
            "title": "concurrent small calls (n_threads=1) from 2 and 8 Python threads",
            "sizes": {"reps_per_thread": reps, "threads": list(W12_THREADS), "quick": quick},
            "rounds": rounds, "threads_all": os.cpu_count() or 1,
            "ratio_concurrent_over_serial": ratios, "runs": times}


# -- W8: the design explorer in a browser (benches/w8_explore.py) --------------------------

#: Workloads run only when named in --only (not NumPy-against-native timings).
BROWSER_WORKLOADS = ("W8",)


def run_w8(quick: bool) -> dict[str, Any] | None:
    """W8 (50 changes, 5 with --quick), or None with a message when it cannot run here
    (no chromium, chromedriver, Panel or Selenium)."""
    import w8_explore

    why = w8_explore.unavailable()
    if why is not None:
        print(f"W8 skipped: {why}", flush=True)
        return None
    return w8_explore.measure(5 if quick else 50)


def git_commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _fmt_sizes(s: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v:,}" if isinstance(v, int) else f"{k}={v}" for k, v in s.items()
                     if k != "quick")


def _mib(v: float | None) -> str:
    return "–" if v is None else f"{v:.0f}"


#: A line from which RESULTS.md is hand-written (measured by other scripts, e.g.
#: benches/instructions.py): write_markdown keeps it and what follows.
KEPT_MARKER = "<!-- kept by run.py: measured by other scripts, see benches/README.md -->"


def _kept(path: Path) -> list[str]:
    """The hand-written tail of the file at `path` (from KEPT_MARKER on), if any."""
    text = path.read_text() if path.exists() else ""
    return ["", text[text.index(KEPT_MARKER):].rstrip("\n")] if KEPT_MARKER in text else []


def write_markdown(doc: dict[str, Any], path: Path) -> None:
    if all(r["workload"] in BROWSER_WORKLOADS for r in doc["results"]):
        lines = ["# Benchmark results", "", f"Generated by `python benches/run.py"
                 f"{' --quick' if doc['quick'] else ''} --only W8` on "
                 f"{doc['machine']['cores']} cores ({doc['machine']['platform']}), commit "
                 f"`{doc['commit']}`."]
        path.write_text("\n".join(lines + _markdown_browser(doc) + _kept(path)) + "\n")
        return
    lines = [
        "# Benchmark results",
        "",
        f"Generated by `python benches/run.py{' --quick' if doc['quick'] else ''}` on "
        f"{doc['machine']['cores']} cores ({doc['machine']['platform']}), commit "
        f"`{doc['commit']}`, {doc['rounds']} alternating rounds, medians. Ratios are NumPy "
        "time / native time; 'x floor' is a side's time over allocating and filling fresh "
        "arrays of the output's total size. Peak memory: extra resident memory of one run in "
        "a fresh process.",
    ]
    if any(r.get("kind") not in ("study", "concurrent", "render", "reconstruct", "depth", "merits")
           and r["workload"] not in BROWSER_WORKLOADS for r in doc["results"]):
        lines += [
            "",
            "| workload | sizes | NumPy [s] | native 1 thr [s] | native all [s] | "
            "NumPy/native 1 | NumPy/native all | 1→all speed-up | NumPy x floor | "
            "native x floor | peak MiB NumPy / native / output |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
    for r in doc["results"]:
        if (r.get("kind") in ("study", "concurrent", "render", "reconstruct", "depth", "merits")
                or r["workload"] in BROWSER_WORKLOADS):
            continue
        m = r["median_s"]
        floor = (f"{r['numpy_over_floor']:.2f} | {r['native_all_over_floor']:.2f}"
                 if "numpy_over_floor" in r else "– | –")
        out_mib = f"{r['output_mib']:.0f}" if "output_mib" in r else "–"
        lines.append(
            f"| {r['workload']}: {r['title']} | {_fmt_sizes(r['sizes'])} | {m['numpy']:.4g} | "
            f"{m['native_1']:.4g} | {m['native_all']:.4g} | "
            f"{r['ratio_numpy_over_native_1']:.1f} | {r['ratio_numpy_over_native_all']:.1f} | "
            f"{r['speedup_1_to_all']:.2f} | {floor} | "
            f"{_mib(r['peak_mib']['numpy'])} / {r['peak_mib']['native']:.0f} / {out_mib} |"
        )
    lines += (_markdown_studies(doc) + _markdown_render(doc) + _markdown_w10_w11(doc)
              + _markdown_concurrent(doc) + _markdown_w13(doc))
    lines += _markdown_targets(doc) + _markdown_browser(doc) + _kept(path)
    path.write_text("\n".join(lines) + "\n")


def _markdown_studies(doc: dict[str, Any]) -> list[str]:
    """The studies (no NumPy twin): time per evaluated design and share outside the core."""
    studies = [r for r in doc["results"] if r.get("kind") == "study"]
    if not studies:
        return []
    out = ["", "Studies without a NumPy twin: the time per evaluated design (the search's whole "
           "time over the designs the core evaluated) and the share of the search's time "
           "spent outside the core, at 1 thread and all threads (medians).", "",
           "| workload | sizes | candidates / evaluated by the core | search [s] 1 thr / all "
           "| ms per evaluated design 1 thr / all | core ms per design 1 thr / all "
           "| share outside the core 1 thr / all | target |",
           "|---|---|---|---|---|---|---|---|"]
    for r in studies:
        m, per, core, share = (r["median_s"], r["ms_per_evaluated_design"],
                               r["core_ms_per_evaluated_design"], r["share_outside_core"])
        met = max(share.values()) < r["target_share_outside_core"]
        out.append(
            f"| {r['workload']}: {r['title']} | {_fmt_sizes(r['sizes'])} | "
            f"{r['candidates']} / {r['evaluated_by_core']} | {m['native_1']:.3g} / "
            f"{m['native_all']:.3g} | {per['native_1']:.3g} / {per['native_all']:.3g} | "
            f"{core['native_1']:.3g} / {core['native_all']:.3g} | "
            f"{100 * share['native_1']:.1f} % / {100 * share['native_all']:.1f} % | "
            f"< {100 * r['target_share_outside_core']:.0f} %: {'met' if met else 'NOT met'} |")
    return out


def _markdown_concurrent(doc: dict[str, Any]) -> list[str]:
    """The W12 line: concurrent over serial wall time of the same calls (one process)."""
    out = []
    for r in doc["results"]:
        if r.get("kind") == "concurrent":
            ratios = ", ".join(f"{k.replace('_x', ' x ')} threads {v:.2f}"
                               for k, v in r["ratio_concurrent_over_serial"].items())
            out += ["", f"W12 ({r['title']}; concurrent / serial wall time of the same calls, "
                    f"medians of {r['rounds']} alternating rounds, {r['threads_all']} cores; "
                    f"targets 2 threads <= 0.75, 8 threads <= 0.9 on 2 cores): {ratios}."]
    return out


def _markdown_browser(doc: dict[str, Any]) -> list[str]:
    """The W8 line (the explorer in a browser), when it ran."""
    out = []
    for r in doc["results"]:
        if r["workload"] == "W8":
            c = r["coverage_2d"]
            out += ["", f"W8 (the explorer in headless chromium, seed design, {r['changes']} "
                    "changes of D; target median <= 150 ms, p95 <= 400 ms): blur and samples "
                    f"figures updated in median {r['median_ms']:.0f} ms, p95 {r['p95_ms']:.0f} "
                    f"ms ({'met' if r['met'] else 'not met'}); with the 2-D coverage dots, "
                    f"median {c['median_ms']:.0f} ms, p95 {c['p95_ms']:.0f} ms; load average "
                    f"{r['load_average_1min']['before']:.2f} / "
                    f"{r['load_average_1min']['after']:.2f} before / after."]
    return out


def _markdown_targets(doc: dict[str, Any]) -> list[str]:
    """Agreement, the issue-11 targets of W5 and W6, the machine's load, and the previous
    committed run."""
    by = {r["workload"]: r for r in doc["results"]}
    out = ["", "Load average (1 min) before / after each workload: " + ", ".join(
        f"{n} {r['load_average']['before'][0]:.2f} / {r['load_average']['after'][0]:.2f}"
        for n, r in by.items() if "load_average" in r and n not in BROWSER_WORKLOADS) + "."]
    if "W5" in by:
        r = by["W5"]
        a = r.get("agreement", {})
        out += ["", "W5 (target: NumPy+SciPy / native all >= 10, native 1 -> all threads >= 1.7): "
                f"{r['ratio_numpy_over_native_all']:.1f}x at all threads, "
                f"{r['ratio_numpy_over_native_1']:.1f}x at 1 thread, 1 -> "
                f"{r['threads_all']} threads {r['speedup_1_to_all']:.2f}x. Agreement on every "
                "depth and row: distinct counts equal, covering radius within "
                f"{a.get('covering_radius_max_rel_diff', float('nan')):.1e} relative."]
    if "W6" in by:
        r = by["W6"]
        traced = r.get("traced_peak_mib", {}).get("native")
        out += ["", "W6 (target: native <= 2x the alloc-and-fill floor, peak <= 1.2x outputs): "
                f"native all threads {r['native_all_over_floor']:.2f}x floor "
                f"(1 thread {r['native_1_over_floor']:.2f}x), floor "
                f"{r['median_s']['floor']:.3g} s; peak {r['peak_mib']['native']:.0f} MiB = "
                f"{r['native_peak_over_output']:.3f}x the outputs' {r['output_mib']:.0f} MiB"
                + (f" (tracemalloc peak {traced:.0f} MiB)" if traced is not None else "")
                + "; NumPy and native arrays identical bit for bit."]
    prev = doc.get("previous")
    if prev and prev["workloads"]:
        out += ["", f"Against the previous committed run (commit `{prev['commit']}`): native time "
                "now / then, and NumPy/native ratios then -> now (each measured within one run).",
                "", "| workload | native all now/then | native 1 now/then | NumPy/native all "
                "| NumPy/native 1 |", "|---|---|---|---|---|"]
        for n, c in prev["workloads"].items():
            if "ratio_numpy_over_native_all" in c:
                ra, r1 = c["ratio_numpy_over_native_all"], c["ratio_numpy_over_native_1"]
                ratios = f"{ra[0]:.1f} -> {ra[1]:.1f} | {r1[0]:.1f} -> {r1[1]:.1f}"
            else:  # a study: its share outside the core, then -> now
                sh = c["share_outside_core_all"]
                ratios = f"(share outside the core {sh[0]:.3f} -> {sh[1]:.3f}) | –"
            out.append(f"| {n} | {c['native_all_now_over_then']:.2f} | "
                       f"{c['native_1_now_over_then']:.2f} | {ratios} |")
    return out


def compare(previous: dict[str, Any], results: list[dict[str, Any]]) -> dict[str, Any]:
    """Each workload of the previous run against this run: native time now / then (> 1:
    slower now) and the NumPy/native ratios then and now (within one run each, so they
    cancel most of the machine's state)."""
    old = {r["workload"]: r for r in previous["results"]}
    rows = {}
    for r in results:
        o = old.get(r["workload"])
        if o is None:
            continue
        if (r["workload"] in BROWSER_WORKLOADS
                or r.get("kind") in ("concurrent", "render", "reconstruct", "depth", "merits")
                or o.get("kind") != r.get("kind")):
            continue
        row = {
            "native_all_now_over_then": r["median_s"]["native_all"] / o["median_s"]["native_all"],
            "native_1_now_over_then": r["median_s"]["native_1"] / o["median_s"]["native_1"],
        }
        if r.get("kind") == "study":
            row["share_outside_core_all"] = [o["share_outside_core"]["native_all"],
                                             r["share_outside_core"]["native_all"]]
        else:
            row["ratio_numpy_over_native_all"] = [o["ratio_numpy_over_native_all"],
                                                  r["ratio_numpy_over_native_all"]]
            row["ratio_numpy_over_native_1"] = [o["ratio_numpy_over_native_1"],
                                                r["ratio_numpy_over_native_1"]]
        rows[r["workload"]] = row
    return {"commit": previous.get("commit"), "workloads": rows}


# -- W10, W11: reconstruct and depth (benches/w10_reconstruct.py, w11_depth.py) ----------


def run_w10_w11(name: str, quick: bool, rounds: int) -> dict[str, Any]:
    """W10 (reconstruct) or W11 (depth) as their own scripts run them (W10: its own two
    rounds; W11: at most 3 of ``rounds``)."""
    if name == "W10":
        return {"workload": "W10", "kind": "reconstruct", **w10_reconstruct.run(quick)}
    return {"workload": "W11", "kind": "depth", **w11_depth.run(quick, min(rounds, 3))}


def _w10_w11_summary(r: dict[str, Any]) -> str:
    if r["workload"] == "W10":
        f, q = r["full"], r["ratio"]
        return (f"W10: {f['cells'][0]}^2 cells {f['seconds_all_threads']:.3g} s (1 thread "
                f"{f['seconds_1_thread']:.3g} s, {f['threads_speedup']:.2f}x), "
                f"{f['iterations']} iterations, peak {f['peak_rss_mib']:.0f} MiB; NumPy + "
                f"SciPy at {q['cells'][0]}^2 cells: {q['numpy_over_native']:.0f}x")
    return (f"W11: {r['cells'][0]}^2 cells x {r['candidates']} candidates "
            f"{r['native_s']:.3g} s, NumPy {r['ratio_numpy']:.2f}x, 1 -> all threads "
            f"{r['threads_speedup']:.2f}x, peak {r['peak_mib']:.0f} MiB")


def _markdown_w10_w11(doc: dict[str, Any]) -> list[str]:
    """W10 and W11 as lines against their issues' targets."""
    out: list[str] = []
    if doc["quick"] and any(r.get("kind") in ("reconstruct", "depth") for r in doc["results"]):
        out += ["", "W10 and W11 below are at --quick sizes: their targets are for the full "
                "sizes, and a 'met' here says nothing of them."]
    for r in doc["results"]:
        if r.get("kind") not in ("reconstruct", "depth"):
            continue
        if r["workload"] == "W10":
            f, q = r["full"], r["ratio"]
            out += ["", f"W10 (reconstruct: the seed's raw at 1 m, N = 2000, "
                    f"{f['cells'][0]} x {f['cells'][1]} cells, {f['rows']:,} rows, "
                    f"{f['iterations']} CG iterations; benches/w10_reconstruct.py): "
                    f"{f['seconds_all_threads']:.3g} s at all threads (target ≤ 5 s: "
                    f"{_met(f['seconds_all_threads'] <= 5.0)}), 1 → all threads "
                    f"{f['threads_speedup']:.2f}× (≥ 1.7: {_met(f['threads_speedup'] >= 1.7)}), "
                    f"peak {f['peak_rss_mib']:.0f} MiB (factored map "
                    f"{f['factored_map_mib']:.0f} MiB, explicit {f['explicit_map_mib']:,.0f} "
                    f"MiB); at {q['cells'][0]} x {q['cells'][1]} cells NumPy + SciPy "
                    f"{q['numpy_s']:.3g} s against {q['native_s']:.3g} s: "
                    f"{q['numpy_over_native']:.0f}× (≥ 10: {_met(q['numpy_over_native'] >= 10)}"
                    f"), images within {q['max_diff']:.1e} when both run to the tight "
                    f"relative stop ({q['iterations'][0]} and {q['iterations'][1]} "
                    f"iterations)."]
        else:
            out += ["", f"W11 (depth: the seed's raw at 1 m, {r['cells'][0]} x "
                    f"{r['cells'][1]} cells × {r['candidates']} candidates; "
                    f"benches/w11_depth.py, {r['rounds']} rounds, medians): "
                    f"{r['native_s']:.3g} s (target ≤ 3 s: {_met(r['native_s'] <= 3.0)}), "
                    f"NumPy {r['numpy_s']:.3g} s: {r['ratio_numpy']:.2f}× (≥ 10: "
                    f"{_met(r['ratio_numpy'] >= 10)}), 1 → all threads "
                    f"{r['threads_speedup']:.2f}× (≥ 1.8: {_met(r['threads_speedup'] >= 1.8)}),"
                    f" peak {r['peak_mib']:.0f} MiB; the depth maps agree to 1e-9 on "
                    f"{100 * r['agree_share']:.2f} % of the cells."]
    return out


# -- W13: image merits (benches/w13_merits.py) ---------------------------------------------


def _w13_summary(r: dict[str, Any]) -> str:
    return (f"W13: {r['s_per_evaluated_design']:.3g} s per evaluated design, "
            f"{r['core_s']:.3g} s in the core, share outside the core "
            f"{r['share_outside_core']:.3f}")


def _markdown_w13(doc: dict[str, Any]) -> list[str]:
    """The W13 line: time per evaluated design with image merits, share outside the core."""
    out: list[str] = []
    for r in doc["results"]:
        if r.get("kind") != "merits":
            continue
        sz = r["sizes"]
        share = r["share_outside_core"]
        out += ["", f"W13 ({r['title']}; `evaluate` over {sz['depths']} depths of "
                f"{sz['range_mm'][0]:g}–{sz['range_mm'][1]:g} mm, {len(sz['image'])} image "
                f"merits, N = {sz['photons']:g}, {sz['threads']} threads; "
                f"benches/w13_merits.py, {r['rounds']} rounds, medians): "
                f"{r['s_per_evaluated_design']:.3g} s per evaluated design, "
                f"{r['core_s']:.3g} s of it in the core; share outside the core "
                f"{100 * share:.1f} % (target ≤ {100 * r['target_share_outside_core']:.0f} %: "
                f"{_met(share <= r['target_share_outside_core'])})."]
    return out


def _ordered(names: list[str]) -> list[str]:
    """Workload names in numeric order (W1, ..., W9, W12, W13)."""
    return sorted(names, key=lambda n: int(n[1:]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (CI smoke test)")
    ap.add_argument("--only", nargs="*",
                    choices=(_ordered([*WORKLOADS, *STUDIES, "W9", "W10", "W11", "W12", "W13"])
                             + list(BROWSER_WORKLOADS)),
                    help="workloads to run (default W1-W7 and W9-W13; W8, the explorer in a "
                    "browser, only when named)")
    ap.add_argument("--rounds", type=int, default=None,
                    help="alternating rounds (default 7, 3 with --quick)")
    ap.add_argument("--out", type=Path, default=None,
                    help="output folder (default benches/ for full runs, benches/out/ for "
                    "--quick or --only)")
    ap.add_argument("--memory", nargs=2, metavar=("WORKLOAD", "SIDE"), help=argparse.SUPPRESS)
    ap.add_argument("--traced", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.memory:
        _memory_child(args.memory[0], args.memory[1], args.quick, args.traced)
        return 0
    rounds = args.rounds or (3 if args.quick else 7)
    # A quick or partial (--only) run never overwrites the committed full results.
    out_dir = args.out or (HERE / "out" if args.quick or args.only else HERE)
    out_dir.mkdir(parents=True, exist_ok=True)
    # The committed full run, to compare with (read before it is overwritten).
    prev_path = HERE / "results.json"
    previous = (json.loads(prev_path.read_text())
                if not args.quick and prev_path.exists() else None)
    results = []
    for name in args.only or _ordered([*WORKLOADS, *STUDIES, "W9", "W10", "W11", "W12", "W13"]):
        if name == "W8":
            w8 = run_w8(args.quick)
            if w8 is not None:
                results.append({**w8, "workload": "W8"})
                print(f"W8: median {w8['median_ms']:.0f} ms, p95 {w8['p95_ms']:.0f} ms",
                      flush=True)
            continue
        load_before = os.getloadavg()
        if name == "W9":
            r = w9_render.run(args.quick, min(rounds, W9_MAX_ROUNDS))
            r["load_average"] = {"before": load_before, "after": os.getloadavg()}
            results.append(r)
            print(_w9_summary(r), flush=True)
            continue
        if name in ("W10", "W11"):
            r = run_w10_w11(name, args.quick, rounds)
            r["load_average"] = {"before": load_before, "after": os.getloadavg()}
            results.append(r)
            print(_w10_w11_summary(r), flush=True)
            continue
        if name == "W13":
            r = {"workload": "W13", "kind": "merits", **w13_merits.run(args.quick, min(rounds, 3))}
            r["load_average"] = {"before": load_before, "after": os.getloadavg()}
            results.append(r)
            print(_w13_summary(r), flush=True)
            continue
        if name == "W12":
            r = run_w12(args.quick, rounds)
            r["load_average"] = {"before": load_before, "after": os.getloadavg()}
            results.append(r)
            print("W12: concurrent / serial wall time " + ", ".join(
                f"{k} {v:.2f}" for k, v in r["ratio_concurrent_over_serial"].items()),
                flush=True)
            continue
        if name in STUDIES:
            r = run_study(STUDIES[name], args.quick, rounds)
        else:
            r = run_workload(WORKLOADS[name], args.quick, rounds)
        r["load_average"] = {"before": load_before, "after": os.getloadavg()}
        results.append(r)
        m = r["median_s"]
        if name in STUDIES:
            per, share = r["ms_per_evaluated_design"], r["share_outside_core"]
            print(f"{name}: {per['native_1']:.3g} / {per['native_all']:.3g} ms per evaluated "
                  f"design (1 thr / all), share outside the core {share['native_1']:.3f} / "
                  f"{share['native_all']:.3f}", flush=True)
            continue
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
    if previous is not None:
        doc["previous"] = compare(previous, results)
    (out_dir / "results.json").write_text(json.dumps(doc, indent=2) + "\n")
    write_markdown(doc, out_dir / "RESULTS.md")
    print(f"wrote {out_dir / 'results.json'} and {out_dir / 'RESULTS.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
