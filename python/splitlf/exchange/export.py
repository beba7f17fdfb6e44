"""A raw handed over to the light field ecosystem: :func:`export` writes a :class:`~splitlf.Raw`
with its design's white image and micro-image centres in the files PlenoptiCam, plenpy or
any TIFF reader takes (docs/export.md).

Every number written is computed: the centres by the core
(:meth:`~splitlf.Design.micro_image_centers`), the white image by :func:`~splitlf.render`
of a uniform albedo-1 scene, the ground truth's cell means by the core's exact texture
integrals. The folder is written atomically: complete, or absent after an error.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .. import _native, _validate
from .._files import atomic_folder, check_new_folder
from ..errors import InvalidParameter
from ..imaging.render import DepthMap, Plane, Raw, Scene, native_scene, render
from ..imaging.texture import RandomAlbedo
from ..model.design import Design
from . import formats
from .formats import DN_MAX, TARGETS
from .sidecar import FORMAT, WHITE_DEPTH_F, sidecar_document, write_json

__all__ = ["FORMAT", "TARGETS", "TRUTH_FORMAT", "Export", "export", "libraries", "white_raw"]

#: The ``format`` entry of the ground truth's ``truth/truth.npz``.
TRUTH_FORMAT = "splitlf-export-truth/1"
#: render() options a white image may not take: it is noise-free by definition.
_WHITE_REFUSED = ("noise", "noise_tol", "seed", "executor", "rows_per_task")

#: Per target, each channel's files: raw image, white image, calibration (relative to the
#: channel's folder chN/).
LAYOUT = {
    "plenopticam": {"raw": "raw.tiff", "white": "white.tiff", "calibration": "white.json"},
    "plenpy": {"raw": "Images/raw.png", "white": "Calibration/white.png",
               "calibration": "Calibration/grid.npz"},
    "tiff": {"raw": "raw.tiff", "white": "white.tiff", "calibration": "centres.csv"},
}


@dataclasses.dataclass(frozen=True)
class Export:
    """What :func:`export` wrote: the ``directory`` and the ``sidecar`` (the contents of
    its ``splitlf.json``: files, scale, clipping, orientation, design, noise)."""

    directory: Path
    sidecar: dict[str, Any]

    @property
    def clipped(self) -> int:
        """Pixels clipped to 0 or to the white level over every image written."""
        return sum(c["clipped"][k][e] for c in self.sidecar["channels"]
                   for k in ("raw", "white") for e in ("above", "below"))


def white_raw(design: Design, white_options: Mapping[str, Any] | None = None) -> Raw:
    """The white image of ``design``: :func:`~splitlf.render` of a uniform albedo-1 scene
    (background 1) on the plane at ``WHITE_DEPTH_F`` F, noise-free, with the render
    options ``white_options`` (e.g. ``tol``, ``n_threads``, and whatever the render gains,
    such as a falloff: passed on as given; ``noise``, ``noise_tol``, ``seed``,
    ``executor`` and ``rows_per_task`` refused)."""
    opts = _white_options(white_options)
    opts.setdefault("progress", False)
    return render(design, Scene(1.0, WHITE_DEPTH_F * design.F, background=1.0), **opts)


def _white_options(value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise TypeError("white_options must be a mapping of splitlf.render's keyword "
                        f"arguments, got {type(value).__name__}")
    bad = sorted(k for k in value if k in _WHITE_REFUSED or not isinstance(k, str))
    if bad:
        raise InvalidParameter.of("white_options", bad,
                                  "render options but " + ", ".join(_WHITE_REFUSED) +
                                  " (the white image is noise-free and drawn here)")
    return dict(value)


def _target(value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError(f"target must be one of {TARGETS}, got {type(value).__name__}")
    if value not in TARGETS:
        raise InvalidParameter.of("target", value, " or ".join(repr(t) for t in TARGETS))
    return value


def _scale(value: Any, white: Raw) -> float:
    """DN per unit of value: ``value``, or DN_MAX over the white image's brightest pixel."""
    if value is None:
        peak = max(float(a.max()) for a in white.images)
        if not peak > 0:
            raise InvalidParameter.of("scale", None, "a scale > 0 (the white image is dark: "
                                      "no default)")
        return DN_MAX / peak
    return _validate.positive(value, "scale", 1e15)


def _truth_scene(scene: Any) -> Scene | None:
    if scene is None:
        return None
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a splitlf.Scene or None, got {type(scene).__name__}")
    if isinstance(scene.texture, RandomAlbedo):
        raise TypeError("a RandomAlbedo's cells are drawn by the render: pass the scene with "
                        "its drawn texture as a splitlf.Image")
    return scene


def export(raw: Raw, target: str, directory: str | os.PathLike[str], *,
           scene: Scene | None = None, scale: float | None = None,
           white_options: Mapping[str, Any] | None = None,
           overwrite: bool = False) -> Export:
    """Write ``raw`` for ``target`` into the folder ``directory`` (docs/export.md).

    - ``raw``: a :class:`~splitlf.Raw` (its design, channels and noise model)
    - ``target``: ``"plenopticam"`` (16-bit TIFFs and PlenoptiCam's calibration JSON
      beside the white image), ``"plenpy"`` (plenpy's camera folder: Images/, Calibration/
      with 16-bit PNGs and plenpy's grid file) or ``"tiff"`` (16-bit TIFFs and the
      centres as CSV); one folder chN/ per channel
    - ``scene``: the scene the raw shows (optional): writes the ground truth, truth/
    - ``scale``: digital numbers per unit of the raw's value, DN = rint(value x scale) in
      [0, 65535], black level 0 (None: 65535 over the white image's brightest pixel, so
      the white image spans the 16 bits); values beyond are clipped, counted in the
      sidecar and warned about
    - ``white_options``: keyword arguments of :func:`~splitlf.render` for the white image
      (see :func:`white_raw`)
    - ``overwrite``: replace an existing folder with files in it (otherwise
      ``FileExistsError``); a missing or empty folder is always fine

    Returns an :class:`Export`. Raises ``TypeError``,
    :class:`~splitlf.errors.InvalidParameter`, ``FileExistsError`` and
    ``FileNotFoundError`` (the parent folder), all before any work; ``ImportError`` naming
    the ``export`` extra when tifffile or Pillow is missing.
    """
    if not isinstance(raw, Raw):
        raise TypeError(f"raw must be a splitlf.Raw, got {type(raw).__name__}")
    target_ = _target(target)
    truth = _truth_scene(scene)
    opts = _white_options(white_options)
    _need_libraries(target_, truth is not None)
    if scale is not None:
        _validate.positive(scale, "scale", 1e15)
    out = Path(directory)
    check_new_folder(out, bool(overwrite), "pass overwrite=True to replace it")
    white = white_raw(raw.design, opts)
    scale_ = _scale(scale, white)
    with atomic_folder(out, force=bool(overwrite),
                       hint="pass overwrite=True to replace it") as tmp:
        sidecar = _write_all(tmp, raw, white, target_, scale_, truth, opts)
    _warn_clipping(sidecar)
    return Export(out, sidecar)


def libraries(target: str, truth: bool) -> tuple[str, ...]:
    """The modules an export to ``target`` imports (tifffile for TIFFs, PIL for PNGs; the
    ground truth is TIFF)."""
    return tuple(sorted({"PIL" if target == "plenpy" else "tifffile",
                         *(("tifffile",) if truth else ())}))


def _need_libraries(target: str, truth: bool) -> None:
    for module in libraries(target, truth):
        try:
            __import__(module)
        except ImportError as e:
            raise ImportError(f"export to {target!r} needs the package {e.name} (pip install "
                              "'splitlf[export]')") from None


def _write_all(folder: Path, raw: Raw, white: Raw, target: str, scale: float,
               truth: Scene | None, white_options: dict[str, Any]) -> dict[str, Any]:
    design = raw.design
    (folder / "design.toml").write_text(design.design.to_toml(), encoding="utf-8")
    channels = [_write_channel(folder, design, i, raw.images[i - 1], white.images[i - 1],
                               target, scale)
                for i in range(1, len(raw.images) + 1)]
    truth_doc = None if truth is None else _write_truth(folder / "truth", design, truth)
    doc = sidecar_document(raw, target, scale, channels, truth_doc, white_options)
    write_json(folder / "splitlf.json", doc)
    return doc


def _write_channel(folder: Path, design: Design, i: int, image: np.ndarray,
                   white: np.ndarray, target: str, scale: float) -> dict[str, Any]:
    """Channel i's files; returns its entry of the sidecar."""
    ch = design.resolved()[i - 1]
    names = {k: f"ch{i}/{v}" for k, v in LAYOUT[target].items()}
    clipped = {}
    for key, values in (("raw", image), ("white", white)):
        q = formats.quantise(values, scale)
        formats.write_image(folder / names[key], q.dn, rgb=target == "plenopticam")
        clipped[key] = {"above": q.above, "below": q.below}
    every = design.micro_image_centers(i)
    centres = formats.inside(every, image.shape)
    pitch = design.micro_image_steps(i)
    lattice = (int(ch["Ky"]), int(ch["Kx"]))
    path = folder / names["calibration"]
    if target == "plenopticam":
        formats.write_plenopticam_calibration(path, centres, ch["grid"], pitch)
    elif target == "plenpy":
        formats.write_plenpy_grid(path, centres, image.shape, ch["grid"], pitch, lattice)
    else:
        formats.write_centres_csv(path, centres)
    return {"channel": i, "files": names, "shape": list(image.shape), "grid": ch["grid"],
            "layout": ch["layout"], "lattice": {"rows": lattice[0], "per_row": lattice[1]},
            "centres": {"written": len(centres), "off_the_raw": len(every) - len(centres)},
            "pitch_px": {"row": pitch[0], "column": pitch[1]},
            "microlens_image_diameter_px": 2 * design.image_radius(i) / ch["mu"],
            "clipped": clipped}


def _write_truth(folder: Path, design: Design, scene: Scene) -> dict[str, Any]:
    """The ground truth (docs/export.md, "Ground truth"): the texture's cell means over
    what the pixels of every channel see on the fronto-parallel plane at the scene's
    reference depth (``_native.render_extent``), on cells of the sensor step delta(z)
    there, and the surface's depth (a plane at the cell centres, a depth map as its own
    samples)."""
    z = scene.reference_depth()
    step = design.resolution_step(z)
    region = _native.render_extent(design.core, z)
    grid = _native.cell_grid(region, step)
    x0, y1, step, nx, ny = grid
    extent = (x0, x0 + nx * step, y1 - ny * step, y1)
    cells = _native.cell_averages(native_scene(scene, design, np.random.default_rng(0)), grid)
    arrays: dict[str, Any] = {"format": np.array(TRUTH_FORMAT), "texture": cells,
                              "texture_extent": np.array(extent), "cell_mm": np.array(step),
                              "background": np.array(float(scene.background or 0.0))}
    surface = scene.depth
    doc: dict[str, Any] = {"file": "truth/truth.npz", "texture_tiff": "truth/texture.tiff",
                           "texture_extent_mm": list(extent), "cell_mm": step,
                           "reference_depth_mm": z, "shape": [ny, nx]}
    folder.mkdir()
    formats.write_float_tiff(folder / "texture.tiff", cells)
    if isinstance(surface, Plane):
        xs = x0 + (np.arange(nx) + 0.5) * step
        ys = y1 - (np.arange(ny) + 0.5) * step
        depth = surface.z0 + surface.gx * xs[None, :] + surface.gy * ys[:, None]
        arrays.update(plane=np.array([surface.z0, surface.gx, surface.gy]), depth=depth)
        doc.update(plane=[surface.z0, surface.gx, surface.gy], depth_tiff="truth/depth.tiff")
        formats.write_float_tiff(folder / "depth.tiff", depth)
    else:
        assert isinstance(surface, DepthMap)
        arrays.update(depth_map=surface.depth, depth_map_extent=np.array(surface.extent))
        doc.update(depth_map_extent_mm=list(surface.extent),
                   depth_map_tiff="truth/depth_map.tiff")
        formats.write_float_tiff(folder / "depth_map.tiff", surface.depth)
    with open(folder / "truth.npz", "wb") as fh:
        np.savez(fh, **arrays)
    return doc


def _warn_clipping(sidecar: dict[str, Any]) -> None:
    import warnings

    for c in sidecar["channels"]:
        for key in ("raw", "white"):
            n = c["clipped"][key]
            if n["above"] or n["below"]:
                level = DN_MAX / sidecar["scale"]["dn_per_unit"]
                warnings.warn(f"channel {c['channel']}'s {key} image: {n['above']} pixels "
                              f"above the white level (value {level:.6g}) and {n['below']} "
                              "below 0 clipped (see scale=)", stacklevel=3)
