"""Accuracy of ``splitlf.render`` (issue 21, docs/model.md §10) against two independent
references written from §9-§10 in plain NumPy: tests/exact_render.py (polygon clipping,
the exact route) and tests/mc_render.py (a Monte-Carlo renderer with standard errors from
independent batches).

- Exact route (fronto-parallel plane, rect grid, square aperture, ideal layout, image
  texture): equal to the clipping sums to 1e-12 of a fully lit white pixel.
- White: 1/2 on every fully lit pixel of the seed's two halves, the clipped measure on the
  vignetted ones.
- Every other family (slanted planes, depth maps, hex cells with three lens types and a
  circular aperture in the sensor layout where lens images spill onto the neighbours'
  pixels, a rect sensor layout, edge and star textures, several channels): Monte-Carlo
  z-scores on 20-30 sampled pixels per channel. Per pixel z = (native - MC) /
  sqrt(se^2 + e^2), se the MC's standard error (from 20 batch means, so z follows Student's
  t with 19 degrees of freedom) and e = 2e-4 of white, an allowance for the native's own
  quadrature error (its stated bound is 1e-3 of white). On every pixel |z| stays below the
  Bonferroni bound of the t law (false alarm 1e-3 per family: about 5.4 for 30 pixels);
  the mean of z^2 stays below E t^2 = 19/17 plus four of its standard deviations; and
  |native - MC| <= 1e-3 white + (that bound) se.
- Orientation: a bright square in the texture's upper-left quadrant (X < 0, Y > 0) lands
  where the geometry puts it (the main lens inverts: lens centres c with c_x > 0, c_y < 0,
  i.e. high raw columns and low raw rows); a flipped or transposed raw fails the check.

The self-consistency tests (MC against the exact reference, the depth-map solver against
the plane) need no native render and hold on their own.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from exact_render import exact_raw, exact_raw_x, exact_white, view_extent
from mc_render import mc_channel, mc_pixels, scene
from scipy import stats

import splitlf
from splitlf.inverse.depth import _own_lens_whites, _white, _white_scene

FAMILY_ALPHA = 1e-3  # false-alarm probability of one family's z-score bound
NATIVE_ERR = 2e-4  # of white: the native's own error that a z-score should not punish
ABS_TOL = 1e-3  # of white: the stated accuracy of the 4-D route
EXACT_TOL = 1e-12  # of white: the exact route


def seed_small(kx: int = 8, ky: int = 6) -> splitlf.Design:
    """The seed (docs/model.md §7) with fewer lenses: both halves, share 1/2 each."""
    seed = splitlf.Design.preset("seed")
    return seed.replace(channels=tuple(ch.replace(Kx=kx, Ky=ky) for ch in seed.channels))


def r12_small() -> splitlf.Design:
    """raytrix-r12 (hex, three lens types, circular aperture, sensor layout) with 12 x 10
    lenses and the default sensor grid that covers them."""
    r12 = splitlf.Design.preset("raytrix-r12")
    ch = r12.channels[0].replace(Kx=12, Ky=10, Mx=None, My=None)
    return r12.replace(channels=(ch,))


def rect_two() -> splitlf.Design:
    """Two rect channels: a sensor layout with two defocused lens types (their images
    spill onto the neighbours' pixels) and an ideal layout with two lens types."""
    seed = splitlf.Design.preset("seed")
    s1, s2 = seed.channels
    ch1 = splitlf.Channel(L=s1.L, d=s1.d, v=s1.v, mu=s1.mu, Kx=8, Ky=7, f=(0.55, 0.7),
                          layout="sensor", share=0.6)
    ch2 = splitlf.Channel(L=s2.L, d=s2.d, v=s2.v, mu=s2.mu, Kx=7, Ky=6, f=(0.6, 0.65),
                          Q=15, share=0.4)
    return splitlf.Design(seed.F, seed.D, (ch1, ch2))


def white(design: splitlf.Design, channel: int) -> float:
    """A fully lit white pixel of pitch mu_1 on plane L_1: the channel's share."""
    return design.resolved()[channel - 1]["share"]


def render(design: splitlf.Design, texture, depth, background: float) -> tuple:
    raw = splitlf.render(design, splitlf.Scene(texture, depth, background=background))
    return raw.images


def image_texture(array: np.ndarray, width: float) -> tuple:
    """(API texture, reference texture) of an image ``width`` mm wide centred on the axis."""
    rows, cols = array.shape
    h = width * rows / cols
    return splitlf.Image(array, width), ("image", [-width / 2, width / 2, -h / 2, h / 2],
                                         array)


def view_width(design: splitlf.Design, z: float) -> float:
    """The widest extent (mm, either axis) seen on the plane at z by any ideal-layout
    channel of the design, else a generous bound from the array size."""
    out = 0.0
    for i, ch in enumerate(design.resolved(), 1):
        if ch["layout"] == "ideal" and ch["grid"] == "rect":
            e = view_extent(design, i, z)
            out = max(out, e[1] - e[0], e[3] - e[2])
        else:
            # lens centres within the array, their samples spread by the main-lens blur
            zc = design.F * z / (z - design.F)
            half = (max(ch["Kx"], ch["Ky"]) + 2) * ch["d"] / 2
            blur = design.D / 2 * abs(ch["L"] - zc) / zc
            out = max(out, 2 * z / ch["L"] * (half + blur))
    return out


def sample_pixels(shape: tuple[int, int], n: int, rng: np.random.Generator,
                  values: np.ndarray | None = None) -> list[tuple[int, int]]:
    """n distinct pixels, three quarters of them (when ``values`` is given) among those
    with light."""
    rows, cols = shape
    allpix = np.arange(rows * cols)
    if values is not None:
        lit = allpix[values.ravel() > 0]
        k = min(lit.size, (3 * n) // 4)
        chosen = set(rng.choice(lit, k, replace=False).tolist())
        rest = np.setdiff1d(allpix, np.fromiter(chosen, dtype=np.int64))
        chosen |= set(rng.choice(rest, n - k, replace=False).tolist())
    else:
        chosen = set(rng.choice(allpix, n, replace=False).tolist())
    return [(int(p) // cols, int(p) % cols) for p in sorted(chosen)]


def z_bound(n: int, n_batches: int) -> float:
    """The per-pixel |z| bound of n pixels: the standard error comes from n_batches batch
    means, so z has Student's t law with n_batches - 1 degrees of freedom; Bonferroni over
    the n pixels at FAMILY_ALPHA (20 batches: 5.4 for 30 pixels, 5.7 for 60; the normal
    law's 4.2-4.3 would give false alarms at the t law's heavier tails)."""
    return float(stats.t.ppf(1.0 - FAMILY_ALPHA / (2.0 * max(n, 1)), n_batches - 1))


def mean_z2_bound(n: int, n_batches: int) -> float:
    """Upper bound of the mean of n squared t-scores (nu = n_batches - 1 degrees of
    freedom): E t^2 = nu/(nu - 2) plus four standard deviations of the mean,
    Var t^2 = 2 nu^2 (nu - 1) / ((nu - 2)^2 (nu - 4))."""
    nu = n_batches - 1.0
    var = 2.0 * nu * nu * (nu - 1.0) / ((nu - 2.0) ** 2 * (nu - 4.0))
    return nu / (nu - 2.0) + 4.0 * math.sqrt(var / max(n, 1))


def z_stats(value: np.ndarray, mean: np.ndarray, se: np.ndarray, w: float,
            allowance: float, n_batches: int = 20) -> dict[str, float]:
    """Agreement figures of ``value`` against MC estimates (mean, se from n_batches
    batches), w the channel's white."""
    diff = value - mean
    scale = np.sqrt(se ** 2 + (allowance * w) ** 2)
    # z only where the MC has an error: an integrand constant over a pixel's rays (white,
    # a uniform patch) gives se = 0 and an estimate exact up to rounding, checked by the
    # absolute bound alone
    noisy = scale > 1e-9 * w
    z = diff[noisy] / scale[noisy]
    zmax = z_bound(value.size, n_batches)
    return {"n": float(value.size), "n_noisy": float(noisy.sum()),
            "max_z": float(np.max(np.abs(z), initial=0.0)), "z_bound": zmax,
            "mean_z2": float(np.mean(z ** 2)) if noisy.any() else 0.0,
            "mean_z2_bound": mean_z2_bound(int(noisy.sum()), n_batches),
            "max_diff": float(np.max(np.abs(diff))) / w,
            "max_excess": float(np.max(np.abs(diff) - zmax * se)) / w,
            "max_se": float(np.max(se)) / w, "median_se": float(np.median(se)) / w}


def assert_agree(stats: dict[str, float], what: str) -> None:
    """|z| below the Bonferroni t bound on every pixel, the mean of z^2 below its bound,
    |native - MC| <= 1e-3 white + z_bound se (figures in units of white)."""
    print(what, {k: round(v, 6) for k, v in stats.items()})
    assert stats["max_z"] < stats["z_bound"], (what, stats)
    assert stats["mean_z2"] <= stats["mean_z2_bound"], (what, stats)
    assert stats["max_excess"] <= ABS_TOL, (what, stats)


def check_mc(design: splitlf.Design, raws: tuple, ref_scene: dict, n_pixels: int,
             seed: int, what: str, n_rays: int = 200_000, n_batches: int = 20) -> None:
    """The native raws of every channel against the MC renderer on sampled pixels."""
    rng = np.random.default_rng(seed)
    for i, ch in enumerate(design.resolved(), 1):
        raw = np.asarray(raws[i - 1])
        shape = ((ch["Ky"] * ch["Q"], ch["Kx"] * ch["Q"]) if ch["layout"] == "ideal"
                 else (ch["My"], ch["Mx"]))
        assert raw.shape == shape, (what, i, raw.shape, shape)
        pixels = sample_pixels(shape, n_pixels, rng, raw)
        mean, se = mc_pixels(design, i, pixels, ref_scene, n_rays, n_batches, rng)
        value = np.array([raw[p] for p in pixels])
        assert_agree(z_stats(value, mean, se, white(design, i), NATIVE_ERR, n_batches),
                     f"{what}, channel {i}")


# -- the references against each other (valid without the native render) ------------------


def _random_image_scene(z: float, seed: int) -> tuple:
    """(design, rng, image, texture, scene): the small seed looking at a random 18 x 24
    image over 0.8 of its view on the fronto-parallel plane at z."""
    design = seed_small()
    rng = np.random.default_rng(seed)
    image = rng.random((18, 24))
    _, tex = image_texture(image, 0.8 * view_width(design, z))
    return design, rng, image, tex, scene(tex, ("plane", [z, 0.0, 0.0]), 0.3)


@pytest.mark.parametrize("z", [217.0, 642.0, 1000.0])
def test_mc_matches_exact_reference(z: float) -> None:
    """The MC renderer and the clipping sums agree in z-score on the seed's exact route
    (vignetted pixels of half 2 included), and the MC's errors are honest (mean z^2 is
    neither much above nor much below 1)."""
    design, rng, image, tex, ref_scene = _random_image_scene(z, int(z))
    for i in (1, 2):
        exact = exact_raw(design, i, z, image, tuple(tex[1]))
        pixels = sample_pixels(exact.shape, 40, rng, exact)
        mean, se = mc_pixels(design, i, pixels, ref_scene, 100_000, 20, rng)
        stats = z_stats(np.array([exact[p] for p in pixels]), mean, se, 0.5, 0.0)
        assert_agree(stats, f"MC vs exact, z = {z}, channel {i}")
        n = stats["n_noisy"]
        assert n >= 20
        # honest errors: not inflated either (the lower tail of the same bound)
        assert stats["mean_z2"] >= 2 * 19 / 17 - stats["mean_z2_bound"], stats


@pytest.mark.parametrize("z", [642.0, 1000.0])
def test_mc_channel_matches_exact_reference(z: float) -> None:
    """The whole-raw stratified MC (mc_channel, the docs' independent data route) against
    the clipping sums: no bias (the mean residual within 4 of its standard errors) and a
    residual as large as its own scatter (two independent draws differ by sqrt(2) times
    it: the ratio of mean squares within [0.5, 2]), on both seed halves."""
    design, _, image, tex, ref_scene = _random_image_scene(z, int(z) + 7)
    for i in (1, 2):
        exact = exact_raw(design, i, z, image, tuple(tex[1]))
        a = mc_channel(design, i, ref_scene, n_side=3, rng=np.random.default_rng(1))
        b = mc_channel(design, i, ref_scene, n_side=3, rng=np.random.default_rng(2))
        assert a.shape == exact.shape
        lit = exact > 0.05
        res = (a - exact)[lit]
        spread = np.mean(((a - b)[lit]) ** 2) / 2.0
        assert spread > 0
        assert abs(res.mean()) <= 4.0 * math.sqrt(spread / res.size), (i, res.mean())
        assert 0.5 <= np.mean(res ** 2) / spread <= 2.0, (i, np.mean(res ** 2), spread)
        assert np.sqrt(spread) < 0.02  # stratified: about a percent of white at 81 rays


def test_mc_white_is_exact_measure() -> None:
    """Under a white albedo the MC gives 1/2 on fully lit pixels of both seed halves and
    the clipped measure on the vignetted ones (half 2's partly lit rows and columns)."""
    design = seed_small()
    ref_scene = scene(("constant", [1.0]), ("plane", [500.0, 0.0, 0.0]), 1.0)
    rng = np.random.default_rng(5)
    for i in (1, 2):
        ex = exact_white(design, i)
        pixels = [(7 + 15 * k, q + 15 * j) for k, j, q in ((0, 0, 2), (1, 3, 7), (2, 4, 12),
                                                           (3, 7, 0), (5, 2, 3), (4, 5, 1))]
        mean, se = mc_pixels(design, i, pixels, ref_scene, 100_000, 20, rng)
        value = np.array([ex[p] for p in pixels])
        assert np.all(np.abs(mean - value) <= 1e-12 + z_bound(6, 20) * se), (i, mean, se)
    # the clipped measure: 1/2 exactly where fully lit, 15 (half 1) and 9 (half 2) lit
    # pixels per axis, the partly lit q = 2, 12 of half 2 between 0 and 1/2
    for i, full in ((1, range(0, 15)), (2, range(3, 12))):
        row = exact_white(design, i)[7]
        np.testing.assert_allclose(row[list(full)], 0.5, rtol=0, atol=1e-14)
        assert np.count_nonzero(np.abs(row[:15] - 0.5) < 1e-12) == len(full)
    row2 = exact_white(design, 2)[7, :15]
    assert 0 < row2[2] < 0.5 and 0 < row2[12] < 0.5 and row2[0] == row2[1] == 0.0


def test_mc_depth_map_solver() -> None:
    """The MC's depth-map intersection: a map sampling a plane (bilinear interpolation is
    exact for it inside the outer centres) renders as the plane; a constant map as the
    fronto-parallel plane (against the exact reference)."""
    design = seed_small(6, 5)
    z0, gx, gy = 600.0, 0.4, -0.3
    width = 1.5 * view_width(design, z0)
    n = 41
    centres = -width / 2 + width * (np.arange(n) + 0.5) / n
    X, Y = np.meshgrid(centres, centres[::-1])  # row 0 at the top
    depth = z0 + gx * X + gy * Y
    extent = [-width / 2, width / 2, -width / 2, width / 2]
    rng = np.random.default_rng(11)
    image = rng.random((16, 16))
    _, tex = image_texture(image, 0.7 * width)
    plane = scene(tex, ("plane", [z0, gx, gy]), 0.3)
    dmap = scene(tex, ("depthmap", extent, depth), 0.3)
    for i in (1, 2):
        pixels = sample_pixels((design.channels[i - 1].Ky * 15, design.channels[i - 1].Kx * 15),
                               12, rng)
        m1, s1 = mc_pixels(design, i, pixels, plane, 30_000, 20, rng)
        m2, s2 = mc_pixels(design, i, pixels, dmap, 30_000, 20, rng)
        z = (m1 - m2) / np.sqrt(s1 ** 2 + s2 ** 2 + 1e-30)
        assert np.max(np.abs(z)) < z_bound(len(pixels), 20), (i, z)
    const = scene(tex, ("depthmap", extent, np.full((3, 4), z0)), 0.3)
    exact = exact_raw(design, 1, z0, image, tuple(tex[1]))
    pixels = sample_pixels(exact.shape, 15, rng, exact)
    mean, se = mc_pixels(design, 1, pixels, const, 40_000, 20, rng)
    stats = z_stats(np.array([exact[p] for p in pixels]), mean, se, 0.5, 0.0)
    assert_agree(stats, "constant depth map vs exact")


def spill_design() -> tuple[splitlf.Design, float]:
    """(design, total): raytrix-r12's optics with 3 x 3 lenses, coarse 20 um pixels and a
    sensor grid wide enough to catch every ray that passes the aperture and a lens cell
    (each type's spill included); ``total`` the white raw's sum that then follows from
    §10 alone: share (L_1/L)^2 N |cell| / mu_1^2 (every such ray lands on some pixel)."""
    r12 = splitlf.Design.preset("raytrix-r12")
    ch = r12.channels[0].replace(Kx=3, Ky=3, mu=0.02, Mx=None, My=None)
    res = r12.replace(channels=(ch,)).resolved()[0]
    d, v, L, mu = res["d"], res["v"], res["L"], res["mu"]
    alpha = max(abs(1 + v / L - v / f) for f in res["f"])
    spread = v / L * r12.D / 2
    width = 3.5 * d * (1 + v / L) + 2 * (alpha * d / 2 + spread)
    height = (math.sqrt(3) + 2 / math.sqrt(3)) * d * (1 + v / L) + 2 * (
        alpha * d / math.sqrt(3) + spread)
    mx, my = math.ceil(width / mu) + 2, math.ceil(height / mu) + 2
    design = r12.replace(channels=(ch.replace(Mx=mx, My=my),))
    return design, 9 * (math.sqrt(3) / 2 * d * d) / (mu * mu)


def test_mc_sensor_white_conservation() -> None:
    """Spill bookkeeping of the MC renderer: under white, the sensor-layout raw of a hex
    design with three defocused lens types sums (over every pixel) to the light through
    the aperture and the lens cells, within its standard error; the lenses that reach
    each pixel are all found."""
    design, total = spill_design()
    ch = design.resolved()[0]
    pixels = [(r, c) for r in range(ch["My"]) for c in range(ch["Mx"])]
    white_scene = scene(("constant", [1.0]), ("plane", [450.0, 0.0, 0.0]), 1.0)
    mean, se = mc_pixels(design, 1, pixels, white_scene, 4000, 20, np.random.default_rng(7))
    err = math.sqrt(float(np.sum(se ** 2)))
    assert abs(mean.sum() - total) <= z_bound(1, 20) * err, (mean.sum(), total, err)
    edge = mean.reshape(ch["My"], ch["Mx"])
    assert edge[0].max() == edge[-1].max() == edge[:, 0].max() == edge[:, -1].max() == 0.0


def test_sensor_white_conservation() -> None:
    """The native raw of the same design under white sums to the same total, within the
    stated per-pixel accuracy (1e-3 of white) summed over the pixels with light, and it is
    0 on the grid's border (no light lands there)."""
    design, total = spill_design()
    api, _ = image_texture(np.ones((2, 2)), 3.0)
    raw = np.asarray(render(design, api, 450.0, 1.0)[0])
    lit = np.count_nonzero(raw > 0)
    assert abs(raw.sum() - total) <= ABS_TOL * lit, (raw.sum(), total, lit)
    assert max(raw[0].max(), raw[-1].max(), raw[:, 0].max(), raw[:, -1].max()) == 0.0


# -- the native render: the exact route ------------------------------------------------------


@pytest.mark.parametrize("z", [217.0, 400.0, 642.0, 1000.0, 3000.0])
def test_exact_route(z: float) -> None:
    """Fronto-parallel plane, rect grid, square aperture, ideal layout, an asymmetric image
    texture (covering part of the view, so the mean beyond it counts too): the native raw
    equals the clipping sums to 1e-12 of a fully lit white pixel, on both seed halves."""
    design = seed_small()
    rng = np.random.default_rng(int(z) + 1)
    image = rng.random((17, 23))
    image[:4, :5] += 2.0  # upper-left corner brighter: not symmetric under any flip
    api, tex = image_texture(image, 0.75 * view_width(design, z))
    raws = render(design, api, float(z), 0.25)
    assert len(raws) == 2
    for i in (1, 2):
        ref = exact_raw(design, i, z, image, tuple(tex[1]))
        raw = np.asarray(raws[i - 1])
        assert raw.shape == ref.shape == (90, 120)
        err = np.max(np.abs(raw - ref))
        assert err <= EXACT_TOL * white(design, i), (z, i, err)


X_TEXTURES = [("sinusoid", 0.7, 0.5, 0.4, 0.3), ("sinusoid", 3.1, 0.45, 0.45, -1.2),
              ("bars", 1.3, 0.2, 0.9)]


def _x_texture(texture: tuple) -> Any:
    if texture[0] == "sinusoid":
        return splitlf.Sinusoid(texture[1], texture[2], texture[3], phase=texture[4])
    return splitlf.BarChart(texture[1], texture[2], texture[3])


@pytest.mark.parametrize("z", [217.0, 642.0, 1000.0, 3000.0])
@pytest.mark.parametrize("texture", X_TEXTURES)
def test_exact_route_of_a_texture_of_x(z: float, texture: tuple) -> None:
    """A sinusoid or bars (albedo of X only) on a fronto-parallel plane take the exact
    route (the x polygon's integral times the y polygon's measure): the native raw equals
    an independent reference (the polygon's measure below X as a piecewise quadratic,
    Gauss-Legendre or exact sums between the bar edges; not Green's theorem) to 1e-12 of
    white, on both seed halves (measured: at most 2.3e-14)."""
    design = seed_small(4, 3)
    raws = render(design, _x_texture(texture), z, 0.5)
    for i in (1, 2):
        ref = exact_raw_x(design, i, z, texture)
        raw = np.asarray(raws[i - 1])
        assert raw.shape == ref.shape
        assert np.max(np.abs(raw - ref)) <= EXACT_TOL * white(design, i), (z, i)


@pytest.mark.parametrize("texture", X_TEXTURES)
def test_general_route_of_a_texture_of_x(texture: tuple) -> None:
    """The general route (forced by a plane tilted by 1e-7) gives the exact route's raw of
    a texture of X only to its stated 1e-3 of white, at four depths on both halves. On the
    3.1 c/mm sinusoid it once missed by up to 3.5e-2 (half 2 at 1 m: the adaptive rule's
    2- and 3-point rules agreed by chance over boxes on which the polygon moved several
    periods); with a sinusoid's quarter periods as cuts and boxes spanning over half a
    period rough, measured: at most 1.2e-7 (3.1 c/mm) and 5.4e-7 (0.7 c/mm) of white,
    7.2e-5 for the bars."""
    design = seed_small(4, 3)
    api = _x_texture(texture)
    for z in (217.0, 642.0, 1000.0, 3000.0):
        exact = render(design, api, z, 0.5)
        general = render(design, api, splitlf.Plane(z, 1e-7, 0.0), 0.5)
        for i in (1, 2):
            err = np.max(np.abs(np.asarray(general[i - 1]) - np.asarray(exact[i - 1])))
            assert err <= ABS_TOL * white(design, i), (z, i, err)


@pytest.mark.parametrize("z", [400.0, 700.0, 800.0, 1000.0])
def test_general_route_on_a_fronto_plane(z: float) -> None:
    """The 4-D quadrature route (forced by a plane tilted by 1e-7, a depth change of
    1e-6 mm over the view) against the independent clipping sums of the exact route, on
    every pixel of both seed halves: within the stated 1e-3 of white. A fine random image
    (64 x 64 cells over 8 mm) whose cells' image crosses each pixel's sub-aperture many
    times over: the 2- and 3-point rules once agreed there by chance, off by up to 1.6e-2
    of white (half 2 at 800 mm) and 3.8e-3 (half 1 at 1000 mm)."""
    design = seed_small()
    image = np.random.default_rng(3).random((64, 64))
    api, tex = image_texture(image, 8.0)
    raws = render(design, api, splitlf.Plane(z, 1e-7, 0.0), float(image.mean()))
    for i in (1, 2):
        ref = exact_raw(design, i, z, image, tuple(tex[1]))
        err = np.max(np.abs(np.asarray(raws[i - 1]) - ref))
        assert err <= ABS_TOL * white(design, i), (z, i, err)


def test_white() -> None:
    """White albedo: 1/2 on every fully lit pixel of both seed halves (all of half 1, 9 x 9
    per lens of half 2), the clipped measure on half 2's vignetted pixels."""
    design = seed_small()
    api, _ = image_texture(np.ones((2, 3)), 5.0)  # white inside and (its mean) outside
    for z in (300.0, 642.0):
        raws = render(design, api, z, 1.0)
        for i in (1, 2):
            ref = exact_white(design, i)
            raw = np.asarray(raws[i - 1])
            assert np.max(np.abs(raw - ref)) <= EXACT_TOL * 0.5, (z, i)
            full = np.abs(ref - 0.5) < 1e-12
            assert np.count_nonzero(full) == (15 * 15 if i == 1 else 9 * 9) * 8 * 6
            np.testing.assert_allclose(raw[full], 0.5, rtol=0, atol=EXACT_TOL * 0.5)


# -- the native render: Monte-Carlo z-scores on every family ---------------------------------


def test_mc_seed_slanted_plane() -> None:
    """Seed (rect, square, ideal, two channels) on a slanted plane, image texture."""
    design = seed_small()
    rng = np.random.default_rng(21)
    image = rng.random((20, 26))
    api, tex = image_texture(image, 0.8 * view_width(design, 700.0))
    plane = (700.0, 0.45, -0.3)
    raws = render(design, api, splitlf.Plane(*plane), 0.3)
    check_mc(design, raws, scene(tex, ("plane", list(plane)), 0.3), 30, 22,
             "seed, slanted plane")


def test_mc_hex_sensor_spill() -> None:
    """Reduced raytrix-r12: hex cells, three lens types, circular aperture, sensor layout
    (every type defocused: |alpha| ~ 0.4 >> v/L, light spills onto the neighbours' pixels);
    a Siemens star on the fronto-parallel plane at 450 mm and an image on a slanted
    plane."""
    design = r12_small()
    ch = design.resolved()[0]
    alphas = [1 + ch["v"] / ch["L"] - ch["v"] / f for f in ch["f"]]
    # the spread of a lens's light on the sensor exceeds its image cell: spill
    reach = min(abs(a) for a in alphas) * ch["d"] / 2 + ch["v"] / ch["L"] * design.D / 2
    assert reach > ch["d"] * (1 + ch["v"] / ch["L"]) / 2
    star = splitlf.SiemensStar(12, 0.1, 0.9, center=(0.2, -0.1))
    raws = render(design, star, 450.0, 0.5)
    check_mc(design, raws, scene(("star", [12, 0.1, 0.9, 0.2, -0.1]),
                                 ("plane", [450.0, 0.0, 0.0]), 0.5),
             30, 31, "r12 small, star, fronto", n_rays=100_000)
    rng = np.random.default_rng(32)
    image = rng.random((15, 19))
    api, tex = image_texture(image, 0.8 * view_width(design, 450.0))
    plane = (450.0, -0.3, 0.2)
    raws = render(design, api, splitlf.Plane(*plane), 0.4)
    check_mc(design, raws, scene(tex, ("plane", list(plane)), 0.4), 30, 33,
             "r12 small, image, slanted", n_rays=100_000)


def test_mc_own_lens_white() -> None:
    """The own-lens render (the depth sweep's test of which pixels see one lens) on the
    reduced raytrix-r12, whose defocused lens types spill light onto their neighbours'
    pixels: against the MC renderer with each pixel's own lens alone (its nearest lens
    image, found by brute force) in z-score; never above the full white; and below 0.99
    of it on many lit pixels (the spill it is there to find). On the ideal layout a pixel
    sees its own lens alone: the own-lens white is the white."""
    design = r12_small()
    own = _own_lens_whites(design)[0]
    full = _white(design)[0]
    lit = full > 0.05 * full.max()
    assert np.all(own <= full + ABS_TOL * white(design, 1))
    spilled = np.count_nonzero(own[lit] < 0.99 * full[lit]) / np.count_nonzero(lit)
    assert 0.2 < spilled < 0.9, spilled
    rng = np.random.default_rng(41)
    pixels = sample_pixels(own.shape, 30, rng, own)
    z = _white_scene(design).depth.z0
    white_scene = scene(("constant", [1.0]), ("plane", [z, 0.0, 0.0]), 1.0)
    mean, se = mc_pixels(design, 1, pixels, white_scene, 100_000, 20, rng, own_only=True)
    value = np.array([own[p] for p in pixels])
    assert_agree(z_stats(value, mean, se, white(design, 1), NATIVE_ERR, 20), "own lens")
    seed = seed_small(4, 3)
    for o, w in zip(_own_lens_whites(seed), _white(seed), strict=True):
        np.testing.assert_array_equal(o, w)


def test_mc_rect_sensor_two_channels() -> None:
    """Two rect channels (a sensor layout with spill, an ideal layout with two lens types,
    shares 0.6 / 0.4) on a slanted edge; each channel checked."""
    design = rect_two()
    edge = splitlf.SlantedEdge(10.0, 0.2, 0.9, center=(0.3, -0.2))
    raws = render(design, edge, 500.0, 0.5)
    assert len(raws) == 2
    check_mc(design, raws, scene(("edge", [10.0, 0.2, 0.9, 0.3, -0.2]),
                                 ("plane", [500.0, 0.0, 0.0]), 0.5),
             30, 41, "rect two channels, edge", n_rays=100_000)


def test_mc_star_and_edge_on_seed() -> None:
    """Seed halves: a Siemens star at 300 mm and a slanted edge at 2000 mm (analytic
    textures on the exact route's geometry)."""
    design = seed_small()
    star = splitlf.SiemensStar(8, 0.0, 1.0, center=(0.0, 0.0))
    raws = render(design, star, 300.0, 0.5)
    check_mc(design, raws, scene(("star", [8, 0.0, 1.0, 0.0, 0.0]),
                                 ("plane", [300.0, 0.0, 0.0]), 0.5), 30, 51, "seed, star")
    edge = splitlf.SlantedEdge(-25.0, 0.3, 0.8, center=(-0.5, 0.4))
    raws = render(design, edge, 2000.0, 0.5)
    check_mc(design, raws, scene(("edge", [-25.0, 0.3, 0.8, -0.5, 0.4]),
                                 ("plane", [2000.0, 0.0, 0.0]), 0.5), 30, 52, "seed, edge")


def test_mc_depth_map() -> None:
    """Seed halves (2 x 2 lenses: a depth map costs tens of ms a pixel, docs/render.md) on
    a curved depth map (about 645-655 mm) that covers most of the view (rays beyond its
    extent see the background), image texture."""
    design = seed_small(2, 2)
    z = 600.0
    width = view_width(design, z)
    n = 9
    t = (np.arange(n) + 0.5) / n - 0.5
    X, Y = np.meshgrid(t, t[::-1])
    depth = 650.0 + 4.0 * np.sin(2.5 * X) * np.cos(1.7 * Y) + 3.0 * X
    extent = (-0.45 * width, 0.5 * width, -0.5 * width, 0.4 * width)
    rng = np.random.default_rng(61)
    image = rng.random((14, 18))
    api, tex = image_texture(image, 0.9 * width)
    raws = render(design, api, splitlf.DepthMap(depth, extent), 0.15)
    check_mc(design, raws, scene(tex, ("depthmap", list(extent), depth), 0.15), 20, 62,
             "seed, depth map", n_rays=50_000)


# -- orientation ------------------------------------------------------------------------------


def bright_quadrant(raw: np.ndarray) -> tuple[int, int]:
    """(top, right): which quadrant of a raw holds most of its light above the minimum."""
    r = raw - raw.min()
    h, w = r.shape[0] // 2, r.shape[1] // 2
    sums = np.array([[r[:h, :w].sum(), r[:h, w:].sum()], [r[h:, :w].sum(), r[h:, w:].sum()]])
    top, right = np.unravel_index(np.argmax(sums), sums.shape)
    assert sums[top, right] > 0.7 * sums.sum()
    return 1 - int(top), int(right)


def orientation_case() -> tuple[splitlf.Design, float, np.ndarray, tuple]:
    """A square seed (8 x 8 lenses) at half 1's out-of-focus plane, where each lens sees a
    small patch, and a bright square in the texture's upper-left quadrant (X < 0, Y > 0)."""
    design = seed_small(8, 8)
    z = 642.0
    image = np.zeros((12, 12))
    image[2:5, 2:5] = 1.0  # rows near the top (Y > 0), columns on the left (X < 0)
    x0, x1, _, _ = view_extent(design, 1, z)
    _, tex = image_texture(image, 1.6 * (x1 - x0))
    return design, z, image, tex


def test_orientation_reference() -> None:
    """The geometry (§9's chief ray X = -(z/L)[c + ...]: the main lens inverts) puts a
    bright patch at X < 0, Y > 0 under lenses with c_x > 0, c_y < 0: high raw columns and
    low raw rows (the raw's top right as printed). The exact reference and the MC say so;
    a row-flipped or transposed raw does not pass."""
    design, z, image, tex = orientation_case()
    ref = exact_raw(design, 1, z, image, tuple(tex[1]))
    assert bright_quadrant(ref) == (1, 1)
    for wrong in (ref[::-1], ref.T, ref[:, ::-1]):
        with pytest.raises(AssertionError):
            assert bright_quadrant(wrong) == (1, 1)
    # the MC agrees on the brightest pixel and on its mirror images
    top = np.unravel_index(np.argmax(ref), ref.shape)
    pixels = [top, (ref.shape[0] - 1 - top[0], top[1]), (top[1], top[0])]
    mean, se = mc_pixels(design, 1, pixels, scene(tex, ("plane", [z, 0.0, 0.0]), 0.0),
                         40_000, 20, np.random.default_rng(3))
    assert mean[0] > 0.3 and np.all(mean[1:] < 0.05), (mean, se)
    assert np.all(np.abs(mean - [ref[p] for p in pixels]) <= z_bound(3, 20) * se + 1e-12)


def test_orientation_native() -> None:
    """The native raw shows the bright square where the reference does; a row flip or a
    transpose of the channel would not equal the reference."""
    design, z, image, tex = orientation_case()
    api = splitlf.Image(image, tex[1][1] - tex[1][0])
    raws = render(design, api, z, 0.0)
    assert bright_quadrant(np.asarray(raws[0])) == (1, 1)  # half 2 is blurred at 642 mm
    for i in (1, 2):
        raw = np.asarray(raws[i - 1])
        ref = exact_raw(design, i, z, image, tuple(tex[1]))
        assert np.max(np.abs(raw - ref)) <= EXACT_TOL * 0.5
        assert np.max(np.abs(raw[::-1] - ref)) > 0.1
        assert np.max(np.abs(raw.T - ref)) > 0.1


# -- where a depth map's extent ends --------------------------------------------------------


def test_flat_map_extent_edge_is_the_exact_route() -> None:
    """A flat depth map at 700 mm over a box of the view (the seed cut to 2 x 2 lenses; half
    2's pixels at the box's top and bottom see both the map and the background beyond it)
    against the exact route on the fronto-parallel plane at 700 mm whose image is the map's
    texture inside the box and the background around it: the same ray sets, so the same
    raws. Before the extent's edges were cuts of the outer box and a piece across the edge
    was shared by area, such pixels read up to 8.5e-3 of white too bright."""
    design = seed_small(2, 2)
    e = 0.5 * view_width(design, 600.0)
    n, pad = 12, 24  # inner cells per axis; cells of background around them (3 x the box)
    rng = np.random.default_rng(5)
    inner = rng.random((n, n))
    bg = 0.15
    outer = np.full((n + 2 * pad, n + 2 * pad), bg)
    outer[pad:pad + n, pad:pad + n] = inner
    cell = 2 * e / n
    on_map = splitlf.render(design, splitlf.Scene(
        splitlf.Image(inner, 2 * e), splitlf.DepthMap(np.full((3, 3), 700.0), (-e, e, -e, e)),
        background=bg), progress=False)
    exact = splitlf.render(design, splitlf.Scene(
        splitlf.Image(outer, cell * outer.shape[1]), splitlf.Plane(700.0), background=bg),
        progress=False)
    for i in (0, 1):
        a, b = np.asarray(on_map.images[i]), np.asarray(exact.images[i])
        assert np.abs(a - b).max() <= 1e-9, (i, np.abs(a - b).max())
    # The case is the edge's: some of half 2's pixels see both sides of it.
    seen = np.asarray(exact.images[1])
    assert np.any(np.abs(seen - bg * seen.max() / 0.5) > 1e-3)


def test_mc_cliff_map() -> None:
    """A depth map with a cliff (12 x 12 samples, 560 mm on the left half, 700 mm on the
    right: a one-cell ramp) over a box of the view, a random image, background 0.15: every
    pixel at the lens images' top and bottom rows on the cliff's side (where rays leave the
    box: 13 of half 2's pixels were 40-100 standard errors off at 400,000 rays before the
    extent's edges were handled) and 20 random pixels of each half, against Monte-Carlo
    with 400,000 rays a pixel."""
    design = seed_small(2, 2)
    width = view_width(design, 600.0)
    t = (np.arange(12) + 0.5) / 12 - 0.5
    X, _ = np.meshgrid(t, t)
    depth = np.where(X < 0.0, 560.0, 700.0)
    extent = (-0.5 * width, 0.5 * width, -0.5 * width, 0.5 * width)
    image = np.random.default_rng(61).random((14, 18))
    api, tex = image_texture(image, 0.9 * width)
    raws = render(design, api, splitlf.DepthMap(depth, extent), 0.15)
    ref = scene(tex, ("depthmap", list(extent), depth), 0.15)
    rng = np.random.default_rng(7)
    edge = [(r, c) for r in (3, 26) for c in (8, 9, 10, 23, 24, 25, 26)]
    for i in (1, 2):
        raw = np.asarray(raws[i - 1])
        pixels = sample_pixels(raw.shape, 20, rng, raw) + (edge if i == 2 else [])
        mean, se = mc_pixels(design, i, pixels, ref, 400_000, 20, rng)
        value = np.array([raw[p] for p in pixels])
        assert_agree(z_stats(value, mean, se, white(design, i), 0.0),
                     f"cliff, channel {i}")
