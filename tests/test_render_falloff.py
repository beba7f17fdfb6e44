"""Radiometric falloff (issue 50, docs/model.md §10 "Radiometric falloff", docs/render.md):
``splitlf.render(..., falloff=...)`` weights each ray by cos^4 of its microlens-to-sensor
segment and/or its main-lens-to-array segment.

- A white raw with falloff against an independent plain-NumPy Gauss-Legendre quadrature
  of the weight over each pixel's rays (tests/falloff_reference.py), to the render's tol;
  brightest at each micro-image's centre.
- Textured scenes and a hexagonal design behind a circular aperture against the
  Monte-Carlo renderer with the same weight (tests/mc_render.py), in z-scores as
  tests/test_render_accuracy.py takes them.
- Falloff off gives the raws the build before falloff existed gave, bit for bit
  (tests/data/falloff_off_pinned.npz: rendered at bc2b7d9 by the main checkout's build;
  :func:`pinned_cases` makes them; a deliberate change of the render re-pins them: the
  seed's tilted sinusoid was re-pinned when the general route began to cut a sinusoid at
  its quarter periods, 2026-11-30, which moved it by 1.2e-6 and 8.5e-4 at tol 1e-2; and on
  2026-12-01, when a pixel's square began to be built from its edges, each from its own
  index (docs/render.md, "A memo of the corners"): 2.9e-15 at most; the Illum's pin then
  too, by the quadrature's fix of a cap at the circle's top or bottom, 1.0e-4 at tol 1e-2). The
  Illum's image on a fronto-parallel plane now takes the closed form for a lens's
  interior boxes (docs/render.md, "The interior in closed form"): its pin is the
  quadrature's raw (``_native.render_quadrature``) bit for bit, and the render's within
  its tol.
- The option's checks, Raw.falloff saved and loaded, bands on an executor, the CLI flag.
"""

from __future__ import annotations

import concurrent.futures as cf
from pathlib import Path

import numpy as np
import pytest
from _cli import run_cli
from falloff_reference import white_pixel
from mc_render import mc_pixels, scene
from test_render_accuracy import (
    NATIVE_ERR,
    assert_agree,
    image_texture,
    sample_pixels,
    view_width,
    z_stats,
)

import splitlf
from splitlf import _native
from splitlf.errors import InvalidParameter
from splitlf.imaging.render import scene_parts

FALLOFFS = ("microlens", "main", "both")
PINNED = Path(__file__).parent / "data" / "falloff_off_pinned.npz"


def seed_cut(kx: int, ky: int) -> splitlf.Design:
    seed = splitlf.Design.preset("seed")
    return seed.replace(channels=tuple(c.replace(Kx=kx, Ky=ky) for c in seed.channels))


def illum_cut(k: int) -> splitlf.Design:
    """lytro-illum (hex cells, circular aperture, sensor layout) cut to k x k lenses."""
    d = splitlf.Design.preset("lytro-illum")
    return d.replace(channels=(d.channels[0].replace(Kx=k, Ky=k, Mx=None, My=None),))


PIXELS = [(7, 7), (22, 33), (0, 0), (44, 59), (20, 5), (37, 52), (30, 14), (8, 3)]


@pytest.mark.parametrize("falloff", FALLOFFS)
def test_white_against_quadrature(falloff: str) -> None:
    """The seed (4 x 3 lenses a half) under white at 1 m: every sampled pixel (centres,
    edges and corners of micro-images, vignetted ones of half 2) within tol of white of
    the independent quadrature, at tol 1e-3 and 1e-5."""
    d = seed_cut(4, 3)
    sc = splitlf.Scene(splitlf.Constant(1.0), 1000.0)
    refs = [np.array([white_pixel(d, ch, *p, falloff) for p in PIXELS]) for ch in (1, 2)]
    for tol in (1e-3, 1e-5):
        raw = splitlf.render(d, sc, falloff=falloff, tol=tol)
        assert raw.falloff == falloff
        for ch in (1, 2):
            got = np.array([raw.images[ch - 1][p] for p in PIXELS])
            err = np.abs(got - refs[ch - 1]).max() / 0.5
            assert err <= tol, (falloff, tol, ch, err)
    # the weight is felt: below the paraxial white (1/2) on a fully lit pixel
    assert refs[0][1] < 0.5 - 1e-3


def test_white_is_brightest_at_the_micro_image_centre() -> None:
    """A white raw with falloff falls off from each micro-image's centre to its edges,
    along both axes (the peer's peak detector needs that), and is symmetric about it on
    the lens on the axis; without falloff it is flat."""
    d = seed_cut(3, 3)
    sc = splitlf.Scene(splitlf.Constant(1.0), 1000.0)
    flat = splitlf.render(d, sc).images[0]
    img = splitlf.render(d, sc, falloff="both").images[0]
    np.testing.assert_allclose(flat[15:30, 15:30], 0.5, rtol=0, atol=1e-12)
    block = img[15:30, 15:30]  # the centre lens's image (Q = 15)
    row, col = block[7], block[:, 7]
    for line in (row, col):
        assert np.all(np.diff(line[:8]) > 0) and np.all(np.diff(line[7:]) < 0), line
        np.testing.assert_allclose(line, line[::-1], rtol=0, atol=1e-9)
    assert block.argmax() == 7 * 15 + 7


def test_mc_seed_image() -> None:
    """The seed (3 x 2 lenses a half), a random image on the fronto plane at 1 m, both
    factors: within a few standard errors of the Monte-Carlo renderer with the same weight,
    on both halves (measured at 30 pixels and 200,000 rays a half: |z| <= 2.1, mean z^2
    0.86-0.88, largest difference 1.1e-3 of white at a standard error of 9e-4)."""
    d = seed_cut(3, 2)
    z = 1000.0
    rng = np.random.default_rng(3)
    image = rng.random((24, 30))
    api, tex = image_texture(image, 0.8 * view_width(d, z))
    raw = splitlf.render(d, splitlf.Scene(api, z, background=0.3), falloff="both")
    ref = scene(tex, ("plane", [z, 0.0, 0.0]), 0.3)
    for i in (1, 2):
        a = raw.images[i - 1]
        pixels = sample_pixels(a.shape, 20, rng, a)
        mean, se = mc_pixels(d, i, pixels, ref, 100_000, 20, rng, falloff="both")
        value = np.array([a[p] for p in pixels])
        assert_agree(z_stats(value, mean, se, 0.5, NATIVE_ERR), f"seed image, half {i}")


def test_mc_illum_white() -> None:
    """lytro-illum cut to 4 x 4 lenses (hex, circular aperture, sensor layout) under white
    at 500 mm, each factor alone and both: against the Monte-Carlo renderer with the same
    weight; and each lens's image is brightest near its centre (the issue's white image)."""
    d = illum_cut(4)
    sc = splitlf.Scene(splitlf.Constant(1.0), 500.0)
    ref = scene(("constant", [1.0]), ("plane", [500.0, 0.0, 0.0]), 1.0)
    rng = np.random.default_rng(11)
    for falloff in FALLOFFS:
        a = splitlf.render(d, sc, falloff=falloff).images[0]
        pixels = sample_pixels(a.shape, 20, rng, a)
        mean, se = mc_pixels(d, 1, pixels, ref, 100_000, 20, rng, falloff=falloff)
        value = np.array([a[p] for p in pixels])
        assert_agree(z_stats(value, mean, se, 1.0, NATIVE_ERR), f"illum white, {falloff}")
    flat = splitlf.render(d, sc).images[0]
    both = a / np.where(flat > 0, flat, 1.0)
    lit = flat > 0.5 * flat.max()
    # the ratio to the paraxial raw is largest where a ray's segments are shortest
    assert both[lit].max() - both[lit].min() > 0.05
    assert both[lit].max() <= 1.0 + 1e-9


def test_mc_illum_image() -> None:
    """lytro-illum cut to 4 x 4 lenses, a random image on the plane at 500 mm, both
    factors, against the Monte-Carlo renderer (measured: |z| <= 2.7, largest difference
    1.9e-3 of white at se 1.2e-3). Slow tier (the render takes about 26 s on 2 threads)."""
    d = illum_cut(4)
    z = 500.0
    rng = np.random.default_rng(3)
    image = rng.random((24, 30))
    api, tex = image_texture(image, 0.8 * view_width(d, z))
    a = splitlf.render(d, splitlf.Scene(api, z, background=0.3), falloff="both").images[0]
    ref = scene(tex, ("plane", [z, 0.0, 0.0]), 0.3)
    pixels = sample_pixels(a.shape, 30, rng, a)
    mean, se = mc_pixels(d, 1, pixels, ref, 200_000, 20, rng, falloff="both")
    value = np.array([a[p] for p in pixels])
    assert_agree(z_stats(value, mean, se, 1.0, NATIVE_ERR), "illum image")


def pinned_cases():
    """(name, design, scene, tol) of the pinned falloff-off raws: the exact route (the seed,
    an image at 1 m), the general route on a tilted plane (a sinusoid) and on a hex design
    behind a circular aperture (lytro-illum, an image at 500 mm)."""
    s = seed_cut(3, 2)
    img = np.random.default_rng(50).random((20, 24))
    yield "seed_image", s, splitlf.Scene(splitlf.Image(img, 6.0), 1000.0, background=0.3), None
    sin = splitlf.Sinusoid(0.7, mean=0.5, amplitude=0.4, phase=0.3)
    tilted = splitlf.Scene(sin, splitlf.Plane(900.0, 0.05, -0.02), background=0.5)
    yield "seed_tilted", s, tilted, 1e-2
    il = illum_cut(3)
    yield "illum_image", il, splitlf.Scene(splitlf.Image(img, 4.0), 500.0, background=0.3), 1e-2


def test_falloff_off_is_the_previous_raw() -> None:
    """Falloff off (None, the default) renders the raws of the build before it, bit for
    bit, on both routes."""
    want = np.load(PINNED)
    seen = set()
    for name, d, sc, tol in pinned_cases():
        closed = name == "illum_image"  # a fronto-parallel image on the general route
        for raw in (splitlf.render(d, sc, tol=tol), splitlf.render(d, sc, tol=tol, falloff=None)):
            assert raw.falloff is None
            for i, a in enumerate(raw.images, 1):
                key = f"{name}_{i}"
                if closed:
                    # (The Illum's white is about 1: within tol of white.)
                    assert np.abs(a - want[key]).max() <= tol, key
                    native = _native.RenderScene(*scene_parts(sc, d, np.random.default_rng(0)))
                    a = _native.render_quadrature(d.core, native, tol)[i - 1]
                assert np.array_equal(a, want[key]), (key, np.abs(a - want[key]).max())
                seen.add(key)
    assert seen == set(want.files)


def test_falloff_checks() -> None:
    """A falloff that is not None or a string is a TypeError, an unknown name an
    InvalidParameter naming falloff, in render and in Raw."""
    d = seed_cut(2, 2)
    sc = splitlf.Scene(splitlf.Constant(1.0), 1000.0)
    with pytest.raises(TypeError, match="falloff"):
        splitlf.render(d, sc, falloff=1)  # type: ignore[arg-type]
    for bad in ("cos4", "none", "Both", ""):
        with pytest.raises(InvalidParameter, match="falloff") as e:
            splitlf.render(d, sc, falloff=bad)
        assert e.value.name == "falloff"
    raw = splitlf.render(d, sc)
    with pytest.raises(InvalidParameter, match="falloff"):
        splitlf.Raw(d, raw.images, falloff="cos4")
    # the binding refuses an unknown name too, naming it
    with pytest.raises(InvalidParameter, match="falloff"):
        splitlf._native.render(d.core, splitlf.imaging.render.native_scene(
            sc, d, np.random.default_rng(0)), falloff="cos4")


def test_raw_keeps_its_falloff(tmp_path: Path) -> None:
    """Raw.save and Raw.load keep the falloff; a file without it (as before it existed)
    loads as None; a bad value in the file is refused naming the key."""
    d = seed_cut(2, 2)
    sc = splitlf.Scene(splitlf.Constant(1.0), 1000.0)
    raw = splitlf.render(d, sc, falloff="microlens")
    raw.save(tmp_path / "r.npz")
    back = splitlf.Raw.load(tmp_path / "r.npz")
    assert back.falloff == "microlens" and "falloff microlens" in repr(back)
    assert all(np.array_equal(a, b) for a, b in zip(raw.images, back.images, strict=True))
    off = splitlf.render(d, sc)
    off.save(tmp_path / "o.npz")
    assert "falloff" not in np.load(tmp_path / "o.npz").files
    assert splitlf.Raw.load(tmp_path / "o.npz").falloff is None
    arrays = dict(np.load(tmp_path / "r.npz"))
    arrays["falloff"] = np.array("cos4")
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(ValueError, match="falloff"):
        splitlf.Raw.load(tmp_path / "bad.npz")


def test_bands_on_an_executor_keep_the_falloff() -> None:
    """A render with falloff cut into bands on a thread pool is the in-process one bit for
    bit (the bands carry the falloff)."""
    d = seed_cut(2, 2)
    sc = splitlf.Scene(splitlf.Constant(0.8), 900.0)
    here = splitlf.render(d, sc, falloff="both", tol=1e-2)
    with cf.ThreadPoolExecutor(2) as pool:
        split = splitlf.render(d, sc, falloff="both", tol=1e-2, executor=pool,
                               rows_per_task=7)
    assert split.falloff == "both"
    assert all(np.array_equal(a, b) for a, b in zip(here.images, split.images, strict=True))
    plain = splitlf.render(d, sc, tol=1e-2)
    assert not np.array_equal(plain.images[0], here.images[0])


def test_cli_falloff(tmp_path: Path, capsys) -> None:
    """``splitlf render --falloff microlens`` writes the raw render(falloff="microlens")
    makes, recorded in the file; an unknown value is refused by the parser."""
    d = seed_cut(2, 2)
    toml = tmp_path / "d.toml"
    toml.write_text(d.to_toml())
    np.save(tmp_path / "white.npy", np.ones((4, 4)))
    out = tmp_path / "r.npz"
    args = ["render", str(toml), "--texture", str(tmp_path / "white.npy"), "--width", "50",
            "--depth", "1000", "-o", str(out)]
    code, _, _ = run_cli([*args, "--falloff", "microlens"], capsys)
    assert code == 0
    raw = splitlf.Raw.load(out)
    assert raw.falloff == "microlens"
    white = splitlf.Scene(splitlf.Image(np.ones((4, 4)), 50.0), 1000.0)
    want = splitlf.render(d, white, falloff="microlens")
    assert all(np.array_equal(a, b) for a, b in zip(raw.images, want.images, strict=True))
    code, _, err = run_cli([*args, "--falloff", "cos4", "--force"], capsys)
    assert code == 2 and "--falloff" in err
