"""splitlf: design and analysis of split-sensor light field cameras.

The physics runs in a Rust core (``splitlf._native``); this package holds the camera
description, presets, presentation and orchestration. Lengths are in millimetres; depths
are positive distances in front of the main lens.
"""

from ._native import __version__
from .camera import Camera
from .optics import Curves, DepthOfField, curves, depth_of_field
from .rayspace import Footprints, SampleGrid, Trace, footprints, sample_grid, trace

__all__ = [
    "Camera",
    "Curves",
    "DepthOfField",
    "Footprints",
    "SampleGrid",
    "Trace",
    "__version__",
    "curves",
    "depth_of_field",
    "footprints",
    "sample_grid",
    "trace",
]
