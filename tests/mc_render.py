"""An independent Monte-Carlo renderer of docs/model.md §10 (raw images), plain NumPy.

Nothing here calls the package's physics: a design's fields are read (``design.F``,
``design.D``, ``design.aperture``, ``design.resolved()``), and the §9 lattice, lens-type and
pixel-layout conventions come from tests/reference.py (plain NumPy transcriptions of §9).
Everything else is §10 transcribed: rays, which pixel collects a ray, the scene, the
pixel value.

Scenes are plain tuples mirroring the native seam (COMMON.md, ``_native.RenderScene``)::

    scene = {"texture": (kind, params, image_or_None),
             "surface": (kind, params, depth_map_or_None),
             "background": albedo}

texture kinds ``constant`` [albedo], ``image`` [X0, X1, Y0, Y1] (+ array, row 0 at the top),
``sinusoid`` [frequency, mean, amplitude, phase], ``bars`` [frequency, low, high], ``edge``
[angle (deg), low, high, X0, Y0], ``star`` [spokes, low, high, X0, Y0]; surface kinds
``plane`` [z0, gx, gy] and ``depthmap`` [X0, X1, Y0, Y1] (+ array of depths at the cell
centres, row 0 at the top).

The estimator (unbiased for every alpha = 1 + v/L - v/f, 0 included). A pixel's value is

    share / (mu_1^2 A) * sum over lenses c of  int_{x in cell(c)} int_{w} 1[s(x, w) in pixel]
                                                 1_aperture(w) T(P_hit(x, w)) dw dx (L_1/L)^2

(du dw = (L_1/L)^2 dx dw, x on the channel's array plane). For fixed x the sensor point
s = alpha x - (v/L) w + (v/f) c lies in the pixel square (side mu, centre s_pix) exactly
when w lies in the square of side mu L / v centred at w0(x) = (alpha x + (v/f) c - s_pix) L/v.
So: sample x uniformly in a box B holding every point of the cell whose w-square can meet
the aperture's bounding square (the indicator of the cell is kept in the weight), then w
uniformly in its square; the weight is |B| (mu L / v)^2 (L_1/L)^2 1_cell(x) 1_aperture(w)
T(P_hit). The ``ideal`` layout sums over the pixel's own lens only; the ``sensor`` layout
over every lens whose light can reach the pixel (image centre c (1 + v/L) within
|alpha| r_cell + (v/L) D/2 + mu/2 of the pixel centre per axis, the exact reach).

Radiometric falloff (docs/model.md §10, ``falloff=`` "microlens", "main" or "both"): each
ray's weight is multiplied by cos^4 of its microlens-to-sensor segment, (v^2 / (v^2 +
|s - x|^2))^2, and/or of its main-lens-to-array segment, (L^2 / (L^2 + |x - w|^2))^2,
with s, x, w the ray's own points (:func:`falloff_weight`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from reference import lens_centres, lens_types

SQRT3_2 = math.sqrt(3.0) / 2.0

Scene = dict[str, Any]


def scene(texture: tuple, surface: tuple, background: float) -> Scene:
    """A scene as plain data: ``texture`` = (kind, params[, image]), ``surface`` =
    (kind, params[, depth_map]), ``background`` the albedo of rays that meet no surface."""
    tex = tuple(texture) + (None,) * (3 - len(texture))
    surf = tuple(surface) + (None,) * (3 - len(surface))
    return {"texture": (tex[0], [float(p) for p in tex[1]],
                        None if tex[2] is None else np.asarray(tex[2], dtype=np.float64)),
            "surface": (surf[0], [float(p) for p in surf[1]],
                        None if surf[2] is None else np.asarray(surf[2], dtype=np.float64)),
            "background": float(background)}


# -- textures (§10 "Textures"; the seam's definitions) ---------------------------------------


def albedo(texture: tuple, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The texture's albedo at object-space points (X, Y) [mm], X right, Y up."""
    kind, p, image = texture
    if kind == "constant":
        return np.full(X.shape, p[0])
    if kind == "image":
        X0, X1, Y0, Y1 = p
        rows, cols = image.shape
        col = np.floor((X - X0) / ((X1 - X0) / cols))
        row = np.floor((Y1 - Y) / ((Y1 - Y0) / rows))  # row 0 at the top (Y1)
        inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
        out = np.full(X.shape, image.mean())
        out[inside] = image[row[inside].astype(np.int64), col[inside].astype(np.int64)]
        return out
    if kind == "sinusoid":
        f, mean, amp, phase = p
        return mean + amp * np.sin(2.0 * np.pi * f * X + phase)
    if kind == "bars":
        f, low, high = p
        s = f * X
        return np.where(s - np.floor(s) < 0.5, high, low)
    if kind == "edge":
        angle, low, high, X0, Y0 = p
        a = math.radians(angle)
        return np.where((X - X0) * math.cos(a) - (Y - Y0) * math.sin(a) >= 0.0, high, low)
    if kind == "star":
        spokes, low, high, X0, Y0 = p
        t = np.mod(np.arctan2(Y - Y0, X - X0), 2.0 * np.pi)
        return np.where(np.floor(t * spokes / np.pi) % 2 == 0, high, low)
    raise ValueError(f"unknown texture kind {kind!r}")


# -- surfaces (§10 "Scene") ------------------------------------------------------------------


def depth_at(params: Sequence[float], depth: np.ndarray, X: np.ndarray,
             Y: np.ndarray) -> np.ndarray:
    """A depth map's depth at (X, Y) inside its extent: bilinear between the cell centres,
    constant beyond the outer centres (the seam's ``depthmap``)."""
    X0, X1, Y0, Y1 = params
    rows, cols = depth.shape

    def index(t: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.clip(t, 0.0, n - 1.0)
        i = np.minimum(np.floor(t), max(n - 2, 0)).astype(np.int64)
        return i, np.minimum(i + 1, n - 1), t - i

    c0, c1, tx = index((X - X0) / ((X1 - X0) / cols) - 0.5, cols)
    r0, r1, ty = index((Y1 - Y) / ((Y1 - Y0) / rows) - 0.5, rows)
    top = depth[r0, c0] * (1.0 - tx) + depth[r0, c1] * tx
    bottom = depth[r1, c0] * (1.0 - tx) + depth[r1, c1] * tx
    return top * (1.0 - ty) + bottom * ty


def hit_depth(surface: tuple, F: float, w: np.ndarray, a: np.ndarray,
              march: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """(z, hit) where the rays P(z) = w - z a (w, a: (n, 2)) first meet the surface; hit
    False where a ray meets none (it then sees the background)."""
    kind, p, depth = surface
    if kind == "plane":
        z0, gx, gy = p
        den = 1.0 + gx * a[:, 0] + gy * a[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (z0 + gx * w[:, 0] + gy * w[:, 1]) / den
        hit = (den > 0.0) & (z > F)
        return np.where(hit, z, np.nan), hit
    if kind != "depthmap":
        raise ValueError(f"unknown surface kind {kind!r}")
    X0, X1, Y0, Y1 = p
    lo_d, hi_d = float(depth.min()), float(depth.max())
    # The depths at which the ray lies over the extent: per axis lo <= w - z a <= hi.
    zlo = np.full(w.shape[0], lo_d)
    zhi = np.full(w.shape[0], hi_d)
    with np.errstate(divide="ignore", invalid="ignore"):
        for i, (lo, hi) in enumerate(((X0, X1), (Y0, Y1))):
            ai, wi = a[:, i], w[:, i]
            t1, t2 = (wi - lo) / ai, (wi - hi) / ai  # where w - z a = lo, = hi
            moving = ai != 0.0
            zlo = np.where(moving, np.maximum(zlo, np.minimum(t1, t2)), zlo)
            zhi = np.where(moving, np.minimum(zhi, np.maximum(t1, t2)), zhi)
            still = ~moving & ((wi < lo) | (wi > hi))
            zhi = np.where(still, -np.inf, zhi)
    ok = zhi >= zlo

    def g(z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        P = w[rows] - z[..., None] * a[rows]
        Px = np.clip(P[..., 0], X0, X1)  # inside up to rounding
        Py = np.clip(P[..., 1], Y0, Y1)
        return z - depth_at(p, depth, Px, Py)

    z = np.full(w.shape[0], np.nan)
    hit = np.zeros(w.shape[0], dtype=bool)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return z, hit
    t = np.linspace(0.0, 1.0, march + 1)
    zs = zlo[idx, None] + (zhi[idx] - zlo[idx])[:, None] * t[None, :]  # (m, march+1)
    gs = np.stack([g(zs[:, i], idx) for i in range(march + 1)], axis=1)
    # the first grid interval [i, i+1] where g meets 0 (a sign change or an exact zero)
    change = (gs[:, :-1] == 0.0) | (np.sign(gs[:, :-1]) * np.sign(gs[:, 1:]) <= 0.0)
    any_ = change.any(axis=1)
    first = np.argmax(change, axis=1)
    rows = idx[any_]
    k = first[any_]
    a_z, b_z = zs[any_, k], zs[any_, k + 1]
    ga = gs[any_, k]
    exact = ga == 0.0
    for _ in range(40):  # bisection: the bracket shrinks 2^40-fold (to ~1e-11 mm)
        m = 0.5 * (a_z + b_z)
        gm = g(m, rows)
        left = np.sign(gm) * np.sign(ga) <= 0.0
        b_z = np.where(left, m, b_z)
        a_z = np.where(left, a_z, m)
        ga = np.where(left, ga, gm)
    zr = np.where(exact, zs[any_, k], 0.5 * (a_z + b_z))
    z[rows] = zr
    hit[rows] = True
    return z, hit


# -- the renderer ----------------------------------------------------------------------------


def _cell_half(ch: dict) -> tuple[float, float]:
    """Half-extents of a lens cell's bounding box on the array plane."""
    d = ch["d"]
    return (d / 2.0, d / 2.0) if ch["grid"] == "rect" else (d / 2.0, d / math.sqrt(3.0))


def _in_cell(ch: dict, xi: np.ndarray) -> np.ndarray:
    """Whether offsets xi (n, 2) from a lens centre lie in its cell (closed)."""
    h = ch["d"] / 2.0
    ax, ay = np.abs(xi[:, 0]), np.abs(xi[:, 1])
    if ch["grid"] == "rect":
        return (ax <= h) & (ay <= h)
    return (ax <= h) & (ax / 2.0 + ay * SQRT3_2 <= h)


def _in_aperture(design: Any, w: np.ndarray) -> np.ndarray:
    r = design.D / 2.0
    if design.aperture == "square":
        return (np.abs(w[:, 0]) <= r) & (np.abs(w[:, 1]) <= r)
    return w[:, 0] ** 2 + w[:, 1] ** 2 <= r * r


def pixel_centre(ch: dict, row: int, col: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """(s_pix, own lens) of raw pixel [row, col]: ideal [k Q + q_y, j Q + q_x] with
    s = c (1 + v/L) + theta; sensor [m_y, m_x] with s = mu (m - (M - 1)/2) (§9, §10)."""
    m = 1.0 + ch["v"] / ch["L"]
    if ch["layout"] == "ideal":
        Q = ch["Q"]
        k, qy = divmod(row, Q)
        j, qx = divmod(col, Q)
        c = lens_centres(ch)[k, j]
        theta = ch["mu"] * (np.array([qx, qy], dtype=np.float64) - (Q - 1.0) / 2.0)
        return c * m + theta, [(j, k)]
    s = ch["mu"] * np.array([col - (ch["Mx"] - 1.0) / 2.0, row - (ch["My"] - 1.0) / 2.0])
    return s, []


def candidate_lenses(design: Any, ch: dict, s: np.ndarray) -> list[tuple[int, int]]:
    """Every lens (j, k) whose rays can land in the pixel square centred at s: the sensor
    point of a ray through lens c is c (1 + v/L) + alpha xi - (v/L) w, xi in the cell."""
    c = lens_centres(ch)
    types = lens_types(ch)
    alpha = 1.0 + ch["v"] / ch["L"] - ch["v"] / np.asarray(ch["f"])[types]
    hx, hy = _cell_half(ch)
    spread = (ch["v"] / ch["L"]) * design.D / 2.0 + ch["mu"] / 2.0
    off = np.abs(s[None, None, :] - c * (1.0 + ch["v"] / ch["L"]))
    near = ((off[..., 0] <= np.abs(alpha) * hx + spread + 1e-12)
            & (off[..., 1] <= np.abs(alpha) * hy + spread + 1e-12))
    ks, js = np.nonzero(near)
    return [(int(j), int(k)) for j, k in zip(js, ks, strict=True)]


def ray_albedo(sc: Scene, F: float, L: float, L1: float, x: np.ndarray,
               w: np.ndarray) -> np.ndarray:
    """The albedo seen by the rays through array point x (a channel at L) and main-lens
    point w (both (n, 2)): the scene's texture where the ray first meets its surface, the
    background where it meets none."""
    u = (L1 / L) * (x - (1.0 - L / L1) * w)  # on channel 1's array plane
    a = w / F + (u - w) / L1  # P(z) = w - z a
    z, hit = hit_depth(sc["surface"], F, w, a)
    t = np.full(z.shape, sc["background"])
    if hit.any():
        P = w[hit] - z[hit, None] * a[hit]
        t[hit] = albedo(sc["texture"], P[:, 0], P[:, 1])
    return t


def falloff_weight(falloff: str | None, v: float, L: float, x: np.ndarray, w: np.ndarray,
                   s: np.ndarray) -> np.ndarray:
    """The cos^4 weight of rays through array point x (a channel at L, sensor at v behind
    it), main-lens point w and sensor point s (each (n, 2)): 1 without falloff."""
    out = np.ones(x.shape[0])
    if falloff in ("microlens", "both"):
        out *= (v * v / (v * v + np.sum((s - x) ** 2, axis=1))) ** 2
    if falloff in ("main", "both"):
        out *= (L * L / (L * L + np.sum((x - w) ** 2, axis=1))) ** 2
    if falloff not in (None, "microlens", "main", "both"):
        raise ValueError(f"unknown falloff {falloff!r}")
    return out


def _lens_rays(design: Any, ch: dict, L1: float, j: int, k: int, s: np.ndarray,
               sc: Scene, n: int, rng: np.random.Generator, chunk: int,
               falloff: str | None = None) -> np.ndarray:
    """n weighted samples (weights |B| (mu L/v)^2 (L_1/L)^2 1_cell 1_aperture T) of the
    rays through lens (j, k) landing in the pixel square centred at s; their mean is this
    lens's share of the integral over the pixel's rays of T du dw."""
    L, v, mu, F, D = ch["L"], ch["v"], ch["mu"], design.F, design.D
    c = lens_centres(ch)[k, j]
    f = ch["f"][lens_types(ch)[k, j]]
    alpha = 1.0 + v / L - v / f
    hw = mu * L / (2.0 * v)  # half side of the w square
    hx = _cell_half(ch)
    lo, hi = np.empty(2), np.empty(2)
    reach = (v / L) * (D / 2.0 + hw)  # |w0| <= D/2 + hw  <=>  |alpha x + (v/f) c - s| <= reach
    for i in range(2):
        lo[i], hi[i] = c[i] - hx[i], c[i] + hx[i]
        r = s[i] - (v / f) * c[i]
        if alpha == 0.0:
            if abs(r) > reach:
                return np.zeros(n)
        else:
            a1, a2 = (r - reach) / alpha, (r + reach) / alpha
            lo[i], hi[i] = max(lo[i], min(a1, a2)), min(hi[i], max(a1, a2))
    if np.any(hi <= lo):
        return np.zeros(n)
    box = float(np.prod(hi - lo))
    scale = box * (2.0 * hw) ** 2 * (L1 / L) ** 2
    out = np.empty(n)
    for start in range(0, n, chunk):
        m = min(chunk, n - start)
        x = lo + (hi - lo) * rng.random((m, 2))
        w0 = (alpha * x + (v / f) * c - s) * (L / v)
        w = w0 + hw * (2.0 * rng.random((m, 2)) - 1.0)
        keep = _in_cell(ch, x - c) & _in_aperture(design, w)
        val = np.zeros(m)
        if keep.any():
            val[keep] = ray_albedo(sc, F, L, L1, x[keep], w[keep])
        if falloff is not None:
            s_ray = alpha * x - (v / L) * w + (v / f) * c  # §10: the ray's sensor point
            val *= falloff_weight(falloff, v, L, x, w, s_ray)
        out[start:start + m] = val * scale
    return out


def own_lens(ch: dict, s: np.ndarray) -> tuple[int, int]:
    """The lens a sensor pixel centred at s belongs to (§9): the one whose image centre
    c (1 + v/L) is nearest, ties to the least (j, k); by brute force over every lens."""
    c = lens_centres(ch) * (1.0 + ch["v"] / ch["L"])
    d2 = np.sum((c - s[None, None, :]) ** 2, axis=-1)
    ks, js = np.nonzero(d2 == d2.min())
    return min((int(j), int(k)) for j, k in zip(js, ks, strict=True))


def mc_pixels(design: Any, channel: int, pixels: Sequence[tuple[int, int]], sc: Scene,
              n_rays: int = 200_000, n_batches: int = 20,
              rng: np.random.Generator | None = None,
              chunk: int = 100_000, own_only: bool = False,
              falloff: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(mean, stderr) of the raw values of ``pixels`` ([row, col] of §10's layout) of
    ``channel`` (from 1): n_rays rays per contributing lens, split in n_batches independent
    batches; mean over batches and the standard error of that mean (std of the batch means
    / sqrt(n_batches)). A pixel whose integrand is constant has stderr 0 (the estimate is
    then exact up to rounding). ``own_only``: a sensor pixel takes its own lens's light
    alone (:func:`own_lens`), not its neighbours'. ``falloff``: each ray weighted by
    :func:`falloff_weight`."""
    rng = np.random.default_rng(0) if rng is None else rng
    chs = design.resolved()
    ch, L1, mu1 = chs[channel - 1], chs[0]["L"], chs[0]["mu"]
    area = design.D ** 2 if design.aperture == "square" else math.pi * design.D ** 2 / 4.0
    norm = ch["share"] / (mu1 ** 2 * area)
    per = n_rays // n_batches
    mean = np.empty(len(pixels))
    err = np.empty(len(pixels))
    for i, (row, col) in enumerate(pixels):
        s, own = pixel_centre(ch, row, col)
        if ch["layout"] == "ideal":
            lenses = own
        elif own_only:
            lenses = [own_lens(ch, s)]
        else:
            lenses = candidate_lenses(design, ch, s)
        batches = np.zeros(n_batches)
        for j, k in lenses:
            samples = _lens_rays(design, ch, L1, j, k, s, sc, per * n_batches, rng, chunk,
                                 falloff)
            batches += samples.reshape(n_batches, per).mean(axis=1)
        batches *= norm
        mean[i] = batches.mean()
        err[i] = batches.std(ddof=1) / math.sqrt(n_batches)
    return mean, err


# -- every pixel at once (ideal layout): the same estimator, stratified ---------------------


def mc_channel(design: Any, channel: int, sc: Scene, n_side: int = 4,
               rng: np.random.Generator | None = None, block: int = 4096,
               stop: Any = None) -> np.ndarray:
    """Every pixel of ``channel`` (from 1, ``ideal`` layout only) by the estimator of
    :func:`_lens_rays`, vectorised over pixels: n_side^4 rays a pixel, one in each cell of
    an n_side^2 grid over the pixel's box B of x times an n_side^2 grid over its square of
    w (stratified, so the error falls faster than 1/sqrt(n) on smooth integrands). Returns
    the raw image (Ky Q, Kx Q). ``stop``: called between blocks (e.g. a progress print)."""
    rng = np.random.default_rng(0) if rng is None else rng
    chs = design.resolved()
    ch, L1, mu1 = chs[channel - 1], chs[0]["L"], chs[0]["mu"]
    if ch["layout"] != "ideal":
        raise ValueError("mc_channel draws the ideal layout only")
    area = design.D ** 2 if design.aperture == "square" else math.pi * design.D ** 2 / 4.0
    norm = ch["share"] / (mu1 ** 2 * area)
    L, v, mu, D, Q = ch["L"], ch["v"], ch["mu"], design.D, ch["Q"]
    centres = lens_centres(ch)  # (Ky, Kx, 2)
    focal = np.asarray(ch["f"], dtype=np.float64)[lens_types(ch)]  # (Ky, Kx)
    ky, kx = centres.shape[:2]
    rows, cols = ky * Q, kx * Q
    r_idx, c_idx = np.divmod(np.arange(rows * cols), cols)
    k, qy = np.divmod(r_idx, Q)
    j, qx = np.divmod(c_idx, Q)
    hw = mu * L / (2.0 * v)
    hx = np.array(_cell_half(ch))
    reach = (v / L) * (D / 2.0 + hw)
    n = n_side ** 4
    g = (np.arange(n_side) + 0.0)
    sx, sy, tx, ty = (a.ravel() for a in np.meshgrid(g, g, g, g, indexing="ij"))
    strata_x = np.stack([sx, sy], axis=1)  # (n, 2): the x cell of each ray
    strata_w = np.stack([tx, ty], axis=1)
    out = np.empty(rows * cols)
    for start in range(0, rows * cols, block):
        sl = slice(start, min(start + block, rows * cols))
        c = centres[k[sl], j[sl]]  # (m, 2)
        f = focal[k[sl], j[sl]]
        alpha = 1.0 + v / L - v / f
        theta = mu * (np.stack([qx[sl], qy[sl]], axis=1) - (Q - 1.0) / 2.0)
        s = c * (1.0 + v / L) + theta
        r = s - (v / f)[:, None] * c
        with np.errstate(divide="ignore", invalid="ignore"):
            a1 = (r - reach) / alpha[:, None]
            a2 = (r + reach) / alpha[:, None]
        flat = alpha[:, None] == 0.0
        lo = np.where(flat, c - hx, np.maximum(c - hx, np.minimum(a1, a2)))
        hi = np.where(flat, c + hx, np.minimum(c + hx, np.maximum(a1, a2)))
        dead = np.any(hi <= lo, axis=1) | np.any(flat & (np.abs(r) > reach), axis=1)
        hi = np.where(dead[:, None], lo, hi)
        box = np.prod(hi - lo, axis=1)
        scale = box * (2.0 * hw) ** 2 * (L1 / L) ** 2
        m = c.shape[0]
        ux = (strata_x[None] + rng.random((m, n, 2))) / n_side
        x = lo[:, None, :] + (hi - lo)[:, None, :] * ux
        w0 = (alpha[:, None, None] * x + (v / f)[:, None, None] * c[:, None, :]
              - s[:, None, :]) * (L / v)
        w = w0 + hw * (2.0 * (strata_w[None] + rng.random((m, n, 2))) / n_side - 1.0)
        x2, w2 = x.reshape(-1, 2), w.reshape(-1, 2)
        keep = _in_cell(ch, x2 - np.repeat(c, n, axis=0)) & _in_aperture(design, w2)
        val = np.zeros(m * n)
        if keep.any():
            val[keep] = ray_albedo(sc, design.F, L, L1, x2[keep], w2[keep])
        out[sl] = val.reshape(m, n).mean(axis=1) * scale * norm
        if stop is not None:
            stop(sl.stop, rows * cols)
    return out.reshape(rows, cols)
