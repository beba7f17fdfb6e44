"""splitlf._progress: one progress convention for renders, reconstructions, depth and
design sweeps and optimisations. On a terminal a tqdm bar; elsewhere (a script, CI) sparse
lines on stderr once a run has lasted a while; on success always 100 % at the end."""

from __future__ import annotations

import pytest
from _subprocess import run_python

import splitlf._progress as pg
from splitlf import Design, Scene, render


class Clock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def clock(monkeypatch):
    c = Clock()
    monkeypatch.setattr(pg.time, "monotonic", c)
    monkeypatch.setattr(pg, "LINE_QUIET", 10.0)
    return c


def lines(capsys) -> list[str]:
    return capsys.readouterr().err.splitlines()


def test_progress_none_off_a_terminal_means_lines(monkeypatch):
    monkeypatch.setattr(pg, "_isatty", lambda: False)
    assert pg.progress_flag(None) == "lines"
    monkeypatch.setattr(pg, "_isatty", lambda: True)
    assert pg.progress_flag(None) == "bar"
    assert pg.progress_flag(True) == "bar" and pg.progress_flag(False) == ""
    with pytest.raises(TypeError, match="progress must be None, True or False"):
        pg.progress_flag(1)
    assert pg.progress_bar("") == (None, None)


def test_a_short_run_prints_no_line(clock, capsys):
    bar = pg.Progress("lines", "splitlf job", "step", total=4)
    for _ in range(4):
        clock.t += 2.0  # 8 s in all: under LINE_QUIET
        bar.update()
    bar.close()
    assert lines(capsys) == []


def test_lines_are_sparse_and_end_at_100_percent(clock, capsys):
    bar = pg.Progress("lines", "splitlf job", "step", total=800)
    for _ in range(800):  # 800 steps of 1/8 s: 100 s in all
        clock.t += 0.125
        bar.report(bar.n + 1, 800)
    bar.close()
    out = lines(capsys)
    # one line at the end of the quiet 10 s, then one per 10 % step (each 10 s here), and
    # the last at 100 %: never two within LINE_GAP, never more than one per step or 10 s
    assert out[0] == "splitlf job:  10% (80/800 steps, 10 s)"
    assert out[-1] == "splitlf job: 100% (800/800 steps, 100 s)"
    assert [int(s.split("(")[1].split("/")[0]) for s in out] == list(range(80, 801, 80))


def test_a_slow_step_still_gets_a_line_every_10_s(clock, capsys):
    bar = pg.Progress("lines", "splitlf job", "block", total=10)
    clock.t += 35.0
    bar.report(0, 10)  # no step done yet, but 35 s in: a sign of life
    clock.t += 5.0
    bar.report(0, 10)  # only 5 s later: nothing
    clock.t += 6.0
    bar.report(0, 10)
    bar.close()
    assert lines(capsys) == ["splitlf job:   0% (0/10 blocks, 35 s)",
                             "splitlf job:   0% (0/10 blocks, 46 s)",
                             "splitlf job: 100% (10/10 blocks, 46 s)"]


def test_a_failed_run_does_not_claim_100_percent(clock, capsys):
    bar = pg.Progress("lines", "splitlf job", "step", total=10)
    clock.t += 20.0
    bar.report(3, 10)
    with pytest.raises(RuntimeError):
        try:
            raise RuntimeError("boom")
        finally:
            bar.close()
    assert bar.n == 3
    assert lines(capsys) == ["splitlf job:  30% (3/10 steps, 20 s)"]


def test_a_bar_ends_at_100_percent_on_success(capsys):
    pytest.importorskip("tqdm")
    bar, callback = pg.progress_bar("bar", "splitlf job", "block")
    assert bar is not None and callback is not None
    callback(7, 10)  # the core's last report before it finished: short of the total
    bar.close()
    assert bar.n == 10 and bar._bar.n == 10 and bar._bar.total == 10
    assert "100%" in capsys.readouterr().err
    failed, callback = pg.progress_bar("bar", "splitlf job", "block")
    assert failed is not None and callback is not None
    callback(7, 10)
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt:
        pass
    with pytest.raises(ValueError):
        try:
            raise ValueError
        finally:
            failed.close()
    assert failed._bar.n == 7


def test_a_render_bar_reaches_100_percent(capsys):
    pytest.importorskip("tqdm")
    d = Design.preset("seed")
    d = d.replace(channels=tuple(c.replace(Kx=8, Ky=6) for c in d.channels))
    render(d, Scene("random", 1000.0), progress=True)
    err = capsys.readouterr().err
    assert "splitlf render" in err and "100%" in err


def test_a_script_without_a_terminal_gets_lines():
    """A sweep run by a script (stderr a pipe, not a terminal) with progress=None: lines
    on stderr, the last at 100 % (LINE_QUIET set to 0 in the child, so that the short run
    counts as a long one)."""
    r = run_python("""
        import numpy as np
        import splitlf, splitlf._progress as pg
        pg.LINE_QUIET = 0.0
        assert pg.progress_flag(None) == "lines"
        splitlf.sweep.sweep(splitlf.Design.preset("seed"), {"D": [15.0, 20.0, 25.0]},
                      np.geomspace(150.0, 10_000.0, 5))
    """)
    assert r.returncode == 0, r.stderr
    out = r.stderr.splitlines()
    assert out and out[-1].startswith("splitlf sweep: 100% (3/3 designs, ")
    assert all(s.startswith("splitlf sweep: ") for s in out)
