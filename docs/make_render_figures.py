"""Render docs/render_seed.png and docs/render_r12.png: a raw of the seed and of a Raytrix
R12 (`raytrix-r12`, a quarter of its lenses and pixels per axis: the figure's cost) of the
same textured scene, each with a zoom on a few micro-images (splitlf.plot.raw).
Run: python docs/make_render_figures.py"""

from __future__ import annotations

import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import splitlf  # noqa: E402
from splitlf.plot import raw as plot_raw  # noqa: E402

HERE = Path(__file__).parent


def scene_texture(width: float) -> splitlf.Image:
    """A natural-looking grey image: smooth blobs, a few sharp discs and bars, a slanted
    edge; 480 x 640 cells over ``width`` mm (deterministic)."""
    rng = np.random.default_rng(7)
    rows, cols = 480, 640
    y, x = np.mgrid[0:rows, 0:cols] / cols
    img = 0.45 + 0.0 * x
    for _ in range(40):  # smooth blobs
        cx, cy = rng.uniform(0, 1), rng.uniform(0, 0.75)
        r, a = rng.uniform(0.02, 0.12), rng.uniform(-0.25, 0.25)
        img += a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * r * r))
    for _ in range(12):  # sharp discs
        cx, cy, r = rng.uniform(0, 1), rng.uniform(0, 0.75), rng.uniform(0.01, 0.04)
        img[(x - cx) ** 2 + (y - cy) ** 2 < r * r] = rng.uniform(0.05, 0.95)
    img[:, 300:340][(np.arange(rows) // 12 % 2 == 0)] = 0.9  # bars
    edge = (x - 0.78) * np.cos(0.09) - (y - 0.55) * np.sin(0.09) > 0
    img[(y > 0.45) & (y < 0.65) & (x > 0.7) & (x < 0.86)] = np.where(edge, 0.85, 0.15)[
        (y > 0.45) & (y < 0.65) & (x > 0.7) & (x < 0.86)]
    return splitlf.Image(np.clip(img, 0.0, 1.0), width)


def figure(design: splitlf.Design, z: float, name: str, zoom: int) -> None:
    t = time.perf_counter()
    ext = splitlf._native.render_extent(design.core, z)
    tex = scene_texture(1.05 * (ext[1] - ext[0]))
    raw = splitlf.render(design, splitlf.Scene(tex, z), progress=False)
    fig = plot_raw(raw, zoom=zoom)
    fig.savefig(HERE / name, dpi=110)
    plt.close(fig)
    print(f"docs/{name} in {time.perf_counter() - t:.1f} s")


def main() -> None:
    figure(splitlf.Design.preset("seed"), 1000.0, "render_seed.png", 4)
    r12 = splitlf.Design.preset("raytrix-r12")
    ch = r12.channels[0]
    quarter = r12.replace(channels=[ch.replace(Kx=ch.Kx // 4, Ky=ch.Ky // 4,
                                               Mx=ch.Mx // 4, My=ch.My // 4)])
    figure(quarter, 600.0, "render_r12.png", 4)


if __name__ == "__main__":
    main()
