"""The exact route's factored blocks in NumPy and SciPy (the Python pipeline that
splitlf.reconstruct ran before it became one core call, kept for the tests and benches
that check the core's solve against independently assembled blocks)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

import splitlf
from splitlf import _native

NOISE_FLOOR = 1e-3


def sigma(y: np.ndarray, noise: Mapping[str, float] | None, white: np.ndarray
           ) -> tuple[np.ndarray, str]:
    """Per-row noise sigma: Poisson(N v)/N plus read noise r/N (render's model), or the
    floor NOISE_FLOOR x white for noise-free raws; never below the floor."""
    floor = NOISE_FLOOR * white
    if noise is None:
        return floor, f"noise-free: sigma = {NOISE_FLOOR:g} of white"
    n, r = noise["photons"], noise["read_noise"]
    var = np.maximum(y, 0.0) / n + (r / n) ** 2
    return np.maximum(np.sqrt(var), floor), f"photons {n:g}, read noise {r:g}"


def csr_arrays(m: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A SciPy CSR matrix as the core's (indptr, indices, data, number of columns)."""
    return (np.ascontiguousarray(m.indptr, dtype=np.uint64),
            np.ascontiguousarray(m.indices, dtype=np.uint32),
            np.ascontiguousarray(m.data, dtype=np.float64), int(m.shape[1]))


@dataclasses.dataclass
class Part:
    """The pixels of one lens type of one channel that see only the grid: the map's rows
    norm (y row b) ⊗ (x row a), restricted to the raw rows and columns with such pixels."""

    norm: float
    px: Any  # CSR, (raw columns kept, grid columns)
    py: Any  # CSR, (raw rows kept, grid rows from the top)
    mask: np.ndarray  # (rows kept, columns kept): the pixel is a row of the map
    y: np.ndarray  # the raw values at the mask
    white: float  # the channel's share (a fully lit white pixel)

    def seam(self, w: np.ndarray) -> tuple[Any, ...]:
        """The core's factored block (norm, px, py, weights, values) for row weights w."""
        wf, yf = np.zeros(self.mask.shape), np.zeros(self.mask.shape)
        wf[self.mask], yf[self.mask] = w, self.y
        return (self.norm, csr_arrays(self.px), csr_arrays(self.py), wf.ravel(), yf.ravel())


def parts(raw: splitlf.Raw, chans: tuple[int, ...], z: float, grid: tuple,
           kept_types: tuple[int, ...] | None = None) -> list[Part]:
    from scipy import sparse

    design = raw.design
    gnx, gny = grid[3], grid[4]
    shares = [c["share"] for c in design.resolved()]
    parts = []
    for c in chans:
        norm, types, xs, ys = _native.reconstruction_factors(design.core, z, grid, c)
        img = raw.images[c - 1]
        rows, cols = types.shape
        for t, ((xi, xj, xd, tx), (yi, yj, yd, ty)) in enumerate(zip(xs, ys, strict=True)):
            if kept_types is not None and t + 1 not in kept_types:
                continue
            px = sparse.csr_matrix((xd, xj.astype(np.int64), xi.astype(np.int64)),
                                   shape=(cols, gnx))
            py = sparse.csr_matrix((yd, yj.astype(np.int64), yi.astype(np.int64)),
                                   shape=(rows, gny))
            sx = np.asarray(px.sum(axis=1)).ravel()
            sy = np.asarray(py.sum(axis=1)).ravel()
            # Only raw rows and columns whose rays reach the grid can hold rows of the map:
            # the masks below are over those, not over the whole raw.
            rows_in = np.flatnonzero((ty > 0.0) & (sy > 0.0))
            cols_in = np.flatnonzero((tx > 0.0) & (sx > 0.0))
            total = ty[rows_in, None] * tx[None, cols_in]
            inside = sy[rows_in, None] * sx[None, cols_in]
            kept = ((types[np.ix_(rows_in, cols_in)] == t)
                    & (total - inside <= _native.OUTSIDE_SHARE * total))
            r_any, c_any = kept.any(axis=1), kept.any(axis=0)
            if not r_any.any():
                continue
            r_sel, c_sel = rows_in[r_any], cols_in[c_any]
            mask = kept[np.ix_(r_any, c_any)]
            parts.append(Part(norm=norm, px=px[c_sel], py=py[r_sel], mask=mask,
                               y=img[np.ix_(r_sel, c_sel)][mask], white=shares[c - 1]))
    return parts
