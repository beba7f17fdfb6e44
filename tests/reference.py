"""Plain NumPy transcriptions of docs/model.md, written independently of the package.

Nothing here calls the package: the camera's fields are read, every derived quantity is
computed here from docs/model.md's formulas. Where a test checks one stage of the engine on
its own earlier stage (footprints from the traced polygons, centroid counts from the
footprint positions), that stage's arrays are arguments.
"""

from __future__ import annotations

import math
import warnings
from fractions import Fraction

import numpy as np

# -- §1, §3: the camera and its pixels ------------------------------------------------------


def array_planes(cam) -> tuple[float, float]:
    """L_1 = v', L_2 = v'(1 + kappa) (docs/model.md §1)."""
    return cam.v1, cam.v1 * (1.0 + cam.kappa)


def array_plane(cam, half: int) -> float:
    """L_i of half 1 or 2."""
    return array_planes(cam)[half - 1]


def ng_focal(L: float, v: float) -> float:
    """Ng's setting: 1/f = 1/L + 1/v."""
    return 1.0 / (1.0 / L + 1.0 / v)


def lens_centre(cam, j, K: int):
    """c_j = (j - (K - 1)/2) d, centre of microlens j of K (docs/model.md §3)."""
    return (j - (K - 1) / 2) * cam.d


def pixel_offset(cam, q):
    """theta_q = mu (q - (Q - 1)/2), pixel q's offset from its microlens image centre."""
    return cam.mu * (q - (cam.Q - 1) / 2)


def chief_w(cam, half: int, q):
    """w_q = -(L_i / v) theta_q: main-lens height of pixel q's chief ray (docs/model.md §4)."""
    return -(array_plane(cam, half) / cam.v) * pixel_offset(cam, q)


# -- §2: closed forms over depth ------------------------------------------------------------


def conjugate(cam, z):
    """Eq. 1: z' = F z / (z - F)."""
    return cam.F * z / (z - cam.F)


def sigma_of(cam, z):
    """(sigma, z'): a point of the plane at depth z is the line u + sigma w = p' in ray
    space, sigma = (v' - z') / z' (docs/model.md §5)."""
    zc = conjugate(cam, z)
    return (cam.v1 - zc) / zc, zc


def resolution_step(cam, z):
    """delta(z) = d z / (Q v'), one sensor-resolution step in object space (§6)."""
    return cam.d * z / (cam.Q * cam.v1)


def sensor_step(cam, z):
    """delta(z) = mu z / v' (§9's mu_1 z / L_1): the step of the sample counts' merge
    tolerance and gaps for every design, a Camera too; §6's d z / (Q v') when d = Q mu."""
    return cam.mu * z / cam.v1


def curves(cam, z) -> dict[str, np.ndarray]:
    """docs/model.md §2: Eq. 1, H_i, rep_i, b_i, bounded LF blur, conventional blur."""
    z = np.asarray(z, dtype=np.float64)
    D, d, v, mu = cam.D, cam.d, cam.v, cam.mu
    zc = conjugate(cam, z)
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
    L = array_plane(cam, half)
    return cam.F * L / (L - cam.F)


def lit_pixels(cam, half: int) -> int:
    """docs/model.md §6: pixel q is lit when |w_q| = (L_i/v) mu |q - (Q-1)/2| < D/2."""
    L = array_plane(cam, half)
    q = np.arange(cam.Q)
    w = -(L / cam.v) * cam.mu * (q - (cam.Q - 1) / 2.0)
    return int(np.count_nonzero(np.abs(w) < cam.D / 2.0))


# -- §4: ray space ----------------------------------------------------------------------------


def geometry(cam, half: int):
    """(L, f, a, b, alpha): x = a u + b w on array plane L, and the pixel-strip factor
    alpha = 1 + v/L - v/f (docs/model.md §4)."""
    L = array_plane(cam, half)
    f = cam.f1 if half == 1 else cam.f2
    a, b = L / cam.v1, 1.0 - L / cam.v1
    alpha = 1.0 + cam.v / L - cam.v / f
    return L, f, a, b, alpha


def strips(cam, half: int, j: int, q: int, K: int):
    """(normal, lo, hi) of aperture, microlens and pixel strips: |w| <= D/2,
    |x - c| <= d/2, |s' - s| <= mu/2 with s' = alpha x - (v/L) w + (v/f) c and
    s = c (1 + v/L) + theta_q (docs/model.md §3-4)."""
    L, f, a, b, alpha = geometry(cam, half)
    c = lens_centre(cam, j, K)
    s = c * (1 + cam.v / L) + pixel_offset(cam, q)
    rest = s - cam.v / f * c
    return [
        ((0.0, 1.0), -cam.D / 2, cam.D / 2),
        ((a, b), c - cam.d / 2, c + cam.d / 2),
        ((alpha * a, alpha * b - cam.v / L), rest - cam.mu / 2, rest + cam.mu / 2),
    ]


def exact_region(cam, half: int, j: int, q: int, K: int):
    """(area, centroid u, centroid w) of the same three strips (their float coefficients
    taken as exact rationals), clipped in exact rational arithmetic: no rounding at all,
    so it measures the engine's own rounding. None when empty."""
    (_, wlo, whi), (nm, xlo, xhi), (npx, plo, phi) = [
        (tuple(map(Fraction, n)), Fraction(lo), Fraction(hi))
        for n, lo, hi in strips(cam, half, j, q, K)
    ]
    a, b = nm

    def u(x, w):
        return (x - b * w) / a

    poly = [(u(xlo, wlo), wlo), (u(xhi, wlo), wlo), (u(xhi, whi), whi), (u(xlo, whi), whi)]

    def keep_below(poly, n, h):  # {p: n.p <= h}
        out = []
        for i, A in enumerate(poly):
            B = poly[(i + 1) % len(poly)]
            da = h - (n[0] * A[0] + n[1] * A[1])
            db = h - (n[0] * B[0] + n[1] * B[1])
            if da >= 0:
                out.append(A)
            if da * db < 0:
                t = da / (da - db)
                out.append((A[0] + t * (B[0] - A[0]), A[1] + t * (B[1] - A[1])))
        return out

    poly = keep_below(keep_below(poly, npx, phi), (-npx[0], -npx[1]), -plo)
    a2 = cu = cw = Fraction(0)
    for i, (u0, w0) in enumerate(poly):
        u1, w1 = poly[(i + 1) % len(poly)]
        cross = u0 * w1 - u1 * w0
        a2 += cross
        cu += cross * (u0 + u1)
        cw += cross * (w0 + w1)
    if len(poly) < 3 or a2 <= 0:
        return None
    return float(a2 / 2), float(cu / (3 * a2)), float(cw / (3 * a2))


# -- §5: footprints on a scene plane ----------------------------------------------------------


def footprints(cam, tr, z, half: int, axis: str, sample: str):
    """(position, lo, hi), each (m, n), of the n pixels of the trace ``tr`` (its vertices,
    n_vertices, centroid, lens, pixel and lit arrays) on the planes at depths z
    (docs/model.md §5): extents from the polygon vertices, positions from the centroid or
    the chief ray (NaN where there is no sample)."""
    K = cam.Kx if axis == "x" else cam.Ky
    z = np.asarray(z, float)[:, None]
    sigma, zc = sigma_of(cam, z)
    scale = -z / cam.v1
    u, w = tr.vertices[..., 0], tr.vertices[..., 1]  # (n, 6)
    p = u[None] + sigma[..., None] * w[None]  # (m, n, 6)
    X = p * scale[..., None]
    with warnings.catch_warnings():  # all-NaN rows are the empty polygons
        warnings.simplefilter("ignore", RuntimeWarning)
        lo, hi = np.nanmin(X, axis=2), np.nanmax(X, axis=2)
    empty = tr.n_vertices == 0
    lo[:, empty] = np.nan
    hi[:, empty] = np.nan
    if sample == "centroid":
        pos = (tr.centroid[:, 0] + sigma * tr.centroid[:, 1]) * scale
    else:
        L = array_plane(cam, half)
        c = lens_centre(cam, tr.lens, K)
        wq = -(L / cam.v) * pixel_offset(cam, tr.pixel)
        pos = -(cam.v1 / L) * (c + wq * (L - zc) / zc) * z / cam.v1
        pos[:, ~tr.lit] = np.nan
    return pos, lo, hi


# -- §6: coincidence planes and new samples ---------------------------------------------------


def lit_w(cam, half: int) -> np.ndarray:
    """Chief-ray main-lens heights w_q of the lit pixels (docs/model.md §3-§4, §6)."""
    w = chief_w(cam, half, np.arange(cam.Q))
    return w[np.abs(w) < cam.D / 2]


def chief_p(cam, half: int, K: int, zc: float) -> np.ndarray:
    """Chief samples p' = (v'/L)[c_j + w_q (L - z')/z'] of every lit pixel, (K, Q_lit)."""
    Li = array_plane(cam, half)
    c = lens_centre(cam, np.arange(K), K)[:, None]
    w = lit_w(cam, half)[None, :]
    return (cam.v1 / Li) * (c + w * (Li - zc) / zc)


def greedy_representatives(x: np.ndarray, eps: float) -> list[float]:
    """The first position of each of the least number of closed intervals of length eps
    that cover the sorted positions x, found greedily (docs/samples.md §4)."""
    reps: list[float] = []
    for v in x:
        if not reps or v - reps[-1] > eps:
            reps.append(v)
    return reps


def greedy_count(x: np.ndarray, eps: float) -> int:
    """Least number of closed intervals of length eps covering the sorted positions x."""
    return len(greedy_representatives(x, eps))


def field_gap(x: np.ndarray, W: float) -> float:
    """Largest consecutive gap overlapping the open field (-W, W); inf if [-W, W] is not
    covered."""
    if x.size == 0 or x[0] > -W or x[-1] < W:
        return math.inf
    lo, hi = x[:-1], x[1:]
    m = (hi > -W) & (lo < W)
    return float(np.max(hi[m] - lo[m])) if m.any() else 0.0


def matched(a: np.ndarray, b: np.ndarray, eps: float) -> int:
    """Distinct samples of a (greedy clusters) that have a sample of b within eps."""
    if a.size == 0 or b.size == 0:
        return 0
    reps = np.array(greedy_representatives(a, eps))
    i = np.clip(np.searchsorted(b, reps), 1, b.size - 1) if b.size > 1 else np.zeros(
        reps.size, dtype=int)
    near = np.minimum(np.abs(b[i] - reps), np.abs(b[np.maximum(i - 1, 0)] - reps))
    return int(np.sum(near <= eps))


def new_samples(cam, z, tol: float = 1e-6):
    """(distinct, distinct_2d, max_gap, sampled) of the chief samples at depths z, as
    ``splitlf.new_samples`` returns them (docs/model.md §6, docs/samples.md): merged at
    tol * delta(z) and gaps in delta(z), delta(z) = mu z / v' (§9)."""
    z = np.atleast_1d(np.asarray(z, dtype=float))
    m = z.size
    distinct = np.zeros((3, m), dtype=np.int64)
    d2 = np.zeros((3, m), dtype=np.int64)
    gap = np.zeros((3, m))
    # delta(z) = mu z / v' (§9's mu_1 z / L_1, the step of every design, a Camera too; §6's
    # d z / (Q v') only when d = Q mu), mapped to plane v' (X = -p' z / v'): mu. Merge
    # tolerance and gaps are both in that step.
    step = cam.mu
    eps = tol * step
    W = cam.Kx * cam.d / 4  # |X| <= Kx d z / (4 v')  <=>  |p'| <= Kx d / 4
    for k, zk in enumerate(z):
        zc = conjugate(cam, zk)
        counts = {}
        for axis, K in (("x", cam.Kx), ("y", cam.Ky)):
            p1 = np.sort(chief_p(cam, 1, K, zc).ravel())
            p2 = np.sort(chief_p(cam, 2, K, zc).ravel())
            pu = np.sort(np.concatenate([p1, p2]))
            counts[axis] = [greedy_count(p, eps) for p in (p1, p2, pu)]
            counts[axis + "i"] = matched(p1, p2, eps)
            if axis == "x":
                distinct[:, k] = counts["x"]
                gap[:, k] = [field_gap(p, W) / step for p in (p1, p2, pu)]
        (x1, x2, _), (y1, y2, _) = counts["x"], counts["y"]
        d2[:, k] = [x1 * y1, x2 * y2, x1 * y1 + x2 * y2 - counts["xi"] * counts["yi"]]
    lit = np.array([cam.Kx * lit_w(cam, h).size for h in (1, 2)])
    return distinct, d2, gap, np.append(lit, lit.sum())


def centroid_counts(cam, z: float, positions, tol: float):
    """(counts, gaps, sampled) of the centroid samples at depth z from the footprint
    positions X of half 1 and half 2 (NaN: no sample): sorted and merged with the greedy
    rule at tol * delta(z), gaps over the central field in delta(z) = mu z / v' (§9)."""
    delta = sensor_step(cam, z)
    field = cam.Kx * cam.d * z / (4 * cam.v1)
    pos = [np.sort(x[np.isfinite(x)]) for x in positions]
    pos.append(np.sort(np.concatenate(pos)))
    counts = [greedy_count(p, tol * delta) for p in pos]
    gaps = [field_gap(p, field) / delta for p in pos]
    return counts, gaps, [pos[0].size, pos[1].size]


def closed_form(K: int, q_lit: int, N: int, T: int) -> int:
    """docs/model.md §6 with Q_lit: N Q + T (K - N) when T <= Q and K >= N, else K Q."""
    if T <= q_lit and K >= N:
        return N * q_lit + T * (K - N)
    return K * q_lit


def coincidence_planes(cam, half: int, max_n: int, max_t: int):
    """(N, T, side) -> z' of every valid coincidence plane (docs/model.md §6)."""
    Li = array_plane(cam, half)
    out = {}
    for N in range(1, max_n + 1):
        for T in range(1, max_t + 1):
            if math.gcd(N, T) != 1:
                continue
            r = N * cam.d * cam.v / (T * cam.mu * Li)
            if Li / (1 + r) > cam.F:
                out[(N, T, "far")] = Li / (1 + r)
            if 1 - r > 0 and Li / (1 - r) > cam.F:
                out[(N, T, "near")] = Li / (1 - r)
    return out


def chief_2d(cam, half: int, zc: float) -> np.ndarray:
    """Every lit pixel's 2D chief sample: chief ray through the square aperture, both axes."""
    Li = array_plane(cam, half)
    q = np.arange(cam.Q)
    w = chief_w(cam, half, q)
    jx, qx, jy, qy = np.meshgrid(np.arange(cam.Kx), q, np.arange(cam.Ky), q, indexing="ij")
    wx, wy = w[qx], w[qy]
    lit = (np.abs(wx) < cam.D / 2) & (np.abs(wy) < cam.D / 2)  # |w| inside the square
    cx = lens_centre(cam, np.arange(cam.Kx), cam.Kx)[jx]
    cy = lens_centre(cam, np.arange(cam.Ky), cam.Ky)[jy]
    px = (cam.v1 / Li) * (cx + wx * (Li - zc) / zc)
    py = (cam.v1 / Li) * (cy + wy * (Li - zc) / zc)
    return np.stack([px[lit], py[lit]], axis=1)


def components(p: np.ndarray, eps: float) -> int:
    """Connected components of points closer than eps in both coordinates."""
    if len(p) == 0:
        return 0
    adj = (np.abs(p[:, None, 0] - p[None, :, 0]) <= eps) & (
        np.abs(p[:, None, 1] - p[None, :, 1]) <= eps)
    label = np.arange(len(p))
    while True:
        new = np.where(adj, label[None, :], len(p)).min(axis=1)
        new = new[new]
        if np.array_equal(new, label):
            return int(np.unique(label).size)
        label = new


# -- simulation: the system matrix ------------------------------------------------------------


def cell_integrals(breaks, vals, edges):
    """Exact integral over each cell of the piecewise-linear function (breaks ascending)."""
    pts = np.unique(np.concatenate([breaks, edges[(edges > breaks[0]) & (edges < breaks[-1])]]))
    mid = 0.5 * (pts[1:] + pts[:-1])
    # the linear piece holding each sub-interval (evaluated from inside: jumps at the ends)
    t = np.clip(np.searchsorted(breaks, mid, side="right") - 1, 0, breaks.size - 2)
    slope = (vals[t + 1] - vals[t]) / (breaks[t + 1] - breaks[t])
    f_lo = vals[t] + slope * (pts[:-1] - breaks[t])
    f_hi = vals[t] + slope * (pts[1:] - breaks[t])
    seg = 0.5 * (f_lo + f_hi) * np.diff(pts)
    cell = np.searchsorted(edges, mid) - 1
    out = np.zeros(edges.size - 1)
    np.add.at(out, cell, seg)
    return out


# -- §9: general designs (closed forms per channel and lens type) ------------------------------


def design_focals(ch) -> list[float]:
    """The lens types' focal lengths of a channel: f as given, or Ng's setting (one type)."""
    return [ng_focal(ch.L, ch.v)] if ch.f is None else list(ch.f)


def design_curves(design, z) -> dict:
    """docs/model.md §2 for every channel (H, rep, H/mu) and every lens type (b_t, bounded
    LF blur with f_t; §9), the smallest LF blur of each channel and of the whole design.
    Rows of the per-type arrays: ``rows`` = [(channel, type)] from 0, channel-major."""
    z = np.asarray(z, dtype=np.float64)
    zc = design.F * z / (z - design.F)
    D = design.D
    per_channel: dict[str, list] = {k: [] for k in ("main_blur", "repetitions",
                                                    "conventional_px", "channel_blur_px")}
    per_type: dict[str, list] = {"microlens_blur": [], "blur_px": []}
    rows = []
    with np.errstate(divide="ignore"):
        for c, ch in enumerate(design.channels):
            L, d, v, mu = ch.L, ch.d, ch.v, ch.mu
            H = (D * L / 2.0) * np.abs(1.0 / zc - 1.0 / L)
            per_channel["main_blur"].append(H)
            per_channel["repetitions"].append(2.0 * H / d)
            per_channel["conventional_px"].append(H / mu)
            R = D * v / (2.0 * L)
            own = []
            for t, f in enumerate(design_focals(ch)):
                b = (d * v / 2.0) * np.abs(1.0 / f - 1.0 / (L - zc) - 1.0 / v)
                px = np.minimum(b, R) / mu
                per_type["microlens_blur"].append(b)
                per_type["blur_px"].append(px)
                own.append(px)
                rows.append((c, t))
            per_channel["channel_blur_px"].append(np.min(own, axis=0))
    out = {k: np.array(v) for k, v in {**per_channel, **per_type}.items()}
    out["union_blur_px"] = out["channel_blur_px"].min(axis=0)
    out["conjugate"] = zc
    out["rows"] = rows
    return out


# ---- docs/model.md §9: general designs in 2-D --------------------------------------------
#
# Each function takes a design's fields as the package resolves them
# (``design.resolved()``: one dict per channel, the sensor layout's Mx, My filled in) and
# transcribes §9 with NumPy. Lens arrays are indexed [k, j] (rows, then lenses in a row);
# pixel arrays [row, column] like the channel's pixel grid.

SQRT3_2 = np.sqrt(3.0) / 2.0


def lens_centres(ch: dict) -> np.ndarray:
    """Lattices: centres c (Ky, Kx, 2) on the array plane. ``rect``: d (j - (Kx-1)/2,
    k - (Ky-1)/2); ``hex``: d (j + (k mod 2)/2, k sqrt(3)/2) shifted so that the mean of
    the centres is 0 (the mean in closed form: x (Kx-1)/2 + (odd rows)/(2 Ky), y
    sqrt(3)/2 (Ky-1)/2)."""
    kx, ky, d = ch["Kx"], ch["Ky"], ch["d"]
    j, k = np.meshgrid(np.arange(kx, dtype=np.float64), np.arange(ky, dtype=np.float64))
    if ch["grid"] == "rect":
        return np.stack([d * (j - (kx - 1.0) / 2.0), d * (k - (ky - 1.0) / 2.0)], axis=-1)
    odd = (ky // 2) / ky
    mx, my = (kx - 1.0) / 2.0 + odd / 2.0, SQRT3_2 * (ky - 1.0) / 2.0
    x = j + (k % 2) / 2.0
    y = k * SQRT3_2
    return np.stack([d * (x - mx), d * (y - my)], axis=-1)


def lens_types(ch: dict) -> np.ndarray:
    """Lens types (Ky, Kx): (j - floor(k/2) - k) mod T on hex grids, (j + k) mod T on rect."""
    kx, ky = ch["Kx"], ch["Ky"]
    t = len(ch["f"])
    j, k = np.meshgrid(np.arange(kx), np.arange(ky))
    if ch["grid"] == "hex":
        return np.mod(j - k // 2 - k, t)
    return np.mod(j + k, t)


def pixel_lenses(ch: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pixel layouts: each pixel's lens (j, k), offset theta (rows, cols, 2) from the lens's
    image centre c (1 + v/L), and whether its centre lies in that lens's image cell.

    ``ideal``: Q x Q pixels per lens, theta = mu (q - (Q-1)/2) per axis, always in the cell.
    ``sensor``: pixel centres s = mu (m - (M-1)/2); the lens whose image centre is nearest
    (brute force over every lens; ties to the lower j, then the lower k); the image cell is
    the square of side p = d (1 + v/L) (rect) or the regular hexagon of pitch p with flat
    sides facing the row neighbours (hex), closed.
    """
    m = 1.0 + ch["v"] / ch["L"]
    c = lens_centres(ch)
    if ch["layout"] == "ideal":
        q, kx, ky = ch["Q"], ch["Kx"], ch["Ky"]
        a, b = np.arange(kx * q), np.arange(ky * q)
        off = ch["mu"] * (np.arange(q) - (q - 1.0) / 2.0)
        jj, kk = np.meshgrid(a // q, b // q)
        tx, ty = np.meshgrid(off[a % q], off[b % q])
        return jj, kk, np.stack([tx, ty], axis=-1), np.ones(jj.shape, dtype=bool)
    mx, my, mu = ch["Mx"], ch["My"], ch["mu"]
    sx = mu * (np.arange(mx) - (mx - 1.0) / 2.0)
    sy = mu * (np.arange(my) - (my - 1.0) / 2.0)
    # Lenses ordered j-major, then k: argmin's first minimum is the lowest j, then k.
    cj = np.transpose(c, (1, 0, 2)).reshape(-1, 2) * m
    jk = np.stack(np.meshgrid(np.arange(ch["Kx"]), np.arange(ch["Ky"]), indexing="ij"),
                  axis=-1).reshape(-1, 2)
    jj = np.empty((my, mx), dtype=np.int64)
    kk = np.empty((my, mx), dtype=np.int64)
    for row in range(my):
        dx = sx[:, None] - cj[None, :, 0]
        dy = sy[row] - cj[None, :, 1]
        best = np.argmin(dx * dx + dy * dy, axis=1)
        jj[row], kk[row] = jk[best, 0], jk[best, 1]
    centre = c[kk, jj] * m
    theta = np.stack(np.meshgrid(sx, sy), axis=-1) - centre
    half = ch["d"] * m / 2.0
    ax, ay = np.abs(theta[..., 0]), np.abs(theta[..., 1])
    if ch["grid"] == "rect":
        in_cell = (ax <= half) & (ay <= half)
    else:
        in_cell = (ax <= half) & (ax / 2.0 + ay * SQRT3_2 <= half)
    return jj, kk, theta, in_cell


def chief_w_2d(ch: dict, theta: np.ndarray) -> np.ndarray:
    """Chief ray's main-lens height w = -(L/v) theta (2-D)."""
    return -(ch["L"] / ch["v"]) * theta


def lit_mask(D: float, aperture: str, w: np.ndarray) -> np.ndarray:
    """w strictly inside the aperture of width D: square |w_x|, |w_y| < D/2, circle
    |w| < D/2."""
    r = D / 2.0
    if aperture == "square":
        return (np.abs(w[..., 0]) < r) & (np.abs(w[..., 1]) < r)
    return w[..., 0] * w[..., 0] + w[..., 1] * w[..., 1] < r * r


def conjugate_f(F: float, z):
    """Eq. 1: z' = F z / (z - F)."""
    return F * z / (z - F)


def chief_samples_2d(design, channel: int, z: float) -> dict[str, np.ndarray]:
    """Chief samples in 2-D of every pixel of a channel (from 1): X = -(z/L) [c + w (L -
    z')/z'] (NaN where unlit), lit (chief ray inside the aperture and, sensor layout, the
    pixel in its lens's image cell), lens (j, k) and type."""
    ch = design.resolved()[channel - 1]
    jj, kk, theta, in_cell = pixel_lenses(ch)
    w = chief_w_2d(ch, theta)
    lit = in_cell & lit_mask(design.D, design.aperture, w)
    L = ch["L"]
    zc = conjugate_f(design.F, z)
    g, s = z / L, (L - zc) / zc
    c = lens_centres(ch)[kk, jj]
    X = -g * (c[..., 0] + w[..., 0] * s)
    Y = -g * (c[..., 1] + w[..., 1] * s)
    X[~lit] = np.nan
    Y[~lit] = np.nan
    return {"X": X, "Y": Y, "lit": lit, "lens": np.stack([jj, kk], axis=-1),
            "type": lens_types(ch)[kk, jj]}


def resolution_step_2d(design, z: float) -> float:
    """delta(z) = mu_1 z / L_1."""
    ch = design.resolved()[0]
    return ch["mu"] * z / ch["L"]


def central_field(design, z: float, window: float) -> tuple[float, float]:
    """Half-widths of the 2-D central field: (window/2) d_1 z/L_1, clipped in each axis to
    half the extent of channel 1's array image (rect K d; hex (Kx + 1/2) d wide, Kx d with
    one row, and ((Ky - 1) sqrt(3)/2 + 2/sqrt(3)) d high) on the plane, i.e. a half-width of
    a quarter of the extent."""
    ch = design.resolved()[0]
    d, kx, ky = ch["d"], ch["Kx"], ch["Ky"]
    if ch["grid"] == "rect":
        ex, ey = kx * d, ky * d
    else:
        ex = (kx + 0.5 if ky >= 2 else kx) * d
        ey = ((ky - 1) * SQRT3_2 + 1.0 / SQRT3_2) * d
    g = z / ch["L"]
    w = window / 2.0 * d
    return min(w, ex / 4.0) * g, min(w, ey / 4.0) * g


# -- §9: the 1-D engine on a design's channel (along x, rect grids) -----------------------------


def line_pixels(design, channel: int) -> dict[str, np.ndarray]:
    """Every pixel of a channel (from 1) along x (docs/model.md §9, 1-D): its lens j, type
    j mod T, offset theta from the lens's image centre c_j (1 + v/L), chief height
    w = -(L/v) theta, and lit (|w| < D/2 and, sensor layout, |theta| <= d (1 + v/L)/2).
    Ideal: pixel i = j Q + q, theta = mu (q - (Q-1)/2). Sensor: s = mu (m - (M-1)/2), the
    nearest image centre by brute force over every lens (ties to the lower j)."""
    ch = design.resolved()[channel - 1]
    L, v, mu, d, kx = ch["L"], ch["v"], ch["mu"], ch["d"], ch["Kx"]
    mag = 1.0 + v / L
    c = d * (np.arange(kx) - (kx - 1.0) / 2.0)
    if ch["layout"] == "ideal":
        q = ch["Q"]
        i = np.arange(kx * q)
        j = i // q
        theta = mu * (i % q - (q - 1.0) / 2.0)
        in_cell = np.ones(i.size, dtype=bool)
    else:
        s = mu * (np.arange(ch["Mx"]) - (ch["Mx"] - 1.0) / 2.0)
        dist = np.abs(s[:, None] - c[None, :] * mag)
        j = np.argmin(dist, axis=1)  # the first minimum: the lower j on a tie
        theta = s - c[j] * mag
        in_cell = np.abs(theta) <= d * mag / 2.0
    w = -(L / v) * theta
    return {"j": j, "c": c[j], "type": j % len(ch["f"]), "theta": theta, "w": w,
            "lit": in_cell & (np.abs(w) < design.D / 2.0)}


def line_strips(design, channel: int, c: float, theta: float, t: int):
    """(normal, lo, hi) of the aperture, lens and pixel strips of a pixel of a channel in
    ray space referred to channel 1's array plane L_1 (docs/model.md §4 with v' = L_1):
    |w| <= D/2, |x - c| <= d/2 with x = (L/L_1) u + (1 - L/L_1) w, |s' - s| <= mu/2 with
    s' = alpha x - (v/L) w + (v/f_t) c, alpha = 1 + v/L - v/f_t, s = c (1 + v/L) + theta."""
    chs = design.resolved()
    ch = chs[channel - 1]
    L, v, mu, d, f = ch["L"], ch["v"], ch["mu"], ch["d"], ch["f"][t]
    a, b = L / chs[0]["L"], 1.0 - L / chs[0]["L"]
    alpha = 1.0 + v / L - v / f
    s = c * (1.0 + v / L) + theta
    rest = s - v / f * c
    return [
        ((0.0, 1.0), -design.D / 2, design.D / 2),
        ((a, b), c - d / 2, c + d / 2),
        ((alpha * a, alpha * b - v / L), rest - mu / 2, rest + mu / 2),
    ]


def exact_strip_region(strips):
    """(area, centroid u, centroid w) of the intersection of an aperture strip (normal
    (0, 1)), a lens strip and a pixel strip, their float coefficients taken as exact
    rationals and clipped in exact rational arithmetic. None when empty."""
    (_, wlo, whi), (nm, xlo, xhi), (npx, plo, phi) = [
        (tuple(map(Fraction, n)), Fraction(lo), Fraction(hi)) for n, lo, hi in strips
    ]
    a, b = nm
    poly = [((x - b * w) / a, w) for x, w in ((xlo, wlo), (xhi, wlo), (xhi, whi), (xlo, whi))]

    def keep_below(poly, n, h):  # {p: n.p <= h}
        out = []
        for i, A in enumerate(poly):
            B = poly[(i + 1) % len(poly)]
            da = h - (n[0] * A[0] + n[1] * A[1])
            db = h - (n[0] * B[0] + n[1] * B[1])
            if da >= 0:
                out.append(A)
            if da * db < 0:
                t = da / (da - db)
                out.append((A[0] + t * (B[0] - A[0]), A[1] + t * (B[1] - A[1])))
        return out

    poly = keep_below(keep_below(poly, npx, phi), (-npx[0], -npx[1]), -plo)
    a2 = cu = cw = Fraction(0)
    for i, (u0, w0) in enumerate(poly):
        u1, w1 = poly[(i + 1) % len(poly)]
        cross = u0 * w1 - u1 * w0
        a2 += cross
        cu += cross * (u0 + u1)
        cw += cross * (w0 + w1)
    if len(poly) < 3 or a2 <= 0:
        return None
    return float(a2 / 2), float(cu / (3 * a2)), float(cw / (3 * a2))


def line_chief_X(design, channel: int, z: float) -> np.ndarray:
    """Object-space chief samples X = -p' z / L_1 of the lit pixels of a channel along x,
    p' = (L_1/L) [c + w (L - z')/z'] (docs/model.md §5 with v' = L_1; §9)."""
    px = line_pixels(design, channel)
    chs = design.resolved()
    L, L1 = chs[channel - 1]["L"], chs[0]["L"]
    zc = conjugate_f(design.F, z)
    p = (L1 / L) * (px["c"] + px["w"] * (L - zc) / zc)
    return (-p * z / L1)[px["lit"]]


def design_new_samples(design, z, tol: float = 1e-6):
    """(distinct, max_gap, sampled) of the chief samples of every channel of a design along
    x and of their union, as ``splitlf.new_samples(design, ...)`` returns them: greedy merge
    at tol delta(z), delta(z) = mu_1 z / L_1; gaps over |X| <= Kx_1 d_1 z / (4 L_1) in
    delta(z) (docs/model.md §6, §9)."""
    z = np.atleast_1d(np.asarray(z, dtype=float))
    C = len(design.channels)
    ch1 = design.resolved()[0]
    distinct = np.zeros((C + 1, z.size), dtype=np.int64)
    gap = np.zeros((C + 1, z.size))
    for k, zk in enumerate(z):
        delta = ch1["mu"] * zk / ch1["L"]
        W = ch1["Kx"] * ch1["d"] * zk / (4 * ch1["L"])
        pos = [np.sort(line_chief_X(design, c, zk)) for c in range(1, C + 1)]
        pos.append(np.sort(np.concatenate(pos)))
        distinct[:, k] = [greedy_count(p, tol * delta) for p in pos]
        gap[:, k] = [field_gap(p, W) / delta for p in pos]
    lit = np.array([line_pixels(design, c)["lit"].sum() for c in range(1, C + 1)])
    return distinct, gap, np.append(lit, lit.sum())
