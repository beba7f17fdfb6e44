"""Render docs/fig2.png and docs/fig2.json: the paper's Fig. 2 question, per depth.

The seed design cut to 24 x 16 lenses per half and a conventional camera on the same
sensor (one half's pixels, all the light, focused where half 1's array is imaged: 642 mm)
look at fronto-parallel planes from 300 mm to 2 m. At each depth two scenes are rendered
(splitlf.render, exact route) with photon noise (N = 2000 and 20,000 photo-electrons
for white, two draws each):
a natural image (scikit-image's "camera", 512 x 512 texture cells, each 0.56 to 0.94 of
the reconstruction's cell from 300 mm to 2 m, not aligned with it) and a 5-degree slanted
edge (analytic, no cells at all). Neither is representable on the reconstruction's grid
(the grid is delta(z), the sensor's step; the data's texture cells are of another size and
phase, or it is continuous): no inverse crime. Each raw is
reconstructed with the known depth (splitlf.reconstruct: the raw carries its noise
model, and each camera's weight is chosen from its data) from
half 1 alone, half 2 alone, the split sensor, and the conventional camera, over the same
region (the central half, per axis, of what both arrays image), and measured against the truth
(splitlf.measure: PSNR on the image, MTF50 on the edge).

Run: python docs/make_fig2.py (two photon counts, N = 2000 and 20,000, two noise draws
each; the time is in docs/fig2.json); python docs/make_fig2.py --figure redraws the figure
from docs/fig2.json (its images made anew from the same raws, a few minutes).
"""

from __future__ import annotations

import json
import sys
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
PHOTONS = (2000.0, 20000.0)
DRAWS = 2
#: The first noise level, for the studies that take one (make_prior.py, make_fig2_designs.py).
NOISE = {"photons": PHOTONS[0], "read_noise": 0.0}
CAMERAS = ("half 1", "half 2", "split", "conventional")
LIGHT_FIELD = CAMERAS[:3]


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
    if sys.argv[1:] == ["--figure"]:
        redraw()
        return
    t0 = time.perf_counter()
    split, conv = designs()
    out: dict = {"depths": list(DEPTHS), "nyquist": [], "region": [], "runs": {},
                 "seconds": {}}
    shown: dict = {}
    for z in DEPTHS:
        region = central(split, z)
        out["nyquist"].append(1.0 / (2.0 * split.resolution_step(z)))
        out["region"].append(list(region))
    # The light field cameras at both photon counts and draws, then the conventional
    # camera (the reference; its choice is the slow one, docs/fig2.md) at N = 2000's
    # first draw.
    plan = [(n_i, draw, LIGHT_FIELD) for n_i in range(len(PHOTONS)) for draw in range(DRAWS)]
    plan += [(0, 0, ("conventional",))]
    for n_i, draw, cams in plan:
        photons = PHOTONS[n_i]
        key = f"{photons:.0f}/{draw}"
        run = out["runs"].setdefault(key, {m: {c: [] for c in CAMERAS} for m in (
            "psnr", "mtf50", "lambda_psnr", "lambda_mtf")})
        t1 = time.perf_counter()
        for i, z in enumerate(DEPTHS):
            seed = 1000 * draw + 100 * n_i + 10 * i
            one_depth((split, conv), z, photons, seed, run, cams,
                      shown if (n_i, draw) == (0, 0) else None)
            print(f"N {photons:6.0f} draw {draw} {z:6.0f} mm  " + "  ".join(
                f"{c}: {run['psnr'][c][-1]:5.2f} dB {run['mtf50'][c][-1]:6.2f} c/mm "
                f"(lambda {run['lambda_psnr'][c][-1]:.3g})" for c in cams)
                + f"  ({time.perf_counter() - t0:.0f} s)", flush=True)
        out["seconds"][f"{key} {', '.join(cams)}"] = time.perf_counter() - t1
        (HERE / "fig2.json").write_text(json.dumps(out, indent=1) + "\n")
    out["verdict"] = verdict(out)
    out["seconds"]["total"] = time.perf_counter() - t0
    (HERE / "fig2.json").write_text(json.dumps(out, indent=1) + "\n")
    figure(out, shown)
    print(json.dumps(out["verdict"], indent=1))
    print(f"docs/fig2.png, docs/fig2.json in {time.perf_counter() - t0:.0f} s")


def redraw() -> None:
    """The figure again from docs/fig2.json, its images made anew (the same raws: the
    seeds of N = 2000's first draw; the edges too, their measures dropped)."""
    out = json.loads((HERE / "fig2.json").read_text())
    split, conv = designs()
    shown: dict = {}
    scratch = {m: {c: [] for c in CAMERAS} for m in ("psnr", "mtf50", "lambda_psnr",
                                                      "lambda_mtf")}
    for z in SHOWN:
        seed = 10 * DEPTHS.index(z)
        for cams in (LIGHT_FIELD, ("conventional",)):
            one_depth((split, conv), z, PHOTONS[0], seed, scratch, cams, shown)
    figure(out, shown)


def one_depth(designs_: tuple[splitlf.Design, splitlf.Design], z: float, photons: float,
              seed: int, run: dict, cams: tuple[str, ...], shown: dict | None) -> None:
    """Both scenes at depth ``z`` rendered with photon noise N = ``photons`` (the raws
    carry it), each of ``cams`` reconstructed at its own data-chosen weight, into ``run``."""
    split, conv = designs_
    region = central(split, z)
    span = _native.pixel_span(split.core, z, None)
    tex = natural(2.0 * (max(abs(v) for v in region) + 2.0 * span))
    edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
    noise = {"photons": photons, "read_noise": 0.0}
    for scene_i, texture in enumerate((tex, edge)):
        sc = splitlf.Scene(texture, z)
        if cams == ("conventional",):
            raw = splitlf.render(conv, sc, noise=noise, seed=seed + scene_i + 5,
                                 progress=False)
        else:
            raw = splitlf.render(split, sc, noise=noise, seed=seed + scene_i, progress=False)
        for cam in cams:
            channels = {"half 1": 1, "half 2": 2}.get(cam)
            rec = splitlf.reconstruct(raw, z, region=region, channels=channels,
                                      progress=False)
            assert rec.noise_source == "raw" and rec.regularization_rule == "weighted gcv"
            measured(run, shown if z in SHOWN else None, cam, rec, texture)


def verdict(out: dict) -> dict:
    """At 642 mm (half 1's out-of-focus plane), per photon count: the split sensor's gain
    over half 1 and over the better half, by PSNR (dB) and MTF50 (share of Nyquist), each
    draw's and their spread (a gain smaller than the spread between the two draws' gains
    is no gain); and half 1's dip against its mean at 500 and 800 mm."""
    k = out["depths"].index(642.0)
    nyq = out["nyquist"]
    res: dict = {}
    for photons in PHOTONS:
        runs = [out["runs"][f"{photons:.0f}/{d}"] for d in range(DRAWS)]
        row: dict = {}
        for m in ("psnr", "mtf50"):
            scale = (lambda v, j: v) if m == "psnr" else (lambda v, j: v / nyq[j])
            at = [{c: scale(r[m][c][k], k) for c in LIGHT_FIELD} for r in runs]
            gain1 = [a["split"] - a["half 1"] for a in at]
            gainb = [a["split"] - max(a["half 1"], a["half 2"]) for a in at]
            off = [0.5 * (scale(r[m]["half 1"][k - 1], k - 1) + scale(r[m]["half 1"][k + 1], k + 1))
                   for r in runs]
            row[m] = {"at_642": at, "split_minus_half1": gain1, "split_minus_better_half": gainb,
                      "draw_spread_split_minus_half1": max(gain1) - min(gain1),
                      "half1_dip": [a["half 1"] - o for a, o in zip(at, off, strict=True)]}
        res[f"{photons:.0f}"] = row
    return res


def measured(out: dict, shown: dict | None, cam: str, rec: splitlf.Reconstruction,
             texture: Any) -> None:
    """A reconstruction's measure and chosen weight into ``out``: PSNR of the natural image
    (kept in ``shown`` with its truth when given), MTF50 of the slanted edge."""
    if isinstance(texture, splitlf.SlantedEdge):
        out["mtf50"][cam].append(measure.mtf50(rec, texture))
        out["lambda_mtf"][cam].append(rec.regularization)
        return
    out["psnr"][cam].append(measure.psnr(rec, texture))
    out["lambda_psnr"][cam].append(rec.regularization)
    if shown is not None:
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
    """The images of the first draw at N = 2000 at the SHOWN depths, then MTF50 and PSNR
    against depth: each camera's mean over the draws it has (the conventional camera: N =
    2000's first), N = 2000 solid, N = 20,000 dotted."""
    cols = ("truth",) + CAMERAS
    fig = plt.figure(figsize=(12, 10.5), layout="constrained")
    grid = fig.add_gridspec(len(SHOWN) + 1, len(cols), height_ratios=[1] * len(SHOWN) + [1.3])
    image_rows(fig, grid, shown, cols, SHOWN)
    z = np.array(out["depths"])
    nyq = np.array(out["nyquist"])
    ax_m = fig.add_subplot(grid[-1, : len(cols) // 2 + 1])
    ax_p = fig.add_subplot(grid[-1, len(cols) // 2 + 1:])
    colours = dict(zip(CAMERAS, ("C0", "C1", "C2", "C3"), strict=True))
    for photons, line in zip(PHOTONS, ("-", ":"), strict=True):
        runs = [out["runs"][f"{photons:.0f}/{d}"] for d in range(DRAWS)]
        for cam, mark in zip(CAMERAS, ("o", "s", "^", "d"), strict=True):
            done = [r for r in runs if r["psnr"][cam]]
            if not done:
                continue
            mtf = np.mean([np.array(r["mtf50"][cam], dtype=float) for r in done], axis=0)
            psnr = np.mean([r["psnr"][cam] for r in done], axis=0)
            label = f"{cam}, N = {photons:.0f}"
            ax_m.plot(z, mtf / nyq, line + mark, color=colours[cam], label=label, ms=4)
            ax_p.plot(z, psnr, line + mark, color=colours[cam], label=label, ms=4)
    for ax in (ax_m, ax_p):
        ax.set_xscale("log")
        ax.set_xlabel("depth z [mm]")
        ax.axvline(642.0, color="0.7", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
    ax_m.set_ylabel("MTF50 / sensor Nyquist 1/(2 delta(z))")
    ax_p.set_ylabel("PSNR [dB]")
    top = 0.35
    ax_m.set_ylim(0.0, top)
    conv = out["runs"][f"{PHOTONS[0]:.0f}/0"]["mtf50"]["conventional"]
    for zi, v, q in zip(z, conv, nyq, strict=True):
        if v / q > top:
            ax_m.annotate(f"conventional {v / q:.2f}", (zi, top), xytext=(zi * 1.04, 0.93 * top),
                          fontsize=7, color=colours["conventional"])
    ax_m.legend(fontsize=7, ncol=2, loc="lower right")
    fig.suptitle("Seed (24 x 16 lenses per half), known depth, each camera at its data-chosen "
                 "weight: half 1's out-of-focus band at 642 mm\nand the split sensor's cure "
                 f"(images: N = {PHOTONS[0]:.0f}, first draw; curves: mean of the draws)")
    fig.savefig(HERE / "fig2.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
