"""The sensor noise model shared by the forward models (:func:`splitlf.render`, the 1-D
:func:`splitlf.simulate`) and the inverse ones: Poisson shot noise on the photo-electrons
plus Gaussian read noise (docs/model.md §10), and the seed that draws it."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from . import _validate
from .errors import InvalidParameter

__all__ = ["MAX_PHOTONS", "MAX_POISSON_MEAN", "NOISE_FREE", "add_noise", "options", "seed",
           "stated"]

#: Largest ``photons`` of the noise model (a full-aperture pixel's photo-electrons; real
#: full wells hold ~1e4-1e6): beyond it shot noise is nil at double precision anyway.
MAX_PHOTONS = 1e15
#: Largest mean photo-electron count of one pixel that the Poisson draw accepts (NumPy's
#: generator refuses means near 2**63).
MAX_POISSON_MEAN = 1e18


def options(value: Any) -> dict[str, float] | None:
    """``noise``: None (noise-free) or ``{"photons": N, "read_noise": r}`` with N in
    (0, :data:`MAX_PHOTONS`] and r finite >= 0 (default 0); ``TypeError`` / ``ValueError``
    / :class:`InvalidParameter` otherwise."""
    if value is None:
        return None
    if not isinstance(value, Mapping):
        raise TypeError(f"noise must be None or a dict {{photons, read_noise}}, got {value!r}")
    unknown = set(value) - {"photons", "read_noise"}
    if unknown or "photons" not in value:
        raise ValueError(
            f"invalid noise keys {sorted(value)}: needs photons and optional read_noise"
        )
    photons = _validate.positive(value["photons"], "noise photons", MAX_PHOTONS)
    read = _validate.nonnegative(value.get("read_noise", 0.0), "noise read_noise")
    return {"photons": photons, "read_noise": read}


#: The noise model of a noise-free raw (what :func:`splitlf.render` records without
#: ``noise``): no photon noise (N infinite) and no read noise.
NOISE_FREE: dict[str, float] = {"photons": math.inf, "read_noise": 0.0}


def stated(value: Any, name: str = "noise") -> dict[str, float] | None:
    """A noise model as a :class:`~splitlf.Raw` carries it and :func:`splitlf.reconstruct`
    takes it: None (not stated) or ``{"photons": N, "read_noise": r}`` with N in (0,
    :data:`MAX_PHOTONS`] or ``math.inf`` for a noise-free raw (then r must be 0) and r
    finite >= 0 (default 0); ``TypeError`` / :class:`InvalidParameter` naming ``name``
    otherwise."""
    if value is None:
        return None
    if isinstance(value, Mapping) and "photons" in value:
        n = value["photons"]
        if (isinstance(n, (numbers.Real, np.floating)) and not isinstance(n, bool)
                and n == math.inf):
            unknown = set(value) - {"photons", "read_noise"}
            if unknown:
                raise InvalidParameter.of(name, sorted(value),
                                          "keys photons and optional read_noise")
            r = _validate.nonnegative(value.get("read_noise", 0.0), f"{name} read_noise")
            if r != 0.0:
                raise InvalidParameter.of(f"{name} read_noise", r,
                                          "0 for a noise-free raw (photons = inf)")
            return dict(NOISE_FREE)
    try:
        return options(value)
    except ValueError as e:
        if isinstance(e, InvalidParameter):
            raise
        raise InvalidParameter.of(name, sorted(value), "keys photons and optional "
                                  "read_noise") from None


def add_noise(y: np.ndarray, noise: dict[str, float] | None,
              rng: np.random.Generator) -> np.ndarray:
    """Poisson shot noise on photons * y photo-electrons, Gaussian read noise (electrons
    rms), back in the normalised units of y."""
    if noise is None:
        return y
    n = noise["photons"]
    lam = np.maximum(y, 0.0) * n
    peak = float(lam.max(initial=0.0))
    if peak > MAX_POISSON_MEAN:
        raise InvalidParameter.of(
            "noise photons", n, f"at most {MAX_POISSON_MEAN:g} photo-electrons in the "
            f"brightest pixel (here photons x {peak / n:g}): lower photons or the albedo")
    counts = rng.poisson(lam).astype(np.float64)
    if noise["read_noise"] > 0:
        counts += rng.normal(0.0, noise["read_noise"], size=y.shape)
    return counts / n


def seed(value: Any) -> int | None:
    """``seed``: an integer >= 0, or None (fresh entropy)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"seed must be an integer >= 0 or None, got {value!r}")
    if value < 0:
        raise InvalidParameter.of("seed", int(value), "an integer >= 0 or None")
    return int(value)
