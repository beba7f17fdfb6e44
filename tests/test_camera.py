"""The camera description: validation, derived values, TOML round trip, replace, pickle."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference as ref
from designs import non_ng, seed
from splitlf import Camera, InvalidParameter

LENGTHS = ("F", "D", "d", "v", "mu", "f1", "f2")


def test_paper_fields():
    cam = Camera.paper()
    assert (cam.F, cam.D, cam.d, cam.mu, cam.Q, cam.Kx, cam.Ky) == (80.0, 20.0, 0.135, 0.009,
                                                                    15, 266, 88)
    assert cam.v1 == pytest.approx(80 * 642 / 562, rel=1e-15)
    assert cam.v1 * (1 + cam.kappa) == pytest.approx(80 * 217 / 137, rel=1e-14)
    assert cam.v == pytest.approx(cam.d * cam.v1 / cam.D, rel=1e-15)
    assert cam.L(1) == cam.v1 and cam.L(2) == pytest.approx(cam.v1 * (1 + cam.kappa), rel=1e-15)
    assert cam.is_ng(1) and cam.is_ng(2)
    # f-number matching on half 1: the aperture image D v / L_1 equals mu Q.
    assert cam.D * cam.v / cam.L(1) == pytest.approx(cam.mu * cam.Q, rel=1e-12)


@pytest.mark.parametrize("name", LENGTHS)
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf, -math.inf])
def test_bad_lengths(name, bad):
    with pytest.raises(ValueError, match=rf"\b{name}\b") as e:
        Camera.paper().replace(**{name: bad})
    assert "allowed" in str(e.value)


@pytest.mark.parametrize("v1", [80.0, 79.0, 10.0])
def test_v1_must_exceed_F(v1):
    with pytest.raises(ValueError, match=r"v1 = .*> F = 80"):
        Camera.paper().replace(v1=v1)


@pytest.mark.parametrize("kappa", [-0.1, -1e-12, math.nan, math.inf])
def test_bad_kappa(kappa):
    with pytest.raises(ValueError, match="kappa"):
        Camera.paper().replace(kappa=kappa)


def test_kappa_zero_gives_two_identical_halves():
    cam = Camera.paper().replace(kappa=0.0)
    assert cam.L(1) == cam.L(2) and cam.f1 == cam.f2


@pytest.mark.parametrize("name", ["Q", "Kx", "Ky"])
@pytest.mark.parametrize("bad", [0, -3, 10**8, 10**30])
def test_bad_counts(name, bad):
    with pytest.raises(ValueError, match=rf"\b{name}\b.*allowed"):
        Camera.paper().replace(**{name: bad})


@pytest.mark.parametrize("name", ["Q", "Kx", "Ky"])
@pytest.mark.parametrize("bad", [15.0, 15.5, "15", True, None])
def test_count_types(name, bad):
    with pytest.raises(TypeError, match=name):
        Camera.paper().replace(**{name: bad})


@pytest.mark.parametrize("bad", ["80", None, [80.0], True, 1 + 0j])
def test_length_types(bad):
    with pytest.raises(TypeError, match=r"\bF\b"):
        Camera.paper().replace(F=bad)


def test_numpy_scalars_are_accepted():
    import numpy as np

    cam = Camera.paper().replace(D=np.float32(20.0), Q=np.int64(15))
    assert cam == Camera.paper() and isinstance(cam.Q, int) and isinstance(cam.D, float)


def test_unknown_field_in_replace():
    with pytest.raises(TypeError, match="focal"):
        Camera.paper().replace(focal=3.0)


def test_immutable():
    cam = Camera.paper()
    with pytest.raises(AttributeError):
        cam.F = 50.0


def test_replace_keeps_ng_setting_unless_given():
    cam = Camera.paper()
    # v = 0.5 (below the seed's 0.617: with v = 0.7 the microlens images overlap, refused).
    moved = cam.replace(v=0.5)
    L1, L2 = ref.array_planes(moved)
    assert moved.f1 == pytest.approx(ref.ng_focal(L1, 0.5), rel=1e-15)
    assert moved.f2 == pytest.approx(ref.ng_focal(L2, 0.5), rel=1e-15)
    fixed = cam.replace(f1=0.5)
    assert fixed.f1 == 0.5 and not fixed.is_ng(1) and fixed.is_ng(2)
    assert fixed.replace(v=0.5).f1 == 0.5


def test_half_argument():
    cam = Camera.paper()
    for bad in (0, 3, -1):
        with pytest.raises(ValueError, match="half"):
            cam.L(bad)


def test_toml_round_trip(tmp_path):
    for cam in (seed(), non_ng().replace(Kx=7, D=13.1)):
        path = tmp_path / "cam.toml"
        cam.to_toml(path)
        back = Camera.from_toml(path)
        assert back == cam
        assert [back.is_ng(h) for h in (1, 2)] == [cam.is_ng(h) for h in (1, 2)]


@settings(max_examples=60, deadline=None)
@given(
    D_share=st.floats(0.005, 0.999), v1=st.floats(80.0001, 500.0), kappa=st.floats(0.0, 3.0),
    mu=st.floats(1e-4, 0.1), Q=st.integers(1, 60), f1=st.one_of(st.none(), st.floats(0.01, 10)),
)
def test_toml_round_trip_property(tmp_path_factory, D_share, v1, kappa, mu, Q, f1):
    # D up to the largest whose microlens images do not overlap, d (v1 + v) / v.
    seed = Camera.paper()
    D = D_share * seed.d * (v1 + seed.v) / seed.v
    cam = seed.replace(D=D, v1=v1, kappa=kappa, mu=mu, Q=Q, f1=f1)
    path = tmp_path_factory.mktemp("t") / "c.toml"
    cam.to_toml(path)
    assert Camera.from_toml(path) == cam


def test_toml_errors(tmp_path):
    p = tmp_path / "c.toml"
    text = Camera.paper().to_toml()
    p.write_text(text.replace("[camera]", "[camera]\nfocal_length = 3.0"))
    with pytest.raises(ValueError, match="focal_length"):
        Camera.from_toml(p)
    p.write_text(text.replace("Q = 15", "Q = -2"))
    with pytest.raises(ValueError, match=r"\bQ\b"):
        Camera.from_toml(p)
    p.write_text(text.replace("Q = 15", "Q = 15.5"))
    with pytest.raises(TypeError, match=r"\bQ\b"):
        Camera.from_toml(p)
    p.write_text("[camera\nF = 1")
    with pytest.raises(ValueError, match="not valid TOML"):
        Camera.from_toml(p)
    p.write_text(text.replace("F = 80.0", ""))
    with pytest.raises(ValueError, match="missing.*'F'"):
        Camera.from_toml(p)
    p.write_text(text + "\n[other]\nx = 1\n")
    with pytest.raises(ValueError, match="other"):
        Camera.from_toml(p)
    with pytest.raises(OSError):
        Camera.from_toml(tmp_path / "absent.toml")


def test_flat_toml(tmp_path):
    p = tmp_path / "flat.toml"
    p.write_text("\n".join(f"{k} = {v!r}" for k, v in Camera.paper().as_dict(False).items()
                           if v is not None))
    assert Camera.from_toml(p) == Camera.paper()


def test_pickle():
    cam = Camera.paper().replace(f2=0.6)
    back = pickle.loads(pickle.dumps(cam))
    assert back == cam and not back.is_ng(2) and back.is_ng(1)
    assert back.out_of_focus_depth(1) == cam.out_of_focus_depth(1)


def test_half_is_the_integer_1_or_2():
    cam = Camera.paper()
    for method in (cam.L, cam.is_ng, cam.out_of_focus_depth, cam.lit_pixels,
                   cam.image_radius, cam.ng_focal_length):
        with pytest.raises(TypeError, match="half"):
            method(True)
        with pytest.raises(TypeError, match="half"):
            method(1.0)
        for bad in (0, 3, 2**63):
            with pytest.raises(InvalidParameter, match="half") as e:
                method(bad)
            assert e.value.name == "half" and e.value.value == bad
    assert cam.L(np.int64(2)) == cam.L(2) and cam.is_ng(np.int8(1))


def test_integers_beyond_the_float_range_are_named_errors():
    cam = Camera.paper()
    with pytest.raises(InvalidParameter, match=r"invalid F = ") as e:
        cam.replace(F=10**400)
    assert e.value.name == "F"
    with pytest.raises(InvalidParameter, match=r"\[1, 65535\]") as e:
        cam.replace(Q=10**400)
    assert e.value.name == "Q" and len(str(e.value)) < 200
    with pytest.raises(InvalidParameter, match=r"\[1, 10000000\]"):
        cam.replace(Kx=-(10**30))


def test_binary_toml_error_names_the_file(tmp_path):
    p = tmp_path / "camera.toml"
    p.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff\xfe")
    with pytest.raises(ValueError, match="camera.toml") as e:
        Camera.from_toml(p)
    assert "not a TOML text file" in str(e.value)


def test_to_toml_replaces_the_file_whole(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("old")
    Camera.paper().to_toml(p)
    assert Camera.from_toml(p) == Camera.paper()
    assert [q.name for q in tmp_path.iterdir()] == ["c.toml"]  # no temporary file left
