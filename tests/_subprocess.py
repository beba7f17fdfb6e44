"""Run a snippet in a fresh interpreter (for fork, memory-limit and signal tests)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

#: Generous limit for a child that should finish in seconds: reaching it means a hang.
HANG_TIMEOUT = 120


def run_python(code: str, timeout: float = HANG_TIMEOUT) -> subprocess.CompletedProcess:
    """Run ``code`` (dedented) with this interpreter; stdout/stderr captured as text."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=timeout)
