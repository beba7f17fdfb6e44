"""Measure docs/prior.json and docs/prior.png: the edge-preserving priors against the
quadratic one on the Fig. 2 study's set-up (docs/fig2.md, docs/make_fig2.py).

The seed cut to 24 x 16 lenses per half, fronto-parallel planes at the eight depths of
docs/make_fig2.py (300 mm to 2 m), a natural image (scikit-image's "camera", 512 x 512
texture cells, each under a tenth of the reconstruction's cell) and a 5-degree slanted edge
(analytic), rendered by splitlf.render with Poisson photon noise N = 2000 (the seeds of
docs/make_fig2.py for the first noise draw). The data's textures are finer than the
reconstruction's grid or continuous and the noise is Poisson: no inverse crime. Each raw
is reconstructed with the known depth and noise model over the same region as
docs/make_fig2.py, from half 1, half 2 and the split sensor, under three priors:
quadratic, Huber (thresholds 0.02, 0.05, 0.1 of white) and TV (smoothing 0.01).

The rule, fixed before the run: each prior (and each Huber threshold) at its
own best weight lambda, the oracle: the best PSNR of the natural image against its truth
on a log grid of lambda, walked from a start (4 quadratic, 16 Huber, 0.5 TV) by factors of
4 while PSNR rises, then refined by factors of 2 either side of the best (unimodal
assumption: the walk stops at the first fall). Huber's threshold is the best of its three
by the same PSNR. The weight so chosen at each depth and camera is then used, unchanged,
for the slanted edge (MTF50) and for a second noise draw of both scenes (other seeds): the
second draw tells a difference from noise. Times: the whole reconstruct call, this
process, at the chosen weights.

Run: python docs/make_prior.py (1384 s on 2 cores shared with other work).
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
from make_fig2 import (  # noqa: E402  docs/, its folder
    DEPTHS,
    NOISE,
    central,
    designs,
    image_rows,
    natural,
)

import splitlf  # noqa: E402
from splitlf import _native, measure  # noqa: E402

HERE = Path(__file__).parent
CAMERAS = {"half 1": 1, "half 2": 2, "split": None}
#: (prior, threshold) configurations and the weight each search starts from.
CONFIGS = {"quadratic": ("quadratic", None, 4.0), "huber 0.02": ("huber", 0.02, 16.0),
           "huber 0.05": ("huber", 0.05, 16.0), "huber 0.1": ("huber", 0.1, 16.0),
           "tv 0.01": ("tv", 0.01, 0.5)}
PRIORS = {"quadratic": ("quadratic",), "huber": ("huber 0.02", "huber 0.05", "huber 0.1"),
          "tv": ("tv 0.01",)}
SHOWN = (642.0, 1000.0)


def rec(raw: splitlf.Raw, z: float, region: Any, cam: str, config: str,
        lam: float) -> tuple[splitlf.Reconstruction, float]:
    prior, threshold, _ = CONFIGS[config]
    t0 = time.perf_counter()
    r = splitlf.reconstruct(raw, z, region=region, channels=CAMERAS[cam], noise=NOISE,
                            regularization=lam, prior=prior, threshold=threshold,
                            allow_slow=True)
    return r, time.perf_counter() - t0


def best_weight(raw: splitlf.Raw, z: float, region: Any, cam: str, config: str,
                tex: Any) -> tuple[float, float, dict[float, float]]:
    """The oracle's weight (see the module doc): (lambda, its PSNR, every PSNR tried)."""
    tried: dict[float, float] = {}

    def psnr(lam: float) -> float:
        if lam not in tried:
            tried[lam] = measure.psnr(rec(raw, z, region, cam, config, lam)[0], tex)
        return tried[lam]

    lam = CONFIGS[config][2]
    up = psnr(lam * 4.0) > psnr(lam)
    factor = 4.0 if up else 0.25
    while psnr(lam * factor) > psnr(lam):
        lam *= factor
    for f in (2.0, 0.5):
        psnr(lam * f)
    best = max(tried, key=lambda k: tried[k])
    return best, tried[best], tried


def one_depth(i: int, z: float, split: splitlf.Design, out: dict, shown: dict) -> None:
    region = central(split, z)
    span = _native.pixel_span(split.core, z, None)
    tex = natural(2.0 * (max(abs(v) for v in region) + 2.0 * span))
    edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
    raws = {(s, d): splitlf.render(split, splitlf.Scene(t, z), noise=NOISE,
                                   seed=10 * i + s + 1000 * d)
            for s, t in enumerate((tex, edge)) for d in (0, 1)}
    for cam in CAMERAS:
        row: dict = {}
        for config in CONFIGS:
            row[config] = dict(zip(("lambda", "psnr", "tried"),
                                   best_weight(raws[0, 0], z, region, cam, config, tex),
                                   strict=True))
        for name, configs in PRIORS.items():
            config = max(configs, key=lambda c: row[c]["psnr"])
            lam = row[config]["lambda"]
            r1, secs = rec(raws[0, 0], z, region, cam, config, lam)
            e1 = rec(raws[1, 0], z, region, cam, config, lam)[0]
            r2 = rec(raws[0, 1], z, region, cam, config, lam)[0]
            e2 = rec(raws[1, 1], z, region, cam, config, lam)[0]
            out[cam][name].append({
                "config": config, "lambda": lam, "threshold": CONFIGS[config][1],
                "psnr": [measure.psnr(r1, tex), measure.psnr(r2, tex)],
                "mtf50": [measure.mtf50(e1, edge), measure.mtf50(e2, edge)],
                "seconds": secs, "iterations": r1.iterations, "passes": r1.passes,
                "search": {c: {str(k): v for k, v in row[c]["tried"].items()}
                           for c in configs}})
            if z in SHOWN and cam == "split":
                shown[z, name] = r1.image
                shown[z, "truth"] = measure.truth(r1, tex)


def main() -> None:
    t0 = time.perf_counter()
    split, _ = designs()
    out: dict = {"depths": list(DEPTHS), "nyquist": [1.0 / (2.0 * split.resolution_step(z))
                                                     for z in DEPTHS]}
    out.update({cam: {p: [] for p in PRIORS} for cam in CAMERAS})
    shown: dict = {}
    for i, z in enumerate(DEPTHS):
        one_depth(i, z, split, out, shown)
        for cam in CAMERAS:
            print(f"{z:6.0f} mm {cam:7s} " + "  ".join(
                f"{p}: {out[cam][p][-1]['psnr'][0]:5.2f}/{out[cam][p][-1]['psnr'][1]:5.2f} dB "
                f"{out[cam][p][-1]['mtf50'][0] / out['nyquist'][i]:.3f} "
                f"(lambda {out[cam][p][-1]['lambda']:g}, {out[cam][p][-1]['seconds']:.2f} s)"
                for p in PRIORS), flush=True)
    out["seconds"] = time.perf_counter() - t0
    (HERE / "prior.json").write_text(json.dumps(out, indent=1) + "\n")
    figure(out, shown)
    print(f"docs/prior.png, docs/prior.json in {out['seconds']:.0f} s")


def figure(out: dict, shown: dict) -> None:
    cols = ("truth", *PRIORS)
    fig = plt.figure(figsize=(12, 9), layout="constrained")
    grid = fig.add_gridspec(len(SHOWN) + 1, len(cols), height_ratios=[1] * len(SHOWN) + [1.2])
    image_rows(fig, grid, shown, cols, SHOWN)
    z = np.array(out["depths"])
    nyq = np.array(out["nyquist"])
    ax_p = fig.add_subplot(grid[-1, :2])
    ax_m = fig.add_subplot(grid[-1, 2:])
    for cam, colour in zip(CAMERAS, ("C0", "C1", "C2"), strict=True):
        for name, style in (("huber", "-o"), ("tv", "--s")):
            gain = [np.mean(a["psnr"]) - np.mean(b["psnr"])
                    for a, b in zip(out[cam][name], out[cam]["quadratic"], strict=True)]
            ratio = [np.mean(a["mtf50"]) / np.mean(b["mtf50"])
                     for a, b in zip(out[cam][name], out[cam]["quadratic"], strict=True)]
            ax_p.plot(z, gain, style, color=colour, ms=4, label=f"{cam}, {name}")
            ax_m.plot(z, ratio, style, color=colour, ms=4, label=f"{cam}, {name}")
        ax_m.plot(z, np.array([np.mean(b["mtf50"]) for b in out[cam]["quadratic"]]) / nyq,
                  ":", color=colour, lw=0.8)
    ax_p.axhline(1.0, color="0.5", lw=0.8, ls="--")
    ax_p.set_ylabel("PSNR gain over quadratic [dB] (mean of 2 draws)")
    ax_m.axhline(1.0, color="0.5", lw=0.8)
    ax_m.set_ylabel("MTF50 ratio to quadratic (dotted: quadratic's MTF50 / Nyquist)")
    for ax in (ax_p, ax_m):
        ax.set_xscale("log")
        ax.set_xlabel("depth z [mm]")
        ax.grid(True, which="both", alpha=0.3)
    ax_p.legend(fontsize=7, ncol=2)
    fig.suptitle("Edge-preserving priors against the quadratic one, each at its oracle "
                 "weight (seed 24 x 16 lenses, N = 2000; images: the split sensor's)")
    fig.savefig(HERE / "prior.png", dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
