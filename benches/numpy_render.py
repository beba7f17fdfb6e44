"""Honest NumPy implementations of the raw-image workloads (W9; docs/model.md §10): the
exact separable route and the general route's pixel integrals, the twins of the core's
render (benches/w9_render.py). The sampling workloads are in benches/numpy_impl.py.

Written the way a competent NumPy user would: fully vectorised over pixels, in-place
arithmetic where it saves passes, no Python loops over elements.
"""

from __future__ import annotations

import math

import numpy as np
from numpy_impl import SQRT3_2, _lens_centres

# -- W9: raw images (docs/model.md §10) --------------------------------------------------------
#
# Lengths in mm. A ray through lens c of a channel is (xi, w): xi = x - c its point in the
# lens's cell on the array plane L, w its point on the main lens; it meets the sensor at
# s = c (1 + v/L) + alpha xi - (v/L) w (alpha = 1 + v/L - v/f) and the scene at
# P(z) = B w - (z/L)(c + xi), B = 1 - z/F + z/L (§10: P = w - z a, a = w/F + (x - w)/L).
# du dw = (L_1/L)^2 dxi dw, so a pixel's value is norm * integral over its rays of
# T(P) dxi dw with norm = share (L_1/L)^2 / (mu_1^2 A), A the aperture's area.


def render_norm(design, ch) -> float:
    """share (L_1/L)^2 / (mu_1^2 A): raw units per unit of ray measure in (xi, w)."""
    ch1 = design.channels[0]
    area = design.D ** 2 if design.aperture == "square" else np.pi * design.D ** 2 / 4.0
    return ch.share * (ch1.L / ch.L) ** 2 / (ch1.mu ** 2 * area)


def render_white(design, ch) -> float:
    """A fully lit pixel's value under a white albedo: every ray through the lens's cell
    whose sensor point is in the pixel (cell area x (mu L/v)^2 of w), times the norm."""
    cell = ch.d ** 2 if ch.grid == "rect" else SQRT3_2 * ch.d ** 2
    return render_norm(design, ch) * cell * (ch.mu * ch.L / ch.v) ** 2


def _focals(ch) -> list[float]:
    """The lens types' focal lengths (Ng's setting 1/f = 1/L + 1/v when f is None)."""
    return [1.0 / (1.0 / ch.L + 1.0 / ch.v)] if ch.f is None else list(ch.f)


@np.errstate(divide="ignore", invalid="ignore")
def _clip_all(V: np.ndarray, k: np.ndarray, n0, n1, h) -> tuple[np.ndarray, np.ndarray]:
    """Sutherland-Hodgman against n0 x + n1 y <= h, vectorised over polygons and vertices
    (`_clip` loops over vertex slots: slow for many-sided polygons): V (P, M, 2), each
    polygon's first k vertices in order; returns (P, 2M, 2) with the kept slots first."""
    P, M, _ = V.shape
    slot = np.arange(M)[None, :]
    nxt = np.where(slot + 1 < k[:, None], slot + 1, 0)
    B = np.take_along_axis(V, nxt[..., None], axis=1)
    da = h[:, None] - (n0[:, None] * V[..., 0] + n1[:, None] * V[..., 1])
    db = h[:, None] - (n0[:, None] * B[..., 0] + n1[:, None] * B[..., 1])
    edge = slot < k[:, None]
    t = da / (da - db)
    cand = np.stack([V, V + t[..., None] * (B - V)], axis=2).reshape(P, 2 * M, 2)
    keep = np.stack([edge & (da >= 0.0),
                     edge & (((da > 0.0) & (db < 0.0)) | ((da < 0.0) & (db > 0.0)))],
                    axis=2).reshape(P, 2 * M)
    order = np.argsort(~keep, axis=1, kind="stable")
    return np.take_along_axis(cand, order[..., None], axis=1), keep.sum(axis=1)


@np.errstate(divide="ignore", invalid="ignore")  # parallel edges: no crossing
def _poly_clip(V: np.ndarray, k: np.ndarray, n0, n1, h) -> tuple[np.ndarray, np.ndarray]:
    """Every polygon's part where n0 x + n1 y <= h (Sutherland-Hodgman, one edge),
    vectorised over polygons: V (N, M, 2) holds each one's first k vertices in order; only
    the polygons with a vertex beyond the line are clipped; the result is compacted to the
    largest count."""
    n0, n1, h = (np.broadcast_to(a, k.shape) for a in (n0, n1, h))
    live = np.arange(V.shape[1])[None, :] < k[:, None]
    cut = np.flatnonzero(((n0[:, None] * V[..., 0] + n1[:, None] * V[..., 1] > h[:, None])
                          & live).any(axis=1))
    if cut.size == 0:
        return V, k
    V2, k2 = _clip_all(V[cut], k[cut], n0[cut], n1[cut], h[cut])
    M = max(V.shape[1], int(k2.max(initial=0)), 1)
    out = np.empty((V.shape[0], M, 2))
    out[:, :V.shape[1]] = V
    out[cut] = V2[:, :M] if V2.shape[1] >= M else np.pad(V2, ((0, 0), (0, M - V2.shape[1]),
                                                               (0, 0)))
    k = k.copy()
    k[cut] = k2
    return out, k


def _poly_area(V: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Shoelace areas (counter-clockwise positive) about each polygon's first vertex."""
    N, M, _ = V.shape
    if M < 3:
        return np.zeros(N)
    d = V[:, 1:] - V[:, :1]
    cross = d[:, :-1, 0] * d[:, 1:, 1] - d[:, 1:, 0] * d[:, :-1, 1]
    valid = np.arange(1, M - 1)[None, :] + 1 < k[:, None]
    return 0.5 * np.where(valid, cross, 0.0).sum(axis=1)


@np.errstate(invalid="ignore")
def exact_axis_weights(design, ch, alpha: float, K: int, z: float, e0: float, h: float,
                       n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-axis weights of the exact route (docs/model.md §4, §10), vectorised over the
    K Q pixels p = j Q + q of one axis of an ideal-layout rect channel whose lenses have
    type alpha: the 1-D ray set of pixel p is the polygon |xi| <= d/2, |w| <= D/2,
    |alpha xi - (v/L) w - theta_q| <= mu/2 in (xi, w); its scene coordinate
    X = B w - (z/L)(c_j + xi) is linear, so the measure of the part over texture cell i
    (edges e0 + i h, i = 0..n) is A(e_{i+1}) - A(e_i), A(e) the area of the polygon clipped
    by X <= e. Returns (first, band, total): band[p, m] the measure over cell first[p] + m
    (zero beyond the cells the polygon meets; cells past the texture are dropped: their
    rays see the mean), total[p] the polygon's whole measure."""
    Q, d, mu, L, v = ch.Q, ch.d, ch.mu, ch.L, ch.v
    p = np.arange(K * Q)
    c = d * (p // Q - (K - 1) / 2.0)
    theta = mu * (p % Q - (Q - 1) / 2.0)
    r, hd, vl = design.D / 2.0, d / 2.0, v / L
    P = p.size
    rect = np.array([[-hd, -r], [hd, -r], [hd, r], [-hd, r]])
    V = np.broadcast_to(rect, (P, 4, 2)).copy()
    k = np.full(P, 4)
    V, k = _poly_clip(V, k, alpha, -vl, theta + mu / 2.0)
    V, k = _poly_clip(V, k, -alpha, vl, mu / 2.0 - theta)
    total = _poly_area(V, k)
    B = 1.0 - z / design.F + z / L
    X = B * V[..., 1] - (z / L) * (c[:, None] + V[..., 0])
    live = np.arange(V.shape[1])[None, :] < k[:, None]
    lo = np.where(live, X, np.inf).min(axis=1)
    hi = np.where(live, X, -np.inf).max(axis=1)
    lit = total > 0.0
    i0 = np.where(lit, np.clip(np.floor((lo - e0) / h), 0, n), 0).astype(np.int64)
    i1 = np.where(lit, np.clip(np.ceil((hi - e0) / h), 0, n), 0).astype(np.int64)
    nb = max(int((i1 - i0).max(initial=0)), 1)
    idx = np.minimum(i0[:, None] + np.arange(nb + 1)[None, :], n)  # (P, nb + 1) edges
    edge = e0 + idx * h
    # A(e) for every (pixel, edge): the pixel's polygon clipped by X <= e, i.e.
    # -(z/L) xi + B w <= e + (z/L) c.
    Vr = np.repeat(V, nb + 1, axis=0)
    kr = np.repeat(k, nb + 1)
    Vc, kc = _poly_clip(Vr, kr, -z / L, B, (edge + (z / L) * c[:, None]).ravel())
    below = _poly_area(Vc, kc).reshape(P, nb + 1)
    band = np.diff(below, axis=1)
    band[idx[:, 1:] == idx[:, :-1]] = 0.0  # past the last texture edge
    band[~lit] = 0.0
    total[~lit] = 0.0
    return i0, band, total


def _band_sum(first_y, band_y, tex_bu, first_x, band_x, out):
    """out[b, a] = sum_{r, c} band_y[b, r] T[first_y[b] + r, first_x[a] + c] band_x[a, c]:
    the rows first (M = band_y T, (rows, texture columns)), then one gather of M's columns
    per band offset."""
    rows, tcols = band_y.shape[0], tex_bu.shape[1]
    nr = tex_bu.shape[0]
    M = np.zeros((rows, tcols))
    for m in range(band_y.shape[1]):
        M += band_y[:, m, None] * tex_bu[np.minimum(first_y + m, nr - 1)]
    tmp = np.empty_like(out)
    out.fill(0.0)
    for m in range(band_x.shape[1]):
        np.take(M, np.minimum(first_x + m, tcols - 1), axis=1, out=tmp)
        tmp *= band_x[:, m]
        out += tmp
    return out


def render_exact(design, z: float, image: np.ndarray,
                 extent: tuple[float, float, float, float]) -> dict[str, np.ndarray]:
    """W9's NumPy twin of the exact route: every channel's raw for an image texture
    (row 0 at the top, beyond it the mean) on the fronto-parallel plane at depth z, for a
    design of rect grids, a square aperture and the ideal layout. Per channel and lens
    type: the per-axis weights (`exact_axis_weights`), then the separable sum
    raw = norm [Iy T Ix^T + mean (total_y total_x^T - in_y in_x^T)], vectorised (band
    gathers); channels with several lens types take each pixel from its type's sum."""
    if design.aperture != "square":
        raise ValueError("the exact route needs a square aperture")
    image = np.asarray(image, dtype=np.float64)
    tex_bu = np.ascontiguousarray(image[::-1])  # row r: Y in [Y0 + r h, Y0 + (r + 1) h]
    tr, tc = image.shape
    X0, X1, Y0, Y1 = extent
    hx, hy = (X1 - X0) / tc, (Y1 - Y0) / tr
    mean = float(image.mean())
    out = {}
    for i, ch in enumerate(design.channels, 1):
        if ch.grid != "rect" or ch.layout != "ideal":
            raise ValueError("the exact route needs rect grids and the ideal layout")
        norm = render_norm(design, ch)
        Q = ch.Q
        focals = _focals(ch)
        raw = np.empty((ch.Ky * Q, ch.Kx * Q))
        part = raw if len(focals) == 1 else np.empty_like(raw)
        for t, f in enumerate(focals):
            alpha = 1.0 + ch.v / ch.L - ch.v / f
            fx, bx, Tx = exact_axis_weights(design, ch, alpha, ch.Kx, z, X0, hx, tc)
            fy, by, Ty = exact_axis_weights(design, ch, alpha, ch.Ky, z, Y0, hy, tr)
            _band_sum(fy, by, tex_bu, fx, bx, part)
            part += mean * (np.outer(Ty, Tx) - np.outer(by.sum(axis=1), bx.sum(axis=1)))
            part *= norm
            if len(focals) > 1:  # lens (j, k) has type (j + k) mod T (rect grids)
                jk = (np.arange(ch.Ky * Q)[:, None] // Q + np.arange(ch.Kx * Q)[None, :] // Q)
                mask = jk % len(focals) == t
                raw[mask] = part[mask]
        out[f"channel{i}"] = raw
    return out


def lens_grid(ch) -> tuple[np.ndarray, np.ndarray]:
    """Every lens's centre (n, 2) on the array plane and type index (n,), j-major over
    (j, k) (docs/model.md §9, Lattices and Lens types)."""
    j, k = (a.ravel().astype(np.float64) for a in
            np.meshgrid(np.arange(ch.Kx), np.arange(ch.Ky), indexing="ij"))
    cx, cy = _lens_centres(ch, j, k)
    T = len(_focals(ch))
    ji, ki = j.astype(np.int64), k.astype(np.int64)
    t = ((ji - ki // 2 - ki) if ch.grid == "hex" else (ji + ki)) % T
    return np.stack([cx, cy], axis=1), t


def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1]."""
    return np.polynomial.legendre.leggauss(n)


def _xi_pieces(ch, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, ...]:
    """The region cell ∩ box [lo, hi] (per pair of pixel and lens, cell coordinates xi)
    as pieces [x0, x1] in xi_x over which the cell's y-limits, clipped to the box, are
    linear: the box's x-ends, xi_x = 0 (the hexagon's corner) and where the hexagon's
    sloped sides cross the box's y-ends. Returns (owner, x0, x1, ylo, yhi): owner the pair
    of each non-empty piece and the box's y-range."""
    a = ch.d / 2.0
    x_lo, x_hi = np.maximum(lo[:, 0], -a), np.minimum(hi[:, 0], a)
    if ch.grid == "hex":
        y_lo, y_hi = np.maximum(lo[:, 1], -ch.d / np.sqrt(3.0)), np.minimum(hi[:, 1],
                                                                      ch.d / np.sqrt(3.0))
        cuts = [np.zeros_like(x_lo)]
        for y in (y_lo, y_hi):
            q = 2.0 * a - np.sqrt(3.0) * np.abs(y)  # |xi_x| where the side is at height |y|
            cuts += [q, -q]
        b = np.stack([x_lo, *cuts, x_hi], axis=1)
    else:
        y_lo, y_hi = np.maximum(lo[:, 1], -a), np.minimum(hi[:, 1], a)
        b = np.stack([x_lo, x_hi], axis=1)
    b = np.sort(np.clip(b, x_lo[:, None], np.maximum(x_hi, x_lo)[:, None]), axis=1)
    x0, x1 = b[:, :-1], b[:, 1:]
    ok = (x1 > x0) & (y_hi > y_lo)[:, None]
    owner = np.broadcast_to(np.arange(lo.shape[0])[:, None], x0.shape)[ok]
    return owner, x0[ok], x1[ok], y_lo[owner], y_hi[owner]


def _cell_y(ch, x: np.ndarray) -> np.ndarray:
    """Half-height of the lens cell at xi_x."""
    if ch.grid == "hex":
        return (ch.d - np.abs(x)) / np.sqrt(3.0)
    return np.full(x.shape, ch.d / 2.0)


class ImageTexture:
    """An image texture of docs/model.md §10 (row 0 at the top, square cells; beyond the
    image the albedo is its mean) for the general-route twin: point values, and exact
    integrals over polygons by Green's theorem, ∬ T dX dY = ∮ G dY with
    G(X, Y) = ∫ T dX along the row through Y (piecewise linear in X)."""

    def __init__(self, image: np.ndarray, extent: tuple[float, float, float, float]):
        self.T = np.ascontiguousarray(np.asarray(image, dtype=np.float64)[::-1])  # bottom-up
        self.rows, self.cols = self.T.shape
        self.X0, self.X1, self.Y0, self.Y1 = (float(e) for e in extent)
        self.hx = (self.X1 - self.X0) / self.cols
        self.hy = (self.Y1 - self.Y0) / self.rows
        self.mean = float(self.T.mean())
        self.C = np.zeros((self.rows, self.cols + 1))  # C[r, i]: ∫ from X0 to column i's edge
        np.cumsum(self.T * self.hx, axis=1, out=self.C[:, 1:])
        self.S = np.zeros((self.rows + 1, self.cols + 1))  # summed-area table at the corners
        np.cumsum(self.C * self.hy, axis=0, out=self.S[1:])

    def box(self, Xa, Xb, Ya, Yb) -> np.ndarray:
        """∬ T over the axis-aligned boxes [Xa, Xb] x [Ya, Yb] (Xa <= Xb, Ya <= Yb): the
        summed-area table, bilinear inside a cell (exact), the mean beyond the image."""
        def corner(X, Y):
            Xc, Yc = np.clip(X, self.X0, self.X1), np.clip(Y, self.Y0, self.Y1)
            fx, fy = (Xc - self.X0) / self.hx, (Yc - self.Y0) / self.hy
            i = np.minimum(np.floor(fx), self.cols - 1).astype(np.int64)
            j = np.minimum(np.floor(fy), self.rows - 1).astype(np.int64)
            tx, ty = fx - i, fy - j
            S = self.S
            s = ((S[j, i] * (1.0 - tx) + S[j, i + 1] * tx) * (1.0 - ty)
                 + (S[j + 1, i] * (1.0 - tx) + S[j + 1, i + 1] * tx) * ty)
            # beyond the image: the mean over the rest of the quadrant [X0, X] x [Y0, Y]
            return s + self.mean * ((X - self.X0) * (Y - self.Y0) - (Xc - self.X0) * (Yc - self.Y0))
        return corner(Xb, Yb) - corner(Xa, Yb) - corner(Xb, Ya) + corner(Xa, Ya)

    def G(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """∫ T dX from X0 to X along the row through Y (the mean beyond the image)."""
        r = np.floor((Y - self.Y0) / self.hy)
        in_row = (r >= 0) & (r < self.rows)
        r = np.where(in_row, r, 0).astype(np.int64)
        Xc = np.clip(X, self.X0, self.X1)
        i = np.clip(np.floor((Xc - self.X0) / self.hx), 0, self.cols - 1).astype(np.int64)
        g = (self.C[r, i] + (Xc - (self.X0 + i * self.hx)) * self.T[r, i]
             + self.mean * (X - Xc))
        return np.where(in_row, g, self.mean * (X - self.X0))

    def integral(self, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∬ T, signed area) over the polygons with vertices (X[i, m], Y[i, m]) in order
        (a polygon with fewer vertices repeats its last one)."""
        Xb, Yb = np.roll(X, -1, axis=-1), np.roll(Y, -1, axis=-1)
        owner = np.repeat(np.arange(X.shape[0]), X.shape[-1])
        return self.boundary(X.ravel(), Y.ravel(), Xb.ravel(), Yb.ravel(), owner, X.shape[0])

    def boundary(self, xa, ya, xb, yb, owner, n) -> tuple[np.ndarray, np.ndarray]:
        """(∬ T, signed area) over n regions, each given by its boundary as oriented
        segments (xa, ya) -> (xb, yb) (counter-clockwise, in any order; owner[i] the region
        of segment i): Green's theorem, ∮ G dY, each segment cut where it crosses a row or
        a column line (G is linear along each part: its midpoint value is exact). The parts
        of all segments are one flat array (ragged: as many as a segment has crossings),
        sorted by (segment, t)."""
        area = np.bincount(owner, weights=0.5 * (xa * yb - xb * ya), minlength=n)
        live = np.flatnonzero(ya != yb)  # only segments with dY contribute
        xa, ya, xb, yb, owner = xa[live], ya[live], xb[live], yb[live], owner[live]
        m = live.size
        seg = np.arange(m)
        ts, es = [np.zeros(m), np.ones(m)], [seg, seg]
        for a, b, o, h in ((xa, xb, self.X0, self.hx), (ya, yb, self.Y0, self.hy)):
            lo = np.ceil((np.minimum(a, b) - o) / h)
            hi = np.floor((np.maximum(a, b) - o) / h)
            cnt = np.maximum(hi - lo + 1, 0).astype(np.int64)
            which = np.repeat(seg, cnt)
            k = lo[which] + (np.arange(which.size) - np.repeat(np.cumsum(cnt) - cnt, cnt))
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (o + k * h - a[which]) / (b - a)[which]
            keep = (t > 0.0) & (t < 1.0)
            ts.append(t[keep])
            es.append(which[keep])
        t, e = np.concatenate(ts), np.concatenate(es)
        order = np.lexsort((t, e))
        t, e = t[order], e[order]
        same = e[1:] == e[:-1]
        t0, t1, e = t[:-1][same], t[1:][same], e[:-1][same]
        tm = 0.5 * (t0 + t1)
        dX, dY = xb[e] - xa[e], yb[e] - ya[e]
        g = self.G(xa[e] + tm * dX, ya[e] + tm * dY) * (t1 - t0) * dY
        return np.bincount(owner[e], weights=g, minlength=n), area


def _inside_parts(ax, ay, bx, by, nx, ny, h):
    """Cyrus-Beck: the parameters [t0, t1] of the segments a -> b (shape S) inside the
    convex regions n . p <= h (half-planes along the last axis of nx, ny, h, broadcast
    against S + (H,)); t0 >= t1 where a segment is outside."""
    dx, dy = (bx - ax)[..., None], (by - ay)[..., None]
    num = h - (nx * ax[..., None] + ny * ay[..., None])
    den = nx * dx + ny * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / den
    t1 = np.minimum(np.where(den > 0.0, t, np.inf).min(axis=-1), 1.0)
    t0 = np.maximum(np.where(den < 0.0, t, -np.inf).max(axis=-1), 0.0)
    out = ((den == 0.0) & (num < 0.0)).any(axis=-1)
    return t0, np.where(out, -np.inf, t1)


def _hits(design, ch, plane, cx, cy, wx, wy):
    """Where the rays (x = (cx, cy) on the channel's array plane, w) meet the plane
    Z = z0 + gx X + gy Y: (X, Y, hit) (docs/model.md §10, Scene)."""
    F, L = design.F, ch.L
    z0, gx, gy = plane
    ax = wx / F + (cx - wx) / L
    ay = wy / F + (cy - wy) / L
    if gx == 0.0 and gy == 0.0:
        return wx - z0 * ax, wy - z0 * ay, np.ones(np.shape(ax), dtype=bool)
    den = 1.0 + gx * ax + gy * ay
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (z0 + gx * wx + gy * wy) / den
    return wx - z * ax, wy - z * ay, (den > 0.0) & (z > F)


def circle_sides(tol: float = 1e-3) -> int:
    """Sides of the equal-area polygon standing for a circular aperture at accuracy ``tol``
    (docs/render.md: its area gap to the disc, about 2.5 / n^2, kept within tol / 4;
    32 to 1024 sides): 100 at 1e-3."""
    return int(min(max(math.ceil(math.sqrt(2.5 / (tol / 4.0))), 32), 1024))


def equal_area_ngon(n_gon: int) -> tuple[np.ndarray, float, float]:
    """The regular n_gon of the unit disc's area: (angles phi of its edges' normals, the
    angular step, its circumradius); its inradius is R cos(step / 2)."""
    step = 2.0 * np.pi / n_gon
    R = float(np.sqrt(2.0 * np.pi / (n_gon * np.sin(step))))
    return (np.arange(n_gon) + 0.5) * step, step, R


def _aperture_halfplanes(design, n_gon: int = 256) -> tuple[np.ndarray, float, float, float]:
    """The aperture as half-planes cos(phi) w_x + sin(phi) w_y <= h: a square's 4 sides, or
    a circle's n_gon-gon of the disc's area (angles phi of its edges' normals). Returns
    (phi, h, the angular step, the polygon's circumradius)."""
    r = design.D / 2.0
    if design.aperture == "square":
        return np.array([0.0, 0.5, 1.0, 1.5]) * np.pi, r, 0.0, r * np.sqrt(2.0)
    phi, step, R = equal_area_ngon(n_gon)
    return phi, r * R * np.cos(step / 2.0), step, r * R


def _lens_images(ch, vl: float, m: float) -> tuple[np.ndarray, ...]:
    """Each lens type's alpha = 1 + v/L - v/f, the lens centres, their types and their
    image centres (1 + v/L) c (docs/model.md §9-§10)."""
    alphas = np.array([1.0 + vl - ch.v / f for f in _focals(ch)])
    centres, types = lens_grid(ch)
    return alphas, centres, types, centres * m


def _pixel_centres(res: dict, mu: float, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Sensor-layout pixel centres (x, y) of pixels [rows, cols]."""
    return np.stack([mu * (cols - (res["Mx"] - 1.0) / 2.0),
                     mu * (rows - (res["My"] - 1.0) / 2.0)], axis=1)


def render_pixels(design, channel: int, rows: np.ndarray, cols: np.ndarray, scene: dict,
                  n_xi: int = 12, chunk: int = 2 ** 18) -> np.ndarray:
    """W9's NumPy twin of the general route: the values of the raw pixels [rows, cols] of
    a sensor-layout channel (docs/model.md §10), vectorised over (pixel, lens, node).

    A pixel (sensor point s, square of side mu) collects from every lens c whose light can
    reach it (image centre c (1 + v/L) within |alpha| r_cell + (v/L) D/2 + mu/2 per axis)
    the rays (xi, w) with xi in the lens's cell and w in the aperture whose sensor point is
    in the pixel: for fixed xi, w in the square of side mu L/v around
    w0 = (L/v)(alpha xi - sigma), sigma = s - c (1 + v/L). So the pixel's value is
    norm * sum over lenses of ∫_xi [∫_w T(P(xi, w)) dw] dxi:

    - outer, xi: the cell ∩ the box where that square can meet the aperture, cut into
      pieces over which its y-limits are linear (`_xi_pieces`: the cell's shape exactly),
      n_xi x n_xi Gauss-Legendre nodes per piece: a fixed rule, no adaptivity;
    - inner, w over the square ∩ the aperture (a circle as a 256-gon of its area,
      clipped where the square crosses its rim): the rays through one point x all pass
      through x's conjugate point, so a plane sees that polygon as the polygon of its
      vertices' hits, and T is integrated over it exactly (`ImageTexture.box` on a
      fronto-parallel plane, where it is an axis-aligned square: a summed-area table;
      `ImageTexture.integral` otherwise); the mean times the polygon's area in w is the
      inner integral. Exact on a fronto-parallel plane; on a slanted plane the map's
      Jacobian, taken as constant over the square, varies by ~1e-3 across it.

    ``scene``: {"image": array (row 0 at the top), "extent": (X0, X1, Y0, Y1),
    "plane": (z0, gx, gy), "background": albedo of rays that meet no surface}. Rays that
    miss the plane are not handled (ValueError)."""
    ch = design.channels[channel - 1]
    res = design.resolved()[channel - 1]
    if ch.layout != "sensor":
        raise NotImplementedError("the general-route twin handles sensor-layout channels")
    r = design.D / 2.0
    circle = design.aperture == "circle"
    L, v, mu = ch.L, ch.v, ch.mu
    vl, m = v / L, 1.0 + v / L
    hw = mu / (2.0 * vl)  # half side of the pixel's w square
    alphas, centres, types, img = _lens_images(ch, vl, m)
    rows, cols = np.asarray(rows), np.asarray(cols)
    s = _pixel_centres(res, mu, rows, cols)
    half = np.array([ch.d / 2.0, ch.d / np.sqrt(3.0) if ch.grid == "hex" else ch.d / 2.0])
    reach = np.abs(alphas).max() * half + vl * r + mu / 2.0
    near = np.all(np.abs(s[:, None, :] - img[None, :, :]) <= reach + 1e-12, axis=2)
    pix, lens = np.nonzero(near)
    alpha = alphas[types[lens]]
    c = centres[lens]
    sigma = s[pix] - img[lens]
    # xi box where the square can meet the aperture, |w0| <= r + hw per axis:
    # alpha xi in sigma -+ (v/L)(r + hw).
    span = vl * (r + hw)
    with np.errstate(divide="ignore", invalid="ignore"):
        e1 = (sigma - span) / alpha[:, None]
        e2 = (sigma + span) / alpha[:, None]
    zero = alpha == 0.0
    e1[zero] = np.where(np.abs(sigma[zero]) <= span, -np.inf, np.inf)
    e2[zero] = np.where(np.abs(sigma[zero]) <= span, np.inf, -np.inf)
    owner, x0, x1, ylo, yhi = _xi_pieces(ch, np.minimum(e1, e2), np.maximum(e1, e2))
    g1, w1 = _gauss(n_xi)
    tex = ImageTexture(scene["image"], scene["extent"])
    plane = tuple(float(p) for p in scene["plane"])
    fronto = plane[1] == 0.0 and plane[2] == 0.0
    phi, h_ap, step_ap, r_out = _aperture_halfplanes(design)
    # the n-gon edges that can cross a square near the rim: within its angular half-width
    n_edges = 4 if not circle else int(np.ceil(2.0 * np.arcsin(
        min(1.0, np.sqrt(2.0) * hw / (r - np.sqrt(2.0) * hw))) / step_ap)) + 3
    corner = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * hw
    out = np.zeros(len(rows))
    step = max(1, chunk // (n_xi * n_xi))
    for i in range(0, owner.size, step):
        o = owner[i:i + step]
        a, b = x0[i:i + step, None], x1[i:i + step, None]
        xm, xh = 0.5 * (a + b), 0.5 * (b - a)
        xx = xm + xh * g1  # (n, n_xi)
        yh = np.minimum(yhi[i:i + step, None], _cell_y(ch, xx))
        yl = np.maximum(ylo[i:i + step, None], -_cell_y(ch, xx))
        hy = 0.5 * np.maximum(yh - yl, 0.0)
        yy = 0.5 * (yh + yl)[:, :, None] + hy[:, :, None] * g1  # (n, n_xi, n_xi)
        wxi = ((xh * w1)[:, :, None] * hy[:, :, None] * w1).ravel()  # xi weights
        xx = np.broadcast_to(xx[:, :, None], yy.shape).ravel()
        yy = yy.ravel()
        oo = np.repeat(o, n_xi * n_xi)
        al = alpha[oo]
        w0x = (al * xx - sigma[oo, 0]) / vl
        w0y = (al * yy - sigma[oo, 1]) / vl
        cx, cy = c[oo, 0] + xx, c[oo, 1] + yy
        # Where the square lies: inside the aperture, outside, or across its rim.
        fx, fy = np.abs(w0x) + hw, np.abs(w0y) + hw  # farthest corner
        nx, ny = np.maximum(np.abs(w0x) - hw, 0.0), np.maximum(np.abs(w0y) - hw, 0.0)
        if circle:
            inside = fx * fx + fy * fy <= h_ap * h_ap  # inside the n-gon's inscribed circle
            outside = nx * nx + ny * ny >= r_out * r_out
        else:
            inside = (fx <= r) & (fy <= r)
            outside = (nx >= r) | (ny >= r)
        val = np.zeros(xx.size)
        k = np.flatnonzero(inside)
        if fronto:  # the square's image is an axis-aligned square: its corners' hits
            X, Y, _ = _hits(design, ch, plane, cx[k, None], cy[k, None],
                            w0x[k, None] + corner[[0, 2], 0], w0y[k, None] + corner[[0, 2], 1])
            Xa, Xb = np.minimum(X[:, 0], X[:, 1]), np.maximum(X[:, 0], X[:, 1])
            Ya, Yb = np.minimum(Y[:, 0], Y[:, 1]), np.maximum(Y[:, 0], Y[:, 1])
            val[k] = tex.box(Xa, Xb, Ya, Yb) / ((Xb - Xa) * (Yb - Ya)) * (2.0 * hw) ** 2
        else:
            X, Y, hit = _hits(design, ch, plane, cx[k, None], cy[k, None],
                              w0x[k, None] + corner[:, 0], w0y[k, None] + corner[:, 1])
            if not hit.all():
                raise ValueError("a ray misses the plane")
            tot, area = tex.integral(X, Y)
            val[k] = tot / area * (2.0 * hw) ** 2
        # across the rim: the square clipped by the aperture's nearby edges
        k = np.flatnonzero(~inside & ~outside)
        if k.size:
            V = np.broadcast_to(corner, (k.size, 4, 2)) + np.stack([w0x[k], w0y[k]], 1)[:, None]
            nv = np.full(k.size, 4)
            if circle:
                first = np.floor(np.arctan2(w0y[k], w0x[k]) / step_ap - n_edges / 2.0)
                for e in range(n_edges):
                    ang = (first + e + 0.5) * step_ap
                    V, nv = _poly_clip(V, nv, np.cos(ang), np.sin(ang), h_ap)
            else:
                for ang in phi:
                    V, nv = _poly_clip(V, nv, np.cos(ang), np.sin(ang), h_ap)
            lit = nv >= 3
            k, V, nv = k[lit], V[lit], nv[lit]
            last = V[np.arange(k.size), nv - 1]
            pad = np.arange(V.shape[1])[None, :] >= nv[:, None]
            V = np.where(pad[..., None], last[:, None, :], V)
            wa = _poly_area(V, nv)
            X, Y, hit = _hits(design, ch, plane, cx[k, None], cy[k, None], V[..., 0], V[..., 1])
            if not hit.all():
                raise ValueError("a ray misses the plane")
            tot, area = tex.integral(X, Y)
            with np.errstate(divide="ignore", invalid="ignore"):
                val[k] = np.where(wa > 0.0, tot / area * wa, 0.0)
        tot = (val * wxi).reshape(len(o), -1).sum(axis=1)
        out += np.bincount(pix[o], weights=tot, minlength=len(rows))
    return render_norm(design, ch) * out


def render_pixels_s(design, channel: int, rows: np.ndarray, cols: np.ndarray, scene: dict,
                    n_s: int = 3, chunk: int = 1024, n_gon: int | None = None
                    ) -> np.ndarray:
    """Like `render_pixels`, with the integration order swapped (the order the core uses
    for the R12, docs/render.md "outer s"): outer, the sensor point s over the pixel's
    square (∩ the lens's reach), n_s x n_s Gauss-Legendre nodes, fixed; inner, exact, the
    rays through s from one lens: xi in the cell whose main-lens point
    w(xi) = (L/v)(alpha xi - sigma) is in the aperture, i.e. the cell clipped by the
    aperture's preimage (centre sigma/alpha, radius (v/L) r/|alpha|; a circle as an n_gon
    of its area, by default `circle_sides()` as the core draws it at tol 1e-3), mapped to
    the plane through its vertices' hits and integrated exactly (`ImageTexture.integral`);
    the mean times the polygon's area in xi, times (L/v)^2 (ds = (v/L)^2 dw at fixed xi).
    Exact inner integral on a fronto-parallel plane (the map is affine); on a slanted
    plane the map is projective and its Jacobian is taken as constant over the polygon."""
    ch = design.channels[channel - 1]
    res = design.resolved()[channel - 1]
    if ch.layout != "sensor" or ch.grid != "hex" or design.aperture != "circle":
        raise NotImplementedError("this twin handles hex sensor-layout channels, circle")
    r = design.D / 2.0
    L, v, mu = ch.L, ch.v, ch.mu
    vl, m = v / L, 1.0 + v / L
    alphas, centres, types, img = _lens_images(ch, vl, m)
    rows, cols = np.asarray(rows), np.asarray(cols)
    s = _pixel_centres(res, mu, rows, cols)
    a, b = ch.d / 2.0, ch.d / np.sqrt(3.0)
    hexv = np.array([[0.0, -b], [a, -b / 2], [a, b / 2], [0.0, b], [-a, b / 2], [-a, -b / 2]])
    rho = vl * r
    reach_ab = np.abs(alphas).max() * np.array([a, b]) + rho  # |sigma| per axis
    near = np.all(np.abs(s[:, None, :] - img[None, :, :]) <= reach_ab + mu / 2.0 + 1e-12,
                  axis=2)
    pix, lens = np.nonzero(near)
    alpha = alphas[types[lens]]
    c = centres[lens]
    # the pixel square in sigma = s - img, clipped to the lens's reach
    e = s[pix] - img[lens]
    lo = np.maximum(e - mu / 2.0, -(np.abs(alpha)[:, None] * np.array([a, b]) + rho))
    hi = np.minimum(e + mu / 2.0, np.abs(alpha)[:, None] * np.array([a, b]) + rho)
    ok = np.all(hi > lo, axis=1)
    pix, alpha, c, lo, hi = pix[ok], alpha[ok], c[ok], lo[ok], hi[ok]
    g, wg = _gauss(n_s)
    # nodes: (pairs, n_s, n_s)
    sx = 0.5 * (lo[:, 0] + hi[:, 0])[:, None] + 0.5 * (hi[:, 0] - lo[:, 0])[:, None] * g
    sy = 0.5 * (lo[:, 1] + hi[:, 1])[:, None] + 0.5 * (hi[:, 1] - lo[:, 1])[:, None] * g
    wx_ = 0.25 * ((hi[:, 0] - lo[:, 0])[:, None] * wg)[:, :, None] * (
        (hi[:, 1] - lo[:, 1])[:, None] * wg)[:, None, :]
    SX = np.broadcast_to(sx[:, :, None], wx_.shape).ravel()
    SY = np.broadcast_to(sy[:, None, :], wx_.shape).ravel()
    WT = wx_.ravel()
    own = np.repeat(np.arange(pix.size), n_s * n_s)
    al = alpha[own]
    gx0, gy0 = SX / al, SY / al  # the aperture's preimage: centre sigma/alpha
    rad = rho / np.abs(al)
    if n_gon is None:
        n_gon = circle_sides()
    phi, step, R = equal_area_ngon(n_gon)  # the equal-area n-gon of the unit disc
    h_in = R * np.cos(step / 2.0)  # its inradius
    tex = ImageTexture(scene["image"], scene["extent"])
    plane = tuple(float(p) for p in scene["plane"])
    # The cell's sides (counter-clockwise, outward normals) and the n-gon's (per node).
    hx0, hx1 = hexv, np.roll(hexv, -1, axis=0)
    hn = np.stack([hx1[:, 1] - hx0[:, 1], hx0[:, 0] - hx1[:, 0]], 1)
    hh = (hn * hx0).sum(axis=1)
    gn = np.stack([np.cos(phi), np.sin(phi)], 1)
    gv = R * np.stack([np.cos(phi - step / 2.0), np.sin(phi - step / 2.0)], 1)
    # Where the n-gon holds the whole cell (every vertex within its inradius), the region
    # is the cell; where it is farther than the cell's circumradius, nothing.
    d2 = (hexv[None, :, 0] - gx0[:, None]) ** 2 + (hexv[None, :, 1] - gy0[:, None]) ** 2
    whole = (d2 <= (h_in * rad[:, None]) ** 2).all(axis=1)
    far = np.hypot(gx0, gy0) >= b + R * rad
    val = np.zeros(SX.size)
    todo = np.flatnonzero(~far)
    for i in range(0, todo.size, chunk):
        k = todo[i:i + chunk]
        g0 = np.stack([gx0[k], gy0[k]], 1)
        rk = rad[k]
        rim = np.flatnonzero(~whole[k])
        # the region's boundary: the cell's sides inside the n-gon ...
        ax, ay = np.broadcast_to(hx0[:, 0], (k.size, 6)), np.broadcast_to(hx0[:, 1], (k.size, 6))
        bx, by = np.broadcast_to(hx1[:, 0], (k.size, 6)), np.broadcast_to(hx1[:, 1], (k.size, 6))
        t0, t1 = np.zeros((k.size, 6)), np.ones((k.size, 6))
        # Only the n-gon's edges facing the cell matter: those within the cone from its
        # centre g0 that holds the cell's circumcircle (the n-gon is star-shaped about g0).
        gr = g0[rim]
        dist = np.hypot(gr[:, 0], gr[:, 1])
        half = np.arcsin(np.minimum(1.0, b / np.maximum(dist, 1e-300)))
        mid = np.arctan2(-gr[:, 1], -gr[:, 0])
        i0 = np.floor((mid - half) / step).astype(np.int64) - 1
        cnt = np.minimum(np.ceil((mid + half) / step).astype(np.int64) + 2 - i0, n_gon)
        W = int(cnt.max(initial=1))
        idx = (i0[:, None] + np.arange(W)) % n_gon  # (rim, W) edges; slots >= cnt repeat
        used = np.arange(W)[None, :] < cnt[:, None]
        idx = np.where(used, idx, idx[:, :1])
        nx_, ny_ = gn[idx, 0], gn[idx, 1]
        # n-gon half-planes of a node: n . p <= n . g0 + rad R cos(step/2)
        ngh = nx_ * gr[:, 0, None] + ny_ * gr[:, 1, None] + (rk[rim] * h_in)[:, None]
        t0[rim], t1[rim] = _inside_parts(ax[rim], ay[rim], bx[rim], by[rim], nx_[:, None, :],
                                         ny_[:, None, :], ngh[:, None, :])
        # ... and the n-gon's sides inside the cell (where the n-gon cuts it)
        vx = g0[rim, 0, None] + rk[rim, None] * gv[idx, 0]
        vy = g0[rim, 1, None] + rk[rim, None] * gv[idx, 1]
        nxt = (idx + 1) % n_gon
        wx2 = g0[rim, 0, None] + rk[rim, None] * gv[nxt, 0]
        wy2 = g0[rim, 1, None] + rk[rim, None] * gv[nxt, 1]
        u0, u1 = _inside_parts(vx, vy, wx2, wy2, hn[:, 0], hn[:, 1], hh)
        u1 = np.where(used, u1, -np.inf)
        seg_a = [np.stack([ax + t0 * (bx - ax), ay + t0 * (by - ay)], -1),
                 np.stack([vx + u0 * (wx2 - vx), vy + u0 * (wy2 - vy)], -1)]
        seg_b = [np.stack([ax + t1 * (bx - ax), ay + t1 * (by - ay)], -1),
                 np.stack([vx + u1 * (wx2 - vx), vy + u1 * (wy2 - vy)], -1)]
        ok = [t1 > t0, u1 > u0]
        A = np.concatenate([sa[o] for sa, o in zip(seg_a, ok, strict=True)])
        Bv = np.concatenate([sb[o] for sb, o in zip(seg_b, ok, strict=True)])
        own_k = np.concatenate([np.broadcast_to(np.arange(k.size)[:, None], t1.shape)[ok[0]],
                                np.broadcast_to(rim[:, None], u1.shape)[ok[1]]])
        # xi-area of each region, and its image on the plane through the rays' hits
        xi_area = np.bincount(own_k, weights=0.5 * (A[:, 0] * Bv[:, 1] - Bv[:, 0] * A[:, 1]),
                              minlength=k.size)
        kk = k[own_k]
        cxy, sig, alk = c[own[kk]], np.stack([SX[kk], SY[kk]], 1), al[kk][:, None]
        ends = []
        for Pt in (A, Bv):
            w = (alk * Pt - sig) / vl
            x = cxy + Pt
            X, Y, hit = _hits(design, ch, plane, x[:, 0], x[:, 1], w[:, 0], w[:, 1])
            if not hit.all():
                raise ValueError("a ray misses the plane")
            ends += [X, Y]
        tot, parea = tex.boundary(ends[0], ends[1], ends[2], ends[3], own_k, k.size)
        with np.errstate(divide="ignore", invalid="ignore"):
            val[k] = np.where(xi_area > 0.0, tot / parea * xi_area, 0.0)
    tot = np.bincount(own, weights=val * WT, minlength=pix.size) / (vl * vl)
    return render_norm(design, ch) * np.bincount(pix, weights=tot, minlength=len(rows))
