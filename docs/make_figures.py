"""Render the figures of docs/ (Agg backend, no display): python docs/make_figures.py"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import splitlf  # noqa: E402
import splitlf.plot  # noqa: E402

HERE = Path(__file__).resolve().parent


def ray_space() -> Path:
    ax = splitlf.plot.ray_space(splitlf.Camera.paper())
    out = HERE / "ray_space.png"
    ax.figure.savefig(out, dpi=150)
    plt.close(ax.figure)
    return out


if __name__ == "__main__":
    for make in (ray_space,):
        print(make())
