"""Honest NumPy implementations of the benchmark workloads.

Written the way a competent NumPy user would: fully vectorised over depths (and pixels),
in-place arithmetic where it saves passes, no Python loops over elements.
"""

from __future__ import annotations

import numpy as np


def curves(cam, z: np.ndarray) -> dict[str, np.ndarray]:
    """W1: every closed-form curve of MODEL.md §2 at every depth."""
    F, D, d, v, mu = cam.F, cam.D, cam.d, cam.v, cam.mu
    n = z.size
    zc = F * z / (z - F)
    inv_zc = 1.0 / zc
    out = {k: np.empty((2, n)) for k in
           ("main_blur", "repetitions", "microlens_blur", "blur_px", "conventional_px")}
    for i, (L, f) in enumerate(((cam.v1, cam.f1), (cam.v1 * (1.0 + cam.kappa), cam.f2))):
        H = out["main_blur"][i]
        np.subtract(inv_zc, 1.0 / L, out=H)
        np.abs(H, out=H)
        H *= D * L / 2.0
        r = out["repetitions"][i]
        np.multiply(H, 2.0, out=r)
        r /= d
        np.divide(H, mu, out=out["conventional_px"][i])
        b = out["microlens_blur"][i]
        np.subtract(L, zc, out=b)
        with np.errstate(divide="ignore"):
            np.divide(1.0, b, out=b)
        np.subtract(1.0 / f, b, out=b)
        b -= 1.0 / v
        np.abs(b, out=b)
        b *= d * v / 2.0
        p = out["blur_px"][i]
        np.minimum(b, D * v / (2.0 * L), out=p)
        p /= mu
    out["conjugate"] = zc
    return out
