"""Figures (matplotlib, the ``plot`` extra). Every function takes ``ax=None`` and returns
the Axes it drew on; none of them selects a matplotlib backend."""

from .curves import blur, repetitions

__all__ = ["FIGURES", "blur", "repetitions"]

#: What ``splitlf figures`` writes: file stem -> function name in this module.
FIGURES = {
    "fig1_blur": "blur",
    "fig5_repetitions": "repetitions",
}
