"""Ray-space engine (docs/model.md §3-5, checks of §8): every native result is compared with an
independent computation (tests/reference.py's NumPy and exact rational clipping from
docs/model.md, shapely here)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Polygon

import reference as ref
import splitlf
from splitlf import Camera

PAPER = Camera.paper()
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# -- independent clipping by shapely (the strips from tests/reference.py) -------------------
def strip_polygon(n, lo, hi, C, R):
    """A strip as a long quadrilateral centred near C, half-length R."""
    n = np.asarray(n, float)
    nn = n @ n
    t = np.array([-n[1], n[0]]) / math.sqrt(nn)
    p_lo = C + n * (lo - n @ C) / nn
    p_hi = C + n * (hi - n @ C) / nn
    return Polygon([p_lo - R * t, p_lo + R * t, p_hi + R * t, p_hi - R * t])


def shapely_region(cam: Camera, half: int, j: int, q: int, K: int):
    """Integration region of pixel (j, q) as the intersection of three strips (shapely)."""
    _, _, a, _, _ = ref.geometry(cam, half)
    C = np.array([ref.lens_centre(cam, j, K) / a, 0.0])
    R = 4 * (cam.D + cam.d / a) * (1 + abs(1 - a) / a)
    region = None
    for n, lo, hi in ref.strips(cam, half, j, q, K):
        s = strip_polygon(n, lo, hi, C, R)
        region = s if region is None else region.intersection(s)
    return region


def signed_area(v):
    u, w = v[:, 0], v[:, 1]
    return 0.5 * np.sum(u * np.roll(w, -1) - np.roll(u, -1) * w)


# -- designs ------------------------------------------------------------------------------
@st.composite
def designs(draw, ng: bool = False):
    """Cameras in general position: any f1, f2 (not Ng's setting), any v, mu."""
    F = draw(st.floats(20, 120))
    v1 = F * draw(st.floats(1.05, 1.6))
    kappa = draw(st.floats(0.0, 0.8))
    D = draw(st.floats(2, 40))
    d = draw(st.floats(0.02, 0.5))
    # Up to f-number matched on half 1: a larger v makes the microlens images overlap.
    v = d * v1 / D * draw(st.floats(0.5, 1.0))
    Q = draw(st.integers(1, 12))
    mu = D * v / (v1 * Q) * draw(st.floats(0.4, 1.6))
    K = draw(st.integers(1, 4))
    f1 = None if ng else v * draw(st.floats(0.2, 4.0))
    f2 = None if ng else v * draw(st.floats(0.2, 4.0))
    return Camera(F, D, v1, kappa, d, v, mu, Q, K, draw(st.integers(1, 3)), f1, f2)


# -- trace: polygons --------------------------------------------------------------------
@SETTINGS
@given(designs(), st.sampled_from([1, 2]), st.sampled_from(["x", "y"]))
def test_polygons_match_independent_clipping(cam, half, axis):
    # Two independent clippings of the three strips: exact rational arithmetic (area and
    # centroid to 1e-12 relative) and shapely/GEOS (a different algorithm in floating
    # point; its long strip quads cost it accuracy, measured up to ~5e-12, so 1e-10).
    tr = splitlf.trace(cam, half, axis)
    K = cam.Kx if axis == "x" else cam.Ky
    assert tr.vertices.shape == (K * cam.Q, 6, 2)
    full = cam.D * cam.d * cam.v1 / cam.L(half)
    for i in range(K * cam.Q):
        j, q = int(tr.lens[i]), int(tr.pixel[i])
        assert (j, q) == divmod(i, cam.Q)
        k = int(tr.n_vertices[i])
        assert np.isnan(tr.vertices[i, k:]).all()
        exact = ref.exact_region(cam, half, j, q, K)
        geos = shapely_region(cam, half, j, q, K)
        if exact is None or exact[0] <= 1e-13 * full:
            # empty, or a sliver below rounding: area (near) 0
            assert tr.area[i] <= 1e-12 * full
            assert geos.area <= 1e-11 * full
            continue
        area, cu, cw = exact
        assert 3 <= k <= 6
        v = tr.vertices[i, :k]
        assert signed_area(v) > 0  # counter-clockwise
        assert tr.area[i] == pytest.approx(area, rel=1e-12)
        size = max(np.ptp(v[:, 0]), np.ptp(v[:, 1]))
        # centroid to 1e-12 of max(|centroid|, polygon size): relative, without blowing up
        # where the centroid happens to sit near u = 0
        assert abs(tr.centroid[i, 0] - cu) <= 1e-12 * max(size, abs(cu))
        assert abs(tr.centroid[i, 1] - cw) <= 1e-12 * max(size, abs(cw))
        assert tr.area[i] == pytest.approx(geos.area, rel=1e-10)
        assert abs(tr.centroid[i, 0] - geos.centroid.x) <= 1e-10 * max(size, abs(cu))
        assert abs(tr.centroid[i, 1] - geos.centroid.y) <= 1e-10 * max(size, abs(cw))


@SETTINGS
@given(designs(), st.sampled_from([1, 2]))
def test_light_never_exceeds_the_microlens_share(cam, half):
    tr = splitlf.trace(cam, half, "x")
    full = cam.D * cam.d * cam.v1 / cam.L(half)
    per_lens = tr.area.reshape(cam.Kx, cam.Q).sum(axis=1)
    assert (per_lens <= full * (1 + 1e-12)).all()


@pytest.mark.parametrize("half", [1, 2])
def test_light_is_conserved_in_the_seed_design(half):
    # docs/model.md §8: the microlens image D v / L_i fits inside Q mu for both halves of the
    # preset (equal for half 1, smaller for half 2), so every ray through the aperture
    # and a microlens reaches one of its Q pixels: Σ areas = D d v'/L_i.
    assert PAPER.D * PAPER.v / PAPER.L(half) <= PAPER.Q * PAPER.mu * (1 + 1e-12)
    tr = splitlf.trace(PAPER, half, "x")
    full = PAPER.D * PAPER.d * PAPER.v1 / PAPER.L(half)
    per_lens = tr.area.reshape(PAPER.Kx, PAPER.Q).sum(axis=1)
    np.testing.assert_allclose(per_lens, full, rtol=1e-12)


def test_half1_ng_rectangles():
    # docs/model.md §8: in Ng's setting half 1's polygons are axis-aligned rectangles of width d
    # and height mu v'/v (pixel strip: -(v/v') w in theta_q ± mu/2).
    tr = splitlf.trace(PAPER, 1, "y")
    assert (tr.n_vertices == 4).all() and tr.lit.all()
    v = tr.vertices[:, :4]
    u, w = v[..., 0], v[..., 1]
    width = u.max(1) - u.min(1)
    height = w.max(1) - w.min(1)
    np.testing.assert_allclose(width, PAPER.d, rtol=1e-12)
    np.testing.assert_allclose(height, PAPER.mu * PAPER.v1 / PAPER.v, rtol=1e-12)
    # axis-aligned: every vertex sits on the bounding box's corners
    for k in range(4):
        on_u = np.isclose(u[:, k], u.min(1), rtol=0, atol=1e-13) | np.isclose(
            u[:, k], u.max(1), rtol=0, atol=1e-13
        )
        on_w = np.isclose(w[:, k], w.min(1), rtol=0, atol=1e-13) | np.isclose(
            w[:, k], w.max(1), rtol=0, atol=1e-13
        )
        assert on_u.all() and on_w.all()


def test_half2_ng_parallelograms_of_positive_slope():
    # Half 2 in Ng's setting: pixel-strip edges are horizontal (alpha = 0), microlens
    # edges are x = a u + b w = const with b = 1 - L2/v' < 0: slope dw/du = -a/b > 0.
    tr = splitlf.trace(PAPER, 2, "x")
    _, _, a, b, _ = ref.geometry(PAPER, 2)
    lit = tr.n_vertices > 0
    assert (tr.n_vertices[lit] == 4).all()
    v = tr.vertices[lit, :4]
    e = np.roll(v, -1, axis=1) - v  # edge vectors
    horizontal = np.abs(e[..., 1]) <= 1e-12 * np.abs(e[..., 0])
    assert (horizontal.sum(axis=1) == 2).all()
    slanted = e[~horizontal]
    slopes = slanted[:, 1] / slanted[:, 0]
    assert (slopes > 0).all()
    np.testing.assert_allclose(slopes, -a / b, rtol=1e-9)
    # opposite edges parallel and equal: a parallelogram
    np.testing.assert_allclose(e[:, 0], -e[:, 2], atol=1e-12)
    np.testing.assert_allclose(e[:, 1], -e[:, 3], atol=1e-12)


def test_lit_and_chief_follow_model():
    # Chief ray: w_q = -(L/v) theta_q, through the microlens centre x = c (docs/model.md §4);
    # lit iff |w_q| < D/2 (docs/model.md §6).
    for half in (1, 2):
        tr = splitlf.trace(PAPER, half, "x")
        L, _, a, b, _ = ref.geometry(PAPER, half)
        wq = -(L / PAPER.v) * ref.pixel_offset(PAPER, tr.pixel)
        c = ref.lens_centre(PAPER, tr.lens, PAPER.Kx)
        np.testing.assert_allclose(tr.chief[:, 1], wq, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(tr.chief[:, 0], (c - b * wq) / a, rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(tr.lit, np.abs(wq) < PAPER.D / 2)
        assert tr.lit.reshape(-1, PAPER.Q).sum(1).max() == PAPER.lit_pixels(half)
        # a lit pixel always collects light (its chief ray is inside its polygon)
        assert (tr.area[tr.lit] > 0).all()


# -- footprints ---------------------------------------------------------------------------
@SETTINGS
@given(
    designs(),
    st.sampled_from([1, 2]),
    st.sampled_from(["x", "y"]),
    st.sampled_from(["centroid", "chief"]),
    st.lists(st.floats(1.01, 30.0), min_size=1, max_size=5),
)
def test_footprints_match_numpy_reference(cam, half, axis, sample, zf):
    z = cam.F * np.asarray(zf)
    fp = splitlf.footprints(cam, z, half, axis, sample, kernel=True)
    tr = splitlf.trace(cam, half, axis)
    pos, lo, hi = ref.footprints(cam, tr, z, half, axis, sample)
    n = len(tr.area)
    assert fp.position.shape == fp.lo.shape == (len(z), n)
    span = np.nanmax(np.abs(hi)) if np.isfinite(hi).any() else 1.0
    for got, want in ((fp.position, pos), (fp.lo, lo), (fp.hi, hi)):
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * span)
    # kernel: breakpoints are the sorted vertex projections; ∫ weight dX = area z / v'
    assert fp.kernel_breaks.shape == (len(z), n, 6)
    for r, zr in enumerate(z):
        sigma, _ = ref.sigma_of(cam, zr)
        for i in range(n):
            k = int(tr.n_vertices[i])
            b, v = fp.kernel_breaks[r, i], fp.kernel_values[r, i]
            assert np.isnan(b[k:]).all() and np.isnan(v[k:]).all()
            if k == 0:
                continue
            proj = -(tr.vertices[i, :k, 0] + sigma * tr.vertices[i, :k, 1]) * zr / cam.v1
            np.testing.assert_allclose(b[:k], np.sort(proj), rtol=1e-12, atol=1e-12 * span)
            integral = np.sum(0.5 * (v[1:k] + v[: k - 1]) * np.diff(b[:k]))
            assert integral == pytest.approx(tr.area[i] * zr / cam.v1, rel=1e-9, abs=1e-12)


@SETTINGS
@given(designs(), st.sampled_from([1, 2]), st.floats(1.05, 20.0), st.floats(0.01, 0.99))
def test_kernel_is_the_chord_length(cam, half, zf, frac):
    # Independent: shapely's intersection of the line u + sigma w = p' with the polygon,
    # its length measured along w (Euclidean length / sqrt(1 + sigma^2)).
    z = cam.F * zf
    fp = splitlf.footprints(cam, [z], half, "x", kernel=True)
    tr = splitlf.trace(cam, half, "x")
    sigma, _ = ref.sigma_of(cam, z)
    for i in np.flatnonzero(tr.n_vertices > 0):
        k = int(tr.n_vertices[i])
        b, v = fp.kernel_breaks[0, i, :k], fp.kernel_values[0, i, :k]
        X = b[0] + frac * (b[-1] - b[0])
        if b[-1] - b[0] <= 1e-9 * abs(b[0]):
            continue
        p = -X * cam.v1 / z
        poly = Polygon(tr.vertices[i, :k])
        W = 2 * cam.D
        line = LineString([(p - sigma * -W, -W), (p - sigma * W, W)])
        want = poly.intersection(line).length / math.sqrt(1 + sigma**2)
        got = np.interp(X, b, v)
        assert got == pytest.approx(want, rel=1e-7, abs=1e-9 * cam.D)


def test_chief_samples_collapse_on_out_of_focus_planes():
    # docs/model.md §8: on z_i every chief sample of a microlens projects to that microlens
    # (p' = (v'/L) c), so half i has exactly K distinct positions per axis.
    for half in (1, 2):
        z = PAPER.out_of_focus_depth(half)
        for axis, K in (("x", PAPER.Kx), ("y", PAPER.Ky)):
            fp = splitlf.footprints(PAPER, [z], half, axis, "chief")
            pos = fp.position[0].reshape(K, PAPER.Q)
            lit = ~np.isnan(pos)
            spread = np.nanmax(pos, 1) - np.nanmin(pos, 1)
            assert (spread <= 1e-12 * np.nanmax(np.abs(pos))).all()
            c = ref.lens_centre(PAPER, np.arange(K), K)
            want = -c * PAPER.v1 / PAPER.L(half) * z / PAPER.v1
            np.testing.assert_allclose(np.nanmean(pos, 1), want, rtol=1e-12, atol=1e-12)
            assert len(np.unique(np.round(pos[lit] / PAPER.d, 6))) == K
            # the other half does not collapse there
            other = splitlf.footprints(PAPER, [z], 3 - half, axis, "chief").position[0]
            assert len(np.unique(np.round(other[~np.isnan(other)] / PAPER.d, 6))) > K


def test_centroid_and_chief_agree_when_fully_lit_and_differ_when_vignetted():
    z = np.array([150.0, 217.0, 400.0, 642.0, 2000.0])
    for half in (1, 2):
        tr = splitlf.trace(PAPER, half, "x")
        full = np.isclose(tr.area, tr.area.max(), rtol=1e-12)
        part = (tr.area > 0) & ~full
        cen = splitlf.footprints(PAPER, z, half, "x", "centroid").position
        chi = splitlf.footprints(PAPER, z, half, "x", "chief").position
        np.testing.assert_allclose(cen[:, full], chi[:, full], rtol=1e-12, atol=1e-12)
        if half == 1:
            assert full.all()  # f-number matched: no vignetting in half 1
        else:
            # Half 2 lights fewer than Q pixels per microlens: the two edge pixels of each
            # microlens are partly vignetted (clipped by |w| <= D/2), so their centroid
            # moves away from the chief ray. Exception: on z_2 (z' = L_2) every ray through
            # microlens j lands at p' = (v'/L_2) x, and the clipped parallelogram still
            # spans x in [c - d/2, c + d/2] on every w, so both project to c there.
            assert part.sum() == 2 * PAPER.Kx
            assert tr.lit[part].all()
            gap = np.abs(cen[:, part] - chi[:, part])
            on_z2 = np.isclose(z, PAPER.out_of_focus_depth(2))
            assert (gap[~on_z2] > 1e-4).all()
            np.testing.assert_allclose(gap[on_z2], 0.0, atol=1e-12)


# -- sample_grid --------------------------------------------------------------------------
@pytest.mark.parametrize("sample", ["chief", "centroid"])
@pytest.mark.parametrize("half", [1, 2])
@pytest.mark.parametrize("cam", [PAPER.replace(Kx=7, Ky=5), PAPER.replace(Kx=4, Ky=3, f2=0.9)])
def test_sample_grid_is_the_outer_combination_of_the_axes(cam, half, sample):
    z = 300.0
    g = splitlf.sample_grid(cam, z, half, sample)
    X, Y = g
    assert X.shape == Y.shape == (cam.Ky * cam.Q, cam.Kx * cam.Q)
    fx = splitlf.footprints(cam, [z], half, "x", sample).position[0]
    fy = splitlf.footprints(cam, [z], half, "y", sample).position[0]
    both = ~np.isnan(fy)[:, None] & ~np.isnan(fx)[None, :]
    want_x = np.where(both, fx[None, :], np.nan)
    want_y = np.where(both, fy[:, None], np.nan)
    np.testing.assert_array_equal(X, want_x)
    np.testing.assert_array_equal(Y, want_y)


@SETTINGS
@given(designs(), st.sampled_from([1, 2]), st.sampled_from(["chief", "centroid"]))
def test_sample_grid_random_designs(cam, half, sample):
    z = 3.0 * cam.F
    X, Y = splitlf.sample_grid(cam, z, half, sample, n_threads=1)
    fx = splitlf.footprints(cam, [z], half, "x", sample).position[0]
    fy = splitlf.footprints(cam, [z], half, "y", sample).position[0]
    both = ~np.isnan(fy)[:, None] & ~np.isnan(fx)[None, :]
    np.testing.assert_array_equal(X, np.where(both, fx[None, :], np.nan))
    np.testing.assert_array_equal(Y, np.where(both, fy[:, None], np.nan))


# -- bad input ----------------------------------------------------------------------------
HUGE = Camera(80.0, 20.0, 90.0, 0.3, 0.1, 0.3, 0.01, 65535, 10_000_000, 10_000_000)


@pytest.mark.parametrize(
    "call, exc, words",
    [
        (lambda: splitlf.trace(PAPER, 3), ValueError, "half = 3"),
        (lambda: splitlf.trace(PAPER, 0), ValueError, "1 or 2"),
        (lambda: splitlf.trace(PAPER, "1"), TypeError, "half"),
        (lambda: splitlf.trace(PAPER, True), TypeError, "half"),
        (lambda: splitlf.trace(PAPER, 1, "z"), ValueError, "axis"),
        (lambda: splitlf.trace(PAPER, 1, 0), TypeError, "axis"),
        (lambda: splitlf.footprints(PAPER, [500.0], 1, "w"), ValueError, "axis"),
        (lambda: splitlf.footprints(PAPER, [500.0], 5), ValueError, "half"),
        (lambda: splitlf.footprints(PAPER, [500.0], 1, sample="mean"), ValueError, "sample"),
        (lambda: splitlf.footprints(PAPER, [500.0, 80.0], 1), ValueError, "z[1] = 80"),
        (lambda: splitlf.footprints(PAPER, [500.0, 10.0], 1), ValueError, "> F"),
        (lambda: splitlf.footprints(PAPER, [np.nan], 1), ValueError, "finite"),
        (lambda: splitlf.footprints(PAPER, [np.inf], 1), ValueError, "finite"),
        (lambda: splitlf.footprints(PAPER, [500.0], 1, kernel="yes"), TypeError, "kernel"),
        (lambda: splitlf.footprints(PAPER, ["a"], 1), TypeError, "z"),
        (lambda: splitlf.footprints(PAPER, [500.0], 1, n_threads=0), ValueError, "n_threads"),
        (lambda: splitlf.sample_grid(PAPER, 80.0, 1), ValueError, "> F"),
        (lambda: splitlf.sample_grid(PAPER, math.nan, 1), ValueError, "finite"),
        (lambda: splitlf.sample_grid(PAPER, 500.0, 2, "pixel"), ValueError, "sample"),
        (lambda: splitlf.sample_grid(PAPER, 500.0, -1), ValueError, "half"),
        (lambda: splitlf.sample_grid(HUGE, 500.0, 1), MemoryError, "bytes"),
        (lambda: splitlf.trace(HUGE, 1), MemoryError, "bytes"),
        (lambda: splitlf.footprints(HUGE, [500.0], 1), MemoryError, "bytes"),
        # 2e6 depths x 3,990 pixels x 3 outputs = 190 GB: refused before anything is allocated.
        (lambda: splitlf.footprints(PAPER, np.full(2 * 10**6, 500.0), 1), MemoryError, "bytes"),
    ],
)
def test_bad_input_raises_before_work(call, exc, words):
    with pytest.raises(exc, match=words.replace("[", r"\[").replace("]", r"\]")):
        call()


def test_large_depth_array_with_one_bad_depth_is_refused_up_front():
    z = np.full(200_000, 500.0)
    z[-1] = 40.0  # checked before any footprint is computed
    with pytest.raises(ValueError, match=r"z\[199999\] = 40"):
        splitlf.footprints(PAPER, z, 1)


def test_noncontiguous_depths_and_threads_agree():
    z = np.linspace(100.0, 3000.0, 40)[::2]
    a = splitlf.footprints(PAPER, z, 2, "y", n_threads=1)
    b = splitlf.footprints(PAPER, np.ascontiguousarray(z), 2, "y", n_threads=2)
    np.testing.assert_array_equal(a.position, b.position)
    np.testing.assert_array_equal(a.lo, b.lo)
    assert a.kernel_breaks is None and a.kernel_values is None
    assert shapely.__version__  # shapely is the test dependency of the clipping checks


# -- plot ---------------------------------------------------------------------------------
def test_ray_space_plot_draws_the_traced_polygons():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import splitlf.plot

    fig, ax = plt.subplots()
    out = splitlf.plot.ray_space(PAPER, n_lenses=2, ax=ax)
    assert out is ax
    polys = list(ax.collections)
    assert len(polys) == 2  # half 1 grey, half 2 yellow
    n1 = sum(len(p.vertices) > 0 for p in polys[0].get_paths())
    n2 = sum(len(p.vertices) > 0 for p in polys[1].get_paths())
    assert (n1, n2) == (2 * PAPER.lit_pixels(1), 2 * PAPER.lit_pixels(2))
    assert len(ax.get_lines()) == 3 * 2 + 2  # three planes x two lenses + aperture edges
    plt.close(fig)


def test_plot_without_matplotlib_says_how_to_install(monkeypatch):
    import sys

    import splitlf.plot

    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r"splitlf\[plot\]"):
        splitlf.plot.ray_space(PAPER)
