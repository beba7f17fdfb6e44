"""Designs and depths at the edges of the floating-point range, through the public API:
finite, consistent results, or a named error (never inf/NaN passed on as an answer)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import splitlf

P = splitlf.Camera.paper()
HUGE = np.array([1e307, 1.7976931348623157e308])


def test_conjugate_of_huge_depths_tends_to_f():
    c = splitlf.curves(P, HUGE)
    np.testing.assert_allclose(c.conjugate, P.F, rtol=0, atol=1e-12)
    limit = splitlf.curves(P, [1e30])
    for name in ("main_blur", "repetitions", "microlens_blur", "blur_px", "conventional_px"):
        got = getattr(c, name)
        assert np.isfinite(got).all(), name
        np.testing.assert_allclose(got, np.repeat(getattr(limit, name), 2, axis=1),
                                   rtol=1e-9, err_msg=name)


@pytest.mark.parametrize("sample", ["chief", "centroid"])
def test_samples_at_huge_depths_equal_those_far_away(sample):
    s = splitlf.new_samples(P, HUGE, sample=sample)
    far = splitlf.new_samples(P, [1e12], sample=sample)
    assert (s.distinct[2] >= s.distinct[:2].max(axis=0)).all()
    np.testing.assert_array_equal(s.distinct, np.repeat(far.distinct, 2, axis=1))


@pytest.mark.parametrize("sample", ["chief", "centroid"])
def test_footprints_at_huge_depths_are_finite(sample):
    fp = splitlf.footprints(P, HUGE, 1, sample=sample)
    for a in (fp.position, fp.lo, fp.hi):
        assert np.isfinite(a).all()


@pytest.mark.parametrize("field, value", [("v", 5e-324), ("d", 1e-320), ("mu", 4e-310),
                                          ("D", 1e-315)])
def test_subnormal_lengths_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        P.replace(**{field: value})


def test_derived_focal_length_is_validated_like_a_given_one():
    # An explicit f <= 0 is refused; so is a derived one that would overflow the formulas.
    with pytest.raises(ValueError):
        P.replace(D=1e200, v1=1e200)


# D = 0.1 with F = 1e-300: with the seed's D = 20 the microlens images overlap (refused).
@pytest.mark.parametrize("changes", [{"v1": 1e300}, {"F": 1e-300, "v1": 1.0, "D": 0.1}])
def test_depth_of_field_has_no_empty_interval(changes):
    cam = P.replace(**changes)
    for t in (1e-3, 0.5, 7.0):
        dof = splitlf.depth_of_field(cam, threshold_px=t)
        for name in ("half1", "half2", "split", "conventional1", "conventional2"):
            for lo, hi in getattr(dof, name):
                assert lo < hi, (name, lo, hi, t)


def test_boundary_contacts_are_not_lit():
    # Half 2's polygons touch the aperture strip in ten pixels: exact area 0, computed
    # ~5e-16 of a full pixel. The rule of docs/model.md §9 ("Lit by area") drops them.
    cam = splitlf.Camera(F=40.0, D=10.0, v1=45.0, kappa=0.2, d=0.1, v=0.45, mu=0.1 / 12, Q=12,
                         Kx=8, Ky=4)
    for half in (1, 2):
        tr = splitlf.trace(cam, half)
        biggest = tr.area.max()
        assert ((tr.area == 0) | (tr.area >= 1e-9 * biggest)).all()
        assert (np.isnan(tr.centroid[:, 0]) == (tr.area == 0)).all()
    s = splitlf.new_samples(cam, [100.0], sample="centroid")
    lit_x = [int((splitlf.trace(cam, h).area > 0).sum()) for h in (1, 2)]
    assert list(s.sampled[:2]) == lit_x
    assert not any(math.isnan(v) for v in s.max_gap.ravel() if not math.isinf(v))
