"""Super-resolved all-in-focus images from raws (docs/model.md §11, docs/reconstruct.md).

:func:`reconstruct` solves for the albedo on a uniform grid of cells over a region of a
known surface: the core builds the sparse linear map A (row = raw pixel, column = cell,
entry = what the pixel records when the cell alone is white), with the forward model's own
integration, so that ``A t`` is ``render``'s raw of the image texture t: on the exact route
(a fronto-parallel plane, rect cells, a square aperture, the ideal layout) as per-axis
factors, otherwise as explicit rows: from the tilted route for a tilted plane on those designs
(wide pixels cut into parts where it tilts along both axes), from the general route in
record mode for the rest (planes too steep along both axes even for parts, depth maps,
hex arrays, circular apertures, sensor layouts: on planes, and on depth maps that every
ray meets once, each pixel's footprint density over the cells). The core's matrix-free
conjugate gradients (SciPy's ``cg`` iteration, in parallel) solve the regularised least
squares

    min_t  sum_rows ((A t - raw) / sigma)^2  +  lambda * |D t|^2

with sigma the raw's noise per pixel (from ``noise``, or the noise model the raw carries,
or estimated from the data; a stated floor for noise-free raws), D the differences
between neighbouring cells and lambda the prior's weight: chosen per call from the data
(generalised cross-validation for a raw of photon noise, known or not; the unbiased
predictive risk against the floor for a noise-free raw; searched in the core over log
lambda on the region's central part), or fixed by the caller. With ``prior="huber"`` or
``"tv"`` the square of each difference is replaced by an edge-preserving penalty, solved
by reweighted passes of the same CG in the core (lambda chosen for the quadratic prior).

A mosaiced raw (``raw.cfa``, docs/model.md §12) is reconstructed per colour from that
colour's pixels only (the core's rows of the other colours left out), each pixel divided
by its colour's QE and weighted by its colour's noise (photons N QE): a
:class:`ColourReconstruction` of three grey ones on the same grid (docs/reconstruct.md,
"Colour").
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _native, _validate
from .._noise import stated as _stated
from .._progress import Show
from .._progress import progress_bar as _progress
from .._progress import progress_flag as _progress_flag
from .._validate import channels as _channels
from .._validate import extent as _extent
from ..errors import InvalidParameter
from ..imaging.render import DepthMap, Plane, Raw
from ..imaging.texture import COLOURS
from ..model.design import Design

Extent = tuple[float, float, float, float]

#: The noise (fraction of a fully lit white pixel, 1 sigma) assumed for a raw given without
#: ``noise``: the forward model's stated accuracy (docs/render.md).
NOISE_FLOOR = 1e-3
#: The choice of lambda from the data (docs/reconstruct.md, "The prior's weight"): the
#: bracket searched, for weights 1/sigma^2 (lambda ~ 1/s^2 for neighbouring cells' albedos
#: differing by about s: s from 0.003 to 30); capped at the data's range (the refusal of
#: too large a ``regularization``).
CHOOSE_BRACKET = (1e-3, 1e5)
#: The photon counts an estimate of the noise can find (widening the bracket's search
#: when the noise is not known: lambda / N is searched).
CHOOSE_PHOTONS = (10.0, 1e7)
#: Golden-section steps in log lambda after the scan over decades.
CHOOSE_GOLDEN_STEPS = 4
#: Rademacher probes of the trace estimate (the fit's degrees of freedom) at each lambda.
CHOOSE_PROBES = 4
#: The choice is made on the region's central part, at most this many cells a side
#: (tiles take the same lambda).
CHOOSE_SIDE = 64
#: Each of the choice's solves stops at this many iterations at most.
CHOOSE_MAX_ITER = 500
#: The probe solves' relative stop.
CHOOSE_PROBE_RTOL = 1e-6
#: The iterations the whole choice may take (its solves summed): no lambda is tried once
#: the next one's solves could exceed it; the time plan counts the choice at this many.
CHOOSE_BUDGET = 20_000
#: The weight rho on the fit's degrees of freedom in the risk (weighted GCV:
#: m RSS / (m - rho df)^2; UPRE: RSS + 2 rho df - m) for a known surface. Plain GCV
#: (rho = 1) under-smooths at half 1's out-of-focus plane (0.4-0.8 dB short of the best
#: weight there); 1.25 is within 0.2 dB of the best weight at 642 mm and 1 m
#: (docs/reconstruct.md, "The weight on the degrees of freedom").
CHOOSE_DF_WEIGHT = 1.25
#: rho for the surface of a depth estimate, whose depth errors make the model inexact:
#: plain GCV fits them and under-smooths (lambda 0.1 against about 16 by the truth,
#: 3.7 dB against 16 dB, docs/reconstruct.md "An estimated surface").
CHOOSE_DF_WEIGHT_ESTIMATE = 2.0
#: Conjugate-gradient stop: the residual of the normal equations relative to their
#: right-hand side.
CG_RTOL = 1e-10
#: At most this many iterations.
CG_MAX_ITER = 2000
#: For a raw whose noise is known: the stop once the residual is this share of the noise's
#: expected norm in the right-hand side (docs/reconstruct.md step 3).
CG_NOISE_TOL = 1e-3
#: Cells by which a tile's solve reaches into its neighbours (cropped after): the prior
#: couples a tile's edge cells to its margin, which fewer pixels see.
TILE_OVERLAP = 8
#: The priors on the differences of neighbouring cells: lambda |D t|^2, or an
#: edge-preserving one solved by iteratively reweighted least squares in the core
#: (docs/reconstruct.md, "Edge-preserving priors").
PRIORS = ("quadratic", "huber", "tv")
#: Huber's threshold s (albedo, a share of white): differences of neighbouring cells up to
#: s are penalised as squares, larger ones in proportion to their size. The best of 0.02,
#: 0.05 and 0.1 by PSNR in 22 of 24 cases of docs/make_prior.py (the other two: ties).
HUBER_THRESHOLD = 0.02
#: Total variation's smoothing epsilon (albedo): |r| is rounded to r^2 / (2 epsilon) below it.
TV_SMOOTHING = 0.01
#: The edge-preserving priors' outer loop: at most this many reweighted solves ...
PRIOR_PASSES = 10
#: ... stopped once the cells move by less than this RMS (albedo) from one to the next.
PRIOR_TOL = 1e-3
#: The least tile side (cells).
MIN_TILE = 16
#: A tilted plane's padded grid reaches no nearer than this many times F: its padding
#: stops there (docs/reconstruct.md step 2).
PAD_NEAREST: float = _native.PAD_NEAREST
#: A reconstruction expected to take longer than this (seconds, an upper bound at
#: CG_MAX_ITER iterations) is refused unless ``allow_slow=True``: a few minutes.
MAX_SECONDS = 180.0

_log = logging.getLogger("splitlf.reconstruct")


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Reconstruction:
    """A reconstructed albedo image: ``image`` (2-D float64, row 0 at the top = largest Y,
    column 0 at the left, like a texture) of cells of pitch ``step`` (mm) uniform over
    ``extent`` = (X0, X1, Y0, Y1) in object-space mm, on the surface ``depth`` (a depth in
    mm for a fronto-parallel plane, else the :class:`~splitlf.Plane` or
    :class:`~splitlf.DepthMap` given; for an estimate, its surface), from
    ``channels`` (numbered from 1) of ``design`` and their lenses of ``lens_types``
    (numbered from 1; None: every type); and what the solve did: ``rows`` (raw
    pixels used), ``iterations``, ``residual`` (the normal equations' relative residual),
    ``regularization`` (lambda), ``regularization_rule`` (how it was set: ``"fixed"``
    (given), ``"gcv"`` (generalised cross-validation: a raw of photon noise, known or
    estimated) or ``"upre"`` (the unbiased predictive risk: a noise-free raw), ``"weighted
    gcv"`` / ``"weighted upre"`` when the fit's degrees of freedom are charged ``df_weight``
    = rho > 1 times: ``CHOOSE_DF_WEIGHT`` on a known surface, ``CHOOSE_DF_WEIGHT_ESTIMATE``
    on an estimate's; ``df_weight`` is 1 for a fixed lambda), ``noise``
    (the per-pixel sigma model used, as text), ``noise_model`` (it as ``{"photons": N,
    "read_noise": r}``, photons ``inf`` for noise-free), ``noise_source`` (``"given"``: the
    call's ``noise``; ``"raw"``: carried by the raw; ``"estimated"``: from the data, read
    noise taken as 0), ``choice`` (the lambdas the choice tried, in order, as (lambda,
    score, RSS, df, iterations) in the search's units; empty for a fixed lambda and a known
    noise), ``tiles`` (the solves: 1, or the tiles of a tiled reconstruction, whose
    ``rows`` is then summed over the tiles, ``iterations`` the most and ``residual`` the
    largest of any tile), ``prior`` (its name), ``threshold`` (Huber's s or TV's epsilon;
    None for the quadratic prior) and ``passes`` (the prior's reweighted solves, the most
    of any tile; iterations count every pass)."""

    image: np.ndarray
    extent: Extent
    step: float
    design: Design
    depth: float | Plane | DepthMap
    channels: tuple[int, ...]
    rows: int
    iterations: int
    residual: float
    regularization: float
    noise: str
    tiles: int = 1
    lens_types: tuple[int, ...] | None = None
    prior: str = "quadratic"
    threshold: float | None = None
    passes: int = 1
    regularization_rule: str = "fixed"
    noise_model: dict[str, float] | None = None
    noise_source: str = "given"
    choice: tuple[tuple[float, float, float, float, int], ...] = ()
    df_weight: float = 1.0

    def __post_init__(self) -> None:
        self.image.setflags(write=False)

    def __repr__(self) -> str:
        """A short summary (never the arrays): shape, extent, step, surface, channels and
        what the solve did."""
        ny, nx = self.image.shape
        x0, x1, y0, y1 = self.extent
        depth = (f"{self.depth:g} mm" if isinstance(self.depth, float)
                 else type(self.depth).__name__)
        types = "" if self.lens_types is None else f", lens_types={self.lens_types}"
        return (f"Reconstruction({ny} x {nx} cells of {self.step:.4g} mm over X "
                f"[{x0:.4g}, {x1:.4g}], Y [{y0:.4g}, {y1:.4g}] mm, depth {depth}, "
                f"channels={self.channels}{types}, rows={self.rows}, "
                f"iterations={self.iterations}, residual={self.residual:.2e}, "
                f"regularization={self.regularization:g} ({self.regularization_rule}), "
                f"noise {self.noise} ({self.noise_source}), {self._prior_text()}"
                f"tiles={self.tiles})")

    def _prior_text(self) -> str:
        if self.threshold is None:
            return ""
        return f"prior={self.prior!r} ({self.threshold:g}, {self.passes} passes), "


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class ColourReconstruction:
    """The reconstruction of a mosaiced raw (docs/model.md §12): ``colours``, three
    :class:`Reconstruction` (red, green, blue) on the same grid, each from its colour's
    pixels only; ``cfa`` the raw's colour filter array. ``image`` is the three stacked,
    shape (ny, nx, 3); ``extent``, ``step``, ``design``, ``depth`` and ``channels`` are
    the colours' (the same). Measure each colour on its own (``splitlf.measure.psnr(
    rec.colours[k], texture.colour(k))``)."""

    colours: tuple[Reconstruction, Reconstruction, Reconstruction]
    cfa: Mapping[str, Any]

    @property
    def image(self) -> np.ndarray:
        """The colours' images stacked, (ny, nx, 3) (red, green, blue)."""
        out = np.stack([r.image for r in self.colours], axis=-1)
        out.setflags(write=False)
        return out

    @property
    def extent(self) -> Extent:
        return self.colours[0].extent

    @property
    def step(self) -> float:
        return self.colours[0].step

    @property
    def design(self) -> Design:
        return self.colours[0].design

    @property
    def depth(self) -> float | Plane | DepthMap:
        return self.colours[0].depth

    @property
    def channels(self) -> tuple[int, ...]:
        return self.colours[0].channels

    def __repr__(self) -> str:
        """A short summary: the pattern and each colour's reconstruction."""
        inner = "; ".join(f"{n}: {r!r}" for n, r in zip(COLOURS, self.colours, strict=True))
        return f"ColourReconstruction({self.cfa['pattern']}, {inner})"


def _depth(depth: Any) -> float | Plane | DepthMap:
    """A fronto-parallel plane as its depth (mm); a slanted Plane or a DepthMap as given."""
    if isinstance(depth, Plane):
        if depth.gx == 0.0 and depth.gy == 0.0:
            return float(depth.z0)
        return depth
    if isinstance(depth, DepthMap):
        return depth
    if isinstance(depth, bool) or not isinstance(depth, (int, float, np.integer, np.floating)):
        raise TypeError("depth must be a number (mm), a splitlf.Plane or a splitlf.DepthMap, "
                        f"got {type(depth).__name__}")
    z = float(depth)
    if not math.isfinite(z):
        raise InvalidParameter.of("depth", z, "a finite depth > F (mm)")
    return z


def _lens_types(lens_types: Any) -> list[int] | None:
    """The lens type numbers given (from 1), their types checked; the core checks them
    against the channels' lens types."""
    if lens_types is None:
        return None
    if isinstance(lens_types, (int, np.integer)) and not isinstance(lens_types, bool):
        lens_types = (lens_types,)
    if (not isinstance(lens_types, Sequence) or isinstance(lens_types, str)
            or not lens_types):
        raise TypeError("lens_types must be None, a lens type number or a non-empty "
                        f"sequence of them, got {lens_types!r}")
    for t in lens_types:
        if isinstance(t, bool) or not isinstance(t, (int, np.integer)):
            raise TypeError(f"lens_types must hold integers, got {t!r}")
    return [int(t) for t in lens_types]


def _prior(prior: Any, threshold: Any) -> tuple[str, float | None]:
    """The prior's name (one of ``PRIORS``) and its threshold (the default for the prior
    when None; None for the quadratic prior, which takes none)."""
    if not isinstance(prior, str):
        raise TypeError(f"prior must be one of {PRIORS}, got {prior!r}")
    if prior not in PRIORS:
        raise InvalidParameter.of("prior", prior, f"one of {', '.join(PRIORS)}")
    if prior == "quadratic":
        if threshold is not None:
            raise InvalidParameter.of("threshold", threshold,
                                      "None for the quadratic prior (it has no threshold)")
        return prior, None
    if threshold is None:
        return prior, HUBER_THRESHOLD if prior == "huber" else TV_SMOOTHING
    return prior, _validate.real(threshold, "threshold")


def _reporter(show: Show) -> tuple[Callable[[str, int, int, list[str]], None], list[Any]]:
    """The core's progress callback (phase, done, total, notes): each note (the grid's size
    and the expected work, before the work starts) logged on ``splitlf.reconstruct``, and
    with ``show`` a report per phase (a bar on a terminal, sparse lines elsewhere: the
    map's raw rows, the solve's iterations). Returns
    it and the list holding the open bar (closed by the caller)."""
    bars: list[Any] = []
    names = {"map": ("splitlf reconstruct (map)", "block"),
             "solve": ("splitlf reconstruct (CG)", "step")}
    state = {"phase": ""}

    def report(phase: str, done: int, total: int, notes: list[str]) -> None:
        for note in notes:
            _log.info("%s", note)
        if not show or phase not in names:
            return
        if phase != state["phase"]:
            for bar in bars:
                bar.close()
            bars.clear()
            bar, _ = _progress(show, *names[phase])
            if bar is not None:
                bars.append(bar)
            state["phase"] = phase
        for bar in bars:
            bar.report(done, total)

    return report, bars


def reconstruct(raw: Raw, depth: Any, *, region: Any = None, step: float | None = None,
                regularization: float | None = None, channels: Any = None,
                noise: Mapping[str, float] | None = None, tile: int | None = None,
                n_threads: int | None = None, progress: bool | None = None,
                lens_types: Any = None, allow_slow: bool = False, prior: str = "quadratic",
                threshold: float | None = None) -> Reconstruction | ColourReconstruction:
    """The albedo on a grid of cells over ``region`` of the surface ``depth``, from the raw
    (docs/model.md §11, docs/reconstruct.md).

    - ``raw``: a :class:`splitlf.Raw` (rendered, loaded or wrapped)
    - ``depth``: the surface: a depth (mm), a :class:`splitlf.Plane` (slanted or not) or a
      :class:`splitlf.DepthMap`, deeper than F over the region; a tilted plane may be
      nearer than F elsewhere in the view, where ``render`` would refuse it, and its
      padding (a pixel's span beyond the region) is clipped where the plane comes nearer
      than ``PAD_NEAREST`` F (docs/reconstruct.md step 2). A depth map with a
      ``confidence`` (an estimate, :func:`splitlf.estimate_depth`) is taken as its
      surface, :meth:`DepthMap.surface` (a map every ray meets once: the footprint
      route; or, when the surface is within 3 % of a plane, that fitted plane: the
      tilted route, docs/reconstruct.md step 6); the result's ``depth`` is that surface
    - ``region``: (X0, X1, Y0, Y1) mm (None: what each chosen channel sees through at
      least half its aperture at the reference depth, ``_native.seen_region``; for a
      depth map, within its extent); rounded out to whole cells
    - ``step``: the cell pitch, mm (None: delta(z) = mu_1 z / L_1, the sensor's step, at
      the reference depth: a plane's depth at the region's centre (on the axis without a
      region), a depth map's median)
    - ``regularization``: lambda, the smoothness prior's weight (None: chosen from the
      data per call, in the core: generalised cross-validation m RSS / (m - df)^2 for a
      raw of photon noise, known or not (it also takes in the model's own error), the
      unbiased predictive risk RSS + 2 df - m against the floor for a noise-free raw, df
      the fit's degrees of freedom by a Hutchinson trace estimate; searched over decades
      of ``CHOOSE_BRACKET`` then by golden section in log lambda, on the region's central
      ``CHOOSE_SIDE`` cells; docs/reconstruct.md). A number fixes it
    - ``prior``: the penalty on the differences r of neighbouring cells, times lambda:
      ``"quadratic"`` (r^2, the default), ``"huber"`` (r^2 up to ``threshold``, linear
      beyond: edges keep their height) or ``"tv"`` (|r|, rounded below ``threshold``).
      The edge-preserving two are solved in the core by iteratively reweighted least
      squares: at most ``PRIOR_PASSES`` solves, each warm-started, until the cells move
      by less than ``PRIOR_TOL`` RMS (docs/reconstruct.md); a data-chosen lambda is the
      quadratic prior's
    - ``threshold``: Huber's s or TV's epsilon, in albedo (a share of white); None: the
      prior's default (``HUBER_THRESHOLD``, ``TV_SMOOTHING``); must be None for the
      quadratic prior
    - ``channels``: channel numbers from 1 (None: every channel)
    - ``lens_types``: lens type numbers from 1 (a multi-focus array's types, in the order
      of the channel's ``f``): only the pixels under lenses of these types are used
      (None: every type)
    - ``noise``: the raw's noise, as for :func:`splitlf.render` (``{"photons": N,
      "read_noise": r}``; ``{"photons": math.inf}``: noise-free, weighted as
      ``NOISE_FLOOR`` of white); None: the noise model the raw carries (``raw.noise``),
      and when it carries none, estimated from the data (photon noise, N fitted by GCV's
      RSS / (m - df); read noise taken as 0). It also sets the solve's stop: with a
      known noise the CG stops once its residual is
      ``CG_NOISE_TOL`` of the noise's expected norm in the right-hand side (measured: the
      image moves from the fully converged one by 0.1–2 % of its error against the
      truth, docs/reconstruct.md step 3), or at ``CG_RTOL`` of the right-hand side,
      whichever comes first; noise-free, at ``CG_RTOL`` only
    - ``tile``: at most this many cells per side in one solve (at least ``MIN_TILE``): a
      larger region is solved in tiles, each reaching ``TILE_OVERLAP`` cells into its
      neighbours and padded by a pixel's span of its own, and the tiles' own cells put
      together (None: one solve, or tiles of the size that fits when one would not)
    - ``n_threads``: threads of the general route's map and of the solve (None: all
      cores; the result does not depend on it)
    - ``progress``: reports of the map and of the solve's iterations (None: a bar when
      stderr is a terminal); the grid's size, the memory plan and the expected time are
      logged (``logging``, logger ``splitlf.reconstruct``, level INFO) before the work
    - ``allow_slow``: run a reconstruction expected to take more than ``MAX_SECONDS``
      (an upper bound at ``CG_MAX_ITER`` iterations, from the plan's entries); without
      it such a run is refused before it starts

    A raw with a colour filter array (``raw.cfa``) gives a :class:`ColourReconstruction`:
    one reconstruction per colour, each from that colour's pixels only (the others' rows
    left out in the core), its pixels divided by the colour's QE and its noise photons N
    QE, lambda chosen per colour (docs/reconstruct.md, "Colour"); ``raw.grey()`` gives a
    grey reconstruction of every pixel instead (exact for a grey scene).

    Cells within one pixel's span (``_native.pixel_span``) beyond the region are solved
    for too and cropped, so that every pixel that sees the region is explained. The whole
    reconstruction is one core call (``_native.reconstruct``: the grid, the map, the
    weights, the solve, the tiles) after the types are checked here. Raises
    ``TypeError``, :class:`~splitlf.errors.InvalidParameter` (also a ``regularization``
    so large that the prior drowns the data: the message states the range for the raw
    and grid), :class:`~splitlf.errors.TooLargeError` (not even a tile's solve would fit;
    or, without ``allow_slow``, a run expected to exceed ``MAX_SECONDS``) and
    ``KeyboardInterrupt``.
    """
    if not isinstance(raw, Raw):
        raise TypeError(f"raw must be a splitlf.Raw, got {type(raw).__name__}")
    if tile is not None and (isinstance(tile, bool) or not isinstance(tile, int | np.integer)):
        raise TypeError(f"tile must be None or an integer number of cells, got {tile!r}")
    if not isinstance(allow_slow, bool):
        raise TypeError(f"allow_slow must be True or False, got {allow_slow!r}")
    design = raw.design
    surface = _depth(depth)
    df_weight = CHOOSE_DF_WEIGHT
    if isinstance(surface, DepthMap) and surface.confidence is not None:
        # An estimate: reconstruct on the surface it stands for (docs/depth.md; the plane
        # it was fitted into, if it was: the tilted route), and choose lambda for a model
        # known to be inexact (its depth's error).
        surface = surface.surface(design, plane=True)
        df_weight = CHOOSE_DF_WEIGHT_ESTIMATE
    chans = _channels(design, channels)
    noise_, source = _stated(noise), "given"
    if noise_ is None:
        noise_, source = _stated(raw.noise), "raw"
    if noise_ is None:
        source = "estimated"
    lam = None if regularization is None else _validate.real(regularization, "regularization")
    prior_, threshold_ = _prior(prior, threshold)
    _validate.n_threads(n_threads)
    plane = surface if not isinstance(surface, float) else Plane(surface)
    options = {
        "channels": list(chans), "lens_types": _lens_types(lens_types),
        "region": None if region is None else _extent(region, "region"),
        "step": None if step is None else _validate.positive_length(step, "step"),
        "regularization": lam, "tile": None if tile is None else int(tile),
        "prior": None if threshold_ is None else (prior_, threshold_, PRIOR_PASSES, PRIOR_TOL),
        "noise": None if noise_ is None else (noise_["photons"], noise_["read_noise"]),
        "allow_slow": allow_slow, "n_threads": n_threads,
        "settings": (NOISE_FLOOR, CG_RTOL, CG_MAX_ITER, CG_NOISE_TOL, TILE_OVERLAP, MIN_TILE,
                     MAX_SECONDS),
        "choose": (*CHOOSE_BRACKET, CHOOSE_PHOTONS, CHOOSE_GOLDEN_STEPS, CHOOSE_PROBES, CHOOSE_SIDE,
                   CHOOSE_MAX_ITER, CHOOSE_PROBE_RTOL, CHOOSE_BUDGET, df_weight)}
    call = _Call(design, plane.seam(), surface, chans, source, df_weight, prior_, threshold_,
                 _progress_flag(progress))
    if raw.cfa is None:
        return _solve(call, list(raw.images), options)
    return _colours(call, raw, options, noise_)


@dataclasses.dataclass(frozen=True)
class _Call:
    """What one reconstruction call's solves share."""

    design: Design
    seam: Any
    surface: float | Plane | DepthMap
    chans: tuple[int, ...]
    source: str
    df_weight: float
    prior: str
    threshold: float | None
    show: Show


def _colours(call: _Call, raw: Raw, options: dict[str, Any],
             noise: Mapping[str, float] | None) -> ColourReconstruction:
    """One solve per colour of a mosaiced raw: that colour's pixels only, divided by its
    QE (the grey raw's), its noise N QE."""
    cfa = raw.cfa
    assert cfa is not None
    images = list(raw.grey().images)
    out = []
    for k in range(3):
        q = cfa["qe"][k]
        opts = dict(options, colour=(cfa["pattern"], k))
        if noise is not None and noise["photons"] != math.inf:
            opts["noise"] = (noise["photons"] * q, noise["read_noise"])
        _log.info("reconstruct: colour %s", COLOURS[k])
        out.append(_solve(call, images, opts))
    return ColourReconstruction((out[0], out[1], out[2]), cfa)


def _solve(call: _Call, images: list[np.ndarray], options: dict[str, Any]
           ) -> Reconstruction:
    """One call into the core's reconstruction, as a :class:`Reconstruction`."""
    report, bars = _reporter(call.show)
    try:
        image, extent, h, rows, iterations, resid, passes, tiles, types, chosen = (
            _native.reconstruct(
                call.design.core, [np.asarray(i, dtype=np.float64) for i in images],
                call.seam, options, report))
    finally:
        for bar in bars:
            bar.close()
    lam_used, rule, (photons, read), _, trials = chosen
    if rule != "fixed" and call.df_weight != 1.0:
        rule = f"weighted {rule}"
    noise_text = (f"noise-free: sigma = {NOISE_FLOOR:g} of white" if photons == math.inf else
                  f"photons {photons:g}, read noise {read:g}")
    _log.info("reconstruct: lambda %.6g (%s), noise %s (%s)", lam_used, rule, noise_text,
              call.source)
    return Reconstruction(image=image, extent=extent, step=h, design=call.design,
                          depth=call.surface, channels=call.chans, rows=rows,
                          iterations=iterations, residual=resid, regularization=lam_used,
                          noise=noise_text, tiles=tiles,
                          lens_types=None if types is None else tuple(types),
                          regularization_rule=rule,
                          df_weight=call.df_weight if rule != "fixed" else 1.0,
                          noise_model={"photons": photons, "read_noise": read},
                          noise_source=call.source, choice=tuple(trials), prior=call.prior,
                          threshold=call.threshold, passes=passes)
