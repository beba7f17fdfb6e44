"""Figures of splitlf (optional: ``pip install "splitlf[plot]"``).

Matplotlib is imported lazily inside each function; no function selects a backend.
Every function takes ``ax=None`` (a new figure when None) and returns the Axes.
"""

from .rayspace import ray_space

__all__ = ["ray_space"]
