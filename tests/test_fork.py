"""Thread pools survive fork() and stay bounded in number."""

from __future__ import annotations

import sys

import pytest
from _subprocess import run_python

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="fork and /proc are Linux")


def test_sweep_in_forked_workers_after_threads_in_the_parent():
    # The parent first uses the 1-thread pool (threads_per_task = 1) from a thread pool
    # executor, then forks workers that use the same pool size: before pools were rebuilt
    # per process, the children blocked forever.
    r = run_python("""
        import concurrent.futures as cf, multiprocessing
        import numpy as np
        import splitlf
        from splitlf.sweep import sweep
        P = splitlf.Camera.paper()
        z = np.geomspace(150.0, 1e4, 40)
        a = sweep(P, {"D": [10.0, 20.0]}, z, executor=cf.ThreadPoolExecutor(2))
        ctx = multiprocessing.get_context("fork")
        with cf.ProcessPoolExecutor(2, mp_context=ctx) as ex:
            b = sweep(P, {"D": [10.0, 20.0]}, z, executor=ex)
        print("ok", a.equals(b) if hasattr(a, "equals") else a == b)
    """)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["ok", "True"], r.stdout


def test_direct_calls_in_a_forked_child():
    # The parent used the all-core pool and a 2-thread pool; a forked child uses both
    # again (and a new size), through every kind of chunked driver.
    r = run_python("""
        import os
        import numpy as np
        import splitlf
        P = splitlf.Camera.paper()
        z = np.geomspace(150.0, 1e4, 200)
        want = splitlf.curves(P, z).blur_px
        splitlf.curves(P, z, n_threads=2)
        splitlf.new_samples(P, z, n_threads=2)
        pid = os.fork()
        if pid == 0:
            ok = np.array_equal(splitlf.curves(P, z).blur_px, want)
            ok &= np.array_equal(splitlf.curves(P, z, n_threads=2).blur_px, want)
            splitlf.new_samples(P, z)
            splitlf.footprints(P, z[:5], 2, n_threads=2)
            splitlf.coincidence_planes(P, 1, n_threads=3)
            os._exit(0 if ok else 3)
        _, status = os.waitpid(pid, 0)
        print("child", os.waitstatus_to_exitcode(status))
    """)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["child", "0"], r.stdout


def test_thread_pools_are_bounded():
    # One pool per distinct n_threads used to be kept forever (5,052 threads after
    # n_threads = 1..100); at most _native.MAX_POOLS pools are kept now. Threads of a
    # dropped pool exit asynchronously: wait for them (a hang timeout, not a timing).
    r = run_python("""
        import os, time
        import numpy as np
        import splitlf
        from splitlf import _native
        P = splitlf.Camera.paper()
        z = np.geomspace(150.0, 1e4, 50)
        base = len(os.listdir("/proc/self/task"))
        for n in range(1, 101):
            splitlf.curves(P, z, n_threads=n)
        bound = base + _native.MAX_POOLS * 100
        while len(os.listdir("/proc/self/task")) > bound:
            time.sleep(0.05)
        print("threads", len(os.listdir("/proc/self/task")) - base, "pools", _native.MAX_POOLS)
    """, timeout=60)
    assert r.returncode == 0, r.stderr
    words = r.stdout.split()
    assert words[0] == "threads" and int(words[1]) <= int(words[3]) * 100, r.stdout


def test_exact_route_render_in_a_forked_child():
    # The parent renders on the exact route; a forked child (a process pool's worker)
    # renders the same scene: before the exact route's profile tables were built on a
    # leased pool, they used rayon's global pool, whose threads are the parent's, and the
    # child blocked forever.
    r = run_python("""
        import os
        import numpy as np
        import splitlf
        d = splitlf.Design.preset("seed")
        d = d.replace(channels=tuple(c.replace(Kx=6, Ky=4) for c in d.channels))
        scene = splitlf.Scene("random", 900.0)
        a = splitlf.render(d, scene, seed=1)
        pid = os.fork()
        if pid == 0:
            b = splitlf.render(d, scene, seed=1)
            ok = all(np.array_equal(x, y) for x, y in zip(a.images, b.images))
            os._exit(0 if ok else 3)
        _, status = os.waitpid(pid, 0)
        print("child", os.waitstatus_to_exitcode(status))
    """, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["child", "0"], r.stdout
