"""Shared designs: the seed design, one outside Ng's setting, an f/2 design."""

from __future__ import annotations

import pytest

from splitlf import Camera


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
