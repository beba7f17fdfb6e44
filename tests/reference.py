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


def chief_w(ch: dict, theta: np.ndarray) -> np.ndarray:
    """Chief ray's main-lens height w = -(L/v) theta (2-D)."""
    return -(ch["L"] / ch["v"]) * theta


def lit_mask(D: float, aperture: str, w: np.ndarray) -> np.ndarray:
    """w strictly inside the aperture of width D: square |w_x|, |w_y| < D/2, circle
    |w| < D/2."""
    r = D / 2.0
    if aperture == "square":
        return (np.abs(w[..., 0]) < r) & (np.abs(w[..., 1]) < r)
    return w[..., 0] * w[..., 0] + w[..., 1] * w[..., 1] < r * r


def conjugate(F: float, z):
    """Eq. 1: z' = F z / (z - F)."""
    return F * z / (z - F)


def chief_samples_2d(design, channel: int, z: float) -> dict[str, np.ndarray]:
    """Chief samples in 2-D of every pixel of a channel (from 1): X = -(z/L) [c + w (L -
    z')/z'] (NaN where unlit), lit (chief ray inside the aperture and, sensor layout, the
    pixel in its lens's image cell), lens (j, k) and type."""
    ch = design.resolved()[channel - 1]
    jj, kk, theta, in_cell = pixel_lenses(ch)
    w = chief_w(ch, theta)
    lit = in_cell & lit_mask(design.D, design.aperture, w)
    L = ch["L"]
    zc = conjugate(design.F, z)
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
