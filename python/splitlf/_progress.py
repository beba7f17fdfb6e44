"""Progress reports of long computations (renders, reconstructions, depth sweeps, design
sweeps, optimisations), one convention for all.

``progress`` is None, True or False. True draws a tqdm bar on stderr; None draws it only
when stderr is a terminal, and otherwise (a script, a CI log) prints sparse one-line
reports to stderr instead, once the work has lasted :data:`LINE_QUIET` seconds (a short
run stays silent): one per 1/:data:`LINE_STEPS` of the work or per :data:`LINE_EVERY`
seconds, whichever comes first, and a last one at 100 %. False reports nothing. On
success a report always ends at 100 % (the core's callback runs only at its signal
checks, so the last count it sees may be short of the total).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any, Literal

__all__ = ["LINE_EVERY", "LINE_GAP", "LINE_QUIET", "LINE_STEPS", "Progress", "Show",
           "progress_bar", "progress_flag"]

#: How a report is shown: a tqdm bar, sparse lines, or not at all ("").
Show = Literal["bar", "lines", ""]
#: Seconds after which a line is printed even when the work has not advanced a step.
LINE_EVERY = 10.0
#: A line each time the work passes another 1/LINE_STEPS of the total (10 %), though never
#: two within :data:`LINE_GAP` seconds.
LINE_STEPS = 10
#: Least seconds between two lines (but the last one).
LINE_GAP = 1.0
#: Seconds of silence at the start: a run shorter than this prints no line at all.
LINE_QUIET = 10.0


def progress_flag(progress: Any) -> Show:
    """How to report for the ``progress`` argument: None -> a bar when stderr is a terminal,
    else lines; True -> a bar; False -> nothing. ``TypeError`` for anything else."""
    if progress is not None and not isinstance(progress, bool):
        raise TypeError(f"progress must be None, True or False, got {progress!r}")
    if progress is None:
        return "bar" if _isatty() else "lines"
    return "bar" if progress else ""


def _isatty() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stderr
        return False


class Progress:
    """A report of ``total`` units of work: a tqdm bar, or lines on stderr.

    ``update(n)`` adds n units, ``report(done, total)`` sets both (the core's callback),
    ``close()`` ends it: at 100 % unless an exception raised since it started is on its
    way (so a ``finally: close()`` completes a successful run only)."""

    def __init__(self, show: Show, desc: str, unit: str, total: int = 1) -> None:
        self.desc, self.unit = desc, unit
        self.total, self.n = max(int(total), 0), 0
        self._raised_before = sys.exc_info()[1]
        self._bar: Any = None
        if show == "bar":
            try:
                from tqdm.auto import tqdm
            except ImportError:
                show = "lines"
            else:
                self._bar = tqdm(total=self.total, desc=desc, unit=unit)
        self.show = show
        self._start = self._last = time.monotonic()
        self._last_step = self._lines = 0
        self._shown = -1  # the count the last line showed
        self._closed = False

    def report(self, done: int, total: int) -> None:
        """The work done so far of ``total`` (the core's progress callback)."""
        self.total = int(total)
        if self._bar is not None and self._bar.total != total:
            self._bar.total = total
        self._advance(int(done) - self.n)

    def update(self, n: int = 1) -> None:
        """``n`` more units done."""
        self._advance(int(n))

    def _advance(self, n: int) -> None:
        self.n += n
        if self._bar is not None:
            self._bar.update(n)
            return
        now = time.monotonic()
        step = self.n * LINE_STEPS // self.total if self.total > 0 else 0
        if now - self._start < LINE_QUIET:
            return
        if now - self._last >= LINE_EVERY or (step > self._last_step
                                               and now - self._last >= LINE_GAP):
            self._line(now)
            self._last_step = step

    def _line(self, now: float) -> None:
        self._last, self._lines, self._shown = now, self._lines + 1, self.n
        share = 100.0 * self.n / self.total if self.total > 0 else 100.0
        print(f"{self.desc}: {share:3.0f}% ({self.n}/{self.total} {self.unit}s, "
              f"{now - self._start:.0f} s)", file=sys.stderr, flush=True)

    def close(self) -> None:
        """End the report, at 100 % unless an exception is on its way."""
        if self._closed:
            return
        self._closed = True
        raised = sys.exc_info()[1]
        ok = raised is None or raised is self._raised_before
        if ok and self.n < self.total:
            if self._bar is not None:
                self._bar.update(self.total - self.n)
            self.n = self.total
        if self._bar is not None:
            self._bar.close()
        elif ok and self._shown != self.n and (
                self._lines or time.monotonic() - self._start >= LINE_QUIET):
            self._line(time.monotonic())


def progress_bar(show: Show | bool, desc: str = "splitlf render", unit: str = "block",
                 total: int = 1) -> tuple[Progress | None, Callable[[int, int], None] | None]:
    """A report (None when ``show`` is off) and the core's callback ``(done, total)`` for
    it; ``show`` as :func:`progress_flag` returns it (True stands for a bar)."""
    mode: Show = "bar" if show is True else (show or "")
    if not mode:
        return None, None
    bar = Progress(mode, desc, unit, total)
    return bar, bar.report
