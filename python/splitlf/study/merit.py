"""The evaluation layer (``splitlf.merits``; its :func:`evaluate` is ``splitlf.evaluate``):
every figure of merit of a design, from one call.

:func:`evaluate` is what :func:`splitlf.sweep.sweep`, :func:`splitlf.optimise`,
:func:`splitlf.compare.compare` and the explorer report per design: the core's figures of
merit over a set of depths (one call of ``_native.design_figures_of_merit``, the only place
in the package that calls it), the closed-form values of the design, and on request the
super-resolution MTF50 of :func:`splitlf.simulate`. A :class:`~splitlf.Camera` is a
two-channel :class:`~splitlf.Design`: its merits are its design's (channel i = half i).

Merit names end in the row they describe: ``_channel1``, ``_channel2``, ..., ``_union``
(all channels together); :func:`merit_names` lists them for a design in the order of
:class:`Merits`, :func:`merit_doc` describes one. The image merits (docs/merits.md:
``psnr_worst_union``, ``mtf50_median_channel1``, ...; :func:`image_merit_names`) are
computed on request (``evaluate(..., image=[...])``) by :func:`splitlf.image_merits`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _native, _validate
from ..errors import InvalidParameter
from ..model.design import Design
from ._options import check_options, merits_2d_option

__all__ = ["DEFAULT_THRESHOLD_PX", "DEFAULT_TOL", "DEFAULT_WINDOW", "IMAGE_DEPTHS",
           "IMAGE_PHOTONS", "IMAGE_STATS", "Merits", "evaluate", "image_merit_names",
           "merit_doc", "merit_names"]

#: Default sharpness threshold on the blur radius [px] and merge tolerance [delta(z)].
DEFAULT_THRESHOLD_PX: float = _native.DEFAULT_THRESHOLD_PX
DEFAULT_TOL: float = _native.DEFAULT_TOL
#: Default width of the central field of the 2-D merits, in lens pitches of channel 1 (as
#: :func:`splitlf.coverage`'s).
DEFAULT_WINDOW: float = _native.DEFAULT_WINDOW
#: Options of the MTF50 simulations (noise-free, random albedo): a 128-cell window, 16 test
#: frequencies, 4x oversampling (docs/compare.md, "Budget").
SIMULATE_OPTIONS: dict[str, Any] = {"window": 128, "n_frequencies": 16, "oversample": 4}
#: The image merits (splitlf.image_merits, docs/merits.md): the statistic over the depths
#: (worst: the least; median) of the PSNR [dB] and of the MTF50 [share of the sensor's
#: Nyquist frequency], named ``<statistic>_<row>``.
IMAGE_STATS = ("psnr_worst", "psnr_median", "mtf50_worst", "mtf50_median")
#: Their photon count (photo-electrons of a white pixel), the default of ``photons``.
IMAGE_PHOTONS = 2000.0
#: Their depths: this many, log-spaced over [min, max] of the evaluation's depths.
IMAGE_DEPTHS = 5

_DOCS = {
    "sharp_fraction": "share of [min, max] depth (log) where {row} is sharp (light field "
                      "blur below threshold_px)",
    "max_gap_worst": "largest max_gap of {row} over the depths [delta(z)] (NaN with a hex "
                     "channel)",
    "max_gap_median": "median max_gap of {row} over the depths [delta(z)] (NaN with a hex "
                      "channel)",
    "lit_fraction": "lit pixels over pixels of {row} along x (NaN for a hex channel)",
    "light_per_pixel": "share x mean polygon area of the lit pixels of {row} along x / L_1: "
                       "1-D etendue per lit pixel [mm rad] (NaN for a hex channel)",
    "covering_radius_worst": "largest covering radius of the central field by {row} over the "
                             "depths [delta(z)] (2-D, splitlf.coverage)",
    "covering_radius_median": "median covering radius of the central field by {row} over the "
                              "depths [delta(z)] (2-D, splitlf.coverage)",
    "distinct_2d_median": "median number of distinct 2-D samples of {row} in the central "
                          "field over the depths (splitlf.coverage)",
    "sharp_fraction_conventional": "share of [min, max] depth (log) where a conventional "
                                   "camera with its sensor on the array plane of {row} is "
                                   "sharp (closed-form blur below threshold_px)",
    "out_of_focus_depth": "out-of-focus plane of {row}, F L / (L - F) [mm]",
    "image_fill": "microlens image width over the lens's pixel cell in {row}, D v / L over "
                  "Q mu (ideal layout) or over the image pitch d (1 + v / L) (sensor "
                  "layout): 1 = f-number matched, < 1 vignetting",
    "microlens_f_number": "smallest microlens f-number f_t / d of the lens types of {row}",
}


def merit_doc(name: str) -> str:
    """A sentence describing merit ``name`` (one of :func:`merit_names`, or of
    :func:`image_merit_names`)."""
    if name == "f_number":
        return "main-lens f-number F / D"
    stat, _, row = name.rpartition("_")
    if stat in IMAGE_STATS:
        what, _, how = stat.partition("_")
        text = "the union of all channels" if row == "union" else row.replace("channel",
                                                                              "channel ")
        unit = ("PSNR [dB] of the reconstruction of a natural-image ensemble" if what == "psnr"
                else "MTF50 [share of the sensor's Nyquist frequency] of the reconstruction "
                     "of a slanted edge")
        return (f"{'least' if how == 'worst' else 'median'} over {IMAGE_DEPTHS} depths "
                f"(log-spaced over the depth range) of the {unit} by {text}, at photon noise "
                "of `photons` for white and the data-chosen (GCV) prior weight "
                "(splitlf.image_merits)")
    if name.startswith("mtf50_"):
        return (f"super-resolution MTF50 at {name[6:-2]} mm [cycles/mm on the object] "
                "(splitlf.simulate, noise-free, random albedo)")
    prefix, _, row = name.rpartition("_")
    text = "the union of all channels" if row == "union" else row.replace("channel",
                                                                          "channel ")
    return _DOCS[prefix].format(row=text)


def image_merit_names(design: Design) -> tuple[str, ...]:
    """The names of the image merits :func:`evaluate` computes on request for ``design``:
    each of :data:`IMAGE_STATS` per channel (``_channel1``, ...) and the union."""
    d = _validate.design(design)
    rows = [f"channel{i}" for i in range(1, len(d.channels) + 1)] + ["union"]
    return tuple(f"{s}_{r}" for s in IMAGE_STATS for r in rows)


def image_option(design: Design | Sequence[Design], image: Any) -> tuple[str, ...]:
    """The image merits asked for, checked: a sequence of :func:`image_merit_names` of
    ``design`` (of any of them, for a sequence of designs)."""
    if isinstance(image, str | bytes) or not isinstance(image, Sequence):
        raise TypeError(f"image must be a sequence of image merit names, got "
                        f"{type(image).__name__}")
    designs = design if isinstance(design, Sequence) else [design]
    allowed = tuple(dict.fromkeys(n for d in designs for n in image_merit_names(d)))
    for name in image:
        if not isinstance(name, str):
            raise TypeError(f"image must hold merit names (str), got {type(name).__name__}")
        if name not in allowed:
            raise InvalidParameter.of("image", name, f"image merit names: {', '.join(allowed)}")
    return tuple(dict.fromkeys(image))


def merit_names(design: Design, merits_2d: bool = False,
                mtf50: Sequence[float] = (), image: Sequence[str] = ()) -> tuple[str, ...]:
    """The names of :func:`evaluate`'s merits of ``design``, in its order, for C channels:

    - the core's (per channel from 1, then the union): ``sharp_fraction_channel1``, ...,
      ``sharp_fraction_union``, ``max_gap_worst_*``, ``max_gap_median_*``, then per
      channel ``lit_fraction_channel*`` and ``light_per_pixel_channel*`` (5 C + 3 names);
    - with ``merits_2d``, the core's 2-D merits per channel and union:
      ``covering_radius_worst_*``, ``covering_radius_median_*``, ``distinct_2d_median_*``;
    - the closed-form values: ``f_number``, then per channel
      ``sharp_fraction_conventional_channel*``, ``out_of_focus_depth_channel*``,
      ``image_fill_channel*``, ``microlens_f_number_channel*`` (1 + 4 C names);
    - with ``mtf50`` depths, ``mtf50_<z>mm`` for each (``f"mtf50_{z:g}mm"``);
    - the image merits asked for in ``image`` (of :func:`image_merit_names`), in its order.
    """
    d = _validate.design(design)
    n = len(d.channels)
    closed = ["f_number"] + [f"{p}_channel{i}" for p in
                             ("sharp_fraction_conventional", "out_of_focus_depth",
                              "image_fill", "microlens_f_number") for i in range(1, n + 1)]
    return (tuple(_native.design_metrics(d.core, merits_2d_option(merits_2d))) + tuple(closed)
            + tuple(f"mtf50_{float(z):g}mm" for z in mtf50) + image_option(d, image))


@dataclasses.dataclass(frozen=True, eq=False)
class Merits(Mapping[str, float]):
    """The merits of one design (:func:`evaluate`): a read-only mapping {name: value} in
    the order of :func:`merit_names` (``m["sharp_fraction_union"]``, ``dict(m)``; equal to
    a dict of the same items), with the settings they were computed with, so a number is
    never separated from its meaning: ``depths`` [mm], ``threshold_px``, ``tol``,
    ``window`` (of the 2-D merits; None when they were not computed)."""

    merits: Mapping[str, float]
    depths: np.ndarray
    threshold_px: float
    tol: float
    window: float | None = None

    def __getitem__(self, name: str) -> float:
        return self.merits[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.merits)

    def __len__(self) -> int:
        return len(self.merits)

    def __repr__(self) -> str:
        return (f"Merits({dict(self.merits)!r}, {self.depths.size} depths over "
                f"[{self.depths.min():g}, {self.depths.max():g}] mm, "
                f"threshold_px={self.threshold_px!r}, tol={self.tol!r}, "
                f"window={self.window!r})")


def _mtf50_depths(values: Any) -> list[float]:
    if isinstance(values, str | bytes) or not isinstance(values, Sequence | np.ndarray):
        raise TypeError("mtf50 must be a sequence of depths [mm], got "
                        f"{type(values).__name__}")
    return [_validate.real(z, "mtf50") for z in values]


# -- the evaluation ------------------------------------------------------------------------

def _closed_form(design: Design, z: np.ndarray, threshold_px: float) -> dict[str, float]:
    """The closed-form merits of :func:`merit_names` (from the core's derived values)."""
    from ..model.optics import sharp_fractions

    design = design.design  # the plain Design: a Camera's per-half overrides not used
    n = len(design.channels)
    sf = sharp_fractions(design, (float(z.min()), float(z.max())), threshold_px)
    out = {"f_number": design.f_number}
    out.update({f"sharp_fraction_conventional_channel{i}": sf[f"conventional channel {i}"]
                for i in range(1, n + 1)})
    out.update({f"out_of_focus_depth_channel{i}": design.out_of_focus_depth(i)
                for i in range(1, n + 1)})
    resolved = design.resolved()
    for i, (ch, res) in enumerate(zip(design.channels, resolved, strict=True), 1):
        cell = res["Q"] * ch.mu if ch.layout == "ideal" else ch.d * (1.0 + ch.v / ch.L)
        out[f"image_fill_channel{i}"] = 2.0 * design.image_radius(i) / cell
    for i, res in enumerate(resolved, 1):
        out[f"microlens_f_number_channel{i}"] = min(res["f"]) / res["d"]
    return out


def mtf50_at(design: Design, z: float, row: str, seed: int, n_threads: int | None) -> float:
    """The super-resolution MTF50 [cycles/mm] at depth ``z`` of simulation row ``row``
    (``"union"``, ``"channel i"``; ``"conventional i"``: the conventional camera on
    channel i's plane, simulated for this row only); NaN for a design with a hex channel
    (the simulation is 1-D along x on rect lattices, docs/simulate.md)."""
    from ..inverse.simulate import simulate

    if any(ch.grid != "rect" for ch in design.channels):
        return math.nan
    conventional = row.startswith("conventional ")
    channel = int(row.rpartition(" ")[2]) if conventional else 1
    r = simulate(design, z, seed=seed, n_threads=n_threads, conventional_channel=channel,
                 conventional=conventional, **SIMULATE_OPTIONS)
    return float(r.mtf50[row])


def image_values(design: Design, names: Sequence[str], z: np.ndarray, photons: float,
                 n_threads: int | None) -> dict[str, float]:
    """The image merits ``names`` (checked) of ``design`` over :data:`IMAGE_DEPTHS`
    log-spaced depths of [min, max] of ``z`` (one depth when they are equal), by
    :func:`splitlf.image_merits` at ``photons`` (its defaults otherwise: the natural
    ensemble, GCV's prior weight), only the rows named."""
    from ..inverse.merits import image_merits

    if not names:
        return {}
    lo, hi = float(z.min()), float(z.max())
    zi = np.geomspace(lo, hi, IMAGE_DEPTHS) if hi > lo else np.array([lo])
    rows = {n: n.rpartition("_")[2].replace("channel", "channel ") for n in names}
    r = image_merits(design, zi, photons, rows=list(dict.fromkeys(rows.values())),
                     n_threads=n_threads)
    out = {}
    for n in names:
        stat = n.rpartition("_")[0]
        v = r.rows[rows[n]][stat.partition("_")[0]]
        with np.errstate(all="ignore"):
            out[n] = (math.nan if np.isnan(v).all() else
                      float(np.nanmin(v) if stat.endswith("worst") else np.nanmedian(v)))
    return out


def evaluate(design: Design, depths: Any, *, threshold_px: float = DEFAULT_THRESHOLD_PX,
             tol: float = DEFAULT_TOL, merits_2d: bool = False,
             window: float = DEFAULT_WINDOW, mtf50: Sequence[float] = (),
             mtf50_row: str = "union", seed: int = 0, image: Sequence[str] = (),
             photons: float = IMAGE_PHOTONS, n_threads: int | None = None) -> Merits:
    """Every figure of merit of ``design`` over ``depths`` (docs/optimise.md, "Merits").

    - ``design``: a :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one: half i is
      channel i)
    - ``depths``: 1-D array-like of scene depths [mm], each finite and > F; [min, max] of
      them is the depth range of the sharp fractions
    - ``threshold_px``: sharpness threshold on the blur radius [pixels], finite > 0
    - ``tol``: merge tolerance of the sample positions [multiples of delta(z)], finite >= 0
      (in (0, 1] with ``merits_2d``: the 2-D distinct samples use it too)
    - ``merits_2d``: also compute the 2-D merits (worst and median covering radius, median
      distinct 2-D samples of :func:`splitlf.coverage` over the depths). They cost a 2-D
      analysis per depth, so they are off by default and then absent from the result
    - ``window``: width of their central field in lens pitches of channel 1, finite > 0
      (default 16, as :func:`splitlf.coverage`; checked even when ``merits_2d`` is off)
    - ``mtf50``: depths [mm] at which :func:`splitlf.simulate` (noise-free, random albedo,
      ``seed``, :data:`SIMULATE_OPTIONS`) gives the MTF50 of ``mtf50_row`` (``"union"``,
      ``"channel i"``, or ``"conventional i"``: a conventional camera on channel i's
      plane) as ``mtf50_<z>mm``; NaN for a design with a hex channel. About a second per
      depth for the seed
    - ``image``: image merits to compute (names of :func:`image_merit_names`, e.g.
      ``psnr_worst_union``, ``mtf50_median_channel1``; :func:`merit_doc` explains each):
      the least or median over :data:`IMAGE_DEPTHS` depths log-spaced over [min, max] of
      ``depths`` of :func:`splitlf.image_merits`'s PSNR and MTF50 / Nyquist at ``photons``
      photo-electrons for white (finite > 0), the prior weight chosen by GCV as
      ``reconstruct(regularization=None)`` chooses it (docs/merits.md); NaN for an MTF50
      that never falls to half below Nyquist at any of the depths
    - ``n_threads``: threads of the core (None: all cores)

    Returns :class:`Merits` (a read-only mapping in the order of :func:`merit_names`). The
    core's merits come from one call of the core (``design_figures_of_merit``), the
    closed-form ones from the core's derived values. Raises ``TypeError`` for arguments of
    the wrong type and :class:`~splitlf.errors.InvalidParameter` (a ``ValueError``) for
    values out of range (a depth <= F included).
    """
    d = _validate.design(design)
    z = _validate.depths(depths, "depths")
    thr, t, w = check_options(threshold_px, tol, merits_2d, window)
    threads = _validate.n_threads(n_threads)
    sim_z = _mtf50_depths(mtf50)
    if not isinstance(mtf50_row, str):
        raise TypeError(f"mtf50_row must be a row name (str), got {type(mtf50_row).__name__}")
    names = image_option(d, image)
    n_photons = _validate.positive(photons, "photons")
    values = _native.design_figures_of_merit(d.core, z, thr, t, threads, w)
    merits = dict(zip(_native.design_metrics(d.core, w is not None), values, strict=True))
    merits.update(_closed_form(d, z, thr))
    for zs in sim_z:
        merits[f"mtf50_{zs:g}mm"] = mtf50_at(d, zs, mtf50_row, seed, threads)
    merits.update(image_values(d, names, z, n_photons, threads))
    z = z.copy()
    z.flags.writeable = False
    return Merits(merits, z, thr, t, w)
