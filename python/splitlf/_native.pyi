"""Type stubs of the Rust extension module (rust/py)."""

from typing import final

import numpy as np
import numpy.typing as npt

__all__ = [
    "CameraCore",
    "__version__",
    "coincidence_planes",
    "curves",
    "depth_of_field",
    "figures_of_merit",
    "footprints",
    "kernel_support",
    "new_samples",
    "render",
    "sample_grid",
    "sharp_fractions",
    "system_matrix",
    "trace",
]

__version__: str

_F64 = npt.NDArray[np.float64]
_I64 = npt.NDArray[np.int64]
_Intervals = list[tuple[float, float]]

@final
class CameraCore:
    def __new__(
        cls,
        f_main: float,
        aperture: float,
        v1: float,
        kappa: float,
        d: float,
        v: float,
        mu: float,
        q: int,
        kx: int,
        ky: int,
        f1: float | None = None,
        f2: float | None = None,
    ) -> CameraCore: ...
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

def curves(
    camera: CameraCore, z: _F64, n_threads: int | None = None
) -> tuple[_F64, _F64, _F64, _F64, _F64, _F64]: ...
def depth_of_field(
    camera: CameraCore, threshold_px: float = 0.5
) -> tuple[_Intervals, _Intervals, _Intervals, _Intervals, _Intervals]: ...
def sharp_fractions(
    camera: CameraCore, threshold_px: float, lo: float, hi: float
) -> list[float]: ...
def new_samples(
    camera: CameraCore,
    z: _F64,
    tol: float = 1e-6,
    sample: str = "chief",
    n_threads: int | None = None,
) -> tuple[_I64, _I64, _F64, _I64]: ...
def coincidence_planes(
    camera: CameraCore,
    half_: int,
    max_n: int = 4,
    max_t: int | None = None,
    n_threads: int | None = None,
) -> tuple[_I64, _I64, list[str], _F64, _F64, _F64, _I64, _I64, _I64, _I64]: ...
def figures_of_merit(
    camera: CameraCore,
    z: _F64,
    threshold_px: float = 0.5,
    tol: float = 1e-6,
    n_threads: int | None = None,
) -> list[float]: ...
def trace(
    camera: CameraCore, half: int, axis: str = "x"
) -> tuple[
    _F64,
    npt.NDArray[np.int64],
    _F64,
    _F64,
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    _F64,
    npt.NDArray[np.bool_],
]: ...
def footprints(
    camera: CameraCore,
    z: _F64,
    half: int,
    axis: str = "x",
    sample: str = "centroid",
    kernel: bool = False,
    n_threads: int | None = None,
) -> tuple[_F64, _F64, _F64, _F64 | None, _F64 | None]: ...
def sample_grid(
    camera: CameraCore, z: float, half: int, sample: str = "chief", n_threads: int | None = None
) -> tuple[_F64, _F64]: ...
def kernel_support(
    camera: CameraCore, z: float, source: str, n_threads: int | None = None
) -> float: ...
def system_matrix(
    camera: CameraCore,
    z: float,
    source: str,
    origin: float,
    step: float,
    n_cells: int,
    field_lo: float,
    field_hi: float,
    n_threads: int | None = None,
) -> tuple[_I64, _I64, _F64, _I64, tuple[int, int]]: ...
def render(
    camera: CameraCore,
    z: float,
    source: str,
    origin: float,
    step: float,
    field_lo: float,
    field_hi: float,
    textures: _F64,
    n_threads: int | None = None,
) -> tuple[_F64, _I64]: ...
