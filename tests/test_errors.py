"""The exception hierarchy across the seam, named native results, the exported limits."""

from __future__ import annotations

import inspect
import pickle

import numpy as np
import pytest

import splitlf
import splitlf.sweep
from splitlf import InvalidParameter, SplitlfError, TooLargeError, _native, _validate

P = splitlf.Camera.paper()


def test_core_parameter_errors_are_invalid_parameter():
    with pytest.raises(InvalidParameter) as e:
        P.replace(Q=0)
    assert isinstance(e.value, ValueError) and isinstance(e.value, SplitlfError)
    assert (e.value.name, e.value.value, e.value.index) == ("Q", 0, None)
    assert str(_native.MAX_Q) in e.value.allowed
    with pytest.raises(InvalidParameter) as e:
        splitlf.new_samples(P, [500.0], sample="mean")
    assert (e.value.name, e.value.value) == ("sample", "mean")
    with pytest.raises(InvalidParameter) as e:
        splitlf.depth_of_field(P, threshold_px=-1.0)
    assert (e.value.name, e.value.value) == ("threshold_px", -1.0)


def test_bad_depth_names_the_parameter_and_element():
    with pytest.raises(InvalidParameter) as e:
        splitlf.curves(P, [500.0, 600.0, 80.0])
    assert (e.value.name, e.value.value, e.value.index) == ("z", 80.0, 2)
    assert "F = 80" in e.value.allowed
    with pytest.raises(InvalidParameter) as e:
        splitlf.evaluate(P, [500.0, np.nan])
    assert (e.value.name, e.value.index) == ("depths", 1)


@pytest.mark.parametrize("call", [
    lambda: splitlf.curves(P, [5e-324]),
    lambda: splitlf.new_samples(P, [-1e308]),
    lambda: P.replace(mu=-5e-324),
    lambda: P.replace(kappa=-5e-324),
])
def test_messages_of_extreme_numbers_are_one_short_line(call):
    # Rust's {} prints 5e-324 with 324 digits: the message was 435-759 characters.
    with pytest.raises(ValueError) as e:
        call()
    msg = str(e.value)
    assert len(msg) < 200 and "\n" not in msg, msg


def test_too_large_is_memory_error_with_sizes():
    with pytest.raises(TooLargeError) as e:
        splitlf.trace(P.replace(Kx=10**7, Q=65535), 1)
    assert isinstance(e.value, MemoryError) and isinstance(e.value, SplitlfError)
    assert e.value.bytes > e.value.limit > 0 and "trace" in str(e.value)
    back = pickle.loads(pickle.dumps(e.value))
    assert (type(back), back.bytes, str(back)) == (TooLargeError, e.value.bytes, str(e.value))


def test_coincidence_work_is_refused_up_front():
    # Minutes of brute force (and deaf to Ctrl-C) before the work limit.
    cam = P.replace(Kx=10**6, Ky=10**6, Q=16)
    with pytest.raises(TooLargeError) as e:
        splitlf.coincidence_planes(cam, 1, max_n=1000, max_t=1000)
    msg = str(e.value)
    assert "max_n = 1000" in msg and "max_t = 1000" in msg
    assert str(_native.MAX_COINCIDENCE_WORK) in msg and e.value.bytes is None


@pytest.mark.parametrize("kwargs, name", [
    ({"half": 2**63}, "half"),
    ({"half": -2**200}, "half"),
    ({"max_n": 2**63}, "max_n"),
    ({"max_t": 2**63}, "max_t"),
    ({"max_t": 2**70}, "max_t"),
    ({"n_threads": 2**63}, "n_threads"),
    ({"n_threads": 2**64 + 5}, "n_threads"),
])
def test_huge_integers_are_named_errors(kwargs, name):
    args = {"half": 1, **kwargs}
    for call in (lambda: splitlf.coincidence_planes(P, **args),
                 lambda: _native.design_coincidence_planes(P.core, args.pop("half"), **args)):
        with pytest.raises(InvalidParameter) as e:
            call()
        # the native call names its own parameter: the channel number
        native = "channel" if name == "half" else name
        assert e.value.name in (name, native) and e.value.value == kwargs[name], str(e.value)


@pytest.mark.parametrize("call, name", [
    (lambda: _native.design_trace(P.core, True), "channel"),
    (lambda: _native.design_trace(P.core, 1, n_threads=True), "n_threads"),
    (lambda: _native.design_coincidence_planes(P.core, 1, max_n=False), "max_n"),
    (lambda: _native.design_sample_grid(P.core, 500.0, np.True_), "channel"),
    (lambda: _native.design_trace(P.core, 1.0), "channel"),
    (lambda: splitlf.trace(P, True), "half"),
    (lambda: splitlf.trace(P, 1.0), "half"),
    (lambda: splitlf.trace(P, 1, n_threads=True), "n_threads"),
    (lambda: P.L(True), "half"),
    (lambda: P.is_ng(True), "half"),
])
def test_bools_and_floats_are_not_integers(call, name):
    with pytest.raises(TypeError, match=name):
        call()


def test_native_integers_accept_numpy_and_huge_python_ints():
    a = _native.design_trace(P.core, np.int64(2), n_threads=np.uint8(2))
    b = _native.design_trace(P.core, 2)
    assert np.array_equal(a.area, b.area)
    with pytest.raises(InvalidParameter, match=r"channel = 3\b"):
        _native.design_trace(P.core, np.int32(3))
    with pytest.raises(InvalidParameter, match=r"half = 3\b"):
        splitlf.trace(P, np.int32(3))


def test_python_side_range_errors_are_invalid_parameter():
    with pytest.raises(InvalidParameter) as e:
        splitlf.curves(P, [500.0], n_threads=_native.MAX_THREADS + 1)
    assert e.value.name == "n_threads" and str(_native.MAX_THREADS) in e.value.allowed
    with pytest.raises(InvalidParameter) as e:
        splitlf.curves(P, np.full((2, 2), 500.0))
    assert e.value.name == "z"


def test_named_native_results():
    z = np.array([300.0, 500.0])
    c = _native.design_curves(P.core, z)
    assert not isinstance(c, tuple) and c.blur_px.shape == (2, 2)
    assert _native.design_new_samples(P.core, z).distinct.shape == (3, 2)
    planes = _native.design_coincidence_planes(P.core, 1)
    assert len(planes.side) == len(planes.N) == len(planes.counted) > 0
    t = _native.design_trace(P.core, 1)
    assert t.vertices.shape == (P.Kx * P.Q, 6, 2) and t.lit.dtype == np.bool_
    f = _native.design_footprints(P.core, z, 1, kernel=True)
    assert f.kernel_breaks.shape == (2, P.Kx * P.Q, 6)
    assert _native.design_footprints(P.core, z, 1).kernel_values is None
    g = _native.design_sample_grid(P.core, 500.0, 1)
    assert g.X.shape == g.Y.shape == (P.Ky * P.Q, P.Kx * P.Q)
    dof = _native.design_depth_of_field(P.core)
    assert dof.union == splitlf.depth_of_field(P).split
    with pytest.raises(AttributeError):
        c.blur_px = None  # frozen


def test_limits_and_defaults_come_from_the_core():
    assert _validate.MAX_THREADS == _native.MAX_THREADS == 1024
    assert _native.MAX_Q == 65535 and _native.MAX_K == 10_000_000
    sig = inspect.signature
    assert sig(splitlf.new_samples).parameters["tol"].default == _native.DEFAULT_TOL
    assert (sig(splitlf.depth_of_field).parameters["threshold_px"].default
            == _native.DEFAULT_THRESHOLD_PX)
    assert (sig(splitlf.coincidence_planes).parameters["max_n"].default
            == _native.DEFAULT_MAX_N)
    assert _native.available_memory() > 0


@pytest.mark.parametrize("z", [500.0, 500, np.float32(500.0), np.array(500.0), [500.0],
                               (500.0,), np.array([500.0])])
def test_sample_grid_takes_one_depth_in_any_form(z):
    want = splitlf.sample_grid(P.replace(Kx=6, Ky=4), 500.0, 1)
    got = splitlf.sample_grid(P.replace(Kx=6, Ky=4), z, 1)
    assert got.z == 500.0
    np.testing.assert_array_equal(got.X, want.X)
    np.testing.assert_array_equal(got.Y, want.Y)


def test_sample_grid_refuses_several_depths():
    with pytest.raises(InvalidParameter, match="one depth") as e:
        splitlf.sample_grid(P, [500.0, 600.0], 1)
    assert e.value.name == "z"
    with pytest.raises(TypeError, match="z"):
        splitlf.sample_grid(P, True, 1)
