"""The named designs the tests share (imported by tests/conftest.py and the test files).

- ``seed``: the paper's reconstruction (docs/model.md §7).
- ``non_ng``: the seed with arbitrary microlens focal lengths (neither half in Ng's setting).
- ``f2_design``: an f/2 main lens, f-number matched on half 1 (v = d v'/D), Ng's setting.
- ``vignetted``: D = 14 with the seed's v, so both halves are f-number mismatched: half 1
  lights 11 of 15 pixels, half 2 lights 7 (on a smaller sensor, 60 x 20 microlenses).
- ``off_ng``: another geometry outside Ng's setting: explicit microlens focal lengths,
  even Q, K_y below the largest N of the coincidence tests.
"""

from __future__ import annotations

from splitlf import Camera


def seed() -> Camera:
    return Camera.paper()


def non_ng() -> Camera:
    return Camera.paper().replace(f1=0.58, f2=0.71)


def f2_design() -> Camera:
    cam = Camera.paper()
    return cam.replace(D=40.0, v=cam.d * cam.v1 / 40.0)


def vignetted() -> Camera:
    return Camera.paper().replace(D=14.0, Kx=60, Ky=20)


def off_ng() -> Camera:
    return Camera(F=50.0, D=12.5, v1=60.0, kappa=0.8, d=0.1, v=0.48, mu=0.01, Q=10,
                  Kx=40, Ky=3, f1=0.5, f2=0.45)


#: The designs of the `design` fixture (the closed forms and depth of field).
OPTICS = {"seed": seed, "non_ng": non_ng, "f2": f2_design}
#: The designs of the sample counts: vignetting and a geometry outside Ng's setting.
SAMPLES = {"seed": seed, "vignetted": vignetted, "off_ng": off_ng}
