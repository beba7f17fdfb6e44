"""One timing helper shared by the benchmark scripts."""

from __future__ import annotations

import gc
import time
from collections.abc import Callable
from typing import Any


def timed_call(fn: Callable[..., Any], *args: Any) -> tuple[float, Any]:
    """Seconds of one call of ``fn(*args)``, after a garbage collection, and its result."""
    gc.collect()
    t0 = time.perf_counter()
    r = fn(*args)
    return time.perf_counter() - t0, r


def timed(fn: Callable[..., Any], *args: Any) -> float:
    """Seconds of one call of ``fn(*args)``, after a garbage collection, its result dropped."""
    return timed_call(fn, *args)[0]
