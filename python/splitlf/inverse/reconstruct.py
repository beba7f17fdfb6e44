"""Super-resolved all-in-focus images from raws (docs/model.md §11, docs/reconstruct.md).

:func:`reconstruct` solves for the albedo on a uniform grid of cells over a region of a
known surface: the core builds the sparse linear map A (row = raw pixel, column = cell,
entry = what the pixel records when the cell alone is white), with the forward model's own
integration, so that ``A t`` is ``render``'s raw of the image texture t: on the exact route
(a fronto-parallel plane, rect cells, a square aperture, the ideal layout) as per-axis
factors (``_native.reconstruction_factors``), otherwise as explicit rows
(``_native.surface_system``): from the tilted route for a tilted plane on those designs
(wide pixels cut into parts where it tilts along both axes), from the general route in
record mode for the rest (planes too steep along both axes even for parts, depth maps,
hex arrays, circular apertures, sensor layouts: on planes, and on depth maps that every
ray meets once, each pixel's footprint density over the cells). The core's
matrix-free conjugate gradients (``_native.solve_normal``, SciPy's ``cg`` iteration, in
parallel) solve the regularised least squares

    min_t  sum_rows ((A t - raw) / sigma)^2  +  lambda * |D t|^2

with sigma the raw's noise per pixel (from ``noise``, or a stated floor for noise-free
raws), D the differences between neighbouring cells and lambda a fixed prior weight. The
regulariser's weight never depends on the number of rows: more data never hurts.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .. import _native, _validate
from .._noise import options as _noise
from .._progress import progress_bar as _progress
from .._progress import progress_flag as _progress_flag
from .._validate import channels as _channels
from .._validate import extent as _extent
from ..errors import InvalidParameter, TooLargeError
from ..imaging.render import DepthMap, Plane, Raw
from ..model.design import Design

Extent = tuple[float, float, float, float]

#: The noise (fraction of a fully lit white pixel, 1 sigma) assumed for a raw given without
#: ``noise``: the forward model's stated accuracy (docs/render.md).
NOISE_FLOOR = 1e-3
#: The default weight lambda of the smoothness prior: neighbouring cells' albedos differ by
#: about 1/sqrt(lambda) = 0.5 (a prior as wide as the albedo range's half).
DEFAULT_REGULARIZATION = 4.0
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
#: The least tile side (cells).
MIN_TILE = 16


@dataclasses.dataclass(frozen=True, eq=False)
class Reconstruction:
    """A reconstructed albedo image: ``image`` (2-D float64, row 0 at the top = largest Y,
    column 0 at the left, like a texture) of cells of pitch ``step`` (mm) uniform over
    ``extent`` = (X0, X1, Y0, Y1) in object-space mm, on the surface ``depth`` (a depth in
    mm for a fronto-parallel plane, else the :class:`~splitlf.Plane` or
    :class:`~splitlf.DepthMap` given), from
    ``channels`` (numbered from 1) of ``design`` and their lenses of ``lens_types``
    (numbered from 1; None: every type); and what the solve did: ``rows`` (raw
    pixels used), ``iterations``, ``residual`` (the normal equations' relative residual),
    ``regularization`` (lambda), ``noise`` (the per-pixel sigma model used) and ``tiles``
    (the solves: 1, or the tiles of a tiled reconstruction, whose ``rows`` is then summed
    over the tiles, ``iterations`` the most and ``residual`` the largest of any tile)."""

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

    def __post_init__(self) -> None:
        self.image.setflags(write=False)


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


def _depth_range(surface: float | Plane | DepthMap, ext: Extent) -> tuple[float, float]:
    """The least and greatest depth of the surface over the rectangle ``ext`` (a depth
    map's over its whole extent: a bound)."""
    if isinstance(surface, float):
        return surface, surface
    if isinstance(surface, Plane):
        return surface.depths(ext)
    return float(surface.depth.min()), float(surface.depth.max())


def _reference_depth(surface: float | Plane | DepthMap, region: Extent | None) -> float:
    """The depth that sizes the defaults: a plane's depth at the region's centre (on the
    axis, X = Y = 0, without a region), a depth map's median."""
    if isinstance(surface, float):
        return surface
    if isinstance(surface, Plane):
        if region is None:
            return surface.z0
        x0, x1, y0, y1 = region
        return surface.z0 + surface.gx * 0.5 * (x0 + x1) + surface.gy * 0.5 * (y0 + y1)
    return float(np.median(surface.depth))


def _exact(design: Design, surface: float | Plane | DepthMap, chans: tuple[int, ...]) -> bool:
    """Whether the map can be built in factored form (the forward model's exact route)."""
    if not isinstance(surface, float) or design.aperture != "square":
        return False
    res = design.resolved()
    return all(res[c - 1]["grid"] == "rect" and res[c - 1]["layout"] == "ideal" for c in chans)


def _type_count(design: Design, chans: tuple[int, ...]) -> int:
    """The most lens types of any of the channels (a channel without ``f``: one)."""
    res = design.resolved()
    return max(len(res[i - 1]["f"]) for i in chans)


def _lens_types(design: Design, chans: tuple[int, ...], lens_types: Any
                ) -> tuple[int, ...] | None:
    """The lens types kept (numbered from 1), or None for every type."""
    if lens_types is None:
        return None
    n = _type_count(design, chans)
    if isinstance(lens_types, (int, np.integer)) and not isinstance(lens_types, bool):
        lens_types = (lens_types,)
    if (not isinstance(lens_types, Sequence) or isinstance(lens_types, str)
            or not lens_types):
        raise TypeError("lens_types must be None, a lens type number or a non-empty "
                        f"sequence of them, got {lens_types!r}")
    out: list[int] = []
    for t in lens_types:
        if isinstance(t, bool) or not isinstance(t, (int, np.integer)):
            raise TypeError(f"lens_types must hold integers, got {t!r}")
        if not 1 <= t <= n:
            raise InvalidParameter.of("lens_types", int(t),
                                      f"lens type numbers in 1..{n} (the chosen channels' "
                                      "lens types)")
        if int(t) in out:
            raise InvalidParameter.of("lens_types", int(t), "each lens type at most once")
        out.append(int(t))
    return None if sorted(out) == list(range(1, n + 1)) else tuple(sorted(out))


def _sigma(y: np.ndarray, noise: Mapping[str, float] | None, white: np.ndarray
           ) -> tuple[np.ndarray, str]:
    """Per-row noise sigma: Poisson(N v)/N plus read noise r/N (render's model), or the
    floor NOISE_FLOOR x white for noise-free raws; never below the floor."""
    floor = NOISE_FLOOR * white
    if noise is None:
        return floor, f"noise-free: sigma = {NOISE_FLOOR:g} of white"
    n, r = noise["photons"], noise["read_noise"]
    var = np.maximum(y, 0.0) / n + (r / n) ** 2
    return np.maximum(np.sqrt(var), floor), f"photons {n:g}, read noise {r:g}"


def _csr(m: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A SciPy CSR matrix as the core's (indptr, indices, data, number of columns)."""
    return (np.ascontiguousarray(m.indptr, dtype=np.uint64),
            np.ascontiguousarray(m.indices, dtype=np.uint32),
            np.ascontiguousarray(m.data, dtype=np.float64), int(m.shape[1]))


@dataclasses.dataclass
class _Part:
    """The pixels of one lens type of one channel that see only the grid: the map's rows
    norm (y row b) ⊗ (x row a), restricted to the raw rows and columns with such pixels."""

    norm: float
    px: Any  # CSR, (raw columns kept, grid columns)
    py: Any  # CSR, (raw rows kept, grid rows from the top)
    mask: np.ndarray  # (rows kept, columns kept): the pixel is a row of the map
    y: np.ndarray  # the raw values at the mask
    white: float  # the channel's share (a fully lit white pixel)

    def seam(self, w: np.ndarray) -> tuple[Any, ...]:
        """The core's factored block (norm, px, py, weights, values) for row weights w."""
        wf, yf = np.zeros(self.mask.shape), np.zeros(self.mask.shape)
        wf[self.mask], yf[self.mask] = w, self.y
        return (self.norm, _csr(self.px), _csr(self.py), wf.ravel(), yf.ravel())


@dataclasses.dataclass
class _Rows:
    """Explicit rows of the map (any surface, any design) over the padded grid's cells, as
    the core's CSR arrays, the raw values of its rows and each row's fully lit white
    value."""

    csr: tuple[np.ndarray, np.ndarray, np.ndarray, int]
    y: np.ndarray
    white: np.ndarray

    @property
    def mask(self) -> np.ndarray:
        return np.ones(self.y.shape, dtype=bool)

    def seam(self, w: np.ndarray) -> tuple[Any, ...]:
        """The core's block of explicit rows (A, weights, values)."""
        return (self.csr, np.ascontiguousarray(w, dtype=np.float64), self.y)


def _tiles_hint(e: TooLargeError, nx: int, ny: int, pad: int, step: float) -> TooLargeError:
    """``e`` with a suggested tile: the region's cells scaled by the share of the need
    that fits (each tile is padded by ``pad`` cells of its own, so tiles overlap by that).
    When the padding alone is past what fits (a tile below ``MIN_TILE``), tiles cannot
    help: a coarser step is suggested instead (a row's entries scale as the inverse square
    of the step, the pixels do not change)."""
    if not (e.bytes and e.limit) or e.bytes <= 0:
        return e
    scale = math.sqrt(0.8 * e.limit / e.bytes)
    side = max(1, int(math.sqrt((nx + 2 * pad) * (ny + 2 * pad)) * scale) - 2 * pad)
    head = f"{e} The region is {nx} x {ny} cells (padded by {pad} per side)"
    if side < MIN_TILE:
        coarse = step / scale
        msg = (f"{head}: tiles would not help, the padding (a pixel's span on the surface, "
               f"{pad} cells) needs the memory; use a coarser step (at least about "
               f"{coarse:.3g} mm, step={coarse:.3g}), or fewer channels.")
    else:
        msg = f"{head}: reconstruct it in tiles of at most {side} x {side} cells (tile={side})."
    out = TooLargeError(msg, what=e.what, nbytes=e.bytes, limit=e.limit)
    out.tile = side  # type: ignore[attr-defined]
    return out


def _rows(raw: Raw, chans: tuple[int, ...], surface: Plane | DepthMap | float, grid: tuple,
          n_threads: int | None, progress: Any, types: tuple[int, ...] | None = None
          ) -> list[_Rows]:
    design = raw.design
    plane = surface if not isinstance(surface, float) else Plane(surface)
    kind, params, depth_map = plane.seam()
    scene = _native.RenderScene("constant", [0.0], None, kind, params, depth_map, 0.0)
    chan, pix, indptr, indices, data = _native.surface_system(
        design.core, scene, grid, list(chans), n_threads, progress,
        None if types is None else list(types))
    if chan.size == 0:
        return []
    shares = np.array([c["share"] for c in design.resolved()])
    ch = chan.astype(np.int64)
    # Each row's raw value, read from its own channel's image (no copy of whole raws).
    y = np.empty(chan.size)
    for c in np.unique(ch):
        sel = ch == c
        y[sel] = raw.images[c].ravel()[pix[sel].astype(np.int64)]
    return [_Rows(csr=(indptr, indices, data, grid[3] * grid[4]), y=y, white=shares[ch])]


def _parts(raw: Raw, chans: tuple[int, ...], z: float, grid: tuple,
           kept_types: tuple[int, ...] | None = None) -> list[_Part]:
    from scipy import sparse

    design = raw.design
    gnx, gny = grid[3], grid[4]
    shares = [c["share"] for c in design.resolved()]
    parts = []
    for c in chans:
        norm, types, xs, ys = _native.reconstruction_factors(design.core, z, grid, c)
        img = raw.images[c - 1]
        rows, cols = types.shape
        for t, ((xi, xj, xd, tx), (yi, yj, yd, ty)) in enumerate(zip(xs, ys, strict=True)):
            if kept_types is not None and t + 1 not in kept_types:
                continue
            px = sparse.csr_matrix((xd, xj.astype(np.int64), xi.astype(np.int64)),
                                   shape=(cols, gnx))
            py = sparse.csr_matrix((yd, yj.astype(np.int64), yi.astype(np.int64)),
                                   shape=(rows, gny))
            sx = np.asarray(px.sum(axis=1)).ravel()
            sy = np.asarray(py.sum(axis=1)).ravel()
            # Only raw rows and columns whose rays reach the grid can hold rows of the map:
            # the masks below are over those, not over the whole raw.
            rows_in = np.flatnonzero((ty > 0.0) & (sy > 0.0))
            cols_in = np.flatnonzero((tx > 0.0) & (sx > 0.0))
            total = ty[rows_in, None] * tx[None, cols_in]
            inside = sy[rows_in, None] * sx[None, cols_in]
            kept = ((types[np.ix_(rows_in, cols_in)] == t)
                    & (total - inside <= _native.OUTSIDE_SHARE * total))
            r_any, c_any = kept.any(axis=1), kept.any(axis=0)
            if not r_any.any():
                continue
            r_sel, c_sel = rows_in[r_any], cols_in[c_any]
            mask = kept[np.ix_(r_any, c_any)]
            parts.append(_Part(norm=norm, px=px[c_sel], py=py[r_sel], mask=mask,
                               y=img[np.ix_(r_sel, c_sel)][mask], white=shares[c - 1]))
    return parts


def _tiled(raw: Raw, surface: float | Plane | DepthMap, grid: tuple, tile: int, lam: float,
           chans: tuple[int, ...], noise: Mapping[str, float] | None, n_threads: int | None,
           progress: bool | None, types: tuple[int, ...] | None = None) -> Reconstruction:
    """The grid (X0, Y1, step, nx, ny) solved in tiles of at most ``tile`` cells per side,
    each solve reaching TILE_OVERLAP cells into its neighbours (cropped)."""
    x0, y1, h, nx, ny = grid
    out = np.empty((ny, nx))
    rows = iterations = count = 0
    resid = 0.0
    noise_text = ""
    for j0 in range(0, ny, tile):
        for i0 in range(0, nx, tile):
            j1, i1 = min(ny, j0 + tile), min(nx, i0 + tile)
            e0, e1 = max(0, i0 - TILE_OVERLAP), min(nx, i1 + TILE_OVERLAP)
            f0, f1 = max(0, j0 - TILE_OVERLAP), min(ny, j1 + TILE_OVERLAP)
            sub = (x0 + e0 * h, x0 + e1 * h, y1 - f1 * h, y1 - f0 * h)
            r = _reconstruct(raw, surface, region=sub, step=h, regularization=lam,
                             channels=chans, noise=noise, tile=None, n_threads=n_threads,
                             progress=progress, lens_types=types)
            if r.image.shape != (f1 - f0, e1 - e0):
                raise RuntimeError(f"a tile's grid {r.image.shape} is not its cells "
                                   f"{(f1 - f0, e1 - e0)}")
            out[j0:j1, i0:i1] = r.image[j0 - f0:j1 - f0, i0 - e0:i1 - e0]
            rows += r.rows
            iterations = max(iterations, r.iterations)
            resid = max(resid, r.residual)
            noise_text = r.noise
            count += 1
    return Reconstruction(image=out, extent=(x0, x0 + nx * h, y1 - ny * h, y1), step=h,
                          design=raw.design, depth=surface, channels=chans, rows=rows,
                          iterations=iterations, residual=resid, regularization=lam,
                          noise=noise_text, tiles=count, lens_types=types)


def reconstruct(raw: Raw, depth: Any, *, region: Any = None, step: float | None = None,
                regularization: float | None = None, channels: Any = None,
                noise: Mapping[str, float] | None = None, tile: int | None = None,
                n_threads: int | None = None, progress: bool | None = None,
                lens_types: Any = None) -> Reconstruction:
    """The albedo on a grid of cells over ``region`` of the surface ``depth``, from the raw
    (docs/model.md §11, docs/reconstruct.md).

    - ``raw``: a :class:`splitlf.Raw` (rendered, loaded or wrapped)
    - ``depth``: the surface: a depth (mm), a :class:`splitlf.Plane` (slanted or not) or a
      :class:`splitlf.DepthMap`, deeper than F over the region (padded by a pixel's span);
      a tilted plane may be nearer than F elsewhere in the view, where ``render`` would
      refuse it
    - ``region``: (X0, X1, Y0, Y1) mm (None: what each chosen channel sees through at
      least half its aperture at the reference depth, ``_native.seen_region``; for a
      depth map, within its extent); rounded out to whole cells
    - ``step``: the cell pitch, mm (None: delta(z) = mu_1 z / L_1, the sensor's step, at
      the reference depth: a plane's depth at the region's centre (on the axis without a
      region), a depth map's median)
    - ``regularization``: lambda, the smoothness prior's weight (None:
      ``DEFAULT_REGULARIZATION``); it does not depend on the number of pixels
    - ``channels``: channel numbers from 1 (None: every channel)
    - ``lens_types``: lens type numbers from 1 (a multi-focus array's types, in the order
      of the channel's ``f``): only the pixels under lenses of these types are used
      (None: every type)
    - ``noise``: the raw's noise, as for :func:`splitlf.render` (``{"photons": N,
      "read_noise": r}``); None: noise-free, weighted as ``NOISE_FLOOR`` of white. It also
      sets the solve's stop: with a known noise the CG stops once its residual is
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
    - ``progress``: tqdm bars of the map and of the solve's iterations (None: only when
      stderr is a terminal)

    Cells within one pixel's span (``_native.pixel_span``) beyond the region are solved
    for too and cropped, so that every pixel that sees the region is explained. Raises
    ``TypeError``, :class:`~splitlf.errors.InvalidParameter`,
    :class:`~splitlf.errors.TooLargeError` (not even a tile's solve would fit) and
    ``KeyboardInterrupt``.
    """
    if tile is not None and (isinstance(tile, bool) or not isinstance(tile, int | np.integer)):
        raise TypeError(f"tile must be None or an integer number of cells, got {tile!r}")
    if tile is not None and tile < MIN_TILE:
        raise InvalidParameter.of("tile", tile, f"an integer >= {MIN_TILE} (cells) or None")
    kw: dict[str, Any] = {"region": region, "step": step, "regularization": regularization,
                          "channels": channels, "noise": noise, "n_threads": n_threads,
                          "progress": progress, "lens_types": lens_types}
    try:
        return _reconstruct(raw, depth, tile=None if tile is None else int(tile), **kw)
    except TooLargeError as e:
        side = getattr(e, "tile", None)
        if tile is not None or side is None or side < MIN_TILE:
            raise
        # One solve would not fit: tiles of the size that does.
        return _reconstruct(raw, depth, tile=int(side), **kw)


def _reconstruct(raw: Raw, depth: Any, *, region: Any, step: float | None,
                 regularization: float | None, channels: Any,
                 noise: Mapping[str, float] | None, tile: int | None,
                 n_threads: int | None, progress: bool | None,
                 lens_types: Any = None) -> Reconstruction:
    """:func:`reconstruct` over its region: one solve, or tiles of at most ``tile`` cells
    per side."""
    if not isinstance(raw, Raw):
        raise TypeError(f"raw must be a splitlf.Raw, got {type(raw).__name__}")
    design = raw.design
    surface = _depth(depth)
    chans = _channels(design, channels)
    types = _lens_types(design, chans, lens_types)
    noise_ = _noise(noise)
    lam = DEFAULT_REGULARIZATION if regularization is None else _validate.real(
        regularization, "regularization")
    if not (math.isfinite(lam) and lam > 0.0):
        raise InvalidParameter.of("regularization", lam, "a finite value > 0")
    _validate.n_threads(n_threads)
    show = _progress_flag(progress)
    core = design.core
    given = None if region is None else _extent(region, "region")
    z_ref = _reference_depth(surface, given)
    if isinstance(surface, Plane):
        # Before the defaults (the step is delta at z_ref): a plane deeper than F over a
        # region may be nearer than F on the axis. The padded region is checked below.
        zlo, where, hint = ((z_ref, "on the axis", "; a plane nearer than F on the axis "
                             "needs a region") if given is None else
                            (_depth_range(surface, given)[0], "least depth over the region",
                             ""))
        if zlo <= design.F:
            raise InvalidParameter.of("depth", f"{zlo:.6g} mm ({where})",
                                      f"depths > F = {design.F:g} mm everywhere in the "
                                      f"region{hint}")
    if step is None:
        step_ = design.resolution_step(z_ref)
    else:
        step_ = _validate.positive_length(step, "step")
    if given is not None:
        ext = given
    else:
        ext = _native.seen_region(core, z_ref, list(chans))
        if isinstance(surface, DepthMap):
            m = surface.extent
            ext = (max(ext[0], m[0]), min(ext[1], m[1]), max(ext[2], m[2]), min(ext[3], m[3]))
            if not (ext[0] < ext[1] and ext[2] < ext[3]):
                raise InvalidParameter.of("region", "none", "a region: the depth map's extent "
                                          "lies outside what the channels see; give one")
    x0, y1, h, nx, ny = _native.cell_grid(ext, step_)
    inner: Extent = (x0, x0 + nx * h, y1 - ny * h, y1)
    if tile is not None and (nx > tile or ny > tile):
        return _tiled(raw, surface, (x0, y1, h, nx, ny), tile, lam, chans, noise, n_threads,
                      progress, types)
    # Pad by the widest pixel span over the surface's depths there (twice: the padded
    # region's depth range can be wider).
    padded = inner
    pad = 0
    for _ in range(2):
        zlo, zhi = _depth_range(surface, padded)
        if zlo <= design.F:
            raise InvalidParameter.of(
                "depth", f"{zlo:.6g} mm (least depth over the region)",
                f"depths > F = {design.F:g} mm everywhere in the region")
        pad = math.ceil(max(_native.pixel_span(core, zlo, list(chans)),
                            _native.pixel_span(core, zhi, list(chans))) / h)
        padded = (inner[0] - pad * h, inner[1] + pad * h, inner[2] - pad * h, inner[3] + pad * h)
    gx0, gy1, _, gnx, gny = _native.cell_grid(padded, h)
    exact = _exact(design, surface, chans)
    bar = None
    try:
        parts: Sequence[_Part | _Rows]
        try:
            if exact:
                assert isinstance(surface, float)
                parts = _parts(raw, chans, surface, (gx0, gy1, h, gnx, gny), types)
            else:
                bar, report = _progress(show, "splitlf reconstruct (map)", "block")
                parts = _rows(raw, chans, surface, (gx0, gy1, h, gnx, gny), n_threads,
                              report, types)
                if bar is not None:
                    bar.close()
                    bar = None
        except TooLargeError as e:
            raise _tiles_hint(e, nx, ny, pad, h) from None
        rows = sum(int(p.mask.sum()) for p in parts)
        if rows == 0:
            raise InvalidParameter.of(
                "region", f"({inner[0]:.6g}, {inner[1]:.6g}, {inner[2]:.6g}, {inner[3]:.6g})",
                "a region some pixel of the chosen channels"
                + ("" if types is None else " and lens types") + " sees")
        factored: list[tuple[Any, ...]] = []
        explicit: list[tuple[Any, ...]] = []
        for p in parts:
            sigma, noise_text = _sigma(p.y, noise_, np.broadcast_to(p.white, p.y.shape))
            (factored if isinstance(p, _Part) else explicit).append(p.seam(1.0 / sigma ** 2))
        bar, report = _progress(show, "splitlf reconstruct (CG)", "step")
        try:
            t, iterations, resid = _native.solve_normal(
                (gny, gnx), lam, factored, explicit, CG_RTOL, CG_MAX_ITER,
                0.0 if noise_ is None else CG_NOISE_TOL, n_threads, report)
        except TooLargeError as e:
            raise _tiles_hint(e, nx, ny, pad, h) from None
    finally:
        if bar is not None:
            bar.close()
    img = t[pad:pad + ny, pad:pad + nx].copy()
    return Reconstruction(image=img, extent=inner, step=h, design=design, depth=surface,
                          channels=chans, rows=rows, iterations=iterations, residual=resid,
                          regularization=lam, noise=noise_text, lens_types=types)
