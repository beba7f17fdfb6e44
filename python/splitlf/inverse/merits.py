"""Image merits (docs/merits.md): the PSNR a design's reconstruction reaches on an ensemble
of natural images, and the MTF50 of its mean response to a slanted edge, per depth and per
row (each channel, each lens type, the union), at a stated photon noise, without rendering
a raw.

The core (``_native.image_merits``, ``inverse::merit``) builds the reconstruction's map
over a patch of cells at the field's centre, padded by ``margin`` pixel spans, weights its
rows by the photon noise of a flat scene at the ensemble's mean, and estimates the
estimator's expected squared error over a power-law Gaussian ensemble (:class:`Ensemble`)
with ``samples`` Monte-Carlo draws of image and noise (one CG solve each per weight
tried), at the prior weight a reconstruction would choose from the draws' data
(``rule="gcv"``: generalised cross-validation as ``reconstruct(regularization=None)``
chooses it, on the draws' mean score) or, for comparison, at the weight of least expected
error (``rule="oracle"``, which no reconstruction can know). This module chooses the rows,
converts the error to PSNR (peak 1, as :func:`splitlf.measure.psnr`) and the edge's
expected image to MTF50 (:func:`splitlf.measure.mtf50_image`) as a share of the sensor's
Nyquist frequency 1 / (2 delta(z)).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from .. import _native, _validate
from ..errors import InvalidParameter
from ..imaging.texture import SlantedEdge
from .measure import mtf50_image
from .reconstruct import CHOOSE_BRACKET, CHOOSE_DF_WEIGHT, CHOOSE_PROBES, NOISE_FLOOR

__all__ = ["Ensemble", "ImageMerits", "image_merits"]

#: CG's relative stop and iteration cap in the merits' solves.
MERIT_RTOL = 1e-4
MERIT_MAX_ITER = 500
#: The rules of the prior's weight: GCV on the draws' data (plain, or weighted as a
#: reconstruction on a known surface weighs it), or the least expected error (the oracle's).
RULES = ("gcv", "weighted gcv", "oracle")
#: The most knots a measured spectrum may have (the core's ``ensemble::MAX_KNOTS``).
MAX_KNOTS = 4096
#: The bracket of the prior's weight (inverse-variance units, as reconstruct's) and the
#: golden-section steps of the search for the least expected error (rule "oracle").
MERIT_BRACKET = (1e-2, 1e4)
MERIT_GOLDEN_STEPS = 4
#: GCV's golden-section steps and its probes' relative stop in the merits: fewer than a
#: reconstruction's (4, 1e-6), measured on the seed cut at 800 mm (union, N = 2000): the
#: same PSNR within 0.005 dB (lambda 30 against 38 in a flat valley) in 0.45 of the
#: iterations (docs/merits.md, "Time").
MERIT_GCV_GOLDEN_STEPS = 2
MERIT_PROBE_RTOL = MERIT_RTOL
#: GCV's parabolic step after the decades instead of the golden sections: off; it saves a
#: quarter of the iterations but moves PSNR by up to 0.21 dB and MTF50 by up to 0.069 of
#: Nyquist on docs/make_merits.py's rows (docs/merits.md, "Speed").
MERIT_GCV_PARABOLA = False
#: CG's two-level preconditioner in the merits' solves (Jacobi plus an exact solve on
#: aggregates of cells, docs/merits.md "Two-level preconditioner"): the same solutions in
#: 0.5-0.65 of the iterations on the seed's half 2.
MERIT_COARSE = True
#: The edge of the MTF50: the study's (docs/fig2.md), through the field's centre.
MERIT_EDGE = SlantedEdge(5.0, 0.1, 0.9)


@dataclasses.dataclass(frozen=True)
class Ensemble:
    """A Gaussian image ensemble of power spectrum S(f) = amplitude^2 |f|^-exponent about
    ``mean`` (f in cycles per cell; S per cell^2, the periodogram's units
    E|DFT(x)|^2 / cells), flat below ``floor`` cycles per cell (S(f) = S(floor) for
    0 < f < floor; 0, the default: the power law down to the draws' lowest frequency).
    Natural images have exponents near 2 (scale invariance, Field 1987; van der Schaaf and
    van Hateren 1996); :meth:`fit` takes one from an image.

    ``spectrum``, when not empty, replaces the power law by a measured radial spectrum:
    knots (f, S), f strictly increasing in (0, 1] cycles per cell, S > 0, interpolated
    linearly in log f - log S and flat beyond the first and the last knot (the floor still
    applies; ``amplitude`` and ``exponent`` then only describe it). :meth:`measure` takes
    one from an image."""

    mean: float
    amplitude: float
    exponent: float = 2.0
    floor: float = 0.0
    spectrum: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        _validate.finite(self.mean, "mean")
        _validate.nonnegative(self.amplitude, "amplitude")
        _validate.nonnegative(self.exponent, "exponent", upper=float(_native_max_exponent()))
        _validate.nonnegative(self.floor, "floor", upper=0.5)
        object.__setattr__(self, "spectrum", _knots(self.spectrum))

    @classmethod
    def fit(cls, image: Any, exponent: float | None = None, *,
            flat_below_band: bool = False) -> Ensemble:
        """The ensemble fitted to ``image`` (2-D, on the cells): its mean, and a line through
        its radially averaged periodogram (Hann-windowed) in log-log over octave bins from
        2 cycles per image to 1/2 cycle per cell, equal weight per bin; ``exponent`` fixes
        the slope (only the amplitude is fitted). ``flat_below_band``: the spectrum flat
        below the fitted band (``floor`` = 2 cycles per image), not the line extrapolated
        to the draws' slower modes, which an image the size of the merit's padded patch
        rarely has: on docs/fig2.md's study that extrapolation cost half 2's merit 1.7-2.6
        dB against the study (docs/merits.md, "Why the merit and the study differ"). Off
        by default (the published merits were computed without it)."""
        x = _image(image)
        lf, lp = _radial(x, 2.0 / min(x.shape), 0.5, 8)
        if exponent is None:
            slope, icpt = np.polyfit(lf, lp, 1)
            a = min(max(-float(slope), 0.0), float(_native_max_exponent()))
        else:
            a = _validate.nonnegative(exponent, "exponent", upper=float(_native_max_exponent()))
        icpt = float(np.mean(np.asarray(lp) + a * np.asarray(lf)))
        if not isinstance(flat_below_band, bool):
            raise TypeError(f"flat_below_band must be a bool, got {type(flat_below_band).__name__}")
        floor = 2.0 / min(x.shape) if flat_below_band else 0.0
        return cls(float(x.mean()), math.exp(0.5 * icpt), a, floor)

    @classmethod
    def measure(cls, image: Any, per_octave: int = 4) -> Ensemble:
        """The ensemble of ``image``'s own spectrum (2-D, on the cells): its mean, and its
        radially averaged periodogram (Hann-windowed, as :meth:`fit`) over ``per_octave``
        log-spaced bins an octave (1 to 16) from 2 cycles per image to the corner's
        sqrt(2)/2 cycles per cell, a knot at each bin's geometric centre with the bin's
        mean power; flat below the first knot (no power extrapolated to slower modes than
        the image shows). ``amplitude`` and ``exponent`` are :meth:`fit`'s, for the record.
        Unlike a power law it keeps the image's own shape (docs/merits.md, "A measured
        spectrum")."""
        x = _image(image)
        k = _validate.integer_in(per_octave, "per_octave", 1, 16)
        lo = 2.0 / min(x.shape)
        bins = max(1, math.ceil(k * math.log2(math.sqrt(0.5) / lo)))
        lf, lp = _radial(x, lo, math.sqrt(0.5), bins)
        line = cls.fit(x)
        knots = tuple((math.exp(f), math.exp(p)) for f, p in zip(lf, lp, strict=True))
        return cls(line.mean, line.amplitude, line.exponent, 0.0, knots)


def _image(image: Any) -> np.ndarray:
    x = np.asarray(image, dtype=np.float64)
    if x.ndim != 2 or min(x.shape) < 8 or not np.all(np.isfinite(x)):
        raise InvalidParameter.of("image", f"shape {x.shape}", "a finite 2-D image, >= 8 x 8")
    return x


def _radial(x: np.ndarray, lo: float, hi: float, bins: int) -> tuple[list[float], list[float]]:
    """log f at each non-empty bin's geometric centre and log of its mean power: the
    radially averaged Hann-windowed periodogram of ``x`` (mean removed) over ``bins``
    log-spaced bins from ``lo`` to ``hi`` cycles per cell."""
    ny, nx = x.shape
    w = np.outer(np.hanning(ny), np.hanning(nx))
    p = np.abs(np.fft.fft2((x - x.mean()) * w)) ** 2 / float((w ** 2).sum())
    f = np.hypot(np.fft.fftfreq(nx)[None, :], np.fft.fftfreq(ny)[:, None])
    edges = np.geomspace(lo, hi, bins + 1)
    lf, lp = [], []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        m = (f >= a) & (f < b)
        if m.any():
            v = float(p[m].mean())
            if not v > 0.0:
                raise InvalidParameter.of("image", f"no power at {a:.3g}-{b:.3g} cycles per "
                                          "cell", "an image with contrast in every band")
            lf.append(math.log(float(np.sqrt(a * b))))
            lp.append(math.log(v))
    return lf, lp


def _knots(spectrum: Any) -> tuple[tuple[float, float], ...]:
    """The spectrum's knots as float pairs, checked: f strictly increasing in (0, 1], S
    finite > 0, at most MAX_KNOTS."""
    try:
        pairs = [tuple(k) for k in spectrum]
    except TypeError:
        raise TypeError("spectrum must be a sequence of (f, S) pairs, got "
                        f"{type(spectrum).__name__}") from None
    if len(pairs) > MAX_KNOTS:
        raise InvalidParameter.of("spectrum", f"{len(pairs)} knots", f"at most {MAX_KNOTS} knots")
    out: list[tuple[float, float]] = []
    for i, k in enumerate(pairs):
        if len(k) != 2:
            raise InvalidParameter.of("spectrum", f"knot {i} of length {len(k)}",
                                      "(f, S) pairs")
        f = _validate.positive(k[0], f"spectrum knot {i}'s f", upper=1.0)
        s = _validate.positive(k[1], f"spectrum knot {i}'s S")
        if out and f <= out[-1][0]:
            raise InvalidParameter.of("spectrum", f"knot {i} at f = {f:g}",
                                      "frequencies strictly increasing")
        out.append((f, s))
    return tuple(out)


def _native_max_exponent() -> float:
    return 4.0


@dataclasses.dataclass(frozen=True)
class ImageMerits:
    """The merits per row (``"channel i"``, ``"type t"``, ``"union"``) over ``depths``:
    ``psnr`` [dB] with ``psnr_error`` (the draws' standard error, dB), ``mtf50`` (share of
    the sensor's Nyquist frequency 1 / (2 delta(z)); NaN when the edge's transfer never
    falls to half below it), ``regularization`` (the weight the rule chose) and
    ``seconds`` (per depth, the row's call), each an array over the depths; with the
    photons and the ensemble. Rows of the same channels and lens types (a one-channel
    design's ``"channel 1"`` and ``"union"``) are computed once: the same numbers, the
    seconds of the one call."""

    depths: np.ndarray
    photons: float
    ensemble: Ensemble
    rows: dict[str, dict[str, np.ndarray]]


def _rows(design: Any, rows: Any) -> dict[str, tuple[list[int], list[int] | None]]:
    """Each row's (channels, lens types) from its name; None: every channel alone, every
    lens type alone (when there are several) and the union."""
    n = len(design.channels)
    types = max(len(r["f"]) for r in design.resolved())
    every = ([f"channel {i}" for i in range(1, n + 1)]
             + ([f"type {t}" for t in range(1, types + 1)] if types > 1 else []) + ["union"])
    names = every if rows is None else list(rows)
    out: dict[str, tuple[list[int], list[int] | None]] = {}
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"rows must be row names (str), got {type(name).__name__}")
        if name not in every:
            raise InvalidParameter.of("rows", name, f"one of {', '.join(every)}")
        kind, _, k = name.partition(" ")
        if kind == "channel":
            out[name] = ([int(k)], None)
        elif kind == "type":
            out[name] = (list(range(1, n + 1)), [int(k)])
        else:
            out[name] = (list(range(1, n + 1)), None)
    return out


def image_merits(design: Any, depths: Any, photons: float = 2000.0, *,
                 ensemble: Ensemble | None = None, rows: Any = None, patch: int = 48,
                 samples: int = 4, margin: float = 2.0, seed: int = 0, rule: str = "gcv",
                 n_threads: int | None = None) -> ImageMerits:
    """The image merits of ``design`` at each of ``depths`` (docs/merits.md).

    - ``photons``: photo-electrons of a white pixel (photon noise), finite > 0
    - ``ensemble``: the image ensemble (:class:`Ensemble`); None: exponent 2 with the
      amplitude and mean fitted to scikit-image's ``camera`` photograph (as docs/fig2.md
      shows it: 0.1 + 0.8 of its grey levels), the study's natural image
    - ``rows``: row names (``"channel i"``, ``"type t"``, ``"union"``); None: every channel
      alone, every lens type alone (when there are several) and the union
    - ``patch``: the patch's side in cells of delta(z), 8 to 256; ``samples``: the draws,
      2 to 64; ``margin``: the padding in pixel spans, 1 to 8; ``seed``: the draws' seed
    - ``rule``: the prior's weight: ``"gcv"`` chosen from the draws' data as
      ``reconstruct(regularization=None)`` chooses it (its bracket ``CHOOSE_BRACKET`` and
      probes ``CHOOSE_PROBES``; ``MERIT_GCV_GOLDEN_STEPS`` golden-section steps, the probes
      solved to ``MERIT_PROBE_RTOL``; plain GCV, its degrees of freedom charged once where
      ``reconstruct`` charges them ``CHOOSE_DF_WEIGHT`` times: the merits' data are the
      model's own, with no model error to guard against); ``"weighted gcv"`` the same with
      the degrees of freedom charged ``CHOOSE_DF_WEIGHT`` (1.25) times, exactly as
      ``reconstruct`` chooses on a known surface (docs/merits.md, "A measured spectrum":
      closer to a study's weight); or ``"oracle"``, the weight of least expected error
    - ``n_threads``: threads of the core (None: all cores)
    """
    d = _validate.design(design)
    z = _validate.depths(depths, "depths")
    n = _validate.positive(photons, "photons")
    p = _validate.integer_in(patch, "patch", 8, 256)
    k = _validate.integer_in(samples, "samples", 2, 64)
    m = _validate.finite(margin, "margin")
    s = _validate.integer_in(seed, "seed", 0, 2 ** 63 - 1)
    threads = _validate.n_threads(n_threads)
    if not isinstance(rule, str):
        raise TypeError(f"rule must be a str, got {type(rule).__name__}")
    if rule not in RULES:
        raise InvalidParameter.of("rule", rule, f"one of {', '.join(RULES)}")
    bracket, golden = ((MERIT_BRACKET, MERIT_GOLDEN_STEPS) if rule == "oracle"
                       else (CHOOSE_BRACKET, MERIT_GCV_GOLDEN_STEPS))
    if ensemble is None:
        ensemble = natural_ensemble()
    if not isinstance(ensemble, Ensemble):
        raise TypeError(f"ensemble must be a splitlf.Ensemble, got {type(ensemble).__name__}")
    chosen = _rows(d, rows)
    out: dict[str, dict[str, list[float]]] = {
        r: {q: [] for q in ("psnr", "psnr_error", "mtf50", "regularization", "seconds")}
        for r in chosen}
    for zi in z:
        scene = _native.RenderScene(*MERIT_EDGE.seam(), "plane", [float(zi), 0.0, 0.0],
                                    None, 0.0)
        nyq = 1.0 / (2.0 * d.resolution_step(float(zi)))
        # Rows of the same channels and lens types (a one-channel design's channel 1 and
        # union) are one computation, reported under each name.
        done: dict[tuple[Any, ...], dict[str, float]] = {}
        for name, (chans, types) in chosen.items():
            key = (tuple(chans), None if types is None else tuple(types))
            if key not in done:
                req = {"channels": chans, "lens_types": types, "photons": n,
                       "ensemble": (ensemble.mean, ensemble.amplitude, ensemble.exponent,
                                    ensemble.floor, list(ensemble.spectrum)),
                       "patch": p, "step": None, "regularization": None, "rule": rule,
                       "df_weight": CHOOSE_DF_WEIGHT,
                       "settings": (NOISE_FLOOR, MERIT_RTOL, MERIT_MAX_ITER, k, *bracket,
                                    golden, s, m, CHOOSE_PROBES, MERIT_PROBE_RTOL,
                                    MERIT_GCV_PARABOLA),
                       "coarse": MERIT_COARSE}
                t0 = time.perf_counter()
                r = _native.image_merits(d.core, float(zi), req, scene, n_threads=threads)
                done[key] = {
                    "seconds": time.perf_counter() - t0,
                    "psnr": -10.0 * math.log10(r["mse"]),
                    "psnr_error": 10.0 / math.log(10.0) * r["error"] / r["mse"],
                    "mtf50": mtf50_image(r["edge"], r["extent"], r["step"], MERIT_EDGE) / nyq,
                    "regularization": r["lam"]}
            for q, v in done[key].items():
                out[name][q].append(v)
    return ImageMerits(z.copy(), n, ensemble,
                       {r: {q: np.asarray(v) for q, v in c.items()} for r, c in out.items()})


_NATURAL: list[Ensemble] = []


def natural_ensemble() -> Ensemble:
    """Exponent 2, the amplitude and mean fitted (:meth:`Ensemble.fit`) to scikit-image's
    ``camera`` photograph as docs/fig2.md shows it (0.1 + 0.8 of its grey levels, one
    photograph pixel a cell); needs scikit-image (the ``reconstruct`` extra)."""
    if not _NATURAL:
        try:
            from skimage import data
        except ImportError as e:  # pragma: no cover - the extra is installed in the tests
            raise ImportError("the default ensemble needs scikit-image (pip install "
                              "'splitlf[reconstruct]'); or pass ensemble=Ensemble(...)") from e
        img = 0.1 + 0.8 * data.camera().astype(np.float64) / 255.0
        _NATURAL.append(Ensemble.fit(img, exponent=2.0))
    return _NATURAL[0]
