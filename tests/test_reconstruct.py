"""splitlf.reconstruct (docs/reconstruct.md): the core's linear map against an independent
NumPy derivation (tests/exact_render.py's per-axis clipping weights), the factored form the
solver uses against the explicit map and against render, and the solve on simple scenes."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from exact_render import axis_weights
from factored_parts import parts as _parts

import splitlf
from splitlf import _native, measure


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
        forward = p.norm * (p.px @ (p.py @ t).T).T[p.mask]
        assert np.max(np.abs(forward - p.y)) <= 1e-12
    chan, pix, indptr, indices, data = _native.reconstruction_system(design.core, z, grid)
    assert sum(int(p.mask.sum()) for p in parts) == len(chan)
    flat_t = t.ravel()
    explicit = np.array([data[indptr[r]:indptr[r + 1]] @ flat_t[indices[indptr[r]:indptr[r + 1]]]
                         for r in range(len(chan))])
    want = np.array([raw.images[int(c)].ravel()[p] for c, p in zip(chan, pix, strict=True)])
    assert np.max(np.abs(explicit - want)) <= 1e-12


def _dense_solution(design: splitlf.Design, z: float, grid: tuple, raw: splitlf.Raw,
                    lam: float) -> np.ndarray:
    """The regularised least squares solved directly: A from the independent reference map
    (every kept pixel of both halves), W = 1/sigma^2 of render's photon noise (N = 2000),
    D the differences between neighbour cells as dense matrices."""
    nx, ny = grid[3], grid[4]
    rows, ys, whites = [], [], []
    for c in (1, 2):
        A, kept = reference_map(design, c, z, grid)
        rows.append(A[kept])
        ys.append(raw.images[c - 1].ravel()[kept])
        whites.append(np.full(int(kept.sum()), design.resolved()[c - 1]["share"]))
    A, y, white = np.vstack(rows), np.concatenate(ys), np.concatenate(whites)
    w = 1.0 / np.maximum(np.sqrt(np.maximum(y, 0.0) / 2000.0), 1e-3 * white) ** 2

    def diff(n: int) -> np.ndarray:
        return np.eye(n)[1:] - np.eye(n)[:-1]

    D = np.vstack([np.kron(np.eye(ny), diff(nx)), np.kron(diff(ny), np.eye(nx))])
    H = A.T @ (w[:, None] * A) + lam * D.T @ D
    return np.linalg.solve(H, A.T @ (w * y)).reshape(ny, nx)


def test_core_solve_is_the_direct_solution() -> None:
    """The core's matrix-free conjugate gradients (factored blocks, and the same rows given
    explicitly) reach the direct solution of the same least squares, and do not depend on
    the thread count."""
    design = seed_small(6, 5)
    z = 400.0
    grid = _native.cell_grid((-1.2, 1.2, -1.0, 1.0), 0.07)
    nx, ny = grid[3], grid[4]
    noise = {"photons": 2000.0, "read_noise": 0.0}
    raw = splitlf.render(design, splitlf.Scene(splitlf.RandomAlbedo(0.3), z), noise=noise,
                         seed=4)
    lam = 0.5
    want = _dense_solution(design, z, grid, raw, lam)
    parts = _parts(raw, (1, 2), z, grid)
    sig = [np.maximum(np.sqrt(np.maximum(p.y, 0.0) / 2000.0), 1e-3 * p.white) for p in parts]
    factored = [p.seam(1.0 / s ** 2) for p, s in zip(parts, sig, strict=True)]
    chan, pix, indptr, indices, data = _native.reconstruction_system(design.core, z, grid)
    y = np.array([raw.images[int(c)].ravel()[q] for c, q in zip(chan, pix, strict=True)])
    white = np.array([design.resolved()[int(c)]["share"] for c in chan])
    w = 1.0 / np.maximum(np.sqrt(np.maximum(y, 0.0) / 2000.0), 1e-3 * white) ** 2
    explicit = [((indptr, indices, data, nx * ny), w, y)]
    scale = float(np.max(np.abs(want)))
    for blocks in ((factored, []), ([], explicit)):
        got, its, resid = _native.solve_normal((ny, nx), lam, blocks, (1e-13, 20_000, 0.0))
        assert 0 < its < 20_000 and resid <= 1e-12
        assert np.max(np.abs(got - want)) <= 1e-8 * scale, np.max(np.abs(got - want))
        one, its1, _ = _native.solve_normal((ny, nx), lam, blocks, (1e-13, 20_000, 0.0),
                                          n_threads=1)
        assert its1 == its and np.array_equal(one, got)


def test_solve_refuses_bad_blocks() -> None:
    """The core's solve names the field of an inconsistent block (never a panic)."""
    ptr = np.array([0, 1, 2], dtype=np.uint64)
    idx = np.array([0, 1], dtype=np.uint32)
    val = np.array([1.0, 0.5])
    one = np.ones(4)
    good = (2.0, (ptr, idx, val, 2), (ptr, idx, val, 2), one, one)
    got, _, _ = _native.solve_normal((2, 2), 1.0, ([good], []), (1e-10, 100, 0.0))
    assert got.shape == (2, 2) and np.all(np.isfinite(got))
    bad_cases = {
        "px": (2.0, (ptr, np.array([0, 5], dtype=np.uint32), val, 2), good[2], one, one),
        "py": (2.0, good[1], (ptr[::-1].copy(), idx, val, 2), one, one),
        "weights": (2.0, good[1], good[2], -one, one),
        "values": (2.0, good[1], good[2], one, np.full(4, np.nan)),
        "factors": (2.0, good[1], (ptr, idx, val, 3), one, one),
    }
    for field, block in bad_cases.items():
        with pytest.raises(splitlf.errors.InvalidParameter, match=field):
            _native.solve_normal((2, 2), 1.0, ([block], []), (1e-10, 100, 0.0))
    with pytest.raises(splitlf.errors.InvalidParameter, match="weights"):
        _native.solve_normal((2, 2), 1.0, ([], [((ptr, idx, val, 4), one, one[:2])]),
                             (1e-10, 100, 0.0))
    with pytest.raises(splitlf.errors.InvalidParameter, match="regularization"):
        _native.solve_normal((2, 2), 0.0, ([good], []), (1e-10, 100, 0.0))
    with pytest.raises(splitlf.errors.InvalidParameter, match="rtol"):
        _native.solve_normal((2, 2), 1.0, ([good], []), (float("nan"), 100, 0.0))
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(splitlf.errors.InvalidParameter, match="noise_tol"):
            _native.solve_normal((2, 2), 1.0, ([good], []), (1e-10, 100, bad))


def test_constant_albedo_reconstructs_constant() -> None:
    design = seed_small(24, 16)
    for z in (642.0, 1000.0):
        raw = splitlf.render(design, splitlf.Scene(flat(0.6), z))
        rec = splitlf.reconstruct(raw, z, region=(-2.0, 2.0, -1.5, 1.5))
        assert rec.image.shape[0] > 20 and rec.image.shape[1] > 30
        assert np.max(np.abs(rec.image - 0.6)) <= 0.006, (z, rec.image.min(), rec.image.max())
        assert rec.residual <= 1e-5


@pytest.fixture(scope="module")
def sinusoid_psnr() -> dict[tuple[float, int | None], float]:
    """PSNR of noise-free reconstructions of a 1 cycle/mm sinusoid (24 x 16 lenses, a
    4 x 3 mm region) at 642 mm (half 1's out-of-focus plane) and 1 m, from the split
    sensor (None) and from each half alone."""
    design = seed_small(24, 16)
    tex = splitlf.Sinusoid(1.0, 0.5, 0.4)
    out = {}
    for z in (642.0, 1000.0):
        raw = splitlf.render(design, splitlf.Scene(tex, z))
        for ch in (None, 1, 2):
            rec = splitlf.reconstruct(raw, z, region=(-2.0, 2.0, -1.5, 1.5), channels=ch)
            out[z, ch] = measure.psnr(rec, tex)
    return out


@pytest.mark.parametrize("z", [642.0, 1000.0])
def test_more_data_never_hurts(sinusoid_psnr: dict, z: float) -> None:
    """Noise-free, the split sensor's reconstruction is at least as close to the truth as
    the better half's alone (measured: 31.4 dB against 26.4 at 642 mm, 34.1 against 24.4
    at 1 m)."""
    p = sinusoid_psnr
    assert p[z, None] >= max(p[z, 1], p[z, 2]), p


def test_the_band(sinusoid_psnr: dict) -> None:
    """Half 1 alone loses the sinusoid at its out-of-focus plane (642 mm; measured 11 dB
    against 24 dB at 1 m); the split sensor keeps it (31 dB against 34 dB)."""
    p = sinusoid_psnr
    assert p[642.0, 1] < p[1000.0, 1] - 10.0, p
    assert p[642.0, None] > p[1000.0, None] - 6.0, p
    assert p[642.0, None] > 25.0, p


def test_reconstruct_a_monte_carlo_raw() -> None:
    """Against the inverse crime: the raw comes from the independent Monte-Carlo renderer
    (tests/mc_render.py, rays sampled per docs/model.md section 10, a continuous sinusoid
    that no grid of cells represents exactly), then photon noise (N = 2000); the
    reconstruction from it is as good as from render's raw with the same noise, and
    recovers the sinusoid well beyond the flat mean."""
    from mc_render import mc_pixels, scene

    design = seed_small(6, 6)
    only = design.replace(channels=(design.channels[0],))
    z, freq = 1000.0, 0.5
    tex = splitlf.Sinusoid(freq, 0.5, 0.4)
    shape = only.resolved()[0]["Ky"] * 15, only.resolved()[0]["Kx"] * 15
    pixels = [(r, c) for r in range(shape[0]) for c in range(shape[1])]
    mc_scene = scene(("sinusoid", [freq, 0.5, 0.4, 0.0]), ("plane", [z, 0.0, 0.0]), 0.5)
    mean, se = mc_pixels(only, 1, pixels, mc_scene, n_rays=4000, n_batches=4,
                         rng=np.random.default_rng(7))
    rng = np.random.default_rng(8)
    noise = {"photons": 2000.0, "read_noise": 0.0}

    def noisy(v: np.ndarray) -> np.ndarray:
        return rng.poisson(np.maximum(v, 0.0) * 2000.0) / 2000.0

    mc_raw = splitlf.Raw(only, (noisy(mean.reshape(shape)),))
    ref = splitlf.render(only, splitlf.Scene(tex, z))
    ref_raw = splitlf.Raw(only, (noisy(np.asarray(ref.images[0])),))
    region = (-1.0, 1.0, -1.0, 1.0)
    # The same fixed lambda for both raws (the comparison is of the data; the data-chosen
    # weight under-smooths this small problem, 900 rows: lambda 0.58, 15.6 dB, against
    # the best fixed weight's 19.9 dB near 3; docs/reconstruct.md).
    kw: dict[str, Any] = {"region": region, "noise": noise, "regularization": 4.0}
    p_mc = measure.psnr(splitlf.reconstruct(mc_raw, z, **kw), tex)
    p_ref = measure.psnr(splitlf.reconstruct(ref_raw, z, **kw), tex)
    assert float(np.median(se)) < 0.5 * np.sqrt(0.25 / 2000.0)  # MC error below the noise
    # Measured 19.5 dB (render's raw: 18.6); the flat mean image scores 11 dB (half 1 at
    # 1 m spreads a pixel over 2.2 mm, so a 2 mm period is deconvolved from noise).
    assert p_mc > 16.0, (p_mc, p_ref)
    assert abs(p_mc - p_ref) < 1.5, (p_mc, p_ref)


def test_bad_input() -> None:
    design = seed_small(24, 16)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 1000.0))
    region = (-1.0, 1.0, -1.0, 1.0)
    with pytest.raises(splitlf.InvalidParameter, match="step"):
        splitlf.reconstruct(raw, 1000.0, region=region, step=0.0)
    # A plane nearer than F: the core's depth check, its error naming reconstruct's own
    # parameter (the label the binding gives the core call), index 0 of the one depth.
    with pytest.raises(splitlf.InvalidParameter, match=r"invalid depth depth\[0\] = 50: "
                       rf"depths must be > F = {design.F:g} mm") as info:
        splitlf.reconstruct(raw, 50.0, region=region)
    assert (info.value.name, info.value.index, info.value.value) == ("depth", 0, 50.0)
    with pytest.raises(splitlf.InvalidParameter, match="depth"):
        splitlf.reconstruct(raw, float("nan"), region=region)
    with pytest.raises(splitlf.InvalidParameter, match="depth"):
        splitlf.reconstruct(raw, splitlf.Plane(100.0, 0.0, 40.0), region=region)  # 60 mm
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


def test_mtf50_of_a_gaussian_edge() -> None:
    """measure.mtf50 on an image of a slanted edge blurred by a Gaussian of sigma (sampled
    at the cell centres) gives the Gaussian's MTF50, sqrt(ln 2 / 2) / (pi sigma), within 3 %;
    and psnr/ssim of the truth against itself are infinite and 1."""
    from math import erf, log, pi, sqrt

    h, n, sigma = 0.05, 160, 0.2
    edge = splitlf.SlantedEdge(5.0, 0.2, 0.8)
    xs = -n * h / 2 + (np.arange(n) + 0.5) * h
    X, Y = np.meshgrid(xs, -xs)
    a = np.radians(edge.angle)
    dist = X * np.cos(a) - Y * np.sin(a)
    image = 0.2 + 0.6 * 0.5 * (1 + np.vectorize(erf)(dist / (sigma * sqrt(2))))
    rec = splitlf.Reconstruction(image=image, extent=(xs[0] - h / 2, xs[-1] + h / 2,
                                                      xs[0] - h / 2, xs[-1] + h / 2),
                                 step=h, design=seed_small(), depth=1000.0, channels=(1,),
                                 rows=0, iterations=0, residual=0.0, regularization=1.0,
                                 noise="")
    want = sqrt(log(2) / 2) / (pi * sigma)
    got = measure.mtf50(rec, edge)
    assert abs(got - want) <= 0.03 * want, (got, want)
    assert measure.ssim(rec, image) == pytest.approx(1.0)
    assert np.isinf(measure.psnr(rec, image))


def _csr(system: tuple, n_cells: int) -> tuple[np.ndarray, np.ndarray, Any]:
    from scipy import sparse

    chan, pix, indptr, indices, data = system
    return chan, pix, sparse.csr_matrix(
        (data, indices.astype(np.int64), indptr.astype(np.int64)), shape=(len(chan), n_cells))


def _surface_scene(surface: splitlf.Plane | splitlf.DepthMap) -> Any:
    return _native.RenderScene("constant", [0.0], None, *surface.seam(), 0.0)


@pytest.mark.parametrize(("z", "step"), [(300.0, 0.125), (642.0, 0.125), (1000.0, 0.125),
                                         (400.0, 0.07)])
def test_general_map_is_the_exact_map_on_a_fronto_plane(z: float, step: float) -> None:
    """The general route in record mode (any surface, any design: on a plane, each pixel's
    footprint density integrated over the cells, rust/core/src/imaging/render/footprint.rs)
    against the
    exact route's map on a fronto-parallel plane: the same rows, and per row an L1
    difference (the worst error over every albedo in [0, 1]) within 1e-4 of white
    (measured 2.2e-5, 6.7e-10, 1.6e-5 and 1.7e-5; the route's error target is 1e-4 of a
    row's sum; at 642 mm the pixels' footprints have sharp edges, on node lines of their
    own; the earlier rule on the render's outer integral was exact where every grid line's
    kink was cut and 5.0e-3 at 0.07 mm cells)."""
    design = seed_small(6, 5)
    grid = _native.cell_grid((-2.5, 2.5, -2.0, 2.0), step)
    n = grid[3] * grid[4]
    c1, p1, A1 = _csr(_native.reconstruction_system(design.core, z, grid), n)
    c2, p2, A2 = _csr(_native.surface_system(design.core, _surface_scene(splitlf.Plane(z)),
                                             grid), n)
    assert len(c1) > 200
    assert np.array_equal(c1, c2) and np.array_equal(p1, p2)
    white = float(A1.sum(axis=1).max())
    assert float(abs(A1 - A2).sum(axis=1).max()) <= 1e-4 * white


def _map_against_render(design: splitlf.Design, surface: Any, region: tuple, step: float,
                        tol: float) -> tuple[float, int]:
    """max |A t - render(t)| / white over the map's rows, t a random image on the grid."""
    grid = _native.cell_grid(region, step)
    x0, y1, h, nx, ny = grid
    chan, pix, A = _csr(_native.surface_system(design.core, _surface_scene(surface), grid),
                        nx * ny)
    t = np.random.default_rng(3).random((ny, nx))
    raw = splitlf.render(design, splitlf.Scene(splitlf.Image(t, nx * h), surface,
                                               background=0.5), tol=tol)
    want = np.array([raw.images[int(c)].ravel()[int(p)] for c, p in zip(chan, pix, strict=True)])
    white = float(A.sum(axis=1).max())
    return float(np.max(np.abs(A @ t.ravel() - want))) / white, len(chan)


def test_general_map_is_the_render_on_a_slanted_plane() -> None:
    """A t equals render's raw of the image t on a plane tilted 25 mm per mm in Y (from
    550 to 650 mm over the grid): within 1e-3 of white (render's own target is tol = 2e-4;
    measured 2.9e-4 on a 6 x 5-lens seed)."""
    err, rows = _map_against_render(seed_small(3, 3), splitlf.Plane(600.0, 0.0, 25.0),
                                    (-1.2, 1.2, -1.0, 1.0), 0.07, 2e-4)
    assert rows > 20
    assert err <= 1e-3, err


@pytest.mark.parametrize(("gx", "gy"), [(0.6, 20.0), (-20.0, 1.0), (8.0, 20.0), (12.0, 12.0)])
def test_tilted_map_in_both_axes_is_the_render(gx: float, gy: float) -> None:
    """A plane tilted along both axes on the tilted route (docs/reconstruct.md step 5):
    gently along the other axis (0.6 beside 20 mm per mm, 1 beside -20: the pixels wide
    along it cut into a few parts), or steeply (8 beside 20, 12 beside 12: into up to
    16 x 16), about 600 mm over the grid: A t equals render's raw of the image t (render's
    general route, tol 2e-4) within 4e-4 of white (measured 1.4e-4, 2.1e-4, 7.2e-5 and
    1.5e-4; 8.4e-5 for the first plane without its X tilt; 5.5e-4 and 1.0e-3 for the
    first two with every pixel within 1e-3 cut whole; 8.4e-3 for the third with every
    pixel cut whole)."""
    err, rows = _map_against_render(seed_small(3, 3), splitlf.Plane(600.0, gx, gy),
                                    (-1.2, 1.2, -1.0, 1.0), 0.07, 2e-4)
    assert rows > 300
    assert err <= 4e-4, err


@pytest.mark.parametrize("gx, gy, region, step",
                         [(0.0, 25.0, (-1.2, 1.2, -1.0, 1.0), 0.07),
                          (0.0, -15.0, (-1.0, 1.0, -1.5, 1.5), 0.05),
                          (25.0, 0.0, (-1.0, 1.0, -1.2, 1.2), 0.07),
                          (-15.0, 0.0, (-1.5, 1.5, -1.0, 1.0), 0.05)])
def test_tilted_map_is_the_render(gx: float, gy: float, region: tuple, step: float) -> None:
    """A plane tilted along one axis (about X: gx = 0; about Y: gy = 0) on the exact
    route's designs takes the tilted route (exact areas between the tilted axis's edges,
    the other axis's areas per thin depth slab): A t equals render's raw of the image t
    (render's general route, tol 2e-4) within 3e-4 of white (measured 6.7e-5 and 8.4e-5
    tilted about X, 5.4e-5 and 8.1e-5 about Y). The map against the general route's own
    map, row by row, is `system::tests::tilted_route_is_the_general_route` in the core
    (a tilt of 1e-13 along the other axis no longer sends a plane down the general route:
    the tilted route takes gentle tilts along both axes)."""
    err, rows = _map_against_render(seed_small(3, 3), splitlf.Plane(600.0, gx, gy), region,
                                    step, 2e-4)
    assert rows > 300
    assert err <= 3e-4, err


def test_general_map_is_the_render_on_hex_and_circle() -> None:
    """A hexagonal array on a sensor layout behind a circular aperture (lytro-illum cut
    to 12 x 10 lenses) at 300 mm: A t against render's raw of the image t (tol 2e-4),
    99 % of rows within 1e-3 of white (measured 8e-4; 1.4e-4 against tol 2e-5); and at the
    two rows farthest from render the independent Monte-Carlo renderer (tests/mc_render.py)
    sides with the map (measured: within 1 standard error, render off by 1e-3)."""
    from mc_render import mc_pixels, scene

    d = splitlf.Design.preset("lytro-illum")
    small = d.replace(channels=(d.channels[0].replace(Kx=12, Ky=10, Mx=None, My=None),))
    surface = splitlf.Plane(300.0)
    grid = _native.cell_grid((-2.5, 2.5, -2.0, 2.0), 2.0 * small.resolution_step(300.0))
    x0, y1, h, nx, ny = grid
    chan, pix, A = _csr(_native.surface_system(small.core, _surface_scene(surface), grid),
                        nx * ny)
    assert len(chan) > 1000
    t = np.random.default_rng(3).random((ny, nx))
    tex = splitlf.Image(t, nx * h)
    raw = splitlf.render(small, splitlf.Scene(tex, surface, background=0.5), tol=2e-4)
    want = raw.images[0].ravel()[pix.astype(np.int64)]
    got = A @ t.ravel()
    white = float(A.sum(axis=1).max())
    err = np.abs(got - want) / white
    assert np.percentile(err, 99) <= 1e-3, np.percentile(err, 99)
    worst = np.argsort(err)[-2:]
    cols = raw.images[0].shape[1]
    pixels = [divmod(int(pix[i]), cols) for i in worst]
    sc = scene(("image", list(tex.extent), t), ("plane", [300.0, 0.0, 0.0]), 0.5)
    mc, se = mc_pixels(small, 1, pixels, sc, n_rays=200_000, n_batches=10,
                       rng=np.random.default_rng(5))
    for i, k in enumerate(worst):
        assert abs(got[k] - mc[i]) <= 4.0 * se[i] + 2e-4 * white, (got[k], want[k], mc[i], se[i])


def _sampled_map(f: Any, n: int, ext: tuple) -> splitlf.DepthMap:
    """f sampled at the centres of n x n cells over ext (row 0 at the top)."""
    xs = ext[0] + (np.arange(n) + 0.5) * (ext[1] - ext[0]) / n
    ys = ext[3] - (np.arange(n) + 0.5) * (ext[3] - ext[2]) / n
    return splitlf.DepthMap(f(xs[None, :], ys[:, None]), ext)


def test_depth_map_of_a_plane_is_the_plane() -> None:
    """A depth map sampled from a tilted plane (bilinear: the plane itself inside its
    outer samples) that every ray meets once goes the plane's way, the footprint density
    (rust/core/src/imaging/render/footprint.rs, with the map's local gradient in the ray map's
    Jacobian): behind a circular aperture both take the general route, and the maps agree
    row for row within 1e-4 of white (L1 per row; measured 3.3e-5 over 218 rows, the same
    rows; the map's lattice also has node lines on its sample lines)."""
    design = seed_small(12, 12).replace(aperture="circle")
    z0, gx, gy = 800.0, 0.3, 2.0
    dm = _sampled_map(lambda x, y: z0 + gx * x + gy * y, 33, (-8.0, 8.0, -8.0, 8.0))
    # One corner sample, far from the grid, 1e-6 off the plane: the map is not a plane
    # (which would take the plane's own route, test_planar_map_takes_the_planes_route),
    # and on the grid it is the plane.
    z = dm.depth.copy()
    z[0, 0] *= 1.0 + 1e-6
    dm = splitlf.DepthMap(z, dm.extent)
    grid = _native.cell_grid((-1.5, 1.5, -1.2, 1.2), design.resolution_step(z0))
    n = grid[3] * grid[4]
    c1, p1, A1 = _csr(_native.surface_system(
        design.core, _surface_scene(splitlf.Plane(z0, gx, gy)), grid), n)
    c2, p2, A2 = _csr(_native.surface_system(design.core, _surface_scene(dm), grid), n)
    assert len(c1) > 200
    assert np.array_equal(c1, c2) and np.array_equal(p1, p2)
    white = float(A1.sum(axis=1).max())
    assert float(abs(A1 - A2).sum(axis=1).max()) <= 1e-4 * white


def test_planar_map_takes_the_planes_route() -> None:
    """A depth map whose samples are a plane (an estimate fitted into one, docs/depth.md)
    is that plane between its outer sample centres (bilinear interpolation of a plane):
    over a grid inside them its map is the plane's own, on the tilted route, to rounding;
    a grid reaching past them (where the map is constant, not the plane) keeps the map's
    footprint route, whose rows differ from the plane's there."""
    design = seed_small(12, 12)
    z0, gx, gy = 800.0, 0.3, 2.0
    plane = _surface_scene(splitlf.Plane(z0, gx, gy))
    grid = _native.cell_grid((-1.5, 1.5, -1.2, 1.2), design.resolution_step(z0))
    n = grid[3] * grid[4]
    c1, p1, A1 = _csr(_native.surface_system(design.core, plane, grid), n)
    assert len(c1) > 200
    white = float(A1.sum(axis=1).max())
    # Outer centres at +-7.75 mm (33 cells over 16 mm, the grid inside them), then at
    # +-1.2 and +-0.975 mm (4 cells over 3.2 by 2.6 mm: the grid reaches past them).
    for cells, ext, same in [(33, (-8.0, 8.0, -8.0, 8.0), True),
                             (4, (-1.6, 1.6, -1.3, 1.3), False)]:
        dm = _sampled_map(lambda x, y: z0 + gx * x + gy * y, cells, ext)
        c2, p2, A2 = _csr(_native.surface_system(design.core, _surface_scene(dm), grid), n)
        if same:
            assert np.array_equal(c1, c2) and np.array_equal(p1, p2)
            assert float(abs(A1 - A2).sum(axis=1).max()) <= 1e-12 * white
        else:
            assert len(c2) > 0
            assert len(c1) != len(c2) or float(abs(A1 - A2).sum()) > 1e-9 * white


def test_depth_map_seen_once_against_monte_carlo() -> None:
    """The map on a curved depth map (a bowl on a slope, 298-317 mm over its extent) that
    every ray meets once (the footprint route with the map's local gradient, docs/
    reconstruct.md step 6): A t for an image t against the independent Monte-Carlo
    renderer (tests/mc_render.py) at 8 rows of each half, each within 4 standard errors
    plus 2e-4 of white (measured: within 2.4 standard errors, 9.7e-4 of white, the
    standard errors 3.6e-4 to 4.3e-4 of white at 400,000 rays)."""
    from mc_render import mc_pixels, scene

    from splitlf.imaging.render import _expected_shapes

    design = seed_small(6, 6)
    ext = (-3.0, 3.0, -3.0, 3.0)
    dm = _sampled_map(lambda x, y: 300.0 + 2.0 * y + 0.8 * x * x + 0.5 * y * y, 25, ext)
    grid = _native.cell_grid((-1.5, 1.5, -1.5, 1.5), 0.1)
    x0, y1, h, nx, ny = grid
    chan, pix, A = _csr(_native.surface_system(design.core, _surface_scene(dm), grid),
                        nx * ny)
    t = np.random.default_rng(4).random((ny, nx))
    got = A @ t.ravel()
    white = float(A.sum(axis=1).max())
    sc = scene(("image", [x0, x0 + nx * h, y1 - ny * h, y1], t),
               ("depthmap", list(ext), np.asarray(dm.depth)), 0.5)
    rng = np.random.default_rng(8)
    for ch in (1, 2):
        mine = np.flatnonzero(chan == ch - 1)
        assert len(mine) > 150, (ch, len(mine))
        rows = rng.choice(mine, 8, replace=False)
        cols = _expected_shapes(design)[ch - 1][1]
        pixels = [divmod(int(pix[i]), cols) for i in rows]
        mc, se = mc_pixels(design, ch, pixels, sc, n_rays=400_000, n_batches=10,
                           rng=np.random.default_rng(ch))
        for k, i in enumerate(rows):
            assert abs(got[i] - mc[k]) <= 4.0 * se[k] + 2e-4 * white, (ch, pixels[k], got[i],
                                                                      mc[k], se[k])


@pytest.mark.parametrize("gx, gy", [(0.0, 10.0), (10.0, 0.0), (0.5, 10.0)])
def test_reconstruct_a_monte_carlo_raw_of_a_slanted_plane(gx: float, gy: float) -> None:
    """The inverse crime avoided on the tilted route: a plane tilted 10 mm per mm in Y
    (about the X axis), in X (about the Y axis), or in Y and gently in X (0.5 mm per mm),
    from about 990 to 1010 mm over the region,
    the raw from the independent Monte-Carlo renderer (a continuous sinusoid no cell grid
    represents) with photon noise N = 2000, reconstructed with the known plane; it
    recovers the sinusoid well beyond the flat mean."""
    from mc_render import mc_pixels, scene

    design = seed_small(6, 6)
    only = design.replace(channels=(design.channels[0],))
    plane, freq = splitlf.Plane(1000.0, gx, gy), 0.5
    tex = splitlf.Sinusoid(freq, 0.5, 0.4)
    shape = only.resolved()[0]["Ky"] * 15, only.resolved()[0]["Kx"] * 15
    pixels = [(r, c) for r in range(shape[0]) for c in range(shape[1])]
    mc_scene = scene(("sinusoid", [freq, 0.5, 0.4, 0.0]), ("plane", [1000.0, gx, gy]), 0.5)
    mean, se = mc_pixels(only, 1, pixels, mc_scene, n_rays=4000, n_batches=4,
                         rng=np.random.default_rng(9))
    rng = np.random.default_rng(10)
    raw = splitlf.Raw(only, (rng.poisson(np.maximum(mean, 0.0).reshape(shape) * 2000.0)
                             / 2000.0,))
    # Cells of 0.2 mm (twice delta(z): a pixel's image then spans 11 cells, not 22, and the
    # record-mode map costs a quarter); the sinusoid is at a fifth of their Nyquist.
    rec = splitlf.reconstruct(raw, plane, region=(-1.0, 1.0, -1.0, 1.0), step=0.2,
                              noise={"photons": 2000.0, "read_noise": 0.0})
    p = measure.psnr(rec, tex)
    flat = 10.0 * np.log10(1.0 / np.mean((measure.truth(rec, tex) - 0.5) ** 2))
    assert float(np.median(se)) < 0.5 * np.sqrt(0.25 / 2000.0)
    assert p > flat + 5.0, (p, flat)


def _memory_limit(monkeypatch: pytest.MonkeyPatch, limit: int) -> None:
    """reconstruct's one native call with a memory limit of ``limit`` bytes."""
    real = _native.reconstruct

    def call(design: Any, images: Any, surface: Any, options: dict, progress: Any = None) -> Any:
        return real(design, images, surface, {**options, "memory_limit": limit}, progress)

    monkeypatch.setattr(_native, "reconstruct", call)


def test_too_large_by_the_padding_suggests_a_coarser_step(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """When the padding alone does not fit, a tile would be a cell or two: the error says
    tiles do not help and names a step sqrt(need / (0.8 limit)) times coarser, and
    reconstruct raises it rather than tiling (the hint's formula: the core's unit test)."""
    design = seed_small(6, 5)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 400.0))
    _memory_limit(monkeypatch, 1000)
    with pytest.raises(splitlf.errors.TooLargeError) as e:
        # (a fixed lambda: the choice's own sub-grid would be refused first, unhinted)
        splitlf.reconstruct(raw, 400.0, region=(-0.5, 0.5, -0.5, 0.5), step=0.05,
                            regularization=4.0)
    coarse = 0.05 * np.sqrt(e.value.bytes / (0.8 * 1000))
    assert "tiles would not help" in str(e.value) and "tile=" not in str(e.value)
    assert f"step={coarse:.3g}" in str(e.value), (coarse, str(e.value))
    assert e.value.limit == 1000 and e.value.bytes > 1000


@pytest.fixture(scope="module")
def tiled_scene() -> tuple[splitlf.Design, splitlf.Image, dict[str, float]]:
    design = seed_small(24, 16)
    tex = splitlf.Image(np.random.default_rng(5).random((200, 200)), 20.0)
    return design, tex, {"photons": 2000.0, "read_noise": 0.0}


@pytest.mark.parametrize("z", [642.0, 1000.0])
def test_tiles_are_the_one_solve(tiled_scene: Any, z: float) -> None:
    """A region solved in tiles of 16 cells (each reaching 8 cells into its neighbours)
    differs from the one solve by far less than the photon noise moves either (two noise
    draws), and is as close to the truth. Measured: 0.0079 / 0.0046 RMS against noise
    0.057 / 0.046 at 642 / 1000 mm; RMSE against the truth equal to 4 digits."""
    design, tex, noise = tiled_scene
    scene = splitlf.Scene(tex, z, background=0.5)
    raws = [splitlf.render(design, scene, noise=noise, seed=s) for s in (2, 3)]
    kw: dict[str, Any] = {"region": (-2.0, 2.0, -1.5, 1.5), "noise": noise}
    one, two = (splitlf.reconstruct(r, z, **kw) for r in raws)
    tiled = splitlf.reconstruct(raws[0], z, tile=16, **kw)
    ny, nx = one.image.shape
    assert tiled.tiles == -(-nx // 16) * -(-ny // 16) > 4 and one.tiles == 1
    assert tiled.image.shape == one.image.shape and tiled.extent == one.extent

    def rms(a: np.ndarray) -> float:
        return float(np.sqrt(np.mean(a ** 2)))

    noise_rms = rms(one.image - two.image) / np.sqrt(2.0)
    assert rms(tiled.image - one.image) <= 0.25 * noise_rms, (rms(tiled.image - one.image),
                                                             noise_rms)
    truth = measure.truth(one, tex)
    assert rms(tiled.image - truth) <= 1.01 * rms(one.image - truth)


def test_a_solve_too_large_falls_back_to_tiles(tiled_scene: Any,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """When one solve would not fit, reconstruct takes the tiles its plan suggests (and
    with an explicit tile too large it raises, naming a tile that would fit)."""
    design, tex, noise = tiled_scene
    raw = splitlf.render(design, splitlf.Scene(tex, 1000.0, background=0.5), noise=noise)
    # A fixed lambda: the choice's own sub-grid would be refused first, without the hint.
    kw: dict[str, Any] = {"region": (-4.0, 4.0, -3.0, 3.0), "noise": noise,
                          "regularization": 4.0}
    one = splitlf.reconstruct(raw, 1000.0, **kw)
    _memory_limit(monkeypatch, 1)
    with pytest.raises(splitlf.errors.TooLargeError) as e:
        splitlf.reconstruct(raw, 1000.0, **kw)
    with pytest.raises(splitlf.errors.TooLargeError) as e16:
        splitlf.reconstruct(raw, 1000.0, tile=16, **kw)
    assert e16.value.bytes < e.value.bytes
    monkeypatch.undo()
    _memory_limit(monkeypatch, (e16.value.bytes + e.value.bytes) // 2)
    rec = splitlf.reconstruct(raw, 1000.0, **kw)
    assert rec.tiles > 1 and rec.image.shape == one.image.shape, rec.tiles
    assert float(np.sqrt(np.mean((rec.image - one.image) ** 2))) < 0.05
    with pytest.raises(splitlf.errors.TooLargeError, match="tile="):
        splitlf.reconstruct(raw, 1000.0, tile=200, **kw)
    monkeypatch.undo()
    for bad in (0, 15):
        with pytest.raises(splitlf.errors.InvalidParameter, match="tile"):
            splitlf.reconstruct(raw, 1000.0, tile=bad, **kw)
    with pytest.raises(TypeError, match="tile"):
        splitlf.reconstruct(raw, 1000.0, tile=16.0, **kw)  # type: ignore[arg-type]


def test_reconstruct_is_one_native_call(monkeypatch: pytest.MonkeyPatch) -> None:
    """After the Python checks, a reconstruction (also a tiled one) is one call into the
    core: every function of splitlf._native is wrapped to count its calls."""
    design = seed_small(6, 5)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 400.0))
    calls: list[str] = []
    for name in dir(_native):
        f = getattr(_native, name)
        if callable(f) and not isinstance(f, type) and not name.startswith("_"):
            def counted(*a: Any, _f: Any = f, _n: str = name, **k: Any) -> Any:
                calls.append(_n)
                return _f(*a, **k)
            monkeypatch.setattr(_native, name, counted)
    for kw in ({}, {"tile": 16}, {"depth": splitlf.Plane(400.0, 0.5, 0.0)}):
        depth = kw.pop("depth", 400.0)
        calls.clear()
        splitlf.reconstruct(raw, depth, region=(-1.0, 1.0, -1.0, 1.0), step=0.05, **kw)
        assert calls == ["reconstruct"], calls


def test_regularization_beyond_the_data_is_refused() -> None:
    """regularization=1e300 once returned an image of -1.9e5: the prior drowned the data
    and CG lost its precision. It is refused, naming the range; at the range's top the
    image is the data's weighted mean (the limit of an infinite prior: the constant c
    minimising sum w (c A 1 - y)^2 is the albedo of a flat scene, 0.4)."""
    design = seed_small(6, 5)
    raw = splitlf.render(design, splitlf.Scene(flat(0.4), 400.0))
    kw: dict[str, Any] = {"region": (-1.0, 1.0, -1.0, 1.0), "step": 0.1}
    with pytest.raises(splitlf.errors.InvalidParameter, match="regularization") as e:
        splitlf.reconstruct(raw, 400.0, regularization=1e300, **kw)
    top = float(str(e.value).split("(0, ")[1].split("]")[0])
    assert 1e3 < top < 1e300
    rec = splitlf.reconstruct(raw, 400.0, regularization=0.999 * top, **kw)
    assert np.max(np.abs(rec.image - 0.4)) < 1e-3, np.max(np.abs(rec.image - 0.4))


def test_slow_runs_are_announced_and_refused(monkeypatch: pytest.MonkeyPatch,
                                             caplog: pytest.LogCaptureFixture) -> None:
    """The grid's size and the expected work are logged before the work; a run expected
    past MAX_SECONDS is refused (TooLargeError naming allow_slow) unless allow_slow=True."""
    import logging

    from splitlf.inverse import reconstruct as module

    design = seed_small(6, 5)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 400.0))
    kw: dict[str, Any] = {"region": (-1.0, 1.0, -1.0, 1.0), "step": 0.05}
    with caplog.at_level(logging.INFO, logger="splitlf.reconstruct"):
        rec = splitlf.reconstruct(raw, 400.0, **kw)
    ny, nx = rec.image.shape
    assert any(f"{nx} x {ny} cells" in r.getMessage() and "expected" in r.getMessage()
               for r in caplog.records), [r.getMessage() for r in caplog.records]
    monkeypatch.setattr(module, "MAX_SECONDS", 1e-9)
    with pytest.raises(splitlf.errors.TooLargeError, match="allow_slow=True"):
        splitlf.reconstruct(raw, 400.0, **kw)
    again = splitlf.reconstruct(raw, 400.0, allow_slow=True, **kw)
    assert np.array_equal(again.image, rec.image)
    with pytest.raises(TypeError, match="allow_slow"):
        splitlf.reconstruct(raw, 400.0, allow_slow=1, **kw)  # type: ignore[arg-type]


def test_mtf50_of_an_edge_outside_the_region_is_refused() -> None:
    """An edge whose line misses the region (X = 100 mm against a region of X in [-1, 1]:
    every cell on one side) once gave an MTF50 of 1.32; it is refused, naming the edge."""
    design = seed_small(6, 5)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 400.0))
    rec = splitlf.reconstruct(raw, 400.0, region=(-1.0, 1.0, -1.0, 1.0), step=0.05)
    for center in ((100.0, 0.0), (0.0, -50.0), (1.5, 0.0)):
        with pytest.raises(splitlf.errors.InvalidParameter, match="edge"):
            measure.mtf50(rec, splitlf.SlantedEdge(angle=5.0, center=center))


def test_repr_is_short() -> None:
    design = seed_small(6, 5)
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 400.0))
    rec = splitlf.reconstruct(raw, 400.0, region=(-1.0, 1.0, -1.0, 1.0), step=0.05)
    text = repr(rec)
    assert len(text) < 400 and "array" not in text and "40 x 40 cells" in text, text


def _two_types() -> splitlf.Design:
    """Half 1 of the seed cut to 8 x 6 lenses with interleaved lens types of two focal
    lengths (a rect multi-focus array: the exact route)."""
    d = seed_small(8, 6)
    f = d.resolved()[0]["f"][0]
    return splitlf.Design(F=d.F, D=d.D, aperture=d.aperture,
                          channels=(d.channels[0].replace(f=(f, 1.4 * f)),))


def _raytrix_small() -> splitlf.Design:
    d = splitlf.Design.preset("raytrix-r12")
    return d.replace(channels=(d.channels[0].replace(Kx=6, Ky=5, Mx=None, My=None),))


@pytest.mark.parametrize("which", ["rect two types (exact route)",
                                   "rect two types, tilted plane (tilted route)",
                                   "raytrix-r12 (general route)"])
def test_lens_types_use_only_their_lenses(which: str) -> None:
    """reconstruct(lens_types=...) uses the pixels under those lens types (each pixel's lens
    from splitlf.chief_samples, its type by the model's rule) and no others: with the other
    types' pixels set to 5 (far from any albedo) a type's image is the same bit for bit,
    while the image of every type changes; a type's rows and the other types' rows add up
    to the whole; every type listed is every type (None)."""
    rect = which.startswith("rect")
    design = _two_types() if rect else _raytrix_small()
    z = 1000.0 if rect else 400.0
    surface: Any = splitlf.Plane(z, 0.0, 2.0) if "tilted" in which else z
    n_types = len(design.resolved()[0]["f"])
    kw: dict[str, Any] = {"region": (-1.0, 1.0, -0.8, 0.8) if rect else (-0.8, 0.8, -0.6, 0.6),
                          "step": (2.0 if rect else 4.0) * design.resolution_step(z),
                          "noise": {"photons": 2000.0, "read_noise": 0.0},  # fewer iterations
                          "regularization": 4.0}
    tex = splitlf.Image(np.random.default_rng(7).random((40, 40)), 8.0)
    raw = splitlf.render(design, splitlf.Scene(tex, surface, background=0.5))
    # Each pixel's lens type from its lens (j, k) by docs/model.md §9's rule: (j + k) mod T
    # on rect lattices, (j - floor(k / 2) - k) mod T on hex ones.
    lens = splitlf.chief_samples(design, 1, z).lens
    j, k = lens[..., 0], lens[..., 1]
    types = (j + k if rect else j - k // 2 - k) % n_types
    assert sorted(np.unique(types)) == list(range(n_types))
    whole = splitlf.reconstruct(raw, surface, **kw)
    t = 2
    spoilt = raw.images[0].copy()
    spoilt[types != t - 1] = 5.0
    bad = splitlf.Raw(design, [spoilt])
    one = splitlf.reconstruct(raw, surface, lens_types=t, **kw)
    assert one.lens_types == (t,)
    np.testing.assert_array_equal(one.image, splitlf.reconstruct(bad, surface, lens_types=[t],
                                                                 **kw).image)
    assert np.abs(splitlf.reconstruct(bad, surface, **kw).image - whole.image).max() > 0.1
    others = tuple(u for u in range(1, n_types + 1) if u != t)
    rest = splitlf.reconstruct(raw, surface, lens_types=others, **kw)
    assert 0 < one.rows < whole.rows and 0 < rest.rows < whole.rows
    assert one.rows + rest.rows == whole.rows
    every = splitlf.reconstruct(raw, surface, lens_types=tuple(range(n_types, 0, -1)), **kw)
    assert every.lens_types is None and every.rows == whole.rows


def test_lens_types_bad_input() -> None:
    design = _two_types()
    raw = splitlf.render(design, splitlf.Scene(flat(0.5), 1000.0))
    kw: dict[str, Any] = {"region": (-1.0, 1.0, -0.8, 0.8)}
    with pytest.raises(splitlf.InvalidParameter, match=r"lens_types.*1\.\.2"):
        splitlf.reconstruct(raw, 1000.0, lens_types=3, **kw)
    with pytest.raises(splitlf.InvalidParameter, match="lens_types"):
        splitlf.reconstruct(raw, 1000.0, lens_types=0, **kw)
    with pytest.raises(splitlf.InvalidParameter, match="at most once"):
        splitlf.reconstruct(raw, 1000.0, lens_types=(1, 1), **kw)
    with pytest.raises(TypeError, match="lens_types"):
        splitlf.reconstruct(raw, 1000.0, lens_types="1", **kw)
    with pytest.raises(TypeError, match="lens_types"):
        splitlf.reconstruct(raw, 1000.0, lens_types=(1.0,), **kw)
    with pytest.raises(TypeError, match="lens_types"):
        splitlf.reconstruct(raw, 1000.0, lens_types=(), **kw)
    # The core's own checks, behind the Python ones.
    scene = _surface_scene(splitlf.Plane(1000.0))
    grid = _native.cell_grid((-1.0, 1.0, -0.8, 0.8), 0.2)
    for bad in ([0], [3], [-2**63], []):
        with pytest.raises(splitlf.InvalidParameter, match="lens_types"):
            _native.surface_system(design.core, scene, grid, None, None, None, bad)


def test_plane_nearer_than_f_in_the_view_is_taken_over_its_region() -> None:
    """A tilted plane is checked over the region, not over the design's whole view
    (docs/reconstruct.md step 2): Z = 300 + 20 Y on the seed cut to 6 x 64 lenses is 660
    to 740 mm over the region, but some ray of the design meets it nearer than F (at
    61 mm: render refuses it, as it renders every pixel). The map has rows over the
    region, and at six of them A t equals the independent Monte-Carlo renderer's raw of
    the image t (tests/mc_render.py, where rays that meet the plane nearer than F are
    background) within 4 standard errors + 2e-4 of white (measured 0.6 to 1.8 standard
    errors, 1.7e-4 to 3.9e-4 of white). reconstruct's default step is delta at the
    region's centre depth (700 mm); a region reaching below Y = -11 (depth < F) raises."""
    from mc_render import mc_pixels, scene

    design = seed_small(6, 64)
    surface = splitlf.Plane(300.0, 0.0, 20.0)
    with pytest.raises(splitlf.errors.InvalidParameter, match="wherever a ray"):
        splitlf.render(design, splitlf.Scene(splitlf.Sinusoid(0.5, 0.5, 0.4), surface))
    region = (-2.0, 2.0, 18.0, 22.0)
    grid = _native.cell_grid(region, 0.07)
    x0, y1, h, nx, ny = grid
    chan, pix, A = _csr(_native.surface_system(design.core, _surface_scene(surface), grid),
                        nx * ny)
    assert len(chan) > 300
    t = np.random.default_rng(4).random((ny, nx))
    got = A @ t.ravel()
    white = float(A.sum(axis=1).max())
    sc = scene(("image", [x0, x0 + nx * h, y1 - ny * h, y1], t), ("plane", [300.0, 0.0, 20.0]),
               0.5)
    rows = np.random.default_rng(6).choice(len(chan), 6, replace=False)
    for c in (0, 1):
        mine = [int(i) for i in rows if chan[i] == c]
        if not mine:
            continue
        pixels = [divmod(int(pix[i]), 6 * 15) for i in mine]
        # 20 batches of 50,000 rays (10 of 20,000 put one row at 4.1 standard errors, an
        # underestimated error: 2,000,000 rays put it at 0.15)
        mc, se = mc_pixels(design, c + 1, pixels, sc, n_rays=1_000_000, n_batches=20,
                           rng=np.random.default_rng(7 + c))
        for i, k in enumerate(mine):
            assert abs(got[k] - mc[i]) <= 4.0 * se[i] + 2e-4 * white, (c, got[k], mc[i], se[i])
    raw = splitlf.Raw(design, (np.full((64 * 15, 6 * 15), 0.5),) * 2)
    # (the former default: noise-free at the floor, lambda = 4; the subject is the map)
    rec = splitlf.reconstruct(raw, surface, region=region, channels=(1,), progress=False,
                              noise={"photons": np.inf}, regularization=4.0)
    assert rec.step == pytest.approx(design.resolution_step(700.0))
    # each half takes half the light (share 0.5): a raw of 0.5 is an albedo of 1
    assert float(np.median(rec.image)) == pytest.approx(1.0, rel=0.01)
    with pytest.raises(splitlf.errors.InvalidParameter, match="depth"):
        splitlf.reconstruct(raw, surface, region=(-2.0, 2.0, -12.0, 22.0), progress=False)


@pytest.mark.parametrize(("z", "channels"), [(1000.0, None), (642.0, (1,))])
def test_noise_stop_moves_the_image_far_less_than_its_error(
        tiled_scene: Any, monkeypatch: pytest.MonkeyPatch, z: float, channels: Any) -> None:
    """For a raw of known noise the CG stops once its residual is CG_NOISE_TOL of the
    noise's expected norm in the right-hand side (docs/reconstruct.md step 3): fewer
    iterations than the relative stop alone, and an image that moves by a small share of
    its own error against the truth (measured: 220 against 727 iterations, 0.20 % of it, at
    1 m; 93 against 357, 1.4 %, on half 1 alone at its out-of-focus plane, 642 mm). A
    noise-free raw stops on the relative residual alone: the same image whatever
    CG_NOISE_TOL."""
    from splitlf import reconstruction

    design, tex, noise = tiled_scene
    scene = splitlf.Scene(tex, z, background=0.5)
    raw = splitlf.render(design, scene, noise=noise, seed=2)
    kw: dict[str, Any] = {"region": (-2.0, 2.0, -1.5, 1.5), "channels": channels,
                          "progress": False}
    fast = splitlf.reconstruct(raw, z, noise=noise, **kw)
    monkeypatch.setattr(reconstruction, "CG_NOISE_TOL", 0.0)
    full = splitlf.reconstruct(raw, z, noise=noise, **kw)

    def rms(a: np.ndarray) -> float:
        return float(np.sqrt(np.mean(a ** 2)))

    err = rms(full.image - measure.truth(full, tex))
    moved = rms(fast.image - full.image)
    assert fast.iterations < full.iterations
    assert moved <= 0.05 * err, (moved, err)
    # (a fixed lambda: the data-chosen one's search stops its solves at the floor's noise)
    clean = splitlf.render(design, scene)
    a = splitlf.reconstruct(clean, z, regularization=4.0, **kw)
    monkeypatch.setattr(reconstruction, "CG_NOISE_TOL", 0.5)
    b = splitlf.reconstruct(clean, z, regularization=4.0, **kw)
    assert a.iterations == b.iterations and np.array_equal(a.image, b.image)
