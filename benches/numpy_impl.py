"""Honest NumPy implementations of the benchmark workloads.

Written the way a competent NumPy user would: fully vectorised over depths (and pixels),
in-place arithmetic where it saves passes, no Python loops over elements.
"""

from __future__ import annotations

import numpy as np


def curves(cam, z: np.ndarray) -> dict[str, np.ndarray]:
    """W1: every closed-form curve of docs/model.md §2 at every depth."""
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
    """Distinct count (neighbours closer than eps merge) and the largest gap overlapping the
    open central field |p'| < half_field, per row of a row-sorted array."""
    dif = np.diff(p, axis=1)
    distinct = 1 + np.count_nonzero(dif > eps, axis=1)
    touches = (p[:, 1:] > -half_field) & (p[:, :-1] < half_field)
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


# -- W2: footprints ------------------------------------------------------------------------

def _half_geometry(cam, half: int):
    """L_i, f_i and the ray-space constants of one half (docs/model.md §4)."""
    L = cam.v1 if half == 1 else cam.v1 * (1.0 + cam.kappa)
    f = cam.f1 if half == 1 else cam.f2
    return L, f, L / cam.v1, 1.0 - L / cam.v1, 1.0 + cam.v / L - cam.v / f


def _clip(V: np.ndarray, k: np.ndarray, n: tuple[np.ndarray, np.ndarray], h: np.ndarray):
    """Sutherland–Hodgman against n·x <= h, vectorised over pixels. V (P, M, 2) holds each
    pixel's first k vertices (counter-clockwise); returns the clipped (P, 2M, 2) and counts."""
    P, M, _ = V.shape
    rows = np.arange(P)
    cand = np.full((P, 2 * M, 2), np.nan)
    keep = np.zeros((P, 2 * M), dtype=bool)
    for i in range(M):
        a = V[:, i]
        b = V[rows, np.where(i + 1 < k, i + 1, 0)]
        da = h - (n[0] * a[:, 0] + n[1] * a[:, 1])
        db = h - (n[0] * b[:, 0] + n[1] * b[:, 1])
        edge = i < k
        cand[:, 2 * i] = a
        keep[:, 2 * i] = edge & (da >= 0.0)
        cross = edge & (((da > 0.0) & (db < 0.0)) | ((da < 0.0) & (db > 0.0)))
        t = da / (da - db)
        cand[:, 2 * i + 1] = a + t[:, None] * (b - a)
        keep[:, 2 * i + 1] = cross
    order = np.argsort(~keep, axis=1, kind="stable")  # kept slots first, in order
    return np.take_along_axis(cand, order[..., None], axis=1), keep.sum(axis=1)


@np.errstate(invalid="ignore", divide="ignore")  # NaN rows are empty polygons
def polygons(cam, half: int, K: int):
    """Integration polygon of every pixel of one half along an axis with K microlenses
    (docs/model.md §4), vectorised over pixels: vertices (P, 6, 2) padded by repeating the last
    vertex (NaN when empty), vertex counts, and centroids (P, 2)."""
    L, _, a, b, alpha = _half_geometry(cam, half)
    idx = np.arange(K * cam.Q)
    c = (idx // cam.Q - (K - 1.0) / 2.0) * cam.d
    theta = cam.mu * (idx % cam.Q - (cam.Q - 1.0) / 2.0)
    h = cam.D / 2.0
    mid = alpha * c + theta
    n = (np.full(c.shape, alpha * a), np.full(c.shape, alpha * b - cam.v / L))
    x_lo, x_hi = c - cam.d / 2.0, c + cam.d / 2.0
    quad = np.stack([np.stack([(x - b * w) / a, np.full(c.shape, w)], axis=1)
                     for x, w in ((x_lo, -h), (x_hi, -h), (x_hi, h), (x_lo, h))], axis=1)
    V, k = _clip(quad, np.full(c.shape, 4), n, mid + cam.mu / 2.0)
    V, k = _clip(V, k, (-n[0], -n[1]), -(mid - cam.mu / 2.0))
    # Drop repeated consecutive vertices and trailing copies of the first one.
    P, M, _ = V.shape
    slot = np.arange(M)[None, :]
    same = np.zeros((P, M), dtype=bool)
    same[:, 1:] = (V[:, 1:] == V[:, :-1]).all(axis=2)
    keep = (slot < k[:, None]) & ~same
    V = np.take_along_axis(V, np.argsort(~keep, axis=1, kind="stable")[..., None], axis=1)
    k = keep.sum(axis=1)
    for _ in range(M):
        last = V[np.arange(P), np.maximum(k - 1, 0)]
        drop = (k > 1) & (last == V[:, 0]).all(axis=1)
        if not drop.any():
            break
        k = k - drop
    assert k.max() <= 6, "more than 6 vertices (only reachable through rounding)"
    V = V[:, :6]
    # Fan sums relative to the first vertex, in the engine's order (area, then centroid).
    o = V[:, 0]
    a2 = np.zeros(P)
    cu = np.zeros(P)
    cw = np.zeros(P)
    for i in range(1, 5):
        valid = i + 1 < k
        u1, w1 = V[:, i, 0] - o[:, 0], V[:, i, 1] - o[:, 1]
        u2, w2 = V[:, i + 1, 0] - o[:, 0], V[:, i + 1, 1] - o[:, 1]
        cross = np.where(valid, u1 * w2 - u2 * w1, 0.0)
        a2 += cross
        cu += np.where(valid, cross * (u1 + u2), 0.0)
        cw += np.where(valid, cross * (w1 + w2), 0.0)
    empty = (k < 3) | ~(a2 > 0.0)
    centroid = np.stack([o[:, 0] + cu / (3.0 * a2), o[:, 1] + cw / (3.0 * a2)], axis=1)
    centroid[empty] = np.nan
    pad = np.minimum(np.arange(6)[None, :], np.maximum(k - 1, 0)[:, None])
    V = np.take_along_axis(V, pad[..., None], axis=1)
    V[empty] = np.nan
    k[empty] = 0
    return V, k, centroid


def footprints(cam, z: np.ndarray, chunk: int = 16) -> dict[str, np.ndarray]:
    """W2: centroid position and extent [lo, hi] (object-space X) of every pixel of both
    halves along x at every depth (docs/model.md §5). The projection p' = u + σ w is vectorised
    over depths × pixels, one vertex at a time (6), with running min/max written in place
    into the outputs; chunks of depths keep the temporary in cache (16 was fastest here,
    ~5x faster than one (depths, pixels, 6) broadcast reduced along its last axis)."""
    m = z.size
    out = {}
    for half in (1, 2):
        V, _, cen = polygons(cam, half, cam.Kx)
        vu = np.ascontiguousarray(V[:, :, 0].T)  # (6, n)
        vw = np.ascontiguousarray(V[:, :, 1].T)
        n = vu.shape[1]
        pos, lo, hi = (np.empty((m, n)) for _ in range(3))
        p = np.empty((chunk, n))
        for s in range(0, m, chunk):
            zs = z[s:s + chunk]
            zc = cam.F * zs / (zs - cam.F)
            sigma = ((cam.v1 - zc) / zc)[:, None]
            scale = (-zs / cam.v1)[:, None]
            mx, mn, pk = lo[s:s + chunk], hi[s:s + chunk], p[:zs.size]
            np.multiply(sigma, vw[0], out=mx)
            mx += vu[0]
            mn[...] = mx
            for k in range(1, 6):
                np.multiply(sigma, vw[k], out=pk)
                pk += vu[k]
                np.maximum(mx, pk, out=mx)
                np.minimum(mn, pk, out=mn)
            mx *= scale  # X = -p' z / v' reverses the order: lo from the largest p'
            mn *= scale
            q = pos[s:s + chunk]
            np.multiply(sigma, cen[:, 1], out=q)
            q += cen[:, 0]
            q *= scale
        out.update({f"position_{half}": pos, f"lo_{half}": lo, f"hi_{half}": hi})
    return out


# -- W4: full-sensor sample grid ---------------------------------------------------------

def _chief_axis(cam, half: int, K: int, z: float) -> np.ndarray:
    """Object-space chief sample X of every pixel along one axis (NaN where unlit)."""
    L = cam.v1 if half == 1 else cam.v1 * (1.0 + cam.kappa)
    zc = cam.F * z / (z - cam.F)
    c = ((np.arange(K) - (K - 1.0) / 2.0) * cam.d)[:, None]
    w = (-(L / cam.v) * (cam.mu * (np.arange(cam.Q) - (cam.Q - 1.0) / 2.0)))[None, :]
    p = (cam.v1 / L) * (c + w * (L - zc) / zc)
    x = -p * z / cam.v1
    x[:, ~(np.abs(w[0]) < cam.D / 2.0)] = np.nan
    return x.ravel()


def sample_grid(cam, z: float) -> dict[str, np.ndarray]:
    """W4: chief sample positions (X, Y) of every pixel of both halves: the separable outer
    construction, one broadcast per output (NaN where either axis yields no sample)."""
    out = {}
    for half in (1, 2):
        xs = _chief_axis(cam, half, cam.Kx, z)
        ys = _chief_axis(cam, half, cam.Ky, z)
        out[f"X_{half}"] = xs[None, :] + 0.0 * ys[:, None]
        out[f"Y_{half}"] = ys[:, None] + 0.0 * xs[None, :]
    return out
