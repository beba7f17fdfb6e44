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

Run: python docs/make_fig2_slanted.py [--cache DIR] (two noise draws of the same
Monte-Carlo image, each camera at its data-chosen weight; the time is in the JSON).
"""

from __future__ import annotations

import argparse
import json
import pickle
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
DRAWS = 2  # photon-noise draws of the same Monte-Carlo image


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
           ) -> list[splitlf.Raw]:
    """The Monte-Carlo raw's noise draws (DRAWS): the first drawn in the renderer's own
    stream (channel 1's rays, its noise, channel 2's rays, its noise: the raw of the runs
    before 2026-11-29 bit for bit), the others from the same noise-free images."""
    path = None if cache is None else cache / "fig2_slanted_clean.npz"
    if path is not None and path.exists():
        with np.load(path) as f:
            clean = [f["ch1"], f["ch2"]]
            first = [f["noisy1"], f["noisy2"]]
    else:
        sc = scene(("image", [-WIDTH / 2, WIDTH / 2, -HEIGHT / 2, HEIGHT / 2], tex),
                   ("plane", [p.z0, p.gx, p.gy]), float(tex.mean()))
        rng = np.random.default_rng(2026)
        clean, first = [], []
        for ch in (1, 2):
            clean.append(mc_channel(d, ch, sc, n_side=5, rng=rng))
            first.append(rng.poisson(NOISE["photons"] * clean[-1]) / NOISE["photons"])
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(path, ch1=clean[0], ch2=clean[1], noisy1=first[0], noisy2=first[1])
    raws = [splitlf.Raw(d, tuple(first), noise=NOISE)]
    for k in range(1, DRAWS):
        rng = np.random.default_rng(2026 + k)
        raws.append(splitlf.Raw(d, tuple(rng.poisson(NOISE["photons"] * c)
                                         / NOISE["photons"] for c in clean), noise=NOISE))
    return raws


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


def one_band(band: tuple, raws: list[splitlf.Raw], p: splitlf.Plane,
             truth_tex: splitlf.Image, t0: float) -> dict:
    """One band: each camera reconstructed from every draw at its data-chosen weight, the
    depth estimated from the first draw; what the JSON and the figure need of it."""
    zm, region, step = band
    row: dict[str, Any] = {"depth": zm, "region": list(region), "step": step, "psnr": {},
                           "ssim": {}, "regularization": {}, "seconds": {}}
    shown = {}
    for name, chans in CAMERAS.items():
        got, secs = [], []
        for raw in raws:
            t1 = time.perf_counter()
            got.append(splitlf.reconstruct(raw, p, region=region, step=step,
                                           channels=chans, progress=False,
                                           allow_slow=True))
            secs.append(time.perf_counter() - t1)
        shown[name] = SimpleNamespace(extent=got[0].extent, image=got[0].image)
        row["psnr"][name] = [measure.psnr(r, truth_tex) for r in got]
        row["ssim"][name] = [measure.ssim(r, truth_tex) for r in got]
        row["regularization"][name] = [r.regularization for r in got]
        row["seconds"][name] = secs
        print(f"  {zm:.0f} mm {name}: " + ", ".join(
            f"{v:.2f} dB (lambda {lam:.3g}, {t:.0f} s)" for v, lam, t in
            zip(row["psnr"][name], row["regularization"][name], secs, strict=True)),
            flush=True)
    est = splitlf.estimate_depth(raws[0], depths=(250.0, 3000.0), region=region,
                                 step=DEPTH_STEP, progress=False)
    x0, x1, y0, y1 = est.extent
    ny = est.depth.shape[0]
    ys = y1 - (np.arange(ny) + 0.5) * (y1 - y0) / ny
    true = (p.z0 + p.gy * ys)[:, None] * np.ones(est.depth.shape)
    rel = np.abs(est.depth - true) / true
    e = measure.depth_errors(est, p)
    row["depth_errors"] = e
    print(f"{zm:.0f} mm: {time.perf_counter() - t0:.0f} s, depth median "
          f"{100 * e['median']:.2f} %", flush=True)
    return {"row": row, "recs": shown,
            "depth_view": SimpleNamespace(extent=est.extent, image=np.where(
                est.confident, est.depth, np.nan)),
            "error_view": SimpleNamespace(extent=est.extent, image=np.where(
                est.confident, 100.0 * rel, np.nan))}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", type=Path, default=None,
                    help="a folder to keep the rendered raw and each band in between runs")
    ap.add_argument("--order", type=lambda v: [int(b) for b in v.split(",")],
                    default=[3, 2, 4, 1, 5, 6, 7, 0],
                    help="the bands to run, in this order (numbered from 0, nearest "
                         "first; default: from the out-of-focus plane's band outwards)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    d = design()
    p, theta = plane(d)
    tex = texture(p, theta)
    truth_tex = splitlf.Image(tex, WIDTH)
    raws = render(d, p, tex, args.cache)
    print(f"raw: {time.perf_counter() - t0:.0f} s", flush=True)

    every = bands(d, p)
    done: dict[int, dict] = {}
    for k in args.order:  # each band kept in the cache as it is done
        path = None if args.cache is None else args.cache / f"fig2_slanted_band{k}.pkl"
        if path is not None and path.exists():
            done[k] = pickle.loads(path.read_bytes())
            continue
        done[k] = one_band(every[k], raws, p, truth_tex, t0)
        if path is not None:
            path.write_bytes(pickle.dumps(done[k]))
    if len(done) < len(every):
        print(f"bands done: {sorted(done)}; the JSON and figure need all {len(every)}")
        return
    rows = [done[k]["row"] for k in range(len(every))]
    recs = {n: [done[k]["recs"][n] for k in range(len(every))] for n in CAMERAS}
    depth_views = [done[k]["depth_view"] for k in range(len(every))]
    error_views = [done[k]["error_view"] for k in range(len(every))]
    out = {"plane": {"z0": p.z0, "gx": p.gx, "gy": p.gy}, "bands": rows,
           "photons": NOISE["photons"], "mc_rays_per_pixel": 5 ** 4, "draws": DRAWS,
           "note": "psnr, ssim, regularization, seconds: one entry per noise draw; the "
                   "images and depth shown are the first draw's; each camera's weight "
                   "chosen from the data (regularization=None), the raw carrying its "
                   "noise",
           "seconds": sum(sum(sum(v) for v in r["seconds"].values()) for r in rows)}
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
    psnr_axes(fig.add_subplot(gs[0, 6]), mids, {n: [float(np.mean(r["psnr"][n])) for r in rows]
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
