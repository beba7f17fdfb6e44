"""Property-based fuzzing of the public API on random valid designs (and random invalid
fields): every result finite and consistent where documented, round trips exact, threads
equal to serial, bad input refused with a named error.

Designs are small (K_x, K_y <= 40, Q <= 16) so that about 1,800 cases (1,560 valid
designs, 400 invalid fields) run in well under a minute. Ranges are log-uniform over
plausible optics: any f-number from f/0.7 to f/32, the array from 1.001 F to 4 F, f-number
mismatch (vignetting) up to a factor 5 (a v above the matched one makes neighbouring
microlens images overlap, which a design refuses), Ng's setting or explicit microlens
focal lengths.
"""

from __future__ import annotations

import concurrent.futures
import decimal
import math
import pickle
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import splitlf
from splitlf import Camera, InvalidParameter, _native
from splitlf.model.camera import COUNT_FIELDS, FIELDS


def log_floats(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Floats log-uniform in [lo, hi]."""
    return st.floats(math.log(lo), math.log(hi)).map(math.exp)


@st.composite
def design_fields(draw) -> dict:
    """Fields of a random valid design, for ``Camera.paper().replace(**fields)``:
    v1 > F, kappa >= 0 (sometimes exactly 0), mu = d / Q, f1/f2 None (Ng) or explicit."""
    F = draw(log_floats(5.0, 500.0))
    Q = draw(st.integers(1, 16))
    d = draw(log_floats(0.005, 1.0))
    v1 = F * (1.0 + draw(log_floats(1e-3, 3.0)))
    D = F / draw(log_floats(0.7, 32.0))
    # v up to f-number matching on half 1 (D v / v1 = d; often exact, as in the seed):
    # under-filled below. Above it the microlens images overlap: no valid design
    # (docs/model.md §9).
    v = d * v1 / D * draw(st.one_of(st.just(1.0), log_floats(0.2, 0.999)))
    focal = st.one_of(st.none(), log_floats(0.2, 5.0).map(lambda k: v * k))
    return {
        "F": F, "D": D, "v1": v1,
        "kappa": draw(st.one_of(st.just(0.0), log_floats(1e-4, 3.0))),
        "d": d, "v": v, "mu": d / Q, "Q": Q,
        "Kx": draw(st.integers(1, 40)), "Ky": draw(st.integers(1, 40)),
        "f1": draw(focal), "f2": draw(focal),
    }


def designs() -> st.SearchStrategy[Camera]:
    return design_fields().map(lambda f: Camera.paper().replace(**f))


@st.composite
def design_and_depths(draw, max_random: int = 8):
    """A design and depths > F: random ones from just beyond F to 10^5 F, plus (sometimes)
    both out-of-focus planes."""
    cam = draw(designs())
    rel = draw(st.lists(log_floats(1e-6, 1e5), min_size=1, max_size=max_random))
    z = [cam.F * (1.0 + r) for r in rel]
    if draw(st.booleans()):
        z += [cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)]
    return cam, np.array(z)


def fuzz(examples: int) -> settings:
    """``examples`` random cases, no deadline (a case's time is no property)."""
    return settings(max_examples=examples, deadline=None)


# -- curves ---------------------------------------------------------------------------------
@fuzz(300)
@given(design_and_depths())
def test_curves_finite(case):
    cam, z = case
    c = splitlf.curves(cam, z)
    assert np.all(np.isfinite(c.conjugate)) and np.all(c.conjugate >= cam.F)  # so > 0
    for key in ("main_blur", "repetitions", "blur_px", "conventional_px"):
        a = getattr(c, key)
        assert a.shape == (2, z.size)
        assert np.all(np.isfinite(a)) and np.all(a >= 0), key
    for h in (1, 2):
        # b_i is unbounded only where z' lies on array i (docs/model.md §2: L_i - z' = 0);
        # the plotted LF blur is bounded by the microlens image radius R_i there too.
        b = c.microlens_blur[h - 1]
        assert not np.any(np.isnan(b)) and np.all(b >= 0)
        np.testing.assert_array_equal(np.isinf(b), c.conjugate == cam.L(h))
        assert np.all(c.blur_px[h - 1] <= cam.image_radius(h) / cam.mu)


# -- depth of field -------------------------------------------------------------------------
def assert_intervals(iv, F):
    for lo, hi in iv:
        assert F <= lo < hi, iv
    for (_, hi), (lo, _) in zip(iv, iv[1:], strict=False):
        assert hi <= lo, iv  # sorted and disjoint (open intervals may touch)


@fuzz(300)
@given(designs(), log_floats(0.05, 20.0))
def test_depth_of_field_sorted_disjoint(cam, threshold):
    dof = splitlf.depth_of_field(cam, threshold)
    for key in ("half1", "half2", "split", "conventional1", "conventional2"):
        assert_intervals(getattr(dof, key), cam.F)
    for lo, hi in dof.half1 + dof.half2:
        assert any(a <= lo and hi <= b for a, b in dof.split), (lo, hi, dof.split)


# -- new samples ----------------------------------------------------------------------------
def new_samples_with_planes(cam, z, sample):
    """new_samples at z and at the coincidence planes (N <= 2) of both halves, where
    samples merge and the counts dip."""
    planes = [splitlf.coincidence_planes(cam, h, max_n=2).z for h in (1, 2)]
    z = np.concatenate([z, *planes])
    r = splitlf.new_samples(cam, z, sample=sample)
    assert r.distinct.shape == r.max_gap.shape == (3, z.size)
    return r


@fuzz(300)
@given(design_and_depths(), st.sampled_from(["chief", "centroid"]))
def test_new_samples_union_bounds(case, sample):
    cam, z = case
    r = new_samples_with_planes(cam, z, sample)
    d, gap = r.distinct, r.max_gap
    assert np.all(d[2] >= np.maximum(d[0], d[1]))
    assert np.all(d[2] <= d[0] + d[1])
    assert np.all(d[:2] <= r.sampled[:2, None]) and r.sampled[2] == r.sampled[0] + r.sampled[1]
    assert not np.any(np.isnan(gap)) and np.all(gap >= 0)
    if sample == "chief":
        assert list(r.sampled[:2]) == [cam.Kx * cam.lit_pixels(h) for h in (1, 2)]


# Half 2 of this design, on its coincidence plane N = 1, T = 2 (near side, z = 256/29 mm,
# z' = 256/3 mm), has chief samples p' = -0.5, -0.25, 0, 0, 0.25, 0.5 on plane v': its
# outermost samples lie exactly on the edges of the central field, W = K_x d / 4 = 0.5, so
# it covers the field with a largest gap of 0.25 (1.25 delta). Half 1 adds p' = -0.825
# outside the field; the union's gap [-0.825, -0.5] only touches the field at its edge
# point -W and must not count (docs/samples.md §6: gaps count when x_{k+1} > -W and
# x_k < W). Under the former rule (>= and <=) the union's gap was 1.625 delta > 1.25.
EDGE_GAP = (Camera(F=8.0, D=2.0, v1=16.0, kappa=1.0, d=1.0, v=8.0, mu=0.2, Q=5, Kx=2, Ky=1),
            np.array([256 / 29]))


def test_gap_touching_the_field_edge_from_outside_does_not_count():
    cam, z = EDGE_GAP
    gap = splitlf.new_samples(cam, z).max_gap[:, 0]
    np.testing.assert_allclose(gap, [1.625, 1.25, 1.25], rtol=1e-12)


@fuzz(300)
@example(case=EDGE_GAP, sample="chief")
@given(design_and_depths(), st.sampled_from(["chief", "centroid"]))
def test_union_max_gap_at_most_each_half(case, sample):
    # docs/samples.md §6: max_gap only decreases when positions are added.
    cam, z = case
    gap = new_samples_with_planes(cam, z, sample).max_gap
    assert np.all(gap[2] <= np.minimum(gap[0], gap[1]) * (1 + 1e-12))


@fuzz(150)
@given(designs())
def test_chief_samples_collapse_on_out_of_focus_planes(cam):
    # docs/model.md §8: on z_i every lit pixel of microlens j samples c_j (K per axis).
    for h in (1, 2):
        r = splitlf.new_samples(cam, [cam.out_of_focus_depth(h)])
        k = cam.Kx if cam.lit_pixels(h) else 0
        assert r.distinct[h - 1, 0] == k


# -- coincidence planes ---------------------------------------------------------------------
@fuzz(200)
@given(designs(), st.sampled_from([1, 2]), st.integers(1, 4), st.data())
def test_counted_equals_eqs_8_9(cam, half, max_n, data):
    max_t = data.draw(st.one_of(st.none(), st.integers(1, cam.Q)), label="max_t")
    t = splitlf.coincidence_planes(cam, half, max_n=max_n, max_t=max_t)
    np.testing.assert_array_equal(t.counted, t.new_samples)
    np.testing.assert_array_equal(t.new_samples, t.new_samples_x * t.new_samples_y)
    assert np.all(np.isfinite(t.z)) and np.all(t.z > cam.F) and np.all(np.diff(t.z) >= 0)


def test_no_coincidence_plane_at_or_before_f():
    # Found by the fuzz above: with N d v / (T mu L) one rounding error below 1, the near
    # side's conjugate lay ~1e16 L away and its plane's depth rounded to F (4.99...9).
    cam = Camera(F=4.999999999999999, D=5.0, v1=9.999999999999998, kappa=0.0, d=1.0,
                 v=1.9999999999999996, mu=0.2, Q=5, Kx=1, Ky=1)
    t = splitlf.coincidence_planes(cam, 1, max_n=1)
    assert len(t.z) > 0 and np.all(t.z > cam.F)
    np.testing.assert_array_equal(t.counted, t.new_samples)


# -- round trips ----------------------------------------------------------------------------
@fuzz(150)
@given(designs())
def test_pickle_and_toml_round_trips(cam):
    back = pickle.loads(pickle.dumps(cam))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "camera.toml"
        cam.to_toml(path)
        from_file = Camera.from_toml(path)
    for other in (back, from_file):
        assert other == cam
        assert [other.is_ng(h) for h in (1, 2)] == [cam.is_ng(h) for h in (1, 2)]


# -- threads --------------------------------------------------------------------------------
def _calls(cam, z):
    return [
        (splitlf.curves, (cam, z), {}),
        (splitlf.new_samples, (cam, z), {"sample": "chief"}),
        (splitlf.new_samples, (cam, z), {"sample": "centroid", "n_threads": 2}),
    ]


def _arrays(result) -> dict:
    return {k: v for k, v in vars(result).items() if isinstance(v, np.ndarray)}


@fuzz(20)
@given(st.lists(design_and_depths(max_random=40), min_size=8, max_size=8))
def test_threads_equal_serial(cases):
    """8 designs x 3 calls = 24 calls from 8 Python threads at once (480 in all)."""
    calls = [c for cam, z in cases for c in _calls(cam, z)]
    serial = [f(*a, **k) for f, a, k in calls]
    with concurrent.futures.ThreadPoolExecutor(8) as ex:
        futures = [ex.submit(f, *a, **k) for f, a, k in calls]
        threaded = [fu.result() for fu in futures]
    for want, got in zip(serial, threaded, strict=True):
        w, g = _arrays(want), _arrays(got)
        assert w.keys() == g.keys()
        for key in w:
            np.testing.assert_array_equal(g[key], w[key], err_msg=key)


# -- invalid input --------------------------------------------------------------------------
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf, np.float64("nan"),
                              np.float32("inf"), 10**400, -(10**400)])
WRONG_TYPE = st.sampled_from(["1.0", b"1", [1.0], (1.0,), {"x": 1}, 1 + 0j, True, False,
                              np.bool_(True), decimal.Decimal("1.5"), object()])


def invalid_length(name: str) -> st.SearchStrategy:
    """Non-finite, non-positive (kappa: negative) or subnormal values, and wrong types
    (None is Ng's setting for f1 and f2, so a wrong type only for the others)."""
    if name == "kappa":
        bad = st.floats(max_value=-5e-324, allow_nan=False, allow_infinity=False)
    else:
        bad = st.one_of(st.floats(max_value=0.0, allow_nan=False),
                        st.floats(min_value=5e-324, max_value=2.2e-308),  # subnormal
                        st.integers(max_value=0))
    wrong = WRONG_TYPE if name in ("f1", "f2") else st.one_of(WRONG_TYPE, st.none())
    return st.one_of(NON_FINITE, bad, wrong)


def invalid_count(name: str) -> st.SearchStrategy:
    return st.one_of(
        st.integers(max_value=0),
        st.integers(min_value=(_native.MAX_Q if name == "Q" else _native.MAX_K) + 1),
        st.floats(allow_nan=True), NON_FINITE, WRONG_TYPE, st.none(),
    )


@st.composite
def invalid_changes(draw):
    name = draw(st.sampled_from(FIELDS))
    if name in COUNT_FIELDS:
        value = draw(invalid_count(name))
    else:
        value = draw(invalid_length(name))
    if name == "v1":  # also at or inside the focal length
        value = draw(st.one_of(st.just(value), log_floats(1e-3, 1.0).map(lambda k: k * 5.0)))
    return name, value


@fuzz(400)
@given(design_fields(), invalid_changes())
def test_invalid_fields_are_named_errors(fields, change):
    name, value = change
    if name == "v1" and isinstance(value, float) and value > 0:
        fields["F"] = 5.0  # a v1 in (0, 5] is then at or inside the focal length
    with pytest.raises((TypeError, ValueError)) as e:
        Camera.paper().replace(**{**fields, name: value})
    err = e.value
    if isinstance(err, TypeError):
        assert re.search(rf"\b{name}\b", str(err)), (name, value, err)
    else:
        assert isinstance(err, InvalidParameter), (name, value, type(err), err)
        assert err.name == name, (name, value, err)

