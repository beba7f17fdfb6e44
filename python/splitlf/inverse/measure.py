"""Image quality of a reconstruction against the truth (docs/model.md §11,
docs/reconstruct.md): PSNR and SSIM (scikit-image's implementations, the reference ones of
the field, rather than our own), and MTF50 from a slanted edge (ISO 12233 style).

The truth is a texture, evaluated as its averages over the reconstruction's cells by the
core (``_native.cell_averages``: exact polygon integrals of the texture), or an array
already on the reconstruction's grid. Albedos are in their own units (white = 1), so the
PSNR's peak (``data_range``) is 1.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _native
from ..errors import InvalidParameter
from ..imaging.texture import RandomAlbedo, SlantedEdge
from .reconstruct import ColourReconstruction, Reconstruction

#: PSNR's and SSIM's data range: albedo 0 to 1.
DATA_RANGE = 1.0


def _grid(rec: Reconstruction) -> tuple[float, float, float, int, int]:
    ny, nx = rec.image.shape
    return (rec.extent[0], rec.extent[3], rec.step, nx, ny)


def truth(rec: Reconstruction, texture: Any) -> np.ndarray:
    """The texture's averages over the reconstruction's cells (an array of the image's
    shape, row 0 at the top), or ``texture`` itself when it is already such an array."""
    if isinstance(rec, ColourReconstruction):
        raise TypeError("rec is a ColourReconstruction (three colours): measure each colour "
                        "on its own, rec.colours[k] against texture.colour(k)")
    if not isinstance(rec, Reconstruction):
        raise TypeError(f"rec must be a splitlf.Reconstruction, got {type(rec).__name__}")
    if isinstance(texture, np.ndarray):
        if texture.shape != rec.image.shape:
            raise InvalidParameter.of("truth", f"shape {texture.shape}",
                                      f"the reconstruction's shape {rec.image.shape}")
        out = np.asarray(texture, dtype=np.float64)
        if not np.all(np.isfinite(out)):
            raise InvalidParameter.of("truth", "non-finite values", "finite albedos")
        return out
    if isinstance(texture, RandomAlbedo):
        raise TypeError("a RandomAlbedo's draw depends on the render; pass its image (an "
                        "Image texture) or an array on the reconstruction's grid")
    seam = getattr(texture, "seam", None)
    if seam is None:
        raise TypeError(f"truth must be a texture or an array, got {type(texture).__name__}")
    kind, params, image = seam()
    # Cell averages are the texture's alone: any surface will do.
    scene = _native.RenderScene(kind, params, image, "plane", [1000.0, 0.0, 0.0], None, 0.0)
    return _native.cell_averages(scene, _grid(rec))


def psnr(rec: Reconstruction, texture: Any) -> float:
    """Peak signal-to-noise ratio (dB, peak 1) of the reconstruction against the truth
    (``skimage.metrics.peak_signal_noise_ratio``); +inf when they are equal."""
    from skimage.metrics import peak_signal_noise_ratio

    t = truth(rec, texture)
    with np.errstate(divide="ignore"):  # identical images: +inf, not a warning
        return float(peak_signal_noise_ratio(t, rec.image, data_range=DATA_RANGE))


def ssim(rec: Reconstruction, texture: Any) -> float:
    """Mean structural similarity of the reconstruction and the truth
    (``skimage.metrics.structural_similarity``, 7 x 7 windows, data range 1); the image
    must be at least 7 cells on each side."""
    from skimage.metrics import structural_similarity

    t = truth(rec, texture)
    if min(t.shape) < 7:
        raise InvalidParameter.of("rec", f"image {t.shape}", "at least 7 x 7 cells for SSIM")
    return float(structural_similarity(t, rec.image, data_range=DATA_RANGE))


#: Edge-spread bins per cell (ISO 12233's 4x oversampling).
OVERSAMPLE = 4


def mtf50(rec: Reconstruction, edge: SlantedEdge) -> float:
    """The spatial frequency (cycles/mm on the surface) where the reconstruction's
    modulation transfer falls to half, from the slanted ``edge`` it shows (ISO 12233
    style): the cells' signed distances to the known edge binned at 1/4 cell into an
    edge-spread function, its derivative (the line spread) under a Hann window, the FFT's
    modulus normalised at zero frequency, and the first crossing of 0.5, linearly
    interpolated. ``nan`` when the transfer never falls to half below the cells' Nyquist
    frequency (1 / (2 step)). An edge whose line does not cross the region (cells more
    than a step from it on both sides) raises :class:`~splitlf.errors.InvalidParameter`."""
    if not isinstance(rec, Reconstruction):
        raise TypeError(f"rec must be a splitlf.Reconstruction, got {type(rec).__name__}")
    if not isinstance(edge, SlantedEdge):
        raise TypeError(f"edge must be a splitlf.SlantedEdge, got {type(edge).__name__}")
    return mtf50_image(rec.image, rec.extent, rec.step, edge)


def mtf50_image(image: np.ndarray, extent: Any, step: float, edge: SlantedEdge) -> float:
    """:func:`mtf50` of an image on a grid of cells (``image`` (ny, nx), row 0 at the top,
    over ``extent`` (X0, X1, Y0, Y1) mm, cells of ``step`` mm): the edge method without a
    :class:`Reconstruction` (the image merits' expected edge image, docs/merits.md)."""
    if not isinstance(edge, SlantedEdge):
        raise TypeError(f"edge must be a splitlf.SlantedEdge, got {type(edge).__name__}")
    image = np.asarray(image, dtype=np.float64)
    ny, nx = image.shape
    h = float(step)
    xs = extent[0] + (np.arange(nx) + 0.5) * h
    ys = extent[3] - (np.arange(ny) + 0.5) * h
    X, Y = np.meshgrid(xs, ys)
    a = math.radians(edge.angle)
    dist = (X - edge.center[0]) * math.cos(a) - (Y - edge.center[1]) * math.sin(a)
    if not (dist.min() < -h and dist.max() > h):
        x0, x1, y0, y1 = extent
        raise InvalidParameter.of(
            "edge", f"center {tuple(edge.center)}, angle {edge.angle:g} deg",
            f"an edge crossing the reconstruction's region X [{x0:.6g}, {x1:.6g}], "
            f"Y [{y0:.6g}, {y1:.6g}] mm with cells on both sides")
    bin_w = h / OVERSAMPLE
    idx = np.round(dist / bin_w).astype(np.int64)
    lo, hi = idx.min(), idx.max()
    counts = np.bincount(idx.ravel() - lo, minlength=hi - lo + 1)
    sums = np.bincount(idx.ravel() - lo, weights=image.ravel(), minlength=hi - lo + 1)
    filled = counts > 0
    if filled.sum() < 8 * OVERSAMPLE:
        raise InvalidParameter.of("edge", f"{int(filled.sum())} distance bins",
                                  "an edge crossing the reconstruction's region")
    pos = np.arange(lo, hi + 1)
    esf = np.interp(pos, pos[filled], sums[filled] / counts[filled])
    if esf[-1] < esf[0]:
        esf = esf[::-1]
    lsf = np.gradient(esf) * np.hanning(esf.size)
    if not np.any(lsf != 0.0):
        return float("nan")
    spec = np.abs(np.fft.rfft(lsf))
    mtf = spec / spec[0] if spec[0] > 0 else spec
    freq = np.fft.rfftfreq(lsf.size, d=bin_w)  # cycles/mm
    nyq = 1.0 / (2.0 * h)
    below = np.flatnonzero((mtf < 0.5) & (freq <= nyq))
    if below.size == 0:
        return float("nan")
    k = int(below[0])
    if k == 0:
        return 0.0
    f0, f1, m0, m1 = freq[k - 1], freq[k], mtf[k - 1], mtf[k]
    return float(f0 + (0.5 - m0) * (f1 - f0) / (m1 - m0))


#: BadPix's threshold: a confident cell whose relative depth error exceeds this is bad.
BADPIX_THRESHOLD = 0.01


def depth_errors(estimate: Any, truth: Any) -> dict[str, float]:
    """The errors of a depth estimate (docs/depth.md): over its confident cells, the
    ``median`` and 90th percentile (``p90``) of the relative error |z_est - z| / z, and
    ``badpix`` (the share of confident cells above 1 % relative error, the HCI benchmark's
    BadPix with a relative threshold); ``confident`` (the share of confident cells). The
    errors are NaN when no cell is confident.

    ``estimate`` is a :class:`~splitlf.DepthMap` (from :func:`~splitlf.estimate_depth`:
    cells without a ``confident`` mask count as confident); ``truth`` a depth (mm, a
    fronto-parallel plane), a :class:`~splitlf.Plane` (evaluated at the cell centres) or an
    array of the estimate's shape."""
    from ..imaging.render import DepthMap, Plane

    if not isinstance(estimate, DepthMap):
        raise TypeError(f"estimate must be a splitlf.DepthMap, got {type(estimate).__name__}")
    z = estimate.depth
    ny, nx = z.shape
    x0, x1, y0, y1 = estimate.extent
    if isinstance(truth, Plane):
        xs = x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx
        ys = y1 - (np.arange(ny) + 0.5) * (y1 - y0) / ny
        true = truth.z0 + truth.gx * xs[None, :] + truth.gy * ys[:, None]
    elif isinstance(truth, np.ndarray):
        if truth.shape != z.shape:
            raise InvalidParameter.of("truth", f"shape {truth.shape}",
                                      f"the estimate's shape {z.shape}")
        true = np.asarray(truth, dtype=np.float64)
    elif isinstance(truth, int | float | np.integer | np.floating) and not isinstance(
            truth, bool):
        true = np.full(z.shape, float(truth))
    else:
        raise TypeError("truth must be a depth (mm), a splitlf.Plane or an array, got "
                        f"{type(truth).__name__}")
    if not np.all(np.isfinite(true) & (true > 0)):
        raise InvalidParameter.of("truth", "non-finite or non-positive depths",
                                  "finite depths > 0 mm")
    conf = np.ones(z.shape, bool) if estimate.confident is None else estimate.confident
    rel = np.abs(z - true)[conf] / true[conf]
    nan = float("nan")
    return {
        "median": float(np.median(rel)) if rel.size else nan,
        "p90": float(np.percentile(rel, 90)) if rel.size else nan,
        "badpix": float(np.mean(rel > BADPIX_THRESHOLD)) if rel.size else nan,
        "confident": float(conf.mean()),
    }
