"""Figures (matplotlib, optional: ``pip install "splitlf[plot]"``). matplotlib is imported
only when a figure is drawn; this package never selects a backend."""

from .samples import samples

__all__ = ["samples"]
