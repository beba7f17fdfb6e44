"""The `design` fixture (the designs of tests/designs.py's OPTICS) and the hypothesis
profiles.

Hypothesis profiles: ``ci`` (derandomized: the same examples on every run, no example
database) is loaded when the environment variable ``CI`` is set, as it is in ``.ci/run``;
``dev`` (random examples, failures replayed from the local database) otherwise.
``HYPOTHESIS_PROFILE=ci bash tests/run.sh`` reproduces a CI run locally.
"""

from __future__ import annotations

import math
import os

import pytest
from hypothesis import settings

import splitlf._progress
from designs import OPTICS
from splitlf import Camera

settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.register_profile("dev")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


@pytest.fixture(params=sorted(OPTICS))
def design(request) -> Camera:
    return OPTICS[request.param]()


@pytest.fixture(autouse=True)
def _no_progress_lines(monkeypatch):
    """Progress lines (splitlf._progress, when stderr is no terminal) begin once a run has
    lasted LINE_QUIET seconds: never in tests, so that a run slowed by a loaded machine
    does not change the output a test checks (the tests of the lines set it themselves)."""
    monkeypatch.setattr(splitlf._progress, "LINE_QUIET", math.inf)
