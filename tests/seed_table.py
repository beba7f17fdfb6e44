"""The seed design's published numbers as one table (issue 20: pinned before the Camera /
Design engines were folded into one, and required to agree to 1e-12 relative after it).

``python tests/seed_table.py`` rewrote ``tests/data/seed_pinned.json`` once, from the
two-engine code (commit b51e209); ``tests/test_seed_pinned.py`` compares the one engine's
numbers with it. The table is built only from the public API, by row name, so it reads the
same numbers whichever class computes them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import splitlf

PINNED = Path(__file__).resolve().parent / "data" / "seed_pinned.json"
#: Depths of the paper's figures and text (mm): Fig. 1's range, both out-of-focus planes,
#: the 300 mm / 1 m / 3 m columns of the docs.
DEPTHS = [150.0, 217.0, 250.0, 300.0, 400.0, 500.0, 642.0, 800.0, 1000.0, 2000.0, 3000.0,
          10_000.0]


def _finite(x: float) -> float | None:
    return None if not math.isfinite(x) else float(x)


def _intervals(iv) -> list[list[float | None]]:
    return [[_finite(a), _finite(b)] for a, b in iv]


def table(cam, half1: str, half2: str, split: str) -> dict:
    """The table of ``cam`` (the seed), its rows named ``half1``, ``half2``, ``split`` in
    the result classes that compute it."""
    z = np.array(DEPTHS)
    c = splitlf.curves(cam, z)
    dof = splitlf.depth_of_field(cam)
    fr = splitlf.sharp_fractions(cam, (150.0, 10_000.0))
    ns = splitlf.new_samples(cam, z)
    ns_c = splitlf.new_samples(cam, z, sample="centroid")
    out: dict = {
        "out_of_focus": [cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)],
        "image_radius": [cam.image_radius(1), cam.image_radius(2)],
        "curves": {k: np.asarray(getattr(c, k)).tolist() for k in
                   ("conjugate", "main_blur", "repetitions", "blur_px", "conventional_px")},
        "microlens_blur": [[_finite(x) for x in row] for row in c.microlens_blur],
        "dof": {"half1": _intervals(dof.half1), "half2": _intervals(dof.half2),
                "split": _intervals(dof.split)},
        "sharp_fractions": [fr[half1], fr[half2], fr[split]],
        "distinct": ns.distinct.tolist(),
        "max_gap": [[_finite(x) for x in row] for row in ns.max_gap],
        "sampled": ns.sampled.tolist(),
        "distinct_centroid": ns_c.distinct.tolist(),
        "max_gap_centroid": [[_finite(x) for x in row] for row in ns_c.max_gap],
    }
    for h in (1, 2):
        p = splitlf.coincidence_planes(cam, h, max_n=3)
        out[f"planes{h}"] = {k: np.asarray(getattr(p, k)).tolist() for k in
                             ("N", "T", "z", "repetitions", "new_samples", "counted")}
        t = splitlf.trace(cam, h)
        k = np.flatnonzero(t.lens == t.lens[len(t.lens) // 2])  # one lens's pixels (Fig. 4)
        out[f"trace{h}"] = {"area": t.area[k].tolist(), "centroid": t.centroid[k].tolist(),
                            "vertices": np.nan_to_num(t.vertices[k]).tolist()}
        f = splitlf.footprints(cam, [300.0, 642.0, 1000.0], h)
        out[f"footprints{h}"] = {"position_sum": np.sum(f.position, axis=1).tolist(),
                                 "width_sum": np.sum(f.hi - f.lo, axis=1).tolist()}
    return out


if __name__ == "__main__":
    data = table(splitlf.Camera.paper(), "half1", "half2", "split")
    PINNED.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {PINNED}")
