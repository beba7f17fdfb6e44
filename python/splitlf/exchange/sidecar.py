"""The sidecar ``splitlf.json`` of an export (docs/export.md, "The sidecar"): what the files
are, how values became digital numbers, the design, the noise model and which way up the
scene is, in each target's own terms."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from .. import _native
from .._files import json_safe
from ..imaging.render import Raw
from .formats import DN_MAX

__all__ = ["FORMAT", "ORIENTATION", "TARGET_ORIENTATION", "WHITE_DEPTH_F", "sidecar_document",
           "write_json"]

#: The ``format`` entry of the sidecar ``splitlf.json``.
FORMAT = "splitlf-export/1"
#: The white image's scene depth, in focal lengths of the main lens (any depth > F gives
#: the same white: the albedo and the background are 1 everywhere).
WHITE_DEPTH_F = 10.0

#: Which way up the scene is (docs/model.md §10, "Raw layout"), for every target.
ORIENTATION = {
    "rows": "upright: row 0 (at the top) shows the scene's top, Y > 0",
    "columns": "mirrored: column 0 (at the left) shows the scene's X > 0 side, which a "
               "texture shows at its right; numpy.fliplr gives the scene as the texture "
               "shows it",
    "micro_images": "a pixel at offset (dy, dx) from its micro-image centre sees the main "
                    "lens at w = -(L/v) (dx, dy) (docs/model.md §9); in the raw's own "
                    "(mirrored) frame a view cut further right or down in the micro images "
                    "looks through the part of the lens further right or down in that frame: "
                    "flip the view order together with the image",
}

#: The same in each target's own terms.
TARGET_ORIENTATION = {
    "plenopticam": "PlenoptiCam (its option opt_rota off, the default) decodes in the "
                   "raw's frame: its sub-aperture views and refocused images are upright "
                   "and mirrored left to right; flip them, and the order of its "
                   "horizontal viewpoints, left to right to see the scene as the texture "
                   "shows it",
    "plenpy": "plenpy's x is the image's first axis (rows) and y its second (columns): "
              "along x the images are upright (x = 0 shows the scene's top), along y "
              "mirrored (y = 0 shows the scene's X > 0 side); flip y, and the order of "
              "the views along it, to see the scene as the texture shows it",
    "tiff": "no Orientation tag is written, so readers take TIFF's default (1: row 0 "
            "at the top, column 0 at the left): the images are upright and mirrored "
            "left to right",
}


def _noise(raw: Raw, scale: float) -> dict[str, Any]:
    if raw.noise is None:
        return {"stated": False, "model": "not stated by the raw"}
    n, r = raw.noise["photons"], raw.noise["read_noise"]
    doc: dict[str, Any] = {
        "stated": True, "photons": n, "read_noise": r,
        "model": "docs/model.md §10: counts Poisson(N value) plus Gaussian read noise of r "
                 "electrons rms, divided by N (photons null: noise-free)",
    }
    if math.isfinite(n):
        doc.update(gain_dn_per_electron=scale / n, read_noise_dn=scale * r / n)
    return doc


def _options_text(options: dict[str, Any]) -> dict[str, Any]:
    return {k: v if isinstance(v, bool | int | float | str) or v is None else repr(v)
            for k, v in options.items()}


def sidecar_document(raw: Raw, target: str, scale: float, channels: list[dict[str, Any]],
                     truth: dict[str, Any] | None,
                     white_options: dict[str, Any]) -> dict[str, Any]:
    """The sidecar's contents (docs/export.md, "The sidecar")."""
    design = raw.design.design
    return {
        "format": FORMAT,
        "splitlf_version": _native.__version__,
        "target": target,
        "scale": {"dn_per_unit": scale, "bits": 16, "black_level_dn": 0,
                  "white_level_dn": DN_MAX, "white_level_value": DN_MAX / scale,
                  "value": "value = DN / dn_per_unit (docs/model.md §10's units: a pixel of "
                           "pitch mu_1 on plane L_1 seeing the whole aperture under albedo 1 "
                           "reads 1)",
                  "dn": "DN = rint(value x dn_per_unit), clipped to [0, white_level_dn]"},
        "white": {"render": "splitlf.render(design, Scene(1.0, depth, background=1.0), "
                            "**options), noise-free",
                  "depth_mm": WHITE_DEPTH_F * design.F, "options": _options_text(white_options)},
        "orientation": {**ORIENTATION, "target": TARGET_ORIENTATION[target]},
        "noise": _noise(raw, scale),
        "design": {"file": "design.toml", "toml": design.design.to_toml(),
                   "main_lens": {"F": design.F, "D": design.D, "aperture": design.aperture}},
        "channels": channels,
        "ground_truth": truth,
    }


def write_json(path: Path, doc: dict[str, Any]) -> None:
    """``doc`` as indented JSON (non-finite numbers as null)."""
    path.write_text(json.dumps(json_safe(doc), indent=2, allow_nan=False) + "\n",
                    encoding="utf-8")
