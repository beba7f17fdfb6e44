"""splitlf: design and analysis of split-sensor light field cameras.

The physics runs in a Rust core (``splitlf._native``); this package holds the camera
description, presets, presentation and orchestration. Lengths are in millimetres; depths
are positive distances in front of the main lens.
"""

from . import _moved
from ._native import __version__
from .errors import InvalidParameter, SplitlfError, TooLargeError
from .exchange.export import Export, export
from .imaging.render import DepthMap, Plane, Raw, Scene, render
from .imaging.texture import (
    BarChart,
    ColourTexture,
    Constant,
    Image,
    RandomAlbedo,
    SiemensStar,
    Sinusoid,
    SlantedEdge,
)
from .inverse.depth import DepthSweep, estimate_depth
from .inverse.merits import Ensemble, ImageMerits, image_merits
from .inverse.reconstruct import ColourReconstruction, Reconstruction, reconstruct
from .inverse.simulate import Simulation, simulate
from .model.camera import Camera
from .model.design import Channel, Design
from .model.optics import Curves, DepthOfField, curves, depth_of_field, sharp_fractions
from .sampling.rayspace import Footprints, SampleGrid, Trace, footprints, sample_grid, trace
from .sampling.samples import CoincidencePlanes, NewSamples, coincidence_planes, new_samples
from .sampling.samples2d import (
    ChiefSamples,
    Coverage,
    Samples2D,
    chief_samples,
    coverage,
    samples_2d,
)
from .study.merit import Merits, evaluate
from .study.optimise import OptimiseResult, optimise


def explore(design: Design | None = None, *, port: int = 0,
            address: str = "127.0.0.1", reference: Design | None = None) -> object:
    """The interactive design explorer (docs/explore.md) for ``design`` (default: the seed
    preset), with ``reference`` (e.g. the seed beside an optimised design) drawn on the
    same axes. In a Jupyter kernel, serves it in the background and returns the running
    server (``.url``, ``.stop()``), which the notebook shows inline (an IFrame of the
    page); elsewhere starts the server, prints its URL and blocks until Ctrl-C. Binds
    127.0.0.1 by default. Needs the ``explore`` extra (Bokeh), imported on first call."""
    from .explorer import serve

    return serve(design, port=port, address=address, reference=reference,
                 threaded=_in_jupyter_kernel())


def _in_jupyter_kernel() -> bool:
    """Whether this runs in a Jupyter (IPython) kernel, without importing IPython."""
    import sys

    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell is not None and hasattr(shell, "kernel")


__all__ = [
    "BarChart",
    "Camera",
    "Channel",
    "ChiefSamples",
    "ColourReconstruction",
    "ColourTexture",
    "CoincidencePlanes",
    "Constant",
    "Coverage",
    "Curves",
    "DepthMap",
    "DepthOfField",
    "DepthSweep",
    "Design",
    "Ensemble",
    "Export",
    "Footprints",
    "Image",
    "ImageMerits",
    "InvalidParameter",
    "Merits",
    "NewSamples",
    "OptimiseResult",
    "Plane",
    "RandomAlbedo",
    "Raw",
    "SampleGrid",
    "Samples2D",
    "Scene",
    "SiemensStar",
    "Simulation",
    "Sinusoid",
    "SlantedEdge",
    "SplitlfError",
    "TooLargeError",
    "Trace",
    "__version__",
    "chief_samples",
    "coincidence_planes",
    "coverage",
    "curves",
    "depth_of_field",
    "estimate_depth",
    "evaluate",
    "explore",
    "export",
    "footprints",
    "image_merits",
    "new_samples",
    "optimise",
    "render",
    "reconstruct",
    "Reconstruction",
    "measure",
    "sample_grid",
    "samples_2d",
    "sharp_fractions",
    "simulate",
    "trace",
]

#: Submodules whose optional dependencies (matplotlib, xarray, pandas, scipy, dask) are imported
#: only on first use: ``splitlf.plot.blur(...)`` and ``splitlf.sweep.sweep(...)`` work
#: after a plain ``import splitlf``, which itself imports neither.
_LAZY_SUBMODULES = ("cli", "compare", "plot", "report", "sweep")

_moved.install()
from .inverse import measure  # noqa: E402  (after the finder: splitlf.measure is its alias)


def __getattr__(name: str) -> object:
    if name in _LAZY_SUBMODULES or _moved.target(name) is not None:
        from importlib import import_module

        new = _moved.target(name)
        module = import_module(new if new is not None else f".{name}", __name__)
        if name in _LAZY_SUBMODULES:
            globals()[name] = module
        return module
    raise AttributeError(f"module 'splitlf' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY_SUBMODULES])
