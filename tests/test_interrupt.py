"""Ctrl-C interrupts long core calls (the core checks for signals between chunks)."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import pytest
from _subprocess import HANG_TIMEOUT

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="POSIX signals")

# Each call runs for minutes when not interrupted (far beyond the hang timeout), with
# little memory.
LONG_CALLS = {
    "new_samples": "splitlf.new_samples(P.replace(Kx=10**5), np.geomspace(150, 1e4, 50_000))",
    "figures_of_merit": "splitlf.sweep.evaluate_design(P.replace(Kx=10**5), "
                        "np.geomspace(150, 1e4, 50_000))",
    "new_samples_centroid": "splitlf.new_samples(P.replace(Kx=10**5), "
                            "np.geomspace(150, 1e4, 50_000), sample='centroid', n_threads=1)",
}


@pytest.mark.parametrize("call", sorted(LONG_CALLS))
def test_sigint_raises_keyboard_interrupt(call):
    code = textwrap.dedent(f"""
        import numpy as np
        import splitlf, splitlf.sweep
        P = splitlf.Camera.paper()
        print("ready", flush=True)
        try:
            {LONG_CALLS[call]}
            print("finished")
        except KeyboardInterrupt:
            print("interrupted")
    """)
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # let the call start (an earlier signal interrupts it too)
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=HANG_TIMEOUT)
    finally:
        child.kill()
        child.wait()
    assert out.split() == ["interrupted"], (out, err)


@pytest.mark.parametrize("delay", [0.001, 0.003, 0.01])
def test_daemon_thread_inside_the_core_at_exit(delay):
    """A daemon thread still inside a long core call when the interpreter shuts down: the
    core's between-chunk check cannot attach to a finalizing interpreter and stops the call
    instead of panicking (PyO3's "interpreter is not initialized" assertion, a segfault in
    the wheel smoke test of the explorer before the fix). The delay lets the first check
    fall inside the finalization (the imports make it long enough)."""
    code = textwrap.dedent(f"""
        import threading, time
        import numpy as np
        import pandas, scipy.sparse, matplotlib.pyplot  # a longer finalization
        import splitlf
        d = splitlf.Design.preset("seed")
        go = threading.Event()
        def work():
            go.wait()
            splitlf.coverage(d, np.geomspace(300, 10000, 2000), window=2.0, n_threads=1)
        threading.Thread(target=work, daemon=True).start()
        go.set()
        time.sleep({delay})
        print("exiting", flush=True)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=HANG_TIMEOUT)
    assert r.returncode == 0 and r.stdout.split() == ["exiting"], (r.returncode, r.stderr)
    assert "panicked" not in r.stderr, r.stderr
