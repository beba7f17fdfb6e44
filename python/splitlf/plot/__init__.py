"""Figures (matplotlib, the ``plot`` extra). Every function takes ``ax=None`` and returns
the Axes it drew on; none of them selects a matplotlib backend."""

from .curves import blur, repetitions

__all__ = ["blur", "repetitions"]
