"""The image merits against the full-field study of docs/fig2.md (docs/merits.md).

For the seed cut as in docs/make_fig2.py, at each of its depths and both photon counts:
splitlf.image_merits per row (channel 1 = half 1, channel 2 = half 2, union = split), with
the ensemble fitted (splitlf.Ensemble.fit, exponent free) to the study's own truth at that
depth (the natural texture's cell averages over the study's region), against the study's
PSNR and MTF50 / Nyquist (docs/fig2.json: the mean of its two draws). Then the time of one
depth for the seed (full preset), lytro-illum and raytrix-r12 (every row, the default
ensemble). Writes docs/merits.json.

Run: python docs/make_merits.py (both parts); python docs/make_merits.py --timing (the
timing alone, into the existing docs/merits.json); python docs/make_merits.py --measured
(the agreement again with the ensemble's measured spectrum, Ensemble.measure, into
"agreement_measured" of the existing docs/merits.json; with --weighted after it, at the
merits' rule "weighted gcv", into "agreement_measured_weighted").
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import splitlf
from splitlf import _native
from splitlf.inverse.merits import Ensemble, image_merits

HERE = Path(__file__).parent


def study_truth(split: splitlf.Design, z: float) -> np.ndarray:
    import make_fig2 as f2

    region = f2.central(split, z)
    span = _native.pixel_span(split.core, z, None)
    tex = f2.natural(2.0 * (max(abs(v) for v in region) + 2.0 * span))
    grid = _native.cell_grid(region, split.resolution_step(z))
    sc = _native.RenderScene(*tex.seam(), "plane", [1000.0, 0.0, 0.0], None, 0.0)
    return _native.cell_averages(sc, grid)


def agreement(out: dict, key_out: str = "agreement", measured: bool = False,
              rule: str = "gcv") -> None:
    """Every depth, row and photon count against docs/fig2.json's mean of two draws; the
    ensemble fitted to the study's truth (``Ensemble.fit``), or with ``measured`` its
    radially averaged spectrum itself (``Ensemble.measure``); the merits' ``rule``;
    written to ``key_out``."""
    import make_fig2 as f2

    split, _ = f2.designs()
    fig2 = json.loads((HERE / "fig2.json").read_text())
    names = {"channel 1": "half 1", "channel 2": "half 2", "union": "split"}
    for photons in f2.PHOTONS:
        key = f"{photons:.0f}"
        runs = [fig2["runs"][f"{key}/{d}"] for d in range(f2.DRAWS)]
        rows: dict = {}
        for i, z in enumerate(f2.DEPTHS):
            truth = study_truth(split, z)
            ens = Ensemble.measure(truth) if measured else Ensemble.fit(truth)
            r = image_merits(split, [z], photons, ensemble=ens, rule=rule)
            for row, cam in names.items():
                st_p = float(np.mean([ru["psnr"][cam][i] for ru in runs]))
                st_m = float(np.mean([ru["mtf50"][cam][i] for ru in runs])) / fig2["nyquist"][i]
                m = r.rows[row]
                rows.setdefault(row, []).append({
                    "depth": z, "ensemble": [ens.mean, ens.amplitude, ens.exponent],
                    "psnr": float(m["psnr"][0]), "psnr_error": float(m["psnr_error"][0]),
                    "study_psnr": st_p, "mtf50": float(m["mtf50"][0]), "study_mtf50": st_m,
                    "lambda": float(m["regularization"][0]),
                    "study_lambda": [ru["lambda_psnr"][cam][i] for ru in runs],
                    "seconds": float(m["seconds"][0])})
                e = rows[row][-1]
                print(f"N {key} {z:6.0f} {row:9s} psnr {e['psnr']:6.2f}+-{e['psnr_error']:.2f}"
                      f" study {st_p:6.2f} d {e['psnr'] - st_p:+.2f}  mtf {e['mtf50']:.3f} "
                      f"study {st_m:.3f} d {e['mtf50'] - st_m:+.3f} lam {e['lambda']:.3g} "
                      f"({e['seconds']:.2f} s) alpha {ens.exponent:.2f}", flush=True)
        out[key_out][key] = rows
        (HERE / "merits.json").write_text(json.dumps(out, indent=1) + "\n")


def timing(out: dict) -> None:
    for name, depths in (("seed", (642.0, 1000.0)), ("lytro-illum", (1000.0, 2500.0)),
                         ("raytrix-r12", (407.0, 700.0))):
        d = splitlf.Design.preset(name)
        t0 = time.perf_counter()
        r = image_merits(d, list(depths), 2000.0, n_threads=2)
        wall = time.perf_counter() - t0
        out["timing"][name] = {row: {"depths": list(depths), "seconds": v["seconds"].tolist(),
                                     "psnr": v["psnr"].tolist(), "mtf50": v["mtf50"].tolist()}
                               for row, v in r.rows.items()}
        out["timing"][name]["all rows, per depth"] = wall / len(depths)
        print(name, json.dumps(out["timing"][name]), flush=True)
        (HERE / "merits.json").write_text(json.dumps(out, indent=1) + "\n")


def main() -> None:
    import sys

    sys.path.insert(0, str(HERE))
    if sys.argv[1:] == ["--timing"]:
        out = json.loads((HERE / "merits.json").read_text())
        out["timing"] = {}
        timing(out)
        return
    if sys.argv[1:2] == ["--measured"]:
        weighted = sys.argv[2:] == ["--weighted"]
        key = "agreement_measured" + ("_weighted" if weighted else "")
        out = json.loads((HERE / "merits.json").read_text())
        out[key] = {}
        agreement(out, key, measured=True, rule="weighted gcv" if weighted else "gcv")
        return
    out: dict = {"agreement": {}, "timing": {}}
    t0 = time.perf_counter()
    agreement(out)
    timing(out)
    out["seconds"] = time.perf_counter() - t0
    (HERE / "merits.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
