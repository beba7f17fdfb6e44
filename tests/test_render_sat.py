"""The general route's boxes in closed form (docs/render.md, "The interior in closed
form"): on a fronto-parallel plane with an image or constant texture, a lens's boxes whose
polygon of rays is one polygon moving by translation are integrated from the texture's
summed areas instead of by the adaptive quadrature.

References: ``_native.render_quadrature``, the same render with every box by the
quadrature (the build before the closed form bit for bit: tests/test_render_falloff.py's
pinned Illum raw), and the Monte-Carlo renderer (tests/test_render_accuracy.py,
``test_mc_closed_form_interior``). The closed form itself is checked against an
independent sum in the core (``sat::tests``) and against the quadrature at tol 1e-10 on
three designs (``interior::tests``).
"""

from __future__ import annotations

import numpy as np
import pytest
from mc_render import scene
from test_render_accuracy import check_mc, image_texture

import splitlf
from splitlf import _native
from splitlf.imaging.render import scene_parts

Z = 1000.0


def cut(name: str, kx: int, ky: int) -> splitlf.Design:
    """The preset cut to kx x ky lenses (a sensor layout's grid shrunk to fit)."""
    d = splitlf.Design.preset(name)
    chs = tuple(ch.replace(Kx=kx, Ky=ky, Mx=None, My=None) if ch.layout == "sensor"
                else ch.replace(Kx=kx, Ky=ky) for ch in d.channels)
    return d.replace(channels=chs)


def rect_sensor() -> splitlf.Design:
    """Rect cells behind a square aperture on a sensor layout, two defocused lens types
    (the general route on rect cells: the square preimage inside the cell, and the cell
    inside it)."""
    seed = splitlf.Design.preset("seed")
    s1 = seed.channels[0]
    ch = splitlf.Channel(L=s1.L, d=s1.d, v=s1.v, mu=s1.mu, Kx=5, Ky=4, f=(0.55, 0.7),
                         layout="sensor")
    return splitlf.Design(seed.F, seed.D, (ch,))


DESIGNS = {
    "r12": lambda: cut("raytrix-r12", 3, 3),
    "illum": lambda: cut("lytro-illum", 5, 4),
    "rect_sensor": rect_sensor,
}


def native(design: splitlf.Design, scene: splitlf.Scene) -> _native.RenderScene:
    return _native.RenderScene(*scene_parts(scene, design, np.random.default_rng(0)))


def photo(design: splitlf.Design, n: int, seed: int) -> splitlf.Scene:
    """A random n x n image over the design's view at Z (wider than the view: some rays
    see the mean beyond it)."""
    x0, x1, y0, y1 = (float(v) for v in _native.render_extent(design.core, Z))
    img = np.random.default_rng(seed).random((n, n))
    return splitlf.Scene(splitlf.Image(img, width=0.8 * max(x1 - x0, y1 - y0)), Z)


def white_of(design: splitlf.Design) -> float:
    return max(float(a.max()) for a in splitlf.render(design, splitlf.Scene(1.0, Z)).images)


@pytest.mark.parametrize("name", sorted(DESIGNS))
@pytest.mark.parametrize("n", [16, 128, 512])
def test_closed_form_is_the_quadrature_to_tol(name: str, n: int) -> None:
    """The default render (closed form) and the quadrature alone, both at tol 1e-3,
    agree to 1e-3 of white on every pixel; the closed form changed some pixels (it was
    taken)."""
    d = DESIGNS[name]()
    sc = native(d, photo(d, n, n))
    new = _native.render(d.core, sc, tol=1e-3)
    old = _native.render_quadrature(d.core, sc, 1e-3)
    w = white_of(d)
    diff = max(float(np.abs(a - b).max()) for a, b in zip(new, old, strict=True)) / w
    changed = sum(int((a != b).sum()) for a, b in zip(new, old, strict=True))
    print(name, n, diff, changed)
    assert diff <= 1e-3
    assert changed > 0


def worst(design: splitlf.Design, scene: splitlf.Scene, tol: float) -> float:
    """The largest difference of the closed form's raw and the quadrature's at tol, of
    white."""
    core = native(design, scene)
    new = _native.render(design.core, core, tol=tol)
    old = _native.render_quadrature(design.core, core, tol)
    diff = max(float(np.abs(a - b).max()) for a, b in zip(new, old, strict=True))
    return diff / white_of(design)


def test_closed_form_at_a_tight_tolerance() -> None:
    """Rect cells behind a square aperture (the quadrature exact between its cuts, at any
    tol): a 16 x 16 image and a constant agree to 1e-12 of white at tol 1e-10 (measured
    7e-14). The Illum (hex cells, a disc): a constant to 1e-9 at tol 1e-7 (measured
    1.05e-10 since the lens images' rims, the boxes the aperture's circle cuts, take the
    closed form too: exact for a constant, where the quadrature's rims carry its own
    residual; 3e-12 when both took the rims by the quadrature); an image to 1e-6 at tol
    1e-8 (measured 3.2e-7; 2.1e-6 at tol 1e-6 and 1e-7,
    where the quadrature, not the closed form, misses its target: the closed form's value
    stays put while the quadrature's moves toward it as tol falls)."""
    d = DESIGNS["rect_sensor"]()
    for sc in (photo(d, 16, 3), splitlf.Scene(splitlf.Constant(0.7), Z)):
        assert worst(d, sc, 1e-10) <= 1e-12
    d = DESIGNS["illum"]()
    assert worst(d, splitlf.Scene(splitlf.Constant(0.7), Z), 1e-7) <= 1e-9
    assert worst(d, photo(d, 16, 3), 1e-8) <= 1e-6


def test_constant_is_its_albedo_times_white() -> None:
    """A constant's closed form is its albedo times white's: to 1e-13 of white."""
    d = DESIGNS["illum"]()
    w = splitlf.render(d, splitlf.Scene(1.0, Z)).images[0]
    c = splitlf.render(d, splitlf.Scene(splitlf.Constant(0.35), Z)).images[0]
    assert np.abs(c - 0.35 * w).max() <= 1e-13 * w.max()


def test_other_scenes_are_the_quadrature_bit_for_bit() -> None:
    """Where the closed form does not apply (a sinusoid, a slanted plane, falloff on) the
    render is the quadrature's raw bit for bit."""
    d = DESIGNS["illum"]()
    img = splitlf.Image(np.random.default_rng(5).random((12, 12)), width=40.0)
    scenes = [splitlf.Scene(splitlf.Sinusoid(0.3, mean=0.5, amplitude=0.3), Z),
              splitlf.Scene(img, splitlf.Plane(Z, 0.05, -0.02), background=0.4)]
    for sc in scenes:
        core = native(d, sc)
        new = _native.render(d.core, core, tol=1e-2)
        old = _native.render_quadrature(d.core, core, 1e-2)
        assert all(np.array_equal(a, b) for a, b in zip(new, old, strict=True))


def test_mc_closed_form_interior() -> None:
    """Against the Monte-Carlo renderer (tests/mc_render.py, z-scores as in
    tests/test_render_accuracy.py): the Illum cut to 4 x 4 lenses (hex cells, a disc, the
    sensor layout; most of its pixels take the closed form) and raytrix-r12 cut to 3 x 3,
    random images at 1 m."""
    for d, n, seed in ((cut("lytro-illum", 4, 4), 48, 61), (cut("raytrix-r12", 3, 3), 128, 62)):
        x0, x1, y0, y1 = (float(v) for v in _native.render_extent(d.core, Z))
        width = 0.8 * max(x1 - x0, y1 - y0)
        img = np.random.default_rng(seed).random((n, n))
        api, tex = image_texture(img, width)
        raws = splitlf.render(d, splitlf.Scene(api, Z, background=0.3)).images
        check_mc(d, raws, scene(tex, ("plane", [Z, 0.0, 0.0]), 0.3), 20, seed,
                 f"closed form, {d.channels[0].Kx} x {d.channels[0].Ky} lenses",
                 n_rays=100_000)
