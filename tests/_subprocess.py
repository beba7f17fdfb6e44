"""Run a snippet in a fresh interpreter (for fork, memory-limit and signal tests)."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap

#: Generous limit for a child that should finish in seconds: reaching it means a hang.
HANG_TIMEOUT = 120


def run_python(code: str, timeout: float = HANG_TIMEOUT) -> subprocess.CompletedProcess:
    """Run ``code`` (dedented) with this interpreter; stdout/stderr captured as text."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=timeout)


def default_sigint() -> None:
    """``preexec_fn`` of a child that is sent SIGINT: the signal's default action restored,
    so that Python installs its KeyboardInterrupt handler. A test runner started in the
    background by a non-interactive shell (``bash .ci/run &``) ignores SIGINT, its children
    inherit that, and a child that ignores SIGINT would never see the Ctrl-C under test."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
