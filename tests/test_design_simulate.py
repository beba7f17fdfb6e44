"""splitlf.simulate and its forward model on a Design (docs/simulate.md, "Designs"):
the camera is the seed design bit for bit, each channel's rows integrate to its
collected light, render = matrix x texture, the union beats a channel on its out-of-focus
plane, and bad sources, channels and hex grids are refused by name."""

from __future__ import annotations

import numpy as np
import pytest

import splitlf
import splitlf.inverse.simulate as simulation
from splitlf import Camera, Channel, Design, InvalidParameter, simulate
from splitlf.inverse.simulate import design_sources, forward, system_matrix

SEED = Camera.paper()

#: Three rect channels (square aperture, shares summing to 1): an ideal layout whose
#: microlens image is one lens pitch wide (wider than its Q pixels), a sensor layout with
#: three lens types, an ideal layout with two lens types.
MIX = Design(F=50.0, D=10.0, channels=(
    Channel(L=60.0, d=0.1, v=0.6, mu=0.01, Kx=101, Ky=3, Q=9, share=0.3),
    Channel(L=66.0, d=0.12, v=0.5, mu=0.008, Kx=85, Ky=3, layout="sensor",
            f=(0.45, 0.5, 0.55), share=0.3),
    Channel(L=75.0, d=0.1, v=0.6, mu=0.01, Kx=75, Ky=3, Q=8, f=(0.5, 0.62), share=0.4),
))

PAIRS = [("half1", "channel1"), ("half2", "channel2"),
         ("conventional1", "conventional1"), ("conventional2", "conventional2")]


def _bits_equal(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


# -- the camera is the seed design, bit for bit ----------------------------------------------

@pytest.mark.parametrize("z", [217.0, 642.0, 2000.0])
@pytest.mark.parametrize("cam_src,des_src", PAIRS)
def test_camera_half_sources_are_the_seed_design_channels_bit_for_bit(z, cam_src, des_src):
    # The camera's source names (half i) are a two-channel design's channel i; the camera
    # and the seed preset give the same kernels, matrices and values.
    d = splitlf.Design.preset("seed")
    step = SEED.resolution_step(z) / 2
    n = 4000
    origin = -n * step / 2
    tex = np.random.default_rng(3).uniform(0, 1, (2, n))
    va, pa = forward(SEED, z, cam_src, origin, step, tex)
    vb, pb = forward(d, z, des_src, origin, step, tex)
    assert va.shape[1] > 100 and _bits_equal(va, vb) and _bits_equal(pa, pb)
    (ma, qa), (mb, qb) = (system_matrix(SEED, z, cam_src, origin, step, n),
                          system_matrix(d, z, des_src, origin, step, n))
    assert _bits_equal(qa, qb) and ma.shape == mb.shape
    for attr in ("data", "indices", "indptr"):
        assert _bits_equal(getattr(ma, attr), getattr(mb, attr))
    ks = (splitlf._native.design_kernel_support(SEED.core, z, des_src),
          splitlf._native.design_kernel_support(d.core, z, des_src))
    assert ks[0] == ks[1]


CAMERA_ROWS = {"half1": "channel 1", "half2": "channel 2", "split": "union",
               "conventional": "conventional 1"}


def _assert_same(a, b):
    """Every output of Simulation a equals b's bit for bit."""
    same = _bits_equal
    assert a.configs == b.configs
    assert same(a.x, b.x) and same(a.truth, b.truth) and same(a.frequencies, b.frequencies)
    assert same(a.delta, b.delta) and same(a.nyquist, b.nyquist)
    assert same(a.microlens_frequency, b.microlens_frequency)
    for k in a.configs:
        assert same(a.reconstruction(k), b.reconstruction(k)), k
        for m in ("rmse", "psnr", "mtf50", "regularization"):
            assert same(getattr(a, m)[k], getattr(b, m)[k]), (m, k)
        assert same(a.contrast[k], b.contrast[k])
        assert a.pixels[k] == b.pixels[k]


@pytest.mark.parametrize("z,noise", [(642.0, None), (400.0, {"photons": 1e4, "read_noise": 3}),
                                     (150.0, None)])
def test_camera_simulation_is_the_seed_design_simulation(z, noise):
    kw = dict(noise=noise, seed=5, window=64, n_frequencies=6, oversample=2)
    a = simulate(SEED, z, **kw)
    b = simulate(splitlf.Design.preset("seed"), z, **kw)
    assert type(a) is type(b) is simulation.Simulation
    assert a.configs == ("channel 1", "channel 2", "union", "conventional 1")
    # delta(z) is docs/model.md §9's mu_1 z/L_1 for every design, the camera too (at 150 mm
    # one ulp from §6's d z/(Q v') of the paper's symbols: 0.135/15 != 0.009).
    assert a.delta == SEED.resolution_step(z)
    assert a.delta == pytest.approx(SEED.d * z / (SEED.Q * SEED.v1), rel=1e-15)
    _assert_same(a, b)
    # The split sensor's words are the rows.
    for name, row in CAMERA_ROWS.items():
        assert _bits_equal(getattr(a, name), a.reconstructions[row]), name
    # Conventional on array plane 2, by half or by channel.
    a2 = simulate(SEED, z, conventional_half=2, **kw)
    c2 = simulate(SEED, z, conventional_channel=2, **kw)
    assert c2.configs[-1] == "conventional 2" and c2.conventional_half == 2
    assert _bits_equal(a2.conventional, c2.reconstructions["conventional 2"])
    _assert_same(a2, c2)


# -- without the conventional reference ------------------------------------------------------

@pytest.mark.parametrize("subject,z,noise", [
    (SEED, 400.0, {"photons": 1e4, "read_noise": 3}), (SEED, 150.0, None),
    (MIX, 300.0, {"photons": 5e3, "read_noise": 1})])
def test_without_the_conventional_row_every_other_row_is_unchanged(subject, z, noise):
    kw = dict(noise=noise, seed=3, window=32, n_frequencies=5, oversample=2)
    full = simulate(subject, z, **kw)
    part = simulate(subject, z, conventional=False, **kw)
    conv = full.configs[-1]
    assert conv.startswith("conventional") and part.configs == full.configs[:-1]
    assert set(part.rmse) == set(part.mtf50) == set(part.pixels) == set(part.configs)
    assert conv not in part.reconstructions and conv not in part.contrast
    assert part.conventional is None and full.conventional is not None
    assert part.conventional_half is None and full.conventional_half == 1
    same = _bits_equal
    assert same(part.x, full.x) and same(part.truth, full.truth)
    assert same(part.frequencies, full.frequencies) and part.delta == full.delta
    for k in part.configs:  # noise draws, grids and solves all the same
        assert same(part.reconstruction(k), full.reconstruction(k)), k
        assert same(part.contrast[k], full.contrast[k]), k
        for m in ("rmse", "psnr", "mtf50", "regularization", "pixels"):
            assert getattr(part, m)[k] == getattr(full, m)[k], (m, k)


@pytest.mark.parametrize("bad", [0, 1, "no", None])
def test_conventional_flag_must_be_a_bool(bad):
    with pytest.raises(TypeError, match="conventional"):
        simulate(SEED, 642.0, conventional=bad, mtf=False, window=16)


# -- a three-channel design ------------------------------------------------------------------

@pytest.mark.parametrize("z", [180.0, 300.0, 600.0])
@pytest.mark.parametrize("source", design_sources(MIX))
def test_design_rows_integrate_to_the_channel_light_and_render_is_matrix_times_texture(
        z, source):
    # Row sum = share x polygon area / (D mu_1) (light field, area in ray space on L_1;
    # the camera's core test with the share for the beam splitter's 1/2), and
    # D mu_c L_1/L_c / (D mu_1) for the conventional sensor on channel c's plane.
    c = int(source[-1])
    ch = MIX.channels[c - 1]
    mu1, l1 = MIX.channels[0].mu, MIX.channels[0].L
    step = MIX.resolution_step(z) / 2
    n = 6000
    origin = -n * step / 2
    a, pixels = system_matrix(MIX, z, source, origin, step, n)
    assert a.shape[0] > 50
    sums = np.asarray(a.sum(axis=1)).ravel()
    if source.startswith("channel"):
        area = splitlf.trace(MIX, channel=c).area
        want = ch.share * area[pixels] / (MIX.D * mu1)
    else:
        want = np.full(pixels.size, MIX.D * ch.mu * l1 / ch.L / (MIX.D * mu1))
    np.testing.assert_allclose(sums, want, rtol=1e-9)
    tex = np.random.default_rng(c).uniform(0, 1, (3, n))
    values, pv = forward(MIX, z, source, origin, step, tex)
    assert _bits_equal(pv, pixels)
    np.testing.assert_allclose(values, (a @ tex.T).T, rtol=1e-10, atol=1e-14)


def test_union_beats_the_channel_on_its_out_of_focus_plane():
    # On channel 1's out-of-focus plane (300 mm) its Q pixels under a lens all see one box
    # of width d: it collapses to about one sample per lens. The union of the three
    # channels keeps far more; the margins are measured here and printed in the docs.
    z = MIX.out_of_focus_depth(1)
    r = simulate(MIX, z, window=128, n_frequencies=16, seed=1)
    assert r.configs == ("channel 1", "channel 2", "channel 3", "union", "conventional 1")
    assert r.pixels["union"] == sum(r.pixels[f"channel {c}"] for c in (1, 2, 3))
    assert r.mtf50["union"] > 2 * r.mtf50["channel 1"]
    assert r.rmse["union"] < 0.5 * r.rmse["channel 1"]
    for k in r.configs:
        assert r.reconstruction(k).shape == r.truth.shape
    s = r.summary()
    assert list(s["rmse"]) == list(r.configs)


# -- refusals --------------------------------------------------------------------------------

def test_bad_sources_channels_and_hex_are_refused_by_name():
    z, step, n = 300.0, 0.01, 100
    for bad in ("half1", "channel4", "channel0", "conventional", "channel 1"):
        with pytest.raises(InvalidParameter) as e:
            system_matrix(MIX, z, bad, 0.0, step, n)
        assert e.value.name == "source"
    with pytest.raises(TypeError):
        forward(MIX, z, 1, 0.0, step, np.ones(n))
    with pytest.raises(InvalidParameter) as e:  # a half only in a two-channel design
        forward(SEED, 642.0, "half3", 0.0, step, np.ones(n))
    assert e.value.name == "source"
    with pytest.raises(InvalidParameter) as e:
        simulate(MIX, z, conventional_channel=4)
    assert e.value.name == "conventional_channel"
    with pytest.raises(InvalidParameter) as e:
        simulate(SEED, 642.0, conventional_channel=3)
    assert e.value.name == "conventional_channel"
    with pytest.raises(TypeError):
        simulate(MIX, z, conventional_half=1, conventional_channel=1)
    hexed = MIX.replace(aperture="circle", channels=(*MIX.channels[:2], Channel(
        L=75.0, d=0.1, v=0.6, mu=0.01, Kx=15, Ky=3, grid="hex", layout="sensor",
        share=0.4)))
    with pytest.raises(InvalidParameter) as e:
        simulate(hexed, z)
    assert e.value.name == "channels[3].grid"
    for src in ("channel3", "conventional3"):
        with pytest.raises(InvalidParameter) as e:
            system_matrix(hexed, z, src, 0.0, step, n)
        assert e.value.name == "channels[3].grid"
    assert system_matrix(hexed, z, "channel1", -0.5, step, n)[0].shape[1] == n
    with pytest.raises(InvalidParameter):
        simulate(MIX, 40.0)
