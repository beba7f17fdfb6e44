"""Honest NumPy implementations of the benchmark workloads (the raw images' twins are in
benches/numpy_render.py).

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


# -- W5: coverage (NumPy + SciPy) ------------------------------------------------------------

SQRT3_2 = 0.8660254037844386  # sqrt(3)/2, the core's constant


def _lens_centres(ch, j: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lens centres (x, y) on the array plane (docs/model.md §9, Lattices), by the core's
    expressions (so that ties of the nearest-lens rule resolve identically)."""
    if ch.grid == "rect":
        return (ch.d * (j - (ch.Kx - 1.0) / 2.0), ch.d * (k - (ch.Ky - 1.0) / 2.0))
    mx = (ch.Kx - 1.0) / 2.0 + (ch.Ky // 2) / ch.Ky / 2.0
    my = SQRT3_2 * (ch.Ky - 1.0) / 2.0
    return (ch.d * ((j + (k % 2) / 2.0) - mx), ch.d * (k * SQRT3_2 - my))


def sensor_pixels(design, ch, Mx: int, My: int) -> dict[str, np.ndarray]:
    """Every pixel of a sensor-layout channel (docs/model.md §9, Pixel layouts and Chief
    samples in 2-D): its lens (j, k) (the nearest lens image centre among the candidates of
    the core's rule: the nearest lens column of each row parity in the nearest rows; ties to
    the lower j, then k), that lens's centre c on the array plane, the chief-ray height
    w = -(L/v) theta and the lit flag, vectorised over the whole (My, Mx) grid, one
    candidate lens at a time. Depth-independent."""
    if ch.layout != "sensor":
        raise NotImplementedError("the reference handles sensor-layout channels")
    m = 1.0 + ch.v / ch.L
    p = ch.d * m
    sx = ch.mu * (np.arange(Mx) - (Mx - 1.0) / 2.0)
    sy = ch.mu * (np.arange(My) - (My - 1.0) / 2.0)
    last_j, last_k = ch.Kx - 1.0, ch.Ky - 1.0
    hexgrid = ch.grid == "hex"
    if hexgrid:
        mx = (ch.Kx - 1.0) / 2.0 + (ch.Ky // 2) / ch.Ky / 2.0
        my = SQRT3_2 * (ch.Ky - 1.0) / 2.0
        k0 = np.clip(np.floor(sy / (p * SQRT3_2) + my / SQRT3_2), 0.0, last_k)
        rows = [np.clip(k0 + dk, 0.0, last_k) for dk in (-1, 0, 1, 2)]
    else:
        t = sy / p + (ch.Ky - 1.0) / 2.0
        rows = [np.clip(np.floor(t), 0.0, last_k), np.clip(np.ceil(t), 0.0, last_k)]

    def columns(par: int):
        t = sx / p + (mx - par / 2.0 if hexgrid else (ch.Kx - 1.0) / 2.0)
        return [np.clip(np.floor(t), 0.0, last_j), np.clip(np.ceil(t), 0.0, last_j)]

    cols = [columns(0), columns(1)] if hexgrid else [columns(0)]
    shape = (My, Mx)
    bd = np.full(shape, np.inf)
    bj = np.zeros(shape)
    bk = np.zeros(shape)
    for k in rows:  # (My,) candidate row of every sensor row
        dyy = (sy - _lens_centres(ch, np.zeros(1), k)[1] * m) ** 2
        par = (k % 2).astype(int) if hexgrid else np.zeros(My, dtype=int)
        for pv in np.unique(par):
            rsel = par == pv
            b_d, b_j, b_k = bd[rsel], bj[rsel], bk[rsel]
            kk = k[rsel, None]
            for j in cols[pv]:  # floor, then ceil
                cxj = _lens_centres(ch, j, np.full(Mx, float(pv)))[0]
                dd = (sx - cxj * m) ** 2 + dyy[rsel, None]
                better = (dd < b_d) | ((dd == b_d) & ((j < b_j) | ((j == b_j) & (kk < b_k))))
                np.copyto(b_d, dd, where=better)
                np.copyto(b_j, np.broadcast_to(j, shape)[rsel], where=better)
                np.copyto(b_k, np.broadcast_to(kk, b_k.shape), where=better)
            bd[rsel], bj[rsel], bk[rsel] = b_d, b_j, b_k
    del bd
    cx, cy = _lens_centres(ch, bj, bk)
    tx = sx[None, :] - cx * m
    ty = sy[:, None] - cy * m
    ax, ay = np.abs(tx), np.abs(ty)
    half = p / 2.0
    if hexgrid:
        lit = (ax <= half) & (ax / 2.0 + ay * SQRT3_2 <= half)
    else:
        lit = (ax <= half) & (ay <= half)
    del ax, ay
    lv = -(ch.L / ch.v)
    tx *= lv  # w = -(L/v) theta
    ty *= lv
    r = design.D / 2.0
    if design.aperture == "circle":
        lit &= tx * tx + ty * ty < r * r
    else:
        lit &= (np.abs(tx) < r) & (np.abs(ty) < r)
    return {"j": bj, "k": bk, "cx": cx, "cy": cy, "wx": tx, "wy": ty, "lit": lit}


def lit_pixels(design, ch, Mx: int, My: int) -> tuple[np.ndarray, ...]:
    """Lens centre (cx, cy) and chief-ray height (wx, wy) of every lit pixel."""
    px = sensor_pixels(design, ch, Mx, My)
    lit = px["lit"]
    return px["cx"][lit], px["cy"][lit], px["wx"][lit], px["wy"][lit]


def chief_samples(design, channel: int, z: float) -> dict[str, np.ndarray]:
    """W6: every pixel's chief sample X, Y (NaN where unlit), lit flag, lens (j, k) and lens
    type of one sensor-layout channel at depth z, the arrays of `splitlf.chief_samples`."""
    ch = design.channels[channel - 1]
    res = design.resolved()[channel - 1]
    px = sensor_pixels(design, ch, res["Mx"], res["My"])
    zc = design.F * z / (z - design.F)
    g, s = z / ch.L, (ch.L - zc) / zc
    lit = px["lit"]
    out = {}
    for name, c, w in (("X", "cx", "wx"), ("Y", "cy", "wy")):
        a = px[w]  # reused in place: X = -g (c + w s)
        a *= s
        a += px[c]
        a *= -g
        a[~lit] = np.nan
        out[name] = a
    j, k = px["j"].astype(np.int64), px["k"].astype(np.int64)
    del px
    T = len(ch.f) if ch.f is not None else 1
    out["type"] = ((j - k // 2 - k) if ch.grid == "hex" else (j + k)) % T
    out["lens"] = np.stack([j, k], axis=-1)
    out["lit"] = lit
    return out


def _field(design, z: float, window: float) -> tuple[float, float]:
    """Half-widths of the 2-D central field (docs/model.md §9, Scale and field)."""
    ch = design.channels[0]
    if ch.grid == "hex":
        w = ch.Kx + 0.5 if ch.Ky >= 2 else float(ch.Kx)
        ex, ey = w * ch.d, ((ch.Ky - 1.0) * SQRT3_2 + 1.0 / SQRT3_2) * ch.d
    else:
        ex, ey = ch.Kx * ch.d, ch.Ky * ch.d
    g = z / ch.L
    hw = window / 2.0 * ch.d
    return min(hw, ex / 4.0) * g, min(hw, ey / 4.0) * g


def covering_radius_qhull(P: np.ndarray, hx: float, hy: float) -> float:
    """Covering radius of the box |x| <= hx, |y| <= hy by the points P (n, 2): the largest
    nearest-point distance over the candidates (Voronoi vertices in the box, crossings of
    Voronoi edges with its sides, its corners), by scipy.spatial.Voronoi (qhull) and a
    cKDTree. Candidates are points of the box evaluated exactly, so extra ones (a hull
    ridge's whole bisector line instead of its ray) cannot change the result."""
    from scipy.spatial import Voronoi, cKDTree

    if len(P) == 0:
        return float("inf")
    corners = np.array([[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]])
    cands = [corners]
    tree = cKDTree(P)
    if len(P) >= 3:
        vor = Voronoi(P)
        V = vor.vertices

        def near(c, h):  # inside, or within rounding of the side (then clamped in)
            return np.abs(c) <= h + 1e-12 * (h + np.abs(c))

        inside = near(V[:, 0], hx) & near(V[:, 1], hy)
        cands.append(np.clip(V[inside], [-hx, -hy], [hx, hy]))
        rv = np.asarray(vor.ridge_vertices)
        rp = vor.ridge_points
        finite = (rv >= 0).all(axis=1)
        a, b = V[rv[finite, 0]], V[rv[finite, 1]]
        # Hull ridges: the bisector line of the two points (the ray is part of it).
        pa, pb = P[rp[~finite, 0]], P[rp[~finite, 1]]
        mid = (pa + pb) / 2.0
        nrm = np.stack([-(pb[:, 1] - pa[:, 1]), pb[:, 0] - pa[:, 0]], axis=1)
        for axis, h in ((0, hx), (1, hy)):
            other, ho = 1 - axis, (hy if axis == 0 else hx)
            for side in (-h, h):
                da, db = a[:, axis] - side, b[:, axis] - side
                cross = (np.minimum(da, db) <= 0.0) & (np.maximum(da, db) >= 0.0) & (da != db)
                t = da[cross] / (da[cross] - db[cross])
                v = a[cross, other] + t * (b[cross, other] - a[cross, other])
                ok = nrm[:, axis] != 0.0
                tl = (side - mid[ok, axis]) / nrm[ok, axis]
                v = np.concatenate([v, mid[ok, other] + tl * nrm[ok, other]])
                v = v[near(v, ho)]
                c = np.empty((v.size, 2))
                c[:, axis] = side
                c[:, other] = np.clip(v, -ho, ho)
                cands.append(c)
    dist, _ = tree.query(np.concatenate(cands))
    return float(dist.max())


def coverage(design, z: np.ndarray, tol: float, window: float) -> dict[str, np.ndarray]:
    """W5: distinct 2-D samples in the central field and its covering radius, for every
    channel and the union, at every depth (docs/model.md §9), with NumPy and SciPy.

    Per call: every pixel's lens and chief-ray height (`lit_pixels`, depth-independent).
    Per depth: the chief samples of every lit pixel (vectorised), kept within a Chebyshev
    margin m of the field; distinct samples by the same relation (cKDTree.query_pairs with
    the Chebyshev metric, the strict test, scipy.sparse.csgraph.connected_components,
    representative = least X then least Y); the covering radius by qhull's Voronoi diagram.
    The margin is exact when rho < m2 (m2: m, or less when a component reaching the margin's
    edge has its representative nearer the field; docs/model.md §9 implementation), else it
    doubles. A design with one channel has its union row equal to that channel's."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    F = design.F
    res = design.resolved()
    chans = [(ch, lit_pixels(design, ch, r["Mx"], r["My"]))
             for ch, r in zip(design.channels, res, strict=True)]
    n_ch = len(chans)
    rows = n_ch + 1
    distinct = np.zeros((rows, z.size), dtype=np.int64)
    rho = np.zeros((rows, z.size))
    ch1 = design.channels[0]
    for iz, zi in enumerate(z):
        zi = float(zi)
        zc = F * zi / (zi - F)
        delta = ch1.mu * zi / ch1.L
        eps = tol * delta
        hx, hy = _field(design, zi, window)
        m = 2.0 * max(ch.d * zi / ch.L for ch, _ in chans)
        while True:
            sets = []
            for ch, (cx, cy, wx, wy) in chans:
                g, s = zi / ch.L, (ch.L - zc) / zc
                X = wx * s
                X += cx
                X *= -g
                keep = np.abs(X) <= hx + m
                Y = wy[keep] * s
                Y += cy[keep]
                Y *= -g
                keep2 = np.abs(Y) <= hy + m
                sets.append(np.stack([X[keep][keep2], Y[keep2]], axis=1))
            if n_ch > 1:
                sets.append(np.concatenate(sets))
            exact = True
            out = []
            for pts in sets:
                n = len(pts)
                pairs = cKDTree(pts).query_pairs(eps, p=np.inf, output_type="ndarray")
                d = np.abs(pts[pairs[:, 0]] - pts[pairs[:, 1]])
                pairs = pairs[(d[:, 0] < eps) & (d[:, 1] < eps)]
                graph = coo_matrix((np.ones(len(pairs), dtype=np.int8),
                                    (pairs[:, 0], pairs[:, 1])), shape=(n, n))
                nc, lab = connected_components(graph, directed=False)
                order = np.lexsort((pts[:, 1], pts[:, 0], lab))
                first = np.ones(n, dtype=bool)
                first[1:] = lab[order[1:]] != lab[order[:-1]]
                reps = pts[order[first]]  # one per component, in label order
                excess = np.maximum(np.abs(pts[:, 0]) - hx, np.abs(pts[:, 1]) - hy)
                touch = np.zeros(nc, dtype=bool)
                touch[lab[excess > m - 3.0 * eps]] = True
                rex = np.maximum(np.abs(reps[:, 0]) - hx, np.abs(reps[:, 1]) - hy)
                m2 = min(m, rex[touch].min(initial=np.inf))
                nd = int(np.count_nonzero(rex <= 0.0))
                # qhull on the representatives within 4 mean spacings of the field first;
                # all of them only if rho reaches that far (rarely).
                m1 = 4.0 * np.sqrt(4.0 * hx * hy / max(nd, 1)) if nd else np.inf
                inner = rex <= m1
                r = covering_radius_qhull(reps[inner] / delta, hx / delta, hy / delta)
                if not inner.all() and not r * delta * (1.0 + 1e-9) < m1:
                    r = covering_radius_qhull(reps / delta, hx / delta, hy / delta)
                exact &= r * delta * (1.0 + 1e-9) < m2
                out.append((nd, r))
            if exact:
                break
            m *= 2.0
        if n_ch == 1:
            out.append(out[0])
        for row, (nd, r) in enumerate(out):
            distinct[row, iz], rho[row, iz] = nd, r
    return {"distinct": distinct, "covering_radius": rho,
            "covering_radius_mm": rho * (ch1.mu * z / ch1.L)}
