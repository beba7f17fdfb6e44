"""An independent exact reference for §10's exact route, plain NumPy and polygon clipping.

The route: a fronto-parallel plane at depth z, a rect grid, a square aperture, the ideal
layout and an image texture (docs/model.md §4, §5, §10). A pixel's ray set is then the
product of its x polygon and its y polygon in ray space (u, w), and the scene position of
a ray is separable too: per axis, X = w - z (w/F + (u - w)/L_1) (§10's P(z)). So

    value = share / (mu_1^2 D^2) * [ sum_{r, c} T[r, c] Ix[c] Iy[r] + mean(T) * rest ],

Ix[c] the area (du dw) of the x polygon's part whose X lies in column c's interval, Iy[r]
the same for the y polygon and row r's Y interval, and rest the product measure of the
rays that land outside the image (which see its mean).

The polygons are built by clipping the three strips of §4 in (u, w) (aperture
|w| <= D/2, lens |x - c| <= d/2 with x = (L/L_1) u + (1 - L/L_1) w, pixel
|s' - s| <= mu/2 with s' = alpha x - (v/L) w + (v/f) c); the part of a polygon on one
side of the line X = e is clipped again and its area taken with the shoelace formula
(about a vertex of the polygon, for accuracy); a cell's measure is the difference of two
such areas. No weight profile is formed, so this shares no code or method with the
package's exact route.

Axes: raw [k Q + q_y, j Q + q_x] with lens (j, k) at c = d (j - (K_x - 1)/2,
k - (K_y - 1)/2) and offsets theta = mu (q - (Q - 1)/2) ascending in sensor x and y; the
texture's row 0 is its top (largest Y), column 0 its left (smallest X).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from reference import lens_types

Poly = list[tuple[float, float]]


def clip(poly: Poly, n: tuple[float, float], h: float) -> Poly:
    """The part of a convex polygon where n . p <= h (Sutherland-Hodgman, one edge)."""
    out: Poly = []
    for i, A in enumerate(poly):
        B = poly[(i + 1) % len(poly)]
        da = h - (n[0] * A[0] + n[1] * A[1])
        db = h - (n[0] * B[0] + n[1] * B[1])
        if da >= 0.0:
            out.append(A)
        if (da > 0.0 and db < 0.0) or (da < 0.0 and db > 0.0):
            t = da / (da - db)
            out.append((A[0] + t * (B[0] - A[0]), A[1] + t * (B[1] - A[1])))
    return out


def area(poly: Poly) -> float:
    """Shoelace area of a polygon (counter-clockwise positive), about its first vertex."""
    if len(poly) < 3:
        return 0.0
    u0, w0 = poly[0]
    s = 0.0
    for i in range(1, len(poly) - 1):
        a, b = poly[i], poly[i + 1]
        s += (a[0] - u0) * (b[1] - w0) - (b[0] - u0) * (a[1] - w0)
    return 0.5 * s


def pixel_polygon(F: float, D: float, L1: float, ch: dict, c: float, theta: float,
                  f: float) -> Poly:
    """The 1-D integration region (u, w) of the pixel with offset theta under the lens at
    c of type focal length f (§4 with the reference plane L_1), counter-clockwise."""
    L, v, mu, d = ch["L"], ch["v"], ch["mu"], ch["d"]
    a, b = L / L1, 1.0 - L / L1  # x = a u + b w
    alpha = 1.0 + v / L - v / f
    s = c * (1.0 + v / L) + theta
    rest = s - (v / f) * c
    # aperture strip x lens strip: a parallelogram, counter-clockwise in (u, w) (a > 0)
    poly: Poly = [((x - b * w) / a, w) for x, w in
                  ((c - d / 2, -D / 2), (c + d / 2, -D / 2), (c + d / 2, D / 2),
                   (c - d / 2, D / 2))]
    npx = (alpha * a, alpha * b - v / L)  # s' - (v/f) c = npx . (u, w)
    poly = clip(poly, npx, rest + mu / 2)
    return clip(poly, (-npx[0], -npx[1]), -(rest - mu / 2))


def axis_weights(F: float, D: float, L1: float, ch: dict, K: int, f: float, z: float,
                 edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inside, total): inside[p, i] the measure of pixel p's 1-D polygon (p = j Q + q
    along one axis, K lenses) whose scene position at depth z lies in [edges[i],
    edges[i + 1]]; total[p] its whole measure."""
    Q, d, mu = ch["Q"], ch["d"], ch["mu"]
    kz = 1.0 - z / F + z / L1  # X = kz w - (z / L1) u
    nX = (-z / L1, kz)
    inside = np.zeros((K * Q, edges.size - 1))
    total = np.zeros(K * Q)
    for j in range(K):
        c = d * (j - (K - 1) / 2.0)
        for q in range(Q):
            p = j * Q + q
            poly = pixel_polygon(F, D, L1, ch, c, mu * (q - (Q - 1) / 2.0), f)
            full = area(poly)
            total[p] = full
            if full <= 0.0:
                continue
            X = [nX[0] * u + nX[1] * w for u, w in poly]
            lo, hi = min(X), max(X)
            below = np.empty(edges.size)  # measure with X <= edge
            for i, e in enumerate(edges):
                if e <= lo:
                    below[i] = 0.0
                elif e >= hi:
                    below[i] = full
                else:
                    below[i] = area(clip(poly, nX, e))
            inside[p] = np.diff(below)
    return inside, total


def exact_raw(design: Any, channel: int, z: float, image: np.ndarray,
              extent: tuple[float, float, float, float]) -> np.ndarray:
    """The raw of ``channel`` (from 1) for an image texture (row 0 at the top) over
    ``extent`` = (X0, X1, Y0, Y1) on the fronto-parallel plane at depth ``z``; beyond the
    image the albedo is its mean (§10). Requires a rect grid, a square aperture and the
    ideal layout."""
    if design.aperture != "square":
        raise ValueError("the exact route needs a square aperture")
    chs = design.resolved()
    ch, L1, mu1 = chs[channel - 1], chs[0]["L"], chs[0]["mu"]
    if ch["grid"] != "rect" or ch["layout"] != "ideal":
        raise ValueError("the exact route needs a rect grid and the ideal layout")
    image = np.asarray(image, dtype=np.float64)
    rows, cols = image.shape
    X0, X1, Y0, Y1 = extent
    xe = X0 + (X1 - X0) * np.arange(cols + 1) / cols
    ye = Y0 + (Y1 - Y0) * np.arange(rows + 1) / rows  # ascending Y: row rows-1 first
    Kx, Ky, Q = ch["Kx"], ch["Ky"], ch["Q"]
    types = lens_types(ch)  # [k, j]
    raw = np.zeros((Ky * Q, Kx * Q))
    mean = image.mean()
    for t, f in enumerate(ch["f"]):
        if not np.any(types == t):
            continue
        ix, tx = axis_weights(design.F, design.D, L1, ch, Kx, f, z, xe)
        iy, ty = axis_weights(design.F, design.D, L1, ch, Ky, f, z, ye)
        iy = iy[:, ::-1]  # column r of iy: texture row r (row 0 the largest Y)
        inner = iy @ image @ ix.T
        rest = np.outer(ty, tx) - np.outer(iy.sum(axis=1), ix.sum(axis=1))
        full = inner + mean * rest
        mask = np.kron(types == t, np.ones((Q, Q), dtype=bool))
        raw[mask] = full[mask]
    return raw * ch["share"] / (mu1 ** 2 * design.D ** 2)


def exact_white(design: Any, channel: int, z: float = 1000.0) -> np.ndarray:
    """The raw of ``channel`` under a white albedo (any depth: the value is the ray-set
    measure)."""
    return exact_raw(design, channel, z, np.ones((1, 1)), (-1.0, 1.0, -1.0, 1.0))


def view_extent(design: Any, channel: int, z: float) -> tuple[float, float, float, float]:
    """(X0, X1, Y0, Y1): the rectangle of the plane at depth z seen by the channel's
    pixels (from the vertices of every pixel polygon), for sizing test textures."""
    chs = design.resolved()
    ch, L1 = chs[channel - 1], chs[0]["L"]
    kz = 1.0 - z / design.F + z / L1
    out = []
    for K in (ch["Kx"], ch["Ky"]):
        X = []
        for f in ch["f"]:
            for j in (0, K - 1):
                c = ch["d"] * (j - (K - 1) / 2.0)
                for q in range(ch["Q"]):
                    theta = ch["mu"] * (q - (ch["Q"] - 1) / 2.0)
                    poly = pixel_polygon(design.F, design.D, L1, ch, c, theta, f)
                    X += [kz * w - (z / L1) * u for u, w in poly]
        out += [min(X), max(X)]
    return out[0], out[1], out[2], out[3]


def x_texture_integral(poly: Poly, nX: tuple[float, float], texture: tuple) -> float:
    """The integral over a pixel's 1-D polygon (u, w) of T(X), X = nX . (u, w), for a
    texture of X only: ("sinusoid", f, mean, amplitude, phase) or ("bars", f, low, high).
    Not by Green's theorem (the package's route): the measure with X <= s, A(s), is
    quadratic in s between the vertices' X, so its density is linear there (from three
    clipped areas); bars are summed exactly over the pieces cut also at their edges, a
    sinusoid by 48-point Gauss-Legendre on parts of the pieces of at most 1/4 period."""
    X = sorted({nX[0] * u + nX[1] * w for u, w in poly})
    total = 0.0
    nodes, weights = np.polynomial.legendre.leggauss(48)
    for a, b in zip(X[:-1], X[1:], strict=True):
        if b - a <= 1e-15 * max(1.0, abs(a)):
            continue
        if texture[0] == "bars":
            f, low, high = texture[1:]
            k0, k1 = math.floor(2 * f * a), math.ceil(2 * f * b)
            cuts = [a, *[k / (2 * f) for k in range(k0 + 1, k1) if a < k / (2 * f) < b], b]
            for s0, s1 in zip(cuts[:-1], cuts[1:], strict=True):
                m = 0.5 * (s0 + s1)
                value = high if (f * m) % 1.0 < 0.5 else low
                total += value * (area(clip(poly, nX, s1)) - area(clip(poly, nX, s0)))
            continue
        f, mean, amp, phase = texture[1:]
        A0, A1 = area(clip(poly, nX, a)), area(clip(poly, nX, b))
        m, h = 0.5 * (a + b), b - a
        Am = area(clip(poly, nX, m))
        mean_density = (A1 - A0) / h
        slope = -8.0 * (Am - 0.5 * (A0 + A1)) / h ** 2
        n_sub = max(1, math.ceil(4 * f * h))  # sub-intervals of at most 1/4 period
        for s0 in a + h * np.arange(n_sub) / n_sub:
            s = s0 + 0.5 * (h / n_sub) * (1.0 + nodes)
            density = mean_density + slope * (s - m)
            T = mean + amp * np.sin(2 * math.pi * f * s + phase)
            total += 0.5 * (h / n_sub) * float(np.sum(weights * T * density))
    return total


def exact_raw_x(design: Any, channel: int, z: float, texture: tuple) -> np.ndarray:
    """The raw of ``channel`` (from 1) for a texture of X only (see
    :func:`x_texture_integral`) on the fronto-parallel plane at depth z: per type, the x
    polygons' integrals times the y polygons' measures."""
    chs = design.resolved()
    ch, L1, mu1 = chs[channel - 1], chs[0]["L"], chs[0]["mu"]
    Kx, Ky, Q, d, mu = ch["Kx"], ch["Ky"], ch["Q"], ch["d"], ch["mu"]
    nX = (-z / L1, 1.0 - z / design.F + z / L1)
    types = lens_types(ch)
    raw = np.zeros((Ky * Q, Kx * Q))
    for t, f in enumerate(ch["f"]):
        ix = np.zeros(Kx * Q)
        for j in range(Kx):
            for q in range(Q):
                poly = pixel_polygon(design.F, design.D, L1, ch, d * (j - (Kx - 1) / 2.0),
                                     mu * (q - (Q - 1) / 2.0), f)
                ix[j * Q + q] = x_texture_integral(poly, nX, texture) if area(poly) > 0 else 0
        _, ty = axis_weights(design.F, design.D, L1, ch, Ky, f, z, np.array([0.0, 1.0]))
        mask = np.kron(types == t, np.ones((Q, Q), dtype=bool))
        raw[mask] = np.outer(ty, ix)[mask]
    return raw * ch["share"] / (mu1 ** 2 * design.D ** 2)
