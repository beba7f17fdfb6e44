"""Render docs/samples.png: distinct samples and max gap of the seed design, 150 mm - 10 m.

Run from the repository root: python docs/make_samples_figure.py
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # this script only; the library never selects a backend

import matplotlib.pyplot as plt  # noqa: E402

import splitlf  # noqa: E402
import splitlf.plot  # noqa: E402


def main() -> None:
    cam = splitlf.Camera.paper()
    ax_count, _ = splitlf.plot.samples(cam, (150.0, 10_000.0), n=1500, max_n=2)
    out = Path(__file__).with_name("samples.png")
    ax_count.figure.savefig(out, dpi=130)
    plt.close(ax_count.figure)
    print(out)


if __name__ == "__main__":
    main()
