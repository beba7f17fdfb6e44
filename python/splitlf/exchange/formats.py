"""The files of each export target (docs/export.md): 16-bit images, the micro-image centres
in each target's own calibration format, and the quantisation to digital numbers.

Images: 16-bit TIFF through ``tifffile`` (the reference TIFF writer of the scientific
Python stack, by the author of the TIFF support of imageio and scikit-image; it writes and
reads uint16 exactly, with no colour management), 16-bit PNG through Pillow (plenpy's
camera folder reads its images through imageio, whose PNG reader is Pillow). Both are
imported on first use: the ``export`` extra.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

__all__ = ["DN_MAX", "TARGETS", "Quantised", "inside", "quantise",
           "read_image", "write_centres_csv", "write_image", "write_plenopticam_calibration",
           "write_plenpy_grid"]

#: The export targets.
TARGETS = ("plenopticam", "plenpy", "tiff")
#: The largest digital number of a 16-bit file (the white level).
DN_MAX = 65535


class Quantised:
    """An image in digital numbers: ``dn`` = rint(value x scale) held to [0, DN_MAX], with
    how many pixels were clipped at either end (``above``: value x scale > DN_MAX + 1/2;
    ``below``: < -1/2, e.g. read noise below black)."""

    def __init__(self, values: np.ndarray, scale: float) -> None:
        scaled = np.rint(np.asarray(values, dtype=np.float64) * scale)
        self.above = int(np.count_nonzero(scaled > DN_MAX))
        self.below = int(np.count_nonzero(scaled < 0))
        self.dn = np.clip(scaled, 0, DN_MAX).astype(np.uint16)


def quantise(values: np.ndarray, scale: float) -> Quantised:
    """``values`` in digital numbers at ``scale`` (DN per unit of value)."""
    return Quantised(values, scale)


def write_image(path: Path, dn: np.ndarray, rgb: bool = False) -> None:
    """A 16-bit image: .tiff through tifffile, .png through Pillow; greyscale, or with
    ``rgb`` three equal channels (a TIFF only: PlenoptiCam decodes generic files as RGB)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".tiff":
        import tifffile

        if rgb:
            tifffile.imwrite(path, np.repeat(dn[:, :, None], 3, axis=2), photometric="rgb")
        else:
            tifffile.imwrite(path, dn, photometric="minisblack")
    elif path.suffix == ".png":
        from PIL import Image

        Image.fromarray(np.ascontiguousarray(dn, dtype=np.uint16)).save(path)
    else:  # pragma: no cover - the targets name their files
        raise AssertionError(f"no writer for {path.suffix}")


def read_image(path: Path) -> np.ndarray:
    """A 16-bit image written by :func:`write_image`, as uint16 [row, column] (and
    [..., channel] for an RGB one)."""
    if path.suffix == ".tiff":
        import tifffile

        return np.asarray(tifffile.imread(path))
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im).astype(np.uint16)


def write_float_tiff(path: Path, values: np.ndarray) -> None:
    """A float32 greyscale TIFF (the ground truth's albedos and depths)."""
    import tifffile

    path.parent.mkdir(parents=True, exist_ok=True)
    tifffile.imwrite(path, np.asarray(values, dtype=np.float32), photometric="minisblack")


def inside(centres: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The centres (rows of [row, column, k, j]) that lie on the raw: within the pixels'
    area, [-1/2, rows - 1/2) x [-1/2, columns - 1/2)."""
    r, c = centres[:, 0], centres[:, 1]
    keep = (r >= -0.5) & (r < shape[0] - 0.5) & (c >= -0.5) & (c < shape[1] - 0.5)
    return np.asarray(centres[keep])


def write_plenopticam_calibration(path: Path, centres: np.ndarray, grid: str,
                                  pitch: tuple[float, float]) -> None:
    """PlenoptiCam's calibration file (``PlenopticamConfig.save_cal_data``: the keys of
    ``plenopticam.cfg.constants.CALIBS_KEYS``, written as PlenoptiCam writes them, sorted
    and indented by 4): ``mic_list``, one [y, x, ly, lx] per micro image (row, column, the
    lens's row and column index), ``pat_type`` "hex" or "rec", ``ptc_mean`` [pitch_y,
    pitch_x] in pixels (pitch_y the spacing of lens rows)."""
    doc = {
        "mic_list": [[float(r), float(c), int(k), int(j)] for r, c, k, j in centres],
        "pat_type": "hex" if grid == "hex" else "rec",
        "ptc_mean": [pitch[0], pitch[1]],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, sort_keys=True, indent=4, allow_nan=False),
                    encoding="utf-8")


def write_plenpy_grid(path: Path, centres: np.ndarray, shape: tuple[int, int], grid: str,
                      pitch: tuple[float, float], lattice: tuple[int, int]) -> None:
    """plenpy's grid file (the keys of ``plenpy.utilities.grids.AbstractGrid.save``, which
    ``HexGrid.from_file`` / ``RectGrid.from_file`` read): plenpy's x is the image's first
    axis (rows) and y its second (columns), so ``grid_points`` is [row, column] per lens
    in the centres' order (lattice rows first: plenpy's index i m + j), ``grid_parameters_
    spacing`` [spacing_x, spacing_y] is [2 x row step, column step] on a hex grid (plenpy's
    hex rows are 1/2 spacing_x apart, odd ones shifted by 1/2 spacing_y) and [row step,
    column step] on a rect one, ``grid_parameters_offset`` the first lens's [row, column],
    rotation 0, ``n`` lattice rows, ``m`` lenses per row, ``noise`` zeros (the points are
    the lattice itself) and ``crop_amount`` 0."""
    step_x = 2 * pitch[0] if grid == "hex" else pitch[0]
    points = np.ascontiguousarray(centres[:, :2], dtype=np.float64)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        np.savez(fh,
                 grid_parameters_size=np.array(shape, dtype=np.int64),
                 grid_parameters_spacing=np.array([step_x, pitch[1]]),
                 grid_parameters_rotation=np.array(0.0),
                 grid_parameters_offset=points[0].copy(),
                 grid_points=points, noise=np.zeros_like(points),
                 n=np.array(lattice[0]), m=np.array(lattice[1]),
                 crop_amount=np.array(0.0))


def write_centres_csv(path: Path, centres: np.ndarray) -> None:
    """The centres as CSV: a header row ``row,column,k,j`` then one lens per line (the
    coordinates with 17 significant digits: they read back exactly)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["row", "column", "k", "j"])
        for r, c, k, j in centres:
            w.writerow([repr(float(r)), repr(float(c)), int(k), int(j)])
