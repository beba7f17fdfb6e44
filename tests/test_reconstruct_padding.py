"""reconstruct's padding on a tilted plane (docs/reconstruct.md step 2): where the
padding (a pixel's span beyond the region) would reach nearer than F, it is clipped at
PAD_NEAREST F instead of the region being refused; a region nearer than F is refused."""

from __future__ import annotations

import logging
import math
import re

import pytest

import splitlf
from splitlf.inverse.reconstruct import PAD_NEAREST


def test_padding_is_clipped_where_the_plane_comes_near_f(
        caplog: pytest.LogCaptureFixture) -> None:
    """The issue's case: Plane(600, 0, 52.1) over a region at 460-880 mm on the seed cut
    to 4 x 16 lenses, half 2 alone and the split sensor. Half 2's span at 460 mm is about
    22 mm, which would put the padding's bottom at a negative depth; the padded grid now
    stops where the plane is 1.1 F deep: its bottom padding is the whole cells of
    (460 mm - 1.1 F) / (52.1 mm per mm) less one (hand calculation), its top padding the
    full span."""
    seed = splitlf.Design.preset("seed")
    d = seed.replace(channels=tuple(c.replace(Kx=4, Ky=16) for c in seed.channels))
    p = splitlf.Plane(600.0, 0.0, 52.1)
    region = (-0.2, 0.2, (460.0 - 600.0) / 52.1, (880.0 - 600.0) / 52.1)
    raw = splitlf.render(d, splitlf.Scene(0.5, 1000.0))  # any raw: the map is the test
    step = 0.2
    for chans in ((2,), (1, 2)):
        caplog.clear()
        with caplog.at_level(logging.INFO, logger="splitlf.reconstruct"):
            r = splitlf.reconstruct(raw, p, region=region, step=step, channels=chans,
                                    regularization=4.0, progress=False)
        assert r.rows > 0 and r.image.shape == (41, 2)
        note = next(m for m in caplog.messages if "padded by" in m)
        pad, nx, ny = map(int, re.search(r"padded by (\d+) per side to (\d+) x (\d+)",
                                         note).groups())
        inner_y0 = r.extent[2]
        z_inner = p.z0 + p.gy * inner_y0
        bottom = math.floor((z_inner - PAD_NEAREST * d.F) / (p.gy * step) - 1.0)
        assert 0 < bottom < pad
        assert (nx, ny) == (2 + 2 * pad, 41 + pad + bottom), (note, bottom)
        # Its nearest cell is deeper than PAD_NEAREST F.
        assert p.z0 + p.gy * (inner_y0 - bottom * step) >= PAD_NEAREST * d.F


def test_region_nearer_than_f_is_refused() -> None:
    seed = splitlf.Design.preset("seed")
    d = seed.replace(channels=tuple(c.replace(Kx=4, Ky=16) for c in seed.channels))
    raw = splitlf.render(d, splitlf.Scene(0.5, 1000.0))
    p = splitlf.Plane(600.0, 0.0, 52.1)
    near = (-0.2, 0.2, (70.0 - 600.0) / 52.1, 0.0)  # 70 mm < F at its bottom
    with pytest.raises(splitlf.errors.InvalidParameter, match="F = 80") as e:
        splitlf.reconstruct(raw, p, region=near, step=0.2, channels=(2,), progress=False)
    assert e.value.name == "depth"
