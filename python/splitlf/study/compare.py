"""Plenoptic architectures compared on one sensor and one main lens (docs/compare.md).

:func:`architectures` builds, from a preset's sensor and main lens, the base
:class:`~splitlf.Design` of each architecture — a plain light field camera (one channel),
the split sensor (two), a three-way split (three), a Raytrix-style multi-focus camera (one
hexagonal channel, three lens types) and a conventional camera — with the fields each may
change (its array planes, array-to-sensor distances and lens focal lengths; the sensor,
the pixel and lens pitches and the main lens are the budget and stay fixed).
:func:`compare` optimises every light field architecture with :func:`splitlf.optimise` for
one objective, sets the conventional camera's focus, then :func:`evaluate` measures the
optimised designs over the depth range: per depth the covering radius of the union of
channels (:func:`splitlf.coverage`) and whether the design is sharp (:func:`splitlf.curves`),
and one row of scalar figures per design, every merit among them from
:func:`splitlf.evaluate` (sharp fraction, covering radius and distinct 2-D samples over
the depths, light per pixel, the super-resolution MTF50 of :func:`splitlf.simulate` where
it applies).

Orchestration only: every number comes from the core through the public API; this module
picks designs, bounds and depths, and reduces the core's per-depth arrays (worst, median).
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _validate
from ..errors import InvalidParameter
from ..model.design import Channel, Design
from ..model.optics import curves, sharp_fractions
from ..sampling.samples2d import DEFAULT_TOL, DEFAULT_WINDOW, coverage
from .merit import (
    IMAGE_PHOTONS,
    SIMULATE_OPTIONS,
    Merits,
    image_merit_names,
    image_option,
    mtf50_at,
)
from .merit import evaluate as _merits
from .sweep import with_changes

__all__ = [
    "ARCHITECTURES",
    "DEPTH_RANGE",
    "PRESETS",
    "SIMULATE_OPTIONS",
    "Architecture",
    "Comparison",
    "architectures",
    "compare",
    "evaluate",
    "mtf50",
]

#: The architectures, in the order of every table and figure.
ARCHITECTURES = ("plain", "split", "split3", "multifocus", "conventional")
#: The sensors (and main lenses) a comparison is built on: the preset they are taken from.
PRESETS = ("seed", "raytrix-r12")
#: The depth range of the study [mm].
DEPTH_RANGE = (150.0, 10_000.0)
#: The seed's sensor, 36 x 24 mm (docs/model.md §7).
SEED_SENSOR_MM = (36.0, 24.0)
#: Bounds of the free fields, relative to the base: an array plane L between the planes
#: whose out-of-focus depth F L / (L - F) is OUT_OF_FOCUS_MM (far, near); v between
#: V_BOUNDS times the base's v; a lens type's focal length between F_BOUNDS times it.
OUT_OF_FOCUS_MM = (50_000.0, 120.0)
V_BOUNDS = (0.25, 3.0)
F_BOUNDS = (0.5, 4.0)
#: The focal lengths of the multi-focus base on the seed sensor, over its v: the ratios
#: f_t / v of the Raytrix R12 preset's three lens types (0.58267, 0.52402, 0.56057 mm
#: over v = 0.33713 mm), so that the seed-sensor multi-focus camera starts as a scaled R12.
R12_F_OVER_V = (0.58267 / 0.33713, 0.52402 / 0.33713, 0.56057 / 0.33713)
#: The multi-focus base on the seed sensor: v over the seed's. The seed's square aperture
#: images to a square of side D v / L behind each lens, which must fit the lens's
#: hexagonal cell (docs/model.md §9); at the seed's L it does for v <= 0.7357 v_seed
#: (the core's rule), so the base starts at 0.7 v_seed (the image 70 % of the pitch).
HEX_SQUARE_V = 0.7
#: Defaults of the evaluation: depths over DEPTH_RANGE (log-spaced); the simulation's
#: options are :data:`splitlf.merits.SIMULATE_OPTIONS` (``SIMULATE_OPTIONS`` here too).
EVAL_DEPTHS = 60
#: Labels of the architectures (figures, tables).
LABELS = {
    "plain": "plain light field (1 channel)",
    "split": "split sensor (2 channels)",
    "split3": "three-way split (3 channels)",
    "multifocus": "multi-focus hex (3 lens types)",
    "conventional": "conventional camera",
}
#: The names of the 2-D merits (docs/optimise.md): a constraint or an objective naming one
#: makes :func:`splitlf.optimise` compute them, over a central field of ``window`` pitches.
MERITS_2D = ("covering_radius_worst_", "covering_radius_median_", "distinct_2d_median_")


@dataclasses.dataclass(frozen=True)
class Architecture:
    """One architecture on a sensor: ``name`` (one of :data:`ARCHITECTURES`), ``label``,
    the ``base`` :class:`~splitlf.Design` and the ``free`` fields with their bounds
    (:func:`splitlf.optimise`'s ``free``; for the conventional camera, its focus: the
    plane of its sensor, ``channels[1].L``). ``conventional`` marks the conventional
    camera (a one-channel design with one pixel per lens, see :func:`architectures`)."""

    name: str
    label: str
    base: Design
    free: Mapping[str, tuple[float, float]]
    conventional: bool = False


@dataclasses.dataclass(frozen=True)
class Comparison:
    """What :func:`compare` found.

    - ``preset``: the preset whose sensor and main lens every design shares
    - ``architectures``: {name: :class:`Architecture`} (bases and bounds)
    - ``designs``: {name: the optimised :class:`~splitlf.Design`}
    - ``optimisations``: {name: :class:`~splitlf.OptimiseResult`} of the light field
      architectures (their histories, active bounds, timing)
    - ``table``: a ``pandas.DataFrame``, one row per architecture (index ``architecture``),
      columns as :func:`evaluate` returns them, plus ``feasible`` (pandas' nullable
      boolean: whether the search found a design meeting every constraint; ``<NA>``, not
      applicable, for the conventional camera, which is not searched: its focus maximises
      its own sharp fraction, and the objective and constraints are light field merits)
      and ``objective`` (the search's objective value; NaN for the conventional camera)
    - ``curves``: a ``pandas.DataFrame``, one row per (architecture, depth): ``z_mm``,
      ``covering_radius`` [delta(z)], ``covering_radius_mm``, ``distinct_2d``,
      ``blur_px``, ``sharp``
    - ``settings``: the objective, constraints, budgets, depths and windows used
    - ``timing``: seconds spent optimising and evaluating
    """

    preset: str
    architectures: Mapping[str, Architecture]
    designs: Mapping[str, Design]
    optimisations: Mapping[str, Any]
    table: Any
    curves: Any
    settings: Mapping[str, Any]
    timing: Mapping[str, float]

    def curve(self, name: str) -> Any:
        """The per-depth rows of architecture ``name`` (a ``pandas.DataFrame``)."""
        if name not in self.designs:
            raise InvalidParameter.of("name", name, ", ".join(self.designs))
        c = self.curves
        return c[c["architecture"] == name].reset_index(drop=True)


# -- the architectures on a sensor ---------------------------------------------------------

def _l_bounds(design: Design) -> tuple[float, float]:
    """Array planes whose out-of-focus planes lie between :data:`OUT_OF_FOCUS_MM`: the
    conjugates of those depths (the core's :func:`splitlf.curves`)."""
    lo, hi = curves(design, np.array(OUT_OF_FOCUS_MM)).conjugate
    return float(lo), float(hi)


def _channel_free(i: int, ch: Channel, bounds: tuple[float, float], focal: bool = False
                  ) -> dict[str, tuple[float, float]]:
    free = {f"channels[{i}].L": bounds,
            f"channels[{i}].v": (V_BOUNDS[0] * ch.v, V_BOUNDS[1] * ch.v)}
    if focal and ch.f is not None:
        for t in range(len(ch.f)):
            free[f"channels[{i}].f[{t}]"] = (F_BOUNDS[0] * ch.v, F_BOUNDS[1] * ch.v)
    return free


def _conventional(F: float, D: float, aperture: str, mu: float, mx: int, my: int,
                  L: float, bounds: tuple[float, float]) -> Architecture:
    """The conventional camera: a sensor of mx x my pixels of pitch mu on the plane L, the
    main lens focused there. Built as a one-channel design with one pixel per lens (rect
    grid, ideal layout, Q = 1, lens pitch d = mu), so that the core's chief samples of its
    pixels are the conventional camera's (every pixel samples X = -(z/L) c on the plane,
    c its centre: a square grid of pitch delta(z) = mu z / L) and its light per pixel is a
    pixel's etendue D mu / L (v = d L_lo / D: the light behind each lens falls on its one
    pixel at every L of the search). Its sharpness is the core's conventional blur of that
    channel (the "conventional channel 1" row), never its light field rows."""
    lo, hi = bounds
    ch = Channel(L=L, d=mu, v=mu * lo / D, mu=mu, Kx=mx, Ky=my, Q=1)
    return Architecture("conventional", LABELS["conventional"],
                        Design(F=F, D=D, aperture=aperture, channels=(ch,)),
                        {"channels[1].L": (lo, hi)}, conventional=True)


def _seed_architectures() -> dict[str, Architecture]:
    seed = Design.preset("seed")
    plain, split3 = Design.preset("seed-plain"), Design.preset("split3")
    F, D = seed.F, seed.D
    ch = seed.channels[0]
    width, height = SEED_SENSOR_MM
    mx, my = math.floor(width / ch.mu + 1e-9), math.floor(height / ch.mu + 1e-9)
    hex_rows = math.floor(height / (ch.d * math.sqrt(3.0) / 2.0))
    v = HEX_SQUARE_V * ch.v
    multi = Design(F=F, D=D, aperture=seed.aperture, channels=(Channel(
        L=ch.L, d=ch.d, v=v, mu=ch.mu, Kx=ch.Kx, Ky=hex_rows,
        f=tuple(r * v for r in R12_F_OVER_V), grid="hex", layout="sensor", Mx=mx, My=my),))
    out = _light_field_architectures(
        {"plain": plain, "split": seed, "split3": split3, "multifocus": multi},
        _l_bounds(seed))
    out["conventional"] = _conventional(F, D, seed.aperture, ch.mu, mx, my, ch.L,
                                        _l_bounds(seed))
    return out


def _light_field_architectures(bases: dict[str, Design], l_bounds: tuple[float, float]
                               ) -> dict[str, Architecture]:
    """The light field architectures from their base designs: every channel's L (within
    ``l_bounds``) and v free, and the lens types' focal lengths of the multi-focus one."""
    out = {}
    for name, base in bases.items():
        free: dict[str, tuple[float, float]] = {}
        for i, c in enumerate(base.channels, 1):
            free.update(_channel_free(i, c, l_bounds, focal=name == "multifocus"))
        out[name] = Architecture(name, LABELS[name], base, free)
    return out


def _r12_architectures() -> dict[str, Architecture]:
    r12 = Design.preset("raytrix-r12")
    seed = Design.preset("seed")
    F, D = r12.F, r12.D
    ch = r12.channels[0]
    mx, my = ch.Mx, ch.My
    assert mx is not None and my is not None
    height = my * ch.mu
    kappa = seed.channels[1].L / seed.channels[0].L - 1.0   # the seed's prism step

    def rect(n: int) -> Design:
        """n rect channels in sensor layout, each on 1/n of the sensor's height, the
        arrays at L (1 + k kappa / (n - 1)), k = 0..n-1 (the seed's steps), Ng's setting,
        shares 1/n."""
        rows = math.floor(height / n / ch.d)
        channels = tuple(Channel(
            L=ch.L * (1.0 + (k * kappa / (n - 1) if n > 1 else 0.0)), d=ch.d, v=ch.v,
            mu=ch.mu, Kx=ch.Kx, Ky=rows, layout="sensor", Mx=mx, My=my // n, share=1.0 / n)
            for k in range(n))
        return Design(F=F, D=D, aperture=r12.aperture, channels=channels)

    out = _light_field_architectures(
        {"plain": rect(1), "split": rect(2), "split3": rect(3), "multifocus": r12},
        _l_bounds(r12))
    out["conventional"] = _conventional(F, D, r12.aperture, ch.mu, mx, my, ch.L,
                                        _l_bounds(r12))
    return out


def architectures(preset: str = "seed") -> dict[str, Architecture]:
    """The five architectures on the sensor and main lens of ``preset`` (one of
    :data:`PRESETS`), in the order of :data:`ARCHITECTURES` (docs/compare.md lists every
    derived number).

    - ``"seed"``: the seed's main lens (F = 80 mm, D = 20 mm, square aperture) and its
      36 x 24 mm sensor of 9 um pixels; lens pitch d = 0.135 mm (Q = 15), 266 lenses
      per row. plain = the ``seed-plain`` preset (176 rows), split = ``seed`` (2 x 88 rows,
      shares 1/2), split3 = ``split3`` (3 x 59 rows, shares 1/3); multi-focus: one hex
      channel of 266 x floor(24 / (d sqrt(3)/2)) = 205 lenses over the 4000 x 2666 pixel
      sensor (sensor layout), at the seed's L and v = 0.7 v_seed (:data:`HEX_SQUARE_V`),
      with three lens types f_t = v x the R12's f_t / v; conventional: 4000 x 2666 pixels.
    - ``"raytrix-r12"``: the R12's main lens (F = 49.885 mm, D = 21.494 mm, circular) and
      its 4080 x 3068 sensor of 5.5 um pixels; lens pitch d = 0.12744 mm, 176 lenses per
      row. multi-focus = the ``raytrix-r12`` preset; plain, split and split3 are rect
      channels in the sensor layout, each on 1/n of the sensor's height
      (floor(16.874 mm / n / d) rows and 3068 // n pixel rows; shares 1/n), at the R12's
      L and v in Ng's setting, the arrays stepped by the seed's kappa = 0.3866 (the base
      only: the search moves them); conventional: 4080 x 3068 pixels.

    Free fields: every channel's ``L`` with its out-of-focus plane between 50 m and
    120 mm, its ``v`` within [0.25, 3] times the base's, and (multi-focus) each lens type's
    focal length within [0.5, 4] times the base's v; the conventional camera's focus
    ``channels[1].L`` over the same planes. ``InvalidParameter`` (``preset``) for another
    preset."""
    if preset == "seed":
        return _seed_architectures()
    if preset == "raytrix-r12":
        return _r12_architectures()
    if not isinstance(preset, str):
        raise TypeError(f"preset must be one of {PRESETS}, got {type(preset).__name__}")
    raise InvalidParameter.of("preset", preset, " or ".join(repr(p) for p in PRESETS))


# -- evaluation ----------------------------------------------------------------------------

def _pixels(design: Design) -> int:
    """Pixels of the design's sensor regions (all channels)."""
    n = 0
    for ch, res in zip(design.channels, design.resolved(), strict=True):
        n += res["Mx"] * res["My"] if ch.layout == "sensor" else \
            (ch.Kx * res["Q"]) * (ch.Ky * res["Q"])
    return n


def _row_pixels(design: Design, i: int) -> int:
    """Pixels of channel i's line along x (K_x Q, or M_x): the lit fraction's denominator."""
    ch, res = design.channels[i - 1], design.resolved()[i - 1]
    return res["Mx"] if ch.layout == "sensor" else ch.Kx * res["Q"]


def _rect_twin(design: Design) -> Design:
    """The design with every hex channel on a rect lattice (the same L, d, v, mu, lens
    types, pixels, share): the core's light per pixel and lit fraction are 1-D measures
    along x on rect lattices (docs/architectures.md), and a row of lenses along x is the
    same on both lattices."""
    general = design.design  # a Camera's channels are its design's
    return general.replace(channels=tuple(ch.replace(grid="rect") if ch.grid == "hex" else ch
                                          for ch in general.channels))


def _light(design: Design, merits: Mapping[str, float], depths: np.ndarray,
           threshold_px: float, tol: float, n_threads: int | None) -> tuple[float, bool]:
    """(light per lit pixel, whether it was taken from the rect twin): the merits
    ``light_per_pixel_channel{i}`` of each channel (``merits``, or the rect twin's
    :func:`splitlf.evaluate` when the design has a hex channel), averaged over the
    channels' lit pixels along x (weights: lit fraction x pixels along x, the number of
    lit pixels of each channel's line)."""
    twin = _rect_twin(design)
    if twin != design:
        merits = _merits(twin, depths, threshold_px=threshold_px, tol=tol,
                         n_threads=n_threads)
    num = den = 0.0
    for i in range(1, len(design.channels) + 1):
        lit = merits[f"lit_fraction_channel{i}"] * _row_pixels(twin, i)
        num += merits[f"light_per_pixel_channel{i}"] * lit
        den += lit
    return (num / den if den > 0 else 0.0), twin != design


def _mtf50_row(conventional: bool) -> str:
    """The simulation row whose MTF50 a design's table reports: the union of channels,
    or for a conventional camera (one pixel per lens) its own sensor, ``conventional 1``."""
    return "conventional 1" if conventional else "union"


def _check_designs(designs: Any) -> None:
    """``designs`` is a non-empty mapping {name: Design}, else ``TypeError``."""
    if not isinstance(designs, Mapping) or not designs:
        raise TypeError("designs must be a non-empty mapping {name: Design}")
    for name, d in designs.items():
        if not isinstance(d, Design):
            raise TypeError(f"designs[{name!r}] must be a splitlf.Design, got "
                            f"{type(d).__name__}")


def mtf50(designs: Mapping[str, Design], simulate_depths: Sequence[float], *,
          conventional: Sequence[str] = (), seed: int = 0,
          n_threads: int | None = None) -> Any:
    """The MTF50 columns of :func:`evaluate` alone: a ``pandas.DataFrame``, one row per
    design (index ``architecture``), one column ``mtf50_<z>mm`` [cycles/mm on the object]
    per depth of ``simulate_depths``: :func:`splitlf.simulate` (noise-free, random albedo,
    ``seed``, :data:`SIMULATE_OPTIONS`) of the union of channels, computed without the
    simulation's conventional reference (``conventional=False``); for a name in
    ``conventional`` (a conventional camera as :func:`architectures` builds it) its own
    sensor's MTF50; NaN for a design with a hex channel (the simulation is 1-D on rect
    lattices). Raises ``TypeError`` (not designs, a depth not a real number) and what
    :func:`splitlf.simulate` raises for a depth out of range."""
    import pandas as pd

    _check_designs(designs)
    conv = set(conventional)
    sim_z = [_validate.real(s, "simulate_depths") for s in simulate_depths]
    columns = [f"mtf50_{zs:g}mm" for zs in sim_z]
    values = [[mtf50_at(d, zs, _mtf50_row(name in conv), seed, n_threads) for zs in sim_z]
              for name, d in designs.items()]
    return pd.DataFrame(values, columns=columns, dtype=float,
                        index=pd.Index(list(designs), name="architecture"))


def _depths(depths: Any, name: str) -> np.ndarray:
    if depths is None:
        return np.geomspace(*DEPTH_RANGE, EVAL_DEPTHS)
    return np.sort(_validate.depth_range(depths, name))


def _positive(value: Any, name: str) -> float:
    x = _validate.real(value, name)
    if not (math.isfinite(x) and x > 0):
        raise InvalidParameter.of(name, x, "a finite number > 0")
    return x


def evaluate(designs: Mapping[str, Design], depths: Any = None, *,
             conventional: Sequence[str] = (), window: float = DEFAULT_WINDOW,
             threshold_px: float = 0.5, tol: float = DEFAULT_TOL,
             simulate_depths: Sequence[float] = (), seed: int = 0,
             image: Sequence[str] = (), photons: float = IMAGE_PHOTONS,
             n_threads: int | None = None) -> tuple[Any, Any]:
    """The figures of each design over ``depths`` (default 60 log-spaced over
    150-10 000 mm), all from the core.

    - ``designs``: {name: :class:`~splitlf.Design`}; ``conventional``: the names among
      them that are conventional cameras (one pixel per lens, see :func:`architectures`:
      their sharpness is the core's conventional blur of channel 1)
    - ``window``: the central field of the covering radius, in lens pitches of the first
      light field design's channel 1 (a conventional camera gets the same field in mm:
      ``window`` x that pitch / its pixel pitch of its own pitches)
    - ``threshold_px``, ``tol``: sharpness threshold [px] and merge tolerance [delta(z)]
    - ``simulate_depths``: depths [mm] at which :func:`splitlf.simulate` (noise-free,
      random albedo, ``seed``) gives the MTF50 of the union (of the conventional camera
      for a conventional design); NaN for a design with a hex channel (:func:`mtf50`)
    - ``image``: image merits to add as columns (names of
      :func:`splitlf.merits.image_merit_names`, e.g. ``psnr_worst_union``), each
      :func:`splitlf.evaluate`'s at ``photons`` photo-electrons for white (docs/merits.md);
      NaN in the row of a design that has no such row (``..._channel2`` of a one-channel
      design). A name no design has is an error. Minutes per design and merit row
      (docs/merits.md, "Time")

    Returns ``(table, curves)``, two ``pandas.DataFrame``:

    - ``table``, one row per design (index ``architecture``): ``channels``, ``pixels``,
      ``shares`` (text), ``sharp_fraction`` (the union's share of [min, max] depth, log,
      where it is sharp: the merit ``sharp_fraction_union``; a conventional camera's own,
      ``sharp_fraction_conventional_channel1``. A channel's light field blur exceeds the
      threshold only in a band around its out-of-focus plane, so a light field design
      whose bands lie outside the range, or are each covered by another channel, is sharp
      everywhere: 1.0, what every optimised light field design reaches when the objective
      rewards sharpness; the covering radius and the light then tell them apart),
      ``covering_radius_worst`` and ``covering_radius_median`` (the union's largest and
      median covering radius over the depths, delta(z) units: the 2-D merits of
      :func:`splitlf.evaluate` over the central field),
      ``distinct_2d_median`` (union), ``field_at_1m_mm`` (the width of the scene channel 1's
      pixel row sees at 1 m: delta(1 m) x its pixels along x; designs with the array
      farther back see a narrower field, which delta(z) units normalise),
      ``light_per_pixel`` (mm rad: the core's
      ``light_per_pixel_channel{i}`` — share x mean integration-polygon area of the lit
      pixels along x / L_1 — averaged over the channels' lit pixels; a hex channel's from
      its rect twin, ``light_from_rect_twin``), ``light_relative`` (over the conventional
      camera's, when one is among the designs), ``out_of_focus_mm`` (text) and
      ``mtf50_<z>mm`` per simulated depth [cycles/mm], then one column per ``image`` name
    - ``curves``, one row per (design, depth): ``architecture``, ``z_mm``,
      ``covering_radius`` [delta(z)], ``covering_radius_mm``, ``distinct_2d``, ``blur_px``
      (the union's light field blur, or the conventional blur) and ``sharp``
      (``blur_px < threshold_px``)
    """
    import pandas as pd

    _check_designs(designs)
    conv = set(conventional)
    unknown = conv - set(designs)
    if unknown:
        raise InvalidParameter.of("conventional", sorted(unknown),
                                  f"names among the designs: {', '.join(designs)}")
    z = _depths(depths, "depths")
    window = _positive(window, "window")
    threshold_px = _positive(threshold_px, "threshold_px")
    sim_z = [_validate.real(s, "simulate_depths") for s in simulate_depths]
    image_names = image_option(list(designs.values()), image)
    photons = _validate.positive(photons, "photons")
    lf = [n for n in designs if n not in conv]
    ref_pitch = designs[lf[0]].channels[0].d if lf else None
    rows, frames = [], []
    for name, d in designs.items():
        is_conv = name in conv
        w = window
        if is_conv and ref_pitch is not None:
            w = window * ref_pitch / d.channels[0].d
        own = [n for n in image_names if n in image_merit_names(d)]
        m = _merits(d, z, threshold_px=threshold_px, tol=tol, merits_2d=True, window=w,
                    mtf50=sim_z, mtf50_row=_mtf50_row(is_conv), seed=seed, image=own,
                    photons=photons, n_threads=n_threads)
        row = _row(name, d, m, is_conv, z, threshold_px, tol, n_threads)
        rows.append(row | {n: float(m[n]) if n in own else math.nan for n in image_names})
        # the per-depth curves (figures, depth bands): the same core analyses per depth
        cov = coverage(d, z, tol=tol, window=w, n_threads=n_threads)
        crv = curves(d, z)
        blur = crv.conventional_px[0] if is_conv else crv.union_blur_px
        frames.append(pd.DataFrame({
            "architecture": name, "z_mm": z, "covering_radius": cov.covering_radius[-1],
            "covering_radius_mm": cov.covering_radius_mm[-1],
            "distinct_2d": cov.distinct[-1], "blur_px": blur, "sharp": blur < threshold_px}))
    table = pd.DataFrame(rows).set_index("architecture")
    conv_rows = [n for n in designs if n in conv]
    if conv_rows:
        ref = table.loc[conv_rows[0], "light_per_pixel"]
        table["light_relative"] = table["light_per_pixel"] / ref
    return table, pd.concat(frames, ignore_index=True)


def _row(name: str, d: Design, m: Merits, is_conv: bool, z: np.ndarray,
         threshold_px: float, tol: float, n_threads: int | None) -> dict[str, Any]:
    """One row of :func:`evaluate`'s table from the design's merits ``m``
    (:func:`splitlf.evaluate` with the 2-D merits) and its descriptive fields."""
    light, twin = _light(d, m, z, threshold_px, tol, n_threads)
    sharp = m["sharp_fraction_conventional_channel1" if is_conv else "sharp_fraction_union"]
    return {
        "architecture": name,
        "channels": len(d.channels),
        "pixels": _pixels(d),
        "shares": " ".join(f"{ch.share:.3g}" for ch in d.channels),
        "sharp_fraction": float(sharp),
        "covering_radius_worst": float(m["covering_radius_worst_union"]),
        "covering_radius_median": float(m["covering_radius_median_union"]),
        "distinct_2d_median": float(m["distinct_2d_median_union"]),
        "field_at_1m_mm": d.resolution_step(1000.0) * _row_pixels(d, 1),
        "light_per_pixel": light,
        "light_from_rect_twin": twin,
        "out_of_focus_mm": " ".join(f"{m[f'out_of_focus_depth_channel{i}']:.1f}"
                                    for i in range(1, len(d.channels) + 1)),
        **{k: float(v) for k, v in m.items() if k.startswith("mtf50_") and k.endswith("mm")},
    }


# -- the comparison ------------------------------------------------------------------------

def _uses_2d(objective: Any, constraints: Mapping[str, Any] | None) -> bool:
    names = [objective] if isinstance(objective, str) else []
    names += list(constraints or {})
    return any(isinstance(n, str) and n.startswith(MERITS_2D) for n in names)


def _focus(arch: Architecture, z: np.ndarray, threshold_px: float) -> tuple[Design, float]:
    """The conventional camera's focus: the sensor plane L that maximises its sharp
    fraction of [min z, max z] (the core's closed-form conventional depth of field), by a
    scan of 64 planes over the bounds and a bounded Brent search around the best (SciPy);
    deterministic. Returns (the design, its sharp fraction)."""
    from scipy.optimize import minimize_scalar

    (name, (lo, hi)), = arch.free.items()
    base = arch.base

    def fraction(L: float) -> float:
        d = with_changes(base, {name: float(L)})
        return sharp_fractions(d, (z.min(), z.max()), threshold_px)["conventional channel 1"]

    grid = np.linspace(lo, hi, 64)
    values = [fraction(L) for L in grid]
    k = int(np.argmax(values))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(lambda L: -fraction(L), bounds=(a, b), method="bounded",
                          options={"xatol": 1e-9 * (hi - lo)})
    best = float(res.x) if -res.fun >= values[k] else float(grid[k])
    return with_changes(base, {name: best}), fraction(best)


def compare(preset: str, objective: str | Callable[[dict[str, float]], float],
            sense: str | None = None,
            constraints: Mapping[str, tuple[str, float]] | None = None, *,
            which: Sequence[str] | None = None, depths: Any = None,
            optimise_depths: Any = None, window: float = DEFAULT_WINDOW,
            optimise_window: float = 4.0, maxiter: int = 8, popsize: int = 5,
            polish: bool = False, seed: int = 0, executor: cf.Executor | None = None,
            progress: bool | None = None, merits_2d: bool | None = None,
            de_options: Mapping[str, Any] | None = None,
            simulate_depths: Sequence[float] = (),
            threshold_px: float = 0.5, tol: float = DEFAULT_TOL,
            photons: float = IMAGE_PHOTONS, n_threads: int | None = None) -> Comparison:
    """Optimise every architecture of :func:`architectures` on ``preset``'s sensor and
    main lens for one objective, then :func:`evaluate` the optimised designs.

    - ``preset``: ``"seed"`` or ``"raytrix-r12"`` (:data:`PRESETS`)
    - ``objective``, ``sense``, ``constraints``: as :func:`splitlf.optimise` for a Design
      base, the same for every light field architecture (merit names with rows
      ``union``, ``channel1``, ...; the 2-D merits ``covering_radius_worst_union``,
      ``covering_radius_median_union``, ``distinct_2d_median_union`` are computed over a
      central field of ``optimise_window`` lens pitches)
    - ``which``: a subset of :data:`ARCHITECTURES` (default all five)
    - ``optimise_depths``: the depths of the merits inside the search (default 12
      log-spaced over 150-10 000 mm); ``depths``, ``window``: the evaluation afterwards
      (default 60 depths, 16 pitches)
    - ``maxiter``, ``popsize``, ``polish``, ``seed``, ``executor``, ``progress``,
      ``merits_2d``, ``de_options``, ``threshold_px``, ``tol``, ``n_threads``: passed to
      :func:`splitlf.optimise` (deterministic for a seed, on any executor; ``merits_2d``
      True for a callable objective that reads the 2-D merits)
    - ``simulate_depths``: depths of the MTF50 columns (:func:`evaluate`)
    - ``photons``: photo-electrons for white of the image merits (``psnr_worst_union``,
      ...: :func:`splitlf.merits.image_merit_names`, docs/merits.md) that the objective
      or the constraints name; the table gets a column for each of them

    The conventional camera has no light field merits: its one free field, the plane of
    its sensor, is set to maximise its sharp fraction (the core's conventional depth of
    field), whatever the objective (an image merit included: its image merits take
    minutes a depth, docs/merits.md); its covering radius is that of its pixel grid, the
    same at every focus, so a covering-radius objective or constraint cannot move it.

    Returns a :class:`Comparison`. Raises what :func:`splitlf.optimise` raises for a bad
    objective, constraint or budget (before any search: the first architecture checks
    them), ``InvalidParameter`` for an unknown preset or architecture.
    """
    import pandas as pd

    from .optimise import optimise

    archs = architectures(preset)
    names = list(ARCHITECTURES) if which is None else list(which)
    if not names or any(n not in ARCHITECTURES for n in names) or len(set(names)) < len(names):
        raise InvalidParameter.of("which", names,
                                  f"distinct names among {', '.join(ARCHITECTURES)}")
    names = [n for n in ARCHITECTURES if n in names]
    z_opt = np.geomspace(*DEPTH_RANGE, 12) if optimise_depths is None else \
        _depths(optimise_depths, "optimise_depths")
    z_eval = _depths(depths, "depths")
    optimise_window = _positive(optimise_window, "optimise_window")
    extra: dict[str, Any] = {}
    if merits_2d or (merits_2d is None and _uses_2d(objective, constraints)):
        extra["window"] = optimise_window
    if merits_2d is not None:
        extra["merits_2d"] = merits_2d
    named = ([objective] if isinstance(objective, str) else []) + list(constraints or {})
    image_allowed = {n for a in archs.values() for n in image_merit_names(a.base)}
    image = [n for n in dict.fromkeys(named) if isinstance(n, str) and n in image_allowed]
    photons = _validate.positive(photons, "photons")
    t0 = time.perf_counter()
    designs: dict[str, Design] = {}
    results: dict[str, Any] = {}
    status: dict[str, tuple[bool | None, float]] = {}
    for n in names:
        a = archs[n]
        if a.conventional:
            designs[n], frac = _focus(a, z_opt, threshold_px)
            status[n] = (None, math.nan)
            continue
        res = optimise(a.base, dict(a.free), objective, sense,
                       constraints, depths=z_opt,
                       seed=seed, executor=executor, progress=progress, maxiter=maxiter,
                       popsize=popsize, polish=polish, threshold_px=threshold_px, tol=tol,
                       n_threads=n_threads, de_options=de_options, photons=photons,
                       **extra)
        designs[n], results[n] = res.design, res
        status[n] = (res.feasible, res.objective)
    t1 = time.perf_counter()
    table, crv = evaluate(designs, z_eval, conventional=[n for n in names
                                                          if archs[n].conventional],
                          window=window, threshold_px=threshold_px, tol=tol,
                          simulate_depths=simulate_depths, seed=seed, image=image,
                          photons=photons, n_threads=n_threads)
    t2 = time.perf_counter()
    # feasible: pandas' nullable boolean, <NA> (not applicable) for the conventional camera
    table.insert(0, "feasible", pd.Series({n: status[n][0] for n in names},
                                          dtype="boolean"))
    table.insert(1, "objective", pd.Series({n: status[n][1] for n in names}, dtype=float))
    settings = {
        "preset": preset,
        "objective": objective if isinstance(objective, str) else
        getattr(objective, "__name__", "objective"),
        "sense": sense, "constraints": dict(constraints or {}),
        "optimise_depths": z_opt.tolist(), "depths": z_eval.tolist(),
        "window": window, "optimise_window": optimise_window, "maxiter": maxiter,
        "popsize": popsize, "polish": polish, "seed": seed,
        "de_options": dict(de_options or {}), "threshold_px": threshold_px,
        "tol": tol, "simulate_depths": [float(s) for s in simulate_depths],
        "photons": photons, "image": image,
    }
    return Comparison(preset=preset, architectures={n: archs[n] for n in names},
                      designs=designs, optimisations=results, table=table, curves=crv,
                      settings=settings,
                      timing={"optimise_s": t1 - t0, "evaluate_s": t2 - t1})
