"""Closed forms (Eqs. 1-7) and depth of field against the NumPy reference of docs/model.md."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference as ref
import splitlf
from splitlf import Camera

CURVE_KEYS = ("conjugate", "main_blur", "repetitions", "microlens_blur", "blur_px",
              "conventional_px")


def depths(cam: Camera, n: int = 5000, seed: int = 0) -> np.ndarray:
    """Thousands of depths from just beyond F to 100 m, log-spaced plus random ones,
    including both out-of-focus planes exactly."""
    rng = np.random.default_rng(seed)
    z = np.concatenate([
        cam.F * (1.0 + np.logspace(-6, 3.1, n // 2)),
        np.exp(rng.uniform(np.log(cam.F * 1.0001), np.log(1e5), n - n // 2)),
        [cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)],
    ])
    return z


def test_curves_match_reference(design):
    z = depths(design)
    got = splitlf.curves(design, z)
    want = ref.curves(design, z)
    for key in CURVE_KEYS:
        np.testing.assert_allclose(getattr(got, key), want[key], rtol=1e-12, atol=0, err_msg=key)
    assert got.main_blur.shape == (2, z.size) and got.conjugate.shape == (z.size,)
    np.testing.assert_array_equal(got.z, z)


def test_seed_out_of_focus_planes():
    cam = Camera.paper()
    assert cam.out_of_focus_depth(1) == pytest.approx(642.0, rel=1e-12)
    assert cam.out_of_focus_depth(2) == pytest.approx(217.0, rel=1e-12)
    for h in (1, 2):
        assert cam.out_of_focus_depth(h) == pytest.approx(ref.out_of_focus_depth(cam, h), rel=1e-14)
    # docs/model.md §7: kappa ~ 0.3866, rho ~ 35.3 mm, f/4, Ng's setting on both halves.
    assert cam.kappa == pytest.approx(0.3866, abs=1e-4)
    assert cam.rho == pytest.approx(35.3, abs=0.05)
    assert cam.f_number == 4.0
    L1, L2 = ref.array_planes(cam)
    assert cam.f1 == pytest.approx(ref.ng_focal(L1, cam.v), rel=1e-15)
    assert cam.f2 == pytest.approx(ref.ng_focal(L2, cam.v), rel=1e-15)


def test_blur_on_out_of_focus_plane_is_the_microlens_image_radius(design):
    """b_i is unbounded there; the plotted LF blur is bounded by R_i = D v / (2 L_i)."""
    for h in (1, 2):
        z = design.out_of_focus_depth(h)
        c = splitlf.curves(design, [z])
        L = ref.array_planes(design)[h - 1]
        R_px = design.D * design.v / (2 * L) / design.mu
        assert c.blur_px[h - 1, 0] == pytest.approx(R_px, rel=1e-9)
        assert c.microlens_blur[h - 1, 0] > 1e3 * R_px * design.mu
        assert c.main_blur[h - 1, 0] == pytest.approx(0.0, abs=1e-9)


def test_lit_pixels_match_reference(design):
    for h in (1, 2):
        assert design.lit_pixels(h) == ref.lit_pixels(design, h)
    # The seed design is f-number matched on half 1 only: half 2 is vignetted.
    seed = Camera.paper()
    assert (seed.lit_pixels(1), seed.lit_pixels(2)) == (15, 11)


def test_input_forms_and_threads():
    cam = Camera.paper()
    z = depths(cam, 2000)
    base = splitlf.curves(cam, z)
    # list, float32, strided view, integer array
    as_list = splitlf.curves(cam, z.tolist())
    np.testing.assert_array_equal(as_list.blur_px, base.blur_px)
    z32 = z.astype(np.float32)
    c32 = splitlf.curves(cam, z32)
    np.testing.assert_allclose(c32.blur_px, ref.curves(cam, z32.astype(np.float64))["blur_px"],
                               rtol=1e-12)
    wide = np.zeros(2 * z.size)
    wide[::2] = z
    strided = splitlf.curves(cam, wide[::2])
    np.testing.assert_array_equal(strided.repetitions, base.repetitions)
    ints = splitlf.curves(cam, np.arange(100, 200))
    zi = np.arange(100, 200)
    np.testing.assert_allclose(ints.conjugate, 80.0 * zi / (zi - 80.0), rtol=1e-15)
    for n in (1, 2, 3):
        c = splitlf.curves(cam, z, n_threads=n)
        for key in CURVE_KEYS:
            np.testing.assert_array_equal(getattr(c, key), getattr(base, key))
    empty = splitlf.curves(cam, [])
    assert empty.blur_px.shape == (2, 0)


@pytest.mark.parametrize("bad, index", [([100.0, 80.0], 1), ([90.0, 200.0, 10.0], 2),
                                         ([np.nan], 0), ([300.0, np.inf], 1), ([-5.0], 0)])
def test_bad_depths(bad, index):
    with pytest.raises(ValueError, match=rf"z\[{index}\]"):
        splitlf.curves(Camera.paper(), bad)


@pytest.mark.parametrize("bad, exc", [(["a", "b"], TypeError), ([[100.0, 200.0]], ValueError),
                                       ([1 + 2j], TypeError)])
def test_bad_depth_types(bad, exc):
    with pytest.raises(exc, match="z"):
        splitlf.curves(Camera.paper(), bad)


@pytest.mark.parametrize("n, exc", [(0, ValueError), (-1, ValueError), (2.0, TypeError),
                                     (True, TypeError), (10**6, ValueError)])
def test_bad_threads(n, exc):
    with pytest.raises(exc, match="n_threads"):
        splitlf.curves(Camera.paper(), [100.0], n_threads=n)


def test_curves_requires_camera():
    with pytest.raises(TypeError, match="camera"):
        splitlf.curves({"F": 80}, [100.0])


# -- depth of field ----------------------------------------------------------------------

def _lf_blur(cam, h, z):
    return ref.curves(cam, np.atleast_1d(z))["blur_px"][h - 1]


def _conv_blur(cam, h, z):
    return ref.curves(cam, np.atleast_1d(z))["conventional_px"][h - 1]


def _inside(intervals, z):
    z = np.asarray(z)
    m = np.zeros(z.shape, bool)
    for a, b in intervals:
        m |= (z > a) & (z < b)
    return m


def _blur_functions(cam):
    return {
        "half1": lambda z: _lf_blur(cam, 1, z),
        "half2": lambda z: _lf_blur(cam, 2, z),
        "split": lambda z: np.minimum(_lf_blur(cam, 1, z), _lf_blur(cam, 2, z)),
        "conventional1": lambda z: _conv_blur(cam, 1, z),
        "conventional2": lambda z: _conv_blur(cam, 2, z),
    }


@pytest.mark.parametrize("threshold", [0.5, 0.25, 1.0, 3.0])
def test_dof_boundaries(design, threshold):
    dof = splitlf.depth_of_field(design, threshold)
    for key, blur in _blur_functions(design).items():
        iv = getattr(dof, key)
        for near, far in iv:
            assert design.F <= near < far
            for bound, inward in ((near, +1), (far, -1)):
                if math.isinf(bound) or bound == design.F:
                    continue
                # blur at the boundary equals the threshold
                assert blur(bound)[0] == pytest.approx(threshold, rel=1e-7), (key, bound)
                eps = 1e-6 * bound
                assert blur(bound + inward * eps)[0] < threshold, (key, bound)
                outside = bound - inward * eps
                if not _inside(iv, outside):
                    assert blur(outside)[0] > threshold, (key, bound)


@pytest.mark.parametrize("threshold", [0.5, 2.0])
def test_dof_agrees_with_dense_sampling(design, threshold):
    """Membership in the closed-form intervals = sharpness by the reference blur, on
    200 000 log-spaced depths (away from the boundaries themselves)."""
    dof = splitlf.depth_of_field(design, threshold)
    z = design.F * (1.0 + np.logspace(-5, 4, 200_000))
    for key, blur in _blur_functions(design).items():
        b = blur(z)
        sharp = b < threshold
        near_boundary = np.abs(b / threshold - 1.0) < 1e-6
        member = _inside(getattr(dof, key), z)
        assert np.array_equal(member[~near_boundary], sharp[~near_boundary]), key


def test_dof_seed_shape():
    """Seed design: each LF half loses sharpness in one band around its out-of-focus plane,
    the split sensor is sharp everywhere, the conventional cameras only near their planes."""
    cam = Camera.paper()
    dof = splitlf.depth_of_field(cam)
    for h, key in ((1, "half1"), (2, "half2")):
        iv = getattr(dof, key)
        assert len(iv) == 2
        z_oof = cam.out_of_focus_depth(h)
        assert iv[0][1] < z_oof < iv[1][0]
        assert iv[0][0] == cam.F and math.isinf(iv[1][1])
    assert dof.split == [(cam.F, math.inf)]
    for h, key in ((1, "conventional1"), (2, "conventional2")):
        ((a, b),) = getattr(dof, key)
        assert a < cam.out_of_focus_depth(h) < b


def test_dof_whole_range_when_microlens_image_is_small():
    cam = Camera.paper()
    # R_1 = 7.5 px: with a 10 px threshold the bounded LF blur is always sharp.
    dof = splitlf.depth_of_field(cam, 10.0)
    assert dof.half1 == [(cam.F, math.inf)]


@pytest.mark.parametrize("t", [0.0, -1.0, math.nan, math.inf])
def test_dof_bad_threshold(t):
    with pytest.raises(ValueError, match="threshold_px"):
        splitlf.depth_of_field(Camera.paper(), t)


def test_dof_json_ready():
    d = splitlf.depth_of_field(Camera.paper()).as_dict()
    assert d["split"] == [[80.0, None]]


@settings(max_examples=40, deadline=None)
@given(
    D=st.floats(2.0, 20.0),  # above ~20.1 the seed's microlens images overlap
    kappa=st.floats(0.0, 1.5),
    f1=st.one_of(st.none(), st.floats(0.3, 1.2)),
    f2=st.one_of(st.none(), st.floats(0.3, 1.2)),
    t=st.floats(0.05, 5.0),
)
def test_dof_property(D, kappa, f1, f2, t):
    cam = Camera.paper().replace(D=D, kappa=kappa, f1=f1, f2=f2)
    dof = splitlf.depth_of_field(cam, t)
    z = cam.F * (1.0 + np.logspace(-4, 3, 20_000))
    for key, blur in _blur_functions(cam).items():
        b = blur(z)
        ok = np.abs(b / t - 1.0) > 1e-6
        assert np.array_equal(_inside(getattr(dof, key), z)[ok], (b < t)[ok]), key


@pytest.mark.parametrize("z_range", [(150.0, 10_000.0), (100.0, 1000.0), (500.0, 900.0)])
def test_sharp_fractions_match_sampling(design, z_range):
    """Log-depth sharp fraction = share of 400 001 log-spaced depths whose reference blur
    is below the threshold (to the sampling resolution)."""
    got = splitlf.sharp_fractions(design, z_range, 0.5)
    z = np.geomspace(*z_range, 400_001)
    for key, blur in _blur_functions(design).items():
        want = np.mean(blur(z) < 0.5)
        assert got[key] == pytest.approx(want, abs=2e-5), key


def test_sharp_fractions_bad_range():
    with pytest.raises(ValueError, match="depth range"):
        splitlf.sharp_fractions(Camera.paper(), (1000.0, 100.0))
    with pytest.raises(TypeError, match="z_range"):
        splitlf.sharp_fractions(Camera.paper(), ("a", 100.0))
