"""Plain NumPy transcriptions of docs/model.md, written independently of the package.

Only the camera's fields are read from the package; every derived quantity is computed
here from docs/model.md's formulas.
"""

from __future__ import annotations

import numpy as np


def array_planes(cam) -> tuple[float, float]:
    """L_1 = v', L_2 = v'(1 + kappa) (docs/model.md §1)."""
    return cam.v1, cam.v1 * (1.0 + cam.kappa)


def ng_focal(L: float, v: float) -> float:
    """Ng's setting: 1/f = 1/L + 1/v."""
    return 1.0 / (1.0 / L + 1.0 / v)


def curves(cam, z) -> dict[str, np.ndarray]:
    """docs/model.md §2: Eq. 1, H_i, rep_i, b_i, bounded LF blur, conventional blur."""
    z = np.asarray(z, dtype=np.float64)
    F, D, d, v, mu = cam.F, cam.D, cam.d, cam.v, cam.mu
    zc = F * z / (z - F)
    out = {k: np.empty((2, z.size)) for k in
           ("main_blur", "repetitions", "microlens_blur", "blur_px", "conventional_px")}
    with np.errstate(divide="ignore"):
        for i, (L, f) in enumerate(zip(array_planes(cam), (cam.f1, cam.f2), strict=True)):
            H = (D * L / 2.0) * np.abs(1.0 / zc - 1.0 / L)
            b = (d * v / 2.0) * np.abs(1.0 / f - 1.0 / (L - zc) - 1.0 / v)
            R = D * v / (2.0 * L)
            out["main_blur"][i] = H
            out["repetitions"][i] = 2.0 * H / d
            out["microlens_blur"][i] = b
            out["blur_px"][i] = np.minimum(b, R) / mu
            out["conventional_px"][i] = H / mu
    out["conjugate"] = zc
    return out


def out_of_focus_depth(cam, half: int) -> float:
    L = array_planes(cam)[half - 1]
    return cam.F * L / (L - cam.F)


def lit_pixels(cam, half: int) -> int:
    """docs/model.md §6: pixel q is lit when |w_q| = (L_i/v) mu |q - (Q-1)/2| < D/2."""
    L = array_planes(cam)[half - 1]
    q = np.arange(cam.Q)
    w = -(L / cam.v) * cam.mu * (q - (cam.Q - 1) / 2.0)
    return int(np.count_nonzero(np.abs(w) < cam.D / 2.0))
