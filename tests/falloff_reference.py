"""An independent quadrature of a white raw with radiometric falloff (docs/model.md §10),
plain NumPy, for designs with a rect grid, a square aperture and the ideal layout (the
seed).

A pixel's value is share (L_1/L)^2 / (mu_1^2 A) * int_{xi in cell} int_{w} W dw dxi over
the rays of its lens whose sensor point s = alpha x - (v/L) w + (v/f) c (x = c + xi) lies
in the pixel's square. For fixed xi that is a box of w per axis, (L/v)(alpha x + (v/f) c -
s_pix -+ mu/2), clipped by the aperture's square; its ends kink in xi where they cross the
aperture's edges. So: per axis, xi's interval cut at those kinks, Gauss-Legendre on each
piece; w Gauss-Legendre on its box. W = (v^2/(v^2 + |s - x|^2))^2 (microlens) times
(L^2/(L^2 + |x - w|^2))^2 (main lens) is smooth, and the rule converges exponentially.
Nothing here calls the package: the design's fields only, the lattice from reference.py.
"""

from __future__ import annotations

import numpy as np

from reference import lens_centres, lens_types


def _gl(a: float, b: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    t, wt = np.polynomial.legendre.leggauss(n)
    return 0.5 * (a + b) + 0.5 * (b - a) * t, 0.5 * (b - a) * wt


def _axis_nodes(lo: float, hi: float, kinks: list[float], n: int) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """Gauss-Legendre nodes and weights on [lo, hi] cut at the kinks inside it."""
    cuts = sorted({lo, hi, *(k for k in kinks if lo < k < hi)})
    parts = [_gl(a, b, n) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def white_pixel(design, channel: int, row: int, col: int, falloff: str | None,
                n: int = 24) -> float:
    """The value of raw pixel [row, col] of ``channel`` (from 1) under a white albedo with
    ``falloff`` (None, "microlens", "main", "both"): rect grid, square aperture, ideal
    layout only."""
    chs = design.resolved()
    ch, L1, mu1 = chs[channel - 1], chs[0]["L"], chs[0]["mu"]
    if ch["grid"] != "rect" or ch["layout"] != "ideal" or design.aperture != "square":
        raise ValueError("white_pixel: rect grid, ideal layout, square aperture only")
    L, v, mu, Q, r, h = ch["L"], ch["v"], ch["mu"], ch["Q"], design.D / 2.0, ch["d"] / 2.0
    k, qy = divmod(row, Q)
    j, qx = divmod(col, Q)
    c = lens_centres(ch)[k, j]
    f = np.asarray(ch["f"])[lens_types(ch)[k, j]]
    kappa = v / f
    alpha = 1.0 + v / L - kappa
    s_pix = c * (1.0 + v / L) + mu * (np.array([qx, qy], dtype=np.float64) - (Q - 1.0) / 2.0)
    xi_nodes = []
    for i in range(2):
        kinks = []
        if alpha != 0.0:
            for e in (-1.0, 1.0):
                for sgn in (-1.0, 1.0):
                    kinks.append(((v / L) * e * r + s_pix[i] + sgn * mu / 2.0
                                  - kappa * c[i]) / alpha - c[i])
        xi_nodes.append(_axis_nodes(-h, h, kinks, n))
    (xx, wx), (xy, wy) = xi_nodes
    XI = np.stack(np.meshgrid(xx, xy, indexing="ij"), axis=-1).reshape(-1, 2)
    WXI = np.outer(wx, wy).ravel()
    x = c + XI
    # the w box of each xi, per axis, clipped by the aperture
    lo = (L / v) * (alpha * x + kappa * c - s_pix - mu / 2.0)
    hi = (L / v) * (alpha * x + kappa * c - s_pix + mu / 2.0)
    lo, hi = np.maximum(np.minimum(lo, hi), -r), np.minimum(np.maximum(lo, hi), r)
    live = np.all(hi > lo, axis=1)
    t, tw = np.polynomial.legendre.leggauss(n)
    total = 0.0
    for xi_i in np.flatnonzero(live):
        a, b = lo[xi_i], hi[xi_i]
        w1 = 0.5 * (a[0] + b[0]) + 0.5 * (b[0] - a[0]) * t
        w2 = 0.5 * (a[1] + b[1]) + 0.5 * (b[1] - a[1]) * t
        W = np.stack(np.meshgrid(w1, w2, indexing="ij"), axis=-1).reshape(-1, 2)
        ww = np.outer(0.5 * (b[0] - a[0]) * tw, 0.5 * (b[1] - a[1]) * tw).ravel()
        s = alpha * x[xi_i] - (v / L) * W + kappa * c
        weight = np.ones(W.shape[0])
        if falloff in ("microlens", "both"):
            weight *= (v * v / (v * v + np.sum((s - x[xi_i]) ** 2, axis=1))) ** 2
        if falloff in ("main", "both"):
            weight *= (L * L / (L * L + np.sum((x[xi_i] - W) ** 2, axis=1))) ** 2
        total += WXI[xi_i] * float(ww @ weight)
    norm = ch["share"] * (L1 / L) ** 2 / (mu1 ** 2 * (2.0 * r) ** 2)
    return norm * total
