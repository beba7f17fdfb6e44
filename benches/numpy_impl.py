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


def _chief_p(cam, L: float, K: int, zc: np.ndarray) -> np.ndarray:
    """Chief samples p' of every lit pixel along one axis, for each conjugate: (m, K*Q_lit)."""
    c = (np.arange(K) - (K - 1) / 2.0) * cam.d
    w = -(L / cam.v) * cam.mu * (np.arange(cam.Q) - (cam.Q - 1) / 2.0)
    w = w[np.abs(w) < cam.D / 2.0]
    g = (L - zc) / zc
    p = (cam.v1 / L) * (c[None, :, None] + w[None, None, :] * g[:, None, None])
    return p.reshape(zc.size, -1)


def _count_and_gap(p: np.ndarray, eps: float, half_field: float, scale: float):
    """Distinct count (neighbours closer than eps merge) and the largest gap touching the
    central field |p'| <= half_field, per row of a row-sorted array."""
    dif = np.diff(p, axis=1)
    distinct = 1 + np.count_nonzero(dif > eps, axis=1)
    touches = (p[:, 1:] >= -half_field) & (p[:, :-1] <= half_field)
    gap = np.max(np.where(touches, dif, 0.0), axis=1) * scale
    open_edge = (p[:, 0] > -half_field) | (p[:, -1] < half_field)
    gap[open_edge] = np.inf
    return distinct, gap


def new_samples(cam, z: np.ndarray, tol: float, chunk: int = 256) -> dict[str, np.ndarray]:
    """W3: distinct chief samples along x of half 1, half 2 and their union, and the max gap
    in units of delta(z), at every depth. Vectorised over chunks of depths (bounded memory)."""
    m = z.size
    distinct = np.empty((3, m), dtype=np.int64)
    gap = np.empty((3, m))
    eps = tol * cam.d / cam.Q          # tol * delta(z), in p' units on plane v'
    half_field = cam.Kx * cam.d / 4.0  # |X| <= K d z / (4 v')  <=>  |p'| <= K d / 4
    scale = cam.Q / cam.d              # p' gap -> units of delta(z)
    planes = (cam.v1, cam.v1 * (1.0 + cam.kappa))
    for s in range(0, m, chunk):
        zc = cam.F * z[s:s + chunk] / (z[s:s + chunk] - cam.F)
        p1 = np.sort(_chief_p(cam, planes[0], cam.Kx, zc), axis=1)
        p2 = np.sort(_chief_p(cam, planes[1], cam.Kx, zc), axis=1)
        pu = np.sort(np.concatenate([p1, p2], axis=1), axis=1)
        for row, p in enumerate((p1, p2, pu)):
            distinct[row, s:s + chunk], gap[row, s:s + chunk] = _count_and_gap(
                p, eps, half_field, scale)
    return {"distinct": distinct, "max_gap": gap}
