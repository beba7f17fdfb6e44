"""Render docs/fig2_<preset>.png and docs/fig2_<preset>.json: the paper's Fig. 2 question,
per depth, for the hexagonal presets (`lytro-illum`, `raytrix-r12`), as docs/make_fig2.py
does for the seed.

Each preset is cut to a few lenses (its sensor cut to match: Mx = My = None) and looks at
fronto-parallel planes around its array's conjugate (its out-of-focus plane, where every
pixel under a microlens sees the same point). There is no conventional camera here (the
seed's study has one): behind these presets' circular apertures its raw goes through
render's general route, and out of focus (every depth but one) a raw of it took over ten
minutes. At each depth two scenes are rendered (splitlf.render, the general
route: hex lattice, circular aperture, sensor layout) with photon noise N = 2000: a
natural image (scikit-image's "camera", 512 x 512 texture cells, each well under the
reconstruction's cell) and a 5-degree slanted edge (analytic). Neither is representable on
the reconstruction's grid: no inverse crime. Each raw is reconstructed with the known depth
(splitlf.reconstruct, the noise model given) on cells of 2 (Illum) or 4 (R12) sensor
steps delta(z) (the seed's study uses delta(z); the general route's map and solve cost
grows with the cells a pixel's rays cover) over the central
half (per axis) of what the array images: for the R12 from each of its three lens types
alone (``lens_types``) and from all three, for the Illum from its one lens type. PSNR on
the image, MTF50 on the edge (splitlf.measure).

Run: python docs/make_fig2_designs.py lytro-illum|raytrix-r12 [--cache DIR] (minutes on 2
cores); with --cache the images shown are kept in DIR, and --replot redraws the figure
from DIR and the JSON without reconstructing.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import make_fig2 as seedfig  # docs/, the script's own folder
import matplotlib

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native  # noqa: E402
from splitlf.report import report_data  # noqa: E402

HERE = Path(__file__).parent
NOISE = seedfig.NOISE
#: Per preset: lenses kept (Kx, Ky), cells of `step` sensor steps delta(z) = mu z / L,
#: depths [mm], the depths shown as images. The R12's pixels (5.5 um, 23 under a lens)
#: see patches of tens of delta away from 407 mm (a map row of 780 cells of 4 delta at
#: 700 mm): its cells are coarser, its depths closer to the band and its cut smaller.
SETUP = {
    "raytrix-r12": {"lenses": (8, 7), "step": 4.0,
                    "depths": (300.0, 370.0, 407.0, 500.0, 700.0),
                    "shown": (300.0, 407.0, 700.0)},
    "lytro-illum": {"lenses": (16, 14), "step": 2.0,
                    "depths": (300.0, 500.0, 1000.0, 1600.0, 2500.0, 4000.0, 7000.0),
                    "shown": (500.0, 2500.0, 7000.0)},
}


def design(preset: str) -> splitlf.Design:
    """The preset cut to SETUP's lenses (its sensor cut to match)."""
    full = splitlf.Design.preset(preset)
    kx, ky = SETUP[preset]["lenses"]
    return full.replace(channels=(full.channels[0].replace(Kx=kx, Ky=ky, Mx=None, My=None),))


def cameras(design: splitlf.Design) -> tuple[str, ...]:
    n = len(design.resolved()[0]["f"])
    types = tuple(f"type {t}" for t in range(1, n + 1)) if n > 1 else ()
    return types + ("light field",)


def central(design: splitlf.Design, z: float) -> tuple[float, float, float, float]:
    """The central half (per axis) of what the array images at depth z: (z/L) x the
    array's extent (hex rows sqrt(3)/2 d apart)."""
    c = design.resolved()[0]
    row = c["d"] * (np.sqrt(3.0) / 2.0 if c["grid"] == "hex" else 1.0)
    hx = z / c["L"] * c["Kx"] * c["d"] / 4.0
    hy = z / c["L"] * c["Ky"] * row / 4.0
    return (-hx, hx, -hy, hy)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("preset", choices=sorted(SETUP))
    ap.add_argument("--cache", type=Path, default=None,
                    help="a folder to keep the images shown in")
    ap.add_argument("--replot", action="store_true",
                    help="redraw the figure from --cache and the JSON")
    args = ap.parse_args()
    preset = args.preset
    t0 = time.perf_counter()
    lf = design(preset)
    cams = cameras(lf)
    setup = SETUP[preset]
    band = report_data(lf)["derived"]["channels"][0]["out_of_focus_depth_mm"]
    cache = None if args.cache is None else args.cache / f"fig2_{preset}_shown.npz"
    if args.replot:
        if cache is None:
            ap.error("--replot needs --cache")
        out = json.loads((HERE / f"fig2_{preset}.json").read_text())
        with np.load(cache) as f:
            shown = {(float(k.split("|")[0]), k.split("|")[1]): f[k] for k in f.files}
        figure(out, shown, cams, setup["shown"], band)
        return
    out: dict = {"preset": preset, "lenses": list(setup["lenses"]), "band_mm": band,
                 "step": setup["step"],
                 "depths": list(setup["depths"]), "psnr": {c: [] for c in cams},
                 "mtf50": {c: [] for c in cams}, "lambda_psnr": {c: [] for c in cams},
                 "lambda_mtf": {c: [] for c in cams}, "nyquist": [], "region": [],
                 "seconds": {c: 0.0 for c in cams}}
    shown: dict = {}
    for i, z in enumerate(setup["depths"]):
        region = central(lf, z)
        span = _native.pixel_span(lf.core, z, None)
        tex = seedfig.natural(2.0 * (max(abs(v) for v in region) + 2.0 * span))
        edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
        out["nyquist"].append(1.0 / (2.0 * lf.resolution_step(z)))
        out["region"].append(list(region))
        for scene_i, texture in enumerate((tex, edge)):
            sc = splitlf.Scene(texture, z)
            raw = splitlf.render(lf, sc, noise=NOISE, seed=10 * i + scene_i)
            for cam in cams:
                types = int(cam.split()[1]) if cam.startswith("type") else None
                t1 = time.perf_counter()
                rec = splitlf.reconstruct(raw, z, region=region, noise=NOISE,
                                          step=setup["step"] * lf.resolution_step(z),
                                          lens_types=types)
                out["seconds"][cam] += time.perf_counter() - t1
                seedfig.measured(out, shown if z in setup["shown"] else None, cam, rec,
                                 texture)
        print(f"{z:6.0f} mm  " + "  ".join(  # nan: no MTF50 (sharp to the cells' Nyquist)
            f"{c}: {out['psnr'][c][-1]:5.1f} dB {out['mtf50'][c][-1] / out['nyquist'][-1]:5.3f}"
            for c in cams) + f"  ({time.perf_counter() - t0:.0f} s)", flush=True)
    for cam in cams:  # no MTF50 (a sharp edge): None, not NaN, in the JSON
        out["mtf50"][cam] = [None if not np.isfinite(v) else v for v in out["mtf50"][cam]]
    (HERE / f"fig2_{preset}.json").write_text(json.dumps(out, indent=1) + "\n")
    if cache is not None:
        cache.parent.mkdir(parents=True, exist_ok=True)
        np.savez(cache, **{f"{z:g}|{cam}": img for (z, cam), img in shown.items()})
    figure(out, shown, cams, setup["shown"], band)
    print(f"docs/fig2_{preset}.png, .json in {time.perf_counter() - t0:.0f} s")


def figure(out: dict, shown: dict, cams: tuple[str, ...], depths: tuple[float, ...],
           band: float) -> None:
    cols = ("truth",) + cams
    fig = plt.figure(figsize=(max(2.2 * len(cols) + 1.0, 8.0), 10.5), layout="constrained")
    grid = fig.add_gridspec(len(depths) + 1, len(cols), height_ratios=[1] * len(depths) + [1.3])
    seedfig.image_rows(fig, grid, shown, cols, depths)
    z = np.array(out["depths"])
    nyq = np.array(out["nyquist"])
    half = max(1, len(cols) // 2)
    ax_m = fig.add_subplot(grid[-1, :half])
    ax_p = fig.add_subplot(grid[-1, half:])
    # An edge whose transfer never falls to half below the cells' Nyquist frequency has no
    # MTF50 (None): drawn at that frequency, hollow (a lower bound).
    cap = 1.0 / out["step"]
    ax_m.axhline(cap, color="0.5", ls=":", lw=0.8, label="the cells' Nyquist")
    styles = ("-o", "-s", "-^")
    for cam, style in zip(cams, styles[:len(cams) - 1] + ("-kD",), strict=True):
        m = np.array([np.nan if v is None else v for v in out["mtf50"][cam]], float) / nyq
        line, = ax_m.plot(z, m, style, label=cam, ms=4)
        sharp = ~np.isfinite(m)
        ax_m.plot(z[sharp], np.full(sharp.sum(), cap), style[-1], ms=7, mfc="none",
                  color=line.get_color())
        ax_p.plot(z, out["psnr"][cam], style, label=cam, ms=4)
    for ax in (ax_m, ax_p):
        ax.set_xscale("log")
        ax.set_xticks(z, [f"{v:g}" for v in z], rotation=90)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("depth z [mm]")
        ax.axvline(band, color="0.7", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
    ax_m.set_ylabel(f"MTF50 / sensor Nyquist 1/(2 delta(z)) (cells {out['step']:g} delta)")
    ax_p.set_ylabel("PSNR [dB]")
    ax_m.legend(fontsize=8)
    kx, ky = out["lenses"]
    fig.suptitle(f"{out['preset']} ({kx} x {ky} lenses), photon noise N = 2000, known depth:\n"
                 f"the out-of-focus band at {band:.0f} mm (grey line)")
    fig.savefig(HERE / f"fig2_{out['preset']}.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
