"""Outputs that cannot fit in memory raise TooLargeError (a MemoryError), never abort.

Every call runs in a child whose address space is limited to 3 GiB (RLIMIT_AS), so
nothing here allocates gigabytes: before the memory guard covered every buffer these calls
aborted the process or raised PanicException.
"""

from __future__ import annotations

import sys
import time

import pytest
from _subprocess import run_python

import splitlf

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS and /proc")

LIMITED = """
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
    import numpy as np
    import splitlf
    P = splitlf.Camera.paper()
    try:
        {call}
        print("returned")
    except splitlf.TooLargeError as e:
        assert isinstance(e, MemoryError)
        print("TooLargeError", e.bytes > e.limit, "{name}" in str(e))
"""

CALLS = {
    "trace": "splitlf.trace(P.replace(Kx=10**7, Q=10), 1)",
    # The inputs (800 MB) fit; the outputs do not.
    "new_samples": "splitlf.new_samples(P, np.full(10**8, 500.0))",
    "curves": "splitlf.curves(P, np.full(10**8, 500.0))",
    "sample_grid": "splitlf.sample_grid(P.replace(Kx=1000, Ky=1000), 500.0, 1)",
    "footprints": "splitlf.footprints(P.replace(Kx=10**5), np.geomspace(150, 1e4, 100), 1, "
                  "kernel=True)",
}


@pytest.mark.parametrize("name", sorted(CALLS))
def test_too_large_outputs_raise_memory_error(name):
    r = run_python(LIMITED.format(call=CALLS[name], name=name))
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["TooLargeError", "True", "True"], (r.stdout, r.stderr[-2000:])


def test_no_guard_when_it_fits():
    # The same limit lets an ordinary call through (the guard reads the real headroom).
    r = run_python(LIMITED.format(call="splitlf.curves(P, np.full(10**6, 500.0))", name=""))
    assert r.stdout.split() == ["returned"], r.stderr[-2000:]


@pytest.mark.parametrize("sample", ["chief", "centroid"])
def test_new_samples_memory_estimate_bounds_peak_rss(sample):
    # The estimate the guard compares (read from the error under a tight limit) is an
    # upper bound of what the call really uses (peak RSS growth, same call, no limit).
    cam = "splitlf.Camera.paper().replace(Kx=2**16, Ky=3, Q=16)"  # K Q = 2^20 per axis
    estimate = run_python(f"""
        import resource
        import splitlf
        P = {cam}
        vm = int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (vm + (8 << 20),) * 2)
        try:
            splitlf.new_samples(P, [500.0, 700.0], sample="{sample}", n_threads=1)
        except splitlf.TooLargeError as e:
            print(e.bytes)
    """)
    used = run_python(f"""
        import splitlf
        P = {cam}
        def status(key):
            return int(open("/proc/self/status").read().split(key)[1].split()[0]) * 1024
        base = status("VmRSS:")
        splitlf.new_samples(P, [500.0, 700.0], sample="{sample}", n_threads=1)
        # VmHWM, not ru_maxrss: the latter keeps the forking parent's peak across exec.
        print(status("VmHWM:") - base)
    """)
    assert estimate.returncode == 0 and used.returncode == 0, estimate.stderr + used.stderr
    need, peak = int(estimate.stdout), int(used.stdout)
    assert 0 < peak <= need, (peak, need)


def test_a_fine_reconstruct_grid_is_refused_before_allocating():
    """Issue 46: reconstruct(step=1e-3) on a full seed raw passed the memory guard's plan
    and grew past 6 GB. The core's plan (rust/core/src/inverse/reconstruct.rs) counts
    what the map and the solve allocate and refuses before allocating: at once, with
    TooLargeError, both without a region (over the memory) and over a 4 x 3 mm region
    (16,120^2 padded cells: over the time limit unless allow_slow)."""
    pytest.importorskip("scipy")
    d = splitlf.Design.preset("seed")
    raw = splitlf.render(d, splitlf.Scene(0.5, 1000.0), progress=False)
    for kw in ({}, {"region": (-2.0, 2.0, -1.5, 1.5)}):
        t0 = time.perf_counter()
        with pytest.raises(splitlf.TooLargeError):
            splitlf.reconstruct(raw, 1000.0, step=1e-3, progress=False, **kw)
        assert time.perf_counter() - t0 < 5.0
