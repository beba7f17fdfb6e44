"""splitlf.reconstruct (docs/reconstruct.md): the core's linear map against an independent
NumPy derivation (tests/exact_render.py's per-axis clipping weights), the factored form the
solver uses against the explicit map and against render, and the solve on simple scenes."""

from __future__ import annotations

import numpy as np
import pytest
from exact_render import axis_weights

import splitlf
from splitlf import _native, measure
from splitlf.reconstruction import _parts


def seed_small(kx: int = 10, ky: int = 8) -> splitlf.Design:
    d = splitlf.Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=kx, Ky=ky) for c in d.channels))


def flat(albedo: float) -> splitlf.Image:
    """A uniform albedo over 100 mm (wider than anything these designs see)."""
    return splitlf.Image(np.full((2, 2), albedo), 100.0)


def reference_map(design: splitlf.Design, channel: int, z: float,
                  grid: tuple[float, float, float, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Dense A for one channel (rows: every raw pixel, row-major; columns: grid cells from
    the top row) and the mask of pixels whose rays all land on the grid, from independent
    per-axis clipping weights."""
    x0, y1, h, nx, ny = grid
    chs = design.resolved()
    ch, L1, mu1 = chs[channel - 1], chs[0]["L"], chs[0]["mu"]
    assert len(ch["f"]) == 1
    xe = x0 + h * np.arange(nx + 1)
    ye = (y1 - ny * h) + h * np.arange(ny + 1)
    ix, tx = axis_weights(design.F, design.D, L1, ch, ch["Kx"], ch["f"][0], z, xe)
    iy, ty = axis_weights(design.F, design.D, L1, ch, ch["Ky"], ch["f"][0], z, ye)
    iy = iy[:, ::-1]
    norm = ch["share"] / (mu1 ** 2 * design.D ** 2)
    A = norm * np.einsum("br,ac->barc", iy, ix).reshape(iy.shape[0] * ix.shape[0], ny * nx)
    total = np.outer(ty, tx).ravel()
    inside = np.outer(iy.sum(axis=1), ix.sum(axis=1)).ravel()
    kept = (total > 0) & (inside > 0) & (total - inside <= _native.OUTSIDE_SHARE * total)
    return A, kept


@pytest.mark.parametrize("z", [300.0, 400.0])
def test_core_map_matches_numpy_reference(z: float) -> None:
    design = seed_small(6, 5)
    grid = _native.cell_grid((-2.5, 2.5, -2.0, 2.0), 0.125)
    chan, pix, indptr, indices, data = _native.reconstruction_system(design.core, z, grid)
    n_cells = grid[3] * grid[4]
    for c in (1, 2):
        A, kept = reference_map(design, c, z, grid)
        sel = chan == c - 1
        assert np.array_equal(np.sort(pix[sel]), np.flatnonzero(kept)), c
        rows = np.flatnonzero(sel)
        assert rows.size > 50
        for r in rows:
            dense = np.zeros(n_cells)
            dense[indices[indptr[r]:indptr[r + 1]]] = data[indptr[r]:indptr[r + 1]]
            ref = A[pix[r]]
            assert np.max(np.abs(dense - ref)) <= 1e-12 * max(ref.max(), 1e-300), (c, r)


def test_factored_map_is_the_render() -> None:
    """The solver's factored map times an image texture on the grid equals render's raw at
    every kept pixel, and equals the explicit map's rows."""
    design = seed_small(6, 5)
    z = 400.0
    grid = _native.cell_grid((-2.0, 2.0, -1.6, 1.6), 0.07)  # centred, like the image
    x0, y1, h, nx, ny = grid
    t = np.random.default_rng(1).random((ny, nx))
    tex = splitlf.Image(t, nx * h)
    assert abs(tex.extent[2] - (y1 - ny * h)) < 1e-12 and abs(tex.extent[0] - x0) < 1e-12
    raw = splitlf.render(design, splitlf.Scene(tex, z, background=0.5))
    parts = _parts(raw, (1, 2), z, grid)
    assert len(parts) == 2
    for p in parts:
        assert np.max(np.abs(p.forward(t) - p.y)) <= 1e-12
    chan, pix, indptr, indices, data = _native.reconstruction_system(design.core, z, grid)
    assert sum(int(p.mask.sum()) for p in parts) == len(chan)
    flat_t = t.ravel()
    explicit = np.array([data[indptr[r]:indptr[r + 1]] @ flat_t[indices[indptr[r]:indptr[r + 1]]]
                         for r in range(len(chan))])
    want = np.array([raw.images[int(c)].ravel()[p] for c, p in zip(chan, pix, strict=True)])
    assert np.max(np.abs(explicit - want)) <= 1e-12


def test_constant_albedo_reconstructs_constant() -> None:
    design = seed_small(24, 16)
    for z in (642.0, 1000.0):
        raw = splitlf.render(design, splitlf.Scene(flat(0.6), z))
        rec = splitlf.reconstruct(raw, z, region=(-2.0, 2.0, -1.5, 1.5))
        assert rec.image.shape[0] > 20 and rec.image.shape[1] > 30
        assert np.max(np.abs(rec.image - 0.6)) <= 0.006, (z, rec.image.min(), rec.image.max())
        assert rec.residual <= 1e-5


def test_sinusoid_at_1m_split_sensor_beats_each_half() -> None:
    """At 1 m (neither half's out-of-focus plane) the split sensor's reconstruction of a
    1 cycle/mm sinusoid is closer to the truth than either half's alone."""
    design = seed_small(24, 16)
    tex = splitlf.Sinusoid(1.0, 0.5, 0.4)
    raw = splitlf.render(design, splitlf.Scene(tex, 1000.0))
    region = (-2.0, 2.0, -1.5, 1.5)
    p = {ch: measure.psnr(splitlf.reconstruct(raw, 1000.0, region=region, channels=ch), tex)
         for ch in (None, 1, 2)}
    assert p[None] > max(p[1], p[2]), p


def test_bad_input() -> None:
    design = seed_small(24, 16)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 1000.0))
    region = (-1.0, 1.0, -1.0, 1.0)
    with pytest.raises(splitlf.InvalidParameter, match="step"):
        splitlf.reconstruct(raw, 1000.0, region=region, step=0.0)
    with pytest.raises(splitlf.InvalidParameter, match="depth|z"):
        splitlf.reconstruct(raw, 50.0, region=region)
    with pytest.raises(splitlf.InvalidParameter, match="depth"):
        splitlf.reconstruct(raw, float("nan"), region=region)
    with pytest.raises(splitlf.InvalidParameter, match="depth"):
        splitlf.reconstruct(raw, splitlf.Plane(1000.0, 0.1, 0.0), region=region)
    with pytest.raises(splitlf.InvalidParameter, match="channels"):
        splitlf.reconstruct(raw, 1000.0, region=region, channels=3)
    with pytest.raises(splitlf.InvalidParameter, match="region"):
        splitlf.reconstruct(raw, 1000.0, region=(500.0, 510.0, 0.0, 1.0))
    with pytest.raises(splitlf.InvalidParameter, match="region"):
        splitlf.reconstruct(raw, 1000.0, region=(1.0, -1.0, 0.0, 1.0))
    with pytest.raises(splitlf.InvalidParameter, match="regularization"):
        splitlf.reconstruct(raw, 1000.0, region=region, regularization=-1.0)
    with pytest.raises(TypeError):
        splitlf.reconstruct(raw.images, 1000.0)
    with pytest.raises(splitlf.InvalidParameter, match="region"):
        splitlf.reconstruct(raw, 1000.0)  # the default region: none at 24 x 16 lenses
    r12 = splitlf.Design.preset("raytrix-r12")
    with pytest.raises(splitlf.InvalidParameter, match="design"):
        _native.reconstruction_system(r12.core, 1000.0, _native.cell_grid(region, 0.1))
