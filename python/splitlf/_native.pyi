"""Type stubs of the Rust extension module (rust/py)."""

from collections.abc import Callable, Sequence
from typing import Any, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "CameraCore",
    "ChiefSampleArrays",
    "CoverageArrays",
    "DEFAULT_MAX_N",
    "DEFAULT_THRESHOLD_PX",
    "DEFAULT_TOL",
    "DEFAULT_WINDOW",
    "DEPTH_DEFAULT_STEP",
    "DEPTH_MAX_CANDIDATES",
    "DEPTH_MAX_WINDOW",
    "PAD_NEAREST",
    "DesignCore",
    "DesignCurvesArrays",
    "DesignDepthOfFieldIntervals",
    "DesignSamplesArrays",
    "FootprintArrays",
    "image_merits",
    "MAX_CELLS",
    "MAX_CHANNELS",
    "MAX_COINCIDENCE_WORK",
    "MAX_COVERAGE_WORK",
    "MAX_K",
    "MAX_M",
    "MAX_PAIRS",
    "MAX_POOLS",
    "MAX_Q",
    "MAX_SAMPLES_PER_AXIS",
    "MAX_THREADS",
    "MAX_TOL_2D",
    "MAX_TYPES",
    "MIN_RENDER_TOL",
    "OUTSIDE_SHARE",
    "PlaneColumns",
    "RENDER_TOL",
    "RenderArrays",
    "RenderScene",
    "SampleGridArrays",
    "Samples2dArrays",
    "SystemMatrixArrays",
    "TraceArrays",
    "__version__",
    "available_memory",
    "cfa_colours",
    "cfa_grey",
    "cfa_mosaic",
    "cell_averages",
    "cell_grid",
    "chief_samples",
    "coverage",
    "design_coincidence_planes",
    "design_curves",
    "design_depth_of_field",
    "design_figures_of_merit",
    "design_footprints",
    "design_kernel_support",
    "design_metrics",
    "design_new_samples",
    "design_render",
    "design_sample_grid",
    "design_sharp_fractions",
    "design_system_matrix",
    "design_trace",
    "pixel_span",
    "reconstruction_factors",
    "reconstruction_system",
    "render",
    "render_band",
    "render_quadrature",
    "render_extent",
    "samples_2d",
    "seen_region",
    "solve_normal",
    "reconstruct",
    "surface_system",
    "estimate_depth",
    "depth_whites",
    "depth_surface",
]

__version__: str
MAX_THREADS: int
MAX_POOLS: int
MAX_Q: int
MAX_K: int
DEFAULT_TOL: float
DEFAULT_THRESHOLD_PX: float
DEFAULT_MAX_N: int
MAX_PAIRS: int
MAX_SAMPLES_PER_AXIS: int
MAX_COINCIDENCE_WORK: int
MAX_CELLS: int
MAX_CHANNELS: int
MAX_TYPES: int
MAX_M: int
DEFAULT_WINDOW: float
MAX_TOL_2D: float
MAX_COVERAGE_WORK: int
RENDER_TOL: float
MIN_RENDER_TOL: float
DEPTH_DEFAULT_STEP: float
DEPTH_MAX_CANDIDATES: int
DEPTH_MAX_WINDOW: int
PAD_NEAREST: float

_F64 = npt.NDArray[np.float64]
_I64 = npt.NDArray[np.int64]
_Bool = npt.NDArray[np.bool_]
_Intervals = list[tuple[float, float]]

@final
class CameraCore:
    def __new__(cls, fields: dict[str, float | int | None]) -> CameraCore: ...
    @staticmethod
    def paper() -> CameraCore: ...
    def fields(
        self,
    ) -> tuple[float, float, float, float, float, float, float, int, int, int, float, float]: ...
    def array_plane(self, half_: int) -> float: ...
    def out_of_focus_depth(self, half_: int) -> float: ...
    def image_radius(self, half_: int) -> float: ...
    def lit_pixels(self, half_: int) -> int: ...
    def ng_focal_length(self, half_: int) -> float: ...
    def rho(self) -> float: ...
    def f_number(self) -> float: ...
    def resolution_step(self, z: float) -> float: ...

@final
class DesignCore:
    def __new__(
        cls, f_main: float, aperture: float, shape: str, channels: list[dict[str, Any]]
    ) -> DesignCore: ...
    @staticmethod
    def from_camera(camera: CameraCore) -> DesignCore: ...
    @staticmethod
    def preset(name: str) -> DesignCore: ...
    @staticmethod
    def presets() -> list[str]: ...
    def out_of_focus_depth(self, channel: int) -> float: ...
    def image_radius(self, channel: int) -> float: ...
    def focus_depths(self, channel: int) -> list[float | None]: ...
    def main_lens(self) -> tuple[float, float, str]: ...
    def channels(self) -> list[dict[str, Any]]: ...
    def micro_image_centers(self, channel: int) -> _F64: ...
    def micro_image_steps(self, channel: int) -> tuple[float, float]: ...
    def resolution_step(self, z: float) -> float: ...

@final
class DesignCurvesArrays:
    @property
    def conjugate(self) -> _F64: ...
    @property
    def main_blur(self) -> _F64: ...
    @property
    def repetitions(self) -> _F64: ...
    @property
    def conventional_px(self) -> _F64: ...
    @property
    def microlens_blur(self) -> _F64: ...
    @property
    def blur_px(self) -> _F64: ...
    @property
    def channel_blur_px(self) -> _F64: ...
    @property
    def union_blur_px(self) -> _F64: ...
    @property
    def rows(self) -> list[tuple[int, int]]: ...

@final
class DesignDepthOfFieldIntervals:
    @property
    def types(self) -> list[_Intervals]: ...
    @property
    def channels(self) -> list[_Intervals]: ...
    @property
    def union(self) -> _Intervals: ...
    @property
    def conventional(self) -> list[_Intervals]: ...
    @property
    def rows(self) -> list[tuple[int, int]]: ...

@final
class DesignSamplesArrays:
    @property
    def distinct(self) -> _I64: ...
    @property
    def max_gap(self) -> _F64: ...
    @property
    def sampled(self) -> _I64: ...

@final
class PlaneColumns:
    @property
    def N(self) -> _I64: ...
    @property
    def T(self) -> _I64: ...
    @property
    def side(self) -> list[str]: ...
    @property
    def conjugate(self) -> _F64: ...
    @property
    def z(self) -> _F64: ...
    @property
    def repetitions(self) -> _F64: ...
    @property
    def new_samples_x(self) -> _I64: ...
    @property
    def new_samples_y(self) -> _I64: ...
    @property
    def new_samples(self) -> _I64: ...
    @property
    def counted(self) -> _I64: ...

@final
class TraceArrays:
    @property
    def vertices(self) -> _F64: ...
    @property
    def n_vertices(self) -> _I64: ...
    @property
    def area(self) -> _F64: ...
    @property
    def centroid(self) -> _F64: ...
    @property
    def lens(self) -> _I64: ...
    @property
    def pixel(self) -> _I64: ...
    @property
    def chief(self) -> _F64: ...
    @property
    def lit(self) -> npt.NDArray[np.bool_]: ...
    @property
    def theta(self) -> _F64: ...
    @property
    def type(self) -> _I64: ...

@final
class FootprintArrays:
    @property
    def position(self) -> _F64: ...
    @property
    def lo(self) -> _F64: ...
    @property
    def hi(self) -> _F64: ...
    @property
    def kernel_breaks(self) -> _F64 | None: ...
    @property
    def kernel_values(self) -> _F64 | None: ...

@final
class SampleGridArrays:
    @property
    def X(self) -> _F64: ...
    @property
    def Y(self) -> _F64: ...

@final
class ChiefSampleArrays:
    @property
    def X(self) -> _F64: ...
    @property
    def Y(self) -> _F64: ...
    @property
    def lit(self) -> _Bool: ...
    @property
    def lens(self) -> _I64: ...
    @property
    def type(self) -> _I64: ...

@final
class Samples2dArrays:
    @property
    def samples(self) -> tuple[_F64, ...]: ...
    @property
    def distinct(self) -> _I64: ...
    @property
    def covering_radius(self) -> _F64: ...
    @property
    def covering_radius_mm(self) -> _F64: ...

@final
class CoverageArrays:
    @property
    def distinct(self) -> _I64: ...
    @property
    def covering_radius(self) -> _F64: ...
    @property
    def covering_radius_mm(self) -> _F64: ...

@final
class SystemMatrixArrays:
    @property
    def indptr(self) -> _I64: ...
    @property
    def indices(self) -> _I64: ...
    @property
    def data(self) -> _F64: ...
    @property
    def pixels(self) -> _I64: ...
    @property
    def shape(self) -> tuple[int, int]: ...

@final
class RenderArrays:
    @property
    def values(self) -> _F64: ...
    @property
    def pixels(self) -> _I64: ...

def design_curves(
    design: DesignCore, z: _F64, n_threads: int | None = None
) -> DesignCurvesArrays: ...
def design_depth_of_field(
    design: DesignCore, threshold_px: float = ...
) -> DesignDepthOfFieldIntervals: ...
def design_new_samples(
    design: DesignCore,
    z: _F64,
    tol: float = ...,
    sample: str = "chief",
    n_threads: int | None = None,
) -> DesignSamplesArrays: ...
def design_coincidence_planes(
    design: DesignCore,
    channel: int,
    max_n: int | None = None,
    max_t: int | None = None,
    n_threads: int | None = None,
) -> PlaneColumns: ...
def design_sharp_fractions(
    design: DesignCore, threshold_px: float, lo: float, hi: float
) -> tuple[list[float], list[float], float, list[float]]: ...
def design_figures_of_merit(
    design: DesignCore,
    z: _F64,
    threshold_px: float = ...,
    tol: float = ...,
    n_threads: int | None = None,
    window: float | None = None,
) -> list[float]: ...
def design_metrics(design: DesignCore, merits_2d: bool = False) -> list[str]: ...
def design_trace(
    design: DesignCore, channel: int, axis: str = "x", n_threads: int | None = None
) -> TraceArrays: ...
def design_footprints(
    design: DesignCore,
    z: _F64,
    channel: int,
    axis: str = "x",
    sample: str = "centroid",
    kernel: bool = False,
    n_threads: int | None = None,
) -> FootprintArrays: ...
def design_sample_grid(
    design: DesignCore, z: float, channel: int, sample: str = "chief", n_threads: int | None = None
) -> SampleGridArrays: ...
def chief_samples(
    design: DesignCore,
    channel: int,
    z: float,
    n_threads: int | None = None,
    rows: tuple[int, int] | None = None,
) -> ChiefSampleArrays: ...
def samples_2d(design: DesignCore, z: float, tol: float, window: float) -> Samples2dArrays: ...
def coverage(
    design: DesignCore,
    z: npt.NDArray[np.float64],
    tol: float,
    window: float,
    n_threads: int | None = None,
) -> CoverageArrays: ...
def design_kernel_support(
    design: DesignCore, z: float, source: str, n_threads: int | None = None
) -> float: ...
def design_system_matrix(
    design: DesignCore,
    z: float,
    source: str,
    grid: tuple[float, float, int],
    field: tuple[float, float],
    n_threads: int | None = None,
) -> SystemMatrixArrays: ...
def design_render(
    design: DesignCore,
    z: float,
    source: str,
    grid: tuple[float, float],
    field: tuple[float, float],
    textures: _F64,
    n_threads: int | None = None,
) -> RenderArrays: ...
@final
class RenderScene:
    def __new__(
        cls,
        texture: str,
        texture_params: Sequence[float],
        texture_image: _F64 | None,
        surface: str,
        surface_params: Sequence[float],
        depth_map: _F64 | None,
        background: float,
    ) -> RenderScene: ...
    @property
    def texture_mean(self) -> float: ...

def render(
    design: DesignCore,
    scene: RenderScene,
    tol: float | tuple[float, float, float] | None = None,
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
    own_lens: bool = False,
    falloff: str | None = None,
) -> list[_F64]: ...
def render_band(
    design: DesignCore,
    scene: RenderScene,
    band: tuple[int, int, int],
    tol: float | tuple[float, float, float] | None = None,
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
    falloff: str | None = None,
) -> _F64: ...
def render_quadrature(
    design: DesignCore,
    scene: RenderScene,
    tol: float | tuple[float, float, float] | None = None,
    n_threads: int | None = None,
) -> list[_F64]: ...
def render_extent(design: DesignCore, z: float) -> tuple[float, float, float, float]: ...
def cfa_colours(pattern: str, rows: int, cols: int) -> npt.NDArray[np.uint8]: ...
def cfa_mosaic(planes: Sequence[_F64], pattern: str, qe: Sequence[float]) -> _F64: ...
def cfa_grey(raw: _F64, pattern: str, qe: Sequence[float]) -> _F64: ...
def available_memory() -> int: ...
OUTSIDE_SHARE: float
def seen_region(
    design: DesignCore, z: float, channels: list[int] | None = None
) -> tuple[float, float, float, float]: ...
def pixel_span(design: DesignCore, z: float, channels: list[int] | None = None) -> float: ...
def cell_grid(
    extent: tuple[float, float, float, float], step: float
) -> tuple[float, float, float, int, int]: ...
def surface_system(
    design: DesignCore,
    scene: RenderScene,
    grid: tuple[float, float, float, int, int],
    channels: list[int] | None = None,
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
    lens_types: list[int] | None = None,
) -> tuple[
    npt.NDArray[np.uint32],
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint32],
    npt.NDArray[np.float64],
]: ...
def reconstruction_system(
    design: DesignCore,
    z: float,
    grid: tuple[float, float, float, int, int],
    channels: list[int] | None = None,
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> tuple[
    npt.NDArray[np.uint32],
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint32],
    _F64,
]: ...
def reconstruction_factors(
    design: DesignCore, z: float, grid: tuple[float, float, float, int, int], channel: int
) -> tuple[
    float,
    npt.NDArray[np.uint8],
    list[tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint32], _F64, _F64]],
    list[tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint32], _F64, _F64]],
]: ...
def cell_averages(scene: RenderScene, grid: tuple[float, float, float, int, int]) -> _F64: ...

_CsrIn = tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint32], _F64, int]

def solve_normal(
    shape: tuple[int, int],
    regularization: float | tuple[float, str, float, int, float],
    blocks: tuple[list[tuple[float, _CsrIn, _CsrIn, _F64, _F64]],
                  list[tuple[_CsrIn, _F64, _F64]]],
    stop: tuple[float, int, float],
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> tuple[_F64, int, float]: ...

def image_merits(
    design: DesignCore,
    z: float,
    request: dict[str, Any],
    edge: RenderScene | None = None,
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> dict[str, Any]: ...

def reconstruct(
    design: DesignCore,
    images: list[_F64],
    surface: tuple[str, list[float], _F64 | None],
    options: dict[str, Any],
    progress: Callable[[str, int, int, list[str]], object] | None = None,
) -> tuple[_F64, tuple[float, float, float, float], float, int, int, float, int, int,
           list[int] | None,
           tuple[float, str, tuple[float, float], bool,
                 list[tuple[float, float, float, float, int]]]]: ...


def estimate_depth(
    design: DesignCore,
    raws: list[npt.NDArray[np.float64]],
    request: dict[str, Any],
    n_threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.int64],
    int,
    npt.NDArray[np.float64] | None,
    tuple[float, float, float, int, int],
]: ...


def depth_whites(
    design: DesignCore, min_own_share: float, n_threads: int | None = None
) -> list[npt.NDArray[np.float64]]: ...
def depth_surface(
    design: DesignCore,
    depth: npt.NDArray[np.float64],
    extent: tuple[float, float, float, float],
    confidence: npt.NDArray[np.float64] | None = None,
    confident: npt.NDArray[np.bool_] | None = None,
) -> tuple[npt.NDArray[np.float64], int, int, float,
           tuple[float, float, float] | None]: ...
