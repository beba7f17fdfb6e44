"""Render docs/fig2.png and docs/fig2.json: the paper's Fig. 2 question, per depth.

The seed design cut to 24 x 16 lenses per half and a conventional camera on the same
sensor (one half's pixels, all the light, focused where half 1's array is imaged: 642 mm)
look at fronto-parallel planes from 300 mm to 2 m. At each depth two scenes are rendered
(splitlf.render, exact route) with photon noise (N = 2000 photo-electrons for white):
a natural image (scikit-image's "camera", 512 x 512 texture cells, each well under a tenth
of the reconstruction's cell) and a 5-degree slanted edge (analytic, no cells at all).
Neither is representable on the reconstruction's grid (the grid is delta(z), the sensor's
step; the data's texture is finer or continuous): no inverse crime. Each raw is
reconstructed with the known depth (splitlf.reconstruct, the noise model given) from
half 1 alone, half 2 alone, the split sensor, and the conventional camera, over the same
region (the central half, per axis, of what both arrays image), and measured against the truth
(splitlf.measure: PSNR on the image, MTF50 on the edge).

Run: python docs/make_fig2.py (about 5 minutes on 2 cores).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from skimage import data  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native, measure  # noqa: E402

HERE = Path(__file__).parent
DEPTHS = (300.0, 400.0, 500.0, 642.0, 800.0, 1000.0, 1400.0, 2000.0)
SHOWN = (400.0, 642.0, 1000.0)
NOISE = {"photons": 2000.0, "read_noise": 0.0}
CAMERAS = ("half 1", "half 2", "split", "conventional")


def designs() -> tuple[splitlf.Design, splitlf.Design]:
    seed = splitlf.Design.preset("seed")
    cut = seed.replace(channels=tuple(c.replace(Kx=24, Ky=16) for c in seed.channels))
    ch = cut.channels[0]
    q = round(ch.d / ch.mu)
    conv = splitlf.Design(F=seed.F, D=seed.D, aperture=seed.aperture, channels=(
        splitlf.Channel(L=ch.L, d=ch.mu, v=ch.mu * ch.L / seed.D, mu=ch.mu,
                        Kx=24 * q, Ky=16 * q, Q=1),))
    return cut, conv


def central(design: splitlf.Design, z: float) -> tuple[float, float, float, float]:
    """The central half (per axis) of the plane's part that both arrays image, (z/L) x the
    array's extent: a fixed share of the field at every depth."""
    hx = min(z / c["L"] * c["Kx"] * c["d"] for c in design.resolved()) / 4.0
    hy = min(z / c["L"] * c["Ky"] * c["d"] for c in design.resolved()) / 4.0
    return (-hx, hx, -hy, hy)


def natural(width: float) -> splitlf.Image:
    img = data.camera().astype(np.float64) / 255.0
    return splitlf.Image(0.1 + 0.8 * img, width)


def main() -> None:
    t0 = time.perf_counter()
    split, conv = designs()
    out: dict = {"depths": list(DEPTHS), "psnr": {c: [] for c in CAMERAS},
                 "mtf50": {c: [] for c in CAMERAS}, "nyquist": [], "region": []}
    shown: dict = {}
    for i, z in enumerate(DEPTHS):
        region = central(split, z)
        span = _native.pixel_span(split.core, z, None)
        tex = natural(2.0 * (max(abs(v) for v in region) + 2.0 * span))
        edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
        step = split.resolution_step(z)
        out["nyquist"].append(1.0 / (2.0 * step))
        out["region"].append(list(region))
        for scene_i, texture in enumerate((tex, edge)):
            sc = splitlf.Scene(texture, z)
            raws = {"split": splitlf.render(split, sc, noise=NOISE, seed=10 * i + scene_i),
                    "conventional": splitlf.render(conv, sc, noise=NOISE,
                                                   seed=10 * i + scene_i + 5)}
            for cam in CAMERAS:
                raw = raws["conventional" if cam == "conventional" else "split"]
                channels = {"half 1": 1, "half 2": 2}.get(cam)
                rec = splitlf.reconstruct(raw, z, region=region, channels=channels,
                                          noise=NOISE)
                measured(out, shown, cam, rec, texture, z in SHOWN)
        print(f"{z:6.0f} mm  " + "  ".join(
            f"{c}: {out['psnr'][c][-1]:5.1f} dB {out['mtf50'][c][-1]:6.2f} c/mm"
            for c in CAMERAS), flush=True)
    (HERE / "fig2.json").write_text(json.dumps(out, indent=1) + "\n")
    figure(out, shown)
    print(f"docs/fig2.png, docs/fig2.json in {time.perf_counter() - t0:.0f} s")


def measured(out: dict, shown: dict, cam: str, rec: splitlf.Reconstruction, texture: Any,
             show: bool) -> None:
    """A reconstruction's measure into ``out``: PSNR of the natural image (kept in
    ``shown`` with its truth when ``show``), MTF50 of the slanted edge."""
    if isinstance(texture, splitlf.SlantedEdge):
        out["mtf50"][cam].append(measure.mtf50(rec, texture))
        return
    out["psnr"][cam].append(measure.psnr(rec, texture))
    if show:
        z = rec.depth
        shown[z, cam] = rec.image
        shown[z, "truth"] = measure.truth(rec, texture)


def image_rows(fig: plt.Figure, grid: Any, shown: dict, cols: tuple[str, ...],
               depths: tuple[float, ...]) -> None:
    """A row of grey images per depth (``shown[z, column]``), a column per camera."""
    for r, z in enumerate(depths):
        for c, cam in enumerate(cols):
            ax = fig.add_subplot(grid[r, c])
            ax.imshow(shown[z, cam], cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(cam)
            if c == 0:
                ax.set_ylabel(f"{z:.0f} mm")


def figure(out: dict, shown: dict) -> None:
    cols = ("truth",) + CAMERAS
    fig = plt.figure(figsize=(12, 10.5), layout="constrained")
    grid = fig.add_gridspec(len(SHOWN) + 1, len(cols), height_ratios=[1] * len(SHOWN) + [1.3])
    image_rows(fig, grid, shown, cols, SHOWN)
    z = np.array(out["depths"])
    nyq = np.array(out["nyquist"])
    ax_m = fig.add_subplot(grid[-1, : len(cols) // 2 + 1])
    ax_p = fig.add_subplot(grid[-1, len(cols) // 2 + 1:])
    for cam, style in zip(CAMERAS, ("-o", "-s", "-^", "--d"), strict=True):
        ax_m.plot(z, np.array(out["mtf50"][cam]) / nyq, style, label=cam, ms=4)
        ax_p.plot(z, out["psnr"][cam], style, label=cam, ms=4)
    for ax in (ax_m, ax_p):
        ax.set_xscale("log")
        ax.set_xlabel("depth z [mm]")
        ax.axvline(642.0, color="0.7", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
    ax_m.set_ylabel("MTF50 / sensor Nyquist 1/(2 delta(z))")
    ax_p.set_ylabel("PSNR [dB]")
    ax_m.legend(fontsize=8)
    fig.suptitle("Seed (24 x 16 lenses per half), photon noise N = 2000, known depth: "
                 "half 1's out-of-focus band at 642 mm and the split sensor's cure")
    fig.savefig(HERE / "fig2.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
