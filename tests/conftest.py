"""Shared designs: the seed design, one outside Ng's setting, an f/2 design; and the
hypothesis profiles.

Hypothesis profiles: ``ci`` (derandomized: the same examples on every run, no example
database) is loaded when the environment variable ``CI`` is set, as it is in ``.ci/run``;
``dev`` (random examples, failures replayed from the local database) otherwise.
``HYPOTHESIS_PROFILE=ci bash tests/run.sh`` reproduces a CI run locally.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

from splitlf import Camera

settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.register_profile("dev")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


def seed() -> Camera:
    return Camera.paper()


def non_ng() -> Camera:
    """Arbitrary microlens focal lengths (neither half in Ng's setting)."""
    return Camera.paper().replace(f1=0.58, f2=0.71)


def f2_design() -> Camera:
    """An f/2 main lens, f-number matched on half 1 (v = d v'/D), Ng's setting."""
    cam = Camera.paper()
    return cam.replace(D=40.0, v=cam.d * cam.v1 / 40.0)


DESIGNS = {"seed": seed, "non_ng": non_ng, "f2": f2_design}


@pytest.fixture(params=sorted(DESIGNS))
def design(request) -> Camera:
    return DESIGNS[request.param]()
