"""Render docs/resolution.png: MTF50 and RMSE against depth for the seed design
(splitlf.plot.resolution, noise-free). Run: python docs/make_resolution_figure.py"""

from __future__ import annotations

import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402

import splitlf  # noqa: E402
from splitlf.plot import resolution  # noqa: E402


def main() -> None:
    t = time.perf_counter()
    a_mtf, _ = resolution(splitlf.Camera.paper(), (150.0, 10_000.0), n=30)
    a_mtf.figure.savefig(Path(__file__).with_name("resolution.png"), dpi=130)
    plt.close(a_mtf.figure)
    print(f"docs/resolution.png in {time.perf_counter() - t:.1f} s")


if __name__ == "__main__":
    main()
