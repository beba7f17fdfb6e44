"""2-D chief samples, distinct samples and covering radius (docs/model.md §9), checked
against the NumPy transcription of §9 in tests/reference.py, brute-force components
(every pair) and a covering radius computed here with SciPy (Qhull's Voronoi diagram,
a k-d tree for the nearest distances) or by a dense grid search."""

from __future__ import annotations

import math

import numpy as np
import pytest

import reference as ref
import splitlf
from splitlf import Camera, Channel, Design, InvalidParameter

scipy_spatial = pytest.importorskip("scipy.spatial")
csgraph = pytest.importorskip("scipy.sparse.csgraph")
sparse = pytest.importorskip("scipy.sparse")

# ---------------------------------------------------------------------------------------
# Small designs of every kind: rect/hex x ideal/sensor x square/circle, several lens types,
# a sensor wider than the array (pixels beyond its edge), one row of lenses.


def hex_circle() -> Design:
    return Design(50.0, 10.0, [
        Channel(L=60.0, d=0.1, v=0.3, mu=0.011, Kx=9, Ky=8, grid="hex", layout="sensor",
                f=(0.3, 0.31, 0.32), share=0.5),
        Channel(L=75.0, d=0.1, v=0.3, mu=0.013, Kx=7, Ky=6, grid="hex", layout="sensor",
                Mx=80, My=70, share=0.5),
    ], aperture="circle")


def rect_ideal_square() -> Design:
    return Design(50.0, 8.0, [
        Channel(L=60.0, d=0.1, v=0.4, mu=0.02, Kx=6, Ky=5, Q=5, share=0.5),
        Channel(L=70.0, d=0.1, v=0.4, mu=0.0125, Kx=6, Ky=5, Q=8, f=(0.35, 0.37), share=0.5),
    ], aperture="square")


def rect_ideal_circle() -> Design:
    return Design(50.0, 8.0, [
        Channel(L=60.0, d=0.1, v=0.4, mu=0.02, Kx=6, Ky=5, Q=6, share=0.5),
        Channel(L=64.0, d=0.1, v=0.4, mu=0.025, Kx=5, Ky=5, Q=4, f=(0.4, 0.41, 0.42),
                share=0.5),
    ], aperture="circle")


def rect_sensor_square() -> Design:
    return Design(50.0, 9.0, [
        Channel(L=65.0, d=0.12, v=0.5, mu=0.017, Kx=7, Ky=4, grid="rect", layout="sensor",
                f=(0.3, 0.31, 0.32), Mx=61, My=40),
    ], aperture="square")


def hex_square_one_row() -> Design:
    return Design(40.0, 12.0, [
        Channel(L=55.0, d=0.15, v=0.5, mu=0.01, Kx=5, Ky=4, grid="hex", layout="sensor",
                share=0.5),
        Channel(L=58.0, d=0.15, v=0.5, mu=0.012, Kx=6, Ky=1, grid="hex", layout="sensor",
                share=0.5),
    ], aperture="square")


DESIGNS = {
    "hex_circle": hex_circle,
    "rect_ideal_square": rect_ideal_square,
    "rect_ideal_circle": rect_ideal_circle,
    "rect_sensor_square": rect_sensor_square,
    "hex_square_one_row": hex_square_one_row,
}


def depths(design: Design) -> list[float]:
    """Near the main lens, channel 1's out-of-focus plane (samples collapse), far."""
    L1 = design.channels[0].L
    return [design.F * 1.3, design.F * L1 / (L1 - design.F), 2000.0]


# ---------------------------------------------------------------------------------------
# References built here on tests/reference.py.


def all_samples(design: Design, z: float, rows: str | int) -> np.ndarray:
    """Every lit pixel's chief sample (n, 2) of one channel (from 1) or of the union."""
    channels = range(1, len(design.channels) + 1) if rows == "union" else [rows]
    parts = []
    for c in channels:
        s = ref.chief_samples_2d(design, c, z)
        parts.append(np.stack([s["X"][s["lit"]], s["Y"][s["lit"]]], axis=-1))
    return np.concatenate(parts)


def representatives(pts: np.ndarray, eps: float) -> np.ndarray:
    """Brute force over every pair: components of |dX| < eps and |dY| < eps, each
    represented by its least (X, Y) member."""
    n = len(pts)
    rows, cols = [], []
    for lo in range(0, n, 512):
        blk = pts[lo:lo + 512]
        near = ((np.abs(blk[:, None, 0] - pts[None, :, 0]) < eps)
                & (np.abs(blk[:, None, 1] - pts[None, :, 1]) < eps))
        i, k = np.nonzero(near)
        rows.append(i + lo)
        cols.append(k)
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = sparse.coo_matrix((np.ones(r.size), (r, c)), shape=(n, n))
    _, label = csgraph.connected_components(graph, directed=False)
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    _, first = np.unique(label[order], return_index=True)
    return pts[order[first]]


def inside(pts: np.ndarray, field: tuple[float, float]) -> np.ndarray:
    return pts[(np.abs(pts[:, 0]) <= field[0]) & (np.abs(pts[:, 1]) <= field[1])]


def bisector_crossings(a: np.ndarray, b: np.ndarray, hx: float, hy: float) -> np.ndarray:
    """Where the perpendicular bisectors of the pairs (a_i, b_i) cross the box's sides."""
    mid = (a + b) / 2.0
    nrm = b - a  # the bisector is {p : (p - mid) . nrm = 0}
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis, side in ((0, -hx), (0, hx), (1, -hy), (1, hy)):
            other = 1 - axis
            h = hy if axis == 0 else hx
            # (side - mid_a) n_a + (t - mid_o) n_o = 0  ->  t
            t = mid[:, other] - (side - mid[:, axis]) * nrm[:, axis] / nrm[:, other]
            ok = np.isfinite(t) & (np.abs(t) <= h)
            p = np.empty((ok.sum(), 2))
            p[:, axis] = side
            p[:, other] = t[ok]
            out.append(p)
    return np.concatenate(out)


def covering_radius_scipy(pts: np.ndarray, hx: float, hy: float) -> float:
    """The largest nearest distance over the box |x| <= hx, |y| <= hy: at a Voronoi vertex
    inside it (Qhull), where a Voronoi edge crosses its sides (every ridge's bisector is
    tried: extra points are harmless, each is evaluated exactly), or at a corner."""
    if len(pts) == 0:
        return math.inf
    cand = [np.array([[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]])]
    try:
        vor = scipy_spatial.Voronoi(pts)
        v = vor.vertices
        cand.append(v[(np.abs(v[:, 0]) <= hx) & (np.abs(v[:, 1]) <= hy)])
        pairs = vor.ridge_points
    except scipy_spatial.QhullError:  # fewer than 3 points, or all collinear
        i, k = np.triu_indices(len(pts), 1)
        pairs = np.stack([i, k], axis=-1)
    cand.append(bisector_crossings(pts[pairs[:, 0]], pts[pairs[:, 1]], hx, hy))
    d, _ = scipy_spatial.cKDTree(pts).query(np.concatenate(cand))
    return float(d.max())


def grid_search(pts: np.ndarray, hx: float, hy: float, n: int = 400) -> float:
    """Largest nearest distance over an (n + 1)^2 grid of the box (a lower bound, at most
    half a grid diagonal below the truth)."""
    x, y = np.meshgrid(np.linspace(-hx, hx, n + 1), np.linspace(-hy, hy, n + 1))
    d, _ = scipy_spatial.cKDTree(pts).query(np.stack([x.ravel(), y.ravel()], axis=-1))
    return float(d.max())


# ---------------------------------------------------------------------------------------
# Chief samples.


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_chief_samples_equal_the_reference(name):
    design = DESIGNS[name]()
    for channel in range(1, len(design.channels) + 1):
        for z in depths(design):
            got = splitlf.chief_samples(design, channel, z, n_threads=2)
            want = ref.chief_samples_2d(design, channel, z)
            assert got.X.shape == want["X"].shape == got.lit.shape
            assert got.lens.shape == (*got.X.shape, 2) and got.lens.dtype == np.int64
            np.testing.assert_array_equal(got.lens, want["lens"])
            np.testing.assert_array_equal(got.type, want["type"])
            np.testing.assert_array_equal(got.lit, want["lit"])
            assert got.lit.sum() > 0
            lit = want["lit"]
            scale = np.abs(want["X"][lit]).max()
            for a in ("X", "Y"):
                assert np.all(np.isnan(getattr(got, a)[~lit]))
                err = np.abs(getattr(got, a)[lit] - want[a][lit]).max()
                assert err <= 1e-12 * scale, (name, channel, z, a, err)


def test_chief_samples_of_a_camera_are_its_design():
    cam = Camera.paper().replace(Kx=12, Ky=9)
    for half in (1, 2):
        a = splitlf.chief_samples(cam, half, 400.0)
        b = splitlf.chief_samples(cam.design, half, np.array([400.0]))
        assert a.X.shape == (9 * 15, 12 * 15)
        for f in ("X", "Y", "lit", "lens", "type"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        want = ref.chief_samples_2d(cam.design, half, 400.0)
        np.testing.assert_array_equal(a.lit, want["lit"])
        # Half 1 is f-number matched: every pixel lit; half 2 lights 11 of 15 per axis.
        assert a.lit.sum() == 12 * 9 * (15 * 15 if half == 1 else 11 * 11)


def test_hex_lens_types_differ_from_all_six_neighbours():
    design = hex_circle()  # channel 1: T = 3 on a 9 x 8 hex grid
    ch = design.resolved()[0]
    got = splitlf.chief_samples(design, 1, 300.0)
    j, k = got.lens[..., 0].ravel(), got.lens[..., 1].ravel()
    types = np.full((ch["Ky"], ch["Kx"]), -1)
    types[k, j] = got.type.ravel()
    assert np.all(types >= 0)  # every lens owns pixels
    np.testing.assert_array_equal(types, ref.lens_types(ch))
    c = ref.lens_centres(ch).reshape(-1, 2)
    t = types.ravel()
    dist = np.hypot(*(c[:, None, :] - c[None, :, :]).transpose(2, 0, 1))
    neighbours = np.abs(dist - ch["d"]) < 1e-9
    assert neighbours.sum(axis=1).max() == 6
    for i in range(len(c)):
        nt = t[neighbours[i]]
        assert t[i] not in nt
        if neighbours[i].sum() == 6:
            assert set(nt) == {0, 1, 2} - {t[i]}


# ---------------------------------------------------------------------------------------
# Distinct samples and covering radius.


@pytest.mark.parametrize("name", sorted(DESIGNS))
@pytest.mark.parametrize("tol", [1e-6, 0.3])
def test_distinct_samples_equal_brute_force(name, tol):
    design = DESIGNS[name]()
    n_rows = len(design.channels) + 1
    for z in depths(design):
        got = splitlf.samples_2d(design, z, tol=tol, window=6.0)
        assert got.rows == (*(f"channel {i}" for i in range(1, n_rows)), "union")
        delta = ref.resolution_step_2d(design, z)
        field = ref.central_field(design, z, 6.0)
        for r, row in enumerate([*range(1, n_rows), "union"]):
            reps = representatives(all_samples(design, z, row), tol * delta)
            want = inside(reps, field)
            want = want[np.lexsort((want[:, 1], want[:, 0]))]
            assert got.distinct[r] == len(want), (name, z, row)
            assert got.samples[r].shape == want.shape
            np.testing.assert_allclose(got.samples[r], want, rtol=0, atol=1e-12 * delta)
            rho = covering_radius_scipy(reps / delta, field[0] / delta, field[1] / delta)
            assert got.covering_radius[r] == pytest.approx(rho, rel=1e-9), (name, z, row)
            assert got.covering_radius_mm[r] == pytest.approx(rho * delta, rel=1e-9)


def test_coverage_equals_samples_2d_at_every_depth():
    design = hex_circle()
    z = np.array(depths(design) + [140.0, 700.0])
    c = splitlf.coverage(design, z, window=5, n_threads=2)
    assert c.distinct.shape == c.covering_radius.shape == (3, z.size)
    assert c.distinct.dtype == np.int64 and c.rows == ("channel 1", "channel 2", "union")
    np.testing.assert_array_equal(c.z, z)
    for m, zi in enumerate(z):
        s = splitlf.samples_2d(design, zi, window=5)
        np.testing.assert_array_equal(c.distinct[:, m], s.distinct)
        np.testing.assert_array_equal(c.covering_radius[:, m], s.covering_radius)
        np.testing.assert_array_equal(c.covering_radius_mm[:, m], s.covering_radius_mm)
    one = splitlf.coverage(design, z, window=5, n_threads=1)
    np.testing.assert_array_equal(one.covering_radius, c.covering_radius)
    # The union holds every channel's samples: never fewer, never a larger radius.
    assert np.all(c.distinct[2] >= c.distinct[:2].max(axis=0))
    assert np.all(c.distinct[2] <= c.distinct[:2].sum(axis=0))
    assert np.all(c.covering_radius[2] <= c.covering_radius[:2].min(axis=0) * (1 + 1e-12))


def test_covering_radius_against_a_grid_search():
    # Tiny sets: a 3 x 3 hex array seen through a small aperture, on wide fields.
    design = Design(50.0, 3.0, [Channel(L=60.0, d=0.1, v=0.3, mu=0.02, Kx=3, Ky=3,
                                        grid="hex", layout="sensor")], aperture="circle")
    for z in (100.0, 300.0, 3000.0):
        s = splitlf.samples_2d(design, z, window=100.0)
        delta = ref.resolution_step_2d(design, z)
        field = ref.central_field(design, z, 100.0)
        reps = representatives(all_samples(design, z, 1), 1e-6 * delta) / delta
        hx, hy = field[0] / delta, field[1] / delta
        g = grid_search(reps, hx, hy)
        step = 2.0 * max(hx, hy) / 400
        assert g - 1e-9 <= s.covering_radius[0] <= g + step, (z, s.covering_radius[0], g)
        assert s.covering_radius[0] == pytest.approx(covering_radius_scipy(reps, hx, hy),
                                                     rel=1e-9)


def test_square_grid_of_pitch_delta_covers_at_one_over_root_two():
    # One pixel per lens and d = mu: the samples are the lens centres' image, a square grid
    # of pitch delta(z) at every depth, covering the 16 x 16-pitch field.
    design = Design(50.0, 2.0, [Channel(L=60.0, d=0.01, v=0.3, mu=0.01, Kx=40, Ky=36, Q=1)])
    z = np.geomspace(60.0, 5000.0, 7)
    c = splitlf.coverage(design, z)
    np.testing.assert_allclose(c.covering_radius, 1 / math.sqrt(2), rtol=1e-12)
    np.testing.assert_array_equal(c.distinct, 256)
    np.testing.assert_allclose(c.covering_radius_mm, c.covering_radius * 0.01 * z / 60.0,
                               rtol=1e-12)


def test_no_lit_pixel_means_no_sample_and_an_infinite_radius():
    # Q = 2 puts every pixel mu/2 off its lens's centre: a tiny aperture lights none.
    design = Design(50.0, 0.05, [Channel(L=60.0, d=0.1, v=0.3, mu=0.05, Kx=4, Ky=4, Q=2)],
                    aperture="circle")
    s = splitlf.samples_2d(design, 200.0)
    assert not splitlf.chief_samples(design, 1, 200.0).lit.any()
    np.testing.assert_array_equal(s.distinct, [0, 0])
    assert np.all(np.isinf(s.covering_radius)) and all(len(a) == 0 for a in s.samples)
    assert s.samples[0].shape == (0, 2)


# ---------------------------------------------------------------------------------------
# The seed camera.


def test_seed_camera():
    cam = Camera.paper()
    z1 = cam.out_of_focus_depth(1)
    z = np.array([z1, 300.0, 1500.0])
    c = splitlf.coverage(cam, z)
    d = splitlf.coverage(cam.design, z)
    np.testing.assert_array_equal(c.distinct, d.distinct)
    np.testing.assert_array_equal(c.covering_radius, d.covering_radius)
    assert np.all(c.distinct[2] >= c.distinct[0]) and np.all(c.distinct[2] >= c.distinct[1])
    # Channel 1 on its out-of-focus plane: one sample per lens, at -(z/L1) c, for the
    # 16 x 16 lenses in the field; the lens grid (pitch Q delta) covers at Q / sqrt(2).
    assert c.distinct[0, 0] == 256
    s = splitlf.samples_2d(cam, z1)
    L1, d_ = ref.array_planes(cam)[0], cam.d
    j = np.arange(cam.Kx) - (cam.Kx - 1) / 2
    k = np.arange(cam.Ky) - (cam.Ky - 1) / 2
    cx = -(z1 / L1) * d_ * j[np.abs(j) <= 8]
    cy = -(z1 / L1) * d_ * k[np.abs(k) <= 8]
    want = np.array([[x, y] for x in np.sort(cx) for y in np.sort(cy)])
    np.testing.assert_allclose(s.samples[0], want, rtol=0, atol=1e-9)
    assert s.covering_radius[0] == pytest.approx(15 / math.sqrt(2), rel=1e-9)
    assert s.distinct[2] >= max(s.distinct[0], s.distinct[1])


# ---------------------------------------------------------------------------------------
# Arguments.


def test_invalid_arguments_are_named():
    design = rect_ideal_square()
    for bad in (0, 3, -1, 10**30):
        with pytest.raises(InvalidParameter) as e:
            splitlf.chief_samples(design, bad, 300.0)
        assert e.value.name == "channel"
    for bad in (True, 1.0, "1", None):
        with pytest.raises(TypeError, match="channel"):
            splitlf.chief_samples(design, bad, 300.0)
    for bad in (0.0, -1.0, 2.0, math.nan, math.inf):
        with pytest.raises(InvalidParameter) as e:
            splitlf.coverage(design, [300.0], tol=bad)
        assert e.value.name == "tol"
    with pytest.raises(InvalidParameter) as e:  # too fine for the sample coordinates
        splitlf.samples_2d(design, 300.0, tol=1e-16)
    assert e.value.name == "tol"
    for bad in (0.0, -3.0, math.inf, math.nan):
        with pytest.raises(InvalidParameter) as e:
            splitlf.samples_2d(design, 300.0, window=bad)
        assert e.value.name == "window"
    with pytest.raises(InvalidParameter) as e:
        splitlf.coverage(design, [300.0, 40.0, 500.0])
    assert e.value.name == "z" and e.value.index == 1
    for bad in (50.0, math.nan, -math.inf):
        with pytest.raises(InvalidParameter):
            splitlf.samples_2d(design, bad)
        with pytest.raises(InvalidParameter):
            splitlf.chief_samples(design, 1, bad)
    with pytest.raises(InvalidParameter):
        splitlf.coverage(design, np.full((2, 2), 300.0))
    with pytest.raises(InvalidParameter):
        splitlf.samples_2d(design, [300.0, 400.0])
    with pytest.raises(InvalidParameter) as e:
        splitlf.coverage(design, [300.0], n_threads=0)
    assert e.value.name == "n_threads"
    for call in (lambda: splitlf.coverage("design", [300.0]),
                 lambda: splitlf.samples_2d(None, 300.0),
                 lambda: splitlf.chief_samples(object(), 1, 300.0),
                 lambda: splitlf.coverage(design, ["a"]),
                 lambda: splitlf.coverage(design, [300.0], tol="1e-6"),
                 lambda: splitlf.samples_2d(design, 300.0, window=None),
                 lambda: splitlf.coverage(design, [300.0], n_threads=1.5)):
        with pytest.raises(TypeError):
            call()


def test_depth_arguments_accept_array_likes():
    design = rect_sensor_square()
    a = splitlf.coverage(design, [300, 500])  # integers
    b = splitlf.coverage(design, np.array([300.0, 500.0], dtype=np.float32))
    c = splitlf.coverage(design, (300.0, 500.0))
    np.testing.assert_array_equal(a.distinct, c.distinct)
    np.testing.assert_array_equal(a.distinct, b.distinct)
    one = splitlf.coverage(design, 300.0)
    assert one.distinct.shape == (2, 1) and one.z.shape == (1,)
    assert splitlf.samples_2d(design, np.float64(300.0)).z == 300.0
    assert splitlf.coverage(design, []).distinct.shape == (2, 0)
