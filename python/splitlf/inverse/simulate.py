"""Super-resolution simulation: what the split sensor buys (``docs/simulate.md``).

A textured Lambertian plane at a known depth z is imaged by each channel of a design alone
(for the split sensor, the seed camera: half 1, the original light field camera, and
half 2), by the union of its channels (the split sensor) and by the conventional camera of
one channel's sensor; each image is inverted by regularised least squares on a grid of
spacing delta(z) (full sensor resolution, docs/model.md §6, §9), and the reconstructions
are scored (RMSE, PSNR, MTF50).

The optics run in the Rust core: every pixel value is the exact integral of a
piecewise-constant texture against the pixel's footprint kernel
(``_native.design_render``), and the system matrix holds the exact integral of each
kernel over each grid cell (``_native.design_system_matrix``). This module holds the
orchestration: textures on the fine grid, noise (NumPy's seeded Generator), the sparse
solve (SciPy) and the metrics.

The simulation is 1D, along x: one row of the texture, pixels of one sensor row.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .. import _native, _validate
from .._noise import add_noise as _add_noise
from .._noise import options as _noise
from .._noise import seed as _seed
from .._piecewise import antiderivative as _piecewise_antiderivative
from .._validate import nonnegative as _albedo
from .._validate import rect_grids as _check_rect
from ..errors import InvalidParameter
from ..imaging.texture import (
    ANALYTIC,
    MTF_AMPLITUDE,
    TEXTURES,
    BarChart,
    Image,
    RandomAlbedo,
    SiemensStar,
    Sinusoid,
    SlantedEdge,
)
from ..model.design import Design

__all__ = [
    "HALF_SOURCES",
    "design_sources",
    "forward",
    "system_matrix",
    "BarChart",
    "Image",
    "RandomAlbedo",
    "SiemensStar",
    "Simulation",
    "Sinusoid",
    "SlantedEdge",
    "simulate",
]

#: Prior standard deviation of the albedo difference between neighbouring delta(z) cells,
#: used to set the regularisation weight with noise (docs/simulate.md): that of the
#: default random albedo, sqrt(2/12) = 0.41 for i.i.d. uniform [0, 1] cells.
PRIOR_STEP = 0.4
#: The noise assumed for a noise-free image (1 sigma, a fraction of a fully lit white
#: pixel) in setting the regularisation weight: a fixed floor, so that the weight never
#: depends on the number of pixels, and far below any real noise (the 1-D forward model
#: is exact), so that it only selects the smoothest solution in a null space
#: (docs/simulate.md).
NOISE_FREE_SIGMA = 1e-5
#: Normal equations up to this many cells are solved by dense Cholesky, larger by sparse LU.
DENSE_CELLS = 6000
def _scipy() -> tuple[types.ModuleType, types.ModuleType, types.ModuleType]:
    try:
        import scipy.linalg as sla
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            'splitlf.simulate needs SciPy: pip install "splitlf[simulate]"'
        ) from e
    return sp, spla, sla


#: The split sensor's source names, accepted for a design of two channels (the seed
#: camera's words, docs/model.md §1): half i is channel i's light field.
HALF_SOURCES = {"half1": "channel1", "half2": "channel2"}


def design_sources(design: Design) -> tuple[str, ...]:
    """The pixel sources of a :class:`~splitlf.Design` of C channels: ``"channel1"``, ...,
    ``"channelC"`` (each channel's light field), then ``"conventional1"``, ...,
    ``"conventionalC"`` (the conventional camera with a sensor of pitch mu_c on channel c's
    array plane). A design of two channels (the split sensor, e.g. ``Camera.paper()``) also
    accepts ``"half1"`` and ``"half2"`` for ``"channel1"`` and ``"channel2"``
    (:data:`HALF_SOURCES`)."""
    n = len(design.channels)
    return (tuple(f"channel{c}" for c in range(1, n + 1))
            + tuple(f"conventional{c}" for c in range(1, n + 1)))


def _source(design: Design, source: Any) -> str:
    """The core's name of ``source`` (checked by the core: :class:`InvalidParameter`
    named ``source``); ``"half1"``/``"half2"`` mean channel 1/2 of a two-channel
    design."""
    if not isinstance(source, str):
        raise TypeError(f"source must be a string, got {type(source).__name__}")
    if len(design.channels) == 2:
        return HALF_SOURCES.get(source, source)
    return source


def _field(origin: float, step: float, n: int, field: Any) -> tuple[float, float]:
    if field is None:
        return origin, origin + n * step
    lo, hi = (_validate.real(v, "field") for v in field)
    return lo, hi


def forward(design: Design, z: float, source: str, origin: float, step: float,
            texture: Any, field: tuple[float, float] | None = None,
            n_threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free pixel values (exact, computed in the core) of ``source`` on the plane at
    depth ``z`` for albedos constant on the cells [origin + k step, origin + (k+1) step]:
    ``texture`` (n_cells,) or (n_textures, n_cells), finite and >= 0. Only pixels whose
    kernel lies inside ``field`` (default: the grid) are rendered. Returns (values
    (n_textures, n_pixels) or (n_pixels,), pixel indices along x). Units: a pixel of width
    mu_1 on plane L_1 seeing the whole aperture under a white texture reads 1, and each
    channel's light field includes its ``share`` (the seed camera: the beam splitter's 1/2).

    ``design`` a :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one; the source's
    channel on a rect grid); ``z`` depth [mm] > F; ``source`` one of
    :func:`design_sources` (``"half1"``, ``"half2"`` too for two channels); ``origin``,
    ``step`` [mm] (step > 0);
    ``field`` (lo, hi) [mm]; ``n_threads`` threads of the core (None: all). Raises
    ``TypeError`` (types) and ``ValueError`` (ranges, checked by the core; a hex channel
    named ``channels[i].grid``)."""
    subject = _validate.design(design)
    src = _source(subject, source)
    t = np.asarray(texture)
    if t.dtype == object or not (np.issubdtype(t.dtype, np.floating)
                                 or np.issubdtype(t.dtype, np.integer)):
        raise TypeError(f"texture must be a numeric array, got dtype {t.dtype}")
    if t.ndim not in (1, 2) or t.shape[-1] < 1:
        raise ValueError(f"texture must have shape (n_cells,) or (n, n_cells), got {t.shape}")
    t2 = np.ascontiguousarray(np.atleast_2d(t), dtype=np.float64)
    o, h = _validate.real(origin, "origin"), _validate.real(step, "step")
    lo, hi = _field(o, h, t2.shape[1], field)
    r = _native.design_render(subject.core, _validate.real(z, "z"), src, (o, h), (lo, hi), t2,
                              _validate.n_threads(n_threads))
    return (r.values[0] if t.ndim == 1 else r.values), r.pixels


def system_matrix(design: Design, z: float, source: str, origin: float, step: float,
                  n_cells: int, field: tuple[float, float] | None = None,
                  n_threads: int | None = None) -> tuple[Any, np.ndarray]:
    """The sparse system matrix (``scipy.sparse.csr_matrix``, pixels x cells) of ``source``
    on the plane at depth ``z``: entry (p, k) is the exact integral of pixel p's kernel over
    cell k (assembled in the core), in the units of :func:`forward`. Returns (matrix,
    pixel indices along x).

    ``n_cells`` an integer >= 1; the other arguments as in :func:`forward`. Raises
    ``TypeError``, ``ValueError`` and ``ImportError`` without SciPy."""
    sp = _scipy()[0]
    subject = _validate.design(design)
    src = _source(subject, source)
    o, h = _validate.real(origin, "origin"), _validate.real(step, "step")
    n = _int(n_cells, "n_cells", 1)
    lo, hi = _field(o, h, n, field)
    a = _native.design_system_matrix(subject.core, _validate.real(z, "z"), src, (o, h, n),
                                     (lo, hi), _validate.n_threads(n_threads))
    return sp.csr_matrix((a.data, a.indices, a.indptr), shape=a.shape), a.pixels


# -- textures (splitlf.textures) -----------------------------------------------------------

Texture = (Sinusoid | BarChart | SlantedEdge | SiemensStar | RandomAlbedo | Image
           | Callable[[np.ndarray], Any] | str)


def _texture(value: Any) -> Any:
    if isinstance(value, str):
        if value != "random":
            raise ValueError(
                f"invalid texture = {value!r}: allowed \"random\", or a Sinusoid, BarChart, "
                "SlantedEdge, SiemensStar, RandomAlbedo, Image or a callable albedo(X mm)"
            )
        return RandomAlbedo()
    if isinstance(value, TEXTURES) or callable(value):
        return value
    raise TypeError(
        "texture must be \"random\", a Sinusoid, BarChart, SlantedEdge, SiemensStar, "
        f"RandomAlbedo, Image or a callable albedo(X mm), got {type(value).__name__}"
    )


def _fine_texture(tex: Any, edges: np.ndarray, delta: float,
                  rng: np.random.Generator) -> np.ndarray:
    """Cell averages of the texture on the fine cells between ``edges`` (exact for every
    kind except a callable, which is sampled at the cell centres)."""
    h = np.diff(edges)
    if isinstance(tex, ANALYTIC):  # the row Y = 0 of a 2-D texture
        return np.maximum(np.diff(tex.antiderivative(edges)) / h, 0.0)
    if isinstance(tex, RandomAlbedo):
        cell = delta if tex.cell is None else tex.cell
        k0 = math.floor(edges[0] / cell)
        k1 = math.ceil(edges[-1] / cell)
        cells = np.arange(k0, k1 + 1) * cell
        vals = rng.uniform(tex.low, tex.high, size=cells.size - 1)
        return np.maximum(np.diff(_piecewise_antiderivative(cells, vals, edges, 0.0)) / h, 0.0)
    if isinstance(tex, Image):
        line = tex.line()
        px = np.linspace(-tex.width / 2, tex.width / 2, line.size + 1)
        ad = _piecewise_antiderivative(px, line, edges, float(line.mean()))
        return np.maximum(np.diff(ad) / h, 0.0)
    centres = 0.5 * (edges[1:] + edges[:-1])
    try:
        vals = np.asarray(tex(centres), dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"texture callable must return real albedos for an array of X: {e}") \
            from None
    if vals.shape != centres.shape:
        raise ValueError(
            f"texture callable returned shape {vals.shape} for {centres.shape} positions"
        )
    if not np.all(np.isfinite(vals)) or np.any(vals < 0):
        raise ValueError("texture callable must return finite albedos >= 0")
    return vals


# -- result --------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Simulation:
    """One simulated plane at depth ``z`` [mm] of a design of C channels (docs/simulate.md).

    - ``configs`` (also ``rows``): the names of the rows, in order: ``"channel 1"``, ...,
      ``"channel C"``, ``"union"`` (every channel's pixels together: the split sensor),
      ``"conventional c"`` (absent with ``simulate(..., conventional=False)``)
    - ``delta``: grid spacing delta(z) = mu_1 z / L_1 [mm] (the seed camera: d z / (Q v'),
      docs/model.md §6, §9); ``x`` (W,) cell centres of the central window of W cells [mm]
    - ``truth`` (W,): the texture's average over each cell; ``reconstructions``
      {config: (W,)} the reconstructions on the same cells (also :meth:`reconstruction`);
      the split sensor's names as properties: :attr:`half1` (channel 1), :attr:`half2`
      (channel 2), :attr:`split` (the union), :attr:`conventional` (the conventional row,
      None without it)
    - ``rmse``, ``psnr`` [dB, peak albedo 1], ``mtf50`` [cycles/mm on the object]: one
      value per configuration in ``configs`` (``mtf50`` empty with ``mtf=False``)
    - ``frequencies`` (F,) [cycles/mm] and ``contrast`` {config: (F,)}: the MTF search
    - ``nyquist`` = 1 / (2 delta) and ``microlens_frequency`` = L_1 / (d_1 z), one cycle
      per channel-1 microlens pitch on the object [cycles/mm] (the seed: v' / (d z))
    - ``regularization`` {config: weight lambda of the first-difference penalty}
    - ``pixels`` {config: pixels used}, ``noise``, ``seed``, ``conventional_half`` (the
      channel whose array plane holds the conventional sensor, also
      :attr:`conventional_channel`; None without the conventional row)
    """

    z: float
    delta: float
    x: np.ndarray
    truth: np.ndarray
    rmse: Mapping[str, float]
    psnr: Mapping[str, float]
    mtf50: Mapping[str, float]
    frequencies: np.ndarray
    contrast: Mapping[str, np.ndarray]
    nyquist: float
    microlens_frequency: float
    regularization: Mapping[str, float]
    pixels: Mapping[str, int]
    noise: Mapping[str, float] | None
    seed: int | None
    conventional_half: int | None
    configs: tuple[str, ...]
    reconstructions: Mapping[str, np.ndarray]

    @property
    def rows(self) -> tuple[str, ...]:
        """The names of the rows, as every result of a Design names them (``.rows``): the
        same tuple as ``configs``."""
        return self.configs

    def reconstruction(self, config: str) -> np.ndarray:
        """The reconstruction (W,) of ``config``, one of ``configs``; else
        :class:`~splitlf.errors.InvalidParameter`."""
        if config not in self.configs:
            raise InvalidParameter.of("config", config, ", ".join(self.configs))
        return self.reconstructions[config]

    # The split sensor's words (docs/model.md §1): half i is channel i, the split sensor
    # the union of the channels.
    @property
    def half1(self) -> np.ndarray:
        """Channel 1's reconstruction (half 1 of the split sensor)."""
        return self.reconstruction("channel 1")

    @property
    def half2(self) -> np.ndarray:
        """Channel 2's reconstruction (half 2 of the split sensor);
        :class:`~splitlf.errors.InvalidParameter` for a design of one channel."""
        return self.reconstruction("channel 2")

    @property
    def split(self) -> np.ndarray:
        """The union's reconstruction (the split sensor: both halves' pixels)."""
        return self.reconstruction("union")

    @property
    def conventional(self) -> np.ndarray | None:
        """The conventional camera's reconstruction, None without its row
        (``simulate(..., conventional=False)``)."""
        if self.conventional_half is None:
            return None
        return self.reconstruction(f"conventional {self.conventional_half}")

    @property
    def conventional_channel(self) -> int | None:
        """The channel whose array plane holds the conventional sensor (the same as
        ``conventional_half``), None without the conventional row."""
        return self.conventional_half

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures of merit: a dict of numbers, strings, dicts and None. A value
        that is not finite is None (the PSNR of an exact reconstruction is +inf)."""

        def finite(m: Mapping[str, float]) -> dict[str, float | None]:
            """The mapping with +-inf and NaN as None."""
            return {k: (v if math.isfinite(v) else None) for k, v in m.items()}

        return {
            "z_mm": self.z,
            "delta_mm": self.delta,
            "nyquist_cycles_per_mm": self.nyquist,
            "microlens_frequency_cycles_per_mm": self.microlens_frequency,
            "rmse": dict(self.rmse),
            "psnr_db": finite(self.psnr),
            "mtf50_cycles_per_mm": dict(self.mtf50),
            "regularization": dict(self.regularization),
            "pixels": dict(self.pixels),
            "noise": None if self.noise is None else dict(self.noise),
            "seed": self.seed,
        }


# -- the simulation ---------------------------------------------------------------------------

def _int(value: Any, name: str, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer >= {lo}, got {value!r}")
    if int(value) < lo:
        raise InvalidParameter.of(name, int(value), f"an integer >= {lo}")
    return int(value)


def _fit_contrast(rec: np.ndarray, basis: np.ndarray, amplitude: float) -> np.ndarray:
    """Least-squares fit of rec (..., W) to [1, sin, cos] at one frequency (sampled at the
    cell centres); amplitude of the fitted sinusoid over the texture's."""
    coef, *_ = np.linalg.lstsq(basis, rec.T, rcond=None)
    return np.hypot(coef[1], coef[2]) / amplitude


def _mtf50(freqs: np.ndarray, contrast: np.ndarray) -> float:
    """First crossing of contrast 0.5 scanning up in frequency, linearly interpolated
    (from contrast 1 at frequency 0); the highest tested frequency if it never drops."""
    below = np.flatnonzero(contrast < 0.5)
    if below.size == 0:
        return float(freqs[-1])
    k = int(below[0])
    f0, c0 = (0.0, 1.0) if k == 0 else (float(freqs[k - 1]), float(contrast[k - 1]))
    f1, c1 = float(freqs[k]), float(contrast[k])
    return f0 + (f1 - f0) * (c0 - 0.5) / (c0 - c1) if c0 != c1 else f1


@dataclasses.dataclass(frozen=True)
class _Options:
    """The validated arguments of :func:`simulate`."""

    z: float
    texture: Any
    noise: dict[str, float] | None
    seed: int | None
    window: int
    oversample: int
    mtf: bool
    n_frequencies: int
    regularization: float | None
    conventional_half: int
    n_threads: int | None


def _conventional(subject: Design, half: Any, channel: Any) -> int:
    """The channel (half, for the split sensor) of the conventional camera's sensor: give
    ``conventional_half`` or ``conventional_channel``, not both; default 1."""
    if half is not None and channel is not None:
        raise TypeError("give conventional_half or conventional_channel, not both")
    name = "conventional_half" if channel is None else "conventional_channel"
    value = 1 if half is None and channel is None else (half if channel is None else channel)
    ch = _int(value, name, 1)
    n = len(subject.channels)
    if ch > n:
        raise InvalidParameter.of(name, ch, "1 or 2" if n == 2 else f"an integer in [1, {n}]")
    return ch


def _options(z: Any, texture: Any, noise: Any, seed: Any, window: Any, oversample: Any,
             mtf: Any, n_frequencies: Any, regularization: Any, conventional: int,
             n_threads: Any) -> _Options:
    """Check every argument of :func:`simulate` before any work."""
    win = _int(window, "window", 8)
    if not isinstance(mtf, bool):
        raise TypeError(f"mtf must be a bool, got {mtf!r}")
    ch = conventional
    return _Options(
        z=_validate.real(z, "z"), texture=_texture(texture), noise=_noise(noise),
        seed=_seed(seed), window=win + win % 2, oversample=_int(oversample, "oversample", 1),
        mtf=mtf, n_frequencies=_int(n_frequencies, "n_frequencies", 2),
        regularization=None if regularization is None
        else _albedo(regularization, "regularization"),
        conventional_half=ch, n_threads=_validate.n_threads(n_threads),
    )


@dataclasses.dataclass(frozen=True)
class _Grid:
    """The cells of delta(z) of one plane: the central window of ``win`` cells plus, on
    each side, a margin of the widest kernel (+1 free cell). The light-field halves share
    one grid, the conventional camera has its own; all lie inside the largest ("big")
    grid of ``n_big`` cells starting at ``origin`` [mm], window cells from ``w0``."""

    delta: float
    win: int
    margin: dict[str, int]
    big: int
    n_big: int
    origin: float
    w0: int


def _grid(core: Any, z: float, sources: Mapping[str, str], lf: tuple[str, ...],
          conv: str, delta: float, win: int, threads: int | None) -> _Grid:
    support = {k: _native.design_kernel_support(core, z, s, threads)
               for k, s in sources.items()}
    margin_lf = math.ceil(max(support[k] for k in lf) / delta) + 1
    margin = {k: margin_lf for k in lf}
    margin[conv] = math.ceil(support[conv] / delta) + 1
    big = max(margin.values())
    n_big = win + 2 * big + 2
    return _Grid(delta=delta, win=win, margin=margin, big=big, n_big=n_big,
                 origin=-(n_big // 2) * delta, w0=big + 1)


def _textures(tex: Any, grid: _Grid, oversample: int, freqs: np.ndarray, mtf: bool,
              rng: np.random.Generator) -> np.ndarray:
    """The textures on the fine cells (``oversample`` per delta(z) cell) of the big grid:
    row 0 the texture, then the MTF sinusoids (two phases per frequency)."""
    fine_edges = grid.origin + np.arange(grid.n_big * oversample + 1) * (grid.delta / oversample)
    rows = [_fine_texture(tex, fine_edges, grid.delta, rng)]
    if mtf:
        for f in freqs:
            for ph in (0.0, 0.5 * np.pi):
                rows.append(_fine_texture(Sinusoid(f, phase=ph), fine_edges, grid.delta, rng))
    return np.ascontiguousarray(np.vstack(rows))


def _image_systems(core: Any, z: float, sources: Mapping[str, str],
                   lf: tuple[str, ...], union: str, grid: _Grid, fine: np.ndarray,
                   oversample: int, noise: dict[str, float] | None,
                   rng: np.random.Generator, threads: int | None
                   ) -> tuple[dict[str, np.ndarray], dict[str, Any], dict[str, slice]]:
    """Render each source (noise added in the fixed order of ``sources``: channel 1, ...,
    channel C, conventional) and assemble its system matrix; add the ``union`` of the
    light-field sources ``lf`` (their rows stacked: the split sensor). Returns (images,
    matrices, the cells of the big grid each system covers)."""
    sp = _scipy()[0]
    images: dict[str, np.ndarray] = {}
    mats: dict[str, Any] = {}
    cells: dict[str, slice] = {}
    delta = grid.delta
    for key, src in sources.items():
        m = grid.margin[key]
        first = grid.big - m  # grid of this source: cells [first, first + n) of the big grid
        n = grid.win + 2 * m + 2
        cells[key] = slice(first, first + n)
        origin = grid.origin + first * delta
        field = (origin + delta, origin + (n - 1) * delta)
        y = _native.design_render(
            core, z, src, (origin, delta / oversample), field,
            np.ascontiguousarray(fine[:, first * oversample:(first + n) * oversample]),
            threads).values
        images[key] = _add_noise(y, noise, rng)
        a = _native.design_system_matrix(core, z, src, (origin, delta, n), field, threads)
        mats[key] = sp.csr_matrix((a.data, a.indices, a.indptr), shape=a.shape)
    images[union] = np.hstack([images[k] for k in lf])
    mats[union] = sp.vstack([mats[k] for k in lf]).tocsr()
    cells[union] = cells[lf[0]]
    return images, mats, cells


def _weight(row_sums: np.ndarray, y: np.ndarray, user: float | None,
            noise: dict[str, float] | None) -> float:
    """The weight lambda of the first-difference penalty (docs/simulate.md)."""
    if user is not None:
        return user
    if noise is None:
        # A fixed noise floor (never a function of the number of rows: more data must
        # never hurt): the pixel's white value (its row sum at full light) times
        # NOISE_FREE_SIGMA, over the prior step.
        white = float(np.max(row_sums)) if row_sums.size else 1.0
        return (NOISE_FREE_SIGMA * white) ** 2 / PRIOR_STEP**2
    # MAP weight: pixel noise variance over the prior variance of a cell step.
    mean_signal = float(np.mean(np.maximum(y[0], 0.0)))
    var = mean_signal / noise["photons"] + (noise["read_noise"] / noise["photons"]) ** 2
    return var / PRIOR_STEP**2


def _solve(A: Any, y: np.ndarray, user: float | None,
           noise: dict[str, float] | None) -> tuple[np.ndarray, float]:
    """Regularised least squares min |A x - y|^2 + lambda |D x|^2 for every row of ``y``
    (D: first differences). Returns (solutions (rows, cells), lambda)."""
    sp, spla, sla = _scipy()
    n = A.shape[1]
    dense = n <= DENSE_CELLS
    if dense:
        # Banded but often wide (defocused kernels): dense BLAS is faster here.
        Ad = A.toarray()
        AtA = Ad.T @ Ad
    else:
        AtA = (A.T @ A).tocsc()
    D = sp.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n))
    lam = _weight(np.asarray(A.sum(axis=1)).ravel(), y, user, noise)
    rhs = np.asarray(A.T @ y.T)
    if dense:
        normal = AtA + lam * (D.T @ D).toarray()
        try:
            sol = sla.cho_solve(sla.cho_factor(normal), rhs).T
        except np.linalg.LinAlgError:  # only with a user weight too small to help
            sol = np.linalg.lstsq(normal, rhs, rcond=None)[0].T
    else:
        sol = spla.splu((AtA + lam * (D.T @ D)).tocsc()).solve(rhs).T
    return sol, lam


def _mtf_contrast(rec: np.ndarray, x: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """Contrast of each MTF sinusoid (rows 1, 2 of ``rec`` for the first frequency, ...):
    the mean over both phases of the fitted amplitude over the texture's."""
    c = np.empty(freqs.size)
    for i, f in enumerate(freqs):
        w = 2 * np.pi * f
        basis = np.column_stack([np.ones(x.size), np.sin(w * x), np.cos(w * x)])
        pair = rec[1 + 2 * i: 3 + 2 * i]
        c[i] = float(np.mean(_fit_contrast(pair, basis, MTF_AMPLITUDE)))
    return c


def simulate(
    design: Design,
    z: float,
    texture: Texture = "random",
    noise: Mapping[str, float] | None = None,
    seed: int | None = 0,
    *,
    window: int = 256,
    oversample: int = 8,
    mtf: bool = True,
    n_frequencies: int = 48,
    regularization: float | None = None,
    conventional_half: int | None = None,
    n_threads: int | None = None,
    conventional_channel: int | None = None,
    conventional: bool = True,
) -> Simulation:
    """Simulate the plane at depth ``z`` [mm] carrying ``texture`` and reconstruct it with
    known depth from each channel alone, the union of all channels and the conventional
    camera on one channel's array plane (the seed camera: half 1, half 2, the split sensor
    and the conventional camera).

    - ``design``: a :class:`~splitlf.Design` whose channels all have rect grids (a
      :class:`~splitlf.Camera` is one; docs/simulate.md, "Designs"); ``z``: the plane's
      depth [mm], > F
    - ``texture``: ``"random"`` (:class:`RandomAlbedo` on delta(z) cells), a
      :class:`Sinusoid`, :class:`BarChart`, :class:`RandomAlbedo`, :class:`Image`, or a
      callable albedo(X [mm]) (sampled at the centres of the fine cells)
    - ``noise``: None (noise-free) or ``{"photons": N, "read_noise": r}``: N is the mean
      photo-electron count of a pixel of width mu_1 on plane L_1 that collects the full
      aperture (D mu_1 in ray space) from a white (albedo 1) texture with no beam
      splitter; each channel gets its ``share`` of that (a half of the seed camera: half);
      N finite in (0, :data:`MAX_PHOTONS`]; r (>= 0, finite) is the read noise in
      electrons rms
    - ``seed``: seed of NumPy's Generator (random texture, noise), an integer >= 0 or None
      (fresh entropy); same seed, same result
    - ``window``: cells of delta(z) in the central field that are scored (an integer >= 8,
      rounded up to even; the grid extends beyond it by the widest kernel so that every
      used pixel sees only grid cells)
    - ``oversample``: fine cells per delta(z) cell of the rendered texture (>= 1)
    - ``mtf``: run the MTF search (``n_frequencies`` - 1 frequencies k / n_frequencies of
      the Nyquist frequency 1/(2 delta), two phases each; ``n_frequencies`` >= 2)
    - ``regularization``: the weight lambda of the first-difference penalty (finite >= 0);
      None for the default rule (docs/simulate.md)
    - ``conventional_half`` or ``conventional_channel`` (give one, default 1): the
      conventional camera has its sensor on channel c's array plane, pixel pitch mu_c, as
      many pixels as the channel's row
    - ``n_threads``: threads of the core (None: all cores)
    - ``conventional``: also reconstruct the conventional camera (default True); False
      leaves its row out of the result (its render, system matrix and solve are skipped:
      for a design far out of focus it is by far the largest solve; ``conventional_half``
      is then None) and changes nothing else: the grid is still sized for it, so every
      other row is the same bit for bit

    Returns a :class:`Simulation`. Raises ``TypeError`` for arguments of the wrong type,
    :class:`~splitlf.errors.InvalidParameter` (a ``ValueError``) for values out of range
    (all checked before any work, except a texture callable's output and the Poisson mean,
    checked when computed; a hex channel i is named ``channels[i].grid``), ``ImportError``
    without SciPy.
    """
    _scipy()
    subject = _validate.design(design)
    if not isinstance(conventional, bool):
        raise TypeError(f"conventional must be a bool, got {conventional!r}")
    conv_number = _conventional(subject, conventional_half, conventional_channel)
    o = _options(z, texture, noise, seed, window, oversample, mtf, n_frequencies,
                 regularization, conv_number, n_threads)
    core = subject.core
    lf = tuple(f"channel {c}" for c in range(1, len(subject.channels) + 1))
    union, conv = "union", f"conventional {o.conventional_half}"
    sources = {k: f"channel{c}" for c, k in enumerate(lf, 1)}
    sources[conv] = f"conventional{o.conventional_half}"
    _check_rect(subject)
    configs = (*lf, union, conv) if conventional else (*lf, union)
    delta = subject.resolution_step(o.z)  # mu_1 z / L_1 (docs/model.md §9); validates z
    rng = np.random.default_rng(o.seed)
    # The grid is sized for the conventional camera too, with or without its row, so that
    # the textures, noise draws and windows of the other rows do not depend on it.
    grid = _grid(core, o.z, sources, lf, conv, delta, o.window, o.n_threads)
    if not conventional:
        del sources[conv]  # rendered last: the noise draws of the others are unchanged
    win = o.window
    freqs = np.arange(1, o.n_frequencies) / o.n_frequencies * (0.5 / delta)
    fine = _textures(o.texture, grid, o.oversample, freqs, o.mtf, rng)
    coarse = fine.reshape(fine.shape[0], grid.n_big, o.oversample).mean(axis=2)
    truth = coarse[0, grid.w0:grid.w0 + win]
    x = grid.origin + (np.arange(grid.w0, grid.w0 + win) + 0.5) * delta
    images, mats, cells = _image_systems(core, o.z, sources, lf, union, grid, fine,
                                         o.oversample, o.noise, rng, o.n_threads)

    recs: dict[str, np.ndarray] = {}
    lams: dict[str, float] = {}
    contrast: dict[str, np.ndarray] = {}
    for key in configs:
        sol, lams[key] = _solve(mats[key], images[key], o.regularization, o.noise)
        first = grid.w0 - cells[key].start
        rec = sol[:, first:first + win]
        recs[key] = rec[0]
        if o.mtf:
            contrast[key] = _mtf_contrast(rec, x, freqs)

    rmse = {k: float(np.sqrt(np.mean((recs[k] - truth) ** 2))) for k in configs}
    psnr = {k: (float("inf") if v == 0 else float(-20 * np.log10(v))) for k, v in rmse.items()}
    mtf50 = {k: _mtf50(freqs, contrast[k]) for k in configs} if o.mtf else {}
    ro = types.MappingProxyType
    ch1 = subject.channels[0]
    return Simulation(
        z=o.z, delta=delta, x=x, truth=truth,
        rmse=ro(rmse), psnr=ro(psnr), mtf50=ro(mtf50),
        frequencies=freqs if o.mtf else np.empty(0), contrast=ro(contrast),
        nyquist=0.5 / delta,
        microlens_frequency=ch1.L / (ch1.d * o.z),  # one cycle per channel-1 lens pitch
        regularization=ro(lams), pixels=ro({k: int(mats[k].shape[0]) for k in configs}),
        noise=None if o.noise is None else ro(o.noise), seed=o.seed,
        conventional_half=o.conventional_half if conventional else None, configs=configs,
        reconstructions=ro({k: recs[k] for k in configs}),
    )
