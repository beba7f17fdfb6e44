"""Render docs/fig2_slanted.png and docs/fig2_slanted.json: the paper's Fig. 2 itself --
one slanted plane from 330 mm to 1.85 m -- reconstructed with the known plane, and the
depth estimated from the same raw.

- Camera: the seed design cut to 16 lenses across (its full 88 lens rows: a plane that
  runs from 300 mm to 2 m across the field must be seen over the whole height; the field
  is +-2.7 degrees, so even then the plane lies 3.6 degrees off the optical axis).
- Scene: the plane Z = z0 + gy Y through 300 mm at the bottom of half 2's field and 2 m
  at its top, carrying a photograph (scikit-image's "camera") laid on it so that the
  camera sees it undistorted (each 0.1 mm texture cell takes the photograph's value at its
  view angle (X/Z, Y/Z), bilinear).
- Data: the independent Monte-Carlo renderer of the tests (tests/mc_render.py's
  mc_channel, plain NumPy, every ray traced to the slanted plane: 5^4 stratified rays a
  pixel), then Poisson photon noise (N = 2000 photo-electrons for white). Neither the
  renderer nor the texture is the reconstruction's model: no inverse crime.
- Images: eight bands of depth (a ratio of 1.24 each), each reconstructed
  (splitlf.reconstruct with the splitlf.Plane: the tilted route, docs/reconstruct.md)
  on cells of delta(z) at the band's middle depth, over the central half (per axis) of
  what both arrays image at its near depth: half 1 alone, half 2 alone, the split sensor.
- Depth: splitlf.estimate_depth on each band (candidates 250 mm to 3 m, 0.1 mm cells),
  its error against the true plane over the confident cells.

Run: python docs/make_fig2_slanted.py [--cache DIR] (about 40 minutes on 2 cores, nearly
all of it SciPy's CG).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import matplotlib

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.ndimage import map_coordinates  # noqa: E402
from skimage import data  # noqa: E402

import splitlf  # noqa: E402
from splitlf import measure  # noqa: E402

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "tests"))
from mc_render import mc_channel, scene  # noqa: E402

KX = 16
NEAR, FAR = 300.0, 2000.0  # the plane's depth at the bottom and top of half 2's field
SHOWN = (330.0, 1850.0)  # the bands' depth range (inside both halves' fields)
NOISE = {"photons": 2000.0, "read_noise": 0.0}
CELL, WIDTH, HEIGHT = 0.1, 36.0, 192.0  # the texture's cells and extent, mm
DEPTH_STEP = 0.1  # the depth map's cell pitch, mm
CAMERAS = {"half 1": (1,), "half 2": (2,), "split": (1, 2)}
BINS = np.geomspace(SHOWN[0], SHOWN[1], 9)  # the bands' depth edges


def design() -> splitlf.Design:
    seed = splitlf.Design.preset("seed")
    return seed.replace(channels=tuple(c.replace(Kx=KX) for c in seed.channels))


def plane(d: splitlf.Design) -> tuple[splitlf.Plane, float]:
    """The plane through NEAR at the bottom and FAR at the top of half 2's field (the
    narrower: its array sits further back), and that field's half-angle."""
    theta = min(c["Ky"] * c["d"] / 2.0 / c["L"] for c in d.resolved())
    gy = (FAR - NEAR) / (theta * (FAR + NEAR))
    return splitlf.Plane(NEAR + gy * theta * NEAR, 0.0, gy), theta


def texture(p: splitlf.Plane, theta: float) -> np.ndarray:
    """The photograph as the camera sees it: each texture cell takes the photograph's value
    at its view angle (X/Z, Y/Z), the photograph spanning the field's height."""
    cols, rows = round(WIDTH / CELL), round(HEIGHT / CELL)
    X = (np.arange(cols) + 0.5) * CELL - WIDTH / 2.0
    Y = HEIGHT / 2.0 - (np.arange(rows) + 0.5) * CELL
    Xg, Yg = np.meshgrid(X, Y)
    return photograph(p, 1.05 * theta, Xg, Yg)


def photograph(p: splitlf.Plane, t: float, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The photograph's albedo (0.1 to 0.9) at the points (X, Y) of the plane, taken at
    their view angles (X/Z, Y/Z): the photograph spans view angles -t to t in Y (and in
    X, centred), bilinear, mirrored beyond."""
    Z = p.z0 + p.gx * X + p.gy * Y
    photo = data.camera().astype(np.float64) / 255.0
    n = photo.shape[0] - 1
    u = (X / Z / (2.0 * t) + 0.5) * n
    v = (t - Y / Z) / (2.0 * t) * n
    return 0.1 + 0.8 * map_coordinates(photo, [v, u], order=1, mode="reflect")


def render(d: splitlf.Design, p: splitlf.Plane, tex: np.ndarray, cache: Path | None
           ) -> splitlf.Raw:
    path = None if cache is None else cache / "fig2_slanted_raw.npz"
    if path is not None and path.exists():
        return splitlf.Raw.load(path)
    sc = scene(("image", [-WIDTH / 2, WIDTH / 2, -HEIGHT / 2, HEIGHT / 2], tex),
               ("plane", [p.z0, p.gx, p.gy]), float(tex.mean()))
    rng = np.random.default_rng(2026)
    images = []
    for ch in (1, 2):
        clean = mc_channel(d, ch, sc, n_side=5, rng=rng)
        images.append(rng.poisson(NOISE["photons"] * clean) / NOISE["photons"])
    raw = splitlf.Raw(d, tuple(images))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        raw.save(path)
    return raw


def bands(d: splitlf.Design, p: splitlf.Plane) -> list[tuple[float, tuple, float]]:
    """(middle depth, region, step) of each band: depths in BINS, the cell pitch
    delta(z) at the band's middle depth, the central half (per axis) of what both arrays
    image across at its near depth."""
    out = []
    for zlo, zhi in zip(BINS[:-1], BINS[1:], strict=True):
        zm = float(np.sqrt(zlo * zhi))
        hx = min(zlo / c["L"] * c["Kx"] * c["d"] for c in d.resolved()) / 4.0
        out.append((zm, (-hx, hx, (zlo - p.z0) / p.gy, (zhi - p.z0) / p.gy),
                    d.resolution_step(zm)))
    return out


def view(recs: list[splitlf.Reconstruction], p: splitlf.Plane, ty: np.ndarray,
         tx: np.ndarray) -> np.ndarray:
    """The bands' cells seen from the camera: each display pixel (tx, ty) takes the cell
    under the view ray's point on the plane (nearest cell: pixelisation stays visible)."""
    out = np.full((ty.size, tx.size), np.nan)
    for r in recs:
        x0, x1, y0, y1 = r.extent
        ny, nx = r.image.shape
        zlo, zhi = p.z0 + p.gy * y0, p.z0 + p.gy * y1
        sel = np.flatnonzero((ty >= y0 / zlo) & (ty < y1 / zhi))
        for i in sel:
            Y = p.z0 * ty[i] / (1.0 - p.gy * ty[i])  # Y / (z0 + gy Y) = ty
            X = tx * (p.z0 + p.gy * Y)
            row = min(int((y1 - Y) / (y1 - y0) * ny), ny - 1)
            col = np.clip(((X - x0) / (x1 - x0) * nx).astype(int), 0, nx - 1)
            out[i] = r.image[row, col]
    return out


def display_grid(d: splitlf.Design, p: splitlf.Plane) -> tuple[np.ndarray, np.ndarray]:
    """The view angles (ty from the top, tx) of the display: the bands' depth range in Y,
    the central half of the arrays' field in X, square display pixels."""
    tyb = (SHOWN[0] - p.z0) / p.gy / SHOWN[0]
    tyt = (SHOWN[1] - p.z0) / p.gy / SHOWN[1]
    txw = min(c["Kx"] * c["d"] / c["L"] for c in d.resolved()) / 4.0
    ty = np.linspace(tyt, tyb, 900)
    return ty, np.linspace(-txw, txw, int(900 * 2 * txw / (tyt - tyb)))


def show_view(ax: Any, image: np.ndarray, ty: np.ndarray, tx: np.ndarray, p: splitlf.Plane,
              title: str, depth_ticks: bool, cmap: str = "gray",
              limits: tuple[float, float] = (0.0, 1.0)) -> Any:
    """One panel of the camera's view, labelled with depths on the plane when asked."""
    im = ax.imshow(image, cmap=cmap, vmin=limits[0], vmax=limits[1], aspect="auto",
                   extent=(tx[0], tx[-1], ty[-1], ty[0]), interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set_xticks([])
    zmark = [400, 500, 642, 800, 1000, 1400]
    if depth_ticks:
        ax.set_yticks([(z - p.z0) / p.gy / z for z in zmark])
        ax.set_yticklabels([f"{z:.0f} mm" for z in zmark], fontsize=8)
    else:
        ax.set_yticks([])
    return im


def psnr_axes(ax: Any, mids: list[float], series: dict[str, list[float]]) -> None:
    """PSNR against the bands' middle depths, half 1's out-of-focus plane marked."""
    for name, values in series.items():
        ax.plot(mids, values, "o-", ms=3, label=name)
    ax.axvline(642.0, color="tab:red", lw=0.8, ls=":", label="half 1's out-of-focus plane")
    ax.set_xscale("log")
    ax.set_ylabel("PSNR (dB)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", type=Path, default=None,
                    help="a folder to keep the rendered raw in between runs")
    args = ap.parse_args()
    t0 = time.perf_counter()
    d = design()
    p, theta = plane(d)
    tex = texture(p, theta)
    truth_tex = splitlf.Image(tex, WIDTH)
    raw = render(d, p, tex, args.cache)
    print(f"raw: {time.perf_counter() - t0:.0f} s", flush=True)

    recs: dict[str, list] = {name: [] for name in CAMERAS}
    depth_views, error_views, rows = [], [], []
    for zm, region, step in bands(d, p):
        for name, chans in CAMERAS.items():
            recs[name].append(splitlf.reconstruct(raw, p, region=region, step=step,
                                                  channels=chans, noise=NOISE,
                                                  progress=False))
        est = splitlf.estimate_depth(raw, depths=(250.0, 3000.0), region=region,
                                     step=DEPTH_STEP, progress=False)
        x0, x1, y0, y1 = est.extent
        ny = est.depth.shape[0]
        ys = y1 - (np.arange(ny) + 0.5) * (y1 - y0) / ny
        true = (p.z0 + p.gy * ys)[:, None] * np.ones(est.depth.shape)
        rel = np.abs(est.depth - true) / true
        depth_views.append(SimpleNamespace(extent=est.extent, image=np.where(
            est.confident, est.depth, np.nan)))
        error_views.append(SimpleNamespace(extent=est.extent, image=np.where(
            est.confident, 100.0 * rel, np.nan)))
        e = measure.depth_errors(est, p)
        row = {"depth": zm, "region": list(region), "step": step,
               "psnr": {n: measure.psnr(recs[n][-1], truth_tex) for n in CAMERAS},
               "ssim": {n: measure.ssim(recs[n][-1], truth_tex) for n in CAMERAS},
               "depth_errors": e}
        rows.append(row)
        print(f"{zm:.0f} mm: {time.perf_counter() - t0:.0f} s  "
              + " ".join(f"{n} {v:.1f} dB" for n, v in row["psnr"].items())
              + f"  depth median {100 * e['median']:.2f} %", flush=True)
    out = {"plane": {"z0": p.z0, "gx": p.gx, "gy": p.gy}, "bands": rows,
           "photons": NOISE["photons"], "mc_rays_per_pixel": 5 ** 4,
           "seconds": time.perf_counter() - t0}
    (HERE / "fig2_slanted.json").write_text(json.dumps(out, indent=1))

    # the figure: the images and the depth as the camera sees them, and against depth
    ty, tx = display_grid(d, p)
    fig = plt.figure(figsize=(13, 7.4))
    gs = fig.add_gridspec(2, 7, width_ratios=[1, 1, 1, 1, 1, 0.12, 2.6])
    panels = [(n, recs[n], "gray", (0.0, 1.0)) for n in CAMERAS] + [
        ("depth from the raw (mm)", depth_views, "viridis", (SHOWN[0], SHOWN[1])),
        ("its error (%)", error_views, "magma", (0.0, 10.0))]
    for k, (name, r, cmap, (lo, hi)) in enumerate(panels):
        ax = fig.add_subplot(gs[:, k])
        im = show_view(ax, view(r, p, ty, tx), ty, tx, p, name, k == 0, cmap, (lo, hi))
        if k >= 3:
            fig.colorbar(im, ax=ax, orientation="horizontal", pad=0.02, fraction=0.04)
        ax.axhline((642.0 - p.z0) / p.gy / 642.0, color="tab:red", lw=0.6, ls=":")
    mids = [r["depth"] for r in rows]
    psnr_axes(fig.add_subplot(gs[0, 6]), mids, {n: [r["psnr"][n] for r in rows]
                                                 for n in CAMERAS})
    ax = fig.add_subplot(gs[1, 6])
    ax.plot(mids, [100 * r["depth_errors"]["median"] for r in rows], "o-", label="median")
    ax.plot(mids, [100 * r["depth_errors"]["p90"] for r in rows], "s--",
            label="90th percentile")
    ax.axvline(642.0, color="tab:red", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("depth on the plane (mm)")
    ax.set_ylabel("depth error, confident cells (%)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    fig.suptitle("One slanted plane, 330 mm (bottom) to 1.85 m (top), 3.6 degrees off the "
                 "axis: the seed cut to 16 x 88 lenses a half; Monte-Carlo raw, N = 2000",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(HERE / "fig2_slanted.png", dpi=110)
    plt.close(fig)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
