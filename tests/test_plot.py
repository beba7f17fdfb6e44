"""Figures: each takes ax=None, returns the Axes, draws computed data, picks no backend."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

import splitlf
from splitlf import Camera, plot

matplotlib.use("Agg")  # the tests choose the backend; the library never does


def test_blur_figure_draws_the_curves():
    cam = Camera.paper()
    ax = plot.blur(cam, (150.0, 5000.0), n=500)
    lines = ax.get_lines()
    solid = [ln for ln in lines if ln.get_label() == "light field, array 1"][0]
    z, y = solid.get_data()
    np.testing.assert_allclose(y, splitlf.curves(cam, z).blur_px[0], rtol=1e-15)
    # the peak (bounded blur R_1 = 7.5 px) is drawn at the out-of-focus plane
    assert y.max() == pytest.approx(7.5, rel=1e-9)
    assert ax.get_xscale() == "log"


def test_repetitions_figure_on_given_axes():
    import matplotlib.pyplot as plt

    backend = matplotlib.get_backend()
    fig, ax = plt.subplots()
    out = plot.repetitions(Camera.paper(), ax=ax)
    assert out is ax and matplotlib.get_backend() == backend
    z, y = ax.get_lines()[1].get_data()
    np.testing.assert_allclose(y, splitlf.curves(Camera.paper(), z).repetitions[1], rtol=1e-15)
    plt.close(fig)


@pytest.mark.parametrize("fn", [plot.blur, plot.repetitions])
def test_bad_range(fn):
    with pytest.raises(ValueError, match="z_range"):
        fn(Camera.paper(), (50.0, 1000.0))
    with pytest.raises(TypeError, match="camera"):
        fn("seed")


def test_threads_reach_the_core(monkeypatch):
    from matplotlib.figure import Figure

    import splitlf.sampling.rayspace as rs

    cam = Camera.paper()
    ax = plot.blur(cam, (150.0, 5000.0), n=200, ax=Figure().add_subplot(), n_threads=1)
    z, y = ax.get_lines()[0].get_data()
    np.testing.assert_array_equal(y, splitlf.curves(cam, z).blur_px[0])
    real, seen = rs.trace, []

    def trace(camera, half=None, axis="x", n_threads=None, *, channel=None):
        seen.append(n_threads)
        return real(camera, half, axis, channel=channel)

    monkeypatch.setattr(rs, "trace", trace)
    plot.ray_space(cam, ax=Figure().add_subplot(), n_threads=2)
    assert seen == [2, 2]


def test_bad_sizes():
    cam = Camera.paper()
    with pytest.raises(ValueError, match=r"invalid n = 10000000000: allowed an integer in"):
        plot.blur(cam, n=10**10)
    with pytest.raises(ValueError, match="threshold_px"):
        plot.blur(cam, threshold_px=float("nan"))
    with pytest.raises(ValueError, match="depths"):
        plot.ray_space(cam, depths=[50.0])
