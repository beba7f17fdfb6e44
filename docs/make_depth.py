"""Render docs/depth.png and docs/depth.json: depth from the raw (docs/depth.md).

1. Error against depth. The seed design cut to 16 x 12 lenses per half looks at textured
   fronto-parallel planes from 250 mm to 2.5 m: i.i.d. albedo cells of 10 delta(z) (the
   same angular texture at every depth), rendered by splitlf.render (the forward model's
   exact route) with photon noise N = 2000. The estimator never uses the forward model
   (only the pixels' mean rays and their white values), so this is no inverse crime; the
   tests (tests/test_depth.py) repeat the 400 mm and 1 m cases on raws of the independent
   Monte-Carlo renderer. Candidates: 64 from 200 mm to 4 m, uniform in 1/z. Region: what
   half 1 sees through half its aperture at that depth (half 2's, where half 1 sees none).
   For the split sensor, half 1 alone and half 2 alone: median and 90th percentile of the
   relative error over confident cells, and the confident share.
2. A plane at 1 m whose texture is uniform grey on its left half (the exact route again):
   the split sensor's estimate, its error over confident cells, and which cells say they
   are not confident. (A scene of several depths goes through render's general route,
   which costs milliseconds a pixel: not in this script yet.)

Run: python docs/make_depth.py (a few minutes on 2 cores).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native, measure  # noqa: E402

HERE = Path(__file__).resolve().parent
DEPTHS = (200.0, 4000.0)
NOISE = {"photons": 2000.0, "read_noise": 0.0}
ZS = [250.0, 300.0, 400.0, 500.0, 642.0, 800.0, 1000.0, 1300.0, 1600.0, 2000.0, 2500.0]
SETS = {"split sensor": None, "half 1": (1,), "half 2": (2,)}


def design(kx: int = 16, ky: int = 12) -> splitlf.Design:
    d = splitlf.Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=kx, Ky=ky) for c in d.channels))


def region(d: splitlf.Design, z: float) -> tuple[float, float, float, float]:
    for ch in ([1], [2]):
        try:
            return _native.seen_region(d.core, z, ch)
        except splitlf.InvalidParameter:
            pass
    raise RuntimeError(f"nothing seen at {z} mm")


def error_against_depth(d: splitlf.Design) -> dict[str, list[dict[str, float]]]:
    out: dict[str, list[dict[str, float]]] = {k: [] for k in SETS}
    for z in ZS:
        tex = splitlf.RandomAlbedo(10 * d.resolution_step(z))
        raw = splitlf.render(d, splitlf.Scene(tex, z), noise=NOISE, seed=int(z))
        for name, ch in SETS.items():
            est = splitlf.estimate_depth(raw, depths=DEPTHS, region=region(d, z), channels=ch)
            e = measure.depth_errors(est, z)
            out[name].append({"z": z, **e})
            print(f"{z:6.0f} {name:12s} median {e['median']:.4f} p90 {e['p90']:.4f} "
                  f"confident {e['confident']:.2f}", flush=True)
    return out


def half_uniform(d: splitlf.Design) -> tuple[splitlf.DepthMap, dict[str, float]]:
    z = 1000.0
    cell = 10 * d.resolution_step(z)
    x0, x1, y0, y1 = _native.render_extent(d.core, z)
    cols = 2 * int(np.ceil(max(abs(x0), abs(x1)) / cell)) + 2
    rows = 2 * int(np.ceil(max(abs(y0), abs(y1)) / cell)) + 2
    img = np.random.default_rng(3).uniform(0.0, 1.0, (rows, cols))
    img[:, : cols // 2] = 0.5
    raw = splitlf.render(d, splitlf.Scene(splitlf.Image(img, cols * cell), z), noise=NOISE,
                         seed=7)
    est = splitlf.estimate_depth(raw, depths=DEPTHS, region=region(d, z))
    return est, measure.depth_errors(est, z)


def main() -> None:
    t0 = time.time()
    d = design()
    curves = error_against_depth(d)
    est, e2 = half_uniform(d)
    print("half uniform", e2, flush=True)
    fig, axs = plt.subplots(2, 2, figsize=(12.0, 8.5), layout="constrained")
    ax = axs[0, 0]
    styles = {"split sensor": ("black", "o"), "half 1": ("tab:blue", "s"),
              "half 2": ("tab:orange", "^")}
    for name, rows in curves.items():
        c, m = styles[name]
        zs = [r["z"] for r in rows]
        ax.plot(zs, [100 * r["median"] for r in rows], color=c, marker=m, label=f"{name} median")
        ax.plot(zs, [100 * r["p90"] for r in rows], color=c, marker=m, ls="--", alpha=0.6,
                label=f"{name} 90th pct")
    for z, label in ((217.0, "half 2 out of focus"), (642.0, "half 1 out of focus")):
        ax.axvline(z, color="grey", lw=0.8, ls=":")
        ax.text(z, 60.0, label, rotation=90, va="top", ha="right", fontsize=8, color="grey")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("depth z [mm]")
    ax.set_ylabel("relative depth error over confident cells [%]")
    ax.set_title("seed (16 x 12 lenses), textured planes, N = 2000")
    ax.legend(fontsize=7, ncol=2)
    ax = axs[0, 1]
    for name, rows in curves.items():
        c, m = styles[name]
        ax.plot([r["z"] for r in rows], [r["confident"] for r in rows], color=c, marker=m,
                label=name)
    ax.set_xscale("log")
    ax.set_ylim(0, 1.05)
    for a in axs[0]:
        a.set_xticks(ZS, [f"{z:g}" for z in ZS], rotation=45, fontsize=8)
        a.minorticks_off()
    ax.set_xlabel("depth z [mm]")
    ax.set_ylabel("share of cells confident")
    ax.legend(fontsize=8)
    splitlf.plot.depth(est, axs[1, 0], vmin=950.0, vmax=1050.0)
    axs[1, 0].set_title("plane at 1 m, left half uniform: split sensor's estimate",
                        fontsize=10)
    err = 100 * (est.depth - 1000.0) / 1000.0
    x0, x1, y0, y1 = est.extent
    im = axs[1, 1].imshow(np.where(est.confident, err, np.nan), extent=(x0, x1, y0, y1),
                          cmap="coolwarm", vmin=-2, vmax=2, interpolation="nearest")
    fig.colorbar(im, ax=axs[1, 1], shrink=0.85, label="relative error [%]")
    axs[1, 1].set_title(f"error (confident cells; median {100 * e2['median']:.2f} %)")
    axs[1, 1].set_xlabel("X [mm]")
    axs[1, 1].set_ylabel("Y [mm]")
    fig.savefig(HERE / "depth.png", dpi=90)
    (HERE / "depth.json").write_text(json.dumps(
        {"error_against_depth": curves, "half_uniform_1m": e2,
         "seconds": round(time.time() - t0)}, indent=1) + "\n")
    print(f"done in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
