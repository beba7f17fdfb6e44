"""A 2-D check of docs/compare.md's MTF50 columns: the slanted-edge MTF50 of the saved
optimised designs (docs/compare/<preset>/<architecture>.toml) from splitlf.reconstruct,
beside the 1-D figures of splitlf.compare.mtf50.

For each design and depth z of make_compare.SIMULATE_DEPTHS:
- the design is cut to the lenses of each channel that can see a square of REGION_CELLS
  cells of delta(z) = mu z / L_1 about the axis (that square widened by a pixel's span,
  ``_native.pixel_span``, on each side, plus two lenses each side), its sensor cut to match;
- a 5-degree slanted edge (albedo 0.1 | 0.9, analytic: not representable on the cells) is
  rendered (splitlf.render, its own adaptive integration) noise-free and with photon noise
  N = 2000 (seed 1);
- each raw is reconstructed (splitlf.reconstruct, the known depth, its default prior, the
  noise model given for the noisy raw) on cells of delta(z) over that square, and
  splitlf.measure.mtf50 reads the edge. When the transfer never fell to half below the
  cells' Nyquist frequency 1 / (2 delta(z)): null in the JSON, "≥ Nyquist" in the table.

Run: python docs/make_compare_2d.py [preset ...] [--designs plain,split,...] [--depths
150,300] [--noise "N = 2000"] (seconds per rect design and depth on the seed's sensor; the
hexagonal multi-focus design goes through the general route: minutes per depth). Merges
its results into docs/compare/<preset>_mtf50_2d.json and prints a Markdown table of
MTF50 [cycles/mm] (in brackets: over the cells' Nyquist frequency).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from make_compare import SIMULATE_DEPTHS  # docs/, the script's own folder

import splitlf
from splitlf import _native

HERE = Path(__file__).resolve().parent / "compare"
#: Cells of delta(z) per side of the reconstructed square.
REGION_CELLS = 64
#: Photon noise of the noisy raws (the Fig. 2 studies' N).
NOISE = {"photons": 2000.0}
EDGE = splitlf.SlantedEdge(5.0, 0.1, 0.9)


def cut(design: splitlf.Design, z: float) -> splitlf.Design:
    """Each channel cut to the lenses that can see the square of REGION_CELLS delta(z)
    about the axis at depth z (the square widened by a pixel's span on each side, plus two
    lenses each side), its sensor cut to match."""
    res = design.resolved()
    span = _native.pixel_span(design.core, z, None)
    w = REGION_CELLS * design.resolution_step(z) + 2.0 * span
    chans = []
    for ch, r in zip(design.channels, res, strict=True):
        row = r["d"] * (math.sqrt(3.0) / 2.0 if r["grid"] == "hex" else 1.0)
        kx = math.ceil(w * r["L"] / z / r["d"]) + 4
        ky = math.ceil(w * r["L"] / z / row) + 4
        chans.append(ch.replace(Kx=min(kx, r["Kx"]), Ky=min(ky, r["Ky"]), Mx=None, My=None))
    return design.replace(channels=tuple(chans))


def measure(design: splitlf.Design, z: float, noise: dict | None) -> dict:
    """The MTF50 of one cut design at depth z, noise-free (None) or with ``noise``."""
    d = cut(design, z)
    h = d.resolution_step(z)
    half = REGION_CELLS * h / 2.0
    t0 = time.perf_counter()
    raw = splitlf.render(d, splitlf.Scene(EDGE, z), noise=noise, seed=1, progress=False)
    rec = splitlf.reconstruct(raw, z, region=(-half, half, -half, half), step=h,
                              noise=noise, progress=False)
    m = splitlf.measure.mtf50(rec, EDGE)
    return {"mtf50": None if math.isnan(m) else m, "nyquist": 1.0 / (2.0 * h),
            "lenses": [[c.Kx, c.Ky] for c in d.channels], "rows": rec.rows,
            "iterations": rec.iterations, "seconds": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("presets", nargs="*", default=["seed"])
    ap.add_argument("--designs", default="plain,split,split3")
    ap.add_argument("--depths", default=",".join(f"{z:g}" for z in SIMULATE_DEPTHS),
                    help="depths [mm], comma-separated (default: SIMULATE_DEPTHS)")
    ap.add_argument("--noise", default="noise-free,N = 2000",
                    help='which raws, comma-separated: "noise-free", "N = 2000"')
    args = ap.parse_args()
    depths = [float(z) for z in args.depths.split(",")]
    kinds = {"noise-free": None, "N = 2000": NOISE}
    for preset in args.presets:
        path = HERE / f"{preset}_mtf50_2d.json"
        # Merged into what earlier runs measured: {design: {noise: {depth: result}}}.
        out: dict = (json.loads(path.read_text()) if path.exists() else
                     {"region_cells": REGION_CELLS, "photons": NOISE["photons"], "designs": {}})
        for name in args.designs.split(","):
            design = splitlf.Design.from_toml(HERE / preset / f"{name}.toml")
            rows = out["designs"].setdefault(name, {})
            for z in depths:
                for key in args.noise.split(","):
                    r = measure(design, z, kinds[key])
                    rows.setdefault(key, {})[f"{z:g}"] = r
                    print(f"{preset} {name} {z:g} mm {key}: MTF50 {r['mtf50']} cycles/mm "
                          f"(Nyquist {r['nyquist']:.3f}), {r['rows']} rows, "
                          f"{r['seconds']:.1f} s", flush=True)
                    path.write_text(json.dumps(out, indent=1) + "\n")
        print("| design | raw | " + " | ".join(f"{z:g} mm" for z in SIMULATE_DEPTHS) + " |")
        for name, rows in out["designs"].items():
            for key, rs in rows.items():
                cells = []
                for z in SIMULATE_DEPTHS:
                    r = rs.get(f"{z:g}")
                    cells.append("–" if r is None else f"≥ {r['nyquist']:.2f}"
                                 if r["mtf50"] is None else
                                 f"{r['mtf50']:.2f} ({r['mtf50'] / r['nyquist']:.2f})")
                print(f"| {name} | {key} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
