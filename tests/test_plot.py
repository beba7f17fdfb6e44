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
